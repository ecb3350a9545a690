"""A DXF drawing's contours and holes as data blocks (issue 22).

    cut_sides(drawing, milling=CLIMB) -> [CutSide]      # which side each contour is cut from
    contour_ops(drawing, contour, start=0, clockwise=None, comp=None, tool=1, inside=False) -> Op
    contour_blocks(drawing, contour, ...same choices) -> (blocks, report)
    program_from_drawing(drawing) -> Program

A contour becomes a DRILL that starts a mill sequence (CUT LT / CUT RT for the compensation
side) and MILL STD / MILL ARC + XY-END blocks (QCIR where it is one), exactly: lines and
arcs as drawn, each value rounded once to the programming resolution (reported when it
moves). A circle becomes DRILL + CIRCLE and an axis-parallel rectangle (sharp, or with four
equal corner arcs) DRILL + FRAME, where the routine cuts exactly that contour (values on
the programming grid). Holes become DRILL blocks, and BOLT CIR where three or more of one
diameter are equally spaced on a circle.

Which side the cutter goes is one rule, `cut_sides`, used by the whole-drawing conversion
(`millblocks import`) and the choosing page alike: an outer contour (no closed contour
round it, or an even number nested round it: `enclosing`, `nesting`) is cut from outside,
an inner one (a hole or slot inside another contour) from inside; climb milling with a
clockwise spindle (Data Block 0's default): outer contours clockwise and inner ones
counter-clockwise, both with the tool on the left (CUT LT); conventional milling the
reverse, with the tool on the right (CUT RT); open contours are tool-centre paths (no
compensation), cut as drawn.

The whole-drawing conversion chooses: holes first, then inner contours, then outer ones
(the outside profile last), each on the side `cut_sides` gives. Each starts at its
lowest, then leftmost, point. The drawing has no depths, tools or speeds: the program is a
2-axis program (as an events import is) with tool 1, and the report says what to enter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from app.cnc.blocks import (
    Block,
    Circle,
    Comp,
    DataBlock0,
    Frame,
    HoleOp,
    MillingMode,
    Placement,
    Program,
)
from app.cnc.formats.dxf.reader import Contour, Drawing, DxfNotes, Hole, Segment
from app.cnc.plane import Element as MillElement
from app.cnc.plane import Path, signed_area
from app.cnc.pocketing import regions
from app.cnc.recognition.build import Builder, SetUp, block0, make_program, used_tools
from app.cnc.recognition.common import (
    XY,
    ImportNote,
    Notes,
    decimal_of,
    feed_decimal,
    quantize_nm,
    resolution_nm,
)
from app.cnc.recognition.ops import Element, HoleOpR, HoleSpec, MillOp, Op, PocketOp, RoutineOp
from app.cnc.recognition.recognise import find_bolt_circles
from app.cnc.recognition.steps import ToolData

CHORD_NM = 500  # chords within 0.5 µm of an arc when deciding which contour holds which


@dataclass(frozen=True)
class Cutting:
    """What a drawing cannot give and the machinist enters (the choosing page): the DRILL's
    Z UP, Z DN and FEEDR Z (nm, nm/min; all None: a 2-axis program, the quill moved by hand)
    and the mill blocks' FEEDR XY (None: the drawing's `feed`, the reader option), and the
    diameter and RPM of tools by number (nm; a tool not given has none)."""

    z_up: int | None = None
    z_dn: int | None = None
    feed_z: int | None = None
    feed_xy: int | None = None
    diameters: tuple[tuple[int, int], ...] = ()
    rpms: tuple[tuple[int, int], ...] = ()

    @property
    def has_depth(self) -> bool:
        return self.z_up is not None and self.z_dn is not None


NO_CUTTING = Cutting()


def hole_spec(drawing: Drawing, tool: int = 1, cutting: Cutting = NO_CUTTING) -> HoleSpec:
    """A DRILL with the depths and FEEDR Z of `cutting` (none by default: a 2-axis block, the
    drawing has no depths), in the program's units."""
    return HoleSpec(
        HoleOp.DRILL, cutting.z_up, cutting.z_dn, cutting.feed_z, 1, tool, drawing.units
    )


