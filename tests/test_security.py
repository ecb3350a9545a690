"""Sessions, redirects, the login rate limit and the local mode's Host check (issue 17).

Each test names the ASVS 4.0.3 item it shows where it shows one (docs/security.md lists
them). Sessions live on the server: the cookie carries only a random session id, and
logout, a password change, a role change or an admin's "end sessions" revoke it.
"""

from __future__ import annotations

from collections.abc import Iterator
from datetime import timedelta
from pathlib import Path
from urllib.parse import urlsplit

import pytest
from flask import Flask
from flask.testing import FlaskClient
from sqlalchemy import select, text

from app.storage.accounts import Accounts
from app.storage.models import SessionRow
from app.web.extensions import get_library
from tests.web_support import PASSWORD, accounts_app, csrf, dispose, local_app, log_in

COOKIE = "session"


@pytest.fixture
def app(tmp_path: Path) -> Iterator[Flask]:
    app = accounts_app(tmp_path)
    yield app
    dispose(app)


def logged_in(app: Flask, username: str) -> FlaskClient:
    client = app.test_client()
    assert log_in(client, username).status_code == 302
    return client


def is_logged_out(client: FlaskClient) -> bool:
    response = client.get("/")
    return response.status_code == 302 and "/login" in response.headers["Location"]


def replay(app: Flask, client: FlaskClient) -> FlaskClient:
    """A second browser holding a copy of `client`'s session cookie (a stolen cookie)."""
    cookie = client.get_cookie(COOKIE)
    assert cookie is not None
    thief = app.test_client()
    thief.set_cookie(COOKIE, cookie.value)
    return thief


# -- defect 1: sessions end on the server (ASVS 3.3.1) --------------------------------------


def test_logout_ends_the_session_on_the_server(app: Flask) -> None:
    """ASVS 3.3.1: logout invalidates the session; a copy of the old cookie reads and
    writes nothing afterwards."""
    client = logged_in(app, "ana")
    copy = replay(app, client)
    assert copy.get("/").status_code == 200
    token = csrf(client)
    assert client.post("/logout", data={"csrf_token": token}).status_code == 302
    assert is_logged_out(copy)
    response = copy.post(
        "/programs/1/header",
        data={
            "csrf_token": csrf(copy, "/login"),
            "version": "1",
            "name": "Hijacked",
            "units": "inch",
        },
    )
    assert response.status_code == 302 and "/login" in response.headers["Location"]
    with app.app_context():
        assert get_library().get(1).info.version == 1


def test_the_cookie_holds_only_a_random_session_id(app: Flask) -> None:
    client = logged_in(app, "ana")
    with client.session_transaction() as session:
        assert "user_id" not in session
        assert len(session["sid"]) >= 43  # 256 bits, URL-safe base64
    with app.app_context(), get_library().engine.connect() as conn:
        stored = conn.execute(text("select id from sessions")).scalars().all()
    with client.session_transaction() as session:
        assert session["sid"] not in stored  # only a hash of the id is stored


def test_a_password_change_ends_every_session_of_the_user(app: Flask) -> None:
    phone = logged_in(app, "ana")
    desk = logged_in(app, "ana")
    token = csrf(desk, "/account")
    response = desk.post(
        "/account/password",
        data={"csrf_token": token, "current": PASSWORD, "new": "a new long passphrase"},
    )
    assert response.status_code == 302
    assert is_logged_out(phone)
    assert not is_logged_out(desk)  # the session that changed it goes on, renewed
    assert log_in(app.test_client(), "ana", "a new long passphrase").status_code == 302


def test_a_password_set_from_the_command_line_ends_sessions(app: Flask) -> None:
    client = logged_in(app, "ana")
    with app.app_context():
        Accounts(get_library()).set_password("ana", "reset by the admin")
    assert is_logged_out(client)


