"""Serving a shop (issue 31, docs/deploy.md), each piece tried: the systemd unit verified by
systemd's own `systemd-analyze`, the unit's commands run behind Debian's nginx with TLS (a
self-signed certificate) on free ports, the PostgreSQL steps of the docs run on a real
cluster, a login through the proxy, backups, the health check, upgrade and roll back, the
log lines and the 500 page.
"""

from __future__ import annotations

import http.cookiejar
import json
import os
import re
import shlex
import signal
import socket
import ssl
import subprocess
import sys
import time
import urllib.error
import urllib.parse
import urllib.request
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner
from sqlalchemy import create_engine, text

from app.cli import main
from app.settings import SETTINGS
from app.storage.db import head, make_engine, revisions, upgrade
from app.web import create_app
from tests.conftest import postgres_admin_url
from tests.web_support import PASSWORD, dispose, multipart

ROOT = Path(__file__).resolve().parents[1]
DEPLOY = ROOT / "deploy"
DOCS = ROOT / "docs" / "deploy.md"
PREFIX = "/opt/millblocks"
"""Where the unit and the docs install MillBlocks (a virtual environment)."""


@pytest.fixture(autouse=True)
def clean_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    for setting in SETTINGS:
        monkeypatch.delenv(setting.variable, raising=False)
    monkeypatch.delenv("DATABASE_URL", raising=False)


def cli(*args: str, input: str | None = None) -> tuple[int, str, str]:
    result = CliRunner().invoke(main, list(args), input=input)
    return result.exit_code, result.stdout, result.stderr


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
        return port


def wait_until_listening(port: int, process: subprocess.Popen[bytes], log: Path) -> None:
    """Wait for `process` to accept connections on `port` (it has up to a minute to start
    on a busy machine); fail with its log if it exits first."""
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if process.poll() is not None:
            pytest.fail(f"exited with {process.returncode}:\n{log.read_text()}")
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            return
        except OSError:
            time.sleep(0.2)
    pytest.fail(f"nothing listening on {port} after a minute:\n{log.read_text()}")


def stop(process: subprocess.Popen[bytes]) -> None:
    if process.poll() is None:
        process.send_signal(signal.SIGTERM)
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


# -- the files in the docs are the files in deploy/ -----------------------------------------


def fenced(name: str) -> str:
    """The first fenced block of docs/deploy.md after `deploy/<name>` is first named."""
    docs = DOCS.read_text(encoding="utf-8")
    found = re.search(rf"`deploy/{re.escape(name)}`.*?\n```[a-z]*\n(.*?)```", docs, re.S)
    assert found, f"docs/deploy.md shows no deploy/{name}"
    return found.group(1)


@pytest.mark.parametrize(
    "name",
    ["millblocks.service", "millblocks-dnc.service", "millblocks.env", "nginx-millblocks.conf"],
)
def test_the_docs_show_the_shipped_files(name: str) -> None:
    assert fenced(name) == (DEPLOY / name).read_text(encoding="utf-8")


# -- systemd --------------------------------------------------------------------------------


def unit() -> dict[str, list[str]]:
    """deploy/millblocks.service's [Service] lines: key -> values, in order."""
    lines: dict[str, list[str]] = {}
    section = ""
    for line in (DEPLOY / "millblocks.service").read_text().splitlines():
        if line.startswith("["):
            section = line
        elif section == "[Service]" and "=" in line and not line.startswith("#"):
            key, _, value = line.partition("=")
            lines.setdefault(key, []).append(value)
    return lines


def installed(command: str) -> list[str]:
    """A command of the unit, with this test's virtual environment for /opt/millblocks."""
    return [word.replace(PREFIX, sys.prefix, 1) for word in shlex.split(command)]


def gunicorn(port: int) -> list[str]:
    """The unit's ExecStart on `port`, with 2 workers instead of 4 (this machine's two
    cores are shared by the whole suite)."""
    (start,) = unit()["ExecStart"]
    command = " ".join(installed(start))
    for old, new in (("127.0.0.1:8000", f"127.0.0.1:{port}"), ("--workers 4", "--workers 2")):
        assert old in command, old
        command = command.replace(old, new)
    return command.split(" ")