def as_path(contour: Contour) -> Path:
    """The contour as a `mill.Path` (float nm; elements named by entity index)."""
    return Path(
        _f(contour.segments[0].start),
        tuple(
            MillElement(
                s.source,
                _f(s.end),
                centre=None if s.centre is None else _f(s.centre),
                clockwise=s.clockwise,
            )
            for s in contour.segments
        ),
    )


def contour_ops(
    drawing: Drawing,
    contour: Contour,
    start: int = 0,
    clockwise: bool | None = None,
    comp: Comp | None = None,
    tool: int = 1,
    inside: bool = False,
    cutting: Cutting = NO_CUTTING,
) -> Op:
    """The operation that cuts `contour`: from the start of its segment `start` (closed
    contours; an open one starts at either end: 0 or the last index), round it `clockwise`
    or not (None: as drawn), the tool on the `comp` side (None: left — climb with a
    clockwise spindle). A closed contour that a CIRCLE or FRAME routine cuts exactly becomes
    that routine (INSIDE when `inside`, else OUTSIDE; the routine's own direction comes
    from Data Block 0). The DRILL's depths and the feed are `cutting`'s."""
    spec = hole_spec(drawing, tool, cutting)
    feed = drawing.feed if cutting.feed_xy is None else cutting.feed_xy
    lines = list(contour.sources)
    routine = _routine(drawing, contour, inside, tool, feed) if contour.closed else None
    if routine is not None:
        at, block = routine
        return RoutineOp(lines, at, spec, block)
    segments = list(contour.segments)
    if contour.closed:
        ccw = signed_area(as_path(contour)) > 0
        if clockwise is not None and clockwise == ccw:
            segments = [s.reversed() for s in reversed(segments)]
            # Segment `start` begins where, reversed, segment n - start begins.
            start = (len(segments) - start) % len(segments)
        segments = segments[start:] + segments[:start]
        if len(segments) == 1:
            segments = _halves(segments[0])
    elif start:
        segments = [s.reversed() for s in reversed(segments)]
    side = Comp.NONE if not contour.closed else (comp or Comp.LEFT)
    elements = [Element(s.source, s.end, s.centre, s.clockwise, None, feed) for s in segments]
    return MillOp(lines, segments[0].start, spec, side, elements)


def pocket_ops(
    drawing: Drawing,
    boundary: Contour,
    islands: list[Contour],
    start: int = 0,
    tool: int = 1,
    cutting: Cutting = NO_CUTTING,
) -> PocketOp:
    """The DRILL + POCKET that clears the inside of the closed `boundary` (drawn from the
    start of its segment `start`) round the closed `islands` (each from its first segment).
    A pocket's contour is a shape: each is taken as drawn, whichever way round."""

    def elements(segments: list[Segment]) -> list[Element]:
        if len(segments) == 1:
            segments = _halves(segments[0])  # a circle: two half circles, as PKT ARCs
        return [Element(s.source, s.end, s.centre, s.clockwise, None, 0) for s in segments]

    segments = list(boundary.segments)
    segments = segments[start:] + segments[:start]
    return PocketOp(
        [*boundary.sources, *(s for i in islands for s in i.sources)],
        segments[0].start,
        hole_spec(drawing, tool, cutting),
        drawing.feed if cutting.feed_xy is None else cutting.feed_xy,
        elements(segments),
        [(i.segments[0].start, elements(list(i.segments))) for i in islands],
    )


def holds(drawing: Drawing, outer: int, inner: int) -> bool:
    """True when contour `outer` of the drawing is round contour `inner`: one of the closed
    contours `enclosing` finds round it, out to the outermost."""
    parents = enclosing(drawing)
    around = parents[inner]
    while around is not None:
        if around == outer:
            return True
        around = parents[around]
    return False


