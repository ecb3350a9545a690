"""Irregular pockets with islands, measured with shapely (issue 22).

The planner works with pyclipper; these tests sample its passes independently and measure
the pocket with shapely (GEOS): the union of the swept tool (each pass and link buffered by
the tool radius) must leave nothing inside the boundary minus the islands that a round tool
of that diameter could reach (≤ 0.001 in), and must cut nothing of an island or outside the
wall (≤ 0.0001 in).
"""

from __future__ import annotations

import gc
import math
import types
from collections.abc import Sequence

import pyclipper
import pytest
import shapely
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from shapely.geometry import LineString, Point, Polygon

from app.cnc import plane, sizes
from app.cnc.blocks import MillingMode
from app.cnc.plane import Element, Path, sample
from app.cnc.pocketing import (
    LinkKind,
    PassKind,
    PocketIssue,
    PocketPlan,
    nearest,
    pass_levels,
    plan_pocket,
    regions,
)
from app.cnc.pocketing import plan as plan_module
from app.cnc.pocketing.plan import RESIDUE_NM, _closest_on_element, _way_round
from app.cnc.problems import Severity

IN = 25_400_000
REACH_TOL = 25_400  # 0.001 in: uncut material a round tool could reach
GOUGE_TOL = 2_540  # 0.0001 in: material cut from an island or beyond the wall
Pt = tuple[float, float]


# -- contours ------------------------------------------------------------------------------


def polygon_path(points: list[Pt], block: int = 1) -> Path:
    """A closed contour of lines through `points` (nm)."""
    elements = [Element(block + k, p) for k, p in enumerate([*points[1:], points[0]])]
    return Path(points[0], tuple(elements))


def rect(x0: float, y0: float, x1: float, y1: float, block: int = 1) -> Path:
    return polygon_path([(x0, y0), (x1, y0), (x1, y1), (x0, y1)], block)


def circle(cx: float, cy: float, radius: float, block: int = 20) -> Path:
    start = (cx, cy - radius)
    return Path(start, (Element(block, start, centre=(cx, cy)),))


def obround(x0: float, x1: float, cy: float, half: float, block: int = 30) -> Path:
    """A slot shape: two lines and two half circles (counter-clockwise)."""
    return Path(
        (x0, cy - half),
        (
            Element(block, (x1, cy - half)),
            Element(block + 1, (x1, cy + half), centre=(x1, cy)),
            Element(block + 2, (x0, cy + half)),
            Element(block + 3, (x0, cy - half), centre=(x0, cy)),
        ),
    )


# -- an independent walk over the passes ------------------------------------------------------


def points_of(path: Path) -> list[Pt]:
    """Points along a path: line ends, and arcs walked by angle in steps of 0.002 rad (chords
    within 0.5 ppm of the radius of the arc: 16 nm on a 1.25 in radius)."""
    points = [path.start]
    x, y = path.start
    for e in path.elements:
        if e.centre is None:
            points.append(e.end)
        else:
            cx, cy = e.centre
            radius = math.dist((x, y), (cx, cy))
            a0 = math.atan2(y - cy, x - cx)
            a1 = math.atan2(e.end[1] - cy, e.end[0] - cx)
            turn = (a0 - a1) if e.clockwise else (a1 - a0)
            turn %= 2 * math.pi
            turn = turn or 2 * math.pi
            n = max(8, math.ceil(turn / 0.002))
            sign = -1 if e.clockwise else 1
            points += [
                (
                    cx + radius * math.cos(a0 + sign * turn * i / n),
                    cy + radius * math.sin(a0 + sign * turn * i / n),
                )
                for i in range(1, n + 1)
            ]
            points[-1] = e.end
        x, y = e.end
    return points


def shape(path: Path) -> Polygon:
    return Polygon(points_of(path))


def pocket_region(boundary: Path, islands: list[Path]) -> shapely.Geometry:
    region = shape(boundary)
    for island in islands:
        region = region.difference(shape(island))
    return region


def swept(plan: PocketPlan, r: float) -> shapely.Geometry:
    """The tool buffered along every element of every pass and link, one element at a time
    (GEOS can lose area buffering a line that doubles back on itself, like a cleanup move)."""
    pieces = []
    for p in plan.passes:
        for path in (p.entry.path, p.path):
            pieces.append(Point(path.start).buffer(r, quad_segs=128))
            start = path.start
            for element in path.elements:
                pts = points_of(Path(start, (element,)))
                pieces.append(LineString(pts).buffer(r, quad_segs=128))
                start = element.end
    return shapely.union_all(pieces)


def measure(plan: PocketPlan, boundary: Path, islands: list[Path], r: float) -> tuple[float, float]:
    """(area of reachable material left uncut beyond 0.001 in, area cut beyond 0.0001 in
    outside the region), in nm²."""
    region = pocket_region(boundary, islands)
    reachable = region.buffer(-r, quad_segs=128).buffer(r, quad_segs=128)
    cut = swept(plan, r)
    uncut = reachable.difference(cut.buffer(REACH_TOL, quad_segs=64))
    gouge = cut.difference(region.buffer(GOUGE_TOL, quad_segs=128))
    return uncut.area, gouge.area