@pytest.mark.parametrize("name", ["millblocks.service", "millblocks-dnc.service"])
def test_the_unit_files_pass_systemd_analyze_verify(tmp_path: Path, name: str) -> None:
    """systemd's own check (syntax, every setting known, the commands executable), with
    the commands where this checkout's virtual environment has them."""
    text_ = (DEPLOY / name).read_text().replace(PREFIX, sys.prefix)
    copy = tmp_path / name
    copy.write_text(text_)
    checked = subprocess.run(
        ["systemd-analyze", "verify", str(copy)], capture_output=True, text=True, check=False
    )
    assert (checked.returncode, checked.stdout, checked.stderr) == (0, "", "")
    broken = tmp_path / "broken" / name
    broken.parent.mkdir()
    broken.write_text(text_.replace("ProtectSystem=strict", "ProtectSystem=strcit"))
    checked = subprocess.run(
        ["systemd-analyze", "verify", str(broken)], capture_output=True, text=True, check=False
    )
    assert "protect system value" in checked.stderr  # the check reads what it is given


# -- PostgreSQL, gunicorn, nginx ------------------------------------------------------------


def docs_sql(role: str, password: str) -> str:
    """The role-and-database SQL of docs/deploy.md, for `role` (also the database's name)."""
    docs = DOCS.read_text(encoding="utf-8")
    found = re.search(r"```sql\n(CREATE ROLE .*?)```", docs, re.S)
    assert found, "docs/deploy.md gives no CREATE ROLE block"
    sql = found.group(1).replace("CHANGE-THIS-PASSWORD", password)
    return re.sub(r"\bmillblocks\b", role, sql)


@pytest.fixture
def shop_database() -> Iterator[str]:
    """A role and database made with the docs' SQL on the test cluster; its URL (TCP with
    a password, as deploy/millblocks.env has it)."""
    admin_url = postgres_admin_url()
    role = f"mb_{uuid.uuid4().hex[:10]}"
    password = uuid.uuid4().hex
    psql = subprocess.run(
        ["psql", "-v", "ON_ERROR_STOP=1", "-q", "-d", "postgres"],
        input=docs_sql(role, password),
        capture_output=True,
        text=True,
        check=False,
    )
    assert psql.returncode == 0, psql.stderr
    admin = create_engine(admin_url, isolation_level="AUTOCOMMIT")
    yield admin.url.set(username=role, password=password, database=role).render_as_string(
        hide_password=False
    )
    with admin.connect() as conn:
        for database in (role, f"{role}_restored"):
            conn.execute(text(f'DROP DATABASE IF EXISTS "{database}" WITH (FORCE)'))
        conn.execute(text(f'DROP ROLE IF EXISTS "{role}"'))
    admin.dispose()


