"""The tool path as an SVG drawing: the web preview and the `svg` export.

Seen from above in part coordinates, Y up (the page is flipped with `scale(1,-1)`), in the
program's unit. What it shows, each with its own class so a stylesheet can restyle it:

- the tool centre: `rapid` and `feed` paths (arcs stay arcs), `plunge` marks where a feed
  goes down in place, `hole` circles the tool's size for every DRILL, BORE and TAP, and
  with `swept` the width the tool sweeps along feeds (`swept`);
- the programmed contour of every mill sequence (`contour`: the lines and arcs as
  programmed, before cutter compensation; a CIRCLE or FRAME routine's circle or frame);
- part zero (`g.zero`), the stock outline (`g.stock`: the program's stock, or the reach
  of its cuts with the margin the simulation uses), with `grid` a 1 in / 10 mm grid;
- the order holes are cut in (`g.order`, numbers beside the holes, up to HOLE_LABELS).

Every drawn element sits in a `<g class="block" data-block="N">`, so the editor can link
drawing and block; a block given in `problems` gets the class `problem` and a `<title>`
with its messages. A mill sequence the compiler could not cut is still drawn: its
programmed contour, in its (problem) block's group.

Drawn from the compiled tree (path.py), not from the moves one by one: a `Run` (the
patterns of a LOOP) draws its node once into `<defs>` and places it with `<use>` at each
offset — the compiler guarantees each placement is the node moved by its offset. The move
that brings the tool into each pattern is drawn apart (one path for the whole run), so the
first pattern and the others share one drawing; identical drawings are kept once.

Deterministic: fixed decimals, ids `p1`, `p2`… in the order drawings are first made.

Kept per top-level node (`render(keep=True)`, the editor's preview): the compiler hands out
the same node object for the blocks an edit left alone, so each top-level node's drawing is
kept by (node, where it is entered, its block numbers' base, what is drawn around it) in a
bounded memo, as the cycle time keeps its figures (estimate.py), and an edit draws only the
nodes it changed. The drawing is the same text as one drawn afresh: a kept drawing names its
`<defs>` patterns by their content (`SHAPE_REF`) and the document numbers them `p1`, `p2`… in
the order a fresh drawing would first make them.
"""

from __future__ import annotations

import hashlib
import math
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from html import escape
from typing import Any

import numpy as np

from app.cnc.blocks import Program
from app.cnc.compiler import compile_program
from app.cnc.formats.targets import Option, OptionKind, Out, Report, Target, register
from app.cnc.memo import Memo
from app.cnc.path import CompiledPath, MillSpan, Node, Op, Piece, Run, Seq
from app.cnc.plane import Path
from app.cnc.simulate.stock import rounded_out, stock_box
from app.cnc.units import Units

# Holes are numbered in the order they are cut when a program has at most this many.
HOLE_LABELS = 500
# Level of detail. Beyond this many holes, holes and plunge marks are one path per block
# (a browser lays out every element of every <use>); beyond this many moves the drawing
# is large: marks as paths too, and the editor paints it on a canvas (static/preview.js).
MARKS_AS_ELEMENTS = 2_000
LARGE_MOVES = 50_000

# A pattern's reference in a drawing's text until the document numbers it: `<<` never occurs
# in SVG text (escaped text has `&lt;`), the digest is of the pattern's own text.
SHAPE_REF = re.compile(r"<<([0-9a-f]{16})>>")

STYLE = """
path:not(.swept), circle, line, rect {{ fill: none; stroke-width: {w}; }}
path.swept {{ fill: none; }}
path.rapid {{ stroke: #8a8a8a; stroke-dasharray: {dash} {gap}; }}
path.feed {{ stroke: #0b5fbf; stroke-width: {wide}; }}
path.swept {{ stroke: #9cc3f0; stroke-linecap: round; stroke-linejoin: round; opacity: .45; }}
.contour {{ stroke: #111827; }}
circle.plunge {{ stroke: #c2410c; }}
circle.hole {{ stroke: #15803d; fill: #bbf7d0; fill-opacity: .5; }}
g.problem path, g.problem circle, g.problem rect {{ stroke: #dc2626; }}
g.zero line {{ stroke: #b91c1c; }}
g.stock rect {{ stroke: #a16207; stroke-dasharray: {gap} {gap}; }}
g.grid line {{ stroke: #e5e7eb; stroke-width: {thin}; }}
g.order text {{ fill: #166534; }}
"""


