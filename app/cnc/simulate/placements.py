"""The compiled path as groups of identical motions placed by translation.

A LOOP's patterns are stored once in the compiled path (`path.Run`: one piece, several
offsets); the simulation keeps that: `place` walks the path's tree and gives, in program
order, `Group`s — the segments of one piece in the piece's own coordinates and the offsets
it is placed at. A piece placed once is a group of one. Segments are made once per piece
and entry state, however often the piece is placed, so the work and the memory of this
step grow with the program's distinct pieces, not with its moves.

A Run's placements are entered in the same state relative to their offset (the compiler
groups them that way); `place` checks it (the end of one placement must lead to the entry
of the next) and splits a group where it does not hold — unless only the move in differs
and it runs above the stock, where it cuts and hits nothing: a bolt circle's holes, each
entered from the hole before, are then one (`loose`) group.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from app.cnc.blocks import Program
from app.cnc.memo import Memo
from app.cnc.path import CompiledPath, Node, Piece, Seq
from app.cnc.simulate.segments import I64, Entry, Segments, ToolShapes, piece_segments
from app.cnc.simulate.stock import stock_box


@dataclass
class Group:
    """`segments` (piece coordinates) placed at each of `offsets` (k × 2, nm) in turn;
    `key` names the segments: equal keys, equal segments (the same moves, entered alike).
    `loose`: the placements are entered from different places above the stock (the holes
    of a bolt circle): the first segment's start is the first placement's only."""

    segments: Segments
    offsets: I64
    key: tuple[object, ...]
    loose: bool = False

    @property
    def count(self) -> int:
        """How many segments the group makes: one piece's times its placements."""
        return len(self.segments) * len(self.offsets)

    def absolute(self) -> Segments:
        """Every placement's segments in part coordinates, in order."""
        if len(self.offsets) == 1:
            ox, oy = self.offsets[0].tolist()
            return self.segments.translated(ox, oy)
        return self.segments.tiled(self.offsets)


@dataclass
class Placed:
    """A program's motions as groups in program order, and the tool shapes they use."""

    groups: list[Group]
    shapes: ToolShapes

    def __len__(self) -> int:
        return sum(g.count for g in self.groups)

    def absolute(self) -> Segments:
        """All segments in part coordinates (for small programs and tests: this array grows
        with the program)."""
        return Segments.concatenate([g.absolute() for g in self.groups])


# A piece's segments by (piece, what they depend on), shared by every simulation in the
# process; each entry keeps its piece, so no id in a key is reused while it is in.
SEGMENTS: Memo[tuple[Piece, Segments, Entry, frozenset[int]]] = Memo()


def place(program: Program, path: CompiledPath) -> Placed:
    """The motions of `path` (compiled from `program`) as placed groups."""
    shapes = ToolShapes.of(path)
    # The stock's top (nm): the program's stock, or part Z0 for one sized from the extent
    # (stock.py). A move above it cuts nothing and hits nothing.
    top = 0 if program.stock is None else stock_box(program.stock, program.units).top
    walker = _Walker(shapes, Entry(*path.start, path.initial_tool), top)
    walker.visit(path.root, 0, 0, 0)
    return Placed(walker.groups, shapes)


