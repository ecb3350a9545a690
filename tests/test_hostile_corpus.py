"""The hostile-input corpus (tests/hostile_corpus.py) against the real app and CLI: each
case gets its expected status and message, and nothing answers 500 or a traceback."""

from __future__ import annotations

import html
import io
import json
import re
import uuid
import zipfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from flask import Flask
from flask.testing import FlaskClient

from app.cli import main
from app.cnc.numbers import quoted
from app.storage.backup import BackupError
from app.storage.library import open_library
from app.web.extensions import get_library
from tests.conftest import postgres_admin_url
from tests.hostile_corpus import FEW_NUMBERS, SURFACES, TEXT_ENTRIES, UPLOADS, Case, cases
from tests.test_backup_restore import DAMAGE, bomb, good_backup, rezip
from tests.web_support import accounts_app, csrf, dispose, local_app, log_in

GOLDEN = Path(__file__).parent / "golden"
DOCUMENT = GOLDEN / "drill-single" / "program.json"


@pytest.fixture(scope="module")
def app(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Flask]:
    app = local_app(tmp_path_factory.mktemp("hostile"))
    yield app
    dispose(app)


@pytest.fixture(scope="module")
def client(app: Flask) -> FlaskClient:
    return app.test_client()


@pytest.fixture(scope="module")
def token(client: FlaskClient) -> str:
    return csrf(client)


def text_of(response: Any) -> str:
    return html.unescape(response.get_data(as_text=True))


def ids(surface: str) -> list[Any]:
    return [pytest.param(case, id=case.id) for case in cases(surface)]


def test_the_corpus_has_at_least_500_cases() -> None:
    total = sum(len(cases(surface)) for surface in SURFACES) + len(BACKUPS)
    assert total >= 500, total


BLOCK_VALUES = {
    "x": "1",
    "y": "1",
    "z_up": "0.1",
    "z_dn": "-0.5",
    "feed_z": "5",
    "feed_xy": "5",
    "pecks": "1",
    "tool": "1",
    "holes": "4",
    "angle": "0",
    "radius": "1",
    "end_x": "2",
    "end_y": "1",
    "xl": "1",
    "yw": "1",
    "corner_radius": "0",
    "nx": "1",
    "ny": "1",
    "from_block": "1",
    "to_block": "2",
    "placement": "inside",
}


@pytest.mark.parametrize("case", ids("block"))
def test_block_form(client: FlaskClient, token: str, app: Flask, case: Case) -> None:
    data = {**BLOCK_VALUES, "csrf_token": token, "version": "1", "at": "4", "units": "inch"}
    data.update(kind=case.data["kind"], **{case.data["field"]: case.data["value"]})
    response = client.post("/programs/2/blocks", data=data)
    assert response.status_code in case.status
    assert case.message in text_of(response)
    with app.app_context():
        assert get_library().get(2).info.version == 1


@pytest.mark.parametrize("case", ids("db0"))
def test_data_block_0_form(client: FlaskClient, token: str, app: Flask, case: Case) -> None:
    data = {
        "csrf_token": token,
        "version": "1",
        "x_offset": "0",
        "y_offset": "0",
        "current_tool": "1",
        "z_retract": "0.1",
        "dia_1": "0.25",
        "rpm_1": "1500",
        "tcal_1": "0",
        case.data["field"]: case.data["value"],
    }
    response = client.post("/programs/2/db0", data=data)
    assert response.status_code in case.status
    assert case.message in text_of(response)
    with app.app_context():
        assert get_library().get(2).info.version == 1


@pytest.mark.parametrize("case", ids("query"))
def test_query_arguments(client: FlaskClient, case: Case) -> None:
    response = client.get(case.data["url"])
    assert response.status_code in case.status, response.status_code


def hostile_document(path: str, value: str) -> bytes:
    """The golden document with the JSON text `value` at `path` (dots between keys)."""
    data = json.loads(DOCUMENT.read_text())
    *parents, last = path.split(".")
    target: Any = data
    for key in parents:
        target = target[int(key)] if isinstance(target, list) else target[key]
    marker = "@@HOSTILE@@"
    if isinstance(target, list):
        target[int(last)] = marker
    else:
        target[last] = marker
    return json.dumps(data).replace(f'"{marker}"', value).encode()


@pytest.mark.parametrize("case", ids("document"))
def test_json_document_upload(client: FlaskClient, token: str, app: Flask, case: Case) -> None:
    with app.app_context():
        before = len(get_library().programs())
    document = hostile_document(case.data["path"], case.data["value"])
    response = client.post(
        "/programs/import", data={"csrf_token": token, "file": (io.BytesIO(document), "doc.json")}
    )
    assert response.status_code in case.status
    page = text_of(response)
    assert "Not imported: doc.json: " in page and case.message in page
    with app.app_context():
        assert len(get_library().programs()) == before


