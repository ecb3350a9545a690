"""A server configured from its environment (issue 31): every setting a MILLBLOCKS_*
variable, read by the web app (Flask's `from_prefixed_env`) and the command line alike, and
docs/deploy.md's table of them kept true by a test."""

from __future__ import annotations

import re
from datetime import datetime, timedelta
from pathlib import Path

import pytest
from click.testing import CliRunner
from flask import Flask
from flask.testing import FlaskClient
from sqlalchemy import select, update

from app.cli import main
from app.settings import SETTINGS, SettingError
from app.storage.accounts import Accounts
from app.storage.models import ProgramRow, RevisionRow, SessionRow
from app.web import create_app
from app.web.extensions import get_library
from tests.web_support import PASSWORD, csrf, dispose, log_in, multipart

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(autouse=True)
def clean_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    """No setting leaks in from the shell that runs the tests."""
    for setting in SETTINGS:
        monkeypatch.delenv(setting.variable, raising=False)
    monkeypatch.delenv("DATABASE_URL", raising=False)


def server(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, **variables: str) -> Flask:
    """An app configured the way a shop server is: from the environment alone."""
    for name, value in variables.items():
        monkeypatch.setenv(f"MILLBLOCKS_{name}", value)
    return create_app()


def accounts_server(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, **variables: str) -> Flask:
    shop = {
        "AUTH": "accounts",
        "DATABASE_URL": f"sqlite:///{tmp_path / 'shop.db'}",
        "INSTANCE_PATH": str(tmp_path / "instance"),
    }
    app = server(tmp_path, monkeypatch, **{**shop, **variables})
    with app.app_context():
        book = Accounts(get_library())
        if not book.users():
            book.create("ana", PASSWORD, "programmer")
    return app


def logged_in(app: Flask) -> FlaskClient:
    client = app.test_client()
    assert log_in(client, "ana").status_code == 302
    return client


def is_logged_out(client: FlaskClient) -> bool:
    response = client.get("/")
    return response.status_code == 302 and "/login" in response.headers["Location"]


def age(app: Flask, *, created: timedelta, seen: timedelta) -> None:
    with app.app_context(), get_library().session() as s:
        for row in s.scalars(select(SessionRow)):
            row.created_at -= created
            row.last_seen -= seen


