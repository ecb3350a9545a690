"""A shop's sysadmin's mistakes in the settings, met as the docs run MillBlocks (issue 31,
an audit of the installed wheel): every command, `millblocks serve` and the app factory
gunicorn loads say in one line which setting is wrong and how, never the password, and exit
with the status docs/deploy.md gives (2 from the command line, 4 from gunicorn: the unit does
not restart on either), not a traceback with status 1 or 3 that the unit restarts forever.
A database that does not answer yet is one line too, with a status the unit restarts on.

The real commands in processes of their own (`python -m app.cli`, the unit's gunicorn
command), real SQLite paths and the suite's real PostgreSQL (pg_virtualenv).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import uuid
from pathlib import Path

import pytest
from click.testing import CliRunner
from sqlalchemy import create_engine, text
from sqlalchemy.engine import make_url

from app import create_app
from app.cli import main
from app.settings import DEVELOPMENT, SETTINGS, SettingError
from tests.conftest import postgres_admin_url
from tests.test_deploy import free_port, gunicorn, server_environment, unit

ROOT = Path(__file__).resolve().parents[1]
PASSWORD = "not-the-password-7f3a"
"""The wrong password the tests give: it must appear in no message."""

COMMANDS = [["db", "upgrade"], ["list"], ["export", "1", "--to", "gcode-linuxcnc"]]
"""The commands a sysadmin runs first (the unit's ExecStartPre, a look at the library, an
export from it): each opens the library."""


@pytest.fixture(autouse=True)
def clean_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    for setting in SETTINGS:
        monkeypatch.delenv(setting.variable, raising=False)
    monkeypatch.delenv("DATABASE_URL", raising=False)


def environment(tmp_path: Path, **variables: str) -> dict[str, str]:
    """This process's environment without MillBlocks' settings, then `variables`."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("MILLBLOCKS_")}
    env.pop("DATABASE_URL", None)
    env["MILLBLOCKS_INSTANCE_PATH"] = str(tmp_path / "instance")
    env["PYTHONPATH"] = str(ROOT)
    env.update({f"MILLBLOCKS_{name}": value for name, value in variables.items()})
    return env


