"""Bounded work per request (issue 17, defect 6): an import past the stated limits is
refused naming the limit before it is parsed, a document past the block limit is refused,
and the largest program the library accepts opens, its block list in pages."""

from __future__ import annotations

import io
import re
from collections.abc import Iterator
from decimal import Decimal
from pathlib import Path

import pytest
from click.testing import CliRunner
from flask import Flask
from flask.testing import FlaskClient

from app.cli import main
from app.cnc import document
from app.cnc.blocks import DataBlock0, Mode, Pos, Program, Tool
from app.cnc.formats.reading import ImportFailure, read_program
from app.cnc.sizes import MAX_BLOCKS, MAX_IMPORT_LINES
from app.web.editor_page import PAGE_SIZE
from app.web.extensions import get_library
from tests.web_support import csrf, dispose, local_app


@pytest.fixture
def app(tmp_path: Path) -> Iterator[Flask]:
    app = local_app(tmp_path)
    yield app
    dispose(app)


@pytest.fixture
def client(app: Flask) -> FlaskClient:
    return app.test_client()


def straight_moves(lines: int) -> bytes:
    """A CAM-style G-code file: one short straight feed per line."""
    body = [f"G1 X{(n % 500) / 100:.2f} Y{(n // 500) / 100:.2f}" for n in range(lines - 4)]
    return "\n".join(["G20 G90", "G0 X0 Y0", "G1 Z-0.1 F10", *body, "M30"]).encode()


def test_an_import_past_the_line_limit_is_refused_naming_it() -> None:
    with pytest.raises(ImportFailure) as caught:
        read_program(straight_moves(MAX_IMPORT_LINES + 1), "cam", "gcode")
    assert f"at most {MAX_IMPORT_LINES:,} lines" in str(caught.value)


def test_an_upload_past_the_line_limit_is_refused_and_saves_nothing(
    client: FlaskClient, app: Flask
) -> None:
    with app.app_context():
        before = len(get_library().programs())
    response = client.post(
        "/programs/import",
        data={
            "csrf_token": csrf(client),
            "file": (io.BytesIO(straight_moves(MAX_IMPORT_LINES + 1)), "cam.ngc"),
        },
    )
    assert response.status_code == 422
    assert f"at most {MAX_IMPORT_LINES:,} lines" in response.get_data(as_text=True)
    with app.app_context():
        assert len(get_library().programs()) == before


def test_the_cli_converts_a_file_past_the_webs_limits(tmp_path: Path) -> None:
    """Before: the command line refused a G-code file over 20 000 lines, on the user's own
    machine. A long CAM program converts; only the library (which keeps programs the web
    can open) refuses to store more than MAX_BLOCKS blocks, naming the limit (exit 2)."""
    path = tmp_path / "cam.ngc"
    path.write_bytes(straight_moves(MAX_IMPORT_LINES + 1))
    out = tmp_path / "cam.tape"
    result = CliRunner().invoke(main, ["export", str(path), "--to", "tape-ascii", "-o", str(out)])
    assert result.exit_code == 0, result.stderr
    assert out.read_bytes().count(b"\n") > MAX_IMPORT_LINES - 10
    checked = CliRunner().invoke(main, ["check", str(path)])
    # Read whole (the file gives no RPM: that is the program's one error, exit 1).
    assert checked.exit_code == 1
    assert f"{MAX_IMPORT_LINES - 3} blocks, 1 errors" in checked.stdout
    stored = CliRunner(env={"DATABASE_URL": f"sqlite:///{tmp_path / 'lib.db'}"}).invoke(
        main, ["import", str(path)]
    )
    assert stored.exit_code == 2, stored.output
    assert f"a program has at most {MAX_BLOCKS:,}" in stored.stderr


def big_program(blocks: int) -> Program:
    tool = Tool(number=1, diameter=Decimal("0.25"), rpm=1000, tcal=Decimal(0))
    return Program(
        name="many holes",
        block0=DataBlock0(current_tool=1, z_retract=Decimal("0.1"), tools=(tool,)),
        blocks=tuple(
            Pos(mode=Mode.ABS, x=Decimal(n % 50) / 10, y=Decimal(n // 50) / 10, tool=1)
            for n in range(blocks)
        ),
    )


def test_a_document_past_the_block_limit_is_refused() -> None:
    text = document.dumps(big_program(MAX_BLOCKS + 1))
    with pytest.raises(document.DocumentError) as caught:
        document.loads(text)
    assert f"a program has at most {MAX_BLOCKS}" in str(caught.value)


def test_the_largest_program_opens_with_its_block_list_in_pages(
    client: FlaskClient, app: Flask
) -> None:
    with app.app_context():
        info = get_library().create(big_program(MAX_BLOCKS))
    page = client.get(f"/programs/{info.id}").get_data(as_text=True)
    assert f"blocks {MAX_BLOCKS - PAGE_SIZE + 1}–{MAX_BLOCKS} of {MAX_BLOCKS}" in page
    assert page.count('class="block-row') == PAGE_SIZE + 1  # the page and "new block…"
    assert f'<span class="num">{MAX_BLOCKS + 1}</span>' in page
    first = client.get(f"/programs/{info.id}?page=1").get_data(as_text=True)
    assert f"blocks 1–{PAGE_SIZE} of {MAX_BLOCKS}" in first and "new block…" not in first
    editing = client.get(f"/programs/{info.id}?edit=1234").get_data(as_text=True)
    numbers = [
        int(n) for n in re.findall(r'<li class="block-row[^"]*"\s+data-block="(\d+)"', editing)
    ]
    assert 1234 in numbers and len(numbers) == PAGE_SIZE


def test_the_library_stores_no_program_it_could_not_open(app: Flask) -> None:
    from app.storage.library import LibraryError

    with app.app_context():
        library = get_library()
        with pytest.raises(LibraryError) as caught:
            library.create(big_program(MAX_BLOCKS + 1))
        assert f"a program has at most {MAX_BLOCKS:,}" in str(caught.value)
        info = library.create(big_program(MAX_BLOCKS))
        with pytest.raises(LibraryError):
            library.save(info.id, big_program(MAX_BLOCKS + 1), based_on=1)
        assert library.get(info.id).info.version == 1


def test_a_block_past_the_limit_is_refused_in_the_editor(client: FlaskClient, app: Flask) -> None:
    with app.app_context():
        info = get_library().create(big_program(MAX_BLOCKS))
    response = client.post(
        f"/programs/{info.id}/blocks",
        data={
            "csrf_token": csrf(client),
            "version": "1",
            "kind": "POS",
            "at": str(MAX_BLOCKS + 1),
            "x": "1",
            "y": "1",
            "tool": "1",
        },
    )
    assert response.status_code == 422
    assert f"a program has at most {MAX_BLOCKS:,}" in response.get_data(as_text=True)
