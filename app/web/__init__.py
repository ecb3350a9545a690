"""The web app: `create_app()` (Flask's factory), one blueprint per page area.

The library is opened (and migrated, and given its demo programs the first time) when the
app is created. Every state-changing request carries a CSRF token; every response carries
security headers with a Content-Security-Policy that allows no inline script.
"""

from __future__ import annotations

import os
import secrets
from pathlib import Path
from typing import Any

from flask import Flask, Response, render_template
from flask_wtf.csrf import CSRFError
from werkzeug.middleware.proxy_fix import ProxyFix
from werkzeug.routing import IntegerConverter

from app.resources import data_dir, instance_dir
from app.storage.library import open_library
from app.web import (
    auth,
    crib,
    drawings,
    editor,
    export,
    library,
    machines,
    setup,
    transfers,
    verify,
)
from app.web.extensions import csrf, get_library

__all__ = ["create_app", "get_library"]

CSP = (
    "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
    "object-src 'none'; base-uri 'self'; form-action 'self'; frame-ancestors 'none'"
)


def create_app(test_config: dict[str, Any] | None = None) -> Flask:
    """Build the app. `test_config` overrides configuration (DATABASE_URL, SECRET_KEY...)."""
    app = Flask(
        __name__,
        template_folder=str(data_dir("templates")),
        static_folder=str(data_dir("static")),
        instance_path=str(instance_dir()),
    )
    app.url_map.converters["int"] = RowId
    app.config.update(
        DATABASE_URL=os.environ.get("DATABASE_URL"),
        MAX_CONTENT_LENGTH=2 * 1024 * 1024,
        SESSION_COOKIE_HTTPONLY=True,
        SESSION_COOKIE_SAMESITE="Lax",
        SESSION_COOKIE_SECURE=os.environ.get("MILLBLOCKS_HTTPS") == "1",
        WTF_CSRF_TIME_LIMIT=None,
        MILLBLOCKS_USER=os.environ.get("MILLBLOCKS_USER", "local"),
        MILLBLOCKS_AUTH=os.environ.get("MILLBLOCKS_AUTH", "local"),
    )
    if test_config:
        app.config.update(test_config)
    _harden_cookie(app)
    _trust_proxy(app)
    app.config.setdefault("SECRET_KEY", None)
    if not app.config["SECRET_KEY"]:
        app.config["SECRET_KEY"] = _secret_key(Path(app.instance_path))
    csrf.init_app(app)
    app.extensions["millblocks.library"] = open_library(app.config["DATABASE_URL"])

    for module in (
        auth,
        library,
        editor,
        drawings,
        export,
        machines,
        setup,
        transfers,
        verify,
        crib,
    ):
        app.register_blueprint(module.bp)
    auth.init_app(app)

    app.after_request(_security_headers)
    app.register_error_handler(CSRFError, _csrf_error)
    app.register_error_handler(413, _too_large)
    app.register_error_handler(404, _not_found)
    app.register_error_handler(403, _forbidden)
    app.register_error_handler(422, _refused)
    if app.config["MILLBLOCKS_AUTH"] not in ("local", "accounts"):
        raise ValueError("MILLBLOCKS_AUTH is 'local' or 'accounts'")
    return app


class RowId(IntegerConverter):
    """`<int:…>` in a URL: at most 9 digits, so an id never overflows a database integer
    (/programs/99999999999999999999 is a 404, not an OverflowError)."""

    regex = r"\d{1,9}"

    def __init__(self, map: Any, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("max", 999_999_999)
        super().__init__(map, *args, **kwargs)


def _harden_cookie(app: Flask) -> None:
    """Over HTTPS the session cookie is `__Host-millblocks`: Secure, path /, no Domain, so
    no other site or subdomain can set or read it (ASVS 3.4.4)."""
    app.config["SESSION_COOKIE_PATH"] = "/"
    app.config["SESSION_COOKIE_DOMAIN"] = False
    if app.config["SESSION_COOKIE_SECURE"] and app.config["SESSION_COOKIE_NAME"] == "session":
        app.config["SESSION_COOKIE_NAME"] = "__Host-millblocks"


def _trust_proxy(app: Flask) -> None:
    """Behind N reverse proxies (MILLBLOCKS_PROXY_HOPS=N), take the client's address and
    scheme from the last N X-Forwarded-For/-Proto entries; with 0 (the default) those
    headers are ignored, so a client cannot choose its own address for the login limit."""
    raw = app.config.get("MILLBLOCKS_PROXY_HOPS", os.environ.get("MILLBLOCKS_PROXY_HOPS", "0"))
    hops = int(str(raw or "0"))
    if hops < 0:
        raise ValueError("MILLBLOCKS_PROXY_HOPS is the number of trusted proxies (0 or more)")
    if hops:
        app.wsgi_app = ProxyFix(app.wsgi_app, x_for=hops, x_proto=hops)  # type: ignore[method-assign]


def _secret_key(instance: Path) -> str:
    """A per-installation key kept in instance/secret_key (created on first start)."""
    instance.mkdir(parents=True, exist_ok=True)
    path = instance / "secret_key"
    if not path.exists():
        path.write_text(secrets.token_hex(32))
        path.chmod(0o600)
    return path.read_text().strip()


def _security_headers(response: Response) -> Response:
    response.headers.setdefault("Content-Security-Policy", CSP)
    response.headers.setdefault("X-Content-Type-Options", "nosniff")
    response.headers.setdefault("Referrer-Policy", "same-origin")
    response.headers.setdefault("X-Frame-Options", "DENY")
    return response


def _csrf_error(error: CSRFError) -> tuple[str, int]:
    return render_template("errors/error.html", title="Refused", message=error.description), 400


def _too_large(_error: Exception) -> tuple[str, int]:
    message = "The upload is larger than the 2 MB MillBlocks accepts."
    return render_template("errors/error.html", title="Too large", message=message), 413


def _forbidden(error: Exception) -> tuple[str, int]:
    message = getattr(error, "description", "Not allowed")
    return render_template("errors/error.html", title="Not allowed", message=message), 403


def _refused(error: Exception) -> tuple[str, int]:
    message = getattr(error, "description", "Refused")
    return render_template("errors/error.html", title="Refused", message=message), 422


def _not_found(error: Exception) -> tuple[str, int]:
    message = getattr(error, "description", "Not found")
    return render_template("errors/error.html", title="Not found", message=message), 404
