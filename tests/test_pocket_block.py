"""The POCKET block kind (issue 22): a program's irregular pocket, cut as the tool path says.

The pocket engine's own passes are measured in test_pocketing.py. Here the whole program
is: the DRILL + POCKET + PKT LINE / PKT ARC / ISLAND blocks compile to moves, and those
moves (what every target writes) are measured with shapely against the contours drawn by
the blocks, walked here independently of the app's own reading of them.
"""

from __future__ import annotations

import math
import tracemalloc
from dataclasses import replace
from decimal import Decimal
from pathlib import Path

import pytest
import shapely
import shapely.affinity
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from shapely.geometry import LineString, Point, Polygon

from app.cnc import document
from app.cnc.blocks import (
    Block,
    Comp,
    DataBlock0,
    Direction,
    Hole,
    HoleOp,
    Island,
    MillingMode,
    Mode,
    Pocket,
    PocketArc,
    PocketArcEnd,
    PocketLine,
    Program,
    Rep,
    Tool,
)
from app.cnc.formats.targets import export
from app.cnc.interpret import interpret
from app.cnc.mirror import Axis, mirror
from app.cnc.plane import Element
from app.cnc.plane import Path as MillPath
from app.cnc.problems import Severity
from app.cnc.simulate.programmed import programmed_geometry
from app.cnc.simulate.sweep import simulate
from app.cnc.simulate.verify import Verification, check_part, prepare, verify
from app.cnc.toolpath import ArcFeed, Feed, Rapid
from app.cnc.units import Units, to_nm
from app.cnc.validate import validate
from app.web.forms import group_menu, parse_block, sub_menu
from app.web.preview import preview
from tests.test_pocketing import points_of

GOLDEN = Path(__file__).parent / "golden"
REACH_TOL = 25_400  # 0.001 in: uncut material a round tool could reach
GOUGE_TOL = 2_540  # 0.0001 in: material cut from an island or beyond the wall
D = Decimal


# -- the contours as the blocks draw them (walked here, not by the app) --------------------


def pockets_of(program: Program) -> list[tuple[Polygon, list[Polygon], int, int]]:
    """For each POCKET (each LOOP pattern of one too): the boundary, the islands (shapely,
    nm), the tool radius and Z DN (nm). ABS/INC: from the point before, as the manual's
    blocks are; a REP repeats the patterns of its LOOP (one level, as in the goldens)."""
    blocks = program.blocks
    found: list[tuple[Polygon, list[Polygon], int, int]] = []
    for index, block in enumerate(blocks):
        if not isinstance(block, Pocket):
            continue
        drill = blocks[index - 1]
        assert isinstance(drill, Hole) and drill.z_dn is not None
        tool = program.block0.tool(drill.tool)
        assert tool is not None and tool.diameter is not None
        radius = to_nm(tool.diameter, program.units) // 2
        offsets = [(0, 0)]
        rep = next((b for b in blocks[index:] if isinstance(b, Rep)), None)
        if drill.loop and rep is not None:
            step = (to_nm(rep.x, rep.units), to_nm(rep.y, rep.units))
            offsets = [
                (i * step[0], j * step[1]) for j in range(rep.ny + 1) for i in range(rep.nx + 1)
            ]
        before = _point_before(blocks, index - 1)
        for dx, dy in offsets:
            start = _resolve(drill, (before[0] + dx, before[1] + dy))
            contours = _contours(blocks, index + 1, start)
            outline = [Polygon(points_of(c)) for c in contours]
            found.append((outline[0], outline[1:], radius, to_nm(drill.z_dn, drill.units)))
    return found


def _resolve(block: Block, reference: tuple[int, int]) -> tuple[int, int]:
    x = to_nm(getattr(block, "x"), block.units)  # noqa: B009
    y = to_nm(getattr(block, "y"), block.units)  # noqa: B009
    if block.mode is Mode.INC:
        return (reference[0] + x, reference[1] + y)
    return (x, y)


