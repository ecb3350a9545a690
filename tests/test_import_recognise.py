"""Recognition: imported motion as the data blocks that make exactly that motion.

Each test gives motion (as G-code) and the blocks expected, worked out by hand — and the
near misses that must stay explicit blocks, because the blocks that would be shorter make
other motion (geometry is never invented).
"""

from __future__ import annotations

import math

from app.cnc.formats.reading import read_program
from app.cnc.formats.targets import export
from app.cnc.interpret import interpret
from app.cnc.units import Units
from tests.imports.support import GOLDEN, describe_all, deviation, load, xy_path

HEAD = "G20 G90 G17\nG43 H1\nS1000 M3\nG0 Z0.2\n"
CYCLE = "G98 G82 X{x:.4f} Y{y:.4f} R0.1 Z-0.5 P0.8 F5\n"


def blocks(text: str) -> list[str]:
    return describe_all(read_program(text.encode(), "t", "gcode").program)


def notes(text: str) -> list[str]:
    return [str(n) for n in read_program(text.encode(), "t", "gcode").report]


def holes(points: list[tuple[float, float]]) -> str:
    return HEAD + "".join(CYCLE.format(x=x, y=y) for x, y in points) + "G80\nM30\n"


def on_circle(cx: float, cy: float, r: float, degrees: list[float]) -> list[tuple[float, float]]:
    """Points at MillBlocks' bolt-circle angles θ (clockwise from below: (−sin θ, −cos θ))."""
    return [
        (cx - r * math.sin(math.radians(t)), cy - r * math.cos(math.radians(t))) for t in degrees
    ]


# -- bolt circles ---------------------------------------------------------------------------


def test_holes_equally_spaced_clockwise_are_a_bolt_circle() -> None:
    """Six holes 60° apart on R1.5 about X3 Y3, from θ = 30°, clockwise: BOLT CIR 6 x R1.5
    from 30°, the centre block not drilled (DESIGN.md §3)."""
    text = holes(on_circle(3, 3, 1.5, [30 + 60 * k for k in range(6)]))
    assert blocks(text) == ["DRILL X3 Y3 Z0.1/-0.5 F5 T1", "BOLT CIR DRILL 6 x R1.5 from 30"]


def test_counter_clockwise_holes_are_the_same_bolt_circle_reordered_and_reported() -> None:
    text = holes(on_circle(3, 3, 1.5, [30 - 60 * k for k in range(6)]))
    assert blocks(text) == ["DRILL X3 Y3 Z0.1/-0.5 F5 T1", "BOLT CIR DRILL 6 x R1.5 from 30"]
    assert any("counter-clockwise (the ProtoTRAK Plus's order)" in n for n in notes(text))


def test_holes_on_a_circle_but_not_all_round_it_stay_holes() -> None:
    """Four holes 30° apart on one circle: equally spaced, but a BOLT CIR spreads its holes
    over the whole circle (N holes 360°/N apart): four DRILL blocks."""
    text = holes(on_circle(0, 0, 1, [0, 30, 60, 90]))
    assert len(blocks(text)) == 4


def test_two_holes_are_not_a_bolt_circle() -> None:
    """Two holes lie on countless circles: they stay two DRILLs."""
    assert len(blocks(holes([(1, 0), (-1, 0)]))) == 2


def test_a_bolt_circle_then_another_with_other_depths() -> None:
    first = holes(on_circle(0, 0, 1, [0, 120, 240])).replace("G80\nM30\n", "")
    second = "".join(
        CYCLE.replace("Z-0.5", "Z-0.8").format(x=x, y=y)
        for x, y in on_circle(5, 0, 1, [0, 90, 180, 270])
    )
    assert blocks(first + second + "G80\nM30\n") == [
        "DRILL X0 Y0 Z0.1/-0.5 F5 T1",
        "BOLT CIR DRILL 3 x R1 from 0",
        "DRILL X5 Y0 Z0.1/-0.8 F5 T1",
        "BOLT CIR DRILL 4 x R1 from 0",
    ]


# -- LOOP / REP ---------------------------------------------------------------------------


