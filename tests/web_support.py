"""Helpers the web tests share: apps of each mode, CSRF tokens, logging in."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from flask import Flask
from flask.testing import FlaskClient

from app import create_app
from app.storage.accounts import Accounts
from app.web.extensions import get_library

PASSWORD = "correct horse battery"


def accounts_app(tmp_path: Path, **config: Any) -> Flask:
    """An app in accounts mode on a fresh SQLite file, with ana (programmer), otto
    (operator) and ada (admin)."""
    app = create_app(
        {
            "DATABASE_URL": f"sqlite:///{tmp_path / 'accounts.db'}",
            "SECRET_KEY": "test" * 32,
            "AUTH": "accounts",
            **config,
        }
    )
    with app.app_context():
        book = Accounts(get_library())
        book.create("ana", PASSWORD, "programmer")
        book.create("otto", PASSWORD, "operator")
        book.create("ada", PASSWORD, "admin")
    return app


def local_app(tmp_path: Path, **config: Any) -> Flask:
    """An app in local mode (one local user) on a fresh SQLite file with the demo set."""
    return create_app(
        {"DATABASE_URL": f"sqlite:///{tmp_path / 'local.db'}", "SECRET_KEY": "test" * 32, **config}
    )


def dispose(app: Flask) -> None:
    with app.app_context():
        get_library().engine.dispose()


def csrf(client: FlaskClient, url: str = "/") -> str:
    page = client.get(url).get_data(as_text=True)
    found = re.search(r'name="csrf_token" value="([^"]+)"', page)
    assert found, f"no CSRF token on {url}"
    return found.group(1)


def log_in(
    client: FlaskClient,
    username: str,
    password: str = PASSWORD,
    query: str = "",
    remote: str = "127.0.0.1",
    headers: dict[str, str] | None = None,
) -> Any:
    """POST the login form as a browser at address `remote` does; the response."""
    token = csrf(client, "/login")
    return client.post(
        f"/login{query}",
        data={"csrf_token": token, "username": username, "password": password},
        environ_base={"REMOTE_ADDR": remote},
        headers=headers or {},
    )


def multipart(token: str, filename: str, data: bytes) -> tuple[bytes, str]:
    """The body and Content-Type of a browser's upload form (csrf_token and file), written
    out whole: werkzeug's test builder spools a large body to a temporary file that it leaves
    open when the app refuses the request unread."""
    boundary = "millblocks-test-boundary"
    head = (
        f'--{boundary}\r\nContent-Disposition: form-data; name="csrf_token"\r\n\r\n'
        f"{token}\r\n--{boundary}\r\n"
        f'Content-Disposition: form-data; name="file"; filename="{filename}"\r\n'
        "Content-Type: application/octet-stream\r\n\r\n"
    )
    body = head.encode() + data + f"\r\n--{boundary}--\r\n".encode()
    return body, f"multipart/form-data; boundary={boundary}"
