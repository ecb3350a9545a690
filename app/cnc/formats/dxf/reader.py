"""DXF drawings: entities read with ezdxf, chained into contours, classified (issue 22).

    read_drawing(data, options) -> Drawing

What is read (model space only, any layer unless `options.layers` names some): LINE, ARC,
CIRCLE, LWPOLYLINE and 2D POLYLINE (bulges are arcs). Everything else — splines, ellipses,
text, dimensions, hatches, block references, 3D entities (a Z that changes along the entity,
or an extrusion other than ±Z) — is left out and named with its handle, type and layer.

Units: the drawing's $INSUNITS (inches, feet → inch; millimetres, centimetres, metres →
mm), converted exactly to nanometres. A unitless drawing ($INSUNITS 0 or absent) is refused
unless `options.drawing_units` says what it is: a guess would make a part 25.4 times too
big or too small.

Chaining: ends closer than `options.tolerance` (default 0.0001 in, or 0.002 mm) are joined
into one point (the first one's; the gap is reported). A contour is closed when it comes
back to its start, open otherwise (its two unjoined ends are reported). Where more than two
ends meet, the chain takes the first entity in drawing order and the others start contours
of their own (reported). Circles at or under `options.hole_diameter` become holes.

Raises ImportFailure naming the entity (handle, type, layer) or the header variable.
"""

from __future__ import annotations

import io
import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from decimal import Decimal, InvalidOperation
from typing import Any

from app.cnc.imports.common import MAX_ABS_NM, XY, ImportFailure, Notes, show
from app.cnc.options import Option, OptionKind
from app.cnc.units import Units

BINARY_SENTINEL = b"AutoCAD Binary DXF\r\n\x1a\x00"

# $INSUNITS code → (nm per drawing unit, program units it suggests, name)
INSUNITS: dict[int, tuple[int, Units, str]] = {
    1: (25_400_000, Units.INCH, "inches"),
    2: (304_800_000, Units.INCH, "feet"),
    4: (1_000_000, Units.MM, "millimetres"),
    5: (10_000_000, Units.MM, "centimetres"),
    6: (1_000_000_000, Units.MM, "metres"),
}
DEFAULT_TOLERANCE = {Units.INCH: 2_540, Units.MM: 2_000}  # nm: 0.0001 in, 0.002 mm
OPTIONS: tuple[Option, ...] = (
    Option("layer", OptionKind.TEXT, "", "only these layers (comma-separated); empty: all"),
    Option(
        "hole-diameter",
        OptionKind.DECIMAL,
        None,
        "circles this size or smaller are holes (program units); empty: none",
    ),
    Option("tolerance", OptionKind.DECIMAL, None, "ends this close are chained"),
    Option(
        "units",
        OptionKind.CHOICE,
        "",
        "the program's units; empty: the drawing's",
        ("", "inch", "mm"),
    ),
    Option(
        "drawing-units",
        OptionKind.CHOICE,
        "",
        "what a drawing without units is in; empty: refuse it",
        ("", "inch", "mm"),
    ),
    Option("feed", OptionKind.DECIMAL, None, "FEEDR XY of the mill blocks"),
)
NAMES = tuple(option.name for option in OPTIONS)


@dataclass(frozen=True)
class DxfOptions:
    """Reader options. Lengths and the feed are in the program's units (`units`, else the
    drawing's). `layers` empty: every layer. `hole_diameter` 0: no circle is a hole.
    `tolerance` None: 0.0001 in / 0.002 mm. `units`: the program's units (None: the
    drawing's). `drawing_units`: what a unitless drawing is in (None: refuse it). `feed`:
    FEEDR XY of the mill blocks (None: the manual's default, 1.0 ipm / 24 mm/min)."""

    layers: tuple[str, ...] = ()
    hole_diameter: Decimal = Decimal(0)
    tolerance: Decimal | None = None
    units: Units | None = None
    drawing_units: Units | None = None
    feed: Decimal | None = None