def test_the_command_line_ends_sessions(
    app: Flask, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from click.testing import CliRunner

    from app.cli import main

    monkeypatch.setenv("DATABASE_URL", app.config["DATABASE_URL"])
    client = logged_in(app, "ana")
    result = CliRunner().invoke(main, ["user", "end-sessions", "ana"])
    assert result.exit_code == 0 and "1 sessions of ana ended" in result.output
    assert is_logged_out(client)
    client = logged_in(app, "ana")
    new = "changed at the console"
    result = CliRunner().invoke(main, ["user", "password", "ana", "--password", new])
    assert result.exit_code == 0, result.output
    assert is_logged_out(client)


def test_a_role_change_ends_the_users_sessions(app: Flask) -> None:
    ana = logged_in(app, "ana")
    ada = logged_in(app, "ada")
    token = csrf(ada, "/users")
    response = ada.post("/users/ana/role", data={"csrf_token": token, "role": "operator"})
    assert response.status_code == 302
    assert is_logged_out(ana)


def test_a_user_named_with_a_slash_can_be_re_roled(app: Flask) -> None:
    with app.app_context():
        Accounts(get_library()).create("shop/night", PASSWORD, "operator")
    ada = logged_in(app, "ada")
    token = csrf(ada, "/users")
    response = ada.post("/users/shop/night/role", data={"csrf_token": token, "role": "admin"})
    assert response.status_code == 302
    with app.app_context():
        roles = {u.username: u.role for u in Accounts(get_library()).users()}
    assert roles["shop/night"] == "admin"


def test_an_admin_ends_a_users_sessions(app: Flask) -> None:
    ana = logged_in(app, "ana")
    ada = logged_in(app, "ada")
    token = csrf(ada, "/users")
    response = ada.post("/users/ana/sessions/end", data={"csrf_token": token})
    assert response.status_code == 302
    assert is_logged_out(ana)
    assert not is_logged_out(ada)


def age(app: Flask, *, created: timedelta, seen: timedelta) -> None:
    """Move every stored session back in time."""
    with app.app_context(), get_library().session() as s:
        for row in s.scalars(select(SessionRow)):
            row.created_at -= created
            row.last_seen -= seen


def test_an_idle_session_expires(app: Flask) -> None:
    """ASVS 3.3.1/3.3.2: a session unused for the idle timeout (30 minutes) is over."""
    client = logged_in(app, "ana")
    age(app, created=timedelta(minutes=29), seen=timedelta(minutes=29))
    assert not is_logged_out(client)
    age(app, created=timedelta(minutes=31), seen=timedelta(minutes=31))
    assert is_logged_out(client)


def test_a_session_ends_after_the_absolute_timeout_even_when_active(app: Flask) -> None:
    """ASVS 3.3.2: re-authentication after 12 hours, however active the session is."""
    client = logged_in(app, "ana")
    age(app, created=timedelta(hours=12, minutes=1), seen=timedelta(0))
    assert is_logged_out(client)


def test_session_cookie_attributes_over_https(tmp_path: Path) -> None:
    """ASVS 3.4.1-3.4.5: Secure, HttpOnly, SameSite, the __Host- prefix and path /."""
    app = accounts_app(tmp_path, SESSION_COOKIE_SECURE=True)
    client = app.test_client()
    response = log_in(client, "ana")
    cookie = response.headers.get("Set-Cookie", "")
    assert cookie.startswith("__Host-millblocks=")
    for attribute in ("Secure", "HttpOnly", "SameSite=Lax", "Path=/"):
        assert attribute in cookie, attribute
    assert "Domain=" not in cookie
    dispose(app)


# -- defect 2: open redirect (ASVS 5.1.5) ---------------------------------------------------


@pytest.mark.parametrize(
    "target",
    [
        "/%09/evil.example/x",
        "/%0a/evil.example/x",
        "/%0d/evil.example/x",
        "//evil.example/x",
        "/\\evil.example/x",
        "/%5Cevil.example/x",
        "https://evil.example/x",
        "javascript:alert(1)",
        "%2F%2Fevil.example",
        "/ /evil.example",
        "\\\\evil.example",
    ],
)
def test_login_follows_only_same_site_paths(app: Flask, target: str) -> None:
    """ASVS 5.1.5: a redirect after login goes only to a path of this site."""
    response = log_in(app.test_client(), "ana", query=f"?next={target}")
    assert response.status_code == 302
    location = response.headers["Location"]
    # What a browser does with it: drop tabs and newlines, read backslashes as slashes.
    browser = location.replace("\t", "").replace("\n", "").replace("\r", "").replace("\\", "/")
    parts = urlsplit(browser)
    assert not parts.netloc and not parts.scheme, location
    assert location.startswith("/") and not browser.startswith("//"), location


def test_login_follows_a_same_site_next_path(app: Flask) -> None:
    response = log_in(app.test_client(), "ana", query="?next=/programs/1%3Fat%3D2")
    assert response.headers["Location"] == "/programs/1?at=2"


# -- defect 3: the rate limit counts per account and per address (ASVS 2.2.1) ------------


def test_a_login_does_not_reset_the_count_for_another_account(app: Flask) -> None:
    guesser = app.test_client()
    codes = [log_in(guesser, "ada", "guess").status_code for _ in range(4)]
    assert codes == [401] * 4
    assert log_in(app.test_client(), "ana").status_code == 302  # same address
    assert log_in(guesser, "ada", "guess").status_code == 401  # the fifth
    assert log_in(guesser, "ada", "guess").status_code == 429


def test_guesses_at_one_account_do_not_lock_out_another(app: Flask) -> None:
    guesser = app.test_client()
    for _ in range(5):
        log_in(guesser, "ana", "guess")
    refused = log_in(guesser, "ana", PASSWORD)
    assert refused.status_code == 429
    assert "Too many failed logins for ana" in refused.get_data(as_text=True)
    assert log_in(app.test_client(), "ada").status_code == 302


def test_many_accounts_guessed_from_one_address_are_refused(app: Flask) -> None:
    """ASVS 2.2.1: credential stuffing (many names, one address) is refused too."""
    client = app.test_client()
    codes = [log_in(client, f"user{n}", "guess").status_code for n in range(20)]
    assert codes == [401] * 20
    response = log_in(client, "someone-else", "guess")
    assert response.status_code == 429
    assert "from this address" in response.get_data(as_text=True)


def test_forwarded_addresses_are_ignored_unless_the_proxy_is_trusted(app: Flask) -> None:
    """Without MILLBLOCKS_PROXY_HOPS a client cannot pick its own address."""
    client = app.test_client()
    for n in range(5):
        log_in(client, "ada", "guess", headers={"X-Forwarded-For": f"198.51.100.{n}"})
    assert log_in(client, "ada", headers={"X-Forwarded-For": "198.51.100.99"}).status_code == 429


def test_behind_a_trusted_proxy_each_client_counts_apart(tmp_path: Path) -> None:
    app = accounts_app(tmp_path, PROXY_HOPS=1)
    proxy = "10.0.0.1"
    client = app.test_client()
    for _ in range(5):
        log_in(client, "ada", "guess", remote=proxy, headers={"X-Forwarded-For": "198.51.100.7"})
    blocked = log_in(client, "ada", remote=proxy, headers={"X-Forwarded-For": "198.51.100.7"})
    assert blocked.status_code == 429
    real = log_in(client, "ada", remote=proxy, headers={"X-Forwarded-For": "198.51.100.8"})
    assert real.status_code == 302
    dispose(app)


# -- defect 4: local mode answers loopback names only -----------------------------------


@pytest.mark.parametrize(
    ("host", "status"),
    [
        ("localhost", 200),
        ("localhost:5000", 200),
        ("127.0.0.1:5000", 200),
        ("[::1]:5000", 200),
        ("evil.example", 403),
        ("evil.example:5000", 403),
        ("127.0.0.1.evil.example", 403),
        ("localhost.evil.example", 403),
    ],
)
def test_local_mode_answers_only_loopback_host_names(
    tmp_path: Path, host: str, status: int
) -> None:
    """DNS rebinding: a page served under another name that resolves to 127.0.0.1 must not
    reach the local editor."""
    app = local_app(tmp_path)
    response = app.test_client().get("/", headers={"Host": host})
    assert response.status_code == status
    if status == 403:
        assert "answers only to localhost" in response.get_data(as_text=True)
    dispose(app)