class _Walker:
    def __init__(self, shapes: ToolShapes, entry: Entry, top: int) -> None:
        self.shapes = shapes
        self.at = entry
        self.top = top
        self.groups: list[Group] = []
        self.made: dict[tuple[object, ...], tuple[Segments, Entry]] = {}
        # Pieces by content: the compiler may hold equal pieces as distinct objects (one
        # per Run of a LOOP's rows). Ids are kept with their pieces, so none is reused.
        self.digests: dict[int, tuple[Piece, bytes]] = {}
        # The radius of each tool in the table, and (as tool 0) the default for the others.
        self.radii = (*sorted((n, shapes.radius(n)) for n in shapes.tools), (0, shapes.radius(0)))

    def visit(self, node: Node, dx: int, dy: int, base: int) -> None:
        if isinstance(node, Piece):
            self.piece(node, np.array([[dx, dy]], dtype=np.int64), base)
        elif isinstance(node, Seq):
            for child in node.nodes:
                self.visit(child, dx, dy, base)
        elif isinstance(node.node, Piece):
            offsets = node.offsets + np.array([dx, dy], dtype=np.int64)
            self.piece(node.node, offsets, base + node.base)
        else:
            for ox, oy in node.offsets.tolist():
                self.visit(node.node, dx + ox, dy + oy, base + node.base)

    def piece(self, piece: Piece, offsets: I64, base: int) -> None:
        """`piece` placed at `offsets`, in groups of placements entered alike."""
        for group in self._groups(piece, offsets, base):
            if len(group.segments):
                self.groups.append(group)

    def _entered_above(self, segments: Segments) -> bool:
        """True when the first segment (the move in from where the tool was) is above the
        stock's top at both ends."""
        return bool(len(segments)) and min(segments.z0[0], segments.z1[0]) >= self.top

    def _groups(self, piece: Piece, offsets: I64, base: int) -> Iterator[Group]:
        while len(offsets):
            ox, oy = offsets[0].tolist()
            here = self.at
            entry = Entry(here.x - ox, here.y - oy, here.z, here.tool)
            key = (self._digest(piece), base + piece.base, entry.x, entry.y, entry.z, entry.tool)
            found = self.made.get(key)
            if found is None:
                found = self._segments(piece, base + piece.base, entry)
                self.made[key] = found
            segments, leave = found
            # Placement p + 1 is entered where placement p leaves: alike when that is the
            # entry moved by the step between their offsets.
            step = offsets[:-1] - offsets[1:]
            same_height = (leave.z == entry.z) & (leave.tool == entry.tool)
            exact = (leave.x + step[:, 0] == entry.x) & (leave.y + step[:, 1] == entry.y)
            # Only the first segment, the move from where the tool was, depends on where
            # the placement is entered from; above the stock it cuts and hits nothing, so
            # placements entered from anywhere at this height are alike (a bolt circle's
            # holes, each entered from the hole before).
            loose = self._entered_above(segments)
            alike = np.full(len(step), same_height) if loose else exact & same_height
            count = 1 + (int(np.argmin(alike)) if not alike.all() else len(alike))
            last = offsets[count - 1].tolist()
            self.at = Entry(leave.x + last[0], leave.y + last[1], leave.z, leave.tool)
            yield Group(segments, offsets[:count], key, loose and not exact[: count - 1].all())
            offsets = offsets[count:]

    def _segments(self, piece: Piece, shift: int, entry: Entry) -> tuple[Segments, Entry]:
        """`piece_segments`, kept between simulations (Verify after an edit, a replay): the
        compile gives the same piece object for every block an edit left alone. The key
        holds what the segments depend on besides the moves: where the piece is entered, its
        block numbers, the tools' radii and which of its blocks drill with a point."""
        rows = piece.rows
        if not len(rows) or len(rows) > SEGMENTS.budget // 10:
            return piece_segments(rows, shift, entry, self.shapes)
        blocks = rows["block"]
        low, high = int(blocks.min()) + shift, int(blocks.max()) + shift
        pointed = self.shapes.pointed
        points = tuple(
            pointed[
                np.searchsorted(pointed, low) : np.searchsorted(pointed, high, "right")
            ].tolist()
        )
        key = (id(piece), shift, entry, self.radii, points)
        kept = SEGMENTS.get(key)
        if kept is not None and kept[0] is piece:
            _, segments, leave, used = kept
            self.shapes.used.update(used)
            return segments, leave
        before = set(self.shapes.used)
        self.shapes.used.clear()
        segments, leave = piece_segments(rows, shift, entry, self.shapes)
        used = frozenset(self.shapes.used)
        self.shapes.used.update(before)
        SEGMENTS.keep(key, (piece, segments, leave, used), len(rows))
        return segments, leave

    def _digest(self, piece: Piece) -> bytes:
        """A name for the piece's moves (equal moves, equal names)."""
        known = self.digests.get(id(piece))
        if known is None:
            digest = hashlib.blake2b(piece.rows.tobytes(), digest_size=16).digest()
            known = self.digests[id(piece)] = (piece, digest)
        return known[1]