def _point_before(blocks: tuple[Block, ...], index: int) -> tuple[int, int]:
    """The table's point before block `index` (the goldens have a POS or nothing there)."""
    point = (0, 0)
    for block in blocks[:index]:
        if hasattr(block, "x") and not isinstance(block, Rep | PocketArc):
            point = _resolve(block, point)
    return point


def _contours(blocks: tuple[Block, ...], first: int, start: tuple[int, int]) -> list[MillPath]:
    contours: list[MillPath] = []
    origin, at = start, start
    elements: list[Element] = []
    k = first
    while k < len(blocks):
        block = blocks[k]
        if isinstance(block, Island):
            contours.append(MillPath(origin, tuple(elements)))
            origin = at = _resolve(block, at)
            elements = []
        elif isinstance(block, PocketLine):
            at = _resolve(block, at)
            elements.append(Element(k + 1, at))
        elif isinstance(block, PocketArc):
            centre = _resolve(block, at)
            end_block = blocks[k + 1]
            assert isinstance(end_block, PocketArcEnd)
            at = _resolve(end_block, at)
            elements.append(
                Element(k + 1, at, centre=centre, clockwise=block.direction is Direction.CW)
            )
            k += 1
        else:
            break
        k += 1
    contours.append(MillPath(origin, tuple(elements)))
    return contours


# -- what the moves cut ---------------------------------------------------------------------


def cut_below(program: Program, z_limit: int, radius: int) -> shapely.Geometry:
    """The tool swept along every feed and arc that ends at or below `z_limit` (nm), one
    move at a time; the rapids are checked apart (test_rapids_only_where_cleared)."""
    pieces = []
    at = (0.0, 0.0, 0.0)
    for move in interpret(program).moves:
        if isinstance(move, Feed | ArcFeed | Rapid):
            end = (float(move.x), float(move.y), float(move.z))
            if isinstance(move, Feed) and end[2] <= z_limit and at[2] <= z_limit + 1:
                pieces.append(LineString([at[:2], end[:2]]).buffer(radius, quad_segs=128))
                pieces.append(Point(end[:2]).buffer(radius, quad_segs=128))
            elif isinstance(move, ArcFeed) and end[2] <= z_limit:
                arc = MillPath(
                    at[:2],
                    (Element(0, end[:2], centre=(move.cx, move.cy), clockwise=move.clockwise),),
                )
                pieces.append(LineString(points_of(arc)).buffer(radius, quad_segs=128))
            at = end
    return shapely.union_all(pieces)


def measure(program: Program) -> list[tuple[float, float]]:
    """Per pocket: (reachable area left uncut beyond 0.001 in, area cut beyond 0.0001 in
    outside the pocket), nm², by the moves at Z DN and by every cutting move."""
    results = []
    for boundary, islands, radius, z_dn in pockets_of(program):
        region = boundary
        for island in islands:
            region = region.difference(island)
        reachable = region.buffer(-radius, quad_segs=128).buffer(radius, quad_segs=128)
        at_depth = cut_below(program, z_dn, radius)
        uncut = reachable.difference(at_depth.buffer(REACH_TOL, quad_segs=64))
        # Any move below the top of the part (Z UP is above it in the goldens): the walls
        # and islands must not be cut at any peck level either.
        anywhere = cut_below(program, 0, radius)
        near = anywhere.intersection(boundary.buffer(radius * 4))
        gouge = near.difference(region.buffer(GOUGE_TOL, quad_segs=128))
        results.append((uncut.area, gouge.area))
    return results


def load(name: str) -> Program:
    return document.loads((GOLDEN / name / "program.json").read_text(encoding="utf-8"))


POCKET_GOLDENS = ("pocket-islands", "pocket-mm", "pocket-loop")


@pytest.mark.parametrize("name", POCKET_GOLDENS)
def test_the_moves_clear_the_pocket_and_cut_nothing_else(name: str) -> None:
    """The union of the swept tool at Z DN leaves nothing a round tool could reach, and no
    cutting move touches an island or goes past the wall. pocket-islands' round island
    failed before: its finish pass, one full circle, was left out (its rounded end is its
    start, and the compiler took it for an arc of no length)."""
    program = load(name)
    assert not [p for p in validate(program) if p.severity is Severity.ERROR]
    for uncut, gouge in measure(program):
        assert uncut < 1e4, f"uncut material: {uncut / 25.4e6**2:.3g} in²"
        assert gouge < 1e4, f"cut outside the pocket: {gouge / 25.4e6**2:.3g} in²"