def assert_pocket(plan: PocketPlan, boundary: Path, islands: list[Path], r: float) -> None:
    assert not plan.has_errors, [f.message for f in plan.findings]
    uncut, gouge = measure(plan, boundary, islands, r)
    # A square 0.0001 in on a side is 6.45e6 nm²; a sliver of float noise is far less.
    assert uncut < 1e4, f"uncut material: {uncut / IN**2:.3g} in²"
    assert gouge < 1e4, f"cut outside the region: {gouge / IN**2:.3g} in²"


def plan(boundary: Path, islands: list[Path], r: float, **options: object) -> PocketPlan:
    return plan_pocket(
        boundary,
        islands,
        tool_radius=round(r),
        step_over=options.pop("step_over", round(1.2 * r)),  # type: ignore[arg-type]
        finish_allowance=options.pop("finish_allowance", 254_000),  # type: ignore[arg-type]
        **options,  # type: ignore[arg-type]
    )


# -- hand-made cases --------------------------------------------------------------------------

R = IN // 4  # a 0.5 in end mill


def rectangle_with_round_island() -> tuple[Path, list[Path]]:
    return rect(0, 0, 4 * IN, 3 * IN), [circle(2 * IN, 1.5 * IN, IN / 2)]


def l_shape_with_two_islands() -> tuple[Path, list[Path]]:
    boundary = polygon_path(
        [(0, 0), (5 * IN, 0), (5 * IN, 2 * IN), (2 * IN, 2 * IN), (2 * IN, 5 * IN), (0, 5 * IN)]
    )
    islands = [
        rect(3 * IN, 0.6 * IN, 3.8 * IN, 1.3 * IN, block=10),
        circle(1 * IN, 3.5 * IN, 0.4 * IN, block=20),
    ]
    return boundary, islands


def arc_bounded_boss() -> tuple[Path, list[Path]]:
    """A round-ended pocket with a round-ended boss in it, and a bulge arc on one side."""
    boundary = Path(
        (0, 0),
        (
            Element(1, (4 * IN, 0)),
            Element(2, (4 * IN, 2 * IN), centre=(4 * IN, 1 * IN)),
            Element(3, (2.5 * IN, 2 * IN)),
            # A shallow arc bulging into the pocket (clockwise in a counter-clockwise wall).
            Element(4, (1.5 * IN, 2 * IN), centre=(2 * IN, 3 * IN), clockwise=True),
            Element(5, (0, 2 * IN)),
            Element(6, (0, 0), centre=(0, 1 * IN)),
        ),
    )
    return boundary, [obround(1.5 * IN, 2.5 * IN, 0.9 * IN, 0.3 * IN)]


@pytest.mark.parametrize(
    "case", [rectangle_with_round_island, l_shape_with_two_islands, arc_bounded_boss]
)
def test_pocket_is_cleared_without_cutting_islands_or_walls(case: object) -> None:
    boundary, islands = case()  # type: ignore[operator]
    result = plan(boundary, islands, R)
    assert_pocket(result, boundary, islands, R)


def test_pocket_with_large_step_over_still_clears_sharp_corners() -> None:
    # A step-over of 0.9 D leaves cusps at the rings' corners; cleanup moves must reach them.
    boundary, islands = l_shape_with_two_islands()
    result = plan(boundary, islands, R, step_over=round(1.8 * R), finish_allowance=0)
    assert_pocket(result, boundary, islands, R)
    assert any(e.tag == "cleanup" for p in result.passes for e in p.path.elements)


def test_finish_passes_are_exact_offsets() -> None:
    boundary, islands = rectangle_with_round_island()
    result = plan(boundary, islands, R)
    finish = [p for p in result.passes if p.kind is PassKind.FINISH]
    assert {p.contours for p in finish} == {("boundary",), ("island 1",)}
    assert all(p.exact for p in result.passes)
    island = next(p for p in finish if p.contours == ("island 1",))
    (arc,) = island.path.elements
    assert arc.centre == (2 * IN, 1.5 * IN)
    assert math.dist(island.path.start, (2 * IN, 1.5 * IN)) == pytest.approx(IN / 2 + R, abs=1e-3)
    assert arc.end == island.path.start  # a full circle
    wall = next(p for p in finish if p.contours == ("boundary",))
    corners = {(round(e.end[0]), round(e.end[1])) for e in wall.path.elements}
    assert {(R, R), (4 * IN - R, R), (4 * IN - R, 3 * IN - R), (R, 3 * IN - R)} <= corners
    assert all(e.centre is None for e in wall.path.elements)


def test_finish_pass_of_arc_wall_keeps_arcs_about_the_same_centres() -> None:
    boundary, islands = arc_bounded_boss()
    result = plan(boundary, islands, R)
    wall = next(p for p in result.passes if p.kind is PassKind.FINISH and "boundary" in p.contours)
    arcs = {(e.centre, e.clockwise) for e in wall.path.elements if e.centre is not None}
    # The round ends (radius 1 in → 0.75 in) and the bulge (radius 1 in → 1.25 in).
    assert ((4 * IN, 1 * IN), False) in {(c, cw) for c, cw in arcs} or (
        (4 * IN, 1 * IN),
        True,
    ) in arcs
    starts = [wall.path.start] + [e.end for e in wall.path.elements[:-1]]
    radii = {
        e.centre: round(math.dist(s, e.centre))
        for s, e in zip(starts, wall.path.elements, strict=True)
        if e.centre
    }
    assert radii[(4 * IN, 1 * IN)] == IN - R
    assert radii[(0, 1 * IN)] == IN - R
    assert radii[(2 * IN, 3 * IN)] == round(math.sqrt(1.25) * IN) + R
    boss = next(p for p in result.passes if p.kind is PassKind.FINISH and "island 1" in p.contours)
    assert boss.exact
    # Two half circles about the boss's two centres (one cut where the pass starts).
    assert {e.centre for e in boss.path.elements if e.centre} == {
        (1.5 * IN, 0.9 * IN),
        (2.5 * IN, 0.9 * IN),
    }


