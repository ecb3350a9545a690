"""Calculated geometry, conrads and chamfers (issue 33; app/cnc/solve.py).

Every expected point below is worked out by hand from the print's dimensions (the
derivation beside it), never read from the solver, and compared to 0.0001 in (0.001 mm):
the golden programs (tests/golden/print-*) are the ones checked, so their files are pinned
by arithmetic, not only by a regenerated output. The property test at the end draws random
tangent chains, solves them, writes every point the solver found into the blocks (empty
values filled, tangency and radius dropped) and compiles both to the same tool path.
"""

from __future__ import annotations

import math
from dataclasses import replace
from decimal import Decimal as D
from pathlib import Path

from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from app.cnc import document
from app.cnc.blocks import (
    ArcEnd,
    Block,
    DataBlock0,
    Direction,
    Hole,
    HoleOp,
    MillArc,
    MillLine,
    MillQcir,
    Program,
    Tool,
)
from app.cnc.compiler import compile_program
from app.cnc.cutter import Finding
from app.cnc.formats.targets import export
from app.cnc.interpret import interpret
from app.cnc.problems import Severity
from app.cnc.sequences import programmed_contour
from app.cnc.solve import solve_contour
from app.cnc.structure import MillSequence, build_nodes
from app.cnc.toolpath import ArcFeed, Feed
from app.cnc.units import Units
from app.cnc.validate import validate

GOLDEN = Path(__file__).parent / "golden"
INCH = 25_400_000.0
MM = 1_000_000.0


def golden(name: str) -> Program:
    return document.loads((GOLDEN / name / "program.json").read_text(encoding="utf-8"))


def contour(program: Program) -> list[tuple[str, tuple[float, float], tuple[float, float] | None]]:
    """The finished contour of the program's first mill sequence: (tag, end, centre) per
    element, in the program's units."""
    unit = INCH if program.units is Units.INCH else MM
    node = next(n for n in build_nodes(program.blocks) if isinstance(n, MillSequence))
    drill = program.blocks[node.drill]
    assert isinstance(drill, Hole) and drill.x is not None and drill.y is not None
    start = (round(float(drill.x) * unit), round(float(drill.y) * unit))
    findings: list[Finding] = []
    path, _, _ = programmed_contour(program.blocks, node.mills, start, findings)
    assert not [f for f in findings if f.severity is Severity.ERROR], findings
    return [
        (
            e.tag,
            (e.end[0] / unit, e.end[1] / unit),
            None if e.centre is None else (e.centre[0] / unit, e.centre[1] / unit),
        )
        for e in path.elements
    ]


def near(got: tuple[float, float] | None, wanted: tuple[float, float], tol: float) -> bool:
    return got is not None and math.dist(got, wanted) <= tol


def test_arc_tangent_to_a_line_and_a_line_tangent_to_the_arc() -> None:
    """print-line-tangent-arc: MILL STD X0 Y0 → X3 Y0; ARC CC, TANGENT, RAD 1 (centre and
    end empty); MILL STD TANGENT to X0 Y3.

    Centre: on the left normal of the travel +X at X3 Y0, 1 from it: X3 Y1.
    Tangent point P from Q = (0, 3) to the circle C = (3, 1), r = 1: with v = Q − C =
    (−3, 2), |v|² = 13, P = C + (r²/13)·v ± (r·√12/13)·(2, 3) [the perpendicular of v]:
    P+ = C + ((−3 + 2√12)/13, (2 + 3√12)/13) = C + (3.9282032/13, 12.3923048/13), so
    P+ = (3.3021695, 1.9532542) and P− = (2.2362921, 0.3544381). The arc goes
    counter-clockwise from X3 Y0: it reaches P+ travelling toward Q (its travel there,
    (−0.9532545, 0.3021697), points up and left, to Q): the line leaves at P+.
    """
    elements = contour(golden("print-line-tangent-arc"))
    tol = 0.0001
    assert near(elements[0][1], (3.0, 0.0), tol)
    assert near(elements[1][2], (3.0, 1.0), tol)
    assert near(elements[1][1], (3.3021695, 1.9532542), tol)
    assert near(elements[2][1], (0.0, 3.0), tol)