@pytest.mark.parametrize("name", POCKET_GOLDENS)
def test_rapids_only_where_cleared(name: str) -> None:
    """The tool rapids across only above Z UP, and rapids down only straight (XY still) to
    a level already cut at that point or above the part."""
    program = load(name)
    z_up = min(b.z_up for b in program.blocks if isinstance(b, Hole) and b.z_up is not None)
    z_up_nm = to_nm(z_up, program.units)
    at = (0, 0, 10**12)
    deepest: dict[tuple[int, int], int] = {}
    for move in interpret(program).moves:
        if not isinstance(move, Rapid | Feed | ArcFeed):
            continue
        end = (move.x, move.y, move.z)
        if isinstance(move, Rapid) and end[2] < z_up_nm:
            assert end[:2] == at[:2], f"rapid across at Z {end[2]} nm, below Z UP: {move}"
            assert end[2] >= deepest.get(end[:2], z_up_nm), f"rapid into uncut material: {move}"
        if not isinstance(move, Rapid):
            deepest[end[:2]] = min(deepest.get(end[:2], end[2]), end[2])
        at = end


def test_same_program_same_bytes_on_every_target() -> None:
    program = load("pocket-islands")
    for target in ("gcode-linuxcnc", "tape-eia", "events", "svg"):
        assert export(program, target).data == export(program, target).data


# -- generated programs ---------------------------------------------------------------------