@dataclass(frozen=True)
class Segment:
    """A piece of a contour in nm: a line, or an arc about `centre`, from `start` to `end`.
    `source` indexes `Drawing.entities` (the entity it comes from)."""

    start: XY
    end: XY
    centre: XY | None
    clockwise: bool
    source: int

    def reversed(self) -> Segment:
        return Segment(self.end, self.start, self.centre, not self.clockwise, self.source)


@dataclass(frozen=True)
class Entity:
    """A drawing entity as the report names it."""

    handle: str
    type: str
    layer: str

    def __str__(self) -> str:
        return f"{self.type} {self.handle} (layer {self.layer})"


@dataclass(frozen=True)
class Contour:
    """Chained segments, in chain order. `closed`: the last ends where the first starts."""

    segments: tuple[Segment, ...]
    closed: bool

    @property
    def sources(self) -> tuple[int, ...]:
        return tuple(dict.fromkeys(s.source for s in self.segments))

    @property
    def is_circle(self) -> bool:
        return len(self.segments) == 1 and self.segments[0].centre is not None and self.closed


@dataclass(frozen=True)
class Hole:
    """A circle at or under the hole diameter: its centre and diameter (nm)."""

    centre: XY
    diameter: int
    source: int


@dataclass
class Drawing:
    """What a DXF file holds, in nm: contours, holes, the entities (for names), the units,
    and the notes so far (what was left out, what was assumed)."""

    name: str
    units: Units
    entities: list[Entity]
    contours: list[Contour]
    holes: list[Hole]
    notes: Notes
    tolerance: int
    feed: int


class DxfNotes(Notes):
    """Notes whose places are entities: `LINE 2F (layer 0)`, `entities 2F, 30 (layer 0)`."""

    entities: list[Entity]

    def __init__(self) -> None:
        super().__init__(unit="entity")
        self.entities = []

    def where(self, line: int | None) -> str:
        if line is None:
            return "file"
        return f"entity {self.entities[line - 1]}"

    def span(self, lines: list[int] | tuple[int, ...]) -> str:
        if not lines:
            return "file"
        if len(lines) == 1:
            return self.where(lines[0])
        picked = [self.entities[n - 1] for n in lines]
        layers = sorted({e.layer for e in picked})
        handles = ", ".join(e.handle for e in picked[:6])
        more = f" and {len(picked) - 6} more" if len(picked) > 6 else ""
        return f"entities {handles}{more} (layer {', '.join(layers)})"


def parse_options(options: Mapping[str, str]) -> DxfOptions:
    """Reader options from text (`layer=A,B`, `hole-diameter=0.5`, `tolerance=0.0002`,
    `units=inch|mm`, `drawing-units=inch|mm`, `feed=10`). Raises ImportFailure for an
    unknown option or a bad value."""
    unknown = sorted(set(options) - set(NAMES))
    if unknown:
        raise ImportFailure(
            "", f"dxf import has no option {unknown[0]!r}; its options: {', '.join(NAMES)}"
        )
    return DxfOptions(
        layers=tuple(x.strip() for x in options.get("layer", "").split(",") if x.strip()),
        hole_diameter=_length_option(options, "hole-diameter") or Decimal(0),
        tolerance=_length_option(options, "tolerance"),
        units=_units_option(options, "units"),
        drawing_units=_units_option(options, "drawing-units"),
        feed=_length_option(options, "feed"),
    )


def _units_option(options: Mapping[str, str], key: str) -> Units | None:
    value = options.get(key)
    if value is None:
        return None
    text = value.strip().lower()
    if text in ("inch", "in", "inches"):
        return Units.INCH
    if text in ("mm", "metric", "millimetres", "millimeters"):
        return Units.MM
    raise ImportFailure("", f"option {key}={value!r}: allowed inch or mm")


def _length_option(options: Mapping[str, str], key: str) -> Decimal | None:
    value = options.get(key)
    if value is None:
        return None
    try:
        number = Decimal(value.strip())
    except InvalidOperation:
        number = Decimal(-1)
    if not number.is_finite() or number < 0 or number > 1000:
        raise ImportFailure(
            "", f"option {key}={value!r}: a number from 0 to 1000 (program units) is allowed"
        )
    return number


