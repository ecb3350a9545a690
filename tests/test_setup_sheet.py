"""The set-up sheet at the machine (issue 29 point 7), as the operator reads it: the stock
to put in the vise, each tool's name (Data Block 0 NAME, kept in the document), and the
hole table in cutting order. The picture on screen and in print is tests/test_browser_setup.py.
"""

from __future__ import annotations

import dataclasses
import re
from decimal import Decimal
from pathlib import Path

import pytest
from click.testing import CliRunner
from flask import Flask

from app import create_app
from app.cli import main
from app.cnc import document
from app.cnc.blocks import Program, Stock, Tool
from app.cnc.copy import resolve_copies
from app.cnc.setup import setup_sheet
from app.cnc.validate import validate
from app.web import get_library

GOLDEN = Path(__file__).parent / "golden"


def golden(case: str) -> Program:
    return resolve_copies(document.loads((GOLDEN / case / "program.json").read_text()))


def named(program: Program, number: int, name: str) -> Program:
    tools = tuple(
        dataclasses.replace(t, name=name) if t.number == number else t for t in program.block0.tools
    )
    return dataclasses.replace(program, block0=dataclasses.replace(program.block0, tools=tools))


# -- tool names ---------------------------------------------------------------------------


def test_a_tool_name_round_trips_through_the_document_and_old_documents_load() -> None:
    program = named(golden("bolt-circle-bore-tap"), 3, "1/4-20 TAP")
    text = document.dumps(program)
    assert '"name": "1/4-20 TAP"' in text
    assert document.loads(text).block0.tool(3) == Tool(
        number=3, diameter=Decimal("0.201"), rpm=-400, tcal=Decimal("0.375"), name="1/4-20 TAP"
    )
    # A document written before tools had names reads, and writes back byte for byte.
    old = (GOLDEN / "copy-cancel" / "expected.json").read_text()
    assert '"name": "' not in old.split('"blocks"')[0].split('"tools"')[1]
    assert all(t.name == "" for t in document.loads(old).block0.tools)
    assert document.dumps(document.loads(old)) == old


@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("X" * 25, "Data Block 0, TOOL 3 NAME: 25 characters is too long; allowed up to 24"),
        ("TAP (M6)", "Data Block 0, TOOL 3 NAME: has characters a G-code comment cannot hold"),
        ("TAP; M6", "cannot hold: ';'"),
    ],
)
def test_a_bad_tool_name_is_an_error_naming_the_tool(name: str, message: str) -> None:
    problems = [str(p) for p in validate(named(golden("bolt-circle-bore-tap"), 3, name))]
    assert any(message in p for p in problems), problems
    assert not any("NAME" in str(p) for p in validate(named(golden("drill-single"), 1, "#7 DRILL")))


@pytest.fixture
def app(tmp_path: Path) -> Flask:
    return create_app({"DATABASE_URL": f"sqlite:///{tmp_path / 'web.db'}", "SECRET_KEY": "t" * 32})


def db0_form(program: Program, version: int, **extra: str) -> dict[str, str]:
    db0 = program.block0
    form = {
        "version": str(version),
        "x_offset": str(db0.x_offset),
        "y_offset": str(db0.y_offset),
        "current_tool": str(db0.current_tool),
        "milling": db0.milling.value,
        "z_retract": str(db0.z_retract),
    }
    for t in db0.tools:
        n = t.number
        for key, value in (("dia", t.diameter), ("rpm", t.rpm), ("tcal", t.tcal)):
            form[f"{key}_{n}"] = "" if value is None else str(value)
    return form | extra


def test_the_data_block_0_form_names_a_tool_and_refuses_a_bad_name(app: Flask) -> None:
    program = golden("bolt-circle-bore-tap")
    with app.app_context():
        program_id = get_library().create(program).id
    client = app.test_client()
    page = client.get(f"/programs/{program_id}/db0").get_data(as_text=True)
    token = re.search(r'name="csrf_token" value="([^"]+)"', page)
    assert token and 'aria-label="Tool 3 name"' in page
    url = f"/programs/{program_id}/db0"
    bad = db0_form(program, 1, csrf_token=token.group(1), name_3="TAP (M6)")
    refused = client.post(url, data=bad)
    assert refused.status_code == 422
    assert "TOOL 3 NAME: has characters a G-code comment cannot hold" in refused.get_data(
        as_text=True
    )
    good = db0_form(program, 1, csrf_token=token.group(1), name_3="1/4-20 TAP")
    assert client.post(url, data=good).status_code == 302
    with app.app_context():
        saved = get_library().get(program_id).program
    tool = saved.block0.tool(3)
    assert tool is not None and tool.name == "1/4-20 TAP"
    sheet = client.get(f"/programs/{program_id}/setup").get_data(as_text=True)
    assert "1/4-20 TAP" in sheet


# -- the stock ----------------------------------------------------------------------------


