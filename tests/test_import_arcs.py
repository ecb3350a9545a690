"""No arc changes its sweep on import (issue 36, point 0).

An arc shorter than the import's rounding step (0.001 in) has its ends rounded onto one
point, and an arc from a point to the same point is a full circle: `G0 X3.7999 Y3.135` then
`G2 X3.8 Y3.135 I0.0001 J-0.135` (0.0001 in long, as rs274 reads it) came back as a 360°
circle, and our own 1704 tapes make such arcs where they split an arc at a quadrant line.
Every importer writes blocks through one builder (app/cnc/recognition/build.py), which now
keeps an arc only while rounding leaves its sweep within 10° of the file's; a shorter one
becomes a straight move, or is left out when its ends are one point — each reported.
"""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from app.cnc.blocks import ArcEnd, MillArc, MillQcir, PocketArc
from app.cnc.formats.reading import read_program
from app.cnc.interpret import interpret
from app.cnc.recognition.common import ImportFailure
from app.cnc.toolpath import ArcFeed

HEADER = "G20 G90 G17\nT1 M6\nG43 H1\nS1000 M3\nG0 X3.5 Y3.0 Z0.1\nG1 Z-0.1 F5\n"
FOOTER = "G1 X4.0 Y3.135\nG0 Z0.1\nM30\n"


def sweeps(program_text: bytes, name: str) -> tuple[list[float], str]:
    """The sweep (degrees) of every arc the imported program cuts, and the report."""
    result = read_program(program_text, name, None, None)
    toolpath = interpret(result.program)
    found = []
    at = toolpath.start[:2]
    for move in toolpath.moves:
        if isinstance(move, ArcFeed):
            a0 = math.atan2(at[1] - move.cy, at[0] - move.cx)
            a1 = math.atan2(move.y - move.cy, move.x - move.cx)
            turn = ((a0 - a1) if move.clockwise else (a1 - a0)) % (2 * math.pi)
            found.append(math.degrees(turn or 2 * math.pi))
        if hasattr(move, "x") and hasattr(move, "y"):
            at = (move.x, move.y)
    return found, result.text()


def test_a_tiny_gcode_arc_is_left_out_not_read_as_a_full_circle() -> None:
    """The issue's file: before, one MILL ARC of 360°; now no arc, and the report says
    which line was left out and why."""
    text = HEADER + "G1 X3.7999 Y3.135 F10\nG2 X3.8 Y3.135 I0.0001 J-0.135\n" + FOOTER
    found, report = sweeps(text.encode(), "tiny.ngc")
    assert found == []
    assert (
        "line 8: the arc to X 3.8000 Y 3.1350 (0.0001 in long, 0.04°): its ends are one "
        "point at the programming resolution, so it is left out" in report
    )


def test_a_tiny_arc_on_a_1704_tape_is_left_out_too() -> None:
    """A tape's arc split at a quadrant line leaves such a piece: the tape reader goes
    through the same builder."""
    tape = (
        "%\nN1G50X35000Y31350Z-10500M03\nN2Z-11500\nN3G00Z-12500F40\nN4G01X37999F100\n"
        "N5G02X38000Y31350I38000J30000\nN6G01X40000\nN7G00Z-12500\nN8G50Z-10500\nN9M05\n"
        "N10M30\n"
    )
    found, report = sweeps(tape.encode(), "tiny.tap")
    assert found == []
    assert "tape block 5 (N5, line 6): the arc to X 3.8000 Y 3.1350" in report


def test_a_nearly_full_circle_stays_a_full_circle() -> None:
    """359.9° whose ends round onto one point: the full circle it nearly was, not dropped."""
    text = HEADER + "G1 X3.8003 Y3.135 F10\nG2 X3.7997 Y3.135 I-0.0003 J-0.135\n" + FOOTER
    found, _ = sweeps(text.encode(), "nearly.ngc")
    assert len(found) == 1 and found[0] > 359


def test_an_arc_whose_rounding_would_turn_it_is_a_straight_move() -> None:
    """A half circle of 0.0006 in radius: its ends round to 0.001 in apart and its centre
    onto one of them, so no arc of the grid sweeps its 180°; it is written as the straight
    move between its rounded ends, and reported. (One of 0.0008 in rounds to a true half
    circle of 0.001 in and stays an arc.)"""
    text = HEADER + "G1 X3.8 Y3.135 F10\nG2 X3.8012 Y3.135 I0.0006 J0\n" + FOOTER
    result = read_program(text.encode(), "small.ngc", None, None)
    kinds = [type(b) for b in result.program.blocks]
    assert MillArc not in kinds and ArcEnd not in kinds and MillQcir not in kinds
    assert "so it is written as a straight move to its end" in result.text()


@settings(max_examples=200, deadline=None)
@given(
    radius=st.integers(1, 4000),  # 0.0001 to 0.4 in, in 0.0001 in steps
    start=st.floats(0, 2 * math.pi, allow_nan=False),
    turn=st.floats(0.0001, 2 * math.pi - 0.0001, allow_nan=False),
    clockwise=st.booleans(),
)
def test_an_imported_arc_keeps_its_sweep_or_is_no_arc(
    radius: int, start: float, turn: float, clockwise: bool
) -> None:
    """Arcs of every size and sweep, written to 0.0001 in as a CAM post writes them: each
    comes back sweeping within 10° of what the file says, or not as an arc at all (never a
    full circle from a short arc, never the other way round)."""
    r = radius / 10_000
    cx, cy = 2.0, 2.0
    sign = -1 if clockwise else 1
    x0, y0 = cx + r * math.cos(start), cy + r * math.sin(start)
    x1 = cx + r * math.cos(start + sign * turn)
    y1 = cy + r * math.sin(start + sign * turn)
    x0, y0, x1, y1 = (round(v, 4) for v in (x0, y0, x1, y1))
    if (x0, y0) == (x1, y1):
        return  # the file itself says a full circle
    i, j = round(cx - x0, 4), round(cy - y0, 4)
    g = "G2" if clockwise else "G3"
    text = (
        "G20 G90 G17\nT1 M6\nG43 H1\nS1000 M3\n"
        f"G0 X{x0:.4f} Y{y0:.4f} Z0.1\nG1 Z-0.1 F5\n"
        f"{g} X{x1:.4f} Y{y1:.4f} I{i:.4f} J{j:.4f} F10\nG0 Z0.1\nM30\n"
    )
    try:
        result = read_program(text.encode(), "arc.ngc", None, None)
    except ImportFailure as exc:  # an end off the radius by more than rs274 takes
        assert "radius" in str(exc), exc
        return
    # The sweep the file says, about the centre it gives (I, J from the start).
    centre = (x0 + i, y0 + j)
    a0 = math.atan2(y0 - centre[1], x0 - centre[0])
    a1 = math.atan2(y1 - centre[1], x1 - centre[0])
    before = math.degrees(((a0 - a1) if clockwise else (a1 - a0)) % (2 * math.pi) or 2 * math.pi)
    found, _ = sweeps(text.encode(), "arc.ngc")
    assert len(found) <= 1
    for after in found:
        assert abs(after - before) <= 10.0 + 1e-6, (before, after, text)
    assert not any(isinstance(b, PocketArc) for b in result.program.blocks)
