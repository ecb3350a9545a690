"""Who may do what: local mode, accounts, roles, the login rate limit."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from flask import Flask
from flask.testing import FlaskClient

from app import create_app
from app.web.extensions import get_library
from tests import web_support
from tests.web_support import PASSWORD, accounts_app, csrf, dispose


@pytest.fixture
def app(tmp_path: Path) -> Iterator[Flask]:
    app = accounts_app(tmp_path)
    yield app
    dispose(app)


def log_in(client: FlaskClient, username: str, password: str = PASSWORD) -> int:
    status: int = web_support.log_in(client, username, password).status_code
    return status


def test_pages_need_a_login(app: Flask) -> None:
    client = app.test_client()
    response = client.get("/programs/1")
    assert response.status_code == 302 and "/login" in response.headers["Location"]


def test_operator_views_and_exports_but_cannot_edit(app: Flask) -> None:
    client = app.test_client()
    assert log_in(client, "otto") == 302
    assert client.get("/programs/1").status_code == 200
    assert client.get("/programs/1/export/download?target=gcode-linuxcnc").status_code == 200
    token = csrf(client, "/")
    response = client.post(
        "/programs/1/blocks", data={"csrf_token": token, "version": "1", "kind": "POS", "at": "1"}
    )
    assert response.status_code == 403
    assert "otto (operator) may not do this: it needs the edit right" in response.get_data(
        as_text=True
    )
    with app.app_context():
        assert get_library().get(1).info.version == 1


def test_programmer_edits_and_the_revision_names_them(app: Flask) -> None:
    client = app.test_client()
    log_in(client, "ana")
    token = csrf(client, "/")
    response = client.post(
        "/programs/1/header",
        data={"csrf_token": token, "version": "1", "name": "Renamed", "units": "inch"},
    )
    assert response.status_code == 302
    with app.app_context():
        assert get_library().revisions(1)[-1].author == "ana"
    assert client.post("/machines", data={"csrf_token": token, "name": "x"}).status_code == 403


def test_admin_manages_users(app: Flask) -> None:
    client = app.test_client()
    log_in(client, "ada")
    token = csrf(client, "/users")
    response = client.post(
        "/users",
        data={"csrf_token": token, "username": "newbie", "password": PASSWORD, "role": "operator"},
    )
    assert response.status_code == 302
    assert "newbie" in client.get("/users").get_data(as_text=True)


def test_repeated_failed_logins_get_429(app: Flask) -> None:
    client = app.test_client()
    codes = [log_in(client, "ana", "wrong password") for _ in range(5)]
    assert codes == [401] * 5
    assert log_in(client, "ana", "wrong password") == 429
    assert log_in(client, "ana") == 429  # even the right password waits


def test_login_starts_a_new_session(app: Flask) -> None:
    client = app.test_client()
    with client.session_transaction() as session:
        session["planted"] = "by an attacker"
    log_in(client, "ana")
    with client.session_transaction() as session:
        assert "planted" not in session and "sid" in session


def test_local_mode_serves_only_loopback(tmp_path: Path) -> None:
    app = create_app({"DATABASE_URL": f"sqlite:///{tmp_path / 'l.db'}", "SECRET_KEY": "t" * 32})
    client = app.test_client()
    assert client.get("/", environ_base={"REMOTE_ADDR": "127.0.0.1"}).status_code == 200
    far = client.get("/", environ_base={"REMOTE_ADDR": "192.0.2.7"})
    assert far.status_code == 403
    assert "serves its local user only" in far.get_data(as_text=True)
    with app.app_context():
        get_library().engine.dispose()


def test_passwords_are_stored_hashed(app: Flask) -> None:
    from sqlalchemy import text

    with app.app_context(), get_library().engine.connect() as conn:
        stored = conn.execute(text("select password_hash from users where username='ana'"))
        value = stored.scalar()
    assert isinstance(value, str) and value.startswith("scrypt:") and PASSWORD not in value


def test_session_cookie_flags(app: Flask) -> None:
    client = app.test_client()
    token = csrf(client, "/login")
    response = client.post(
        "/login", data={"csrf_token": token, "username": "ana", "password": PASSWORD}
    )
    cookie = response.headers.get("Set-Cookie", "")
    assert "HttpOnly" in cookie and "SameSite=Lax" in cookie