@register
class SvgTarget(Target):
    name = "svg"
    label = "Tool path picture (SVG)"
    description = "tool path drawing (SVG), as the web preview shows it"
    extension = "svg"
    media_type = "image/svg+xml"
    options = (
        Option("swept", OptionKind.BOOL, False, "draw the width the tool sweeps when feeding"),
        Option("grid", OptionKind.BOOL, False, "draw a 1 in / 10 mm grid"),
    )

    def write(
        self,
        program: Program,
        path: CompiledPath,
        options: Mapping[str, Any],
        report: Report,
        out: Out,
    ) -> None:
        # Drawn from the compiled tree the export hands over: never the Toolpath of every
        # move (the default `write`), so memory stays flat in the program's size.
        drawing = render(program, path, swept=bool(options["swept"]), grid=bool(options["grid"]))
        out.write(drawing.svg.encode("utf-8"))


@dataclass(frozen=True, slots=True)
class Drawing:
    """A drawing and what is in it: the blocks that have something drawn, the holes, and
    whether it is large (more than LARGE_MOVES moves)."""

    svg: str
    blocks: frozenset[int]
    holes: int
    large: bool = False


def draw(
    program: Program,
    swept: bool = False,
    grid: bool = False,
    embedded_style: bool = True,
    problems: Mapping[int, Sequence[str]] | None = None,
) -> str:
    """The SVG text of a program's tool path (see the module docstring).

    `embedded_style` False leaves the `<style>` out, for a page whose own stylesheet
    styles the classes (a Content-Security-Policy without inline styles forbids it there).
    `problems` are messages by block number: those blocks are drawn as problems.
    """
    return render(
        program, swept=swept, grid=grid, embedded_style=embedded_style, problems=problems
    ).svg


def render(
    program: Program,
    path: CompiledPath | None = None,
    *,
    swept: bool = False,
    grid: bool = False,
    embedded_style: bool = True,
    problems: Mapping[int, Sequence[str]] | None = None,
    keep: bool = False,
) -> Drawing:
    """The drawing of `program` (its compiled `path`, compiled here when not given).

    `keep`: draw each top-level node the compiler kept from the drawings kept in this
    process (`KEPT`), and keep those drawn now (the same text either way)."""
    if path is None:
        path = compile_program(program).path
    painter = _Painter(program, path, swept, problems or {}, KEPT if keep else None)
    return painter.document(grid, embedded_style)


# -- boxes and state -------------------------------------------------------------------------


@dataclass(slots=True)
class _Box:
    """An axis-aligned box (nm), empty until something is added."""

    x0: float = math.inf
    y0: float = math.inf
    x1: float = -math.inf
    y1: float = -math.inf

    def add(self, x0: float, y0: float, x1: float, y1: float) -> None:
        self.x0, self.y0 = min(self.x0, x0), min(self.y0, y0)
        self.x1, self.y1 = max(self.x1, x1), max(self.y1, y1)

    def point(self, x: float, y: float, r: float = 0.0) -> None:
        self.add(x - r, y - r, x + r, y + r)

    def join(self, other: _Box, lo: tuple[int, int] = (0, 0), hi: tuple[int, int] = (0, 0)) -> None:
        """Add `other` moved by every offset between `lo` and `hi`."""
        if other.empty:
            return
        self.add(other.x0 + lo[0], other.y0 + lo[1], other.x1 + hi[0], other.y1 + hi[1])

    @property
    def empty(self) -> bool:
        return self.x0 > self.x1


@dataclass(frozen=True, slots=True)
class _State:
    """Where the tool is (nm, in the frame being drawn) and which tool is in."""

    x: int
    y: int
    z: int
    tool: int

    def moved(self, dx: int, dy: int) -> _State:
        return _State(self.x + dx, self.y + dy, self.z, self.tool)


@dataclass(slots=True)
class _Entry:
    """The move that brings the tool into a piece: from where it was to (x, y)."""

    block: int
    kind: str
    x: int
    y: int


@dataclass(slots=True)
class _Body:
    """The drawing of one node entered in one state, in the node's own frame."""

    text: str
    exit: _State
    box: _Box  # everything drawn, tool radius included
    cut: _Box  # the reach of the cuts below Z0 (tool radius included): the stock's extent
    blocks: set[int]
    holes: list[tuple[int, int, int]]  # (x, y, radius) in cutting order (when labelled)
    entry: _Entry | None = None  # drawn apart, when the node is a piece placed by a run
    # The <defs> patterns the text places, in the order first made: (digest, extent, text),
    # the <g> written once per pattern by the document.
    shapes: list[tuple[str, str, str]] = field(default_factory=list)