def enclosing(drawing: Drawing) -> list[int | None]:
    """For each contour of the drawing, the nearest closed contour round it (None: none),
    found once and kept with the drawing.

    A contour is inside a closed contour when its first point is (or lies on its edge);
    the nearest such is the smallest, and only a larger one (or as large and later in the
    drawing) may be round a closed contour, so each contour has one and no contour is round
    itself. Nested contours are then a tree whose depth is the number of contours round
    each (the rule of `cut_sides`). The work: each closed contour's ring is made once;
    each first point is tried against the rings whose boxes hold it, smallest first, until
    one holds it (nested contours: the first tried).
    """
    if drawing.enclosing is not None:
        return drawing.enclosing
    contours = drawing.contours
    closed = [k for k, c in enumerate(contours) if c.closed]
    rings = {k: _ring(contours[k]) for k in closed}
    # The closed contours smallest first (ties: in drawing order), with their boxes.
    order = sorted(closed, key=lambda k: (abs(_area(rings[k])), k))
    rank = {k: at for at, k in enumerate(order)}
    boxes = np.array([_box(rings[k]) for k in order], dtype=np.float64).reshape(len(order), 4)
    found: list[int | None] = []
    for k, contour in enumerate(contours):
        x, y = contour.segments[0].start
        first = rank[k] + 1 if contour.closed else 0
        held = (
            (boxes[first:, 0] <= x)
            & (boxes[first:, 1] <= y)
            & (x <= boxes[first:, 2])
            & (y <= boxes[first:, 3])
        )
        found.append(
            next(
                (
                    order[first + at]
                    for at in np.flatnonzero(held).tolist()
                    if regions.inside([rings[order[first + at]]], (x, y))
                ),
                None,
            )
        )
    drawing.enclosing = found
    return found


def _ring(contour: Contour) -> regions.Ring:
    """A closed contour as a ring for telling inside from outside: lines as they are, arcs
    as chords within CHORD_NM of them, or within a ten-thousandth of the radius for an arc
    of more than 5 mm (at most 222 chords to a whole circle, whatever its size)."""
    path = as_path(contour)
    points = [path.start]
    current = path.start
    for element in path.elements:
        tolerance = float(CHORD_NM)
        if element.centre is not None:
            tolerance = max(tolerance, math.dist(current, element.centre) / 10_000)
        points += regions.element_points(current, element, tolerance)
        current = element.end
    return regions.to_ring(points)


def _box(ring: regions.Ring) -> tuple[int, int, int, int]:
    """The ring's bounding box: (x low, y low, x high, y high)."""
    xs = [x for x, _ in ring]
    ys = [y for _, y in ring]
    return (min(xs), min(ys), max(xs), max(ys))


def _area(ring: regions.Ring) -> float:
    """The ring's signed area (shoelace), nm²."""
    return (
        sum(
            x0 * y1 - x1 * y0
            for (x0, y0), (x1, y1) in zip(ring, [*ring[1:], *ring[:1]], strict=True)
        )
        / 2
    )


def contour_blocks(
    drawing: Drawing,
    contour: Contour,
    start: int = 0,
    clockwise: bool | None = None,
    comp: Comp | None = None,
    tool: int = 1,
    inside: bool = False,
) -> tuple[list[Block], list[ImportNote]]:
    """The blocks of one chosen contour (the choices as `contour_ops` takes them), numbered
    from 1, and the report of how they were made (rounding, what became what)."""
    notes = DxfNotes()
    notes.entities = drawing.entities
    builder = Builder(notes)
    builder.run([contour_ops(drawing, contour, start, clockwise, comp, tool, inside)])
    builder.flush_rounding()
    return builder.blocks, notes.report()


def _halves(circle: Segment) -> list[Segment]:
    """A full circle as two half arcs (an arc block cannot end where it starts)."""
    assert circle.centre is not None
    cx, cy = circle.centre
    sx, sy = circle.start
    opposite = (2 * cx - sx, 2 * cy - sy)
    return [
        Segment(circle.start, opposite, circle.centre, circle.clockwise, circle.source),
        Segment(opposite, circle.start, circle.centre, circle.clockwise, circle.source),
    ]


def _routine(
    drawing: Drawing, contour: Contour, inside: bool, tool: int, feed_nm: int
) -> tuple[XY, Circle | Frame] | None:
    units = drawing.units
    placement = Placement.INSIDE if inside else Placement.OUTSIDE
    feed = feed_decimal(feed_nm, units)

    def on_grid(*values: int) -> bool:
        return all(quantize_nm(v, units) == v for v in values)

    if contour.is_circle:
        segment = contour.segments[0]
        assert segment.centre is not None
        radius = math.dist(segment.start, segment.centre)
        r = round(radius)
        if abs(radius - r) > 0.5 or not on_grid(*segment.centre, r):
            return None
        circle = Circle(
            placement=placement,
            radius=decimal_of(r, units),
            feed_xy=feed,
            tool=tool,
            units=units,
        )
        return segment.centre, circle
    frame = _frame(contour)
    if frame is None:
        return None
    x0, y0, width, height, corner = frame
    if not on_grid(x0, y0, width, height, corner):
        return None
    block = Frame(
        placement=placement,
        xl=decimal_of(width, units),
        yw=decimal_of(height, units),
        corner_radius=decimal_of(corner, units),
        feed_xy=feed,
        tool=tool,
        units=units,
    )
    return (x0, y0), block