def test_rows_of_holes_are_one_grid() -> None:
    """Three rows of four holes, 0.75 apart along X, rows 0.5 apart along Y, row by row (the
    control's order: NX inside NY, seed 001 REP): a LOOP DRILL and a REP NX3 NY2."""
    points = [(1 + 0.75 * i, 1 + 0.5 * j) for j in range(3) for i in range(4)]
    assert blocks(holes(points)) == [
        "INC LOOP DRILL X1 Y1 Z0.1/-0.5 F5 T1",
        "INC REP X0.75 Y0.5 NX3 NY2",
    ]


def test_columns_first_is_a_loop_in_a_loop() -> None:
    """Column by column (Y inside X) is not the REP's order: an outer LOOP along X around an
    inner one along Y; the outer LOOP needs its own block, a LOOP POS at the pattern's
    first point (reported)."""
    points = [(1 + 0.75 * i, 1 + 0.5 * j) for i in range(3) for j in range(4)]
    text = holes(points)
    assert blocks(text) == [
        "INC LOOP POS X1 Y1 T1",
        "INC LOOP DRILL X0 Y0 Z0.1/-0.5 F5 T1",
        "INC REP X0 Y0.5 NX0 NY3",
        "INC REP X0.75 Y0 NX2 NY0",
    ]
    assert any("a LOOP POS at the pattern's first point" in n for n in notes(text))


def test_a_diagonal_row_is_not_a_loop() -> None:
    """REP steps one axis per count: holes along a diagonal stay holes."""
    assert len(blocks(holes([(k * 0.5, k * 0.5) for k in range(5)]))) == 5


def test_a_loop_needs_one_tool() -> None:
    text = HEAD
    for k in range(4):
        text += f"T{1 + k % 2} M6\nG43 H{1 + k % 2}\nS1000 M3\n" + CYCLE.format(x=k, y=0)
    assert len(blocks(text + "M30\n")) == 4


def test_a_pattern_of_several_operations_repeats() -> None:
    """A hole and a short slot, repeated three times along X: the pattern is both."""
    pattern = (
        "G0 X{x:.4f} Y0\nZ0.1\nG1 Z-0.2 F5\nX{x2:.4f} F10\nG0 Z0.2\n"
        "G98 G82 X{x:.4f} Y1 R0.1 Z-0.5 P0.8 F5\nG80\n"
    )
    text = HEAD + "".join(pattern.format(x=2 * k, x2=2 * k + 1) for k in range(3)) + "M30\n"
    assert blocks(text) == [
        "INC LOOP DRILL X0 Y0 Z0.1/-0.2 F5 T1",
        "INC MILL STD X1 Y0 F10",
        "INC DRILL X-1 Y1 Z0.1/-0.5 F5 T1",
        "INC REP X2 Y0 NX2 NY0",
    ]


# -- mill sequences, routines ----------------------------------------------------------------


def test_a_quarter_circle_on_axis_parallel_centre_lines_is_a_qcir() -> None:
    """From X0 Y0 counter-clockwise about X1 Y0 to X1 Y1: 270°, an ARC; then about X1 Y2
    from its bottom to its right: a quarter on the centre lines, a QCIR (seed 001)."""
    text = HEAD + "G0 X0 Y0\nZ0.1\nG1 Z-0.2 F5\nG3 X1 Y1 I1 J0 F10\nG3 X2 Y2 I0 J1\nG0 Z0.2\nM30\n"
    assert blocks(text) == [
        "DRILL X0 Y0 Z0.1/-0.2 F5 T1",
        "MILL ARC CC XY-CENT X1 Y0 F10",
        "MILL ARC XY-END X1 Y1",
        "MILL QCIR CC X2 Y2 F10",
    ]


def test_pecked_mill_sequence_is_one_drill_with_pecks() -> None:
    """The same cuts at Z-0.2 and Z-0.5, re-entered at the level just cut: MillBlocks'
    peck levels from Z UP 0.1 to Z DN -0.5 in 2 (-0.2, -0.5)."""
    one = "G0 X0 Y0\nZ{up}\nG1 Z{z} F5\nX1 F8\nY1\nG0 Z0.2\n"
    text = HEAD + one.format(up="0.1", z="-0.2") + one.format(up="-0.2", z="-0.5") + "M30\n"
    assert blocks(text) == [
        "DRILL X0 Y0 Z0.1/-0.5 F5 x2 T1",
        "MILL STD X1 Y0 F8",
        "MILL STD X1 Y1 F8",
    ]