@pytest.mark.parametrize("case", ids("upload"))
def test_upload(client: FlaskClient, token: str, app: Flask, case: Case) -> None:
    with app.app_context():
        before = len(get_library().programs())
    response = client.post(
        "/programs/import",
        data={"csrf_token": token, "file": (io.BytesIO(case.data["bytes"]), case.data["name"])},
    )
    assert response.status_code in case.status
    page = text_of(response)
    assert case.message in page
    if response.status_code == 422:
        assert f"Not imported: {case.data['name']}: " in page
        with app.app_context():
            assert len(get_library().programs()) == before


@pytest.mark.parametrize("case", ids("cli"))
def test_command_line(case: Case, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'cli.db'}")
    files = {name: data for name, data, _ in UPLOADS} | {"golden": DOCUMENT.read_bytes()}
    argv = []
    for arg in case.data["argv"]:
        if arg.startswith("@"):
            name = arg[1:]
            path = tmp_path / (name if "." in name else f"{name}.json")
            path.write_bytes(files[name])
            arg = str(path)
        argv.append(arg)
    result = CliRunner().invoke(main, argv)
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(
        result.exception
    )
    assert result.exit_code in case.status, result.output
    assert "Traceback" not in result.output
    assert case.message in result.stderr


def backups() -> dict[str, bytes]:
    good = good_backup()
    found = {name: rezip(good, change) for name, (change, _part) in DAMAGE.items()}
    found |= {
        "not a zip": b"PK\x03\x04 not a zip",
        "empty file": b"",
        "a zip without a manifest": _zip({"other.json": b"{}"}),
        "a manifest that is not JSON": _zip({"manifest.json": b"{not json"}),
        "a manifest that is a list": _zip({"manifest.json": b"[]"}),
        "a manifest nested 100 000 deep": _zip({"manifest.json": b"[" * 100_000}),
        "a manifest of another format": _zip({"manifest.json": b'{"format": "x"}'}),
        "a manifest of 20 MB": bomb(20 << 20),
        "a manifest that is latin-1": _zip({"manifest.json": b'{"format": "caf\xe9"}'}),
    }
    return found


def _zip(members: dict[str, bytes]) -> bytes:
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    return out.getvalue()


BACKUPS = [
    *DAMAGE,
    "not a zip",
    "empty file",
    "a zip without a manifest",
    "a manifest that is not JSON",
    "a manifest that is a list",
    "a manifest nested 100 000 deep",
    "a manifest of another format",
    "a manifest of 20 MB",
    "a manifest that is latin-1",
]


@pytest.fixture(scope="module")
def archives() -> dict[str, bytes]:
    return backups()


@pytest.mark.parametrize("name", BACKUPS)
def test_backup_restore_from_the_command_line(
    name: str, archives: dict[str, bytes], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'restore.db'}")
    archive = tmp_path / "backup.zip"
    archive.write_bytes(archives[name])
    result = CliRunner().invoke(main, ["restore", str(archive)])
    assert result.exit_code == 2, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit)
    assert f"{archive}: " in result.stderr


@pytest.fixture(scope="module")
def accounts(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Flask]:
    app = accounts_app(tmp_path_factory.mktemp("logins"))
    yield app
    dispose(app)


@pytest.mark.parametrize("case", ids("login"))
def test_login_form(accounts: Flask, case: Case) -> None:
    client = accounts.test_client()
    data = {"csrf_token": csrf(client, "/login"), **case.data["form"]}
    response = client.post(
        "/login", data=data, environ_base={"REMOTE_ADDR": f"198.51.100.{hash(case.id) % 200}"}
    )
    assert response.status_code in case.status


# -- the one text rule on both databases ------------------------------------------------------