def signed_area(path: Path) -> float:
    pts = points_of(path)
    return sum(a[0] * b[1] - b[0] * a[1] for a, b in zip(pts, pts[1:] + pts[:1], strict=True)) / 2


@pytest.mark.parametrize(
    ("milling", "rpm", "wall_ccw"),
    [
        (MillingMode.CLIMB, 800, True),
        (MillingMode.CONVENTIONAL, 800, False),
        (MillingMode.CLIMB, -800, False),
        (MillingMode.CONVENTIONAL, -800, True),
    ],
)
def test_direction_follows_milling_mode_and_spindle(
    milling: MillingMode, rpm: int, wall_ccw: bool
) -> None:
    # Climb with a clockwise spindle: the wall counter-clockwise, islands clockwise (§3).
    boundary, islands = rectangle_with_round_island()
    result = plan(boundary, islands, R, milling=milling, rpm=rpm)
    for p in result.passes:
        if p.kind is PassKind.FINISH:
            ccw = signed_area(p.path) > 0
            assert ccw == (wall_ccw if p.contours == ("boundary",) else not wall_ccw)


def test_plunge_where_the_tool_fits_and_links_are_named() -> None:
    boundary, islands = rectangle_with_round_island()
    result = plan(boundary, islands, R)
    region = pocket_region(boundary, islands)
    assert result.passes[0].entry.kind is LinkKind.PLUNGE
    assert result.entry == "plunge"
    for at in result.plunges:
        assert Point(at).buffer(R, quad_segs=64).difference(region.buffer(GOUGE_TOL)).area < 1e4
    # The island splits the middle: one more plunge after a retract, every other link feeds.
    kinds = [p.entry.kind for p in result.passes]
    assert kinds.count(LinkKind.RETRACT) == 1
    assert set(kinds[1:]) <= {LinkKind.RETRACT, LinkKind.CLEARED, LinkKind.CUTTING}
    # Cutting order: from the middle out, finishing passes last.
    offsets = [p.offset for p in result.passes]
    assert [p.kind for p in result.passes][-2:] == [PassKind.FINISH, PassKind.FINISH]
    assert offsets[0] == max(offsets)


def test_narrow_slot_the_tool_cannot_enter() -> None:
    slot = rect(0, 0, 2 * IN, 0.4 * IN)  # 0.4 in wide, tool 0.5 in
    result = plan(slot, [], R)
    assert result.passes == ()
    (finding,) = result.findings
    assert finding.issue is PocketIssue.TOOL_TOO_LARGE
    assert finding.severity is Severity.ERROR
    assert finding.contour == "boundary"
    assert "0.5000 in tool fits nowhere" in finding.message


def test_narrow_branch_is_reported_and_the_rest_is_cleared() -> None:
    # A 2 in square with a 0.3 in wide slot going off its right side.
    boundary = polygon_path(
        [
            (0, 0),
            (2 * IN, 0),
            (2 * IN, 0.85 * IN),
            (3 * IN, 0.85 * IN),
            (3 * IN, 1.15 * IN),
            (2 * IN, 1.15 * IN),
            (2 * IN, 2 * IN),
            (0, 2 * IN),
        ]
    )
    result = plan(boundary, [], R)
    narrow = [f for f in result.findings if f.issue is PocketIssue.NARROW]
    assert len(narrow) == 1
    assert narrow[0].severity is Severity.WARNING
    assert "boundary element 4 (block 4)" in narrow[0].message  # the slot's end
    assert_pocket(result, boundary, [], R)


def test_island_problems_are_named() -> None:
    boundary = rect(0, 0, 4 * IN, 3 * IN)
    outside = circle(6 * IN, 1 * IN, IN / 2)
    crossing = circle(4 * IN, 1.5 * IN, IN / 2)
    result = plan(boundary, [outside], R)
    assert [(f.issue, f.contour, f.severity) for f in result.findings] == [
        (PocketIssue.ISLAND_OUTSIDE, "island 1", Severity.ERROR)
    ]
    assert result.passes == ()
    result = plan(
        boundary,
        [crossing, circle(1 * IN, 1.5 * IN, IN / 2), circle(1.5 * IN, 1.5 * IN, IN / 2)],
        R,
    )
    issues = [(f.issue, f.contour) for f in result.findings]
    assert (PocketIssue.ISLAND_TOUCHES_WALL, "island 1") in issues
    assert (PocketIssue.ISLANDS_OVERLAP, "island 2") in issues
    islands = [crossing, circle(1 * IN, 1.5 * IN, IN / 2), circle(1.5 * IN, 1.5 * IN, IN / 2)]
    assert_pocket(result, boundary, islands, R)


