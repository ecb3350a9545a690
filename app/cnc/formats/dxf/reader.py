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
of their own (reported). Circles at or under `options.hole_diameter` become holes. The work
is in proportion to the ends: each is compared only with those in its cell of a grid as
wide as the tolerance and the eight cells round it.

Bounds (app/cnc/sizes.py): `read_drawing` refuses a model space of more than
MAX_DRAWING_ENTITIES entities before any is read (the choosing page reads every stored
drawing so); an import is bounded by its file's lines, a binary DXF's tags counted as
lines before ezdxf reads it (`check_import_size`).

Raises ImportFailure naming the entity (handle, type, layer), the header variable, the
line or binary tag where ezdxf stopped, or the limit. ezdxf reads untrusted bytes with many
exceptions besides its own DXFError (struct.error, KeyError, AssertionError, StopIteration…,
tests/hostile_corpus.py DXF_UPLOADS): whatever it raises while reading the file or an
entity is the importer's error, and no message holds a lone surrogate (ezdxf decodes
undecodable bytes as those: they are shown as `\xff`).
"""

from __future__ import annotations

import contextlib
import io
import itertools
import math
import re
import traceback
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from decimal import Decimal, InvalidOperation
from typing import Any

from app.cnc.formats.dxf import OPTIONS, is_binary_dxf
from app.cnc.numbers import NumberError, parse_int
from app.cnc.recognition.common import MAX_ABS_NM, XY, ImportFailure, Notes, show
from app.cnc.sizes import MAX_DRAWING_ENTITIES
from app.cnc.units import Units

# $INSUNITS code → (nm per drawing unit, program units it suggests, name)
INSUNITS: dict[int, tuple[int, Units, str]] = {
    1: (25_400_000, Units.INCH, "inches"),
    2: (304_800_000, Units.INCH, "feet"),
    4: (1_000_000, Units.MM, "millimetres"),
    5: (10_000_000, Units.MM, "centimetres"),
    6: (1_000_000_000, Units.MM, "metres"),
}
DEFAULT_TOLERANCE = {Units.INCH: 2_540, Units.MM: 2_000}  # nm: 0.0001 in, 0.002 mm
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
    enclosing: list[int | None] | None = field(default=None, repr=False, compare=False)
    """Each contour's nearest closed contour round it: `blocks.enclosing` finds them on first
    use and keeps them here (the choosing page asks several times a request)."""


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


def binary_dxf_tags(data: bytes, at_most: int) -> int:
    """How many tags the binary DXF `data` holds, counted up to `at_most` (cheap: no more
    is read). A file damaged before then counts the tags before the damage: reading it
    names the damage (`read_drawing`)."""
    tags = _BinaryTags(data)
    try:
        for _ in itertools.islice(tags, at_most):
            pass
    except Exception:  # counted so far: read_drawing says what is wrong
        pass
    return tags.count


def read_drawing(
    data: bytes,
    name: str = "",
    options: DxfOptions | None = None,
    limit: int | None = MAX_DRAWING_ENTITIES,
) -> Drawing:
    """The drawing's contours and holes in nm, with the report so far. Raises
    ImportFailure for a file ezdxf cannot read (naming where), a model space of more than
    `limit` entities (a polyline's vertices count one each; None: no limit, for the
    importer, whose callers set their own, and the benchmarks), a unitless drawing without
    `drawing_units`, or units MillBlocks has no program units for."""
    opts = options or DxfOptions()
    doc, entities = _load(data)
    size = sum(_size(entity, number) for number, entity in enumerate(entities, 1))
    if limit is not None and size > limit:
        raise ImportFailure(
            "model space",
            f"the drawing has {size:,} entities (a polyline's vertices count one each); "
            f"a drawing is read with at most {limit:,}",
        )
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
    for number, entity in enumerate(entities, 1):
        reader.entity(entity, number)
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


# -- where ezdxf's reading ends and ours begins ----------------------------------------------


class _BinaryTags(Iterator[Any]):
    """ezdxf's tags of a binary DXF, counted, so that a failure names the tag it was in."""

    def __init__(self, data: bytes) -> None:
        from ezdxf.lldxf.tagger import binary_tags_loader

        self._tags = binary_tags_loader(data)
        self.count = 0  # tags read whole
        self.broken = False  # the loader failed inside tag count + 1

    def __next__(self) -> Any:
        try:
            tag = next(self._tags)
        except StopIteration:
            raise
        except Exception:
            self.broken = True
            raise
        self.count += 1
        return tag