def server_environment(database: str, instance: Path) -> dict[str, str]:
    """The environment the unit gives gunicorn: deploy/millblocks.env (this database, a
    key) and the unit's Environment= lines (this instance folder and runtime folder)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("MILLBLOCKS_")}
    env.pop("DATABASE_URL", None)
    for line in (DEPLOY / "millblocks.env").read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            name, _, value = line.partition("=")
            env[name] = value
    for line in unit()["Environment"]:
        name, _, value = line.partition("=")
        env[name] = value
    env["MILLBLOCKS_DATABASE_URL"] = database
    env["MILLBLOCKS_SECRET_KEY"] = uuid.uuid4().hex * 2
    env["MILLBLOCKS_INSTANCE_PATH"] = str(instance)
    runtime = instance.parent / "run"  # what the unit's RuntimeDirectory= makes
    runtime.mkdir(exist_ok=True)
    env["XDG_RUNTIME_DIR"] = str(runtime)
    env["MILLBLOCKS_NATIVE"] = "0"
    env["PYTHONPATH"] = str(ROOT)  # this checkout's app, wherever the venv was installed from
    return env


def self_signed(folder: Path) -> tuple[Path, Path]:
    certificate, key = folder / "millblocks.pem", folder / "millblocks.key"
    subprocess.run(
        [
            "openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2",
            "-subj", "/CN=localhost", "-addext", "subjectAltName=DNS:localhost,IP:127.0.0.1",
            "-keyout", str(key), "-out", str(certificate),
        ],
        check=True,
        capture_output=True,
    )  # fmt: skip
    return certificate, key


def nginx_conf(folder: Path, http_port: int, https_port: int, upstream: int) -> Path:
    """deploy/nginx-millblocks.conf on this machine's free ports and certificate, inside
    the few lines of nginx.conf a Debian install has around its sites."""
    certificate, key = self_signed(folder)
    site = (DEPLOY / "nginx-millblocks.conf").read_text()
    for old, new in (
        ("listen [::]:80;", ""),
        ("listen [::]:443 ssl;", ""),
        ("listen 80;", f"listen 127.0.0.1:{http_port};"),
        ("listen 443 ssl;", f"listen 127.0.0.1:{https_port} ssl;"),
        ("server 127.0.0.1:8000;", f"server 127.0.0.1:{upstream};"),
        ("/etc/ssl/certs/millblocks.pem", str(certificate)),
        ("/etc/ssl/private/millblocks.key", str(key)),
    ):
        assert old in site, old
        site = site.replace(old, new)
    (folder / "millblocks.conf").write_text(site)
    for temporary in ("body", "proxy", "fastcgi", "uwsgi", "scgi"):
        (folder / temporary).mkdir()
    main_conf = folder / "nginx.conf"
    main_conf.write_text(
        f"""daemon off;
