"""Outputs a shop can trust (issue 16): each defect a machinist found, as the behaviour a
user notices. Each test failed on main before the fix (the commit message says how).

1. a tape's Z words include each tool's TCAL: an import takes it off again, and keeps the
   first tool's DIA and TCAL;
2. LinuxCNC output never rewrites G54 or the tool table unless asked;
3. an arc whose end is off its radius is cut as the control cuts it, and every reader takes
   the export;
4. what `check` accepts, every consumer processes (a MILL STD that goes nowhere inside a
   compensated contour);
5. a program without spindle speeds exports wherever speeds are not needed;
6. ProtoTRAK modified Fanuc: a G code on every line, N numbers 0-999;
7. dwell in the dialect's unit (Fanuc P in whole milliseconds);
8. G20/G21 decides the unit of every imported block;
9. events: a G105's tool diameter is kept, rounding creates no warnings.
"""

from __future__ import annotations

import dataclasses
import re
from decimal import Decimal
from pathlib import Path

import pytest
from click.testing import CliRunner
from flask import Flask
from flask.testing import FlaskClient

from app import create_app
from app.cli import main
from app.cnc.blocks import (
    ArcEnd,
    Block,
    Comp,
    DataBlock0,
    Direction,
    Hole,
    HoleOp,
    MillArc,
    MillLine,
    Mode,
    Program,
    Tool,
)
from app.cnc.estimate import estimate
from app.cnc.formats.reading import read_program
from app.cnc.formats.targets import ExportError, export, targets
from app.cnc.interpret import interpret
from app.cnc.problems import Rule, Severity, has_errors
from app.cnc.setup import render_text, setup_sheet
from app.cnc.toolpath import ArcFeed, Feed
from app.cnc.validate import validate
from app.web import get_library
from tests.imports.support import GOLDEN, load, with_rpms
from tests.referee import RS274, referee_gcode

D = Decimal


def program_of(*blocks: Block, tools: tuple[Tool, ...] | None = None) -> Program:
    tools = tools or (Tool(number=1, diameter=D("0.25"), rpm=1200, tcal=D("0")),)
    return Program(
        name="TRUST",
        part_number="16",
        block0=DataBlock0(current_tool=1, tools=tools),
        blocks=tuple(blocks),
    )


# -- 1. tape import and TCAL -------------------------------------------------------------


def test_tape_import_takes_each_tools_tcal_off_its_z_words() -> None:
    """stop-and-tool-changes drills with tool 2 (TCAL -1.25) and taps with tool 3 (TCAL
    0.375): through an ASCII tape and back, every Z UP and Z DN is the program's, not
    shifted by the TCAL (before: the tap 0.5 in short... a bore 0.25 in deep)."""
    program = load(GOLDEN / "stop-and-tool-changes")
    imported = read_program(export(program, "tape-ascii").data, "t").program
    depths = [(b.z_up, b.z_dn) for b in imported.blocks if isinstance(b, Hole)]
    assert depths == [(b.z_up, b.z_dn) for b in program.blocks if isinstance(b, Hole)]


def test_the_first_tools_diameter_and_tcal_survive_a_tape() -> None:
    """The tape starts with tool 1, which no M06 names: its DIA and TCAL come back (the
    header says so), so the program goes back onto tape without "not calibrated"."""
    program = load(GOLDEN / "stop-and-tool-changes")
    tape = export(program, "tape-ascii").data
    imported = read_program(tape, "t").program
    first = imported.block0.tool(1)
    assert first is not None and (first.diameter, first.tcal) == (D("0.25"), D("0"))
    again = export(
        dataclasses.replace(
            with_rpms(imported, {1: 1200, 2: 800, 3: 400, 4: 2500}),
            name=program.name,
            part_number=program.part_number,
        ),
        "tape-ascii",
    )
    # Tool 3 runs in reverse in the original (RPM -400): the tape says M04, the user
    # enters the speeds; everything else is the same tape.
    assert again.data.replace(b"M03", b"M04") == tape.replace(b"M03", b"M04")


# -- 2. LinuxCNC keeps the machine's settings ------------------------------------------------