def _load(data: bytes) -> tuple[Any, list[Any]]:
    """The document ezdxf reads from `data` (text through its recover mode, binary as is)
    and the entities of its model space. Raises ImportFailure naming where ezdxf stopped:
    the line (its message says which), the binary tag, the model space, or the file."""
    # ezdxf is imported here, when a drawing is read: detecting a file's format and every
    # command that reads no drawing start without it (it is a third of the CLI's start-up).
    from ezdxf import recover
    from ezdxf.document import Drawing as EzDrawing

    tags = _BinaryTags(data) if is_binary_dxf(data) else None
    try:
        if tags is not None:
            doc = EzDrawing.load(tags)
        else:
            doc, _auditor = recover.read(io.BytesIO(data))
    except Exception as exc:  # ezdxf's, whatever the kind: see the module's note
        if tags is not None and tags.broken:
            raise ImportFailure(
                f"binary tag {tags.count + 1}",
                "not a DXF drawing ezdxf can read: the file ends, or is damaged, inside "
                f"this tag ({said(exc)})",
            ) from None
        line = re.search(r"\bline:? (\d+)", str(exc)) if tags is None else None
        raise ImportFailure(
            f"line {line.group(1)}" if line else "",
            f"not a DXF drawing ezdxf can read: {said(exc)}",
            int(line.group(1)) if line else None,
        ) from None
    try:
        return doc, list(doc.modelspace())
    except Exception as exc:  # ezdxf's: a layout table it could not make sense of
        raise ImportFailure(
            "model space", f"ezdxf cannot read the drawing's model space: {said(exc)}"
        ) from None


def _size(entity: Any, number: int) -> int:
    """What an entity counts against the limit: its vertices for a polyline, else 1."""
    try:
        kind = entity.dxftype()
        if kind == "LWPOLYLINE":
            return max(1, len(entity))
        if kind == "POLYLINE":
            return max(1, len(entity.vertices))
    except Exception as exc:  # ezdxf's, reading a damaged entity
        raise ImportFailure(
            _unnamed(entity, number), f"ezdxf cannot read it: {said(exc)}"
        ) from None
    return 1


def said(exc: BaseException) -> str:
    """What an exception raised inside ezdxf says, fit for a message: ezdxf's own errors
    as they are, any other with its kind and the ezdxf module it came from (an
    AssertionError says nothing else); printable (see `printable`) and at most 300
    characters."""
    from ezdxf.lldxf.const import DXFError

    text = str(exc)
    if not isinstance(exc, DXFError):
        # The innermost ezdxf module it came through (never a path of this server).
        files = [f.filename.replace("\\", "/") for f in traceback.extract_tb(exc.__traceback__)]
        inside = [name.rsplit("/ezdxf/", 1)[1] for name in files if "/ezdxf/" in name]
        module = "ezdxf." + inside[-1].removesuffix(".py").replace("/", ".") if inside else ""
        kind = type(exc)
        name = kind.__qualname__
        name = name if kind.__module__ == "builtins" else f"{kind.__module__}.{name}"
        origin = f"{name} in {module}" if module else name
        text = f"{text} ({origin})" if text else origin
    return printable(text, 300)


def printable(text: str, at_most: int = 200) -> str:
    """`text` (a name or message from the drawing) as the report, a page and a terminal can
    show it: a byte ezdxf could not decode (a lone surrogate U+DC80-U+DCFF) as `\\xff`, any
    other lone surrogate as `\\ud800`, control characters as `\\x07`; cut to `at_most`
    characters (…)."""
    out = []
    for char in text:
        code = ord(char)
        if 0xDC80 <= code <= 0xDCFF:
            out.append(f"\\x{code - 0xDC00:02x}")
        elif 0xD800 <= code <= 0xDFFF:
            out.append(f"\\u{code:04x}")
        elif code < 0x20 or code == 0x7F:
            out.append(f"\\x{code:02x}")
        else:
            out.append(char)
    shown = "".join(out)
    return shown if len(shown) <= at_most else shown[: at_most - 1] + "…"


def _unnamed(entity: Any, number: int) -> str:
    """The place of an entity whose handle or layer could not be read."""
    try:
        kind = printable(str(entity.dxftype()), 40)
    except Exception:  # the number alone names it then
        kind = "entity"
    return f"entity {number} of model space ({kind})"


def _attribute(entity: Any, key: str, default: str) -> str:
    """A name attribute (handle, layer) of any entity ezdxf yields, `default` for a kind
    that has none (an unknown one in the ENTITIES section)."""
    value = entity.dxf.get(key, default) if entity.dxf.is_supported(key) else default
    return str(value)


@dataclass(frozen=True)
class _Line:
    start: tuple[float, float, float]
    end: tuple[float, float, float]


