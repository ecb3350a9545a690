"""Imports you can always keep (issue 36 point 3): a program imported with errors is
stored, opens in the editor with its errors shown, and is written as the JSON document —
through each entry point: the upload page, `millblocks import`, and the document writer.

The file is LinuxCNC's comp-g1.ngc as LinuxCNC ships it: it leaves its tool's diameter to
the control's tool table, and names no spindle speeds, so the program it becomes asks for
the diameter of tool 4 (an error on its DRILL CUT LT) and the tools' RPM.
"""

from __future__ import annotations

import io
import re
from pathlib import Path

import pytest
from click.testing import CliRunner
from flask import Flask
from flask.testing import FlaskClient

from app import create_app
from app.cli import main
from app.cnc import document
from app.cnc.blocks import Program
from app.cnc.formats.reading import read_program
from app.cnc.formats.targets import export
from app.cnc.validate import validate
from app.web import get_library

SOURCE = Path(__file__).parent / "imports" / "gcode-corpus" / "linuxcnc" / "comp-g1.ngc"
NO_DIA = "tool 4 has no DIA in Data Block 0"


def imported() -> Program:
    return read_program(SOURCE.read_bytes(), SOURCE.stem).program


def error_texts(program: Program) -> list[str]:
    return [str(p) for p in validate(program) if p.severity.value == "error"]


def test_the_import_has_errors_and_the_document_writer_writes_it() -> None:
    program = imported()
    assert any(NO_DIA in e for e in error_texts(program))
    assert document.loads(document.dumps(program)) == program
    written = export(program, "json")
    assert document.loads(written.data.decode()) == program
    assert any(
        "error, written as it is" in e.message and NO_DIA in e.message
        for e in written.report.entries
    )


@pytest.fixture
def app(tmp_path: Path) -> Flask:
    return create_app({"DATABASE_URL": f"sqlite:///{tmp_path / 'web.db'}", "SECRET_KEY": "t" * 32})


def test_the_upload_page_stores_it_and_the_editor_shows_its_errors(app: Flask) -> None:
    client: FlaskClient = app.test_client()
    token = re.search(r'name="csrf_token" value="([^"]+)"', client.get("/").get_data(as_text=True))
    assert token is not None
    response = client.post(
        "/programs/import",
        data={"csrf_token": token.group(1), "file": (io.BytesIO(SOURCE.read_bytes()), SOURCE.name)},
        content_type="multipart/form-data",
    )
    page = response.get_data(as_text=True)
    assert response.status_code == 201, page
    with app.app_context():
        [stored] = [p for p in get_library().programs() if p.name == "comp-g1.ngc"]
        assert get_library().get(stored.id).program == imported()
    editor = client.get(f"/programs/{stored.id}")
    assert editor.status_code == 200
    assert NO_DIA in editor.get_data(as_text=True)
    download = client.get(f"/programs/{stored.id}/export/download?target=json")
    assert download.status_code == 200
    assert document.loads(download.get_data(as_text=True)) == imported()


def test_millblocks_import_stores_it_and_exports_it_as_the_document(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'lib.db'}")
    runner = CliRunner()
    result = runner.invoke(main, ["import", str(SOURCE)])
    assert result.exit_code == 0, result.output
    new_id = result.stdout.strip()
    assert new_id.isdigit()
    assert NO_DIA in result.stderr  # the errors, listed as it is stored
    out = tmp_path / "comp-g1.json"
    result = runner.invoke(main, ["export", new_id, "--to", "json", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert document.loads(out.read_text()) == imported()
    assert "error, written as it is" in result.stderr