def is_dxf(data: bytes) -> bool:
    """True for a binary DXF, or text whose first group is `0` / `SECTION`."""
    if data.startswith(BINARY_SENTINEL):
        return True
    head = data[:64].lstrip(b"\xef\xbb\xbf").split(None, 2)
    return len(head) >= 2 and head[0] == b"0" and head[1] == b"SECTION"


def read_drawing(data: bytes, name: str = "", options: DxfOptions | None = None) -> Drawing:
    """The drawing's contours and holes in nm, with the report so far. Raises
    ImportFailure for a file ezdxf cannot read, a unitless drawing without
    `drawing_units`, or units MillBlocks has no program units for."""
    # ezdxf is imported here, when a drawing is read: detecting a file's format and every
    # command that reads no drawing start without it (it is a third of the CLI's start-up).
    from ezdxf import recover
    from ezdxf.document import Drawing as EzDrawing
    from ezdxf.lldxf.const import DXFError
    from ezdxf.lldxf.tagger import binary_tags_loader

    opts = options or DxfOptions()
    try:
        if data.startswith(BINARY_SENTINEL):
            doc = EzDrawing.load(binary_tags_loader(data))
        else:
            doc, _auditor = recover.read(io.BytesIO(data))
    except (DXFError, UnicodeDecodeError, ValueError, IndexError, KeyError, TypeError) as exc:
        raise ImportFailure("", f"not a DXF drawing ezdxf can read: {exc}") from None
    notes = DxfNotes()
    scale, drawing_units = _drawing_units(doc, opts, notes)
    units = opts.units or drawing_units
    tolerance = DEFAULT_TOLERANCE[units] if opts.tolerance is None else _nm(opts.tolerance, units)
    feed = _default_feed(units) if opts.feed is None else _nm(opts.feed, units)
    if opts.units is not None and opts.units is not drawing_units:
        notes.assumed(
            None, f"the program is in {units.symbol} (the units option); the drawing is not"
        )
    if opts.feed is None:
        notes.assumed(
            None,
            f"FEEDR XY {show(feed, units)}/min for every mill block (the drawing has no feeds; "
            "give feed=…)".replace(f" {units.symbol}/min", f" {units.feed_symbol}"),
        )
    reader = _Reader(notes, scale, set(opts.layers))
    for entity in doc.modelspace():
        reader.entity(entity)
    if opts.layers:
        missing = sorted(set(opts.layers) - reader.layers_seen)
        for layer in missing:
            notes.assumed(None, f"layer {layer!r} has nothing in model space")
    hole_diameter = _nm(opts.hole_diameter, units)
    contours, holes = _classify(reader, hole_diameter, tolerance, units, notes)
    return Drawing(
        name or "drawing", units, notes.entities, contours, holes, notes, tolerance, feed
    )


def _nm(value: Decimal, units: Units) -> int:
    return int((value * units.nm).to_integral_value())


def _default_feed(units: Units) -> int:
    # The manual's default feed (1.0 ipm); metric: 24 mm/min, the nearest FEEDR step.
    return 25_400_000 if units is Units.INCH else 24_000_000


def _drawing_units(doc: Any, opts: DxfOptions, notes: Notes) -> tuple[int, Units]:
    code = int(doc.header.get("$INSUNITS", 0) or 0)
    if code == 0:
        if opts.drawing_units is None:
            raise ImportFailure(
                "header $INSUNITS",
                "the drawing does not say its units ($INSUNITS 0, unitless); give the option "
                "drawing-units=inch or drawing-units=mm",
            )
        notes.assumed(
            None,
            f"the drawing is unitless ($INSUNITS 0): read in {opts.drawing_units.symbol}, "
            "as the drawing-units option says",
        )
        return opts.drawing_units.nm, opts.drawing_units
    if code not in INSUNITS:
        known = ", ".join(f"{k} ({v[2]})" for k, v in INSUNITS.items())
        raise ImportFailure(
            "header $INSUNITS", f"units code {code} is not one MillBlocks reads; allowed {known}"
        )
    scale, units, label = INSUNITS[code]
    notes.became(None, f"drawing units: {label} ($INSUNITS {code})")
    return scale, units