def test_linuxcnc_output_does_not_touch_g54_or_the_tool_table() -> None:
    result = export(load(GOLDEN / "stop-and-tool-changes"), "gcode-linuxcnc")
    text = result.data.decode()
    assert "G10" not in text
    assert "(SET-UP: G54 = PART ZERO AT TABLE X4.5000 Y3.2500)" in text
    assert "(SET-UP: T2 DIA 0.5000 LENGTH H02 = -1.2500, ITS TCAL)" in text
    assert "(SET-UP: T4 DIA 0.3750 LENGTH H04: UNCALIBRATED, MEASURE IT)" in text
    sheet = render_text(setup_sheet(load(GOLDEN / "stop-and-tool-changes"), result.report))
    assert "set-up: G54 must hold part zero, table X4.5000 Y3.2500" in sheet
    assert "set-up: the length of T2 (H02) must be -1.2500, its TCAL" in sheet


def test_writing_the_offsets_is_asked_for_and_reported() -> None:
    result = export(
        load(GOLDEN / "stop-and-tool-changes"), "gcode-linuxcnc", {"write-offsets": "yes"}
    )
    lines = result.data.decode().splitlines()
    assert "G10 L2 P1 X4.5000 Y3.2500 Z0" in lines
    assert "G10 L1 P2 Z-1.2500 R0.2500" in lines
    assert any(
        e.severity.value == "warning" and "write-offsets" in e.message
        for e in result.report.entries
    )


# -- 3. arcs off their radius ---------------------------------------------------------------


def off_radius_program(off: str) -> Program:
    """A compensated contour whose arc (centre 1 in from the start) ends `off` beyond its
    radius: the XY-END at X(2 + off) Y0 instead of X2 Y0."""
    return program_of(
        Hole(
            op=HoleOp.DRILL,
            x=D(0),
            y=D(0),
            z_up=D("0.1"),
            z_dn=D("-0.2"),
            feed_z=D(5),
            tool=1,
            comp=Comp.LEFT,
        ),
        MillArc(direction=Direction.CW, x=D(1), y=D(0), feed_xy=D(10), tool=1),
        ArcEnd(x=D(2) + D(off), y=D(0)),
        MillLine(x=D(2), y=D(-1), feed_xy=D(10), tool=1),
    )


def test_an_arc_off_its_radius_is_cut_as_the_control_cuts_it() -> None:
    """Seed 001: "the start and center points define the radius ... otherwise the cutter
    path will produce a divot". The arc runs on its start's radius, then a line makes the
    divot to the programmed end: no arc in the tool path has an end off its radius."""
    program = off_radius_program("0.01")
    [warning] = [p for p in validate(program) if p.rule is Rule.ARC_RADIUS]
    assert "divot of 0.010 in" in warning.message
    drill = program.blocks[0]
    assert isinstance(drill, Hole)
    uncompensated = dataclasses.replace(
        program, blocks=(dataclasses.replace(drill, comp=Comp.NONE), *program.blocks[1:])
    )
    moves = [m for m in interpret(uncompensated).moves if isinstance(m, ArcFeed | Feed)]
    arc = next(m for m in moves if isinstance(m, ArcFeed))
    assert (arc.x, arc.y) == (50_800_000, 0)  # on the 1 in radius, at the end's angle
    after = moves[moves.index(arc) + 1]
    assert isinstance(after, Feed) and (after.x, after.y) == (51_054_000, 0)


@pytest.mark.parametrize("target", ["gcode-linuxcnc", "gcode-fanuc", "tape-ascii", "events"])
def test_every_reader_takes_an_export_with_an_off_radius_arc(target: str, tmp_path: Path) -> None:
    """Before, rs274 stopped ("Radius to end of arc differs from radius to start") and our
    own importers refused our own output."""
    program = off_radius_program("0.01")
    data = export(program, target).data
    read_program(data, "t")  # raises ImportFailure if a reader refuses it
    if target == "gcode-linuxcnc" and RS274:
        referee_gcode(program, target, data, tmp_path)


# -- 4. what check accepts, every consumer processes -------------------------------------------