@st.composite
def pocket_programs(draw: st.DrawFn) -> Program:
    """A DRILL + POCKET: a rectangle (inch or mm) with a round end or not, 0-2 square or
    round islands, a tool and a step-over that fit, pecks, climb or conventional, either
    spindle direction, and ABS or INC contour blocks."""
    units = draw(st.sampled_from([Units.INCH, Units.MM]))
    scale = D(1) if units is Units.INCH else D("25.4")
    places = D("0.001") if units is Units.INCH else D("0.01")

    def q(inches: float) -> Decimal:
        return (D(str(inches)) * scale).quantize(places)

    width = draw(st.floats(2.0, 4.0))
    height = draw(st.floats(1.5, 2.5))
    x0, y0 = q(draw(st.floats(-2.0, 2.0))), q(draw(st.floats(-2.0, 2.0)))
    w, h = q(width), 2 * q(height / 2)  # the round end's centre on the resolution
    inc = draw(st.booleans())
    mode = Mode.INC if inc else Mode.ABS

    def line(x: Decimal, y: Decimal, px: Decimal, py: Decimal) -> PocketLine:
        return PocketLine(units=units, mode=mode, x=x - px if inc else x, y=y - py if inc else y)

    corners = [(x0 + w, y0), (x0 + w, y0 + h), (x0, y0 + h), (x0, y0)]
    contour: list[Block] = []
    previous = (x0, y0)
    round_end = draw(st.booleans())
    for k, (x, y) in enumerate(corners):
        if round_end and k == 1:
            cy = y0 + h / 2
            cx = x0 + w
            centre = (cx - previous[0], cy - previous[1]) if inc else (cx, cy)
            contour.append(
                PocketArc(units=units, mode=mode, direction=Direction.CCW, x=centre[0], y=centre[1])
            )
            end = (x - previous[0], y - previous[1]) if inc else (x, y)
            contour.append(PocketArcEnd(units=units, mode=mode, x=end[0], y=end[1]))
        else:
            contour.append(line(x, y, *previous))
        previous = (x, y)
    islands = draw(st.integers(0, 2))
    for j in range(islands):
        size = q(0.4)
        ix = x0 + q(0.5) + j * (w - q(1.4)) / max(islands, 1)
        ix = ix.quantize(places)
        iy = (y0 + h / 2 - size / 2).quantize(places)
        start = (ix, iy)
        contour.append(
            Island(
                units=units,
                mode=mode,
                x=ix - previous[0] if inc else ix,
                y=iy - previous[1] if inc else iy,
            )
        )
        previous = start
        if draw(st.booleans()):
            centre = (ix, iy + size / 2)
            rel = (centre[0] - ix, centre[1] - iy) if inc else centre
            contour.append(
                PocketArc(units=units, mode=mode, direction=Direction.CW, x=rel[0], y=rel[1])
            )
            contour.append(
                PocketArcEnd(units=units, mode=mode, x=D(0) if inc else ix, y=D(0) if inc else iy)
            )
        else:
            for x, y in [(ix + size, iy), (ix + size, iy + size), (ix, iy + size), (ix, iy)]:
                contour.append(line(x, y, *previous))
                previous = (x, y)
        previous = start
    diameter = q(draw(st.sampled_from([0.125, 0.25, 0.375])))
    step = draw(st.sampled_from([None, 0.5, 0.8]))  # of the DIA; None: DIA less 0.050 in
    tool = Tool(
        number=3,
        diameter=diameter,
        rpm=draw(st.sampled_from([1200, -900])),
        tcal=D(0),
    )
    pecks = draw(st.integers(1, 3))
    drill = Hole(
        op=HoleOp.DRILL,
        units=units,
        x=x0,
        y=y0,
        z_up=q(0.1),
        z_dn=-q(draw(st.sampled_from([0.1, 0.25]))),
        feed_z=q(4) if units is Units.INCH else D(100),
        pecks=pecks,
        tool=3,
    )
    pocket = Pocket(
        units=units,
        step_over=None if step is None else (diameter * D(str(step))).quantize(places),
        finish=draw(st.sampled_from([None, D(0), q(0.005)])),
        feed_xy=q(10) if units is Units.INCH else D(250),
        tool=3,
    )
    block0 = DataBlock0(
        current_tool=3,
        milling=draw(st.sampled_from(list(MillingMode))),
        tools=(tool,),
    )
    return Program(name="generated", units=units, block0=block0, blocks=(drill, pocket, *contour))


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(pocket_programs())
def test_generated_pocket_programs_clear_and_do_not_gouge(program: Program) -> None:
    """Programs nobody wrote by hand: every one validates, compiles to moves that clear the
    pocket and cut nothing else, and exports alike twice."""
    errors = [str(p) for p in validate(program) if p.severity is Severity.ERROR]
    assert errors == []
    for uncut, gouge in measure(program):
        assert uncut < 1e4, f"uncut material: {uncut:.3g} nm²"
        assert gouge < 1e4, f"cut outside the pocket: {gouge:.3g} nm²"
    assert export(program, "gcode-linuxcnc").data == export(program, "gcode-linuxcnc").data


# -- the editor's forms ----------------------------------------------------------------------


def test_the_pocket_menu_is_key_0_and_its_blocks_are_offered_in_order() -> None:
    drill = Hole(op=HoleOp.DRILL, x=D(0), y=D(0), z_up=D("0.1"), z_dn=D("-0.2"), tool=1)
    program = Program(name="p", blocks=(drill,))
    first = group_menu(program, 2)
    assert [(c.number % 10, c.key, c.reason) for c in first if c.key == "POCKET"] == [
        (0, "POCKET", "")
    ]
    offered = {c.key: c.reason for c in sub_menu(program, 2, "POCKET")}
    assert offered["POCKET"] == ""
    assert offered["PKT_LINE"] == "follows a POCKET block or another of its contour blocks"
    after_pocket = Program(name="p", blocks=(drill, Pocket(feed_xy=D(10), tool=1)))
    offered = {c.key: c.reason for c in sub_menu(after_pocket, 3, "POCKET")}
    assert offered["PKT_LINE"] == offered["PKT_ARC_CC"] == offered["ISLAND"] == ""
    assert offered["POCKET"].startswith("follows the DRILL")