def test_arc_tangent_to_arc_both_ways() -> None:
    """print-arc-tangent-arc-mm: ARC CC about X40 Y20 from X40 Y0 (end empty), then ARC C
    TANGENT about X80 Y20 (an S-bend: opposite turns), then ARC C TANGENT RAD 30 (centre
    empty: the same turn, inside it), end Y10 (X empty).

    S-bend: the tangent point is on the line of centres, 20 from X40 Y20 toward X80 Y20:
    X60 Y20 (there both arcs travel +Y). Same turn: at X80 Y40 the clockwise arc travels
    +X, so the tangent clockwise arc's centre is 30 to the right of that, X80 Y10; its
    end on Y10 is X80 ± 30, and turning clockwise from the top it reaches X110 first.
    """
    elements = contour(golden("print-arc-tangent-arc-mm"))
    tol = 0.001
    assert near(elements[1][2], (40.0, 20.0), tol) and near(elements[1][1], (60.0, 20.0), tol)
    assert near(elements[2][2], (80.0, 20.0), tol) and near(elements[2][1], (80.0, 40.0), tol)
    assert near(elements[3][2], (80.0, 10.0), tol) and near(elements[3][1], (110.0, 10.0), tol)


def test_intersections() -> None:
    """print-intersections: MILL STD Y0 (X empty) to where the ARC CC about X3 Y1, RAD 1.5
    starts; that arc ends (empty) where the ARC CC about X4.5 Y2.5, RAD 1 starts; that arc
    ends at Y3.5 (X empty).

    Line and circle: y = 0 meets (x − 3)² + 1 = 2.25 at x = 3 ± √1.25 = 3 ± 1.1180340;
    the line from X0 meets X1.8819660 first.
    Circle and circle: centres 2.1213203 apart (d), a = (2.25 − 1 + 4.5)/(2d) = 1.3552799
    along the line of centres from X3 Y1, h = √(2.25 − a²) = 0.6428191 across it: the
    middle X3.9583333 Y1.9583333 ± 0.4545369·(−1, 1): X3.5037964 Y2.4128702 and
    X4.4128702 Y1.5037964. From X1.882 Y0 (at −138.2° about X3 Y1) counter-clockwise the
    arc reaches the second (at 19.6°) before the first (at 70.4°).
    The second arc's end on Y3.5: its top, X4.5 Y3.5.
    """
    elements = contour(golden("print-intersections"))
    tol = 0.0001
    assert near(elements[0][1], (1.8819660, 0.0), tol)
    assert near(elements[1][1], (4.4128702, 1.5037964), tol)
    assert near(elements[2][1], (4.5, 3.5), tol)


def test_line_line_intersection_with_a_conrad() -> None:
    """print-line-line-mm: MILL STD at ANGLE 30 (end empty, CONRAD 10) to where the line at
    ANGLE 300 through X100 Y0 comes from.

    The triangle X0 Y0, apex, X100 Y0 has 30° at the origin and 60° at X100 Y0 (the second
    line arrives travelling −60°), so 90° at the apex, 100·cos 30° = 86.60254 from the
    origin: X75 Y43.30127. The conrad at that right angle: tangent points 10 back along the
    first line, X66.339746 Y38.30127, and 10 on along the second, X80 Y34.641016; centre
    10 right of both, X71.339746 Y29.641016 (a right turn: clockwise)."""
    elements = contour(golden("print-line-line-mm"))
    tol = 0.001
    assert [tag for tag, _, _ in elements] == ["", "conrad", "", ""]
    assert near(elements[0][1], (66.339746, 38.30127), tol)
    assert near(elements[1][1], (80.0, 34.641016), tol)
    assert near(elements[1][2], (71.339746, 29.641016), tol)
    assert near(elements[2][1], (100.0, 0.0), tol)
    values = {
        (n, name): float(v)
        for n, name, v in compile_program(golden("print-line-line-mm")).calculated
    }
    assert abs(values[(2, "x")] - 75.0) <= tol and abs(values[(2, "y")] - 43.30127) <= tol