class _Reader:
    """Turns entities into segments (nm), naming what it leaves out."""

    def __init__(self, notes: DxfNotes, scale: int, layers: set[str]) -> None:
        self.notes = notes
        self.scale = Decimal(scale)
        self.layers = layers
        self.layers_seen: set[str] = set()
        self.pieces: list[list[Segment]] = []  # chains as the entities give them
        self.closed: list[bool] = []
        self.circles: list[tuple[XY, int, int]] = []

    def nm(self, value: float) -> int:
        """A drawing length in nm. Raises ValueError for a number no part has."""
        number = float(value)
        nm = Decimal(repr(number)) * self.scale if math.isfinite(number) else None
        if nm is None or abs(nm) > MAX_ABS_NM:
            raise ValueError(f"the number {number!r} is not a usable length")
        return int(nm.to_integral_value())

    def xy(self, x: float, y: float) -> XY:
        return (self.nm(x), self.nm(y))

    def entity(self, entity: Any) -> None:
        kind = entity.dxftype()
        layer = str(entity.dxf.get("layer", "0"))
        self.layers_seen.add(layer)
        self.notes.entities.append(Entity(str(entity.dxf.get("handle", "?")), kind, layer))
        index = len(self.notes.entities)
        if self.layers and layer not in self.layers:
            self.notes.ignored(index, "on a layer not chosen")
            return
        reader = {
            "LINE": self.line,
            "ARC": self.arc,
            "CIRCLE": self.circle,
            "LWPOLYLINE": self.lwpolyline,
            "POLYLINE": self.polyline,
        }.get(kind)
        if reader is None:
            self.notes.ignored(
                index, f"a {kind} is not read (lines, arcs, circles and polylines are)"
            )
            return
        try:
            problem = reader(entity, index)
        except (ValueError, TypeError, ArithmeticError, IndexError) as exc:
            raise ImportFailure(f"entity {self.notes.entities[-1]}", str(exc)) from None
        if problem:
            self.notes.ignored(index, problem)

    def _flat(self, entity: Any) -> bool:
        x, y, _ = entity.dxf.get("extrusion", (0.0, 0.0, 1.0))
        return abs(float(x)) < 1e-12 and abs(float(y)) < 1e-12

    def line(self, entity: Any, index: int) -> str:
        s, e = entity.dxf.start, entity.dxf.end
        if abs(s[2] - e[2]) > 1e-9:
            return "a 3D line (its Z changes): left out"
        a, b = self.xy(s[0], s[1]), self.xy(e[0], e[1])
        if a == b:
            return "a line of zero length: left out"
        self._add([Segment(a, b, None, False, index)], False)
        return ""

    def arc(self, entity: Any, index: int) -> str:
        if not self._flat(entity):
            return "an arc not in the XY plane: left out"
        start, end = entity.start_point, entity.end_point  # world coordinates
        centre = entity.dxf.center
        ocs = entity.ocs()
        c = ocs.to_wcs(centre)
        clockwise = entity.dxf.extrusion[2] < 0  # mirrored: counter-clockwise seen from below
        a, b = self.xy(start[0], start[1]), self.xy(end[0], end[1])
        if entity.dxf.radius <= 0:
            return "an arc of radius 0: left out"
        self._add([Segment(a, b, self.xy(c[0], c[1]), clockwise, index)], False)
        return ""

    def circle(self, entity: Any, index: int) -> str:
        if not self._flat(entity):
            return "a circle not in the XY plane: left out"
        if entity.dxf.radius <= 0:
            return "a circle of radius 0: left out"
        c = entity.ocs().to_wcs(entity.dxf.center)
        self.circles.append((self.xy(c[0], c[1]), self.nm(entity.dxf.radius), index))
        return ""

    def lwpolyline(self, entity: Any, index: int) -> str:
        if not self._flat(entity):
            return "a polyline not in the XY plane: left out"
        points = [(float(x), float(y), float(b)) for x, y, b in entity.get_points("xyb")]
        return self._vertices(points, bool(entity.closed), index)

    def polyline(self, entity: Any, index: int) -> str:
        if not entity.is_2d_polyline or not self._flat(entity):
            return "a 3D polyline or mesh: left out"
        points = [
            (float(v.dxf.location[0]), float(v.dxf.location[1]), float(v.dxf.get("bulge", 0)))
            for v in entity.vertices
        ]
        return self._vertices(points, bool(entity.is_closed), index)

    def _vertices(self, points: list[tuple[float, float, float]], closed: bool, index: int) -> str:
        if closed and len(points) > 1:
            points = [*points, (points[0][0], points[0][1], 0.0)]
        segments: list[Segment] = []
        for (x0, y0, bulge), (x1, y1, _) in itertools.pairwise(points):
            a, b = self.xy(x0, y0), self.xy(x1, y1)
            if a == b:
                continue
            if abs(bulge) < 1e-12:
                segments.append(Segment(a, b, None, False, index))
                continue
            segments.append(
                Segment(a, b, self._bulge_centre(x0, y0, x1, y1, bulge), bulge < 0, index)
            )
        if not segments:
            return "a polyline with no length: left out"
        self._add(segments, closed and segments[-1].end == segments[0].start)
        return ""

    def _bulge_centre(self, x0: float, y0: float, x1: float, y1: float, bulge: float) -> XY:
        """The centre of the arc a bulge makes (bulge = tan(included angle / 4), positive
        counter-clockwise), computed in the file's numbers then scaled once."""
        theta = 4 * math.atan(bulge)
        mx, my = (x0 + x1) / 2, (y0 + y1) / 2
        chord = math.hypot(x1 - x0, y1 - y0)
        # Distance from the chord's middle to the centre, toward the left of the chord for a
        # counter-clockwise arc of less than 180°.
        h = chord / 2 / math.tan(theta / 2)
        nx, ny = -(y1 - y0) / chord, (x1 - x0) / chord
        return self.xy(mx + nx * h, my + ny * h)

    def _add(self, segments: list[Segment], closed: bool) -> None:
        self.pieces.append(segments)
        self.closed.append(closed)


