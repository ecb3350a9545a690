"""Expected values worked out by hand from seed 001 and DESIGN.md §3, not from the code.

Golden files only restate the code; these pin the behaviour. Each test writes its
derivation next to the numbers.
"""

from __future__ import annotations

import math
from decimal import Decimal as D
from fractions import Fraction
from pathlib import Path

import pytest

from app.cnc import document
from app.cnc.blocks import (
    BoltCircle,
    DataBlock0,
    Hole,
    HoleOp,
    Mode,
    Pos,
    Program,
    Rep,
    Tool,
)
from app.cnc.estimate import estimate
from app.cnc.interpret import interpret
from app.cnc.problems import has_errors
from app.cnc.toolpath import Dwell, Feed, Rapid, SpindleOn, Toolpath
from app.cnc.units import NM_PER_INCH, NM_PER_MM, Units
from app.cnc.validate import validate

GOLDEN = Path(__file__).parent / "golden"
INCH = NM_PER_INCH


def golden(name: str) -> Program:
    return document.loads((GOLDEN / name / "program.json").read_text(encoding="utf-8"))


def hole_bottoms(toolpath: Toolpath) -> list[tuple[int, int]]:
    """XY of every hole: the position at each dwell (DRILL and BORE dwell at the bottom)."""
    x, y = toolpath.start[0], toolpath.start[1]
    bottoms = []
    for move in toolpath.moves:
        if isinstance(move, Rapid | Feed):
            x, y = move.x, move.y
        elif isinstance(move, Dwell):
            bottoms.append((x, y))
    return bottoms


def inches(value: str) -> int:
    return int(Fraction(value) * INCH)


def test_twelve_peck_levels() -> None:
    """Z UP 0.05, Z DN -1.15, 12 pecks (seed 001 §3.4.5.2 PECK).

    The distance Z UP → Z DN is 1.2 in; divided by 12 pecks each level is 0.1 in deeper:
    -0.05, -0.15, …, -1.15 (the last at Z DN). Between levels the drill rapids up to Z UP
    (0.05) and rapids back down to the level just reached.
    """
    toolpath = interpret(golden("drill-12-pecks"))
    feeds = [m.z for m in toolpath.moves if isinstance(m, Feed)]
    expected = [inches("-0.05") - k * inches("0.1") for k in range(12)]
    assert feeds == expected
    assert feeds[-1] == inches("-1.15")
    rapids = [(m.z, m.tag) for m in toolpath.moves if isinstance(m, Rapid) and m.tag]
    assert rapids[:2] == [(inches("0.05"), "peck-retract"), (inches("-0.05"), "peck-reentry")]
    assert sum(1 for _, tag in rapids if tag == "peck-reentry") == 11


def test_two_pecks_first_is_half_way() -> None:
    """The manual's own example: two pecks, the first half the distance, the second at Z DN."""
    program = Program(
        name="two pecks",
        block0=DataBlock0(tools=(Tool(number=1, diameter=D("0.25"), rpm=1000, tcal=D(0)),)),
        blocks=(
            Hole(
                op=HoleOp.DRILL,
                x=D(0),
                y=D(0),
                z_up=D("0.1"),
                z_dn=D("-0.9"),
                feed_z=D(5),
                pecks=2,
                tool=1,
            ),
        ),
    )
    feeds = [m.z for m in interpret(program).moves if isinstance(m, Feed)]
    assert feeds == [inches("-0.4"), inches("-0.9")]


def test_bolt_circle_of_250_holes() -> None:
    """250 holes on R 5 in about (0, 0), angle 0 (seed 001 Fig. 3-3, DESIGN.md §3).

    Angle 0 is straight below the centre: hole 1 at (0, -5). Holes are 360/250 = 1.44°
    apart, taken clockwise seen from above, so hole 2 is to the left of hole 1 (x < 0) and
    slightly higher. Hole 126 (k = 125, 180°) is straight above the centre at (0, 5), and
    hole 1 + k mirrors hole 1 + (250 - k) about the vertical centre line. Every hole is
    5 in from the centre, and neighbours are a chord 2·5·sin(0.72°) = 0.125660 in apart.
    """
    program = Program(
        name="250 holes",
        block0=DataBlock0(tools=(Tool(number=1, diameter=D("0.125"), rpm=3000, tcal=D(0)),)),
        blocks=(
            Hole(
                op=HoleOp.DRILL,
                x=D(0),
                y=D(0),
                z_up=D("0.1"),
                z_dn=D("-0.1"),
                feed_z=D(10),
                tool=1,
            ),
            BoltCircle(op=HoleOp.DRILL, holes=250, angle=D(0), radius=D(5)),
        ),
    )
    assert not has_errors(validate(program))
    holes = hole_bottoms(interpret(program))
    assert len(holes) == 250, "the centre block is not drilled"
    r = 5 * INCH
    assert holes[0] == (0, -r)
    assert holes[125] == (0, r)
    assert holes[1][0] < 0 and holes[1][1] > -r
    for k in range(1, 125):
        assert holes[k][0] == -holes[250 - k][0] and holes[k][1] == holes[250 - k][1]
    for x, y in holes:
        assert abs(math.hypot(x, y) - r) <= 1  # within a nanometre
    chord = 2 * 5 * math.sin(math.radians(0.72))
    assert abs(chord - 0.125660) < 1e-6
    for a, b in zip(holes, holes[1:] + holes[:1], strict=True):
        assert abs(math.dist(a, b) / INCH - chord) < 1e-7  # two nanometre roundings