def test_conrads_and_chamfer() -> None:
    """print-conrad-chamfer: X0 Y0 → X3 Y0 CONRAD 0.25 → X3 Y2 CHAMFER 0.2 → X1 Y2
    CONRAD 0.3 → ARC C about X0 Y2 to X0 Y1 CONRAD 0.2 → X0 Y0.

    Right angle, r 0.25: tangent points 0.25 from the corner, X2.75 Y0 and X3 Y0.25, about
    X2.75 Y0.25. Chamfer 0.2: X3 Y1.8 to X2.8 Y2.
    Line (travel −X along Y2) into the clockwise arc about X0 Y2, r 1 (travel −Y at X1 Y2),
    a left turn: the fillet's centre is below the line, 0.3 from it (Y1.7), and outside the
    arc's circle, 1 + 0.3 from X0 Y2: X = √(1.3² − 0.3²) = √1.6 = 1.2649111. Tangent
    points: X1.2649111 Y2 on the line, X0 Y2 + (1.2649111, −0.3)/1.3 = X0.9730085
    Y1.7692308 on the arc.
    Arc (travel −X at X0 Y1) into the line down X0, a left turn: centre 0.2 right of the
    line (X0.2) and 1.2 from X0 Y2: Y = 2 − √(1.44 − 0.04) = 0.8167840. Tangent points:
    X0 Y2 + (0.2, −1.1832160)/1.2 = X0.1666667 Y1.0139867 on the arc, X0 Y0.8167840 on the
    line.
    """
    elements = contour(golden("print-conrad-chamfer"))
    tags = [tag for tag, _, _ in elements]
    assert tags == ["", "conrad", "", "chamfer", "", "conrad", "", "conrad", ""]
    tol = 0.0001
    expected = [
        ((2.75, 0.0), None),
        ((3.0, 0.25), (2.75, 0.25)),
        ((3.0, 1.8), None),
        ((2.8, 2.0), None),
        ((1.2649111, 2.0), None),
        ((0.9730085, 1.7692308), (1.2649111, 1.7)),
        ((0.1666667, 1.0139867), (0.0, 2.0)),
        ((0.0, 0.8167840), (0.2, 0.8167840)),
        ((0.0, 0.0), None),
    ]
    for (_, end, centre), (wanted_end, wanted_centre) in zip(elements, expected, strict=True):
        assert near(end, wanted_end, tol), (end, wanted_end)
        if wanted_centre is not None:
            assert near(centre, wanted_centre, tol), (centre, wanted_centre)


def test_conrad_in_mm_keeps_the_tool_one_radius_from_the_fillet() -> None:
    """print-conrad-chamfer-mm, CUT RT with a 12 mm tool: the fillet at X75 Y0 (r 6, about
    X69 Y6) is cut with the tool centre on r 6 + 6 = 12 about the same centre."""
    program = golden("print-conrad-chamfer-mm")
    arcs = [m for m in interpret(program).moves if isinstance(m, ArcFeed) and m.tag == "conrad"]
    first = arcs[0]
    assert (first.cx, first.cy) == (69_000_000, 6_000_000)
    assert math.hypot(first.x - first.cx, first.y - first.cy) == 12_000_000