def test_a_pkt_arc_form_makes_its_xy_cent_and_xy_end_blocks() -> None:
    parsed = parse_block(
        "PKT_ARC_CC", {"x": "4", "y": "1", "end_x": "4", "end_y": "2", "stop": "on"}
    )
    assert tuple(parsed.blocks) == (
        PocketArc(direction=Direction.CCW, x=D(4), y=D(1)),
        PocketArcEnd(x=D(4), y=D(2), stop=True),
    )


# -- verify ----------------------------------------------------------------------------------


def test_verify_checks_the_walls_and_islands_and_a_hole_in_an_island_is_intended() -> None:
    """The simulated part of each golden pocket has no gouge. A DRILL later put into
    island 1 is a hole the program asks for: the intended part is the stock less what
    every block means to remove, the hole's cylinder included (before verify judged the
    intended part, it was named a gouge of the island's surface)."""
    program = load("pocket-islands")
    clean = verify(program)
    assert clean.checked["contours"] == 3  # the wall and both islands
    assert [f.kind for f in clean.findings] == []
    drill = Hole(
        op=HoleOp.DRILL, x=D("1.3"), y=D(1), z_up=D("0.1"), z_dn=D("-0.2"), feed_z=D(5), tool=2
    )
    drilled = verify(replace(program, blocks=(*program.blocks, drill)))
    assert [(f.block, f.kind) for f in drilled.findings] == []


# -- mirror -----------------------------------------------------------------------------------


@pytest.mark.parametrize("axis", [Axis.X, Axis.Y, Axis.XY])
def test_a_mirrored_pocket_is_the_mirror_image(axis: Axis) -> None:
    """The mirrored program's pocket is the original's reflected (an arc's direction turns
    under a one-axis mirror), and its moves clear it without touching wall or island.
    Failed before for X and Y: the arcs kept their direction, so the round end bulged
    the other way."""
    program = load("pocket-islands")
    mirrored = mirror(program, axis).program
    assert not [p for p in validate(mirrored) if p.severity is Severity.ERROR]
    sx = -1 if axis in (Axis.X, Axis.XY) else 1
    sy = -1 if axis in (Axis.Y, Axis.XY) else 1
    for (wall, islands, _, _), (m_wall, m_islands, _, _) in zip(
        pockets_of(program), pockets_of(mirrored), strict=True
    ):
        reflected = shapely.affinity.scale(wall, sx, sy, origin=(0, 0))
        assert reflected.symmetric_difference(m_wall).area < 1e6
        for island, m_island in zip(islands, m_islands, strict=True):
            island = shapely.affinity.scale(island, sx, sy, origin=(0, 0))
            assert island.symmetric_difference(m_island).area < 1e6
    for uncut, gouge in measure(mirrored):
        assert uncut < 1e4 and gouge < 1e4


def test_an_arc_end_typed_to_the_resolution_is_on_the_arc() -> None:
    """A 45° arc of radius 2 ends at (1.41421…, 1.41421…); typed to 0.001 in it is
    (1.414, 1.414), 0.0003 in inside the radius. That is typing, not a mistake: the pocket
    is cut (round the arc through both typed ends), as a MILL ARC would be. Failed before:
    "the arc's radius is 2.0000 in at its start and 1.9997 in at its end; they may differ by
    0.0001 in at most"."""
    drill = Hole(
        op=HoleOp.DRILL, x=D(0), y=D(0), z_up=D("0.1"), z_dn=D("-0.1"), feed_z=D(5), tool=1
    )
    blocks = (
        drill,
        Pocket(feed_xy=D(10), tool=1),
        PocketLine(x=D(2), y=D(0)),
        PocketArc(direction=Direction.CCW, x=D(0), y=D(0)),
        PocketArcEnd(x=D("1.414"), y=D("1.414")),
        PocketLine(x=D(0), y=D(0)),
    )
    tools = (Tool(number=1, diameter=D("0.25"), rpm=1500, tcal=D(0)),)
    program = Program(name="sector", block0=DataBlock0(current_tool=1, tools=tools), blocks=blocks)
    assert [str(p) for p in validate(program) if p.severity is Severity.ERROR] == []
    for uncut, gouge in measure(program):
        assert uncut < 1e4 and gouge < 1e4


