"""Bridgeport BOSS: real-time segmented tape checked line by line against seed 004 §8.1.1,
and the rotary table's scalings against the seed's worked examples (§8.2-8.3)."""

from __future__ import annotations

import re
from decimal import Decimal as D
from pathlib import Path

import pytest

from app.cnc import document
from app.cnc.blocks import DataBlock0, Hole, HoleOp, Pos, Program, Tool
from app.cnc.formats.targets import ExportError, export
from app.cnc.rotary import Boss, feed_number, y_distance
from app.cnc.units import Units

GOLDEN = Path(__file__).parent / "golden"


def load(name: str) -> Program:
    return document.loads((GOLDEN / name / "program.json").read_text())


def test_rotary_scaling_from_the_seed() -> None:
    """25° is 2.5 in on BOSS 4/5 and 1.25 in on BOSS 6; 63.5 mm and 31.75 mm in metric.
    12 ipm on a 4 in cutter-path radius is F171 (BOSS 4/5) and F86 (BOSS 6); 210 mm/min on
    100 mm is F120 and F152."""
    assert y_distance(D(25), Boss.BOSS45, Units.INCH) == D("2.5")
    assert y_distance(D(25), Boss.BOSS6, Units.INCH) == D("1.25")
    assert y_distance(D(25), Boss.BOSS45, Units.MM) == D("63.5")
    assert y_distance(D(25), Boss.BOSS6, Units.MM) == D("31.75")
    assert feed_number(D(12), D(4), Boss.BOSS45, Units.INCH) == 171
    assert feed_number(D(12), D(4), Boss.BOSS6, Units.INCH) == 86
    assert feed_number(D(210), D(100), Boss.BOSS45, Units.MM) == 120
    assert feed_number(D(210), D(100), Boss.BOSS6, Units.MM) == 152
    with pytest.raises(ValueError, match="F2286 is outside 2-320"):
        feed_number(D(40), D("1"), Boss.BOSS45, Units.INCH)


def test_segmented_tape_of_three_times_the_segment_size() -> None:
    program = load("loop-rep-grid")
    whole = export(program, "tape-boss").data.decode().splitlines()
    size = sum(len(line) + 1 for line in whole) // 3
    tape = export(program, "tape-boss", {"segment": str(size)}).data.decode().splitlines()
    # b: the tape starts with the rewind stop and the first segment's start.
    assert tape[0] == "%#0"
    # g: it ends M02 (cr) $ (cr) $ (cr).
    assert tape[-3:] == ["M02", "$", "$"]
    body = tape[1:-3]
    # c: #0 and $ stand on lines of their own: every $ but the last is followed by #0.
    assert all(line in ("#0", "$") or not re.search(r"[#$]", line) for line in body)
    segments: list[list[str]] = [[]]
    for i, line in enumerate(body):
        if line == "$":
            assert body[i + 1] == "#0"
            segments.append([])
        elif line != "#0":
            segments[-1].append(line)
    assert len(segments) >= 3
    # d: each segment fits its storage.
    assert all(sum(len(line) + 1 for line in seg) <= size for seg in segments)
    # h: no slash delete; f: no segment ends in a subroutine call (M98 or a #n call).
    assert not any(line.startswith("/") for line in tape)
    assert not any(re.match(r"(M98|#[1-9])", seg[-1]) for seg in segments if seg)
    # e: each segment ends with the tool up at its travel height (Z0.2 for this part).
    z = None
    for seg in segments[:-1]:
        for line in seg:
            found = re.search(r"Z(-?[\d.]+)", line)
            if found:
                z = D(found.group(1))
        assert z == D("0.2")
    # Nothing is lost: the segments hold the whole program, in order.
    whole_body = [line for line in whole if line not in ("%#0", "M02", "$")]
    assert [line for seg in segments for line in seg] == whole_body


def rotary_part(y: str = "0") -> Program:
    tools = (Tool(number=1, diameter=D("0.25"), rpm=1200, tcal=D(0)),)
    return Program(
        name="rotary",
        block0=DataBlock0(current_tool=1, z_retract=D("0.1"), tools=tools),
        blocks=(
            Hole(
                op=HoleOp.DRILL, x=D(1), y=D(y), z_up=D("0.1"), z_dn=D("-0.2"), feed_z=D(5), tool=1
            ),
            Pos(x=D(1), y=D(y), tool=1, index=True),
            Hole(
                op=HoleOp.DRILL, x=D(1), y=D(y), z_up=D("0.1"), z_dn=D("-0.2"), feed_z=D(5), tool=1
            ),
        ),
    )


def test_index_turns_the_table_through_y() -> None:
    """90° per INDEX: Y9. on BOSS 4/5, Y4.5 on BOSS 6, incremental, then back to G90."""
    boss45 = export(rotary_part(), "tape-boss", {"rotary": "yes", "system": "boss45"})
    lines = boss45.data.decode().splitlines()
    assert "G91G00Y9." in lines and lines[lines.index("G91G00Y9.") + 1] == "G90"
    boss6 = export(rotary_part(), "tape-boss", {"rotary": "yes", "index-degrees": "25"})
    assert "G91G00Y1.25" in boss6.data.decode().splitlines()
    fed = export(
        rotary_part(),
        "tape-boss",
        {"rotary": "yes", "system": "boss45", "index-feed": "12", "index-radius": "4"},
    )
    assert "G91G01Y9.F171" in fed.data.decode().splitlines()


def test_y_motion_is_refused_when_y_drives_the_table() -> None:
    with pytest.raises(ExportError) as refused:
        export(rotary_part("2"), "tape-boss", {"rotary": "yes"})
    assert refused.value.report is not None
    errors = [str(e) for e in refused.value.report.entries if e.severity.value == "error"]
    assert errors[0] == (
        "error: block 1: moves in Y, but on this machine the Y output drives the rotary table"
    )


def test_index_without_a_rotary_is_reported() -> None:
    result = export(load("pos-index"), "tape-boss")
    assert "lost: block 1: INDEX: no rotary table (set rotary=yes)" in result.report.text()