def test_events_write_the_conrad_as_cr_at_the_sharp_corner() -> None:
    """The Plus takes a conrad as CR on the event into the corner (seed 003 §2.2.4): the
    event ends at the corner X3 Y0, not at the tangent point; a chamfer has no CR and is
    written as its bevel, an event of its own."""
    text = export(golden("print-conrad-chamfer"), "events").data.decode()
    assert "N001 G101 XB0A YB0A XE3.0A YE0A TC1 F10.0 D0.5 CR0.25 T02;" in text
    assert "N003 G101 XB3.0A YB1.8A XE2.8A YE2.0A TC1 F10.0 D0.5 CR0 T02;" in text
    assert "N005 G102 XB1.0A YB2.0A XE0A YE1.0A XC0A YC2.0A F10.0 TC1 D0.5 CR0.2 T02;" in text


def test_gcode_writes_the_conrad_as_an_arc() -> None:
    """Other targets write the fillet itself: G-code has the arc between the tangent points
    (uncompensated here: the finished contour)."""
    program = golden("print-conrad-chamfer")
    flat = replace(
        program,
        blocks=tuple(
            replace(b, comp=b.comp.NONE) if isinstance(b, Hole) else b for b in program.blocks
        ),
    )
    text = export(flat, "gcode-linuxcnc").data.decode()
    assert "X2.7500" in text and "G3 X3.0000 Y0.2500 I0.0000 J0.2500" in text


def test_calculated_values_are_what_the_editor_shows() -> None:
    """The compile keeps each value it calculated, as the block would hold it."""
    compiled = compile_program(golden("print-line-tangent-arc"))
    values = {(number, name): float(v) for number, name, v in compiled.calculated}
    wanted = {(3, "x"): 3.0, (3, "y"): 1.0, (4, "x"): 3.3021695, (4, "y"): 1.9532542}
    assert values.keys() == wanted.keys()
    assert all(abs(values[k] - wanted[k]) <= 0.0000001 for k in wanted)


def test_a_typed_value_overrides_the_calculated_one() -> None:
    """Typing over a calculated value: the typed centre is used, and checked against the
    tangency (a centre off the normal is the tangency error)."""
    program = golden("print-line-tangent-arc")
    arc = program.blocks[2]
    assert isinstance(arc, MillArc)
    typed = replace(
        program, blocks=(*program.blocks[:2], replace(arc, x=D(3), y=D(1)), *program.blocks[3:])
    )
    assert [p for p in validate(typed) if p.severity is Severity.ERROR] == []
    off = replace(
        program, blocks=(*program.blocks[:2], replace(arc, x=D("3.1"), y=D(1)), *program.blocks[3:])
    )
    assert [str(p) for p in validate(off)] == [
        "block 3, TANGENT: a counter-clockwise arc tangent to the segment before it has its "
        "centre on the left of the travel, square to it; the centre X 3.100 in Y 1.000 in is "
        "not (leave the centre empty and give RAD, or give the centre on that normal)"
    ]


def test_every_consumer_sees_solved_geometry() -> None:
    """Preview (the canonical path), cycle time, Verify and every writer read the same
    solved contour: a program with the calculated points typed in compiles to the same
    moves."""
    program = golden("print-line-tangent-arc")
    compiled = compile_program(program)
    typed = _typed_in(program, {(n, name): v for n, name, v in compiled.calculated})
    assert list(interpret(program).moves) == list(interpret(typed).moves)


# -- random tangent chains ------------------------------------------------------------------


def _typed_in(program: Program, values: dict[tuple[int, str], D]) -> Program:
    """The program with every calculated value written in and nothing left to solve."""
    blocks: list[Block] = []
    for number, block in enumerate(program.blocks, start=1):
        changes: dict[str, object] = {}
        for name in ("x", "y"):
            if (number, name) in values:
                changes[name] = values[(number, name)]
        if isinstance(block, MillLine | MillArc):
            changes["tangent"] = False
        if isinstance(block, MillArc):
            changes["radius"] = None
        blocks.append(replace(block, **changes) if changes else block)  # type: ignore[arg-type]
    return replace(program, blocks=tuple(blocks))