def test_a_pocket_with_a_contour_error_is_drawn_with_the_error_on_its_block() -> None:
    """An open boundary is drawn where it is, its last block red with the message, and the
    blocks after the pocket still drawn. Failed before: the block with the error was left out
    of the drawing, which changed the pocket into another one."""
    program = document.loads(
        (Path(__file__).parent / "bad" / "pocket-open-boundary" / "program.json").read_text(
            encoding="utf-8"
        )
    )
    shown = preview(program)
    assert 'class="block problem" data-block="5"' in shown.svg
    assert "the contour is not closed" in shown.svg
    for number in (3, 4, 5):
        assert f'data-block="{number}"' in shown.svg


def test_verify_finds_material_left_in_the_pocket() -> None:
    """The part cut by a program whose POCKET went round one island more than the program
    verified asks for: the material of that island is named as left in the pocket, at its
    place. (Each golden pocket leaves none: test_verify_checks_the_walls_and_islands...)."""
    program = load("pocket-islands")
    extra = (
        Island(x=D("3.4"), y=D("0.4")),
        PocketLine(x=D("3.6"), y=D("0.4")),
        PocketLine(x=D("3.6"), y=D("0.6")),
        PocketLine(x=D("3.4"), y=D("0.6")),
        PocketLine(x=D("3.4"), y=D("0.4")),
    )
    cut_round_it = replace(program, blocks=(*program.blocks, *extra))
    grid, placed = prepare(cut_round_it)
    result = Verification(program, simulate(grid, placed, None, 25_400), tolerance=25_400)
    check_part(result, programmed_geometry(program), 25_400)
    left = [f for f in result.findings if f.kind == "rest material"]
    assert [f.block for f in left] == [2]
    assert 3.35 < left[0].x / 25.4e6 < 3.65 and 0.35 < left[0].y / 25.4e6 < 0.65


# -- what an adversarial review found (each failed before its fix) --------------------------


def _review_program(*contour: Block, step: str | None = None, finish: str | None = None) -> Program:
    """T1 DIA 0.25, RPM 1500; DRILL at 0,0 (Z UP .1, Z DN -.25) + POCKET + `contour`."""
    drill = Hole(
        op=HoleOp.DRILL, x=D(0), y=D(0), z_up=D("0.1"), z_dn=D("-0.25"), feed_z=D(5), tool=1
    )
    pocket = Pocket(
        feed_xy=D(10),
        tool=1,
        step_over=None if step is None else D(step),
        finish=None if finish is None else D(finish),
    )
    tools = (Tool(number=1, diameter=D("0.25"), rpm=1500, tcal=D(0)),)
    return Program(
        name="review",
        block0=DataBlock0(current_tool=1, tools=tools),
        blocks=(drill, pocket, *contour),
    )


def _rectangle(w: str, h: str) -> tuple[PocketLine, ...]:
    return (
        PocketLine(x=D(w), y=D(0)),
        PocketLine(x=D(w), y=D(h)),
        PocketLine(x=D(0), y=D(h)),
        PocketLine(x=D(0), y=D(0)),
    )


def test_an_island_without_its_contour_is_an_error_and_verify_answers() -> None:
    """An ISLAND with no PKT blocks after it made the whole pocket vanish from every output
    with no message, and verify raised (zip of an empty contour)."""
    program = _review_program(*_rectangle("2", "1.5"), Island(x=D("0.5"), y=D("0.5")))
    errors = [str(p) for p in validate(program) if p.severity is Severity.ERROR]
    assert errors == [
        "block 7: ISLAND without its contour: PKT LINE and PKT ARC blocks follow it and "
        "draw the island back to its start point"
    ]
    verify(program)  # answers (the pocket is not cut), does not raise