def _classify(
    reader: _Reader, hole_diameter: int, tolerance: int, units: Units, notes: DxfNotes
) -> tuple[list[Contour], list[Hole]]:
    holes: list[Hole] = []
    contours: list[Contour] = []
    for centre, radius, index in reader.circles:
        if 2 * radius <= hole_diameter:
            holes.append(Hole(centre, 2 * radius, index))
            continue
        start = (centre[0], centre[1] - radius)
        contours.append(Contour((Segment(start, start, centre, False, index),), True))
    closed = [p for p, c in zip(reader.pieces, reader.closed, strict=True) if c]
    contours += [Contour(tuple(p), True) for p in closed]
    contours += _chain(
        [p for p, c in zip(reader.pieces, reader.closed, strict=True) if not c],
        tolerance,
        units,
        notes,
    )
    return contours, holes


def _chain(
    pieces: list[list[Segment]], tolerance: int, units: Units, notes: DxfNotes
) -> list[Contour]:
    """Open pieces joined end to end where their ends are within `tolerance`."""
    # Snap every end to the first end seen near it.
    points: list[XY] = []

    def snap(p: XY, source: int) -> XY:
        for q in points:
            if p == q:
                return q
            gap = math.dist(p, q)
            if gap <= tolerance:
                notes.rounded(
                    source + 0, f"an end {show(gap, units, 6)} from another is joined to it"
                )
                return q
        points.append(p)
        return p

    snapped: list[list[Segment]] = []
    for piece in pieces:
        first, last = piece[0], piece[-1]
        a = snap(first.start, first.source)
        b = snap(last.end, last.source)
        piece = [*piece]
        piece[0] = Segment(
            a, first.end if len(piece) > 1 else b, first.centre, first.clockwise, first.source
        )
        if len(piece) > 1:
            piece[-1] = Segment(last.start, b, last.centre, last.clockwise, last.source)
        snapped.append(piece)
    snapped = _without_repeats(snapped, notes)
    ends: dict[XY, list[int]] = {}
    for k, piece in enumerate(snapped):
        ends.setdefault(piece[0].start, []).append(k)
        ends.setdefault(piece[-1].end, []).append(k)
    for point, users in ends.items():
        if len(users) > 2:
            names = ", ".join(str(notes.entities[snapped[k][0].source - 1]) for k in users)
            notes.assumed(
                snapped[users[0]][0].source,
                f"{len(users)} ends meet at X{show(point[0], units)} Y{show(point[1], units)} "
                f"({names}): the chain takes them in drawing order",
            )
    used = [False] * len(snapped)
    contours: list[Contour] = []
    # Open chains first (from an end only one piece uses), then the closed ones.
    order = sorted(
        range(len(snapped)),
        key=lambda k: (min(len(ends[snapped[k][0].start]), len(ends[snapped[k][-1].end])) != 1, k),
    )
    for k in order:
        if used[k]:
            continue
        used[k] = True
        chain = list(snapped[k])
        if len(ends[chain[-1].end]) == 1 and len(ends[chain[0].start]) != 1:
            chain = [s.reversed() for s in reversed(chain)]
        while True:
            here = chain[-1].end
            if here == chain[0].start and len(chain) > 0 and _closes(chain):
                break
            nxt = next((j for j in ends.get(here, []) if not used[j]), None)
            if nxt is None:
                break
            used[nxt] = True
            piece = snapped[nxt]
            if piece[0].start != here:
                piece = [s.reversed() for s in reversed(piece)]
            chain += piece
        closed = chain[-1].end == chain[0].start and _closes(chain)
        contour = Contour(tuple(chain), closed)
        if not closed:
            a, b = chain[0].start, chain[-1].end
            notes.assumed(
                chain[0].source,
                f"the contour of {notes.span(list(contour.sources))} is open: its ends at "
                f"X{show(a[0], units)} Y{show(a[1], units)} and X{show(b[0], units)} "
                f"Y{show(b[1], units)} join nothing (a tool-centre path, no compensation)",
            )
        contours.append(contour)
    return contours