def _tools() -> DataBlock0:
    return DataBlock0(
        current_tool=1, tools=(Tool(number=1, diameter=D("0.25"), rpm=1000, tcal=D(0)),)
    )


thousandths = st.integers(min_value=200, max_value=2000).map(lambda k: D(k).scaleb(-3))


@st.composite
def tangent_chains(draw: st.DrawFn) -> Program:
    """A DRILL, a first line, then 1-5 segments each tangent to the one before: tangent
    arcs given by RAD and one end coordinate (centre and the other coordinate empty), and
    tangent lines given one end coordinate."""
    blocks: list[Block] = [
        Hole(op=HoleOp.DRILL, x=D(0), y=D(0), z_up=D("0.1"), z_dn=D("-0.2"), feed_z=D(5), tool=1),
        MillLine(
            x=draw(thousandths),
            y=draw(st.sampled_from([D(0), D("0.5"), D("-0.5")])),
            feed_xy=D(10),
            tool=1,
        ),
    ]
    x, y = float(blocks[1].x or 0), float(blocks[1].y or 0)  # type: ignore[attr-defined]
    heading = math.atan2(y, x)
    for _ in range(draw(st.integers(min_value=1, max_value=5))):
        if draw(st.booleans()):
            radius = float(draw(thousandths))
            clockwise = draw(st.booleans())
            sweep = math.radians(draw(st.integers(min_value=15, max_value=160)))
            side = -1.0 if clockwise else 1.0
            cx = x - side * radius * math.sin(heading)
            cy = y + side * radius * math.cos(heading)
            start_angle = math.atan2(y - cy, x - cx)
            end_angle = start_angle - sweep if clockwise else start_angle + sweep
            ex, ey = cx + radius * math.cos(end_angle), cy + radius * math.sin(end_angle)
            given_x = draw(st.booleans())
            value = D(round(ex if given_x else ey, 3)).quantize(D("0.001"))
            blocks.append(
                MillArc(
                    direction=Direction.CW if clockwise else Direction.CCW,
                    x=None,
                    y=None,
                    radius=D(radius).quantize(D("0.001")),
                    tangent=True,
                    feed_xy=D(10),
                    tool=1,
                )
            )
            blocks.append(ArcEnd(x=value if given_x else None, y=None if given_x else value))
            x, y = ex, ey
            heading += -sweep if clockwise else sweep
        else:
            length = float(draw(thousandths))
            ex, ey = x + length * math.cos(heading), y + length * math.sin(heading)
            along_x = abs(math.cos(heading)) >= abs(math.sin(heading))
            value = D(round(ex if along_x else ey, 3)).quantize(D("0.001"))
            if not draw(st.booleans()):
                blocks.append(
                    MillLine(
                        x=value if along_x else None,
                        y=None if along_x else value,
                        tangent=True,
                        feed_xy=D(10),
                        tool=1,
                    )
                )
                x, y = ex, ey
                continue
            # The line's end left empty: where the tangent arc after it, whose centre the
            # print gives, touches it.
            radius = float(draw(thousandths))
            clockwise = draw(st.booleans())
            side = -1.0 if clockwise else 1.0
            centre_x = D(round(ex - side * radius * math.sin(heading), 3)).quantize(D("0.001"))
            centre_y = D(round(ey + side * radius * math.cos(heading), 3)).quantize(D("0.001"))
            blocks.append(MillLine(x=None, y=None, tangent=True, feed_xy=D(10), tool=1))
            direction = Direction.CW if clockwise else Direction.CCW
            blocks.append(
                MillArc(
                    direction=direction,
                    x=centre_x,
                    y=centre_y,
                    tangent=True,
                    feed_xy=D(10),
                    tool=1,
                )
            )
            # Its end a quarter turn on, given by the coordinate across the turn.
            cx, cy = float(centre_x), float(centre_y)
            t = (cx - x) * math.cos(heading) + (cy - y) * math.sin(heading)
            fx, fy = x + t * math.cos(heading), y + t * math.sin(heading)
            r = math.hypot(cx - fx, cy - fy)
            heading += -math.pi / 2 if clockwise else math.pi / 2
            ex = cx + r * math.cos(heading - side * math.pi / 2)
            ey = cy + r * math.sin(heading - side * math.pi / 2)
            along_x = abs(math.cos(heading)) >= abs(math.sin(heading))
            value = D(round(ex if along_x else ey, 3)).quantize(D("0.001"))
            blocks.append(ArcEnd(x=value if along_x else None, y=None if along_x else value))
            x, y = ex, ey
    return Program(name="CHAIN", block0=_tools(), blocks=tuple(blocks))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(tangent_chains())
