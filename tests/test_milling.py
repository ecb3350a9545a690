"""Milling geometry measured, not restated: distances, uncut area and travel direction.

The tool path is sampled here from the canonical moves (an independent walk over lines and
arcs), and the finished contour is built with shapely from the block values, so these tests
share no geometry code with app/cnc/plane.py, cutter.py, routines.py or sequences.py.
"""

from __future__ import annotations

import itertools
import math
from decimal import Decimal as D

import pytest
import shapely
from shapely.geometry import LineString, Point, Polygon

from app.cnc.blocks import (
    ArcEnd,
    Block,
    Circle,
    Comp,
    DataBlock0,
    Direction,
    Frame,
    Hole,
    HoleOp,
    MillArc,
    MillingMode,
    MillLine,
    MillQcir,
    Placement,
    Program,
    Tool,
)
from app.cnc.interpret import interpret
from app.cnc.problems import Severity
from app.cnc.toolpath import ArcFeed, Feed, Rapid, Toolpath
from app.cnc.units import NM_PER_INCH, NM_PER_MM, Units
from app.cnc.validate import validate

TOL_INCH = 0.0001
Pt = tuple[float, float]


# -- building programs ---------------------------------------------------------------------


def program(
    blocks: list[Block],
    dia: str = "0.5",
    rpm: int = 800,
    milling: MillingMode = MillingMode.CLIMB,
    units: Units = Units.INCH,
) -> Program:
    tool = Tool(number=2, diameter=D(dia), rpm=rpm, tcal=D(0))
    block0 = DataBlock0(
        current_tool=2,
        z_retract=D("0.1") if units is Units.INCH else D("2.5"),
        milling=milling,
        tools=(tool,),
    )
    p = Program(name="t", units=units, block0=block0, blocks=tuple(blocks))
    errors = [str(x) for x in validate(p) if x.severity is Severity.ERROR]
    assert errors == []
    return p


def drill(
    x: str, y: str, comp: Comp = Comp.NONE, pecks: int = 1, units: Units = Units.INCH
) -> Hole:
    metric = units is Units.MM
    return Hole(
        op=HoleOp.DRILL,
        units=units,
        x=D(x),
        y=D(y),
        z_up=D(2) if metric else D("0.1"),
        z_dn=D(-6) if metric else D("-0.25"),
        feed_z=D(120) if metric else D(5),
        pecks=pecks,
        tool=2,
        comp=comp,
    )


def line(x: str, y: str) -> MillLine:
    return MillLine(x=D(x), y=D(y), z_dn=D("-0.25"), feed_xy=D(10), tool=2)


def arc(direction: Direction, cx: str, cy: str, ex: str, ey: str) -> list[Block]:
    centre = MillArc(direction=direction, x=D(cx), y=D(cy), z_dn=D("-0.25"), feed_xy=D(10), tool=2)
    return [centre, ArcEnd(x=D(ex), y=D(ey))]


# -- sampling the tool path ------------------------------------------------------------------


def cutting_samples(
    toolpath: Toolpath, unit: int, z: float | None = None, tags: tuple[str, ...] = ("",)
) -> list[Pt]:
    """Points every ~0.002 unit along XY feed moves at depth `z` whose tag is in `tags`."""
    points: list[Pt] = []
    x, y, zc = (v / unit for v in toolpath.start)
    for move in toolpath.moves:
        if not isinstance(move, Rapid | Feed | ArcFeed):
            continue
        ex, ey, ez = move.x / unit, move.y / unit, move.z / unit
        wanted = (
            not isinstance(move, Rapid)
            and move.tag in tags
            and (z is None or abs(ez - z) < 1e-9)
            and abs(ez - zc) < 1e-9
        )
        if wanted and isinstance(move, Feed):
            n = max(1, math.ceil(math.dist((x, y), (ex, ey)) / 0.002))
            points += [(x + (ex - x) * i / n, y + (ey - y) * i / n) for i in range(n + 1)]
        elif wanted and isinstance(move, ArcFeed):
            cx, cy = move.cx / unit, move.cy / unit
            radius = math.dist((x, y), (cx, cy))
            a0 = math.atan2(y - cy, x - cx)
            a1 = math.atan2(ey - cy, ex - cx)
            turn = (a0 - a1) if move.clockwise else (a1 - a0)
            turn %= 2 * math.pi
            turn = turn or 2 * math.pi
            n = max(2, math.ceil(radius * turn / 0.002))
            sign = -1 if move.clockwise else 1
            points += [
                (
                    cx + radius * math.cos(a0 + sign * turn * i / n),
                    cy + radius * math.sin(a0 + sign * turn * i / n),
                )
                for i in range(n + 1)
            ]
        x, y, zc = ex, ey, ez
    return points


