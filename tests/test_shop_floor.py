"""Shop-floor targets (issue 23): the BOSS tape, the 1704's tape search, OTIME and feeds.

Each test failed on main before its fix (the commit message says how). OTIME's test is in
tests/test_machine.py (test_cycle_time_per_machine).
"""

from __future__ import annotations

import re
from decimal import Decimal as D
from pathlib import Path

import pytest

from app.cnc import document
from app.cnc.blocks import (
    ArcEnd,
    Block,
    Coolant,
    DataBlock0,
    Direction,
    Hole,
    HoleOp,
    MillArc,
    MillLine,
    Pos,
    Program,
    Tool,
)
from app.cnc.formats.gcode.boss import segments
from app.cnc.formats.targets import ExportError, Report, export

GOLDEN = Path(__file__).parent / "golden"


def golden(name: str) -> Program:
    return document.loads((GOLDEN / name / "program.json").read_text(encoding="utf-8"))


def part(*blocks: Block, tools: tuple[Tool, ...] | None = None) -> Program:
    tools = tools or (Tool(number=1, diameter=D("0.25"), rpm=1200, tcal=D("0")),)
    return Program(
        name="FLOOR",
        part_number="23",
        block0=DataBlock0(current_tool=1, z_retract=D("0.1"), tools=tools),
        blocks=blocks,
    )


def hole(x: str, y: str = "0", tool: int = 1) -> Hole:
    return Hole(
        op=HoleOp.DRILL, x=D(x), y=D(y), z_up=D("0.1"), z_dn=D("-0.2"), feed_z=D(5), tool=tool
    )


def lines_of(data: bytes) -> list[str]:
    return data.decode("ascii").split("\r")[:-1]


# -- 1. and 4. the BOSS tape ----------------------------------------------------------------------


@pytest.mark.parametrize(
    ("system", "degrees", "word"),
    [("boss45", "90", "Y9."), ("boss6", "180", "Y9."), ("boss6", "25", "Y1.25")],
)
def test_a_rotary_index_keeps_its_decimal_point(system: str, degrees: str, word: str) -> None:
    """Seed 004 §8.2-8.3 give the Y values with decimals, and every other length on the tape
    has its point: `Y9` would be read as implied decimals (a tiny fraction of the angle)."""
    program = part(hole("1"), Pos(x=D(1), y=D(0), tool=1, index=True), hole("1"))
    options = {"rotary": "yes", "system": system, "index-degrees": degrees}
    tape = lines_of(export(program, "tape-boss", options).data)
    assert f"G91G00{word}" in tape
    assert not any(re.search(r"Y[1-9]\d*$", line) for line in tape)


def test_boss_lines_end_in_a_carriage_return() -> None:
    """Seed 004 §8.1.1: "M02 (cr)$ (cr)$ (cr)" — every line ends in CR."""
    data = export(golden("loop-rep-grid"), "tape-boss").data
    assert b"\n" not in data and data.endswith(b"M02\r$\r$\r")
    assert data.startswith(b"%#0\r")
    crlf = export(golden("loop-rep-grid"), "tape-boss", {"line-end": "crlf"}).data
    assert crlf.endswith(b"M02\r\n$\r\n$\r\n")


def test_boss_writes_no_length_offset_over_tcal() -> None:
    """Z words already include each tool's TCAL: a G43 H would compensate it twice."""
    text = export(golden("stop-and-tool-changes"), "tape-boss").data.decode("ascii")
    assert "T2M06" in text and "G43" not in text and "H0" not in text


def test_boss_needs_calibrated_tools() -> None:
    tools = (Tool(number=1, diameter=D("0.25"), rpm=1200, tcal=None),)
    with pytest.raises(ExportError) as refused:
        export(part(hole("1"), tools=tools), "tape-boss")
    assert str(refused.value).startswith("tape-boss needs calibrated tools")


# -- 3. segmentation -------------------------------------------------------------------------


def test_segmentation_goes_on_after_a_stretch_too_long_to_break() -> None:
    """A stretch with no safe place in it makes its segment too long; the later safe
    places are still used (before, segmentation switched off for the rest of the tape),
    and every segment over the limit is named."""
    cut = [f"G01X{k}.Y0." for k in range(30)]  # no safe place: one long stretch
    holes = [f"G00X{k}.Y5." for k in range(30)]  # a safe place before each
    lines = ["G70G90", *cut, *holes]
    breaks = {len(cut) + 1 + k for k in range(30)}
    report = Report("tape-boss")
    tape = segments(lines, breaks, 80, report)
    pieces = "\n".join(tape).split("$\n#0")
    assert len(pieces) > 3, "the holes after the long cut are segmented"
    sizes = [
        sum(len(ln) + 1 for ln in p.strip("\n").split("\n") if ln not in ("%#0", "#0", "M02", "$"))
        for p in pieces
    ]
    assert sizes[0] > 80 and all(s <= 80 for s in sizes[1:])
    errors = [e.message for e in report.entries if e.severity.value == "error"]
    assert len(errors) == 1 and errors[0].startswith(f"segment 1 is {sizes[0]} characters")