def nowhere_in_a_contour() -> Program:
    """Enter through a MILL STD whose X/Y were prefilled: a line that goes nowhere inside a
    compensated contour (here changing depth)."""
    return program_of(
        Hole(
            op=HoleOp.DRILL,
            x=D(0),
            y=D(0),
            z_up=D("0.1"),
            z_dn=D("-0.2"),
            feed_z=D(5),
            tool=1,
            comp=Comp.RIGHT,
        ),
        MillLine(x=D(1), y=D(0), feed_xy=D(10), tool=1),
        MillLine(x=D(1), y=D(0), z_dn=D("-0.3"), feed_xy=D(10), tool=1),
        MillLine(x=D(1), y=D(1), feed_xy=D(10), tool=1),
        MillLine(x=D(0), y=D(0), mode=Mode.INC, feed_xy=D(10), tool=1),
    )


def test_a_line_that_goes_nowhere_in_a_compensated_contour_exports_everywhere() -> None:
    program = nowhere_in_a_contour()
    problems = validate(program)
    assert not has_errors(problems)
    assert any(p.rule is Rule.ZERO_LENGTH and p.block == 5 for p in problems)
    moves = interpret(program).moves
    # The depth change of block 3 happens where the tool is, between the two lines.
    down = [m for m in moves if isinstance(m, Feed) and m.block == 3]
    assert [(m.z, m.feed) for m in down] == [(-7_620_000, 127_000_000)]
    assert estimate(interpret(program)).total > 0
    for name in targets():
        export(program, name)  # no ZeroDivisionError, no refusal


@pytest.fixture
def app(tmp_path: Path) -> Flask:
    return create_app({"DATABASE_URL": f"sqlite:///{tmp_path / 'web.db'}", "SECRET_KEY": "t" * 32})


def test_the_editor_and_its_pages_open_such_a_program(app: Flask) -> None:
    with app.app_context():
        info = get_library().create(nowhere_in_a_contour())
    client: FlaskClient = app.test_client()
    for url in (
        f"/programs/{info.id}",
        f"/programs/{info.id}/export?target=gcode-linuxcnc&go=1",
        f"/programs/{info.id}/setup",
        f"/programs/{info.id}/export/download?target=tape-eia",
    ):
        assert client.get(url).status_code == 200, url


# -- 5. programs without spindle speeds ---------------------------------------------------------


def events_import() -> Program:
    from tests.test_import_events import sample_2_2_6_3

    return read_program(sample_2_2_6_3(), "sample.cnc").program


@pytest.mark.parametrize("target", ["events", "json", "svg", "canon", "tape-eia", "punch-ascii"])
def test_an_events_import_exports_where_speeds_are_not_needed(target: str) -> None:
    program = events_import()
    assert all(t.rpm is None for t in program.block0.tools)
    export(program, target)


def test_a_target_that_writes_s_words_asks_for_speeds_or_takes_them_by_hand() -> None:
    program = events_import()
    with pytest.raises(ExportError) as refused:
        export(program, "gcode-linuxcnc")
    assert str(refused.value) == (
        "gcode-linuxcnc needs spindle speeds (RPM in Data Block 0); or export with "
        "spindle-speeds=by-hand to set them at the control"
    )
    assert [p.location for p in refused.value.problems] == [
        "Data Block 0, TOOL 1 RPM",
        "Data Block 0, TOOL 2 RPM",
        "Data Block 0, TOOL 3 RPM",
    ]
    result = export(program, "gcode-linuxcnc", {"spindle-speeds": "by-hand"})
    assert "\nM3\n" in result.data.decode() and "\nS" not in result.data.decode()
    assert any("set its speed by hand" in e.message for e in result.report.entries)


def test_the_cli_exports_an_events_file_to_json_and_events(tmp_path: Path) -> None:
    from tests.test_import_events import sample_2_2_6_3

    path = tmp_path / "sample.cnc"
    path.write_bytes(sample_2_2_6_3())
    for target in ("events", "json", "tape-eia"):
        result = CliRunner().invoke(main, ["export", str(path), "--to", target])
        assert result.exit_code == 0, result.output


# -- 6. and 7. ProtoTRAK and Fanuc dialects ---------------------------------------------------


