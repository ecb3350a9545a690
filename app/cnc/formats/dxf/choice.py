"""What the machinist chose from a drawing, as blocks (issue 22's choosing page).

    read_cutting(units, fields) -> Cutting               # raises ChoiceError naming the field
    chosen_blocks(drawing, choices, cutting, milling) -> Chosen(blocks, report)
    insert_blocks(program, blocks, after) -> Program      # raises PlacementError
    drawing_svg(drawing, chosen=()) -> str

A choice is a contour (which one, where the cut starts, which way round, which side the
tool is on, INSIDE or OUTSIDE when a routine cuts it exactly, the tool; the way round, the
side and INSIDE/OUTSIDE left out are `blocks.cut_sides`'s: outer contours from outside,
inner ones from inside, climb — the rule `millblocks import` uses), a pocket (a closed
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
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from decimal import Decimal

import svgwrite

from app.cnc import limits
from app.cnc.blocks import Block, BoltCircle, Comp, DataBlock0, MillingMode, Mode, Program
from app.cnc.formats.dxf.blocks import (
    NO_CUTTING,
    Cutting,
    contour_ops,
    cut_sides,
    drawing_block0,
    enclosing,
    holds,
    hole_spec,
    pocket_ops,
    resolution_half,
)
from app.cnc.formats.dxf.reader import Contour, Drawing, DxfNotes, Segment
from app.cnc.numbers import NumberError, parse_decimal, parse_int
from app.cnc.recognition.build import Builder
from app.cnc.recognition.common import ImportNote
from app.cnc.recognition.ops import HoleOpR, Op, PocketOp
from app.cnc.recognition.recognise import find_bolt_circles
from app.cnc.structure import mill_sequence_end, starts_mill_sequence
from app.cnc.units import Units, to_nm

DIRECTIONS = ("drawn", "cw", "ccw")


@dataclass(frozen=True)
class ContourChoice:
    """Cut contour `contour` (an index into `Drawing.contours`) from the start of its segment
    `start` (an open contour: 0 from its first end, any other value from its last), round
    it `direction` ("drawn", "cw" or "ccw"; closed contours), the tool on the `comp` side
    (an open contour is a tool-centre path), with tool `tool`. `inside`: where a CIRCLE or
    FRAME routine cuts the contour exactly, cut it from the INSIDE (else OUTSIDE). Each of
    `direction`, `comp` and `inside` left None is the rule's (`blocks.cut_sides`)."""

    contour: int
    start: int = 0
    direction: str | None = None
    comp: Comp | None = None
    inside: bool | None = None
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