def arc_points(c: Pt, r: float, a0: float, turn: float, n: int = 4000) -> list[Pt]:
    return [
        (c[0] + r * math.cos(a0 + turn * i / n), c[1] + r * math.sin(a0 + turn * i / n))
        for i in range(n + 1)
    ]


def rounded_rect(x0: float, y0: float, w: float, h: float, cr: float) -> Polygon:
    if cr == 0:
        return Polygon([(x0, y0), (x0 + w, y0), (x0 + w, y0 + h), (x0, y0 + h)])
    pts: list[Pt] = []
    corners = [
        ((x0 + w - cr, y0 + cr), -math.pi / 2),
        ((x0 + w - cr, y0 + h - cr), 0.0),
        ((x0 + cr, y0 + h - cr), math.pi / 2),
        ((x0 + cr, y0 + cr), math.pi),
    ]
    for c, a0 in corners:
        pts += arc_points(c, cr, a0, math.pi / 2, 500)
    return Polygon(pts)


def assert_distance(points: list[Pt], contour: LineString, expected: float, tol: float) -> None:
    assert points, "no cutting moves found"
    distances = [contour.distance(Point(p)) for p in points]
    assert min(distances) == pytest.approx(expected, abs=tol)
    assert max(distances) == pytest.approx(expected, abs=tol)


# -- compensated contours ------------------------------------------------------------------


CONTOURS: dict[str, tuple[Comp, list[Block], LineString]] = {
    # name: (comp, mill blocks after DRILL at (0, 0), shapely contour of the finished surface)
    "left-square-outside-corners": (
        Comp.RIGHT,
        [line("2", "0"), line("2", "1.5"), line("0", "1.5"), line("0", "0")],
        LineString([(0, 0), (2, 0), (2, 1.5), (0, 1.5), (0, 0)]),
    ),
    "inside-corners": (
        Comp.LEFT,
        [line("2", "0"), line("2", "1.5"), line("0", "1.5")],
        LineString([(0, 0), (2, 0), (2, 1.5), (0, 1.5)]),
    ),
    "line-qcir-line-blended": (
        Comp.RIGHT,
        [
            line("2", "0"),
            MillQcir(
                direction=Direction.CCW,
                x=D("2.5"),
                y=D("0.5"),
                z_dn=D("-0.25"),
                feed_xy=D(10),
                tool=2,
            ),
            line("2.5", "1.5"),
        ],
        LineString(
            [(0, 0), (2, 0), *arc_points((2, 0.5), 0.5, -math.pi / 2, math.pi / 2), (2.5, 1.5)]
        ),
    ),
    "arc-outside-then-line": (
        Comp.LEFT,
        [line("1", "0"), *arc(Direction.CW, "1", "-1", "2", "-1"), line("2", "-2")],
        LineString([(0, 0), (1, 0), *arc_points((1, -1), 1, math.pi / 2, -math.pi / 2), (2, -2)]),
    ),
}


@pytest.mark.parametrize("name", sorted(CONTOURS))
def test_compensated_contour_stays_one_radius_from_the_part(name: str) -> None:
    comp, mills, contour = CONTOURS[name]
    toolpath = interpret(program([drill("0", "0", comp=comp), *mills], dia="0.5"))
    points = cutting_samples(toolpath, NM_PER_INCH, z=-0.25)
    assert_distance(points, contour, 0.25, TOL_INCH)


def test_compensation_side_is_right_or_left_of_travel() -> None:
    """Along +X, CUT RT puts the tool centre at y = -r, CUT LT at y = +r."""
    for comp, expected_y in ((Comp.RIGHT, -0.25), (Comp.LEFT, 0.25)):
        toolpath = interpret(program([drill("0", "0", comp=comp), line("2", "0")]))
        points = cutting_samples(toolpath, NM_PER_INCH, z=-0.25)
        assert {round(y, 6) for _, y in points} == {expected_y}