# The drawings of top-level nodes kept between renders (render(keep=True)): (the node, the
# blocks drawn, their problems, the drawing), weighed by the text's length: 32 MB of text in
# all, none over a tenth of it.
_Kept = tuple[object, tuple[int, ...], tuple[object, ...], _Body]
KEPT: Memo[_Kept] = Memo(rows=32 << 20)


@dataclass(slots=True)
class _Group:
    """What one block draws in one body: paths by (class, tool size), circles, contours."""

    paths: dict[tuple[str, int], list[str]] = field(default_factory=dict)
    ends: dict[tuple[str, int], tuple[float, float]] = field(default_factory=dict)
    marks: list[str] = field(default_factory=list)
    contour: list[str] = field(default_factory=list)  # path commands of the contour
    outlines: list[str] = field(default_factory=list)  # routines' circles and frames
    plunges: set[tuple[int, int]] = field(default_factory=set)
    holes: list[str] = field(default_factory=list)  # hole circles as path commands (LOD)
    plunge_rings: list[str] = field(default_factory=list)


# -- the painter -----------------------------------------------------------------------------


class _Painter:
    def __init__(
        self,
        program: Program,
        path: CompiledPath,
        swept: bool,
        problems: Mapping[int, Sequence[str]],
        kept: Memo[_Kept] | None = None,
    ) -> None:
        self.program = program
        self.kept = kept
        self.path = path
        self.units = path.units
        self.unit = path.units.nm
        self.places = path.units.dump_places
        self.swept = swept
        self.problems = problems
        self.shapes: dict[str, str] = {}  # a pattern's text → its digest (SHAPE_REF)
        self.bodies: dict[tuple[object, ...], _Body] = {}
        self.digests: dict[int, bytes] = {}
        self.numbers: dict[float, str] = {}
        holes = self.holes = _hole_count(path.root)
        self.labelled = holes <= HOLE_LABELS
        # Level of detail: a large drawing draws each block's holes and plunge marks as one
        # path, not an element each (a browser lays out every element of every <use>).
        self.large = len(path) > LARGE_MOVES
        self.merged = self.large or holes > MARKS_AS_ELEMENTS
        # What else a node's drawing depends on: kept drawings are only for the same.
        self.context = (swept, self.labelled, self.large, self.merged)

    # -- numbers ----------------------------------------------------------------------------

    def n(self, nm: float) -> str:
        """A length in the drawing's unit, at its printing resolution, no trailing zeros."""
        found = self.numbers.get(nm)
        if found is None:
            text = f"{nm / self.unit:.{self.places}f}".rstrip("0").rstrip(".")
            found = self.numbers[nm] = "0" if text in ("-0", "") else text
        return found

    def xy(self, x: float, y: float) -> str:
        return f"{self.n(x)} {self.n(y)}"

    def radius(self, tool: int) -> int:
        info = self.path.tools.get(tool)
        return info.diameter // 2 if info is not None and info.diameter else 0

    # -- the tree ---------------------------------------------------------------------------

    def paint(self, node: Node, state: _State, base: int, split: bool = False) -> _Body:
        """`node` entered in `state` (its frame), block numbers + `base`. `split` draws a
        piece's entry move apart (for a run to draw once for all its placements)."""
        if isinstance(node, Piece):
            # Pieces alike in content (the compiler makes one per LOOP run, and the runs of
            # a long LOOP are alike) are drawn once for each way they are entered; a piece
            # whose drawing does not depend on where it is entered from, once.
            digest = self.digest(node)
            shift = node.base + base
            key: tuple[object, ...] = (digest, shift, split, state)
            found = self.bodies.get(key)
            if found is None:
                loose = self.loose(node, digest, shift, state) if split else None
                found = self.bodies.get(loose) if loose is not None else None
                if found is None:
                    found = self.piece(node, state, base, split)
                    if loose is not None:
                        self.bodies[loose] = found
                self.bodies[key] = found
            return found
        # A LOOP's runs share their pattern node (the compiler splits one LOOP into a run
        # per row, each placing the same Seq): drawn once for each way it is entered, as a
        # piece is, instead of once per run.
        shared = (id(node), base, split, state)
        found = self.bodies.get(shared)
        if found is None:
            if isinstance(node, Seq):
                found = self.sequence(node.nodes, state, base)
            else:
                found = self.run(node, state, base)
            self.bodies[shared] = found
        return found

    def digest(self, piece: Piece) -> bytes:
        """What a piece's drawing is made of (its moves, holes and mill sequences)."""
        found = self.digests.get(id(piece))
        if found is None:
            made = hashlib.blake2b(piece.rows.tobytes(), digest_size=16)
            made.update(piece.holes.tobytes())
            made.update(repr(piece.mills).encode())
            found = self.digests[id(piece)] = made.digest()
        return found

    def loose(
        self, piece: Piece, digest: bytes, shift: int, state: _State
    ) -> tuple[object, ...] | None:
        """The key of a piece's drawing that holds from any place it is entered from, or
        None: when its first move across is a rapid (its entry, drawn by the run) and
        nothing before it cuts, the drawing depends only on that move and the tool."""
        rows = piece.rows
        op = rows["op"]
        motion = op <= Op.ARC_CCW
        across = np.flatnonzero(
            motion & ((rows["x"] != state.x) | (rows["y"] != state.y) | (op >= Op.ARC_CW))
        )
        if not len(across) or op[across[0]] != Op.RAPID:
            return None
        first = int(across[0])
        if np.any((op[:first] == Op.FEED) | (op[:first] == Op.TOOL)):
            return None
        return (digest, shift, "entered at", first, state.tool)

    def sequence(self, nodes: Iterable[Node], state: _State, base: int, top: bool = False) -> _Body:
        """`nodes` one after the other; `top`: the program's top-level nodes (kept ones
        drawn from `self.kept`)."""
        texts: list[str] = []
        body = _Body("", state, _Box(), _Box(), set(), [])
        for child in nodes:
            part = self.settled(child, state) if top else self.paint(child, state, base)
            texts.append(part.text)
            body.box.join(part.box)
            body.cut.join(part.cut)
            body.blocks |= part.blocks
            body.holes += part.holes
            body.shapes += part.shapes
            state = part.exit
        body.text = "".join(texts)
        body.exit = state
        return body

    def settled(self, node: Node, state: _State) -> _Body:
        """A top-level node: one the compiler kept (a Run placing its node once where it
        stands, as estimate.py's `_top_level` reads them) drawn from `self.kept` when it was
        drawn entered the same way with the same problems, else drawn and kept."""
        if (
            self.kept is None
            or not isinstance(node, Run)
            or node.rep
            or node.offsets.tolist() != [[0, 0]]
        ):
            return self.paint(node, state, 0)
        key = (id(node.node), node.base, state, self.context)
        found = self.kept.get(key)
        if found is not None and found[0] is node.node and found[2] == self.said(found[1]):
            return found[3]
        body = self.paint(node.node, state, node.base)
        blocks = tuple(sorted(body.blocks))
        # The node is kept with its drawing, so no other node can take its id meanwhile;
        # weighed by its text and its patterns' (a LOOP's text is mostly <use>s).
        weight = len(body.text) + sum(len(text) for _, _, text in body.shapes) + 1
        self.kept.keep(key, (node.node, blocks, self.said(blocks), body), weight)
        return body

    def said(self, blocks: tuple[int, ...]) -> tuple[object, ...]:
        """What the problems say of `blocks` (their groups' titles)."""
        problems = self.problems
        return tuple((b, tuple(problems[b])) for b in blocks if b in problems)

    def run(self, run: Run, state: _State, base: int) -> _Body:
        """A node placed at each of the run's offsets: drawn once, then `<use>`d."""
        offsets = [(int(x), int(y)) for x, y in run.offsets.tolist()]
        first = offsets[0]
        # A LOOP's patterns draw their way in apart, so patterns entered from different
        # places still share one drawing.
        split = run.rep > 0 or len(offsets) > 1
        inner = self.paint(run.node, state.moved(-first[0], -first[1]), base + run.base, split)
        lo = (min(x for x, _ in offsets), min(y for _, y in offsets))
        hi = (max(x for x, _ in offsets), max(y for _, y in offsets))
        body = _Body("", inner.exit.moved(*offsets[-1]), _Box(), _Box(), set(inner.blocks), [])
        body.shapes = list(inner.shapes)
        body.box.join(inner.box, lo, hi)
        body.cut.join(inner.cut, lo, hi)
        for dx, dy in offsets:
            body.holes += [(x + dx, y + dy, r) for x, y, r in inner.holes]
        texts = []
        entry = inner.entry
        if entry is not None:
            # Each placement's way in: from where the tool is (before the run, then where
            # the placement before left it) to the entry's end: one path for the run. Where
            # the tool was left is not the same place relative to every placement: a bolt
            # circle's holes are placed by translation, but each is entered from the last.
            parts = []
            at = None
            came = (state.x, state.y)
            for dx, dy in offsets:
                if at != came:
                    parts.append(f"M{self.xy(*came)}")
                at = (entry.x + dx, entry.y + dy)
                parts.append(f"L{self.xy(*at)}")
                body.box.add(
                    min(came[0], at[0]),
                    min(came[1], at[1]),
                    max(came[0], at[0]),
                    max(came[1], at[1]),
                )
                came = (inner.exit.x + dx, inner.exit.y + dy)
            texts.append(
                self.group(entry.block) + f'<path class="{entry.kind}" d="{" ".join(parts)}"/></g>'
            )
            body.blocks.add(entry.block)
        if not split:
            dx, dy = first
            texts.append(
                inner.text
                if (dx, dy) == (0, 0)
                else f'<g transform="translate({self.xy(dx, dy)})">{inner.text}</g>'
            )
        elif inner.text:
            digest = self.shapes.get(inner.text)
            if digest is None:
                digest = hashlib.blake2b(inner.text.encode(), digest_size=8).hexdigest()
                self.shapes[inner.text] = digest
            # Its extent (drawing units, tool radius included): what a canvas needs to
            # paint it once and place the picture (static/preview.js).
            b = inner.box
            extent = f"{self.n(b.x0)} {self.n(b.y0)} {self.n(b.x1)} {self.n(b.y1)}"
            body.shapes.append((digest, extent, inner.text))
            texts += [
                f'<use xlink:href="#<<{digest}>>" x="{self.n(dx)}" y="{self.n(dy)}"/>'
                if (dx, dy) != (0, 0)
                else f'<use xlink:href="#<<{digest}>>"/>'
                for dx, dy in offsets
            ]
        body.text = "".join(texts)
        return body

    # -- a piece ----------------------------------------------------------------------------

    def piece(self, piece: Piece, state: _State, base: int, split: bool) -> _Body:
        """The moves of one piece from `state`: segments, holes, plunges, contours.

        With `split`, the first move, when it is a rapid across with nothing drawn before
        it, is the piece's entry: left out of the drawing and its box (the run draws it).
        """
        shift = piece.base + base
        groups: dict[int, _Group] = {}
        x0 = y0 = cx0 = cy0 = math.inf
        x1 = y1 = cx1 = cy1 = -math.inf
        x, y, z, tool = state.x, state.y, state.z, state.tool
        r = self.radius(tool)
        entry: _Entry | None = None
        rows = piece.rows.tolist()
        # Rows inside a hole's span: its feeds down are the hole's, not plunge marks.
        depth = np.zeros(len(rows) + 1, dtype=np.int64)
        np.add.at(depth, piece.holes["start"], 1)
        np.add.at(depth, piece.holes["end"], -1)
        in_hole = (np.cumsum(depth) > 0).tolist()
        for k, (op, _tag, block, nx, ny, nz, cx, cy, _feed, value) in enumerate(rows):
            if op > Op.ARC_CCW:
                if op == Op.TOOL:
                    tool, z = value, nz
                    r = self.radius(tool)
                continue
            number = block + shift
            if op < Op.ARC_CW and nx == x and ny == y:
                if op == Op.FEED:
                    if nz < z and not in_hole[k]:
                        self.plunge(groups, number, x, y)
                    x0, y0 = min(x0, x - r), min(y0, y - r)
                    x1, y1 = max(x1, x + r), max(y1, y + r)
                    if z < 0 or nz < 0:
                        cx0, cy0 = min(cx0, x - r), min(cy0, y - r)
                        cx1, cy1 = max(cx1, x + r), max(cy1, y + r)
                z = nz
                continue
            if op == Op.RAPID:
                if split and entry is None and not groups:
                    entry = _Entry(number, "rapid", nx, ny)
                else:
                    self.segment(groups, number, "rapid", 0, (x, y), (nx, ny), None)
                    x0, y0 = min(x0, x, nx), min(y0, y, ny)
                    x1, y1 = max(x1, x, nx), max(y1, y, ny)
            elif op == Op.FEED:
                self.segment(groups, number, "feed", 2 * r, (x, y), (nx, ny), None)
                lo_x, lo_y = min(x, nx) - r, min(y, ny) - r
                hi_x, hi_y = max(x, nx) + r, max(y, ny) + r
                x0, y0, x1, y1 = min(x0, lo_x), min(y0, lo_y), max(x1, hi_x), max(y1, hi_y)
                if z < 0 or nz < 0:
                    cx0, cy0 = min(cx0, lo_x), min(cy0, lo_y)
                    cx1, cy1 = max(cx1, hi_x), max(cy1, hi_y)
            else:
                self.segment(groups, number, "feed", 2 * r, (x, y), (nx, ny), (cx, cy, op))
                # The whole circle: an arc's bulge is never more than that.
                reach = math.hypot(x - cx, y - cy) + r
                x0, y0 = min(x0, cx - reach), min(y0, cy - reach)
                x1, y1 = max(x1, cx + reach), max(y1, cy + reach)
                if nz < 0:
                    cx0, cy0 = min(cx0, cx - reach), min(cy0, cy - reach)
                    cx1, cy1 = max(cx1, cx + reach), max(cy1, cy + reach)
            x, y, z = nx, ny, nz
        box, cut = _Box(x0, y0, x1, y1), _Box(cx0, cy0, cx1, cy1)
        holes: list[tuple[int, int, int]] = []
        for start, hx, hy, hole_tool in piece.holes[["start", "x", "y", "tool"]].tolist():
            hr = self.radius(hole_tool)
            self.hole(groups, rows[start][2] + shift, hx, hy, max(hr, self.unit // 100))
            box.point(hx, hy, hr)
            if self.labelled:
                holes.append((hx, hy, hr))
        for mill in piece.mills:
            self.mill(groups, box, mill.moved(0, 0, 0, shift))
        text = "".join(self.close(number, group) for number, group in groups.items())
        blocks = set(groups)
        return _Body(text, _State(x, y, z, tool), box, cut, blocks, holes, entry)

    def hole(self, groups: dict[int, _Group], number: int, x: int, y: int, r: int) -> None:
        group = groups.setdefault(number, _Group())
        if self.merged:
            group.holes.append(self.ring(x, y, r))
        else:
            group.marks.append(
                f'<circle class="hole" cx="{self.n(x)}" cy="{self.n(y)}" r="{self.n(r)}"/>'
            )

    def plunge(self, groups: dict[int, _Group], number: int, x: int, y: int) -> None:
        group = groups.setdefault(number, _Group())
        if (x, y) in group.plunges:
            return
        group.plunges.add((x, y))
        r = self.unit // 50 if self.units is Units.INCH else self.unit // 2
        if self.merged:
            group.plunge_rings.append(self.ring(x, y, r))
        else:
            group.marks.append(
                f'<circle class="plunge" cx="{self.n(x)}" cy="{self.n(y)}" r="{self.n(r)}"/>'
            )

    def ring(self, x: int, y: int, r: int) -> str:
        """A circle as path commands (two half circles), for marks drawn as one path."""
        radius = self.n(r)
        return (
            f"M{self.xy(x - r, y)} A{radius} {radius} 0 0 0 {self.xy(x + r, y)} "
            f"A{radius} {radius} 0 0 0 {self.xy(x - r, y)}"
        )

    def segment(
        self,
        groups: dict[int, _Group],
        number: int,
        kind: str,
        size: int,
        start: tuple[int, int],
        end: tuple[int, int],
        arc: tuple[int, int, int] | None,
    ) -> None:
        """A line or arc of `kind`, joined to the block's last one of that kind if it
        ends where this starts."""
        group = groups.setdefault(number, _Group())
        key = (kind, size)
        parts = group.paths.setdefault(key, [])
        if group.ends.get(key) != start:
            parts.append(f"M{self.xy(*start)}")
        if arc is None:
            parts.append(f"L{self.xy(*end)}")
        else:
            cx, cy, op = arc
            parts.append(self.arc(start, end, (cx, cy), op == Op.ARC_CW))
        group.ends[key] = end

    def arc(
        self,
        start: tuple[float, float],
        end: tuple[float, float],
        centre: tuple[float, float],
        clockwise: bool,
    ) -> str:
        """The SVG arc command from `start` to `end` about `centre`."""
        cx, cy = centre
        r = self.n(math.hypot(start[0] - cx, start[1] - cy))
        # Y is flipped by the page transform, so SVG's sweep flag 1 (positive angle) is
        # counter-clockwise as seen from above.
        sweep = "0" if clockwise else "1"
        if abs(end[0] - start[0]) < 0.5 and abs(end[1] - start[1]) < 0.5:
            # A full circle: two half circles through the opposite point.
            ox, oy = 2 * cx - start[0], 2 * cy - start[1]
            return f"A{r} {r} 0 0 {sweep} {self.xy(ox, oy)} A{r} {r} 0 0 {sweep} {self.xy(*end)}"
        a0 = math.atan2(start[1] - cy, start[0] - cx)
        a1 = math.atan2(end[1] - cy, end[0] - cx)
        turn = ((a0 - a1) if clockwise else (a1 - a0)) % (2 * math.pi)
        large = "1" if turn > math.pi else "0"
        return f"A{r} {r} 0 {large} {sweep} {self.xy(*end)}"

    def mill(self, groups: dict[int, _Group], box: _Box, mill: MillSpan) -> None:
        """The programmed contour of a mill sequence, or its routine's circle or frame; for
        a sequence not cut (its plan has errors), also where its DRILL would go down."""
        if mill.start == mill.end:
            self.plunge(groups, mill.drill, mill.x, mill.y)
        contour = mill.contour()
        if contour is not None:
            self.contour(groups, box, contour)
            return
        # A routine's outline as the compile planned it (never the blocks again).
        for _, outline in mill.outlines():
            self.contour(groups, box, outline)
        shape = mill.shape()
        if shape is None:
            return
        group = groups.setdefault(mill.routine, _Group())
        if not shape.is_frame:
            r = shape.radius
            if r > 0:
                group.outlines.append(
                    f'<circle class="contour" cx="{self.n(mill.x)}" cy="{self.n(mill.y)}" '
                    f'r="{self.n(r)}"/>'
                )
                box.point(mill.x, mill.y, r)
        else:
            w, h = shape.width, shape.height
            corner = max(0, min(shape.corner_radius, w // 2, h // 2))
            if w > 0 and h > 0:
                rounded = f' rx="{self.n(corner)}"' if corner else ""
                group.outlines.append(
                    f'<rect class="contour" x="{self.n(mill.x)}" y="{self.n(mill.y)}" '
                    f'width="{self.n(w)}" height="{self.n(h)}"{rounded}/>'
                )
                box.add(mill.x, mill.y, mill.x + w, mill.y + h)

    def contour(self, groups: dict[int, _Group], box: _Box, contour: Path) -> None:
        at = contour.start
        for element in contour.elements:
            group = groups.setdefault(element.block, _Group())
            if group.ends.get(("contour", 0)) != at:
                group.contour.append(f"M{self.xy(*at)}")
            if element.centre is None:
                group.contour.append(f"L{self.xy(*element.end)}")
                box.add(
                    min(at[0], element.end[0]),
                    min(at[1], element.end[1]),
                    max(at[0], element.end[0]),
                    max(at[1], element.end[1]),
                )
            else:
                cx, cy = element.centre
                group.contour.append(self.arc(at, element.end, element.centre, element.clockwise))
                radius = math.hypot(at[0] - cx, at[1] - cy)
                box.point(cx, cy, radius)
            at = element.end
            group.ends[("contour", 0)] = at

    def group(self, number: int) -> str:
        """The opening tag of a block's group (a problem block's with its messages)."""
        messages = self.problems.get(number)
        if not messages:
            return f'<g class="block" data-block="{number}">'
        title = escape(f"block {number}: " + "; ".join(messages))
        return f'<g class="block problem" data-block="{number}"><title>{title}</title>'

    def close(self, number: int, group: _Group) -> str:
        """One block's drawing: contour, then tool path, then marks."""
        out = [self.group(number)]
        if group.contour:
            out.append(f'<path class="contour" d="{" ".join(group.contour)}"/>')
        out += group.outlines
        for (kind, size), parts in group.paths.items():
            d = " ".join(parts)
            out.append(f'<path class="{kind}" d="{d}"/>')
            if kind == "feed" and self.swept and size:
                # A presentation attribute, not a style: a page's Content-Security-Policy
                # may forbid inline styles.
                out.append(f'<path class="swept" stroke-width="{self.n(size)}" d="{d}"/>')
        if group.plunge_rings:
            out.append(f'<path class="plunge" d="{" ".join(group.plunge_rings)}"/>')
        if group.holes:
            out.append(f'<path class="hole" d="{" ".join(group.holes)}"/>')
        out += group.marks
        out.append("</g>")
        return "".join(out)

    # -- the document -----------------------------------------------------------------------

    def document(self, grid: bool, embedded_style: bool) -> Drawing:
        start = self.path.start
        state = _State(start[0], start[1], start[2], self.path.initial_tool)
        root = self.path.root
        body = (
            self.sequence(root.nodes, state, 0, top=True)
            if isinstance(root, Seq)
            else self.paint(root, state, 0)
        )
        stock = self.stock(body.cut)
        box = _Box()
        box.join(body.box)
        box.point(start[0], start[1])
        mark = self.unit * (0.1 if self.units is Units.INCH else 2.5)
        box.point(0, 0, mark)
        if stock is not None:
            box.add(*stock)
        pad = max(box.x1 - box.x0, box.y1 - box.y0, self.unit / 4) * 0.05
        x0, y0, x1, y1 = box.x0 - pad, box.y0 - pad, box.x1 + pad, box.y1 + pad
        width, height = x1 - x0, y1 - y0
        w = max(width, height) / 700
        out = [
            '<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" '
            f'class="mb-path{" large" if self.large else ""}" data-units="{self.units.value}" '
            'width="100%" height="100%" '
            f'viewBox="{self.n(x0)} {self.n(-y1)} {self.n(width)} {self.n(height)}">'
        ]
        # The patterns in the order a fresh drawing makes them first, numbered so.
        numbers: dict[str, str] = {}
        defs: list[str] = []
        for digest, extent, text in body.shapes:
            if digest not in numbers:
                numbers[digest] = f"p{len(numbers) + 1}"
                defs.append(f'<g id="<<{digest}>>" class="pattern" data-box="{extent}">{text}</g>')
        if embedded_style:
            style = STYLE.format(
                w=self.n(w),
                wide=self.n(1.8 * w),
                thin=self.n(0.5 * w),
                dash=self.n(4 * w),
                gap=self.n(3 * w),
            )
            defs.insert(0, f"<style>{style}</style>")
        if defs:
            out.append("<defs>" + "".join(defs) + "</defs>")
        out.append('<g class="page" transform="scale(1,-1)">')
        if grid:
            out.append(self.grid(x0, y0, x1, y1))
        if stock is not None:
            sx0, sy0, sx1, sy1 = stock
            how = "the program's stock" if self.program.stock is not None else "stock"
            out.append(
                f'<g class="stock"><title>{how}</title><rect x="{self.n(sx0)}" '
                f'y="{self.n(sy0)}" width="{self.n(sx1 - sx0)}" height="{self.n(sy1 - sy0)}"/></g>'
            )
        out.append(
            f'<g class="zero"><title>part zero</title><line x1="{self.n(-mark)}" y1="0" '
            f'x2="{self.n(mark)}" y2="0"/><line x1="0" y1="{self.n(-mark)}" x2="0" '
            f'y2="{self.n(mark)}"/></g>'
        )
        out.append(body.text)
        out.append("</g>")
        if self.labelled and body.holes:
            out.append(self.order(body.holes, max(width, height)))
        out.append("</svg>\n")
        text = "".join(out)
        if numbers:
            text = SHAPE_REF.sub(lambda m: numbers[m.group(1)], text)
        return Drawing(text, frozenset(body.blocks), self.holes, self.large)

    def stock(self, cut: _Box) -> tuple[float, float, float, float] | None:
        """The program's stock, or the reach of its cuts with the simulation's margin
        (rounded outward), or None when nothing cuts below Z0."""
        given = self.program.stock
        if given is not None:
            box = stock_box(given, self.program.units)
            return (box.x0, box.y0, box.x1, box.y1)
        if cut.empty:
            return None
        return rounded_out(cut.x0, cut.y0, cut.x1, cut.y1, self.units)

    def order(self, holes: list[tuple[int, int, int]], size: float) -> str:
        """Each hole's number in cutting order, beside it (outside the flipped page, so
        the text reads upright)."""
        font = size / 60
        texts = []
        for k, (x, y, r) in enumerate(holes, start=1):
            gap = r * 0.75 + font * 0.15
            texts.append(f'<text x="{self.n(x + gap)}" y="{self.n(-(y + gap))}">{k}</text>')
        return f'<g class="order" font-size="{self.n(font)}">{"".join(texts)}</g>'

    def grid(self, x0: float, y0: float, x1: float, y1: float) -> str:
        step = self.unit * (1 if self.units is Units.INCH else 10)
        lines = []
        for k in range(math.floor(x0 / step), math.ceil(x1 / step) + 1):
            v = self.n(k * step)
            lines.append(f'<line x1="{v}" y1="{self.n(y0)}" x2="{v}" y2="{self.n(y1)}"/>')
        for k in range(math.floor(y0 / step), math.ceil(y1 / step) + 1):
            v = self.n(k * step)
            lines.append(f'<line x1="{self.n(x0)}" y1="{v}" x2="{self.n(x1)}" y2="{v}"/>')
        return f'<g class="grid">{"".join(lines)}</g>'


def _hole_count(node: Node) -> int:
    """How many holes `node` cuts (without expanding its runs)."""
    if isinstance(node, Piece):
        return len(node.holes)
    if isinstance(node, Run):
        return _hole_count(node.node) * len(node.offsets)
    return sum(_hole_count(n) for n in node.nodes)