def _frame(contour: Contour) -> tuple[int, int, int, int, int] | None:
    """(x0, y0, width, height, corner radius) when the contour is exactly an axis-parallel
    rectangle, sharp or with four equal 90° corner arcs; else None."""
    segments = contour.segments
    xs = [p for s in segments for p in (s.start[0], s.end[0])]
    ys = [p for s in segments for p in (s.start[1], s.end[1])]
    x0, x1, y0, y1 = min(xs), max(xs), min(ys), max(ys)
    arcs = [s for s in segments if s.centre is not None]
    lines = [s for s in segments if s.centre is None]
    if len(lines) != 4 or len(arcs) not in (0, 4):
        return None
    corner = 0
    if arcs:
        first = arcs[0]
        assert first.centre is not None
        corner = abs(first.start[0] - first.centre[0]) + abs(first.start[1] - first.centre[1])
    want_lines = {
        frozenset({(x0 + corner, y0), (x1 - corner, y0)}),
        frozenset({(x1, y0 + corner), (x1, y1 - corner)}),
        frozenset({(x1 - corner, y1), (x0 + corner, y1)}),
        frozenset({(x0, y1 - corner), (x0, y0 + corner)}),
    }
    if {frozenset({s.start, s.end}) for s in lines} != want_lines:
        return None
    want_arcs = {
        (x0 + corner, y0 + corner),
        (x1 - corner, y0 + corner),
        (x1 - corner, y1 - corner),
        (x0 + corner, y1 - corner),
    }
    if arcs and {s.centre for s in arcs} != want_arcs:
        return None
    if arcs and any(s.clockwise != arcs[0].clockwise for s in arcs):
        return None
    return x0, y0, x1 - x0, y1 - y0, corner


def nesting(drawing: Drawing) -> list[int]:
    """How many closed contours are round each contour (0: an outer one), by `enclosing`."""
    parents = enclosing(drawing)
    depths: dict[int, int] = {}
    for k in range(len(parents)):
        # Up to a contour whose depth is known, then down again (no recursion: a drawing
        # may nest thousands deep).
        path = []
        at: int | None = k
        while at is not None and at not in depths:
            path.append(at)
            at = parents[at]
        depth = -1 if at is None else depths[at]
        for j in reversed(path):
            depth += 1
            depths[j] = depth
    return [depths[k] for k in range(len(parents))]


@dataclass(frozen=True)
class CutSide:
    """Which side of a contour the cutter goes, and which way round it cuts.

    `inner`: the contour lies inside another closed contour (an odd number nested round
    it): a hole or slot, cut from inside (a CIRCLE/FRAME routine INSIDE). `clockwise`:
    the way round (None: an open contour, cut as drawn). `comp`: the compensation side that
    puts the tool on the waste side going that way (NONE for an open contour)."""

    inner: bool
    clockwise: bool | None
    comp: Comp

    @property
    def direction(self) -> str:
        """As the choosing page names it: "cw", "ccw" or "drawn" (an open contour)."""
        if self.clockwise is None:
            return "drawn"
        return "cw" if self.clockwise else "ccw"


def cut_sides(drawing: Drawing, milling: MillingMode = MillingMode.CLIMB) -> list[CutSide]:
    """For each contour of `drawing`, the side the cutter goes and the way round: outer
    contours from outside, inner ones from inside; `milling` CLIMB (a clockwise spindle, as
    the drawing gives no speeds): outside clockwise and inside counter-clockwise with the
    tool on the left; CONVENTIONAL the reverse with the tool on the right (DESIGN.md §3)."""
    climb = milling is MillingMode.CLIMB
    comp = Comp.LEFT if climb else Comp.RIGHT
    sides = []
    for contour, depth in zip(drawing.contours, nesting(drawing), strict=True):
        inner = depth % 2 == 1
        if not contour.closed:
            sides.append(CutSide(inner, None, Comp.NONE))
        else:
            sides.append(CutSide(inner, climb != inner, comp))
    return sides