worker_processes 1;
pid {folder}/nginx.pid;
error_log {folder}/error.log info;
{"user root;" if os.geteuid() == 0 else ""}
events {{ worker_connections 64; }}
http {{
    access_log {folder}/access.log;
    client_body_temp_path {folder}/body;
    proxy_temp_path {folder}/proxy;
    fastcgi_temp_path {folder}/fastcgi;
    uwsgi_temp_path {folder}/uwsgi;
    scgi_temp_path {folder}/scgi;
    include /etc/nginx/mime.types;
    include {folder}/millblocks.conf;
}}
"""
    )
    return main_conf


class Browser:
    """A browser over HTTPS that trusts the test certificate and keeps cookies."""

    def __init__(self, base: str, certificate: Path) -> None:
        self.base = base
        self.cookies = http.cookiejar.CookieJar()
        context = ssl.create_default_context(cafile=str(certificate))
        self.opener = urllib.request.build_opener(
            urllib.request.HTTPCookieProcessor(self.cookies),
            urllib.request.HTTPSHandler(context=context),
        )

    def open(
        self, path: str, data: bytes | None = None, headers: dict[str, str] | None = None
    ) -> tuple[int, str]:
        # A browser names the page a form was sent from (the app's Referrer-Policy is
        # same-origin), and Flask-WTF checks it over HTTPS.
        sent = {"Referer": f"{self.base}/", **(headers or {})}
        request = urllib.request.Request(self.base + path, data=data, headers=sent)
        try:
            with self.opener.open(request, timeout=60) as response:
                return response.status, response.read().decode()
        except urllib.error.HTTPError as error:
            with error:
                return error.code, error.read().decode()

    def token(self, path: str) -> str:
        found = re.search(r'name="csrf_token" value="([^"]+)"', self.open(path)[1])
        assert found, path
        return found.group(1)

    def post(self, path: str, fields: dict[str, str]) -> tuple[int, str]:
        return self.open(path, urllib.parse.urlencode(fields).encode())

    def upload(self, path: str, name: str, data: bytes) -> tuple[int, str]:
        body, content_type = multipart(self.token("/"), name, data)
        return self.open(path, body, {"Content-Type": content_type})


def test_a_shop_server_behind_nginx_with_tls(tmp_path: Path, shop_database: str) -> None:
    """The docs' whole set-up on this machine: the PostgreSQL role and database, the unit's
    `db upgrade` and gunicorn with deploy/millblocks.env, Debian's nginx with
    deploy/nginx-millblocks.conf and a self-signed certificate; then a login through it,
    an upload, the health check, nginx's upload limit, the request lines, and the backups
    the docs advise (pg_dump holds the users, `millblocks backup` the programs)."""
    env = server_environment(shop_database, tmp_path / "instance")
    service = unit()
    (before,) = service["ExecStartPre"]
    upgraded = subprocess.run(
        installed(before), env=env, capture_output=True, text=True, check=False
    )
    assert upgraded.returncode == 0, upgraded.stderr
    assert upgraded.stdout.startswith(f"created the database at {head()} (postgresql")
    assert shop_database.split("@")[0].split(":")[-1] not in upgraded.stdout  # no password
    millblocks = installed(before)[0]
    added = subprocess.run(
        [millblocks, "user", "add", "ana", "--role", "admin", "--password", PASSWORD],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    assert added.returncode == 0, added.stderr

    upstream, http_port, https_port = free_port(), free_port(), free_port()
    command = gunicorn(upstream)
    gunicorn_log = tmp_path / "gunicorn.log"
    nginx_dir = tmp_path / "nginx"
    nginx_dir.mkdir()
    conf = nginx_conf(nginx_dir, http_port, https_port, upstream)
    with gunicorn_log.open("wb") as log:
        server = subprocess.Popen(command, env=env, cwd=tmp_path, stdout=log, stderr=log)
    try:
        wait_until_listening(upstream, server, gunicorn_log)
        nginx = subprocess.Popen(
            ["nginx", "-c", str(conf), "-p", str(nginx_dir), "-e", str(nginx_dir / "error.log")],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,  # -e: its errors go to error.log
        )
        try:
            wait_until_listening(https_port, nginx, nginx_dir / "error.log")
            through_nginx(http_port, https_port, nginx_dir / "millblocks.pem")
        finally:
            stop(nginx)
    finally:
        stop(server)
    lines = gunicorn_log.read_text()
    assert "Traceback" not in lines
    # The unit gives gunicorn the app's settings: threaded workers, not the sync default.
    assert "Using worker: gthread" in lines
    assert re.search(r"INFO millblocks\.request: GET / 200 \d+ ms 127\.0\.0\.1 ana\n", lines)
    assert re.search(r"INFO millblocks\.request: GET /healthz 200 \d+ ms 127\.0\.0\.1 -\n", lines)
    backups(tmp_path, env, millblocks, shop_database)


def through_nginx(http_port: int, https_port: int, certificate: Path) -> None:
    plain = urllib.request.build_opener(NoRedirect)
    with pytest.raises(urllib.error.HTTPError) as moved:
        plain.open(f"http://127.0.0.1:{http_port}/login", timeout=60)
    with moved.value as refused:
        assert refused.code == 301
        assert refused.headers["Location"] == "https://127.0.0.1/login"

    browser = Browser(f"https://localhost:{https_port}", certificate)
    status, body = browser.open("/healthz")
    assert (status, json.loads(body)) == (200, {"status": "ok"})
    status, page = browser.open("/")
    assert status == 200 and "Log in" in page  # redirected to the login page
    status, page = browser.post(
        "/login", {"csrf_token": browser.token("/login"), "username": "ana", "password": PASSWORD}
    )
    assert status == 200 and "ana (admin)" in page, page
    (cookie,) = list(browser.cookies)
    assert cookie.name == "__Host-millblocks" and cookie.secure
    status, page = browser.upload(
        "/programs/import", "plate.ngc", b"G20 G90\nG0 X1 Y1\nG1 Z-0.1 F5\nM2\n"
    )
    assert status == 201, page
    status, page = browser.upload("/programs/import", "huge.ngc", b"(" + b"x" * 2_200_000 + b")")
    assert status == 413 and "nginx" in page  # refused by nginx, before gunicorn


class NoRedirect(urllib.request.HTTPRedirectHandler):
    def redirect_request(self, *args: object, **kwargs: object) -> None:
        return None


def backups(tmp_path: Path, env: dict[str, str], millblocks: str, database: str) -> None:
    """docs/deploy.md's backups: pg_dump of the database restores the users (and the
    programs); `millblocks backup` holds the programs and machines, no users."""
    dump = tmp_path / "millblocks.dump"
    url = make_engine(database).url
    pg_env = {**env, "PGPASSWORD": url.password or "", "PGUSER": url.username or ""}
    subprocess.run(
        ["pg_dump", "--format=custom", f"--file={dump}", url.database or ""],
        env=pg_env,
        check=True,
    )
    restored = f"{url.database}_restored"
    subprocess.run(["createdb", "--owner", url.username or "", restored], check=True)
    subprocess.run(
        ["pg_restore", "--no-owner", f"--dbname={restored}", str(dump)], env=pg_env, check=True
    )
    restored_env = {**env, "MILLBLOCKS_DATABASE_URL": database.rsplit("/", 1)[0] + "/" + restored}
    users = subprocess.run(
        [millblocks, "user", "list"], env=restored_env, capture_output=True, text=True, check=True
    )
    assert users.stdout.split() == ["ana", "admin"]
    archive = tmp_path / "programs.zip"
    subprocess.run([millblocks, "backup", str(archive)], env=env, check=True, capture_output=True)
    elsewhere = {**env, "MILLBLOCKS_DATABASE_URL": f"sqlite:///{tmp_path / 'elsewhere.db'}"}
    for command in (["restore", str(archive)], ["user", "list"]):
        done = subprocess.run(
            [millblocks, *command], env=elsewhere, capture_output=True, text=True, check=True
        )
    assert done.stdout == ""  # no accounts came with the programs
    listed = subprocess.run(
        [millblocks, "list"], env=elsewhere, capture_output=True, text=True, check=True
    )
    assert "plate" in listed.stdout  # the upload (demo programs are off)


# -- the health check -----------------------------------------------------------------------


def test_health_says_whether_the_database_answers() -> None:
    """GET /healthz: 200 while PostgreSQL answers, 503 once the database is gone (and 200
    again when it is back), with no login, in accounts mode, and nothing but the status."""
    admin = create_engine(postgres_admin_url(), isolation_level="AUTOCOMMIT")
    name = f"mb_{uuid.uuid4().hex[:12]}"
    with admin.connect() as conn:
        conn.execute(text(f'CREATE DATABASE "{name}"'))
    url = admin.url.set(database=name).render_as_string(hide_password=False)
    app = create_app({"DATABASE_URL": url, "SECRET_KEY": "t" * 32, "AUTH": "accounts"})
    client = app.test_client()
    answer = client.get("/healthz", environ_base={"REMOTE_ADDR": "10.0.0.9"})
    assert (answer.status_code, answer.get_json()) == (200, {"status": "ok"})
    assert answer.headers["Cache-Control"] == "no-store"
    assert "Set-Cookie" not in answer.headers
    with admin.connect() as conn:
        conn.execute(text(f'DROP DATABASE "{name}" WITH (FORCE)'))
    answer = client.get("/healthz")
    assert (answer.status_code, answer.get_json()) == (503, {"status": "unavailable"})
    with admin.connect() as conn:
        conn.execute(text(f'CREATE DATABASE "{name}"'))
    assert client.get("/healthz").status_code == 200
    dispose(app)
    with admin.connect() as conn:
        conn.execute(text(f'DROP DATABASE "{name}" WITH (FORCE)'))
    admin.dispose()


# -- upgrade and roll back ------------------------------------------------------------------


def test_db_upgrade_says_what_it_did(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """created / upgraded from X to Y / already at Y (a new database was "up to date")."""
    database = f"sqlite:///{tmp_path / 'u.db'}"
    monkeypatch.setenv("MILLBLOCKS_DATABASE_URL", database)
    newest, older = head(), revisions()[-3]
    assert cli("db", "upgrade")[1] == f"created the database at {newest} ({database})\n"
    assert cli("db", "upgrade")[1] == f"already at {newest} ({database})\n"
    assert cli("db", "downgrade", older, "--yes")[1] == f"downgraded from {newest} to {older}\n"
    assert cli("db", "upgrade")[1] == f"upgraded from {older} to {newest} ({database})\n"


def test_db_commands_take_a_percent_encoded_url(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A % in the database URL (a percent-encoded password, s3cr%40t, or a folder's @ as
    %40) reaches Alembic as itself: every `db` command stopped with a traceback ("invalid
    interpolation syntax", Alembic's ConfigParser reading % as interpolation)."""
    folder = tmp_path / "shop@floor"
    folder.mkdir()
    database = f"sqlite:///{tmp_path / 'shop%40floor' / 'p.db'}"
    monkeypatch.setenv("MILLBLOCKS_DATABASE_URL", database)
    newest, previous = head(), revisions()[-2]
    assert cli("db", "upgrade") == (0, f"created the database at {newest} ({database})\n", "")
    assert (folder / "p.db").exists()
    assert cli("db", "downgrade", "--yes")[:2] == (0, f"downgraded from {newest} to {previous}\n")
    assert cli("db", "upgrade")[:2] == (0, f"upgraded from {previous} to {newest} ({database})\n")