@dataclass(frozen=True)
class _Arc:
    """In world coordinates; `flat` False: not in the XY plane (nothing else is read)."""

    flat: bool
    start: tuple[float, float] = (0.0, 0.0)
    end: tuple[float, float] = (0.0, 0.0)
    centre: tuple[float, float] = (0.0, 0.0)
    radius: float = 0.0
    mirrored: bool = False  # extrusion -Z: counter-clockwise seen from below


@dataclass(frozen=True)
class _Circle:
    flat: bool
    centre: tuple[float, float] = (0.0, 0.0)
    radius: float = 0.0


@dataclass(frozen=True)
class _Polyline:
    """Vertices (x, y, bulge); `problem`: why none is read (3D, a mesh, off the XY plane)."""

    problem: str
    points: tuple[tuple[float, float, float], ...] = ()
    closed: bool = False


def _flat(entity: Any) -> bool:
    x, y, _ = entity.dxf.get("extrusion", (0.0, 0.0, 1.0))
    return abs(float(x)) < 1e-12 and abs(float(y)) < 1e-12


def _xy(point: Any) -> tuple[float, float]:
    return (float(point[0]), float(point[1]))


def _line_of(entity: Any) -> _Line:
    s, e = entity.dxf.start, entity.dxf.end
    return _Line((float(s[0]), float(s[1]), float(s[2])), (float(e[0]), float(e[1]), float(e[2])))


def _arc_of(entity: Any) -> _Arc:
    if not _flat(entity):
        return _Arc(False)
    centre = entity.ocs().to_wcs(entity.dxf.center)
    return _Arc(
        True,
        _xy(entity.start_point),
        _xy(entity.end_point),
        _xy(centre),
        float(entity.dxf.radius),
        float(entity.dxf.extrusion[2]) < 0,
    )


def _circle_of(entity: Any) -> _Circle:
    if not _flat(entity):
        return _Circle(False)
    radius = float(entity.dxf.radius)
    if radius <= 0:
        return _Circle(True, radius=radius)
    return _Circle(True, _xy(entity.ocs().to_wcs(entity.dxf.center)), radius)


def _lwpolyline_of(entity: Any) -> _Polyline:
    if not _flat(entity):
        return _Polyline("a polyline not in the XY plane: left out")
    points = tuple((float(x), float(y), float(b)) for x, y, b in entity.get_points("xyb"))
    return _Polyline("", points, bool(entity.closed))


def _polyline_of(entity: Any) -> _Polyline:
    if not entity.is_2d_polyline or not _flat(entity):
        return _Polyline("a 3D polyline or mesh: left out")
    points = tuple(
        (float(v.dxf.location[0]), float(v.dxf.location[1]), float(v.dxf.get("bulge", 0)))
        for v in entity.vertices
    )
    return _Polyline("", points, bool(entity.is_closed))


Geometry = _Line | _Arc | _Circle | _Polyline

# What is read of each kind (ezdxf's objects in, plain numbers out).
GEOMETRY: dict[str, Any] = {
    "LINE": _line_of,
    "ARC": _arc_of,
    "CIRCLE": _circle_of,
    "LWPOLYLINE": _lwpolyline_of,
    "POLYLINE": _polyline_of,
}


# -- units ---------------------------------------------------------------------------------