# -- 5. tape search --------------------------------------------------------------------------


def searched_tape(program: Program, **options: str) -> list[str]:
    opts = {"tape-search": "yes", **options}
    return [
        ln for ln in export(program, "tape-ascii", opts).data.decode().splitlines() if ln[0] == "N"
    ]


def test_the_searched_block_holds_position_spindle_speed_and_feed() -> None:
    """Seed 000 §4: "include all data in the searched block … feedrate, spindle rotation,
    and coolant". Each data block that starts out of the work begins with a block carrying
    every axis, the S code and M03/M04 and the block's feed; the coolant's M code is in the
    block before (one M code per block, §2). Before: M03 without S, spread over three."""
    tools = (
        Tool(number=1, diameter=D("0.25"), rpm=1200, tcal=D(0), coolant=Coolant.FLOOD),
        Tool(number=2, diameter=D("0.5"), rpm=800, tcal=D("-1.25"), coolant=Coolant.MIST),
    )
    program = part(hole("0"), hole("1"), hole("2", tool=2), hole("3", tool=2), tools=tools)
    blocks = searched_tape(program, **{"spindle-codes": "1200=14,800=12"})
    searched = [k for k, b in enumerate(blocks) if re.search(r"G50X-?\d+Y-?\d+Z-?\d+", b)]
    for k in searched:
        if "M0" not in blocks[k]:
            continue  # the positioning of a hole, inside its block
        assert re.search(r"F50S1[24]M03$", blocks[k]), blocks[k]
        assert re.search(r"M0[78]$", blocks[k - 1]), blocks[k - 1]
    # One searched block per data block (the spindle and coolant restated each time).
    assert sum(bool(re.search(r"S1[24]M03$", b)) for b in blocks) == 4


def test_a_block_inside_a_cut_is_no_restart_point() -> None:
    """An arc's block restated only its end and centre: searched to, the tool cut from
    wherever it was. Blocks that continue a cut get no restart group (said in the report);
    the cut's DRILL block is where a search restarts it."""
    program = part(
        hole("0"),
        MillLine(x=D(1), y=D(0), feed_xy=D(10), tool=1),
        MillArc(direction=Direction.CCW, x=D(1), y=D(1), feed_xy=D(10), tool=1),
        ArcEnd(x=D(2), y=D(1)),
        hole("3"),
    )
    result = export(program, "tape-ascii", {"tape-search": "yes"})
    blocks = [ln for ln in result.data.decode().splitlines() if ln[0] == "N"]
    arc = next(k for k, b in enumerate(blocks) if "G30X20000Y10000" in b)
    assert "M03" not in blocks[arc - 1] and "G01X10000F100" in blocks[arc - 1]
    assert any(
        e.message.startswith("tape search: blocks 2-4 continue a cut and are no place")
        for e in result.report.entries
    )
    # The next hole (block 5) is searchable: position, spindle and feed in one block.
    assert any(re.fullmatch(r"N\d+G50X20000Y10000Z2000F50M03", b) for b in blocks)


# -- 7. feeds --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("resolution", "word", "written"),
    [("option1", "F52", "5.2 ipm"), ("option2", "F5", "5.0 ipm")],
)
def test_a_rounded_feed_is_reported(resolution: str, word: str, written: str) -> None:
    program = part(hole("0"), MillLine(x=D(1), y=D(0), feed_xy=D("5.1"), tool=1))
    result = export(program, "tape-ascii", {"resolution": resolution})
    assert word in result.data.decode()
    assert any(
        e.block == 2 and e.message.startswith(f"feed 5.1 ipm is written {word} ({written})")
        for e in result.report.entries
    ), result.report.text()


def test_a_feed_below_the_minimum_is_quoted_as_programmed() -> None:
    program = part(hole("0"), MillLine(x=D(1), y=D(0), feed_xy=D("0.1"), tool=1))
    with pytest.raises(ExportError) as refused:
        export(program, "tape-ascii", {"resolution": "option1"})
    assert refused.value.report is not None
    errors = [e.message for e in refused.value.report.entries if e.severity.value == "error"]
    assert errors[0].startswith("feed 0.1 ipm is below the 1704's minimum 0.2 ipm")


# -- 8. ZEROS --------------------------------------------------------------------------------


def test_zeros_0_punches_every_digit() -> None:
    """Seed 002 ZEROS 0: leading and trailing zeros, no point (2.4: six digits)."""
    text = export(part(hole("1")), "tape-ascii", {"zeros": "0"}).data.decode()
    assert "N2X010000" in text and "Y000000" in text and "F0050" in text
    plain = export(part(hole("1")), "tape-ascii").data.decode()
    assert "N2X10000\n" in plain and "F50\n" in plain