def test_db_current_and_downgrade(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    database = f"sqlite:///{tmp_path / 'c.db'}"
    monkeypatch.setenv("MILLBLOCKS_DATABASE_URL", database)
    newest, previous = head(), revisions()[-2]
    code, out, _ = cli("db", "current")
    assert (code, out) == (0, f"empty: no schema yet ({database}); "
                           f"`millblocks db upgrade` creates it at {newest}\n")  # fmt: skip
    cli("db", "upgrade")
    assert (
        cli("db", "current")[1] == f"at {newest}, the newest this MillBlocks knows ({database})\n"
    )
    # Without --yes it asks, naming what is undone; "n" changes nothing.
    code, _, err = cli("db", "downgrade", input="n\n")
    assert code == 1
    assert f"undo {newest}: " in err and "Go on?" in err
    assert cli("db", "current")[1].startswith(f"at {newest},")
    assert cli("db", "downgrade", input="y\n")[1] == f"downgraded from {newest} to {previous}\n"
    code, out, _ = cli("db", "current")
    assert out == (
        f"at {previous}; this MillBlocks knows up to {newest}: "
        f"`millblocks db upgrade` brings it up ({database})\n"
    )
    code, _, err = cli("db", "downgrade", "0042", "--yes")
    assert code == 2
    assert "no schema revision '0042'; this MillBlocks knows 0001" in err
    assert (
        cli("db", "downgrade", "base", "--yes")[1]
        == f"downgraded from {previous} to base (empty)\n"
    )


def newer_than_the_code(database: str) -> str:
    """Make the database look migrated by a newer MillBlocks; the revision it has."""
    engine = make_engine(database)
    upgrade(engine)
    with engine.begin() as conn:
        conn.execute(text("UPDATE alembic_version SET version_num = '0999'"))
    engine.dispose()
    return "0999"


def test_a_database_newer_than_the_code_is_said_plainly(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Rolled back code on a database a newer MillBlocks upgraded: `db upgrade`, `db
    current` and any command say what happened and what to do (Alembic's traceback
    "Can't locate revision identified by '0999'" was all it said)."""
    database = f"sqlite:///{tmp_path / 'n.db'}"
    monkeypatch.setenv("MILLBLOCKS_DATABASE_URL", database)
    newer_than_the_code(database)
    said = (
        f"the database's schema is at revision 0999, newer than this MillBlocks (it knows up "
        f"to {head()}): a newer MillBlocks upgraded it."
    )
    for command in (["db", "upgrade"], ["list"], ["db", "downgrade", "--yes"]):
        code, out, err = cli(*command)
        assert code == 2, command
        assert said in err and "db downgrade" in err, command
        assert "Traceback" not in out + err
    code, out, _ = cli("db", "current")
    assert (code, out) == (
        1,
        f"at 0999, newer than this MillBlocks (it knows up to {head()}) ({database})\n",
    )


def test_the_server_does_not_start_on_a_newer_database(tmp_path: Path) -> None:
    """The unit's start on such a database: its `db upgrade` stops it with the message and
    exit 2, which the unit does not restart on. gunicorn started by hand: its master says
    it in one line before any worker starts, no traceback of the app's, and gunicorn exits
    4 (the app failed to load), which the unit does not restart on either."""
    database = f"sqlite:///{tmp_path / 'n.db'}"
    newer_than_the_code(database)
    env = server_environment(database, tmp_path / "instance")
    service = unit()
    (before,) = service["ExecStartPre"]
    said = "the database's schema is at revision 0999, newer than this MillBlocks"
    ended = subprocess.run(
        installed(before), env=env, capture_output=True, text=True, timeout=120, check=False
    )
    assert ended.returncode == 2
    assert said in ended.stderr and "Traceback" not in ended.stderr
    assert "2" in service["RestartPreventExitStatus"][0].split()
    command = gunicorn(free_port())
    ended = subprocess.run(
        command, env=env, cwd=tmp_path, capture_output=True, text=True, timeout=120, check=False
    )
    assert ended.returncode == 4
    assert "4" in service["RestartPreventExitStatus"][0].split()
    assert ended.stderr.count(f"MillBlocks cannot start: {said}") == 1
    assert "Booting worker" not in ended.stderr and "Traceback" not in ended.stderr


# -- the 500 page and the log ---------------------------------------------------------------


def test_an_unexpected_error_shows_a_page_with_a_reference_the_log_has(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    """A request that fails inside (here the library's table is gone from the database):
    the 500 page in the app's style with a way back and a reference; the log has the same
    reference with the traceback (Werkzeug's bare page said nothing, logged nothing to
    quote)."""
    database = tmp_path / "broken.db"
    app = create_app({"DATABASE_URL": f"sqlite:///{database}", "SECRET_KEY": "t" * 32})
    engine = make_engine(f"sqlite:///{database}")
    with engine.begin() as conn:
        conn.execute(text("DROP TABLE revisions"))
        conn.execute(text("DROP TABLE programs"))
    engine.dispose()
    capfd.readouterr()
    answer = app.test_client().get("/")
    page = answer.get_data(as_text=True)
    assert answer.status_code == 500
    assert '<link rel="stylesheet" href="/static/app.css">' in page
    assert "Something went wrong" in page and 'href="/">Back to the library</a>' in page
    found = re.search(r'Reference <strong class="reference">([0-9A-F]{8})</strong>', page)
    assert found, page
    reference = found.group(1)
    err = capfd.readouterr().err
    assert re.search(rf"ERROR millblocks: error {reference} on GET /\nTraceback", err), err
    assert "no such table: programs" in err
    assert re.search(
        rf"ERROR millblocks\.request: GET / 500 \d+ ms 127\.0\.0\.1 local error {reference}\n", err
    )
    dispose(app)


def test_log_lines_carry_the_journals_priority_under_systemd(tmp_path: Path) -> None:
    """With stderr the journal (systemd's JOURNAL_STREAM names it), each line starts with
    its syslog priority (<6> info, <3> error), which journald keeps as the entry's level."""
    stderr = tmp_path / "journal"
    config = {"DATABASE_URL": f"sqlite:///{tmp_path / 'j.db'}", "SECRET_KEY": "t" * 32}
    script = (
        "from app.web import create_app\n"
        f"app = create_app({config!r})\n"
        "client = app.test_client()\n"
        "client.get('/healthz')\n"
        "client.get('/no-such-page')\n"
    )
    with stderr.open("wb") as out:
        status = os.fstat(out.fileno())
        env = {
            **os.environ,
            "JOURNAL_STREAM": f"{status.st_dev}:{status.st_ino}",
            "PYTHONPATH": str(ROOT),
        }
        subprocess.run(
            [sys.executable, "-c", script], env=env, stderr=out, check=True, cwd=tmp_path
        )
    written = stderr.read_text()
    assert re.search(
        r"^<6>INFO millblocks\.request: GET /healthz 200 \d+ ms 127\.0\.0\.1 -$", written, re.M
    )
    assert "\n<6>INFO millblocks.request: GET /no-such-page 404 " in written