def test_the_sheet_gives_the_programs_saved_stock() -> None:
    stock = Stock(
        x=Decimal(-2),
        y=Decimal(-2),
        z=Decimal(0),
        xl=Decimal(4),
        yw=Decimal("4.5"),
        zh=Decimal("0.75"),
    )
    program = dataclasses.replace(golden("bolt-circle-bore-tap"), stock=stock)
    sheet = setup_sheet(program)
    assert sheet.stock is not None and sheet.stock.given
    assert sheet.stock.size == "XL 4.0000 × YW 4.5000 × ZH 0.7500 in"
    assert sheet.stock.where == "lower-left corner X -2.0000, Y -2.0000; top Z 0.0000 in"
    # A stock that stands on parallels for its through cuts says how high they must be.
    raised = dataclasses.replace(program, stock=dataclasses.replace(stock, clear=Decimal("0.5")))
    lifted = setup_sheet(raised).stock
    assert lifted is not None and lifted.where.endswith("; on parallels, 0.5000 in clear below it")


def test_the_sheet_sizes_the_stock_as_the_simulation_does() -> None:
    from app.cnc.simulate.verify import prepare

    program = golden("bolt-circle-bore-tap")
    grid, _ = prepare(program)
    sheet = setup_sheet(program)
    assert sheet.stock is not None and not sheet.stock.given
    # Verify's own stock, the same numbers.
    assert grid.stock.describe(program.units).startswith("X -1.8000 to 1.8000, Y -1.8000 to 1.8")
    assert sheet.stock.size == "XL 3.6000 × YW 3.6000 × ZH 0.7500 in"


# -- the hole table -----------------------------------------------------------------------


def test_the_hole_table_lists_each_hole_in_cutting_order() -> None:
    program = named(golden("bolt-circle-bore-tap"), 3, "1/4-20 TAP")
    holes = setup_sheet(program).holes
    assert [(h.block, h.x, h.y, h.tool, h.depth, h.operation) for h in holes] == [
        (2, "0.0000", "-1.0000", 2, "-0.5000", "bore"),
        (2, "-0.8660", "0.5000", 2, "-0.5000", "bore"),
        (2, "0.8660", "0.5000", 2, "-0.5000", "bore"),
        (4, "-1.5910", "-1.5910", 3, "-0.5000", "tap"),
        (4, "-1.5910", "1.5910", 3, "-0.5000", "tap"),
        (4, "1.5910", "1.5910", 3, "-0.5000", "tap"),
        (4, "1.5910", "-1.5910", 3, "-0.5000", "tap"),
    ]
    assert [h.number for h in holes] == list(range(1, 8))
    assert {h.tool_name for h in holes if h.tool == 3} == {"1/4-20 TAP"}


def test_the_hole_table_of_a_loop_and_of_pecks() -> None:
    looped = setup_sheet(golden("loop-bolt-circle")).holes
    assert len(looped) == 8  # a bolt circle of 4, repeated once by LOOP/REP
    assert (looped[4].x, looped[4].y) == ("5.0000", "1.5000")
    pecked = setup_sheet(golden("drill-12-pecks")).holes
    assert [(h.block, h.operation, h.depth) for h in pecked] == [(1, "drill, 12 pecks", "-1.1500")]


def test_the_cli_set_up_sheet_prints_stock_names_and_holes(tmp_path: Path) -> None:
    path = tmp_path / "part.json"
    path.write_text(document.dumps(named(golden("bolt-circle-bore-tap"), 3, "1/4-20 TAP")))
    result = CliRunner().invoke(main, ["setup-sheet", str(path)])
    assert result.exit_code == 0, result.stderr
    out = result.stdout
    assert "Stock XL 3.6000 × YW 3.6000 × ZH 0.7500 in (sized from the program's extent)" in out
    assert "      1/4-20 TAP\n" in out
    assert "HOLE  BLOCK  X           Y           TOOL  Z DN        OPERATION" in out
    assert "   4      4  -1.5910     -1.5910        3  -0.5000     tap (1/4-20 TAP)" in out


# -- the name in G-code -------------------------------------------------------------------


def test_gcode_names_the_tool_in_its_set_up_comments_and_reads_back() -> None:
    from app.cnc.formats.reading import read_program
    from app.cnc.formats.targets import export

    program = named(golden("bolt-circle-bore-tap"), 3, "1/4-20 tap")
    text = export(program, "gcode-linuxcnc").data.decode()
    assert "(SET-UP: T3 IS 1/4-20 TAP)\n(SET-UP: T3 DIA 0.2010 LENGTH H03 = 0.3750, ITS TCAL)" in (
        text
    )
    # Without names the output is as before (the goldens hold it byte for byte).
    plain = export(golden("bolt-circle-bore-tap"), "gcode-linuxcnc").data.decode()
    assert " IS " not in plain and text.replace("(SET-UP: T3 IS 1/4-20 TAP)\n", "") == plain
    # Read back, the tool has its name (in the comment's upper case).
    back = read_program(text.encode(), "back", "gcode").program
    tool = back.block0.tool(3)
    assert tool is not None and tool.name == "1/4-20 TAP"
