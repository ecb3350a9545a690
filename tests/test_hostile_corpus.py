"""The hostile-input corpus (tests/hostile_corpus.py) against the real app and CLI: each
case gets its expected status and message, and nothing answers 500 or a traceback."""

from __future__ import annotations

import html
import io
import json
import zipfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from flask import Flask
from flask.testing import FlaskClient

from app.cli import main
from app.web.extensions import get_library
from tests.hostile_corpus import SURFACES, UPLOADS, Case, cases
from tests.test_backup_restore import DAMAGE, bomb, good_backup, rezip
from tests.web_support import accounts_app, csrf, dispose, local_app

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