def test_random_tangent_chains_solve_to_the_path_of_their_points(program: Program) -> None:
    node = next(n for n in build_nodes(program.blocks) if isinstance(n, MillSequence))
    solution = solve_contour(program.blocks, node.mills, (0, 0))
    # A value drawn at 0.001 in can put a nearly-tangent end just out of reach: that is the
    # error the print would get, not the property's business.
    assume(not solution.failed)
    compiled = compile_program(program)
    values = {(n, name): v for n, name, v in compiled.calculated}
    typed = _typed_in(program, values)
    assert all(
        getattr(b, "x", 0) is not None and getattr(b, "y", 0) is not None for b in typed.blocks
    )
    solved_moves = [m for m in interpret(program).moves if isinstance(m, Feed | ArcFeed)]
    typed_moves = [m for m in interpret(typed).moves if isinstance(m, Feed | ArcFeed)]
    assert solved_moves == typed_moves
    # And each joint is tangent, as the print says: the travel turns by less than 0.1°.
    path, _, _ = programmed_contour(program.blocks, node.mills, (0, 0))
    from app.cnc.plane import tangent

    starts = [path.start] + [e.end for e in path.elements[:-1]]
    for k in range(1, len(path.elements)):
        t1 = tangent(starts[k - 1], path.elements[k - 1], at_end=True)
        t2 = tangent(starts[k], path.elements[k], at_end=False)
        turn = abs(
            math.degrees(math.atan2(t1[0] * t2[1] - t1[1] * t2[0], t1[0] * t2[0] + t1[1] * t2[1]))
        )
        if k >= 2:
            assert turn < 0.1, (k, turn)


def _solve(*blocks: Block) -> tuple[dict[int, tuple[float, float]], list[str]]:
    """Solve a contour after a DRILL at X0 Y0 (inch): each segment's end, and the errors."""
    all_blocks = (Hole(op=HoleOp.DRILL, x=D(0), y=D(0), tool=1), *blocks)
    solution = solve_contour(all_blocks, tuple(range(1, len(all_blocks))), (0, 0))
    ends = {i + 1: (x / INCH, y / INCH) for i, (x, y) in solution.ends.items()}
    return ends, [f"block {f.block}, {f.field}: {f.message}" for f in solution.findings]


def test_tangent_line_and_quarter_circle_from_one_coordinate() -> None:
    """A line X0 Y0 → X1 Y1, then a MILL STD TANGENT given only Y3: along the 45° line, X3.
    A line X0 Y0 → X2 Y0, then a QCIR CC TANGENT given only X3: it starts along +X and turns
    left, so its centre is at X2 Y R and its end at X2 + R, Y R: R = 1, Y1."""
    feed = D(10)
    ends, errors = _solve(
        MillLine(x=D(1), y=D(1), feed_xy=feed, tool=1),
        MillLine(x=None, y=D(3), tangent=True, feed_xy=feed, tool=1),
    )
    assert errors == [] and near(ends[3], (3.0, 3.0), 0.0001)
    ends, errors = _solve(
        MillLine(x=D(2), y=D(0), feed_xy=feed, tool=1),
        MillQcir(direction=Direction.CCW, x=D(3), y=None, tangent=True, feed_xy=feed, tool=1),
    )
    assert errors == [] and near(ends[3], (3.0, 1.0), 0.0001)