def chosen_blocks(
    drawing: Drawing,
    choices: Sequence[Choice],
    cutting: Cutting = NO_CUTTING,
    milling: MillingMode = MillingMode.CLIMB,
) -> Chosen:
    """The blocks that cut `choices` in order, with the depths, feeds and tool diameters of
    `cutting`, and the report (see the module's note). A contour's way round, side and
    INSIDE/OUTSIDE not chosen are `cut_sides(drawing, milling)`'s.

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
    sides = cut_sides(drawing, milling) if any(_open(c) for c in choices) else []
    for choice in choices:
        if not 1 <= choice.tool <= 24:
            raise ChoiceError(f"tool {choice.tool}: allowed 1 to 24")
        if isinstance(choice, PocketChoice):
            ops.append(_pocket(drawing, choice, cutting))
            for k in (choice.contour, *choice.islands):
                used.update(drawing.contours[k].sources)
        elif isinstance(choice, ContourChoice):
            contour = _contour(drawing, choice.contour)
            # What the choice leaves open is the rule's (sides are made when one does).
            side = sides[choice.contour] if sides else None
            direction = choice.direction or (side.direction if side else "drawn")
            if direction not in DIRECTIONS:
                raise ChoiceError(
                    f"contour {choice.contour + 1}: direction {direction!r}; "
                    f"allowed {', '.join(DIRECTIONS)}"
                )
            start = _start(contour, choice.start)
            clockwise = None if direction == "drawn" else direction == "cw"
            comp = choice.comp if choice.comp is not None or side is None else side.comp
            inside = choice.inside if choice.inside is not None or side is None else side.inner
            ops.append(
                contour_ops(
                    drawing, contour, start, clockwise, comp, choice.tool, bool(inside), cutting
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
                spec = hole_spec(drawing, choice.tool, cutting)
                group.append(HoleOpR([hole.source], hole.centre, spec))
                used.add(hole.source)
            if choice.bolt_circles:
                group = find_bolt_circles(group, resolution_half(drawing), notes)
            ops += group
    builder = Builder(notes)
    builder.run(ops)
    builder.flush_rounding()
    block0 = drawing_block0(drawing, ops, notes, cutting)
    block0 = replace(block0, milling=milling)
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


def _open(choice: Choice) -> bool:
    """A contour choice that leaves something to the rule."""
    return isinstance(choice, ContourChoice) and (
        choice.direction is None or choice.comp is None or choice.inside is None
    )


def _pocket(drawing: Drawing, choice: PocketChoice, cutting: Cutting) -> PocketOp:
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
        if not holds(drawing, choice.contour, k):
            raise ChoiceError(
                f"contour {k + 1} is not inside contour {choice.contour + 1}: an island "
                "lies inside its pocket's boundary"
            )
        islands.append(island)
    start = _start(boundary, choice.start)
    return pocket_ops(drawing, boundary, islands, start, choice.tool, cutting)


def pocket_islands(
    drawing: Drawing, pockets: Sequence[int], islands: Sequence[int]
) -> dict[int, tuple[int, ...]]:
    """The islands (contour indices, in the order given) each of `pockets` clears round:
    an island is its nearest pocket's (`blocks.enclosing`: of pockets one inside another,
    the inner one); an island no pocket is round is in none. Work in proportion to the
    contours: each contour's nearest pocket is found once."""
    parents = enclosing(drawing)
    chosen = set(pockets)
    nearest: dict[int, int | None] = {}  # a contour → the nearest pocket round it

    def pocket_round(k: int) -> int | None:
        path = []
        at = parents[k]
        while at is not None and at not in chosen and at not in nearest:
            path.append(at)
            at = parents[at]
        found = at if at is None or at in chosen else nearest[at]
        for j in path:
            nearest[j] = found
        return found

    held: dict[int, list[int]] = {k: [] for k in pockets}
    for j in islands:
        pocket = pocket_round(j)
        if pocket is not None:
            held[pocket].append(j)
    return {k: tuple(found) for k, found in held.items()}


# -- what the drawing cannot give: depths, feeds, the tool ---------------------------------

# The page's fields, as (form name, label in messages).
CUTTING_FIELDS = (
    ("z_up", "Z UP"),
    ("z_dn", "Z DN"),
    ("feed_z", "FEEDR Z"),
    ("feed_xy", "FEEDR XY"),
    ("tool", "tool"),
    ("tool_dia", "tool Ø"),
    ("tool_rpm", "RPM"),
)


def cutting_defaults(units: Units) -> dict[str, str]:
    """The values the choosing page offers (shown in its fields, never assumed unseen): 0.1
    in above the top to 0.1 in deep at 5 ipm down, 10 ipm along, tool 1 a 1/4 in end mill,
    its RPM left for the machinist; in mm 2.5 above to 2.5 deep, 126 and 250 mm/min, 6 mm."""
    if units is Units.INCH:
        values = ("0.100", "-0.100", "5.0", "10.0", "1", "0.250", "")
    else:
        values = ("2.50", "-2.50", "126", "250", "1", "6.00", "")
    return {name: value for (name, _), value in zip(CUTTING_FIELDS, values, strict=True)}