def test_bad_contours_are_named_by_element_and_block() -> None:
    bowtie = polygon_path([(0, 0), (2 * IN, 2 * IN), (2 * IN, 0), (0, 2 * IN)], block=7)
    result = plan(bowtie, [], R)
    (finding,) = result.findings
    assert finding.issue is PocketIssue.SELF_INTERSECTING
    assert (finding.contour, finding.element, finding.block) == ("boundary", 3, 9)
    assert finding.message.startswith("boundary, element 3 (block 9): element 3 crosses")
    open_path = Path((0, 0), (Element(1, (IN, 0)), Element(2, (IN, IN))))
    (finding,) = plan(open_path, [], R).findings
    assert finding.issue is PocketIssue.OPEN_CONTOUR
    assert (
        "element 2 (block 2): the contour is not closed: it ends 1.4142 in from where it starts"
        in finding.message
    )
    result = plan(rect(0, 0, IN, IN), [], R, step_over=2 * R)
    assert [f.issue for f in result.findings] == [PocketIssue.STEP_OVER]
    assert (
        "must be more than 0 and less than the tool diameter 0.5000 in"
        in result.findings[0].message
    )


def test_same_input_same_passes() -> None:
    boundary, islands = l_shape_with_two_islands()
    first = plan(boundary, islands, R)
    again = plan(boundary, islands, R)
    assert first == again
    assert repr(first) == repr(again)


def test_pass_levels_repeat_the_whole_plan_per_peck() -> None:
    boundary, islands = rectangle_with_round_island()
    result = plan(boundary, islands, R)
    levels = pass_levels(result, z_up=2_540_000, z_dn=-6_350_000, pecks=3)
    # Three levels evenly spaced from Z UP 0.1 in to Z DN -0.25 in, the last at Z DN.
    assert [lv.z for lv in levels] == [-423_333, -3_386_667, -6_350_000]
    assert all(lv.passes == result.passes for lv in levels)
    rough = pass_levels(result, 2_540_000, -6_350_000, pecks=2, floor_allowance=127_000)
    # Roughing 0.005 in above Z DN, then the whole pocket again at Z DN (as 2P does).
    assert [lv.z for lv in rough] == [-1_841_500, -6_223_000, -6_350_000]


# -- generated pockets --------------------------------------------------------------------------


@st.composite
def pockets(draw: st.DrawFn) -> tuple[Path, list[Path], int, int, int]:
    """A star-shaped boundary (some sides bulging arcs), 0-2 islands, a tool and step-over."""
    n = draw(st.integers(3, 8))
    gaps = draw(st.lists(st.floats(0.3, 1.0), min_size=n, max_size=n))
    total = sum(gaps)
    angles = [2 * math.pi * sum(gaps[:k]) / total for k in range(n)]
    radii = draw(st.lists(st.floats(1.2, 3.0), min_size=n, max_size=n))
    points = [
        (round(rr * IN * math.cos(a)), round(rr * IN * math.sin(a)))
        for rr, a in zip(radii, angles, strict=True)
    ]
    elements = []
    for k in range(n):
        a, b = points[k], points[(k + 1) % n]
        bulge = draw(st.sampled_from([0.0, 0.0, 0.3, -0.25]))
        if bulge == 0.0:
            elements.append(Element(k + 1, b))
            continue
        # An arc through a and b whose centre sits off the chord's middle.
        mid = ((a[0] + b[0]) / 2, (a[1] + b[1]) / 2)
        chord = math.dist(a, b)
        nx, ny = -(b[1] - a[1]) / chord, (b[0] - a[0]) / chord
        off = chord / (2 * math.tan(2 * math.atan(abs(bulge))))
        sign = 1 if bulge > 0 else -1
        centre = (round(mid[0] + sign * nx * off), round(mid[1] + sign * ny * off))
        elements.append(Element(k + 1, b, centre=centre, clockwise=bulge < 0))
    boundary = Path(points[0], tuple(elements))
    islands = []
    for j in range(draw(st.integers(0, 2))):
        cx = draw(st.floats(-0.8, 0.8)) * IN
        cy = draw(st.floats(-0.8, 0.8)) * IN
        if draw(st.booleans()):
            islands.append(
                circle(round(cx), round(cy), round(draw(st.floats(0.15, 0.4)) * IN), block=20 + j)
            )
        else:
            half = round(draw(st.floats(0.1, 0.35)) * IN)
            islands.append(
                rect(
                    round(cx) - half,
                    round(cy) - half,
                    round(cx) + half,
                    round(cy) + half,
                    20 + 4 * j,
                )
            )
    r = round(draw(st.floats(0.1, 0.3)) * IN)
    step = round(draw(st.floats(0.6, 1.8)) * r)
    allowance = draw(st.sampled_from([0, 127_000, 254_000]))
    return boundary, islands, r, step, allowance


def _direction(start: tuple[float, float], e: Element, at_end: bool) -> tuple[float, float]:
    """The way an element heads at its start or end (unit-free)."""
    if e.centre is None:
        return (e.end[0] - start[0], e.end[1] - start[1])
    p = e.end if at_end else start
    rx, ry = p[0] - e.centre[0], p[1] - e.centre[1]
    return (ry, -rx) if e.clockwise else (-ry, rx)