def test_a_step_over_that_would_make_hundreds_of_passes_is_refused_not_crashed() -> None:
    """STEP .001 on a 2.4 in square raised RecursionError (a 500 in the editor)."""
    program = _review_program(*_rectangle("2.4", "2.4"), step="0.001")
    errors = [str(p) for p in validate(program) if p.severity is Severity.ERROR]
    assert len(errors) == 1 and errors[0].startswith("block 2, STEP: a step-over of 0.0010 in")


def test_a_finish_allowance_wider_than_the_tool_can_take_is_refused() -> None:
    """FIN CUT .3 with a 0.25 tool was taken: the finishing pass cut full width, plunged
    again into solid material and added a score of cleanup spikes."""
    program = _review_program(*_rectangle("2", "1.5"), finish="0.3")
    errors = [str(p) for p in validate(program) if p.severity is Severity.ERROR]
    assert errors == [
        "block 2, FIN CUT: 0.300 in is more than the finishing pass can take: at most the "
        "tool's radius, 0.125 in"
    ]


def test_blocks_after_a_closed_boundary_without_an_island_are_named() -> None:
    """A PKT LINE after the boundary closed (an ISLAND missing, or deleted) said only
    "the contour is not closed: it ends 1.4142 in from where it starts"."""
    program = _review_program(*_rectangle("2", "1.5"), PocketLine(x=D(1), y=D(1)))
    errors = [str(p) for p in validate(program) if p.severity is Severity.ERROR]
    assert errors == [
        "block 7: the boundary closes at block 6, so PKT LINE starts nothing: begin an "
        "island with an ISLAND block first"
    ]


def test_a_block_after_a_closed_boundary_is_drawn_where_it_is_with_its_error() -> None:
    """The compile's own finding (the boundary closed, so the PKT LINE after it starts
    nothing) is geometry, declared on the POCKET kind: the block is drawn in its place, red
    with the message. Failed before: the preview's hand list of geometry rules missed
    POCKET_ORDER, so the block was left out of the drawing (listed as not drawn) and the
    pocket drawn as if the block were not there."""
    program = _review_program(*_rectangle("2", "1.5"), PocketLine(x=D(1), y=D(1)))
    shown = preview(program)
    assert 'class="block problem" data-block="7"' in shown.svg
    assert "so PKT LINE starts nothing" in shown.svg
    assert shown.shown.not_drawn == ()


def test_an_arc_about_its_own_start_says_so() -> None:
    program = _review_program(
        PocketLine(x=D(2), y=D(0)),
        PocketArc(direction=Direction.CCW, x=D(2), y=D(0)),
        PocketArcEnd(x=D(2), y=D(0)),
        PocketLine(x=D(0), y=D(0)),
    )
    errors = [str(p) for p in validate(program) if p.severity is Severity.ERROR]
    assert "block 4: the arc's centre is its start point; the radius would be zero" in errors


def test_messages_about_a_pocket_name_the_pocket() -> None:
    """STOP on a POCKET was refused twice; CUTTER COMP before a POCKET spoke of CIRCLE and
    FRAME; a tool without DIA spoke of cutter-compensated milling; an open boundary ending
    in an arc was named on the arc's XY-CENT, not its XY-END where it ends."""
    program = _review_program(*_rectangle("2", "1.5"))
    blocks = list(program.blocks)
    blocks[1] = replace(blocks[1], stop=True)
    said = [str(p) for p in validate(replace(program, blocks=tuple(blocks)))]
    assert said == ["block 2, STOP: a POCKET block cannot carry STOP"]
    drill = program.blocks[0]
    assert isinstance(drill, Hole)
    blocks = [replace(drill, comp=Comp.RIGHT), *program.blocks[1:]]
    said = [str(p) for p in validate(replace(program, blocks=tuple(blocks)))]
    assert said == [
        "block 1, CUTTER COMP: warning: cutter compensation on the DRILL before a POCKET; a "
        "POCKET keeps the tool off its wall and islands by itself, so it has no effect"
    ]
    no_dia = replace(program, block0=replace(program.block0, tools=(Tool(number=1, rpm=900),)))
    assert "a POCKET needs the cutter's measured diameter" in str(validate(no_dia)[0])
    open_arc = _review_program(
        PocketLine(x=D(2), y=D(0)),
        PocketArc(direction=Direction.CCW, x=D(2), y=D(1)),
        PocketArcEnd(x=D(2), y=D(2)),
    )
    said = [str(p) for p in validate(open_arc) if p.severity is Severity.ERROR]
    assert len(said) == 1 and said[0].startswith("block 5: the contour is not closed")