def test_routines_are_recognised_only_with_the_tool_diameter() -> None:
    """A CIRCLE INSIDE's cuts come back as the routine when the file gives the diameter
    (our set-up comment `T1 DIA …`, or G10 L1 R); the same cuts from a Fanuc file without
    it (another post's) stay a DRILL and its lines and arcs — and make the same path."""
    program = load(GOLDEN / "circle-inside")
    linuxcnc = read_program(export(program, "gcode-linuxcnc").data, "c").program
    text = export(program, "gcode-fanuc").data.decode()
    foreign = "\n".join(line for line in text.splitlines() if "SET-UP" not in line)
    fanuc = read_program(foreign.encode(), "c").program
    assert describe_all(linuxcnc) == describe_all(program)
    with_comments = read_program(text.encode(), "c").program
    assert describe_all(with_comments) == describe_all(program)
    assert [b.title for b in fanuc.blocks] == [
        "DRILL",
        "MILL STD",
        "MILL ARC CC XY-CENT",
        "MILL ARC XY-END",
        "MILL STD",
    ]
    path = xy_path(interpret(program))
    assert deviation(path, xy_path(interpret(linuxcnc))) == 0
    assert deviation(path, xy_path(interpret(fanuc))) == 0


def test_a_circle_that_no_routine_cuts_stays_explicit() -> None:
    """Down at the centre, out to the radius and round: no MillBlocks routine starts at the
    centre of a circle this size, so the blocks are the cuts."""
    text = (
        "G20\nG10 L1 P1 R0.25\nG43 H1\nS1000 M3\nG0 Z0.2\nX2 Y2\nZ0.1\nG1 Z-0.2 F4\n"
        "Y1.0 F9\nG3 X2 Y1 I0 J1\nG0 Z0.2\nM30\n"
    )
    program = read_program(text.encode(), "t", "gcode").program
    assert [b.title for b in program.blocks] == [
        "DRILL",
        "MILL STD",
        "MILL ARC CC XY-CENT",
        "MILL ARC XY-END",
    ]


def test_g20_decides_the_unit_of_every_block() -> None:
    """G20/G21 decides (issue 16, defect 8): X1.9685 Y0.3937 in an inch file are 50 mm and
    10 mm to 0.0001 in, but the file says inch, so the block is inch, rounded to 0.001 in,
    and the report says so — no guessed millimetre block (which turned an inch file's
    F5.0 into F5.0394)."""
    result = read_program((HEAD + "G0 X1.9685 Y0.3937\nM30\n").encode(), "t", "gcode")
    program = result.program
    assert describe_all(program) == ["POS X1.968 Y0.394 T1"]
    assert program.blocks[0].units is Units.INCH and program.units is Units.INCH
    notes = [str(n) for n in result.report]
    assert any("G20: the program and every block are inch" in n for n in notes)
    assert any("X 1.9685 in → 1.968, Y 0.3937 in → 0.394" in n for n in notes), notes


def test_a_2p_routine_with_pecks_comes_back_as_the_one_routine() -> None:
    """A CIR 2P POCKET with 2 pecks cuts its roughing pass at each peck level and the
    finishing pass after the last. Before: it came back as two routines, a one-pass CIRCLE
    0.010 in smaller at the first level and a CIR 2P whose DRILL had Z UP -0.098 (its
    retracts 0.1 in lower than the original's), the report saying the retract differs. Now
    the levels are MillBlocks' even pecks, so it is the one DRILL with 2 pecks and the CIR 2P,
    from G-code and from a 1704 tape alike."""
    original = load(GOLDEN / "circle-2p-pocket-pecks")
    for target, reader in (("gcode-linuxcnc", "gcode"), ("tape-ascii", "tape")):
        result = read_program(export(original, target).data, "p", reader)
        assert describe_all(result.program) == [
            "DRILL X2 Y2 Z0.1/-0.3 F4 x2 T2",
            "CIR 2P POCKET R1 F9 T2",
        ], target
        assert not any("above Z UP here" in str(n) for n in result.report), target
        assert result.program.block0.z_retract == original.block0.z_retract