def program_from_drawing(drawing: Drawing) -> Program:
    """Every hole and contour of the drawing as blocks (the choices in the module doc)."""
    notes = drawing.notes
    holes = sorted(drawing.holes, key=lambda h: (h.diameter, h.source))
    hole_ops: list[Op] = []
    for diameter in sorted({h.diameter for h in holes}):
        group = [h for h in holes if h.diameter == diameter]
        ordered = _bolt_order(group)
        hole_ops += find_bolt_circles(
            [HoleOpR([h.source], h.centre, hole_spec(drawing)) for h in ordered],
            resolution_half(drawing),
            notes,
        )
    sides = cut_sides(drawing)
    order = sorted(
        range(len(drawing.contours)),
        key=lambda k: (not sides[k].inner, _lowest(drawing.contours[k]), k),
    )
    ops = list(hole_ops)
    for k in order:
        contour, side = drawing.contours[k], sides[k]
        start = _start_index(contour)
        ops.append(
            contour_ops(drawing, contour, start, side.clockwise, side.comp, inside=side.inner)
        )
    builder = Builder(notes)
    builder.run(ops)
    builder.flush_rounding()
    if not ops:
        notes.assumed(None, "nothing in the drawing became a block")
    db0 = drawing_block0(drawing, ops, notes)
    return make_program(
        drawing.name, "", drawing.units, "imported from a DXF drawing", db0, builder.blocks
    )


def drawing_block0(
    drawing: Drawing, ops: list[Op], notes: Notes, cutting: Cutting = NO_CUTTING
) -> DataBlock0:
    """Data Block 0 for the blocks of `ops` (each tool they use, with the diameter and RPM
    `cutting` gives it, else none), and the notes that say what is still missing: depths,
    diameters."""
    tools = [tool for tool, _ in used_tools(ops)]
    diameters = dict(cutting.diameters)
    if ops and not cutting.has_depth:
        notes.needs(
            None,
            "the drawing has no depths: the blocks have no Z UP / Z DN (a 2-axis program, the "
            "quill moved by hand); enter them to cut under program control",
        )
    if ops:
        every = " (every block)" if len(tools) == 1 else ""
        for tool in tools:
            if tool not in diameters:
                notes.needs(
                    None,
                    f"tool {tool}{every} has no diameter in the drawing: enter it in Data "
                    "Block 0 (cutter compensation and CIRCLE/FRAME need it)",
                )
    setup = SetUp(
        units=drawing.units,
        tools={tool: ToolData(diameter=diameters.get(tool)) for tool in tools},
        rpms={tool: rpm for tool, rpm in cutting.rpms if tool in tools},
    )
    return block0(setup, ops, notes)


def resolution_half(drawing: Drawing) -> int:
    """Half a programming step (nm): holes this close to a bolt circle's are on it."""
    return resolution_nm(drawing.units) // 2


def _bolt_order(group: list[Hole]) -> list[Hole]:
    """Holes of one diameter, those equally spaced about a common centre first and in
    clockwise order from the one nearest straight below the centre (MillBlocks' BOLT CIR
    order), the rest in drawing order."""
    if len(group) < 3:
        return group
    cx = sum(h.centre[0] for h in group) / len(group)
    cy = sum(h.centre[1] for h in group) / len(group)
    radii = [math.dist(h.centre, (cx, cy)) for h in group]
    if max(radii) - min(radii) > 2 * 12_700 or min(radii) == 0:
        return group

    def clockwise_from_below(h: Hole) -> float:
        dx, dy = h.centre[0] - cx, h.centre[1] - cy
        return math.degrees(math.atan2(-dx, -dy)) % 360

    return sorted(group, key=clockwise_from_below)


def _lowest(contour: Contour) -> tuple[int, int]:
    low = min((s.start for s in contour.segments), key=lambda p: (p[1], p[0]))
    return (low[1], low[0])


def _start_index(contour: Contour) -> int:
    """The segment that starts at the contour's lowest, then leftmost, point (closed), or
    the end nearer the origin's side (open: the chain's own start)."""
    if not contour.closed:
        return 0
    starts = [s.start for s in contour.segments]
    return min(range(len(starts)), key=lambda k: (starts[k][1], starts[k][0], k))


def _f(p: XY) -> tuple[float, float]:
    return (float(p[0]), float(p[1]))