def turns_back(path: Path, limit_deg: float = 170.0) -> bool:
    """True when the outline reverses at a corner (turns by more than `limit_deg`): a cusp,
    where two arcs meeting there can overlap by microns."""
    starts = [path.start, *(e.end for e in path.elements[:-1])]
    n = len(path.elements)
    for k in range(n):
        before, after = path.elements[k - 1], path.elements[k]
        a = _direction(starts[k - 1], before, at_end=True)
        b = _direction(starts[k], after, at_end=False)
        turn = math.degrees(
            abs(math.remainder(math.atan2(b[1], b[0]) - math.atan2(a[1], a[0]), 2 * math.pi))
        )
        if turn > limit_deg:
            return True
    return False


# A generated outline that turns back at a corner: the two inward arcs meeting there (centres
# 129.374044 mm apart, radii summing to 1.2 µm more) cross beside the corner.
CUSP = Path(
    (50800000, 0),
    (
        Element(1, (25400000, 43994091)),
        Element(2, (-25400000, 43994091)),
        Element(3, (-31750000, 0)),
        Element(4, (-35123438, -60835578), centre=(-90470073, -27255191), clockwise=True),
        Element(5, (17462500, -30245937), centre=(19847319, -94840074), clockwise=True),
        Element(6, (43994091, -25400000)),
        Element(7, (50800000, 0)),
    ),
)


def test_an_outline_whose_arcs_cross_at_a_cusp_is_refused() -> None:
    """Found by the generated pockets below (their outline check, shapely's on the arcs as
    short lines, passes it): the planner names the crossing rather than cutting it."""
    assert turns_back(CUSP)
    result = plan_pocket(CUSP, [], tool_radius=6350000, step_over=6350000, finish_allowance=0)
    errors = [f for f in result.findings if f.severity is Severity.ERROR]
    assert [f.issue for f in errors] == [PocketIssue.SELF_INTERSECTING]
    assert "element 5 crosses or touches element 4" in errors[0].message


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(pockets())
def test_generated_pockets_are_cleared_and_not_gouged(
    case: tuple[Path, list[Path], int, int, int],
) -> None:
    boundary, islands, r, step, allowance = case
    outline = shape(boundary)
    assume(outline.is_valid and not turns_back(boundary))  # (a cusp: CUSP's test)
    assume(all(outline.contains(shape(i).buffer(IN / 20)) for i in islands))
    assume(
        not any(
            shape(a).buffer(IN / 20).intersects(shape(b))
            for a in islands
            for b in islands
            if a is not b
        )
    )
    result = plan_pocket(
        boundary, islands, tool_radius=r, step_over=step, finish_allowance=allowance
    )
    if result.has_errors:
        assert [f.issue for f in result.findings if f.severity is Severity.ERROR] == [
            PocketIssue.TOOL_TOO_LARGE
        ]
        assert pocket_region(boundary, islands).buffer(-r).area < (IN / 1000) ** 2
        return
    assert_pocket(result, boundary, islands, r)
    again = plan_pocket(
        boundary, islands, tool_radius=r, step_over=step, finish_allowance=allowance
    )
    assert again == result


# -- the planner's cost grows with the pocket, not faster (issue 30) ------------------------


def island_row(n: int) -> tuple[Path, list[Path]]:
    """A 2 in tall pocket 1.25 n in long with `n` islands in a row, each with a notch and a
    bump (arcs) like the hostile corpus's 8-island pocket: twice the islands, twice the
    boundary, the same offset levels."""
    w, h = round(1.25 * IN * n), 2 * IN
    islands = []
    for k in range(n):
        x0, y0 = round(1.25 * IN * k + 0.4 * IN), round(0.6 * IN)
        a, c = round(0.5 * IN), round(0.8 * IN)
        q, m = c // 8, y0 + c // 2
        islands.append(
            Path(
                (x0, y0),
                (
                    Element(10, (x0 + a, y0)),
                    Element(11, (x0 + a, m - q)),
                    Element(12, (x0 + a, m + q), centre=(x0 + a, m), clockwise=True),
                    Element(13, (x0 + a, y0 + c)),
                    Element(14, (x0, y0 + c)),
                    Element(15, (x0, m + q)),
                    Element(16, (x0, m - q), centre=(x0, m)),
                    Element(17, (x0, y0)),
                ),
            )
        )
    return rect(0, 0, w, h), islands