@pytest.fixture(scope="module", params=["sqlite", "postgresql"])
def shop(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[Flask]:
    """An accounts-mode app (ana, otto, ada) with the demo programs, on each database."""
    folder = tmp_path_factory.mktemp("text")
    if request.param == "sqlite":
        app = accounts_app(folder)
        yield app
        dispose(app)
        return
    from sqlalchemy import create_engine, text

    admin = create_engine(postgres_admin_url(), isolation_level="AUTOCOMMIT")
    name = f"mb_text_{uuid.uuid4().hex[:12]}"
    with admin.connect() as conn:
        conn.execute(text(f'CREATE DATABASE "{name}"'))
    url = admin.url.set(database=name).render_as_string(hide_password=False)
    app = accounts_app(folder, DATABASE_URL=url)
    yield app
    dispose(app)
    with admin.connect() as conn:
        conn.execute(text(f'DROP DATABASE "{name}" WITH (FORCE)'))
    admin.dispose()


@pytest.mark.parametrize(
    ("method", "url", "form", "field"),
    [pytest.param(*entry, id=f"{entry[0]} {entry[1]} {entry[3]}") for entry in TEXT_ENTRIES],
)
def test_a_nul_is_refused_at_every_entry_naming_the_field(
    shop: Flask, method: str, url: str, form: dict[str, str], field: str
) -> None:
    client = shop.test_client()
    if url != "/login":
        assert log_in(client, "ada").status_code == 302
    with shop.app_context():
        before = [(p.id, p.version, p.name) for p in get_library().programs()]
    if method == "GET":
        response = client.get(url)
    else:
        response = client.post(url, data={"csrf_token": csrf(client, "/login"), **form})
    assert response.status_code == 422, response.status_code
    assert f"{field}: has a NUL character (U+0000)" in text_of(response)
    with shop.app_context():
        assert [(p.id, p.version, p.name) for p in get_library().programs()] == before


def surrogate_document(name: str, notes: str = "") -> bytes:
    data = json.loads(DOCUMENT.read_text())
    data["name"], data["notes"] = name, notes
    return json.dumps(data).encode()  # ensure_ascii: the surrogate as its `\\ud800` escape


@pytest.mark.parametrize(
    ("name", "notes", "message"),
    [
        ("a\ud800", "", "program, name: has a lone surrogate (U+D800) at character 2"),
        ("part", "\udfff", "program, notes: has a lone surrogate (U+DFFF)"),
        ("x" * 201, "", "program, name: 201 characters is too long; allowed: at most 200"),
    ],
)
def test_a_document_with_a_lone_surrogate_or_a_long_name_is_refused_on_either_database(
    shop: Flask, name: str, notes: str, message: str
) -> None:
    client = shop.test_client()
    log_in(client, "ana")
    with shop.app_context():
        before = len(get_library().programs())
    document = surrogate_document(name, notes)
    response = client.post(
        "/programs/import",
        data={"csrf_token": csrf(client), "file": (io.BytesIO(document), "doc.json")},
    )
    assert response.status_code == 422
    assert f"Not imported: doc.json: {message}" in text_of(response)
    with shop.app_context():
        assert len(get_library().programs()) == before


def test_a_name_past_the_limit_is_refused_and_the_library_page_stays_small(shop: Flask) -> None:
    """A 1.9 MB program name was stored: the library page grew from 51 kB to 1.95 MB."""
    client = shop.test_client()
    log_in(client, "ana")
    page = len(client.get("/").get_data())
    token = csrf(client)
    response = client.post("/programs", data={"csrf_token": token, "name": "x" * 1_900_000})
    assert response.status_code == 422
    assert "program name: 1,900,000 characters is too long; allowed: at most 200" in text_of(
        response
    )
    assert len(client.get("/").get_data()) == page
    with shop.app_context():
        library = get_library()
        stored = library.get(1)
        notes = {"csrf_token": token, "name": stored.info.name, "notes": "n" * 4001}
        response = client.post(
            "/programs/1/header", data={**notes, "version": str(stored.info.version)}
        )
        assert response.status_code == 422
        assert "notes: 4,001 characters is too long; allowed: at most 4,000" in text_of(response)
        assert library.get(1).info.version == stored.info.version


def test_the_longest_name_can_be_duplicated_and_mirrored(shop: Flask) -> None:
    client = shop.test_client()
    log_in(client, "ana")
    token = csrf(client)
    longest = "N" * 200
    response = client.post("/programs", data={"csrf_token": token, "name": longest})
    assert response.status_code == 302
    program_id = int(response.headers["Location"].split("/")[2])
    for action, suffix in (("duplicate", " (copy)"), ("mirror", " (mirror X)")):
        response = client.post(f"/programs/{program_id}/{action}", data={"csrf_token": token})
        assert response.status_code == 302, action
        copy_id = int(response.headers["Location"].split("/")[2])
        with shop.app_context():
            name = get_library().get(copy_id).info.name
        assert len(name) == 200 and name.endswith(suffix)


def _document_name(name: str) -> Callable[[dict[str, Any], dict[str, bytes]], None]:
    def change(manifest: dict[str, Any], members: dict[str, bytes]) -> None:
        file = manifest["programs"][1]["revisions"][0]["file"]
        data = json.loads(members[file])
        data["name"] = name
        members[file] = json.dumps(data).encode()  # the surrogate as its escape

    return change


def _manifest(*path: Any, value: Any) -> Callable[[dict[str, Any], dict[str, bytes]], None]:
    def change(manifest: dict[str, Any], _members: dict[str, bytes]) -> None:
        target: Any = manifest
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] = value

    return change