def _lobed(lines: int) -> Program:
    """A pocket whose wall is `lines` short PKT LINEs round a lobed outline (radius
    2 + 0.1·cos 7θ in): what a DXF of a curved part gives."""
    points = []
    for k in range(1, lines + 1):
        a = 2 * math.pi * k / lines
        r = 2 + 0.1 * math.cos(7 * a)
        points.append((D(f"{r * math.cos(a):.3f}"), D(f"{r * math.sin(a):.3f}")))
    program = _review_program(*(PocketLine(x=x, y=y) for x, y in points))
    drill = program.blocks[0]
    assert isinstance(drill, Hole)
    start = replace(drill, x=points[-1][0], y=points[-1][1])
    return replace(program, blocks=(start, *program.blocks[1:]))


def test_verify_of_a_wall_of_many_blocks_keeps_no_array_per_block() -> None:
    """A wall of 200 PKT LINEs: verify held every element's distances to every cell at once
    (2.7 GB for 200 lines, past 20 GB for 2000). It keeps the nearest so far instead."""
    program = _lobed(200)
    assert [str(p) for p in validate(program) if p.severity is Severity.ERROR] == []
    grid, placed = prepare(program, cells=200)
    simulation = simulate(grid, placed, None, 25_400)
    geometry = programmed_geometry(program)
    tracemalloc.start()
    try:
        check_part(Verification(program, simulation), geometry, 25_400)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    cells = grid.nx * grid.ny
    assert peak < 40 * 8 * cells, f"{peak / 1e6:.0f} MB for {cells} cells"


def test_a_curve_drawn_as_short_lines_is_not_called_narrow() -> None:
    """A lobed wall of 100 PKT LINEs (curvature radius at least 0.58 in, a 0.25 in tool)
    gave ten 'narrower than the tool' warnings, for the fillets at its joints. The narrow
    slot of the bad corpus still warns (tests/bad/pocket-narrow-slot)."""
    program = _lobed(100)
    assert [str(p) for p in validate(program)] == []
    for uncut, gouge in measure(program):
        assert uncut < 1e4 and gouge < 1e4


def test_an_island_touching_the_wall_is_not_also_called_narrow() -> None:
    """An island drawn against the wall got the 'touches the wall' warning and two 'narrower
    than the tool' warnings for the corners where it meets the wall, which every round tool
    leaves (found by the review of POCKET)."""
    island = (
        Island(x=D(0), y=D(1)),
        PocketLine(x=D(1), y=D(1)),
        PocketLine(x=D(1), y=D(2)),
        PocketLine(x=D(0), y=D(2)),
        PocketLine(x=D(0), y=D(1)),
    )
    program = _review_program(*_rectangle("4", "3"), *island)
    said = [str(p) for p in validate(program)]
    assert said == [
        "block 7: warning: island 1 touches or crosses the pocket's wall; the pocket is cut "
        "around what is left of the boundary without it (the island joins the wall)"
    ]
    for uncut, gouge in measure(program):
        assert uncut < 1e4 and gouge < 1e4


def test_a_pkt_arc_without_its_other_half_is_named() -> None:
    centre_only = _review_program(
        PocketLine(x=D(2), y=D(0)),
        PocketArc(direction=Direction.CCW, x=D(2), y=D(1)),
        PocketLine(x=D(0), y=D(0)),
    )
    assert "block 4: PKT ARC XY-CENT without its XY-END block just after it" in [
        str(p) for p in validate(centre_only)
    ]
    end_only = _review_program(PocketLine(x=D(2), y=D(0)), PocketArcEnd(x=D(0), y=D(0)))
    assert "block 4: PKT ARC XY-END without its XY-CENT block just before it" in [
        str(p) for p in validate(end_only)
    ]