def clipper_points(monkeypatch: pytest.MonkeyPatch, n: int) -> tuple[int, int]:
    """(points handed to Clipper, passes) planning `island_row(n)`: the real Clipper, its
    inputs counted (its work grows with them)."""
    counted = [0]

    class Clipper(pyclipper.Pyclipper):  # type: ignore[misc]
        def AddPath(self, path: list[object], *rest: object) -> object:
            counted[0] += len(path)
            return super().AddPath(path, *rest)

        def AddPaths(self, paths: list[list[object]], *rest: object) -> object:
            counted[0] += sum(map(len, paths))
            return super().AddPaths(paths, *rest)

    class Offset(pyclipper.PyclipperOffset):  # type: ignore[misc]
        def AddPath(self, path: list[object], *rest: object) -> object:
            counted[0] += len(path)
            return super().AddPath(path, *rest)

        def AddPaths(self, paths: list[list[object]], *rest: object) -> object:
            counted[0] += sum(map(len, paths))
            return super().AddPaths(paths, *rest)

    module = types.SimpleNamespace(**vars(pyclipper))
    module.Pyclipper, module.PyclipperOffset = Clipper, Offset
    monkeypatch.setattr(regions, "pyclipper", module)
    boundary, islands = island_row(n)
    result = plan_pocket(boundary, islands, tool_radius=IN // 16, step_over=IN // 10)
    assert not result.has_errors
    monkeypatch.undo()
    return counted[0], len(result.passes)


def test_planning_work_grows_linearly_with_the_islands(monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 30: the planner's work must grow at most as (boundary + islands) x levels. Twice
    the islands in a pocket twice as long (the same levels) hands Clipper about twice the
    points: 1.9x here. Before, every straight move's wall check clipped the whole region
    (every island), the cleanup moves re-united the whole cut area one by one and the
    islands were checked against each other pairwise: 2.8x, and worse with each doubling."""
    four, passes_four = clipper_points(monkeypatch, 4)
    eight, passes_eight = clipper_points(monkeypatch, 8)
    assert passes_eight <= 2.2 * passes_four  # the same levels round twice the islands
    assert eight <= 2.2 * four, f"{four:,} -> {eight:,} points: {eight / four:.2f}x"


def test_planning_frees_what_it_makes_as_it_goes() -> None:
    """Python's garbage collector is paused while a pocket is planned
    (app.cnc.sizes.collector_paused), so the planner must leave no reference cycles: what
    it makes and drops is freed at once, and its memory stays what it holds. pyclipper's
    trees (each node names its parent and its children, its points Python lists) were
    cycles, one per set of components and per wall check: 121 000 objects kept until the
    plan was made for the hostile corpus's 8-island pocket."""
    boundary, islands = island_row(3)
    plan(boundary, islands, R / 4, step_over=round(0.3 * R))  # what the first use loads
    was_enabled = gc.isenabled()
    gc.collect()
    gc.disable()
    try:
        result = plan(boundary, islands, R / 4, step_over=round(0.3 * R))
        assert result.passes and not result.has_errors
        left = gc.collect()
    finally:
        if was_enabled:
            gc.enable()
    assert left == 0, f"{left:,} objects in reference cycles after planning"


def test_planning_gives_the_garbage_collector_back_as_it_was() -> None:
    """The pause lasts the planning only: a plan stopped by the time budget leaves the
    collector running (a server's worker would otherwise run on without it), and planning
    inside another pause (an import's) leaves it paused."""
    boundary, islands = island_row(2)
    assert gc.isenabled()
    with pytest.raises(sizes.OverBudget), sizes.time_budget(0.0):
        plan(boundary, islands, R / 4, step_over=round(0.3 * R))
    assert gc.isenabled()
    with sizes.collector_paused():
        assert plan(boundary, islands, R / 4, step_over=round(0.3 * R)).passes
        assert not gc.isenabled()
    assert gc.isenabled()


def comb(n: int, lift: float = 0.0) -> Path:
    """A ring 1.25 n in long with a notch in its floor every 1.25 in (4 n + 4 lines),
    raised by `lift` nm."""
    floor: list[Pt] = [(0.0, lift)]
    for k in range(n):
        x = 1.25 * IN * k + 0.5 * IN
        floor += [(x, lift), (x, lift + IN / 4), (x + IN / 4, lift + IN / 4), (x + IN / 4, lift)]
    return polygon_path(
        [*floor, (1.25 * IN * n, lift), (1.25 * IN * n, lift + IN), (0.0, lift + IN)]
    )


def way_round_pairs(monkeypatch: pytest.MonkeyPatch, n: int) -> tuple[int, Pt, Pt]:
    """(pairs of sample and element bounded with numpy, the point chosen, the point that
    measuring every pair exactly chooses) for the way round `comb(n)` raised 0.1 in to
    `comb(n)`, sampled every 1/128 in."""
    counted = [0]
    real = nearest._bounds

    def bounds(px: object, py: object, elements: nearest.Elements) -> object:
        lower, upper = real(px, py, elements)  # type: ignore[arg-type]
        counted[0] += lower.size  # (point, element) pairs, in a grid or one by one
        return lower, upper

    monkeypatch.setattr(nearest, "_bounds", bounds)
    previous, ring, step = comb(n, IN / 10), comb(n), IN / 128
    _, chosen = _way_round(previous, ring, step)
    monkeypatch.undo()
    best: tuple[float, Pt] | None = None
    starts = [ring.start] + [e.end for e in ring.elements[:-1]]
    for point, _ in sample(previous, step):
        for start, element in zip(starts, ring.elements, strict=True):
            d = math.dist(_closest_on_element(point, start, element), point)
            if best is None or d < best[0] - 1e-9:
                best = (d, point)
    assert best is not None
    return counted[0], chosen, best[1]


def test_way_round_the_previous_ring_grows_with_the_rings_not_their_product(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Issue 30: the link along the previous ring looks for its point nearest the next ring.
    Every sample against every element grew as the product of the two rings' sizes (4x
    for twice the islands, per pass); samples against the elements near them grow as
    their sum. The point is the one measuring every pair exactly finds."""
    four, chosen_four, exact_four = way_round_pairs(monkeypatch, 4)
    eight, chosen_eight, exact_eight = way_round_pairs(monkeypatch, 8)
    assert chosen_four == exact_four and chosen_eight == exact_eight
    assert eight <= 2.2 * four, f"{four:,} -> {eight:,} pairs: {eight / four:.2f}x"


def test_way_round_measures_exactly_only_the_samples_that_can_win(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Issue 30: the way round the previous ring samples it every eighth of the tool radius.
    Every sample was made in Python (`plane.sample`); now numpy makes them all for the
    bounds and Python only those a pair near the ring can hold (the same arithmetic, so
    the same point: `way_round_pairs` checks it against measuring every pair)."""
    made = [0]
    real = plane.points_along

    def points_along(start: Pt, element: Element, fractions: Sequence[float]) -> list[Pt]:
        made[0] += len(fractions)
        return real(start, element, fractions)

    for n in (4, 8):
        previous, ring, step = comb(n, IN / 10), comb(n), IN / 128
        samples = len(sample(previous, step))
        monkeypatch.setattr(plane, "points_along", points_along)
        monkeypatch.setattr(nearest, "points_along", points_along, raising=False)
        made[0] = 0
        _, chosen = _way_round(previous, ring, step)
        monkeypatch.undo()
        assert made[0] < samples / 4, f"{made[0]:,} of {samples:,} samples made exactly"
        assert chosen == way_round_pairs(monkeypatch, n)[2]


def test_a_long_move_in_pieces_sweeps_about_the_points_of_the_whole_move() -> None:
    """Issue 30: a link's "through cut material?" reads the sweeps of the pieces of the
    passes near it (`regions.SweptIndex`), every 32 segments. Each piece had two round
    ends (a circle of points at the chordal tolerance): the pieces of a ring held 2.3x the
    points of the ring's own sweep, all handed to Clipper. Now only the move's own ends
    are round: at most 1.3x (1.2x here), the same area."""
    r, t = IN / 16, 500.0
    for radius in (IN, 2 * IN):
        points = regions.path_points(circle(0, 0, radius), t)
        index = regions.SweptIndex(r, t)
        index.add(points)
        pieces = index.near(index.boxes(points))
        whole = regions.sweep_lines([points], r, t)
        assert sum(map(len, pieces)) <= 1.3 * sum(map(len, whole))
        # The same area: the union of the pieces' sweeps is the whole move's sweep.
        assert regions.area(regions.union(pieces)) == pytest.approx(
            regions.area(regions.union(whole)), rel=1e-8
        )


def left_two_ways(
    monkeypatch: pytest.MonkeyPatch, boundary: Path, islands: list[Path], **options: object
) -> tuple[list[regions.Ring], list[regions.Ring]]:
    """(material the rings leave as the cleanup search reads it, from each level's two
    offsets; the same from the rings' passes swept one by one and united, as it was read
    before) for the pocket planned with `options`, when the cleanup search starts."""
    found: list[tuple[list[regions.Ring], list[regions.Ring]]] = []
    real = plan_module._Planner.clean_up

    def clean_up(planner: plan_module._Planner) -> int:
        r, t = planner.r, planner.t
        opening = regions.offset(planner.levels[0][1], r, t)
        sweeps = [
            regions.sweep_lines([regions.path_points(p.path, t)], r, t) for p in planner.passes
        ]
        found.append(
            (planner._left_by_rings(), regions.difference(opening, regions.union(*sweeps)))
        )
        return real(planner)

    monkeypatch.setattr(plan_module._Planner, "clean_up", clean_up)
    plan(boundary, islands, R, **options)
    monkeypatch.undo()
    return found[0]


@pytest.mark.parametrize(
    ("case", "step"),
    [(l_shape_with_two_islands, 1.8), (arc_bounded_boss, 1.8), (rectangle_with_round_island, 1.8)],
)
def test_the_cleanup_search_finds_what_the_passes_leave_from_the_levels(
    monkeypatch: pytest.MonkeyPatch, case: object, step: float
) -> None:
    """The cleanup search reads the material the rings leave from two offsets of each
    level's region (issue 30), not from a sweep of every pass: the pieces wide enough to
    chase (`RESIDUE_NM`) are the ones sweeping the passes leaves, to within narrower
    slivers. (From the contours shrunk by d - r and d + r instead, the cusps at the
    rings' corners are missed: the region grown by r is round there.)"""
    boundary, islands = case()  # type: ignore[operator]
    levels, passes = left_two_ways(
        monkeypatch, boundary, islands, step_over=round(step * R), finish_allowance=0
    )
    assert regions.thicker_than(passes, RESIDUE_NM, 500)  # there are cusps to find
    for extra in (regions.difference(levels, passes), regions.difference(passes, levels)):
        assert not regions.thicker_than(extra, RESIDUE_NM, 500)


# -- a link's "through cut material?" from distances (issue 30.2) -----------------------------


def link_answers(
    monkeypatch: pytest.MonkeyPatch, boundary: Path, islands: list[Path], **options: object
) -> list[tuple[bool, bool, bool]]:
    """(the planner's answer, Clipper's answer by area, whether the distances decided) for
    every straight link the planner weighs planning the pocket with `options` (a link
    along a pass, asked again once the cleanup moves are made, is Clipper's)."""
    found: list[tuple[bool, bool, bool]] = []
    real = plan_module._Planner._through_cleared
    by_area = plan_module._Planner._through_cleared_by_area
    asked = [0]

    def through_cleared(planner: plan_module._Planner, move: Path, then: Path) -> bool:
        asked[0] = 0
        answer = real(planner, move, then)
        if len(move.elements) == 1 and move.elements[0].centre is None:
            found.append((answer, by_area(planner, move, then), asked[0] == 0))
        return answer

    def counted(planner: plan_module._Planner, move: Path, then: Path) -> bool:
        asked[0] += 1
        return by_area(planner, move, then)

    monkeypatch.setattr(plan_module._Planner, "_through_cleared", through_cleared)
    monkeypatch.setattr(plan_module._Planner, "_through_cleared_by_area", counted)
    plan(boundary, islands, R, **options)
    monkeypatch.undo()
    return found


def test_a_straight_link_is_answered_from_distances_as_clipper_answers_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Issue 30.2: whether a link cuts only cut material was Clipper's area of the link's
    sweep less the sweeps of every pass near it, a quarter of the 8-island pocket's
    planning. A straight link is now answered from its distances to those passes
    (`regions.move_covered`): every answer is Clipper's, both yes and no are met, and
    Clipper is asked of none of these."""
    cases = [
        (l_shape_with_two_islands, 1.2),
        (l_shape_with_two_islands, 1.8),
        (arc_bounded_boss, 1.5),
        (rectangle_with_round_island, 1.8),
        (lambda: island_row(4), 1.2),
    ]
    answers = []
    for case, step in cases:
        boundary, islands = case()
        answers += link_answers(monkeypatch, boundary, islands, step_over=round(step * R))
    assert all(answer == area for answer, area, _ in answers)
    assert {answer for answer, _, _ in answers} == {True, False}
    assert all(decided for _, _, decided in answers)


def two_passes(gap: float, r: float = R) -> list[list[Pt]]:
    """Two long straight passes `gap` nm apart (y = 0 and y = gap)."""
    return [[(-4 * r, 0.0), (4 * r, 0.0)], [(-4 * r, gap), (4 * r, gap)]]


def covered_two_ways(passes: list[list[Pt]], a: Pt, b: Pt, r: float = R) -> tuple[object, bool]:
    """(`move_covered`'s answer, Clipper's by area) for the straight move a-b among
    `passes` swept by the tool radius `r` (the move by r less the tolerance, as the planner
    asks it)."""
    t = 500.0
    index = regions.SweptIndex(r, t)
    for points in passes:
        index.add(points)
    boxes = index.boxes([a, b])
    starts, ends = index.segments_near(boxes)
    fast = regions.move_covered(a, b, r - t, r, starts, ends, RESIDUE_NM, t)
    extra = regions.difference(regions.sweep_lines([[a, b]], r - t, t), index.near(boxes))
    return fast, not regions.thicker_than(extra, RESIDUE_NM, t)


@pytest.mark.parametrize(
    ("gap", "across", "expected"),
    [
        (1.2 * R, 1.2 * R, True),  # between neighbouring passes: all cut
        (1.99 * R, 1.99 * R, True),  # the sweeps still overlap
        (2 * R + 50_000, 2 * R + 50_000, False),  # a strip 0.05 mm wide is left between them
        (1.2 * R, 3 * R, False),  # on past the second pass into uncut material
    ],
)
def test_move_covered_finds_what_a_straight_move_would_cut(
    gap: float, across: float, expected: bool
) -> None:
    """Issue 30.2: a straight move between two passes cuts nothing new while their sweeps
    meet; past them, or across a strip they leave wider than `RESIDUE_NM`, it does. The
    distances answer as Clipper's areas do. A move along the middle, its ends on no pass
    (the planner's links all start and end on one), finds a strip left, but cannot clear
    its own round ends (bounded from the passes they lie on): that is left to Clipper."""
    passes = two_passes(gap)
    for a, b in (((0.0, 0.0), (0.0, across)), ((-R, 0.0), (R, across))):
        fast, area = covered_two_ways(passes, a, b)
        assert area is expected
        assert fast is expected
    fast, area = covered_two_ways(passes, (-2 * R, gap / 2), (2 * R, gap / 2))
    assert fast is (None if area else False)


def test_move_covered_leaves_a_strip_near_the_limit_to_clipper() -> None:
    """A strip between two passes a few micrometres either side of `RESIDUE_NM` wide is
    too near the limit for the distances' margins: `move_covered` says so (None) rather
    than guess, and the planner asks Clipper."""
    for strip in (RESIDUE_NM - 1_000, RESIDUE_NM + 1_000):
        fast, _ = covered_two_ways(two_passes(2 * R + strip), (0.0, 0.0), (0.0, 2 * R + strip))
        assert fast is None


def test_no_pass_is_swept_to_answer_a_straight_link(monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 30.2, counting operations: planning `island_row(8)` sweeps no piece of a pass
    for a link's question (each was a Clipper offset, and the sweeps beside a long link
    were then united), where it swept hundreds."""
    swept = [0]
    real = regions.SweptIndex._sweep

    def sweep(index: regions.SweptIndex, points: Sequence[Pt], k: int) -> regions.Swept:
        swept[0] += 1
        return real(index, points, k)

    monkeypatch.setattr(regions.SweptIndex, "_sweep", sweep)
    boundary, islands = island_row(8)
    result = plan_pocket(boundary, islands, tool_radius=IN // 16, step_over=IN // 10)
    assert not result.has_errors
    assert swept[0] == 0