def test_bolt_circle_golden_angle_offset() -> None:
    """bolt-circle-250 starts at 0.01°: hole 1 at (-5·sin 0.01°, -5·cos 0.01°).

    5·sin(0.01°) = 5 × 0.000174533 = 0.000872665 in, 5·cos(0.01°) = 4.99999992 in.
    """
    holes = hole_bottoms(interpret(golden("bolt-circle-250")))
    assert len(holes) == 250
    assert abs(holes[0][0] / INCH - -0.000872665) < 1e-7  # rounded to the nanometre
    assert abs(holes[0][1] / INCH - -4.99999992) < 1e-7


def test_bolt_circle_six_holes_at_30_degrees() -> None:
    """Centre (3, 3), R 1.5, 6 holes from 30°: θ = 30, 90, 150, 210, 270, 330.

    Hole at θ is centre + R·(−sin θ, −cos θ):
    30° → (3 − 0.75, 3 − 1.299038) = (2.25, 1.700962); 90° → (1.5, 3);
    150° → (2.25, 4.299038); 210° → (3.75, 4.299038); 270° → (4.5, 3);
    330° → (3.75, 1.700962).
    """
    holes = hole_bottoms(interpret(golden("bolt-circle-drill")))
    expected = [
        (2.25, 1.700962),
        (1.5, 3.0),
        (2.25, 4.299038),
        (3.75, 4.299038),
        (4.5, 3.0),
        (3.75, 1.700962),
    ]
    assert len(holes) == 6
    for (x, y), (ex, ey) in zip(holes, expected, strict=True):
        assert abs(x / INCH - ex) < 1e-6 and abs(y / INCH - ey) < 1e-6


def test_rep_grid_row_by_row() -> None:
    """POS (1, 1), LOOP DRILL INC (0, 0), REP X 0.75 Y 0.5 NX 3 NY 2 (seed 001 Fig. 3-14).

    (NX + 1)(NY + 1) = 4 × 3 = 12 holes. For each Y increment the pattern runs at every X
    increment: row y = 1 at x = 1, 1.75, 2.5, 3.25, then row y = 1.5, then row y = 2.
    """
    holes = hole_bottoms(interpret(golden("loop-rep-grid")))
    xs = ["1", "1.75", "2.5", "3.25"]
    expected = [(inches(x), inches(y)) for y in ("1", "1.5", "2") for x in xs]
    assert holes == expected


def test_tap_feeds_out_to_three_tenths_above_z_up() -> None:
    """TAP Z UP 0.1: to Z DN -0.5 with no dwell, reverse, feed up to 0.1 + 0.3 = 0.4 in.

    Tool 3 turns at -400 RPM (counter-clockwise), so the reversal is clockwise and the
    original counter-clockwise direction is restored at the top.
    """
    toolpath = interpret(golden("tap-inch"))
    moves = toolpath.moves
    feeds = [m for m in moves if isinstance(m, Feed)]
    assert [m.z for m in feeds] == [inches("-0.5"), inches("0.4")]
    assert not any(isinstance(m, Dwell) for m in moves)
    spindle = [(m.clockwise, m.rpm) for m in moves if isinstance(m, SpindleOn)]
    assert spindle == [(False, 400), (True, 400), (False, 400)]
    i_down, i_up = moves.index(feeds[0]), moves.index(feeds[1])
    after_down, after_up = moves[i_down + 1], moves[i_up + 1]
    assert isinstance(after_down, SpindleOn) and after_down.clockwise
    assert isinstance(after_up, SpindleOn) and not after_up.clockwise


def test_metric_tap_feeds_out_7_62_mm() -> None:
    """Metric TAP Z UP 2 mm: feeds out to 2 + 7.62 = 9.62 mm above tool zero."""
    feeds = [m for m in interpret(golden("tap-metric")).moves if isinstance(m, Feed)]
    assert [m.z for m in feeds] == [-15 * NM_PER_MM, int(Fraction("9.62") * NM_PER_MM)]
    assert feeds[0].feed == 250 * NM_PER_MM