def test_the_idle_timeout_comes_from_the_environment(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """MILLBLOCKS_SESSION_IDLE_MINUTES=5: a session unused for 6 minutes is over (the
    documented variable was ignored: the session lived its 30 default minutes)."""
    app = accounts_server(tmp_path, monkeypatch, SESSION_IDLE_MINUTES="5")
    client = logged_in(app)
    age(app, created=timedelta(minutes=4), seen=timedelta(minutes=4))
    assert not is_logged_out(client)  # this request marks the session used again
    age(app, created=timedelta(minutes=6), seen=timedelta(minutes=6))
    assert is_logged_out(client)
    dispose(app)


def test_a_short_idle_limit_does_not_end_a_session_in_use(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """MILLBLOCKS_SESSION_IDLE_MINUTES=1 and a request every 10 s: the session lives on.
    `last_seen` was written once a minute, so a session used every 10 s ended at 60 s."""
    app = accounts_server(tmp_path, monkeypatch, SESSION_IDLE_MINUTES="1")
    client = logged_in(app)
    for _ in range(12):  # two minutes of work
        age(app, created=timedelta(seconds=10), seen=timedelta(seconds=10))
        assert not is_logged_out(client)
    age(app, created=timedelta(seconds=61), seen=timedelta(seconds=61))
    assert is_logged_out(client)
    dispose(app)


def test_the_absolute_timeout_comes_from_the_environment(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """MILLBLOCKS_SESSION_HOURS=1: an active session ends an hour after login."""
    app = accounts_server(tmp_path, monkeypatch, SESSION_HOURS="1")
    client = logged_in(app)
    age(app, created=timedelta(minutes=59), seen=timedelta(0))
    assert not is_logged_out(client)
    age(app, created=timedelta(minutes=2), seen=timedelta(0))
    assert is_logged_out(client)
    dispose(app)


def test_two_servers_given_one_secret_key_share_logins(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Two servers (each its own instance folder) on one database, given the same
    MILLBLOCKS_SECRET_KEY: a login on one is a login on the other. A third without the key
    makes its own, and the login is not good there."""
    database = f"sqlite:///{tmp_path / 'shared.db'}"
    key = "a8d0c5f1e2b34c6d9e7f0a1b2c3d4e5f"
    first = accounts_server(tmp_path, monkeypatch, DATABASE_URL=database, SECRET_KEY=key)
    monkeypatch.setenv("MILLBLOCKS_INSTANCE_PATH", str(tmp_path / "second"))
    second = create_app()
    monkeypatch.delenv("MILLBLOCKS_SECRET_KEY")
    monkeypatch.setenv("MILLBLOCKS_INSTANCE_PATH", str(tmp_path / "third"))
    third = create_app()
    cookie = logged_in(first).get_cookie("session")
    assert cookie is not None
    for other, shared in ((second, True), (third, False)):
        browser = other.test_client()
        browser.set_cookie("session", cookie.value)
        assert is_logged_out(browser) is not shared
    assert not (tmp_path / "instance" / "secret_key").exists()
    assert (tmp_path / "third" / "secret_key").exists()
    for app in (first, second, third):
        dispose(app)


def test_the_instance_path_holds_the_library_and_the_key(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """MILLBLOCKS_INSTANCE_PATH: without DATABASE_URL the SQLite library and the generated
    key live there, for the server and the command line alike."""
    instance = tmp_path / "var" / "millblocks"
    app = server(tmp_path, monkeypatch, INSTANCE_PATH=str(instance))
    assert (instance / "millblocks.db").exists()
    assert (instance / "secret_key").exists()
    with app.app_context():
        made = get_library().programs("", "name", False)
    result = CliRunner().invoke(main, ["list"])
    assert result.exit_code == 0, result.output
    assert len(result.stdout.splitlines()) == len(made) > 0
    dispose(app)


def test_demo_programs_off(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """MILLBLOCKS_DEMO_PROGRAMS=0: a new library starts empty, on the web and from the
    command line (a shop server should not show sample parts to operators)."""
    database = f"sqlite:///{tmp_path / 'empty.db'}"
    app = server(
        tmp_path,
        monkeypatch,
        DEMO_PROGRAMS="0",
        DATABASE_URL=database,
        INSTANCE_PATH=str(tmp_path),
        USER="ada",
    )
    page = app.test_client().get("/").get_data(as_text=True)
    assert "ProtoTRAK Plus sample part" not in page
    with app.app_context():
        assert get_library().programs("", "name", False) == []
    monkeypatch.setenv("MILLBLOCKS_DATABASE_URL", f"sqlite:///{tmp_path / 'cli.db'}")
    result = CliRunner().invoke(main, ["list"])
    assert result.exit_code == 0
    assert result.stdout == ""
    dispose(app)


def upload(client: FlaskClient, name: str, data: bytes) -> tuple[int, str]:
    """POST the import form as a browser does; the status and the page."""
    body, content_type = multipart(csrf(client), name, data)
    response = client.post("/programs/import", data=body, content_type=content_type)
    return response.status_code, response.get_data(as_text=True)


def test_the_webs_upload_and_line_limits_come_from_the_environment(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """MILLBLOCKS_MAX_UPLOAD_BYTES and MILLBLOCKS_MAX_IMPORT_LINES bound an upload; the
    refusal names the configured figure."""
    app = server(
        tmp_path,
        monkeypatch,
        MAX_UPLOAD_BYTES="4000",
        MAX_IMPORT_LINES="50",
        DATABASE_URL=f"sqlite:///{tmp_path / 'limits.db'}",
        INSTANCE_PATH=str(tmp_path),
    )
    client = app.test_client()
    status, page = upload(client, "big.ngc", b"G0 X1 Y1\n" * 600)
    assert status == 413
    assert "4,000 bytes" in page
    status, page = upload(client, "long.ngc", b"G0 X1\n" * 60)
    assert status == 422
    assert "at most 50 lines" in page
    status, _ = upload(client, "short.ngc", b"G20 G90\nG0 X1 Y1\nG1 Z-0.1 F5\nM2\n")
    assert status in (200, 201, 302)
    dispose(app)


@pytest.mark.parametrize(
    ("variable", "value", "said"),
    [
        ("SESSION_HOURS", "twelve", "MILLBLOCKS_SESSION_HOURS: 'twelve' is not a number"),
        ("SESSION_IDLE_MINUTES", "0", "MILLBLOCKS_SESSION_IDLE_MINUTES: 0 is not above 0"),
        ("PROXY_HOPS", "-1", "MILLBLOCKS_PROXY_HOPS: -1 is below 0"),
        ("AUTH", "ldap", "MILLBLOCKS_AUTH: 'ldap' is not one of local, accounts"),
        ("DEMO_PROGRAMS", "maybe", "MILLBLOCKS_DEMO_PROGRAMS: 'maybe' is not 0 or 1"),
        ("TIME_ZONE", "Mars/Olympus", "MILLBLOCKS_TIME_ZONE: 'Mars/Olympus' is not a time zone"),
        ("MAX_UPLOAD_BYTES", "2MB", "MILLBLOCKS_MAX_UPLOAD_BYTES: '2MB' is not a whole number"),
    ],
)
def test_a_bad_setting_is_refused_naming_the_variable(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, variable: str, value: str, said: str
) -> None:
    """Refused at start by the server and by the command line, naming the variable, the
    value and what is allowed (not a traceback, not a silent default)."""
    monkeypatch.setenv("MILLBLOCKS_DATABASE_URL", f"sqlite:///{tmp_path / 'bad.db'}")
    monkeypatch.setenv("MILLBLOCKS_INSTANCE_PATH", str(tmp_path))
    monkeypatch.setenv(f"MILLBLOCKS_{variable}", value)
    with pytest.raises(SettingError) as refused:
        create_app()
    assert said in str(refused.value)
    result = CliRunner().invoke(main, ["list"])
    assert result.exit_code == 2
    assert said in result.stderr
    assert "Traceback" not in result.output


def test_an_unknown_variable_is_reported(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """A misspelt MILLBLOCKS_SESION_HOURS is said at start, not silently ignored."""
    with caplog.at_level("WARNING", logger="millblocks"):
        app = server(
            tmp_path,
            monkeypatch,
            SESION_HOURS="1",
            DATABASE_URL=f"sqlite:///{tmp_path / 'u.db'}",
            INSTANCE_PATH=str(tmp_path),
        )
    assert any(
        "MILLBLOCKS_SESION_HOURS is not a MillBlocks setting" in r.getMessage()
        for r in caplog.records
    )
    dispose(app)


# -- the table in docs/deploy.md ------------------------------------------------------------


def documented_settings() -> dict[str, str]:
    """The settings table of docs/deploy.md: variable -> default, as written."""
    text = (ROOT / "docs" / "deploy.md").read_text(encoding="utf-8")
    section = text.split("## Settings", 1)[1].split("\n## ", 1)[0]
    rows = re.findall(r"^\| `(MILLBLOCKS_[A-Z_]+)` \| ([^|]*) \|", section, re.MULTILINE)
    return {name: default.strip() for name, default in rows}


def test_the_docs_table_lists_every_setting_with_its_default() -> None:
    documented = documented_settings()
    assert documented == {s.variable: s.default_text for s in SETTINGS}


def test_every_variable_the_code_reads_is_a_documented_setting() -> None:
    """A MILLBLOCKS_* name anywhere in app/ is one of SETTINGS (so, in the table), or one
    for building and testing only (the compiled importer's switches)."""
    named = set()
    for path in (ROOT / "app").rglob("*.py"):
        named |= set(re.findall(r"MILLBLOCKS_[A-Z][A-Z_]*[A-Z]", path.read_text("utf-8")))
    developers = {"MILLBLOCKS_NATIVE", "MILLBLOCKS_MYPYC"}
    assert named - developers <= {s.variable for s in SETTINGS}


# -- times in the shop's time zone ----------------------------------------------------------


def test_library_times_are_shown_in_the_shops_zone_and_labelled(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """MILLBLOCKS_TIME_ZONE=America/Chicago: a program saved at 12:00 UTC on 1 July shows
    07:00 CDT on the library page, its history and from the command line (UTC was shown
    with no zone)."""
    database = f"sqlite:///{tmp_path / 'tz.db'}"
    app = server(
        tmp_path,
        monkeypatch,
        TIME_ZONE="America/Chicago",
        DATABASE_URL=database,
        INSTANCE_PATH=str(tmp_path),
    )
    noon = datetime(2024, 7, 1, 12, 0)
    winter = datetime(2024, 1, 15, 18, 30)
    with app.app_context(), get_library().session() as s:
        first = s.scalars(select(ProgramRow).order_by(ProgramRow.name)).first()
        assert first is not None
        s.execute(update(ProgramRow).where(ProgramRow.id == first.id).values(updated_at=noon))
        s.execute(
            update(RevisionRow).where(RevisionRow.program_id == first.id).values(created_at=winter)
        )
        program_id, name = first.id, first.name
    client = app.test_client()
    assert "2024-07-01 07:00 CDT" in client.get("/").get_data(as_text=True)
    history = client.get(f"/programs/{program_id}/history").get_data(as_text=True)
    assert "2024-01-15 12:30 CST" in history
    result = CliRunner().invoke(main, ["list", name])
    assert "2024-07-01 07:00 CDT" in result.stdout
    result = CliRunner().invoke(main, ["history", str(program_id)])
    assert "2024-01-15 12:30 CST" in result.stdout
    dispose(app)


def test_times_default_to_the_servers_zone(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Without MILLBLOCKS_TIME_ZONE, the server's own zone (TZ, else /etc/localtime),
    labelled."""
    monkeypatch.setenv("TZ", "Europe/Berlin")
    app = server(
        tmp_path,
        monkeypatch,
        DATABASE_URL=f"sqlite:///{tmp_path / 'b.db'}",
        INSTANCE_PATH=str(tmp_path),
    )
    with app.app_context(), get_library().session() as s:
        s.execute(update(ProgramRow).values(updated_at=datetime(2024, 7, 1, 12, 0)))
    assert "2024-07-01 14:00 CEST" in app.test_client().get("/").get_data(as_text=True)
    dispose(app)