def millblocks(env: dict[str, str], *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "app.cli", *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def one_line(stderr: str) -> str:
    """The one line a refused start says (a traceback or a second line fails)."""
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, stderr
    assert "Traceback" not in stderr and PASSWORD not in stderr
    return lines[0]


def postgres(password: str | None = None, scheme: str = "postgresql+psycopg") -> str:
    """A URL of the suite's PostgreSQL cluster (its `postgres` database), with `password`
    instead of the right one when given."""
    url = make_url(postgres_admin_url())
    if password is not None:
        url = url.set(password=password)
    shown = url.render_as_string(hide_password=False)
    return scheme + shown[len("postgresql+psycopg") :]


@pytest.mark.parametrize("command", COMMANDS, ids=lambda c: c[0])
@pytest.mark.parametrize(
    ("variables", "said"),
    [
        (
            {"DATABASE_URL": "garbage"},
            "Error: MILLBLOCKS_DATABASE_URL: 'garbage' is not a database URL (such as "
            "postgresql+psycopg://USER:PASSWORD@HOST/DATABASE",
        ),
        (
            {"DATABASE_URL": f"mysql://shop:{PASSWORD}@localhost/millblocks"},
            "Error: MILLBLOCKS_DATABASE_URL: mysql://shop:***@localhost/millblocks: MillBlocks "
            "cannot open this kind of database",
        ),
        (
            {"DATABASE_URL": "sqlite:////proc/1/nope/millblocks.db"},
            "Error: MILLBLOCKS_DATABASE_URL: sqlite:////proc/1/nope/millblocks.db: SQLite "
            "cannot open the file (unable to open database file)",
        ),
        (
            {"INSTANCE_PATH": "/proc/1/nope"},
            "Error: MILLBLOCKS_INSTANCE_PATH: cannot make the folder /proc/1/nope: No such "
            "file or directory",
        ),
    ],
    ids=["not-a-url", "no-driver", "sqlite-path", "instance-path"],
)
def test_a_setting_that_cannot_open_the_library_is_one_line_and_exit_2(
    tmp_path: Path, command: list[str], variables: dict[str, str], said: str
) -> None:
    ended = millblocks(environment(tmp_path, **variables), *command)
    assert ended.returncode == 2, ended.stderr
    assert one_line(ended.stderr).startswith(said)


def test_a_wrong_postgresql_password_is_one_line_without_the_password(tmp_path: Path) -> None:
    """The docs' own URL form with a password PostgreSQL refuses: every command, `serve`
    before it starts gunicorn, and gunicorn started as the unit does (exit 4, which the
    unit does not restart on)."""
    url = postgres(PASSWORD)
    env = environment(tmp_path, DATABASE_URL=url)
    hidden = url.replace(PASSWORD, "***")
    for command in COMMANDS:
        ended = millblocks(env, *command)
        assert ended.returncode == 2, ended.stderr
        line = one_line(ended.stderr)
        assert line.startswith(f"Error: MILLBLOCKS_DATABASE_URL: {hidden}: the server refused:")
        assert "password authentication failed" in line
    ended = millblocks(env, "serve", "--port", str(free_port()))
    assert ended.returncode == 2
    assert "password authentication failed" in one_line(ended.stderr)  # gunicorn never started
    env = server_environment(url, tmp_path / "instance")
    started = subprocess.run(
        gunicorn(free_port()), env=env, cwd=tmp_path, capture_output=True, text=True, timeout=120
    )
    assert started.returncode == 4
    assert "4" in unit()["RestartPreventExitStatus"][0].split()
    # Said once, by gunicorn's master before any worker starts: workers that each fail to
    # load race gunicorn's halt (the second one reaped while it stops for the first), which
    # then ends with a traceback and status 1 — one the unit restarts on (CI, a loaded
    # machine).
    refused = [line for line in started.stderr.splitlines() if "MillBlocks cannot start" in line]
    start = f"MillBlocks cannot start: MILLBLOCKS_DATABASE_URL: {hidden}: the server refused:"
    assert len(refused) == 1 and refused[0].startswith(start), started.stderr
    assert "Booting worker" not in started.stderr
    assert "Traceback" not in started.stderr and PASSWORD not in started.stderr


def test_the_app_factory_says_a_bad_database_in_one_line_and_exits_4(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """`app:create_app()` as gunicorn loads it, on each mistake of the audit."""
    monkeypatch.setenv("MILLBLOCKS_INSTANCE_PATH", str(tmp_path))
    for variable, value, said in (
        ("DATABASE_URL", postgres(PASSWORD), "password authentication failed"),
        ("DATABASE_URL", "garbage", "'garbage' is not a database URL"),
        ("INSTANCE_PATH", "/proc/1/nope", "cannot make the folder /proc/1/nope"),
    ):
        monkeypatch.setenv(f"MILLBLOCKS_{variable}", value)
        with pytest.raises(SystemExit) as ended:
            create_app()
        assert ended.value.code == 4
        line = one_line(capsys.readouterr().err)
        assert line.startswith(f"MillBlocks cannot start: MILLBLOCKS_{variable}: ")
        assert said in line
        monkeypatch.delenv(f"MILLBLOCKS_{variable}")


@pytest.mark.parametrize(
    ("how", "said"),
    [("header", "file is not a database"), ("pages", "database disk image is malformed")],
)
def test_the_app_factory_says_a_damaged_sqlite_file_in_one_line_and_exits_4(
    how: str,
    said: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """The command line named a damaged file and what to do; the app factory (gunicorn's
    workers) ended in the driver's traceback, and gunicorn tried again. Now the same words
    as the command line's, and exit 4: no restart mends the file."""
    from tests.test_cli import _damaged

    path = tmp_path / "library.db"
    _damaged(path, how)
    monkeypatch.setenv("MILLBLOCKS_INSTANCE_PATH", str(tmp_path))
    monkeypatch.setenv("MILLBLOCKS_DATABASE_URL", f"sqlite:///{path}")
    with pytest.raises(SystemExit) as ended:
        create_app()
    assert ended.value.code == 4
    line = one_line(capsys.readouterr().err)
    assert line.startswith(
        f"MillBlocks cannot start: {path}: the database file is damaged (SQLite: {said}). "
        "Stop MillBlocks, move the file aside and restore from a backup"
    )


def test_a_database_that_does_not_answer_is_one_line_and_a_status_the_unit_restarts_on(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Nothing listens on port 1 (PostgreSQL not started yet): the command line exits 1,
    the app factory and gunicorn 3 ("worker failed to boot"); the unit restarts on both."""
    url = f"postgresql+psycopg://millblocks:{PASSWORD}@127.0.0.1:1/millblocks"
    ended = millblocks(environment(tmp_path, DATABASE_URL=url), "db", "upgrade")
    assert ended.returncode == 1
    line = one_line(ended.stderr)
    assert line.startswith(
        "Error: MILLBLOCKS_DATABASE_URL: postgresql+psycopg://millblocks:***@127.0.0.1:1/"
        "millblocks: the database does not answer:"
    )
    assert "Connection refused" in line
    restarted_on = unit()["RestartPreventExitStatus"][0].split()
    assert "1" not in restarted_on and "3" not in restarted_on
    monkeypatch.setenv("MILLBLOCKS_DATABASE_URL", url)
    monkeypatch.setenv("MILLBLOCKS_INSTANCE_PATH", str(tmp_path))
    with pytest.raises(SystemExit) as stopped:
        create_app()
    assert stopped.value.code == 3
    assert "the database does not answer" in one_line(capsys.readouterr().err)
    env = server_environment(url, tmp_path / "instance")
    started = subprocess.run(
        gunicorn(free_port()), env=env, cwd=tmp_path, capture_output=True, text=True, timeout=120
    )
    assert started.returncode == 3, started.stderr  # its master's check: no worker started
    assert started.stderr.count("MillBlocks cannot start yet: MILLBLOCKS_DATABASE_URL:") == 1
    assert "Booting worker" not in started.stderr and "Traceback" not in started.stderr


def test_a_heroku_style_postgres_url_is_taken(tmp_path: Path) -> None:
    """`postgres://…` (Heroku's form, which database_url already meant to take) opens the
    library; it was SQLAlchemy's NoSuchModuleError when given as MILLBLOCKS_DATABASE_URL."""
    admin = create_engine(postgres_admin_url(), isolation_level="AUTOCOMMIT")
    name = f"mb_{uuid.uuid4().hex[:12]}"
    with admin.connect() as conn:
        conn.execute(text(f'CREATE DATABASE "{name}"'))
    try:
        url = postgres(scheme="postgres").rsplit("/", 1)[0] + f"/{name}"
        ended = millblocks(environment(tmp_path, DATABASE_URL=url), "db", "upgrade")
        assert ended.returncode == 0, ended.stderr
        assert ended.stdout.startswith("created the database at ")
    finally:
        with admin.connect() as conn:
            conn.execute(text(f'DROP DATABASE "{name}" WITH (FORCE)'))
        admin.dispose()


# -- the minor findings ---------------------------------------------------------------------


def test_a_short_secret_key_is_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """MILLBLOCKS_SECRET_KEY=x signed every session with a guessable key."""
    monkeypatch.setenv("MILLBLOCKS_INSTANCE_PATH", str(tmp_path))
    monkeypatch.setenv("MILLBLOCKS_DATABASE_URL", f"sqlite:///{tmp_path / 'k.db'}")
    monkeypatch.setenv("MILLBLOCKS_SECRET_KEY", "x")
    said = "MILLBLOCKS_SECRET_KEY: the key has 1 characters, fewer than 32"
    result = CliRunner().invoke(main, ["list"])
    assert result.exit_code == 2
    assert said in result.stderr
    from app.web import create_app as factory

    with pytest.raises(SettingError, match=said):
        factory()
    monkeypatch.setenv("MILLBLOCKS_SECRET_KEY", "k" * 32)
    assert CliRunner().invoke(main, ["list"]).exit_code == 0


def test_a_misspelt_variable_is_named_once(tmp_path: Path) -> None:
    """`db upgrade` (the unit's first command) read the settings twice and warned twice."""
    env = environment(tmp_path, DATABASE_URL=f"sqlite:///{tmp_path / 'w.db'}", SESION_HOURS="1")
    ended = millblocks(env, "db", "upgrade")
    assert ended.returncode == 0, ended.stderr
    assert ended.stderr.count("MILLBLOCKS_SESION_HOURS is not a MillBlocks setting") == 1


def test_the_variables_of_building_and_testing_are_no_misspelling() -> None:
    """Every MILLBLOCKS_* name the test suite, the benchmarks and the build read is a
    setting or one of DEVELOPMENT (MILLBLOCKS_FUZZ_DXF_EXAMPLES was warned about)."""
    named: set[str] = set()
    for folder in ("tests", "bench", "scripts"):
        for path in (ROOT / folder).rglob("*.py"):
            named |= set(re.findall(r"MILLBLOCKS_([A-Z][A-Z_]*[A-Z])", path.read_text("utf-8")))
    for name in ("setup.py", "Makefile"):
        named |= set(re.findall(r"MILLBLOCKS_([A-Z][A-Z_]*[A-Z])", (ROOT / name).read_text()))
    named -= {"SESION_HOURS"}  # the misspelling the settings tests make on purpose
    assert named - DEVELOPMENT <= {s.key for s in SETTINGS}


def test_the_docs_table_has_what_the_readme_tells_a_user_to_set() -> None:
    from tests.test_settings import documented_settings

    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    told = set(re.findall(r"MILLBLOCKS_[A-Z][A-Z_]*[A-Z]", readme))
    assert told <= set(documented_settings())


def test_two_servers_on_one_host_have_control_sockets_of_their_own(tmp_path: Path) -> None:
    """gunicorn 25+ made `~/.gunicorn/gunicorn.ctl` for every server of a user: the
    configuration `millblocks serve` and the unit give it, as gunicorn reads it."""
    sockets = []
    for name in ("first", "second"):
        env = server_environment(f"sqlite:///{tmp_path / 'c.db'}", tmp_path / name)
        env.pop("XDG_RUNTIME_DIR")
        printed = subprocess.run(
            [*gunicorn(free_port()), "--print-config"],
            env=env,
            cwd=tmp_path,
            capture_output=True,
            text=True,
            timeout=120,
            check=True,
        )
        found = re.search(r"^control_socket\s+= (.*)$", printed.stdout, re.MULTILINE)
        assert found is not None
        sockets.append(found.group(1))
    assert sockets == [
        str(tmp_path / "first" / "gunicorn.ctl"),
        str(tmp_path / "second" / "gunicorn.ctl"),
    ]


def test_a_sqlite_file_another_process_holds_is_a_database_that_does_not_answer(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A library file another process holds locked past the busy timeout (a backup copying
    it, a long write) is busy, not a setting: DatabaseUnavailable (the command line exits
    1, gunicorn 3, the unit tries again), not "SQLite cannot open the file … its folder must
    exist and be writable", which sent the sysadmin to check the folder (exit 2, no
    restart). The busy timeout shortened to keep the test short."""
    import sqlite3

    from app.storage import db

    monkeypatch.setattr(db, "SQLITE_BUSY_SECONDS", 0.2)
    path = tmp_path / "held.db"
    holder = sqlite3.connect(path, isolation_level=None)
    holder.execute("CREATE TABLE t (x)")
    holder.execute("BEGIN EXCLUSIVE")
    try:
        with pytest.raises(db.DatabaseUnavailable) as refused:
            db.open_engine(f"sqlite:///{path}")
    finally:
        holder.execute("ROLLBACK")
        holder.close()
    said = str(refused.value)
    assert said.startswith(f"MILLBLOCKS_DATABASE_URL: sqlite:///{path}: the database is busy")
    assert "database is locked" in said and "folder" not in said