def test_compensated_plunge_is_offset_from_the_drill_point() -> None:
    """Reading: the tool goes down at the start of the first offset element."""
    toolpath = interpret(program([drill("0", "0", comp=Comp.RIGHT), line("2", "0")]))
    plunge = next(m for m in toolpath.moves if isinstance(m, Feed) and m.z < 0)
    assert (plunge.x, plunge.y) == (0, -NM_PER_INCH // 4)


# -- CIRCLE and FRAME routines --------------------------------------------------------------


def routine_program(
    routine: Block,
    units: Units = Units.INCH,
    milling: MillingMode = MillingMode.CLIMB,
    rpm: int = 800,
    dia: str = "0.5",
    pecks: int = 1,
) -> Program:
    x, y = ("1", "1") if units is Units.INCH else ("25", "25")
    return program(
        [drill(x, y, pecks=pecks, units=units), routine],
        dia=dia,
        rpm=rpm,
        milling=milling,
        units=units,
    )


INSIDE = (Placement.INSIDE, Placement.IN_TAN, Placement.POCKET)


def circle(
    placement: Placement, radius: str = "1", units: Units = Units.INCH, two_pass: bool = False
) -> Circle:
    feed = D(200) if units is Units.MM else D(8)
    return Circle(
        placement=placement, radius=D(radius), feed_xy=feed, tool=2, units=units, two_pass=two_pass
    )


def frame(
    placement: Placement,
    cr: str = "0.5",
    units: Units = Units.INCH,
    two_pass: bool = False,
    xl: str = "3",
    yw: str = "2",
) -> Frame:
    feed = D(200) if units is Units.MM else D(8)
    return Frame(
        placement=placement,
        xl=D(xl),
        yw=D(yw),
        corner_radius=D(cr),
        feed_xy=feed,
        tool=2,
        units=units,
        two_pass=two_pass,
    )


@pytest.mark.parametrize("placement", [p for p in Placement if p is not Placement.POCKET])
@pytest.mark.parametrize("shape", ["circle", "frame", "sharp-frame"])
def test_routine_wall_pass_is_one_radius_from_the_surface(placement: Placement, shape: str) -> None:
    inside = placement in INSIDE
    if shape == "circle":
        toolpath = interpret(routine_program(circle(placement)))
        contour = Point(1, 1).buffer(1, quad_segs=2048).exterior
    else:
        cr = "0.5" if shape == "frame" or inside else "0"
        if shape == "sharp-frame" and inside:
            cr = "0.25"  # the tool radius: the smallest corner an inside pass reaches
        toolpath = interpret(routine_program(frame(placement, cr=cr)))
        contour = rounded_rect(1, 1, 3, 2, float(cr)).exterior
    points = cutting_samples(toolpath, NM_PER_INCH, z=-0.25)
    assert_distance(points, contour, 0.25, TOL_INCH)
    region = Polygon(contour)
    assert all(region.contains(Point(p)) == inside for p in points)


@pytest.mark.parametrize("shape", ["circle", "frame"])
@pytest.mark.parametrize("placement", [Placement.INSIDE, Placement.OUTSIDE])
def test_plunge_is_an_eighth_inch_away_and_backs_off_the_same_way(
    shape: str, placement: Placement
) -> None:
    routine = circle(placement) if shape == "circle" else frame(placement)
    toolpath = interpret(routine_program(routine))
    contour = (
        Point(1, 1).buffer(1, quad_segs=2048).exterior
        if shape == "circle"
        else rounded_rect(1, 1, 3, 2, 0.5).exterior
    )
    lead_in = cutting_samples(toolpath, NM_PER_INCH, z=-0.25, tags=("lead-in",))
    lead_out = cutting_samples(toolpath, NM_PER_INCH, z=-0.25, tags=("lead-out",))
    # The tool edge is 0.125 in from the finished surface: its centre 0.125 + r away.
    assert contour.distance(Point(lead_in[0])) == pytest.approx(0.375, abs=TOL_INCH)
    assert contour.distance(Point(lead_in[-1])) == pytest.approx(0.25, abs=TOL_INCH)
    assert lead_out[-1] == pytest.approx(lead_in[0])
    # A straight move in, perpendicular to the surface: every point on one normal line.
    assert len({round(x, 9) for x, _ in lead_in}) == 1


@pytest.mark.parametrize("shape", ["circle", "frame"])
@pytest.mark.parametrize("placement", [Placement.IN_TAN, Placement.OUT_TAN])
def test_tangent_entry_and_exit(shape: str, placement: Placement) -> None:
    """The lead arcs meet the wall pass with the same direction of travel (no kink)."""
    routine = circle(placement) if shape == "circle" else frame(placement)
    toolpath = interpret(routine_program(routine))
    lead_in = cutting_samples(toolpath, NM_PER_INCH, z=-0.25, tags=("lead-in",))
    wall = cutting_samples(toolpath, NM_PER_INCH, z=-0.25)
    lead_out = cutting_samples(toolpath, NM_PER_INCH, z=-0.25, tags=("lead-out",))

    def direction(a: Pt, b: Pt) -> Pt:
        d = math.dist(a, b)
        return ((b[0] - a[0]) / d, (b[1] - a[1]) / d)

    into = direction(lead_in[-2], lead_in[-1])
    along = direction(wall[0], wall[1])
    assert math.degrees(math.acos(min(1.0, into[0] * along[0] + into[1] * along[1]))) < 1.0
    leaving = direction(wall[-2], wall[-1])
    out = direction(lead_out[0], lead_out[1])
    assert math.degrees(math.acos(min(1.0, leaving[0] * out[0] + leaving[1] * out[1]))) < 1.0
    contour = (
        Point(1, 1).buffer(1, quad_segs=2048).exterior
        if shape == "circle"
        else rounded_rect(1, 1, 3, 2, 0.5).exterior
    )
    # The lead arcs never come closer to the part than the wall pass does.
    assert min(contour.distance(Point(p)) for p in lead_in + lead_out) >= 0.25 - TOL_INCH


def signed_area(points: list[Pt]) -> float:
    return sum(a[0] * b[1] - b[0] * a[1] for a, b in itertools.pairwise(points)) / 2


@pytest.mark.parametrize("placement", [Placement.INSIDE, Placement.OUTSIDE])
@pytest.mark.parametrize("milling", list(MillingMode))
@pytest.mark.parametrize("rpm", [800, -800])
@pytest.mark.parametrize("shape", ["circle", "frame"])
def test_direction_follows_climb_conventional_and_spindle(
    placement: Placement, milling: MillingMode, rpm: int, shape: str
) -> None:
    """Climb with a clockwise spindle: outside clockwise, inside counter-clockwise
    (positive signed area); conventional reverses it; a negative RPM reverses it again."""
    routine = circle(placement) if shape == "circle" else frame(placement)
    toolpath = interpret(routine_program(routine, milling=milling, rpm=rpm))
    area = signed_area(cutting_samples(toolpath, NM_PER_INCH, z=-0.25))
    counter_clockwise = placement is Placement.INSIDE
    if milling is MillingMode.CONVENTIONAL:
        counter_clockwise = not counter_clockwise
    if rpm < 0:
        counter_clockwise = not counter_clockwise
    assert (area > 0) == counter_clockwise


# -- pockets ---------------------------------------------------------------------------------


def swept(toolpath: Toolpath, unit: int, radius: float, z: float) -> shapely.Geometry:
    points = cutting_samples(toolpath, unit, z=z, tags=("", "lead-in", "step-over", "corner"))
    return LineString(points).buffer(radius, quad_segs=64)


@pytest.mark.parametrize(
    ("shape", "cr", "dia"),
    [
        ("circle", "0", "0.5"),
        ("circle", "0", "0.375"),
        ("frame", "0.5", "0.5"),
        ("frame", "0", "0.5"),
        ("frame", "0.1", "0.25"),
        ("tall-frame", "0.3", "0.375"),
    ],
)
def test_pocket_leaves_nothing_a_round_tool_can_reach(shape: str, cr: str, dia: str) -> None:
    """The pocket minus the swept area holds no circle wider than 0.001 in, except the
    corners a round tool cannot reach (a corner radius below the tool radius)."""
    r = float(dia) / 2
    if shape == "circle":
        routine: Block = circle(Placement.POCKET, radius="1.2")
        pocket = Point(1, 1).buffer(1.2, quad_segs=2048)
    elif shape == "frame":
        routine = frame(Placement.POCKET, cr=cr)
        pocket = rounded_rect(1, 1, 3, 2, float(cr))
    else:
        routine = frame(Placement.POCKET, cr=cr, xl="1.5", yw="3.2")
        pocket = rounded_rect(1, 1, 1.5, 3.2, float(cr))
    toolpath = interpret(routine_program(routine, dia=dia))
    cut = swept(toolpath, NM_PER_INCH, r, z=-0.25)
    reachable = pocket.buffer(-r, quad_segs=64).buffer(r, quad_segs=64)
    exempt = pocket.difference(reachable)
    left = pocket.difference(cut).difference(exempt.buffer(0.0002))
    assert left.buffer(-0.0005).is_empty, f"uncut area {left.area:.6f} in²"
    assert cut.difference(pocket.buffer(1e-4)).area < 1e-6, "the pocket cuts outside its wall"
    if float(cr) < r and shape != "circle":
        assert exempt.area > 0


def test_pocket_passes_overlap_by_fifty_thousandths() -> None:
    """A 1.2 in radius pocket with a 0.5 in tool: passes at radius 0.95, 0.5, 0.05 in
    (step = 0.5 - 0.05 = 0.45), each circle overlapping the last by 0.050 in."""
    toolpath = interpret(routine_program(circle(Placement.POCKET, radius="1.2")))
    radii = sorted(
        {
            round(math.dist((m.cx, m.cy), (m.x, m.y)) / NM_PER_INCH, 6)
            for m in toolpath.moves
            if isinstance(m, ArcFeed) and m.tag == "" and (m.cx, m.cy) == (NM_PER_INCH,) * 2
        }
    )
    assert radii == [0.05, 0.5, 0.95]


# -- two-pass -------------------------------------------------------------------------------


@pytest.mark.parametrize("placement", [Placement.INSIDE, Placement.OUTSIDE, Placement.IN_TAN])
def test_two_pass_roughs_ten_thou_off_and_five_thou_up(placement: Placement) -> None:
    toolpath = interpret(routine_program(circle(placement, two_pass=True)))
    contour = Point(1, 1).buffer(1, quad_segs=2048).exterior
    rough = cutting_samples(toolpath, NM_PER_INCH, z=-0.245)
    finish = cutting_samples(toolpath, NM_PER_INCH, z=-0.25)
    assert_distance(rough, contour, 0.26, TOL_INCH)
    assert_distance(finish, contour, 0.25, TOL_INCH)
    feeds = {m.feed for m in toolpath.moves if isinstance(m, Feed | ArcFeed) and m.block == 2}
    assert feeds == {8 * NM_PER_INCH}, "the finishing pass runs at the same feed"


def test_two_pass_pocket_is_cleared_twice() -> None:
    toolpath = interpret(routine_program(circle(Placement.POCKET, radius="1.2", two_pass=True)))
    pocket = Point(1, 1).buffer(1.2, quad_segs=2048)
    for z in (-0.245, -0.25):
        cut = swept(toolpath, NM_PER_INCH, 0.25, z=z)
        left = pocket.difference(cut)
        wall_stock = 0.01 if z > -0.25 else 0.0
        assert left.buffer(-(wall_stock + 0.0005)).is_empty


def test_pecks_run_the_whole_routine_at_each_level() -> None:
    """Two pecks from Z UP 0.1 to Z DN -0.25: the wall pass at -0.075 and at -0.25."""
    toolpath = interpret(routine_program(circle(Placement.INSIDE), pecks=2))
    laps = [m.z for m in toolpath.moves if isinstance(m, ArcFeed) and m.tag == ""]
    assert laps == [round(-0.075 * NM_PER_INCH), round(-0.25 * NM_PER_INCH)]
    reentries = [m for m in toolpath.moves if isinstance(m, Rapid) and m.tag == "peck-reentry"]
    assert [m.z for m in reentries] == [round(-0.075 * NM_PER_INCH)]


def test_metric_routine_uses_metric_constants() -> None:
    """Metric: plunge 3.18 mm from the wall, roughing 0.25 mm off the wall, 0.13 mm up."""
    routine = circle(Placement.INSIDE, radius="20", units=Units.MM, two_pass=True)
    toolpath = interpret(routine_program(routine, units=Units.MM, dia="10"))
    contour = Point(25, 25).buffer(20, quad_segs=2048).exterior
    rough = cutting_samples(toolpath, NM_PER_MM, z=-5.87)
    finish = cutting_samples(toolpath, NM_PER_MM, z=-6)
    assert_distance(rough, contour, 5.25, 0.001)
    assert_distance(finish, contour, 5.0, 0.001)
    lead_in = cutting_samples(toolpath, NM_PER_MM, z=-6, tags=("lead-in",))
    assert contour.distance(Point(lead_in[0])) == pytest.approx(5 + 3.18, abs=0.001)