def _shape(piece: list[Segment]) -> tuple[tuple[XY, XY, XY | None, bool], ...]:
    """A piece's geometry, the same whichever way it was drawn."""

    def key(segments: list[Segment]) -> tuple[tuple[XY, XY, XY | None, bool], ...]:
        # A line has no direction of turn: reversing one flips a flag that means nothing.
        return tuple(
            (s.start, s.end, s.centre, s.clockwise and s.centre is not None) for s in segments
        )

    forward = key(piece)
    backward = key([s.reversed() for s in reversed(piece)])
    return min(forward, backward, key=repr)


def _without_repeats(pieces: list[list[Segment]], notes: DxfNotes) -> list[list[Segment]]:
    """The pieces less those that repeat an earlier one (a line drawn twice, either way
    round): cut twice, it would be an open contour whose two ends are one point. Each is
    named in the report."""
    seen: dict[tuple[tuple[XY, XY, XY | None, bool], ...], int] = {}
    kept: list[list[Segment]] = []
    for piece in pieces:
        shape = _shape(piece)
        first = seen.get(shape)
        if first is None:
            seen[shape] = piece[0].source
            kept.append(piece)
            continue
        notes.ignored(
            piece[0].source,
            f"{notes.entities[piece[0].source - 1]} repeats {notes.entities[first - 1]} "
            "(the same line drawn twice): left out, so it is cut once",
        )
    return kept


def _closes(chain: list[Segment]) -> bool:
    """A chain that comes back to its start and is more than one line there and back."""
    return len(chain) > 2 or any(s.centre is not None for s in chain)