TEXT_DAMAGE = {
    "a program named with a lone surrogate": (
        _document_name("a\ud800"),
        "revision 1 (programs/2/1.json): program, name: has a lone surrogate (U+D800)",
    ),
    "a program name of 1.9 MB": (
        _document_name("x" * 1_900_000),
        "program, name: 1,900,000 characters is too long; allowed: at most 200",
    ),
    "an author with a lone surrogate": (
        _manifest("programs", 0, "revisions", 0, "author", value="\udcff"),
        "revision 1, author: has a lone surrogate (U+DCFF)",
    ),
    "a revision summary with a NUL": (
        _manifest("programs", 0, "revisions", 0, "summary", value="a\x00"),
        "revision 1, summary: has a NUL character (U+0000)",
    ),
    "a machine named with a NUL": (
        _manifest("machines", 0, "name", value="Bridge\x00port"),
        "machine 1, name: has a NUL character (U+0000)",
    ),
    "machine notes with a lone surrogate": (
        _manifest("machines", 0, "notes", value="\ud800"),
        "machine 1, notes: has a lone surrogate",
    ),
    # The audit of issue 31: these three restored ("23 programs restored"), the machines page
    # grew to 110 kB, and only a send refused them.
    "a serial port with a NUL": (
        _manifest("machines", 0, "serial", "port", value="/dev/tty\x00"),
        "machine 1 (Bridgeport), serial, port: has a NUL character (U+0000) at character 9",
    ),
    "a serial end that is a NUL": (
        _manifest("machines", 0, "serial", "end", value="\x00"),
        "machine 1 (Bridgeport), serial, end: has a NUL character (U+0000)",
    ),
    "a serial port of 100 000 characters": (
        _manifest("machines", 0, "serial", "port", value="/dev/" + "x" * 100_000),
        "machine 1 (Bridgeport), serial, port: 100,005 characters is too long; allowed: at "
        "most 500",
    ),
    "a serial setting named with a lone surrogate": (
        _manifest("machines", 0, "serial", "\udc80", value="1"),
        "machine 1 (Bridgeport), serial, a setting's name: has a lone surrogate (U+DC80)",
    ),
    "a machine option with a NUL": (
        _manifest("machines", 0, "options", "sequence-start", value="1\x00"),
        "machine 1 (Bridgeport), options, sequence-start: has a NUL character (U+0000)",
    ),
    "a travel limit with a lone surrogate": (
        _manifest("machines", 0, "limits", value={"x": ["0", "\ud800"]}),
        "machine 1 (Bridgeport), limits, x [2]: has a lone surrogate (U+D800)",
    ),
    "a target of 100 000 characters": (
        _manifest("machines", 0, "target", value="t" * 100_000),
        "machine 1 (Bridgeport), target: 100,000 characters is too long",
    ),
}


