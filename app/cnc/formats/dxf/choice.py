"""What the machinist chose from a drawing, as blocks (issue 22's choosing page).

    chosen_blocks(drawing, choices) -> Chosen(blocks, report)
    insert_blocks(program, blocks, after) -> Program      # raises PlacementError
    drawing_svg(drawing, chosen=()) -> str

A choice is a contour (which one, where the cut starts, which way round, which side the
tool is on, INSIDE or OUTSIDE when a routine cuts it exactly, the tool), a pocket (a closed
contour whose inside is cleared round the closed contours inside it chosen as its
islands: DRILL + POCKET + PKT blocks), or a group of holes
(in the order they are to be drilled, made into a BOLT CIR where three or more of one
diameter are equally spaced). The choices become blocks in the order given, exactly as
`blocks.py` makes them for a whole drawing. The report says what became what, what was
rounded, and what of the drawing was not chosen or could not be read — nothing is left out
silently.

Pure: no Flask, database or serial code. Lengths in nm, drawing coordinates (part zero at
the drawing's origin), Y up.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import svgwrite

from app.cnc.blocks import Block, BoltCircle, Comp, DataBlock0, Mode, Program
from app.cnc.formats.dxf.blocks import (
    contour_ops,
    drawing_block0,
    holds,
    hole_spec,
    pocket_ops,
    resolution_half,
)
from app.cnc.formats.dxf.reader import Contour, Drawing, DxfNotes, Segment
from app.cnc.imports.build import Builder
from app.cnc.imports.common import ImportNote
from app.cnc.imports.ops import HoleOpR, Op, PocketOp
from app.cnc.imports.recognise import find_bolt_circles
from app.cnc.structure import mill_sequence_end, starts_mill_sequence
from app.cnc.units import Units

DIRECTIONS = ("drawn", "cw", "ccw")


@dataclass(frozen=True)
class ContourChoice:
    """Cut contour `contour` (an index into `Drawing.contours`) from the start of its segment
    `start` (an open contour: 0 from its first end, any other value from its last), round
    it `direction` ("drawn", "cw" or "ccw"; closed contours), the tool on the `comp` side
    (None: LEFT for a closed contour, none for an open one, which is a tool-centre path),
    with tool `tool`. `inside`: where a CIRCLE or FRAME routine cuts the contour exactly,
    cut it from the INSIDE (else OUTSIDE)."""

    contour: int
    start: int = 0
    direction: str = "drawn"
    comp: Comp | None = None
    inside: bool = False
    tool: int = 1


@dataclass(frozen=True)
class HoleChoice:
    """Drill holes `holes` (indices into `Drawing.holes`) in that order with tool `tool`;
    `bolt_circles`: equally spaced holes of one diameter become a BOLT CIR."""

    holes: tuple[int, ...]
    tool: int = 1
    bolt_circles: bool = True


@dataclass(frozen=True)
class PocketChoice:
    """Clear the inside of closed contour `contour` (its cut starting at its segment
    `start`) round the closed contours `islands`, with tool `tool`: DRILL + POCKET +
    PKT LINE / PKT ARC blocks, each island an ISLAND and its blocks."""

    contour: int
    islands: tuple[int, ...] = ()
    start: int = 0
    tool: int = 1


Choice = ContourChoice | HoleChoice | PocketChoice


class ChoiceError(ValueError):
    """A choice that names no contour or hole of the drawing, or a value not allowed."""


class PlacementError(ValueError):
    """Blocks cannot go where asked in a program (the message says why and where instead)."""


@dataclass(frozen=True)
class Chosen:
    """The blocks of the choices (numbered from 1), a Data Block 0 for them (each tool they
    use) and the report."""

    blocks: tuple[Block, ...]
    block0: DataBlock0
    report: tuple[ImportNote, ...]

    def program(self, name: str, units: Units) -> Program:
        """A new program of these blocks."""
        return Program(
            name=name,
            units=units,
            notes="imported from a DXF drawing",
            block0=self.block0,
            blocks=self.blocks,
        )


def chosen_blocks(drawing: Drawing, choices: Sequence[Choice]) -> Chosen:
    """The blocks that cut `choices` in order, and the report (see the module's note).

    Raises ChoiceError for a contour or hole index not in the drawing, a hole chosen twice,
    a direction other than DIRECTIONS or a tool outside 1-24."""
    notes = DxfNotes()
    notes.entities = drawing.entities
    for note in drawing.notes.report():
        # The reader's notes (layers left out, entities it could not take, units assumed).
        notes.entries.append(note)
    ops: list[Op] = []
    used: set[int] = set()
    holes_used: set[int] = set()
    for choice in choices:
        if not 1 <= choice.tool <= 24:
            raise ChoiceError(f"tool {choice.tool}: allowed 1 to 24")
        if isinstance(choice, PocketChoice):
            ops.append(_pocket(drawing, choice))
            for k in (choice.contour, *choice.islands):
                used.update(drawing.contours[k].sources)
        elif isinstance(choice, ContourChoice):
            contour = _contour(drawing, choice.contour)
            if choice.direction not in DIRECTIONS:
                raise ChoiceError(
                    f"contour {choice.contour + 1}: direction {choice.direction!r}; "
                    f"allowed {', '.join(DIRECTIONS)}"
                )
            start = _start(contour, choice.start)
            clockwise = None if choice.direction == "drawn" else choice.direction == "cw"
            ops.append(
                contour_ops(
                    drawing, contour, start, clockwise, choice.comp, choice.tool, choice.inside
                )
            )
            used.update(contour.sources)
        else:
            group: list[Op] = []
            for k in choice.holes:
                if not 0 <= k < len(drawing.holes):
                    raise ChoiceError(f"hole {k + 1}: the drawing has {len(drawing.holes)} holes")
                if k in holes_used:
                    raise ChoiceError(f"hole {k + 1} is chosen twice")
                holes_used.add(k)
                hole = drawing.holes[k]
                group.append(HoleOpR([hole.source], hole.centre, hole_spec(drawing, choice.tool)))
                used.add(hole.source)
            if choice.bolt_circles:
                group = find_bolt_circles(group, resolution_half(drawing), notes)
            ops += group
    builder = Builder(notes)
    builder.run(ops)
    builder.flush_rounding()
    block0 = drawing_block0(drawing, ops, notes)
    # One line per kind, listing every entity it applies to.
    for contour in drawing.contours:
        if not set(contour.sources) & used:
            notes.ignored(contour.sources[0], "a contour not chosen: no blocks")
    for hole in drawing.holes:
        if hole.source not in used:
            notes.ignored(hole.source, "a hole not chosen: no blocks")
    if not ops:
        notes.assumed(None, "nothing was chosen: no blocks")
    return Chosen(tuple(builder.blocks), block0, tuple(notes.report()))


def _pocket(drawing: Drawing, choice: PocketChoice) -> PocketOp:
    """The pocket's operation; ChoiceError for a contour that is open, an island outside
    the boundary, or a contour chosen twice."""
    boundary = _contour(drawing, choice.contour)
    if not boundary.closed:
        raise ChoiceError(f"contour {choice.contour + 1} is open: a pocket's boundary is closed")
    islands = []
    for k in choice.islands:
        island = _contour(drawing, k)
        if k == choice.contour or choice.islands.count(k) > 1:
            raise ChoiceError(f"contour {k + 1} is chosen twice in one pocket")
        if not island.closed:
            raise ChoiceError(f"contour {k + 1} is open: an island is closed")
        if not holds(boundary, island):
            raise ChoiceError(
                f"contour {k + 1} is not inside contour {choice.contour + 1}: an island "
                "lies inside its pocket's boundary"
            )
        islands.append(island)
    return pocket_ops(drawing, boundary, islands, _start(boundary, choice.start), choice.tool)


def _contour(drawing: Drawing, index: int) -> Contour:
    if not 0 <= index < len(drawing.contours):
        raise ChoiceError(f"contour {index + 1}: the drawing has {len(drawing.contours)} contours")
    return drawing.contours[index]


def _start(contour: Contour, start: int) -> int:
    """The segment index a closed contour starts at; an open one: 0 or its last index."""
    count = len(contour.segments)
    if not contour.closed:
        return 0 if start == 0 else count - 1
    if not 0 <= start < count:
        raise ChoiceError(f"segment {start + 1}: the contour has {count} segments")
    return start


def insert_blocks(program: Program, chosen: Chosen, after: int) -> tuple[Program, list[str]]:
    """`program` with the chosen blocks inserted after its block `after` (0: at the start),
    and what else changed: each tool the blocks use that Data Block 0 did not list is added
    to it (without diameter or RPM; the messages say so).

    The blocks are absolute (every position ABS), so they cut the same wherever they go;
    but they must not split what belongs together. Raises PlacementError, naming the block
    and where the blocks may go instead, when `after` is inside a mill sequence or between
    a BOLT CIR and its centre, or when the block that would follow is incremental (it would
    start from the inserted blocks' last point instead of where it starts now)."""
    existing = program.blocks
    blocks = chosen.blocks
    if not 0 <= after <= len(existing):
        raise PlacementError(f"block {after}: the program has blocks 1 to {len(existing)}")
    if existing and blocks and program.units is not blocks[0].units:
        raise PlacementError(
            f"the blocks are in {blocks[0].units.symbol} and the program in "
            f"{program.units.symbol}; read the drawing in the program's units"
        )
    for index in range(len(existing)):
        if starts_mill_sequence(existing, index):
            end = mill_sequence_end(existing, index)  # one past the sequence's last block
            if index + 1 <= after < end:
                raise PlacementError(
                    f"after block {after}: that is inside the mill sequence of blocks "
                    f"{index + 1}-{end}; insert before block {index + 1} or after block {end}"
                )
    following = existing[after] if after < len(existing) else None
    if isinstance(following, BoltCircle):
        raise PlacementError(
            f"after block {after}: block {after + 1} is a BOLT CIR whose centre is block "
            f"{after}; insert before block {after} or after block {after + 1}"
        )
    positioned = following is not None and getattr(following, "x", None) is not None
    if positioned and following is not None and following.mode is Mode.INC:
        raise PlacementError(
            f"after block {after}: block {after + 1} is incremental (INC) and would "
            f"start from the new blocks' last point; insert elsewhere or make block "
            f"{after + 1} absolute first"
        )
    listed = {tool.number for tool in program.block0.tools}
    added = [tool for tool in chosen.block0.tools if tool.number not in listed]
    block0 = program.block0
    if added:
        tools = tuple(sorted((*block0.tools, *added), key=lambda tool: tool.number))
        block0 = replace(block0, tools=tools)
    changes = [
        f"tool {tool.number} added to Data Block 0: enter its diameter and RPM" for tool in added
    ]
    inserted = replace(
        program, block0=block0, blocks=(*existing[:after], *blocks, *existing[after:])
    )
    return inserted, changes


# -- the drawing, for choosing ------------------------------------------------------------

PAD = 0.05  # of the drawing's size, around it


def drawing_svg(drawing: Drawing) -> str:
    """The drawing as SVG for the choosing page: each contour a group `g.contour` with
    `data-contour` (index) holding one path per segment (`data-segment`), each hole a
    `circle.hole` with `data-hole`; start arrows mark each contour's first segment.
    Coordinates in the drawing's units (Y up through a flip)."""
    scale = 1.0 / drawing.units.nm
    points = [p for c in drawing.contours for s in c.segments for p in _extent(s)]
    points += [
        (h.centre[0] + d * h.diameter / 2, h.centre[1] + d * h.diameter / 2)
        for h in drawing.holes
        for d in (-1, 1)
    ]
    if not points:
        points = [(0.0, 0.0), (float(drawing.units.nm), float(drawing.units.nm))]
    xs = [p[0] * scale for p in points]
    ys = [p[1] * scale for p in points]
    width = max(max(xs) - min(xs), 1e-3)
    height = max(max(ys) - min(ys), 1e-3)
    pad = PAD * max(width, height)
    box = (min(xs) - pad, -(max(ys) + pad), width + 2 * pad, height + 2 * pad)
    svg = svgwrite.Drawing(
        size=("100%", "100%"),
        viewBox=" ".join(f"{v:.4f}" for v in box),
        profile="full",
        debug=False,
    )
    svg.attribs["class"] = "dxf-drawing"
    svg.attribs["preserveAspectRatio"] = "xMidYMid meet"
    svg.attribs["role"] = "img"
    svg.attribs["aria-label"] = f"drawing {drawing.name}"
    # Strokes are styled by the page (non-scaling): a Content-Security-Policy without
    # inline styles forbids style attributes.
    flip = svg.g(transform="scale(1,-1)")
    for index, contour in enumerate(drawing.contours):
        group = svg.g(class_="contour closed" if contour.closed else "contour open")
        group.attribs["data-contour"] = str(index)
        group.set_desc(title=_contour_title(drawing, index))
        for k, segment in enumerate(contour.segments):
            path = svg.path(d=_segment_d(segment, scale), class_="segment")
            path.attribs["data-segment"] = str(k)
            group.add(path)
        flip.add(group)
    for index, hole in enumerate(drawing.holes):
        circle = svg.circle(
            center=(round(hole.centre[0] * scale, 6), round(hole.centre[1] * scale, 6)),
            r=round(hole.diameter * scale / 2, 6),
            class_="hole",
        )
        circle.attribs["data-hole"] = str(index)
        circle.set_desc(
            title=f"hole {index + 1}: Ø{hole.diameter * scale:.4g} {drawing.units.symbol}"
        )
        flip.add(circle)
    svg.add(flip)
    return str(svg.tostring())


def _contour_title(drawing: Drawing, index: int) -> str:
    contour = drawing.contours[index]
    kind = "closed" if contour.closed else "open"
    return f"contour {index + 1}: {kind}, {len(contour.segments)} segments"


def _extent(segment: Segment) -> list[tuple[float, float]]:
    """Points that bound a segment: its ends, and for an arc its whole circle's box (a
    little generous, never clipped)."""
    points = [(float(segment.start[0]), float(segment.start[1]))]
    points.append((float(segment.end[0]), float(segment.end[1])))
    if segment.centre is not None:
        cx, cy = segment.centre
        r = ((segment.start[0] - cx) ** 2 + (segment.start[1] - cy) ** 2) ** 0.5
        points += [(cx - r, cy - r), (cx + r, cy + r)]
    return points


def _segment_d(segment: Segment, scale: float) -> str:
    """SVG path data of one segment (drawing units, Y up: the group flips it)."""
    sx, sy = segment.start[0] * scale, segment.start[1] * scale
    ex, ey = segment.end[0] * scale, segment.end[1] * scale
    if segment.centre is None:
        return f"M{sx:.5f},{sy:.5f} L{ex:.5f},{ey:.5f}"
    cx, cy = segment.centre[0] * scale, segment.centre[1] * scale
    r = ((sx - cx) ** 2 + (sy - cy) ** 2) ** 0.5
    if (sx, sy) == (ex, ey):
        # A whole circle: two half arcs (an SVG arc cannot end where it starts).
        mx, my = 2 * cx - sx, 2 * cy - sy
        sweep = 0 if segment.clockwise else 1
        return (
            f"M{sx:.5f},{sy:.5f} A{r:.5f},{r:.5f} 0 0 {sweep} {mx:.5f},{my:.5f} "
            f"A{r:.5f},{r:.5f} 0 0 {sweep} {sx:.5f},{sy:.5f}"
        )
    cross = (sx - cx) * (ey - cy) - (sy - cy) * (ex - cx)
    dot = (sx - cx) * (ex - cx) + (sy - cy) * (ey - cy)
    angle = math.atan2(cross, dot)  # counter-clockwise sweep in (-pi, pi]
    if segment.clockwise:
        large = 1 if angle > 0 else 0
        sweep_flag = 0
    else:
        large = 1 if angle < 0 else 0
        sweep_flag = 1
    # In Y-up coordinates counter-clockwise is SVG's sweep-flag 1 (the group's flip makes
    # it read right on screen).
    return f"M{sx:.5f},{sy:.5f} A{r:.5f},{r:.5f} 0 {large} {sweep_flag} {ex:.5f},{ey:.5f}"


def contour_comp(value: str) -> Comp | None:
    """A compensation side as the page sends it: "left", "right", "none" or "" (default)."""
    return {"left": Comp.LEFT, "right": Comp.RIGHT, "none": Comp.NONE}.get(value)