def test_retract_height_with_negative_z_up() -> None:
    """Z RET 0.1. Block 1 has Z UP -0.25: the retract height is 0.1 above tool zero (0.1),
    not above Z UP (which would be -0.15, inside the part). Block 2 has Z UP 0.2: 0.3.
    """
    toolpath = interpret(golden("drill-negative-z-up"))
    retracts = [(m.block, m.z) for m in toolpath.moves if isinstance(m, Rapid) and m.tag]
    assert retracts == [(1, inches("0.1")), (2, inches("0.3"))]
    xy_rapids = [m for m in toolpath.moves if isinstance(m, Rapid) and m.block == 1]
    assert min(m.z for m in xy_rapids if (m.x, m.y) != (0, 0)) >= inches("-0.25")


def test_cycle_time_on_paper() -> None:
    """drill-single: tool 1 in the spindle at (0, 0, 0.1); DRILL X1 Y1, Z UP 0.1, Z DN -0.5,
    FEEDR Z 5 ipm, Z RET 0.1, so the retract height is 0.2.

    rapid up 0.1 → 0.2: 0.1 in; rapid across to (1, 1): √2 = 1.414214 in; rapid down to
    Z UP: 0.1 in; feed 0.1 → -0.5: 0.6 in at 5 ipm = 7.2 s; dwell 0.8 s; rapid up
    -0.5 → 0.2: 0.7 in. Rapids 2.314214 in at 250 ipm = 0.555411 s.
    Total 7.2 + 0.8 + 0.555411 = 8.555411 s.
    """
    result = estimate(interpret(golden("drill-single")))
    assert result.cutting == pytest.approx(7.2, abs=1e-9)
    assert result.dwell == pytest.approx(0.8, abs=1e-9)
    assert result.rapid == pytest.approx(0.555411, abs=1e-6)
    assert result.total == pytest.approx(8.555411, abs=1e-6)
    assert result.per_tool == {1: pytest.approx(8.555411, abs=1e-6)}


def test_cycle_time_counts_tool_changes() -> None:
    """stop-and-tool-changes changes tools three times (1 → 2 → 4 → 3): 3 × 30 s."""
    result = estimate(interpret(golden("stop-and-tool-changes")))
    assert result.tool_changes == 3
    without = estimate(interpret(golden("stop-and-tool-changes")), tool_change_seconds=0)
    assert result.total - without.total == pytest.approx(90.0)
    assert [reason for _, reason in result.operator_waits] == ["STOP", "STOP"]


def _four_deep(units: Units, step: str) -> Program:
    """Four nested LOOP/REP pairs, 10 patterns each: 10 000 holes.

    Innermost steps X by `step` (NX 9), then Y by `step` (NY 9), then X by 10·step (NX 9),
    then Y by 10·step (NY 9).
    """
    s, s10 = D(step), D(step) * 10
    metric = units is Units.MM
    tools = (Tool(number=1, diameter=D(1), rpm=1000, tcal=D(0)),)

    def loop_pos() -> Pos:
        return Pos(mode=Mode.INC, units=units, x=D(0), y=D(0), tool=1, loop=True)

    drill = Hole(
        op=HoleOp.DRILL,
        mode=Mode.INC,
        units=units,
        x=D(0),
        y=D(0),
        z_up=D(1) if metric else D("0.05"),
        z_dn=D(-1) if metric else D("-0.05"),
        feed_z=D(100) if metric else D(50),
        tool=1,
        loop=True,
    )
    return Program(
        name="four deep",
        units=units,
        block0=DataBlock0(z_retract=D(1) if metric else D("0.05"), tools=tools),
        blocks=(
            Pos(x=D(1), y=D(2), tool=1, units=units),
            loop_pos(),
            loop_pos(),
            loop_pos(),
            drill,
            Rep(units=units, x=s, y=D(0), nx=9, ny=0),
            Rep(units=units, x=D(0), y=s, nx=0, ny=9),
            Rep(units=units, x=s10, y=D(0), nx=9, ny=0),
            Rep(units=units, x=D(0), y=s10, nx=0, ny=9),
        ),
    )


@pytest.mark.parametrize(("units", "step"), [(Units.INCH, "0.1"), (Units.MM, "0.3")])
def test_ten_thousand_patterns_land_exactly(units: Units, step: str) -> None:
    """Every hole of a 4-deep LOOP/REP of 10 000 patterns is where exact arithmetic puts it.

    Hole (a, b, c, d) (outermost d) is at (1, 2) + (a·s + c·10s, b·s + d·10s) with
    Fraction(step) arithmetic; floats summing 0.1 ten thousand times would drift.
    """
    program = _four_deep(units, step)
    assert not has_errors(validate(program))
    holes = hole_bottoms(interpret(program))
    assert len(holes) == 10_000
    s = Fraction(step)
    expected = [
        (Fraction(1) + a * s + c * 10 * s, Fraction(2) + b * s + d * 10 * s)
        for d in range(10)
        for c in range(10)
        for b in range(10)
        for a in range(10)
    ]
    unit = NM_PER_INCH if units is Units.INCH else NM_PER_MM
    actual = [(Fraction(x, unit), Fraction(y, unit)) for x, y in holes]
    assert actual == expected