def _drawing_units(doc: Any, opts: DxfOptions, notes: Notes) -> tuple[int, Units]:
    try:
        value = doc.header.get("$INSUNITS", 0) or 0
    except Exception as exc:  # ezdxf's, reading a damaged header
        raise ImportFailure("header $INSUNITS", f"ezdxf cannot read it: {said(exc)}") from None
    known = ", ".join(f"{k} ({v[2]})" for k, v in INSUNITS.items())
    code = value if isinstance(value, int) and not isinstance(value, bool) else None
    if isinstance(value, str):
        with contextlib.suppress(NumberError):
            code = parse_int(value)
    if code is None:
        raise ImportFailure(
            "header $INSUNITS",
            f"units code {printable(repr(value), 60)} is not a whole number; allowed {known}",
        )
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
        raise ImportFailure(
            "header $INSUNITS",
            f"units code {printable(str(code), 40)} is not one MillBlocks reads; allowed {known}",
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

    def entity(self, entity: Any, number: int) -> None:
        """Read the `number`th entity of model space (ezdxf's object)."""
        try:
            kind = str(entity.dxftype())
            handle = _attribute(entity, "handle", "?")
            layer = _attribute(entity, "layer", "0")
        except Exception as exc:  # ezdxf's, reading a damaged entity
            raise ImportFailure(
                _unnamed(entity, number), f"ezdxf cannot read it: {said(exc)}"
            ) from None
        self.layers_seen.add(layer)
        named = Entity(printable(handle, 40), printable(kind, 40), printable(layer, 80))
        self.notes.entities.append(named)
        index = len(self.notes.entities)
        if self.layers and layer not in self.layers:
            self.notes.ignored(index, "on a layer not chosen")
            return
        read = GEOMETRY.get(kind)
        if read is None:
            self.notes.ignored(
                index, f"a {named.type} is not read (lines, arcs, circles and polylines are)"
            )
            return
        try:
            geometry = read(entity)
        except Exception as exc:  # ezdxf's, reading a damaged entity
            raise ImportFailure(f"entity {named}", f"ezdxf cannot read it: {said(exc)}") from None
        try:
            problem = self.make(geometry, index)
        except (ValueError, ArithmeticError) as exc:
            raise ImportFailure(f"entity {named}", str(exc)) from None
        if problem:
            self.notes.ignored(index, problem)

    def make(self, geometry: Geometry, index: int) -> str:
        """The segments of one entity's geometry (or a circle); what is wrong with it, if
        anything: "" when read."""
        if isinstance(geometry, _Line):
            return self.line(geometry, index)
        if isinstance(geometry, _Arc):
            return self.arc(geometry, index)
        if isinstance(geometry, _Circle):
            return self.circle(geometry, index)
        return self.polyline(geometry, index)

    def line(self, line: _Line, index: int) -> str:
        s, e = line.start, line.end
        if abs(s[2] - e[2]) > 1e-9:
            return "a 3D line (its Z changes): left out"
        a, b = self.xy(s[0], s[1]), self.xy(e[0], e[1])
        if a == b:
            return "a line of zero length: left out"
        self._add([Segment(a, b, None, False, index)], False)
        return ""

    def arc(self, arc: _Arc, index: int) -> str:
        if not arc.flat:
            return "an arc not in the XY plane: left out"
        a, b = self.xy(*arc.start), self.xy(*arc.end)
        if arc.radius <= 0:
            return "an arc of radius 0: left out"
        self._add([Segment(a, b, self.xy(*arc.centre), arc.mirrored, index)], False)
        return ""

    def circle(self, circle: _Circle, index: int) -> str:
        if not circle.flat:
            return "a circle not in the XY plane: left out"
        if circle.radius <= 0:
            return "a circle of radius 0: left out"
        self.circles.append((self.xy(*circle.centre), self.nm(circle.radius), index))
        return ""

    def polyline(self, polyline: _Polyline, index: int) -> str:
        if polyline.problem:
            return polyline.problem
        return self._vertices(list(polyline.points), polyline.closed, index)

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
    ends_seen = _Ends(tolerance)

    def snap(p: XY, source: int) -> XY:
        # Every end goes to the first end seen near it.
        q = ends_seen.near(p)
        if q is None:
            ends_seen.add(p)
            return p
        if q != p:
            gap = math.dist(p, q)
            notes.rounded(source, f"an end {show(gap, units, 6)} from another is joined to it")
        return q

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
    # Where to look next among each point's pieces: those before it are used (a star of
    # many lines at one point is then walked once, not once a line).
    first_free: dict[XY, int] = {}

    def free_at(point: XY) -> int | None:
        users = ends.get(point, [])
        at = first_free.get(point, 0)
        while at < len(users) and used[users[at]]:
            at += 1
        first_free[point] = at
        return users[at] if at < len(users) else None

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
            nxt = free_at(here)
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


class _Ends:
    """The ends seen so far in a grid of cells `tolerance` wide (at least 1 nm): an end
    within `tolerance` of another lies in the other's cell or one of the eight round it,
    so finding it takes the few ends there, not every end."""

    def __init__(self, tolerance: int) -> None:
        self.tolerance = tolerance
        self.cell = max(tolerance, 1)
        self.cells: dict[tuple[int, int], list[tuple[int, XY]]] = {}
        self.count = 0

    def near(self, p: XY) -> XY | None:
        """The first end added that is `p` or within `tolerance` of it (None: none is)."""
        cx, cy = p[0] // self.cell, p[1] // self.cell
        best: tuple[int, XY] | None = None
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for order, q in self.cells.get((cx + dx, cy + dy), ()):
                    if best is not None and order > best[0]:
                        break  # each cell's ends are in the order they were added
                    if q == p or math.dist(p, q) <= self.tolerance:
                        best = (order, q)
                        break
        return None if best is None else best[1]

    def add(self, p: XY) -> None:
        self.cells.setdefault((p[0] // self.cell, p[1] // self.cell), []).append((self.count, p))
        self.count += 1


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