def test_prototrak_writes_the_cycle_on_every_hole_line() -> None:
    text = export(load(GOLDEN / "bolt-circle-250"), "gcode-prototrak").data.decode()
    holes = [line for line in text.splitlines() if " G82 " in line]
    assert len(holes) == 250
    # Seed 003 §2.1 rule 1: "G codes must be on every line" — every line that moves, a
    # cycle's extra holes too (M-code lines carry none, as in the sample of §2.2.6.2).
    moving = [ln for ln in text.splitlines() if ln[0] == "N" and re.search(r" [XYZ]-?[\d.]", ln)]
    assert moving and all(re.match(r"N\d+ G\d\d ", line) for line in moving)


def test_prototrak_line_numbers_stay_within_0_to_999() -> None:
    """Seed 003 §2.2.4: line numbers 0-999. A 250-hole bolt circle runs past N999."""
    result = export(load(GOLDEN / "bolt-circle-250"), "gcode-prototrak")
    numbers = [int(n) for n in re.findall(r"^N(\d+)", result.data.decode(), re.M)]
    assert len(numbers) > 100 and max(numbers) <= 999
    assert any("N numbers restart" in e.message for e in result.report.entries)


@pytest.mark.parametrize("target", ["gcode-fanuc", "gcode-prototrak"])
def test_fanuc_dwell_is_in_whole_milliseconds(target: str) -> None:
    """A Fanuc reads G82's P as whole milliseconds: P800, not P0.8 (which it reads as 0)."""
    text = export(load(GOLDEN / "bolt-circle-250"), target).data.decode()
    assert re.search(r"G82.*P800", text) and "P0.8" not in text
    pecked = export(load(GOLDEN / "drill-12-pecks"), target).data.decode()
    assert re.search(r"G04 ?P800", pecked) and "P0.8" not in pecked
    # And our importer reads it back as the 0.8 s dwell a DRILL makes.
    back = read_program(text.encode(), "t").program
    assert [b.title for b in back.blocks][:2] == ["DRILL", "BOLT CIR DRILL"]


def test_linuxcnc_dwell_stays_in_seconds() -> None:
    text = export(load(GOLDEN / "bolt-circle-250"), "gcode-linuxcnc").data.decode()
    assert re.search(r"G82 .* P0\.8 ", text)


# -- 8. units on re-import -------------------------------------------------------------------


def test_an_inch_gcode_file_comes_back_in_inches() -> None:
    """A compensated contour's tool-centre path is off the 0.001 in grid; before, such
    points were taken for millimetres (F5.0 became F5.0394)."""
    program = load(GOLDEN / "contour-cut-right")
    result = read_program(export(program, "gcode-linuxcnc").data, "t")
    assert {b.units.value for b in result.program.blocks} == {"inch"}
    feeds = {getattr(b, "feed_xy", None) for b in result.program.blocks} - {None}
    assert feeds == {getattr(b, "feed_xy", None) for b in program.blocks} - {None}
    assert any("G20: the program and every block are inch" in str(n) for n in result.report)
    assert not any("whole steps of" in str(n) for n in result.report)


# -- 9. events ------------------------------------------------------------------------------


def test_a_tool_diameter_given_only_on_a_g105_is_kept() -> None:
    text = (
        "PN16 G20;\nN001 G101 XB0A YB0A XE1.0A YE0A TC0 F10.0 CR- T01;\n"
        "N002 G105 FE001 LE001 XO0 YO1.0 RE02 D0.375 T01;\n"
    )
    program = read_program(text.encode(), "t", "events").program
    tool = program.block0.tool(1)
    assert tool is not None and tool.diameter == D("0.375")


def test_rounding_creates_no_divot_or_gouge_warnings() -> None:
    """Seed 003 §2.2.6.3: the Plus's CR0.841 fillet is tangent; rounded to 0.001 in its
    joints turn by less than the programming resolution can show — no warnings."""
    warnings = [p for p in validate(events_import()) if p.severity is Severity.WARNING]
    assert not [p for p in warnings if p.rule in (Rule.COMP_DIVOT, Rule.COMP_GOUGE)], warnings