def read_cutting(units: Units, fields: Mapping[str, str]) -> tuple[Cutting, int]:
    """The depths, feeds and tool the page's fields give (in `units`), and the tool's number.

    Z UP, Z DN and FEEDR Z all blank: a 2-axis program (no depths). Raises ChoiceError
    naming the field for a value that is not a number, a depth not on the programming
    resolution (a tool's diameter finer than it is rounded, and reported, in Data Block 0),
    out of the control's range, a Z DN not below Z UP, or one depth given without the
    other."""

    def text(name: str) -> str:
        return (fields.get(name) or "").strip()

    def number(name: str, label: str) -> Decimal:
        try:
            return parse_decimal(text(name), exponent=False)
        except NumberError as exc:
            raise ChoiceError(f"{label}: {exc}") from None

    def length(name: str, label: str, exact: bool = True) -> int:
        value = number(name, label)
        high = limits.MAX_DIMENSION[units]
        if abs(value) > high:
            raise ChoiceError(f"{label}: {value} {units.symbol}; allowed -{high} to {high}")
        if exact and value != value.quantize(units.resolution):
            raise ChoiceError(
                f"{label}: {value} is finer than the control's {units.resolution} {units.symbol}"
            )
        return to_nm(value, units)

    def feed(name: str, label: str, allowed: limits.FeedLimits) -> int:
        value = number(name, label)
        if not allowed.low <= value <= allowed.high or value % allowed.step:
            raise ChoiceError(
                f"{label}: {value} {units.feed_symbol}; allowed {allowed.low} to "
                f"{allowed.high} in steps of {allowed.step}"
            )
        return to_nm(value, units)

    depths = [name for name in ("z_up", "z_dn", "feed_z") if text(name)]
    z_up = z_dn = feed_z = None
    if depths:
        labels = dict(CUTTING_FIELDS)
        for name in ("z_up", "z_dn", "feed_z"):
            if not text(name):
                raise ChoiceError(
                    f"{labels[name]}: no value given; enter it (or leave Z UP, Z DN and "
                    "FEEDR Z all blank for a 2-axis program, the quill moved by hand)"
                )
        z_up = length("z_up", "Z UP")
        z_dn = length("z_dn", "Z DN")
        if z_dn >= z_up:
            raise ChoiceError(
                f"Z DN: {text('z_dn')} is not below Z UP {text('z_up')}; Z DN is the depth "
                "the tool cuts at, below Z UP"
            )
        feed_z = feed("feed_z", "FEEDR Z", limits.FEED_Z[units])
    feed_xy = feed("feed_xy", "FEEDR XY", limits.FEED_XY[units])
    try:
        tool = parse_int(text("tool"))
    except NumberError as exc:
        raise ChoiceError(f"tool: {exc}") from None
    if not 1 <= tool <= 24:
        raise ChoiceError(f"tool: {tool}; allowed 1 to 24")
    # A tool's size as the shop calls it (3/16 in: 0.1875): Data Block 0 holds it to the
    # resolution, rounded and reported there, as every import's tools are.
    diameter = length("tool_dia", "tool Ø", exact=False)
    if diameter <= 0:
        raise ChoiceError(f"tool Ø: {text('tool_dia')}; the tool's diameter is more than 0")
    rpms: tuple[tuple[int, int], ...] = ()
    if text("tool_rpm"):
        try:
            rpm = parse_int(text("tool_rpm"))
        except NumberError as exc:
            raise ChoiceError(f"RPM: {exc}") from None
        if not limits.MIN_RPM <= rpm <= limits.MAX_RPM:
            raise ChoiceError(
                f"RPM: {rpm}; allowed {limits.MIN_RPM} to {limits.MAX_RPM} (a clockwise "
                "spindle; leave it blank to enter it in Data Block 0)"
            )
        rpms = ((tool, rpm),)
    cutting = Cutting(z_up, z_dn, feed_z, feed_xy, ((tool, diameter),), rpms)
    return cutting, tool


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
