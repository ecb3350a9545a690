"""The web app: `create_app()` (Flask's factory), one blueprint per page area.

The library is opened (and migrated, and given its demo programs the first time) when the
app is created. Every state-changing request carries a CSRF token; every response carries
security headers with a Content-Security-Policy that allows no inline script.
"""

from __future__ import annotations

import os
import secrets
from datetime import datetime
from pathlib import Path
from typing import Any

from flask import Flask, Response, current_app, render_template, request
from flask_wtf.csrf import CSRFError
from werkzeug.middleware.proxy_fix import ProxyFix
from werkzeug.routing import IntegerConverter

from app import settings
from app.cnc import sizes
from app.cnc.text import TextError, check_text
from app.resources import data_dir, instance_dir
from app.storage.library import open_library
from app.web import (
    auth,
    crib,
    drawings,
    editor,
    export,
    health,
    library,
    logs,
    machines,
    setup,
    transfers,
    verify,
)
from app.web.extensions import csrf, get_library
from app.web.logs import MillBlocks

__all__ = ["create_app", "get_library"]

CSP = (
    "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
    "object-src 'none'; base-uri 'self'; form-action 'self'; frame-ancestors 'none'"
)


def create_app(test_config: dict[str, Any] | None = None) -> Flask:
    """Build the app from the MILLBLOCKS_* environment (app.settings; docs/deploy.md),
    `test_config` overriding it (DATABASE_URL, SECRET_KEY, AUTH...: the names without the
    prefix). Raises SettingError for a setting it cannot use and SchemaError for a database
    newer than this code."""
    given = dict(test_config or {})
    prefixed = [key for key in given if key.startswith(f"{settings.PREFIX}_")]
    if prefixed:
        raise ValueError(f"config {prefixed[0]}: settings are named without the prefix here")
    app = MillBlocks(
        __name__,
        template_folder=str(data_dir("templates")),
        static_folder=str(data_dir("static")),
        instance_path=str(given.get("INSTANCE_PATH") or instance_dir()),
    )
    app.url_map.converters["int"] = RowId
    app.config.update(
        SESSION_COOKIE_HTTPONLY=True,
        SESSION_COOKIE_SAMESITE="Lax",
        WTF_CSRF_TIME_LIMIT=None,
    )
    # Loaded as the text given (loads=str): a secret key or a user name is not JSON, and
    # settings.apply reads each value with the app's own number reader.
    app.config.from_prefixed_env(settings.PREFIX, loads=str)
    app.config.update(given)
    settings.apply(app.config, os.environ)
    logs.init_app(app)
    app.config["MAX_CONTENT_LENGTH"] = app.config["MAX_UPLOAD_BYTES"]
    app.config["SESSION_COOKIE_SECURE"] = bool(
        app.config["SESSION_COOKIE_SECURE"] or app.config["HTTPS"]
    )
    _harden_cookie(app)
    _trust_proxy(app)
    if not app.config["SECRET_KEY"]:
        app.config["SECRET_KEY"] = _secret_key(Path(app.instance_path))
    csrf.init_app(app)
    app.extensions["millblocks.library"] = open_library(
        app.config["DATABASE_URL"],
        seed_demo=app.config["DEMO_PROGRAMS"],
        zone=app.config["TIME_ZONE"],
    )
    app.add_template_filter(_shown_time, "shop_time")

    for module in (
        auth,
        health,
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
    app.before_request(_text_rule)  # after the login check: strangers are sent to log in

    app.after_request(_security_headers)
    app.register_error_handler(CSRFError, _csrf_error)
    app.register_error_handler(413, _too_large)
    app.register_error_handler(404, _not_found)
    app.register_error_handler(403, _forbidden)
    app.register_error_handler(422, _refused)
    app.register_error_handler(TextError, _refused_text)
    app.register_error_handler(sizes.OverBudget, _over_budget)
    _budget_requests(app)
    return app


def _shown_time(moment: datetime, seconds: bool = False) -> str:
    """`{{ t | shop_time }}`: a stored time in the shop's zone, labelled."""
    return settings.shown(moment, current_app.config["TIME_ZONE"], seconds)


class RowId(IntegerConverter):
    """`<int:…>` in a URL: at most 9 digits, so an id never overflows a database integer
    (/programs/99999999999999999999 is a 404, not an OverflowError)."""

    regex = r"\d{1,9}"

    def __init__(self, map: Any, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("max", 999_999_999)
        super().__init__(map, *args, **kwargs)


def _budget_requests(app: Flask) -> None:
    """Give each request REQUEST_SECONDS (MILLBLOCKS_REQUEST_SECONDS, default 20) of work:
    past that the core stops it (app.cnc.sizes.spend) and the page says so (503), well
    before gunicorn's 30 s timeout would kill the worker. The last line of defence behind
    the size limits (app.cnc.sizes, app.cnc.cost), which keep legal programs below it; one
    of them, Verify's (sizes.MAX_VERIFY_WORK), is the server's alone, so it is set here for
    every page that simulates."""
    seconds = float(app.config["REQUEST_SECONDS"])
    inner = app.wsgi_app

    def budgeted(environ: dict[str, Any], start_response: Any) -> Any:
        with sizes.time_budget(seconds), sizes.verify_allowed(sizes.MAX_VERIFY_WORK):
            return inner(environ, start_response)

    app.wsgi_app = budgeted  # type: ignore[method-assign]


def _harden_cookie(app: Flask) -> None:
    """Over HTTPS the session cookie is `__Host-millblocks`: Secure, path /, no Domain, so
    no other site or subdomain can set or read it (ASVS 3.4.4)."""
    app.config["SESSION_COOKIE_PATH"] = "/"
    app.config["SESSION_COOKIE_DOMAIN"] = False
    if app.config["SESSION_COOKIE_SECURE"] and app.config["SESSION_COOKIE_NAME"] == "session":
        app.config["SESSION_COOKIE_NAME"] = "__Host-millblocks"


def _trust_proxy(app: Flask) -> None:
    """Behind N reverse proxies (PROXY_HOPS=N), take the client's address and
    scheme from the last N X-Forwarded-For/-Proto entries; with 0 (the default) those
    headers are ignored, so a client cannot choose its own address for the login limit."""
    hops = app.config["PROXY_HOPS"]
    if hops:
        app.wsgi_app = ProxyFix(app.wsgi_app, x_for=hops, x_proto=hops)  # type: ignore[method-assign]


def _secret_key(instance: Path) -> str:
    """A per-installation key kept in instance/secret_key (created on first start)."""
    path = settings.instance_folder(instance) / "secret_key"
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


def _text_rule() -> None:
    """Every form field, query argument, uploaded file's name and URL part meets the one
    text rule (app.cnc.text) before a route reads it: a NUL or a lone surrogate anywhere
    is a 422 naming the field, never a 500 from the database. The fields' lengths are
    checked where they are stored (app.storage)."""
    for values in (request.args, request.form):
        for key, value in values.items(multi=True):
            check_text(key, "a field's name")
            check_text(value, key)
    for key, file in request.files.items(multi=True):
        check_text(key, "a field's name")
        check_text(file.filename or "", f"{key} (the file's name)")
    for key, value in (request.view_args or {}).items():
        if isinstance(value, str):
            check_text(value, key)


def _refused_text(error: TextError) -> tuple[str, int]:
    return render_template("errors/error.html", title="Refused", message=str(error)), 422


def _csrf_error(error: CSRFError) -> tuple[str, int]:
    return render_template("errors/error.html", title="Refused", message=error.description), 400


def _too_large(_error: Exception) -> tuple[str, int]:
    limit = current_app.config["MAX_UPLOAD_BYTES"]
    message = (
        f"The upload is larger than the {limit:,} bytes this MillBlocks accepts "
        "(MILLBLOCKS_MAX_UPLOAD_BYTES)."
    )
    return render_template("errors/error.html", title="Too large", message=message), 413


def _forbidden(error: Exception) -> tuple[str, int]:
    message = getattr(error, "description", "Not allowed")
    return render_template("errors/error.html", title="Not allowed", message=message), 403


def _refused(error: Exception) -> tuple[str, int]:
    message = getattr(error, "description", "Refused")
    return render_template("errors/error.html", title="Refused", message=message), 422


def _over_budget(error: Exception) -> tuple[str, int]:
    return render_template("errors/error.html", title="Too much work", message=str(error)), 503


def _not_found(error: Exception) -> tuple[str, int]:
    message = getattr(error, "description", "Not found")
    return render_template("errors/error.html", title="Not found", message=message), 404