@pytest.mark.parametrize("name", TEXT_DAMAGE)
def test_restore_refuses_text_the_library_cannot_store(
    name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`millblocks restore` crashed on a lone surrogate; now exit 2 naming the field."""
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'restore.db'}")
    change, part = TEXT_DAMAGE[name]
    archive = tmp_path / "backup.zip"
    archive.write_bytes(rezip(good_backup(), change))
    before = CliRunner().invoke(main, ["list"]).stdout
    result = CliRunner().invoke(main, ["restore", str(archive)])
    assert result.exception is None or isinstance(result.exception, SystemExit)
    assert result.exit_code == 2, result.output
    assert f"{archive}: " in result.stderr and part in result.stderr
    assert "Traceback" not in result.output
    assert CliRunner().invoke(main, ["list"]).stdout == before


@pytest.mark.parametrize("name", TEXT_DAMAGE)
def test_restore_of_such_text_changes_nothing_on_either_database(
    name: str, database_url: str
) -> None:
    """On PostgreSQL a NUL was the driver's error mid-restore; now the archive is refused
    before anything is stored."""
    change, part = TEXT_DAMAGE[name]
    library = open_library(database_url, seed_demo=False)
    try:
        with pytest.raises(BackupError, match=re.escape(part)):
            library.restore_backup(io.BytesIO(rezip(good_backup(), change)))
        assert library.programs() == [] and library.machines() == []
    finally:
        library.engine.dispose()


STOCK = {"x": "0", "y": "0", "z": "0", "xl": "4", "yw": "3", "zh": "1", "clear": "0"}


@pytest.mark.parametrize("value", [*FEW_NUMBERS, "1e-999999999", "-1E+999999999", "٣"])
@pytest.mark.parametrize("name", ["x", "xl", "clear"])
def test_the_stock_form_reads_numbers_with_the_one_reader(
    client: FlaskClient, token: str, app: Flask, name: str, value: str
) -> None:
    label = {"x": "X", "xl": "XL", "clear": "CLEAR"}[name]
    with app.app_context():
        version = get_library().get(2).info.version
    data = {**STOCK, name: value, "csrf_token": token, "version": str(version)}
    response = client.post("/programs/2/verify/stock", data=data)
    assert response.status_code == 422
    assert f"{label}: {quoted(value)} " in text_of(response)
    with app.app_context():
        assert get_library().get(2).info.version == version


def test_the_stl_of_a_program_named_in_any_script_downloads(
    client: FlaskClient, token: str, app: Flask
) -> None:
    """The STL's header had the name as it was: not latin-1, so the server's 500."""
    document = json.loads(DOCUMENT.read_text())
    document["name"] = "Деталь 5 ①"
    response = client.post(
        "/programs/import",
        data={"csrf_token": token, "file": (io.BytesIO(json.dumps(document).encode()), "d.json")},
    )
    program_id = int(response.headers["Location"].split("/")[2])
    response = client.get(f"/programs/{program_id}/verify/part.stl")
    assert response.status_code == 200
    header = response.headers["Content-Disposition"]
    header.encode("latin-1")  # what a WSGI server must send
    assert "filename*=UTF-8''%D0%94%D0%B5%D1%82%D0%B0%D0%BB%D1%8C-5-%E2%91%A0.stl" in header


# -- what a program's name can put into a control's file ---------------------------------------

CONTROL_TARGETS = (
    "gcode-fanuc",
    "gcode-prototrak",
    "gcode-linuxcnc",
    "tape-ascii",
    "tape-eia",
    "events",
    "tape-boss",
)
HOSTILE_NAMES = (
    "50% STEPOVER",
    "A%\nG0 X99",
    "ROUGH (SIDE); FINISH",
    "XON\x11XOFF\x13EOT\x04SUB\x1aDEL\x7f",
    "Деталь №5 ½",
)


@pytest.mark.parametrize("name", HOSTILE_NAMES)
@pytest.mark.parametrize("target", CONTROL_TARGETS)
def test_no_name_ends_a_control_s_file_or_block(target: str, name: str) -> None:
    """A `%` in a program's name landed in the Fanuc and ProtoTRAK header comment, and `%`
    ends a file on those controls (seed 003 §2.2.3): `%` stands only where a file starts or
    ends, no control character but the line ends, nothing after `(` ends the comment."""
    from dataclasses import replace

    from app.cnc import document
    from app.cnc.formats.targets import export

    program = replace(document.loads(DOCUMENT.read_text()), name=name, notes=name)
    text = export(program, target, {}).data.decode("ascii")
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    assert all("%" not in line[1:] for line in lines), [ln for ln in lines if "%" in ln[1:]]
    assert not [c for c in text if (ord(c) < 32 and c not in "\r\n\t") or ord(c) == 127]
    for line in lines:
        if "(" in line:  # one comment, ended by its `)` and then the block's end at most
            inner, closed, after = line[line.index("(") + 1 :].partition(")")
            assert closed and "(" not in inner and ";" not in inner, line
            assert after in ("", ";"), line


@pytest.mark.parametrize("target", ["gcode-fanuc", "gcode-prototrak", "tape-ascii"])
def test_our_own_receive_of_a_send_with_a_percent_in_the_name_reads_the_whole_program(
    target: str,
) -> None:
    """Received (app.dnc's capture, as from the port), a `%` in the header comment ended the
    file there: the capture held no program and nothing was saved."""
    from dataclasses import replace

    from app.cnc import document
    from app.cnc.formats.reading import read_program
    from app.cnc.formats.targets import export
    from app.dnc.framing import Capture, outgoing
    from app.dnc.settings import PortSettings

    def received(program: Any) -> Any:
        settings = PortSettings(target=target)
        capture = Capture(settings)
        capture.feed(outgoing(export(program, target, {}).data, settings))
        return read_program(bytes(capture.data), "received").program

    program = document.loads(DOCUMENT.read_text())
    plain = received(program)
    assert len(plain.blocks) > 0
    assert received(replace(program, name="100% CHECKED")).blocks == plain.blocks