def test_a_typed_quarter_circle_that_is_not_tangent_is_an_error() -> None:
    """From X2 Y0 travelling +X, a QCIR CC to X3 Y-1 turns about X3 Y0 and starts going
    −Y: not tangent."""
    feed = D(10)
    _, errors = _solve(
        MillLine(x=D(2), y=D(0), feed_xy=feed, tool=1),
        MillQcir(direction=Direction.CCW, x=D(3), y=D(-1), tangent=True, feed_xy=feed, tool=1),
    )
    assert errors == [
        "block 3, TANGENT: the QCIR to X 3.000 in Y -1.000 in starts 90.00° off the segment "
        "before it, so it is not tangent; leave X or Y empty to have its end calculated"
    ]


def test_the_document_keeps_zero_angles_and_leaves_out_what_is_not_set() -> None:
    """The print's fields are written only when set — but a line's ANGLE 0 and a BOLT CIR's
    angle 0 are values (0 == False in Python: the first writer dropped both, and a line's
    direction with it)."""
    from app.cnc.blocks import BoltCircle

    program = Program(
        name="ZERO",
        block0=_tools(),
        blocks=(
            Hole(
                op=HoleOp.DRILL, x=D(0), y=D(0), z_up=D("0.1"), z_dn=D("-0.2"), feed_z=D(5), tool=1
            ),
            BoltCircle(op=HoleOp.DRILL, holes=4, angle=D(0), radius=D(1)),
            Hole(
                op=HoleOp.DRILL, x=D(0), y=D(0), z_up=D("0.1"), z_dn=D("-0.2"), feed_z=D(5), tool=1
            ),
            MillLine(x=None, y=D(0), angle=D(0), feed_xy=D(10), tool=1),
            MillLine(x=D(2), y=D(1), feed_xy=D(10), tool=1),
        ),
    )
    text = document.dumps(program)
    assert document.loads(text) == program
    blocks = document.to_dict(program)["blocks"]
    assert blocks[1]["angle"] == 0 and blocks[3]["angle"] == 0 and blocks[3]["x"] is None
    assert "tangent" not in blocks[4] and "conrad" not in blocks[4] and "angle" not in blocks[4]


def test_a_conrad_before_a_depth_change_is_its_own_arc_event() -> None:
    """The Plus rounds a corner only between connected events, and an event before a Z DN
    change ends not connected (CR-): there the conrad is written as the arc itself, from
    X1.75 Y0 about X1.75 Y0.25 to X2 Y0.25 (radius 0.25 at the right angle X2 Y0)."""
    program = Program(
        name="Z",
        block0=_tools(),
        blocks=(
            Hole(
                op=HoleOp.DRILL, x=D(0), y=D(0), z_up=D("0.1"), z_dn=D("-0.2"), feed_z=D(5), tool=1
            ),
            MillLine(x=D(2), y=D(0), conrad=D("0.25"), feed_xy=D(10), tool=1),
            MillLine(x=D(2), y=D(2), z_dn=D("-0.3"), feed_xy=D(10), tool=1),
        ),
    )
    lines = export(program, "events").data.decode().splitlines()
    assert lines[2:5] == [
        "N001 G101 XB0A YB0A XE1.75A YE0A TC0 F10.0 D0.25 CR0 T01;",
        "N002 G103 XB1.75A YB0A XE2.0A YE0.25A XC1.75A YC0.25A F10.0 TC0 D0.25 CR- T01;",
        "N003 G101 XB2.0A YB0.25A XE2.0A YE2.0A TC0 F10.0 D0.25 CR- T01;",
    ]
