"""The compiled tool path: canonical moves in compact arrays, with the structure kept.

The vocabulary is the Toolpath's (toolpath.py, in the manner of LinuxCNC's canon.hh); the
storage is a numpy structured array, one row a move (`MOVE`), so a program of a million
moves costs tens of megabytes at most, and usually far less: what a LOOP repeats is stored
once and placed by translation.

A compiled path is a tree of nodes:

- `Piece` — rows for consecutive moves, with their spans (holes with their intent, mill
  sequences with their plans: what consumers read instead of the blocks, see `MillSpan`),
  block numbers relative to `Piece.base` (the first data block it was compiled for, so a
  cached piece serves wherever its blocks land after an edit);
- `Run` — one node placed at several XY offsets in order (the patterns of a LOOP/REP that
  begin in the same state), each placement translated: X, Y and arc centres move, Z and
  everything else stays;
- `Seq` — nodes in order.

`walk(node)` yields `Chunk`s: arrays of absolute moves (translated, block numbers made
absolute) with their hole spans, a bounded number of rows at a time, so a consumer's memory
does not grow with the program. `placed_holes` and `placed_mills` give the spans alone,
placed, without the moves.

Row fields (lengths integer nm, part coordinates; feeds nm/min):

| op | x y z | cx cy | feed | value |
|---|---|---|---|---|
| RAPID, FEED | end point | — | FEED's rate | — |
| ARC_CW, ARC_CCW | end point (z: see below) | centre | rate | — |
| DWELL | — | — | — | milliseconds |
| SPINDLE | — | — | 1 clockwise, 0 not | RPM, or -1 for none (set by hand) |
| SPINDLE_OFF, COOLANT_OFF, INDEX, END | — | — | — | — |
| TOOL | z: the head's Z read with the new tool | — | — | tool number |
| STOP, MESSAGE | — | — | — | index into the piece's (the chunk's) `strings` |
| COOLANT | — | — | — | 1 flood (M08), 2 mist (M07) |

An arc starts where the move before it ends; its Z is its end's. When that Z differs from the
start's, the arc is helical: Z changes in proportion to the angle turned (HELIX, THREAD
MILL). One row turns at most once around its centre: a row whose end is its start in X/Y is
a whole turn (a full circle, or one turn of a helix), so a helix of n turns is n rows. One
row per turn, not per quadrant: a G-code target writes one G2/G3 per row, as a programmer
writes a helix, and the consumers that need quadrants or chords (the 1704 tape, the
simulation) split any arc already.

`tag` is the index of the move's purpose in `TAGS` (`retract`, `peck-reentry`, …).
"""

from __future__ import annotations

import enum
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from decimal import Decimal
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from app.cnc import sizes
from app.cnc.blocks import HoleOp
from app.cnc.cutter import Finding
from app.cnc.plane import Path, translated
from app.cnc.routines import Routine
from app.cnc.toolpath import (
    ArcFeed,
    CoolantOff,
    CoolantOn,
    Dwell,
    Feed,
    IndexTable,
    Message,
    Move,
    ProgramEnd,
    ProgramStop,
    Rapid,
    Repetition,
    SpindleOff,
    SpindleOn,
    ToolChange,
    ToolInfo,
    Toolpath,
)
from app.cnc.units import Units

if TYPE_CHECKING:
    # The pocket engine (and pyclipper) loads when a POCKET is planned, not with the path.
    from app.cnc.pocketing.model import PocketPlan


class Op(enum.IntEnum):
    """What a row is (the canonical call)."""

    RAPID = 0
    FEED = 1
    ARC_CW = 2
    ARC_CCW = 3
    DWELL = 4
    SPINDLE = 5
    SPINDLE_OFF = 6
    TOOL = 7
    STOP = 8
    COOLANT = 9
    COOLANT_OFF = 10
    MESSAGE = 11
    INDEX = 12
    END = 13


TAGS: tuple[str, ...] = (
    "",
    "retract",
    "peck-retract",
    "peck-reentry",
    "lead-in",
    "lead-out",
    "step-over",
    "corner",
    "divot",
    "conrad",  # a corner radius the program asks for (app.cnc.solve.corners)
    "chamfer",
)
TAG = {name: k for k, name in enumerate(TAGS)}

MOVE = np.dtype(
    [
        ("op", np.uint8),
        ("tag", np.uint8),
        ("block", np.int32),
        ("x", np.int64),
        ("y", np.int64),
        ("z", np.int64),
        ("cx", np.int64),
        ("cy", np.int64),
        ("feed", np.int64),
        ("value", np.int64),
    ]
)
Rows = npt.NDArray[np.void]
# Holes, one row each (`HoleSpan` reads one): rows [start, end) of a piece or chunk make it.
HOLE = np.dtype(
    [
        ("start", np.int64),
        ("end", np.int64),
        ("op", np.uint8),
        ("canned", np.bool_),
        ("x", np.int64),
        ("y", np.int64),
        ("z0", np.int64),
        ("r", np.int64),
        ("bottom", np.int64),
        ("feed", np.int64),
        ("pecks", np.int32),
        ("step", np.int64),
        ("dwell_ms", np.int32),
        ("tool", np.int32),
    ]
)
HOLE_OPS = (HoleOp.DRILL, HoleOp.BORE, HoleOp.TAP)
# The largest number of rows `walk` puts in one chunk when it repeats a piece.
CHUNK_ROWS = 1 << 15


@dataclass(frozen=True, slots=True)
class HoleSpan:
    """One hole (DRILL, BORE, TAP) in a piece: rows [start, end) make it.

    In nm: (`x`, `y`) the hole, `z0` the height the tool is at when the span begins, `r`
    Z UP, `bottom` Z DN, `feed` FEEDR Z, `step` the peck depth (0 without pecks). `canned`
    is True when the rows are exactly a canned cycle's from `z0` with a return to `z0`
    (G98): an optional rapid across at `z0`, a rapid down to `r`, the feeds (and pecks) to
    `bottom`, a dwell of `dwell_ms`, a rapid up to `z0` — an emitter may write the cycle.
    `tool` is the tool that makes it (the hole block's, a bolt circle's centre block's).
    """

    start: int
    end: int
    op: HoleOp
    x: int
    y: int
    z0: int
    r: int
    bottom: int
    feed: int
    pecks: int
    step: int
    dwell_ms: int
    canned: bool
    tool: int

    @staticmethod
    def of(row: Sequence[int]) -> HoleSpan:
        """The hole a HOLE row (as a tuple) holds."""
        start, end, op, canned, x, y, z0, r, bottom, feed, pecks, step, dwell, tool = row
        return HoleSpan(
            start,
            end,
            HOLE_OPS[op],
            x,
            y,
            z0,
            r,
            bottom,
            feed,
            pecks,
            step,
            dwell,
            bool(canned),
            tool,
        )

    def row(self) -> tuple[int | bool, ...]:
        """The HOLE row of this hole."""
        return (
            self.start,
            self.end,
            HOLE_OPS.index(self.op),
            self.canned,
            self.x,
            self.y,
            self.z0,
            self.r,
            self.bottom,
            self.feed,
            self.pecks,
            self.step,
            self.dwell_ms,
            self.tool,
        )


@dataclass(frozen=True, slots=True)
class MillSpan:
    """One mill sequence in a piece: rows [start, end) cut it (none when its plan has
    errors: it is not cut, the span only says where it would be).

    `drill` is the DRILL block that starts it and `routine` its CIRCLE/FRAME/POCKET block
    (0 for a contour), both numbered like the piece's rows; (`x`, `y`) the DRILL's point
    (nm), where the sequence is entered; `depth` the DRILL's Z DN (None in a 2-axis
    program); `tool` and `comp` the DRILL's.
    `finished` is the programmed contour (float nm) as it was planned, or None for a
    routine; `contour()` gives it where this span is — moved by (`dx`, `dy`), its blocks
    renumbered by `shift`. `plan` is the rest of what was planned (`MillPlan`), read where
    this span is through `exit()`, `shape()`, `outlines()`, `pocket()` and `findings()`:
    what every consumer reads instead of planning the sequence again.
    """

    start: int
    end: int
    drill: int
    x: int
    y: int
    finished: Path | None
    routine: int
    depth: int | None
    tool: int
    comp: str
    dx: int = 0
    dy: int = 0
    shift: int = 0
    # Not in the repr nor compared: it is made from what the other fields hold (a drawing
    # keys on the repr) and a pocket's plan is large.
    plan: MillPlan = field(default_factory=lambda: MillPlan((0, 0)), repr=False, compare=False)

    def moved(self, rows: int, dx: int, dy: int, blocks: int = 0) -> MillSpan:
        """This span `rows` later, (dx, dy) over and `blocks` block numbers on."""
        return MillSpan(
            self.start + rows,
            self.end + rows,
            self.drill + blocks,
            self.x + dx,
            self.y + dy,
            self.finished,
            self.routine + blocks if self.routine else 0,
            self.depth,
            self.tool,
            self.comp,
            self.dx + dx,
            self.dy + dy,
            self.shift + blocks,
            self.plan,
        )

    @property
    def _here(self) -> bool:
        """True when the plan is where this span is (nothing to move or renumber)."""
        return not (self.dx or self.dy or self.shift)

    def contour(self) -> Path | None:
        """The programmed contour where this span cuts it (None for a routine)."""
        if self.finished is None:
            return None
        if self._here:
            return self.finished
        return translated(self.finished, self.dx, self.dy, self.shift)

    def exit(self) -> tuple[int, int]:
        """The programmed end point (nm): the reference for a following INC block (the
        DRILL's point after a routine)."""
        x, y = self.plan.end
        return x + self.dx, y + self.dy

    def shape(self) -> Routine | None:
        """A CIRCLE/FRAME routine's circle or frame where this span cuts it (None for a
        contour or a POCKET)."""
        routine = self.plan.routine
        if routine is None or self._here:
            return routine
        if routine.is_frame:
            corner = (routine.corner[0] + self.dx, routine.corner[1] + self.dy)
            return replace(routine, block=routine.block + self.shift, corner=corner)
        centre = (routine.centre[0] + self.dx, routine.centre[1] + self.dy)
        return replace(routine, block=routine.block + self.shift, centre=centre)

    def outlines(self) -> tuple[tuple[str, Path], ...]:
        """A POCKET's wall ("boundary") and islands where this span cuts it (empty for
        anything else)."""
        if self._here:
            return self.plan.outlines
        return tuple(
            (name, translated(path, self.dx, self.dy, self.shift))
            for name, path in self.plan.outlines
        )

    def pocket(self) -> PocketPlan | None:
        """A POCKET's passes and links where this span cuts it (None for anything else,
        and for a POCKET whose plan has errors)."""
        plan = self.plan.pocket
        if plan is None or self._here:
            return plan

        def move(path: Path) -> Path:
            return translated(path, self.dx, self.dy, self.shift)

        passes = tuple(
            replace(p, path=move(p.path), entry=replace(p.entry, path=move(p.entry.path)))
            for p in plan.passes
        )
        return replace(plan, passes=passes)

    def findings(self) -> tuple[Finding, ...]:
        """What planning the sequence found (compensation limits, routine sizes, a
        pocket's narrow places), numbered where this span is."""
        if not self.shift:
            return self.plan.findings
        return tuple(replace(f, block=f.block + self.shift) for f in self.plan.findings)


@dataclass(frozen=True, slots=True)
class MillPlan:
    """What a mill sequence was planned as, where it was compiled (nm, block numbers as
    compiled; a MillSpan moves it to where it is cut).

    `end` the programmed end point; `routine` a CIRCLE/FRAME's circle or frame and the way
    it goes round; `outlines` a POCKET's wall and islands; `pocket` a POCKET's passes with
    their links (None when its plan has errors); `findings` what planning found. The
    programmed contour of a line/arc sequence is `MillSpan.finished`.
    """

    end: tuple[int, int]
    routine: Routine | None = None
    outlines: tuple[tuple[str, Path], ...] = ()
    pocket: PocketPlan | None = None
    findings: tuple[Finding, ...] = ()


@dataclass(slots=True)
class Piece:
    """Consecutive moves: `rows` (MOVE), their `holes` and `mills`, block numbers relative
    to `base`, and the texts STOP and MESSAGE rows refer to."""

    rows: Rows
    holes: npt.NDArray[np.void] = field(default_factory=lambda: np.zeros(0, dtype=HOLE))
    mills: tuple[MillSpan, ...] = ()
    base: int = 0
    strings: tuple[str, ...] = ()

    def __len__(self) -> int:
        return len(self.rows)


@dataclass(slots=True)
class Run:
    """`node` placed at each of `offsets` (k × 2, nm) in turn, block numbers + `base`.

    For the patterns of a LOOP, `rep` is its REP block (relative, like rows' blocks),
    `first` the number of its first pattern here (a LOOP's patterns may be several runs)
    and `origin` the offset of the LOOP's first pattern.
    """

    node: Node
    offsets: npt.NDArray[np.int64]
    base: int = 0
    rep: int = 0
    first: int = 0
    origin: tuple[int, int] = (0, 0)
    # Computed on first use (a node may be shared by several runs; the results are the same).
    moves: int = field(default=-1, repr=False, compare=False)
    flat: Piece | None = field(default=None, repr=False, compare=False)


@dataclass(slots=True)
class Seq:
    """Nodes in order."""

    nodes: list[Node] = field(default_factory=list)
    moves: int = field(default=-1, repr=False, compare=False)
    flat: Piece | None = field(default=None, repr=False, compare=False)


Node = Piece | Run | Seq


def size(node: Node) -> int:
    """How many moves `node` makes."""
    if isinstance(node, Piece):
        return len(node.rows)
    if node.moves < 0:
        if isinstance(node, Run):
            node.moves = size(node.node) * len(node.offsets)
        else:
            node.moves = sum(size(n) for n in node.nodes)
    return node.moves


# A node that makes at most this many moves is walked as one piece when it is placed more
# than once (flattened on first use): each placement is then one tiling, not a recursion.
FLAT_ROWS = 4096


def flattened(node: Node) -> Piece:
    """`node`'s moves as one piece (block numbers as the node has them), kept on the node."""
    if isinstance(node, Piece):
        return node
    if node.flat is not None:
        return node.flat
    chunks = list(walk(node))
    rows = np.concatenate([c.rows for c in chunks]) if chunks else np.zeros(0, dtype=MOVE)
    holes: list[npt.NDArray[np.void]] = []
    mills: list[MillSpan] = []
    strings: list[str] = []
    offset = 0
    for chunk in chunks:
        _join_strings(rows[offset : offset + len(chunk.rows)], chunk.strings, strings)
        moved = chunk.holes.copy()
        moved["start"] += offset
        moved["end"] += offset
        holes.append(moved)
        mills += [m.moved(offset, 0, 0) for m in chunk.mills]
        offset += len(chunk.rows)
    all_holes = np.concatenate(holes) if holes else np.zeros(0, dtype=HOLE)
    node.flat = Piece(rows, all_holes, tuple(mills), 0, tuple(strings))
    return node.flat


def _join_strings(rows: Rows, own: tuple[str, ...], joined: list[str]) -> None:
    """Point the STOP and MESSAGE `rows` (a view into the joined rows) at `joined`, the
    texts of every chunk joined so far, instead of their chunk's `own` (texts added)."""
    remap = {}
    for k, text in enumerate(own):
        if text not in joined:
            joined.append(text)
        remap[k] = joined.index(text)
    if any(k != v for k, v in remap.items()):
        texts = (rows["op"] == Op.STOP) | (rows["op"] == Op.MESSAGE)
        rows["value"][texts] = [remap[v] for v in rows["value"][texts].tolist()]


def row_batches(
    chunks: Iterable[Chunk], rows: int = FLAT_ROWS
) -> Iterator[tuple[Rows, tuple[str, ...]]]:
    """The moves of `chunks` in arrays of at least `rows` rows (the last may be shorter), with
    the texts their STOP and MESSAGE rows refer to. For consumers that read moves only (the
    cycle time): a program of many small blocks comes in many small chunks, and numpy's
    cost per call, not per row, would dominate."""
    pending: list[Chunk] = []
    count = 0
    for chunk in chunks:
        if len(chunk.rows) >= rows and not pending:
            yield chunk.rows, chunk.strings
            continue
        pending.append(chunk)
        count += len(chunk.rows)
        if count >= rows:
            yield _joined_rows(pending)
            pending, count = [], 0
    if pending:
        yield _joined_rows(pending)


def _joined_rows(chunks: list[Chunk]) -> tuple[Rows, tuple[str, ...]]:
    if len(chunks) == 1:
        return chunks[0].rows, chunks[0].strings
    rows = np.concatenate([c.rows for c in chunks])
    strings: list[str] = []
    offset = 0
    for chunk in chunks:
        _join_strings(rows[offset : offset + len(chunk.rows)], chunk.strings, strings)
        offset += len(chunk.rows)
    return rows, tuple(strings)


class Chunk:
    """Absolute moves (a MOVE array), their holes and mill sequences (row indices within
    the chunk, blocks absolute) and the texts their STOP and MESSAGE rows refer to.

    `mills` are made on first use: most consumers never read them."""

    __slots__ = ("_mills", "_placements", "holes", "rows", "strings")

    def __init__(
        self,
        rows: Rows,
        holes: npt.NDArray[np.void],
        mills: list[MillSpan] | None,
        strings: tuple[str, ...],
        placements: tuple[Piece, npt.NDArray[np.int64], int] | None = None,
    ) -> None:
        self.rows = rows
        self.holes = holes  # HOLE rows
        self.strings = strings
        self._mills = mills
        self._placements = placements

    @property
    def mills(self) -> list[MillSpan]:
        """The mill spans, in order."""
        if self._mills is None:
            assert self._placements is not None
            piece, offsets, shift = self._placements
            n = len(piece.rows)
            self._mills = [
                mill.moved(k * n, ox, oy, shift)
                for k, (ox, oy) in enumerate(offsets.tolist())
                for mill in piece.mills
            ]
        return self._mills

    def hole_spans(self) -> list[HoleSpan]:
        """The holes as objects."""
        return [HoleSpan.of(row) for row in self.holes.tolist()]


def walk(node: Node, dx: int = 0, dy: int = 0, base: int = 0) -> Iterator[Chunk]:
    """The moves of `node` translated by (dx, dy) with `base` added to block numbers, as
    chunks in order. A piece repeated by a run is tiled in chunks of about CHUNK_ROWS. Each
    chunk spends from the time budget in force (app.cnc.sizes.spend), so every consumer of
    the moves does."""
    if isinstance(node, Piece):
        sizes.spend()
        yield _placed(node, np.array([[dx, dy]], dtype=np.int64), base)
    elif isinstance(node, Seq):
        for child in node.nodes:
            yield from walk(child, dx, dy, base)
    elif isinstance(node.node, Piece) or (len(node.offsets) > 1 and size(node.node) <= FLAT_ROWS):
        piece = flattened(node.node)
        per = max(1, CHUNK_ROWS // max(1, len(piece.rows)))
        offsets = node.offsets + np.array([dx, dy], dtype=np.int64)
        for k in range(0, len(offsets), per):
            sizes.spend()
            yield _placed(piece, offsets[k : k + per], base + node.base)
    else:
        for ox, oy in node.offsets.tolist():
            yield from walk(node.node, dx + ox, dy + oy, base + node.base)


def pieces(node: Node) -> Iterator[Piece]:
    """Each distinct piece under `node` once, unplaced: for the questions a placement does
    not change (which hole operations, which tools), so a LOOP of 10^4 patterns costs its
    pieces, not its placements."""
    seen: set[int] = set()
    stack = [node]
    while stack:
        here = stack.pop()
        if id(here) in seen:
            continue
        seen.add(id(here))
        if isinstance(here, Piece):
            yield here
        elif isinstance(here, Seq):
            stack.extend(reversed(here.nodes))
        else:
            stack.append(here.node)


def placed_holes(
    node: Node, dx: int = 0, dy: int = 0, base: int = 0
) -> Iterator[tuple[npt.NDArray[np.int64], npt.NDArray[np.void]]]:
    """Every hole of `node` in cutting order, without placing its moves: (block numbers,
    HOLE rows moved to where each is cut) per piece placed. For the rules that read only
    the holes (a tap's pilot): a LOOP of holes costs its holes, not its moves."""
    if isinstance(node, Piece):
        if len(node.holes):
            holes = _placed_holes(node.holes, len(node.rows), np.array([[dx, dy]], np.int64))
            yield node.rows["block"][node.holes["start"]] + (node.base + base), holes
    elif isinstance(node, Seq):
        for child in node.nodes:
            yield from placed_holes(child, dx, dy, base)
    elif isinstance(node.node, Piece):
        piece = node.node
        if len(piece.holes):
            offsets = node.offsets + np.array([dx, dy], dtype=np.int64)
            blocks = piece.rows["block"][piece.holes["start"]] + (piece.base + base + node.base)
            yield np.tile(blocks, len(offsets)), _placed_holes(piece.holes, len(piece), offsets)
    else:
        for ox, oy in node.offsets.tolist():
            yield from placed_holes(node.node, dx + ox, dy + oy, base + node.base)


# What one element of a kept plan costs in memory, in rows (62 bytes each): an element
# with its points and its share of the passes and links holding it, about 380 bytes
# (tracemalloc over the pocket-islands plan).
PLAN_ELEMENT_ROWS = 6


def plan_rows(node: Node) -> int:
    """The memory the plans kept on `node`'s mill spans take, in rows: for a cache that
    bounds what it holds by rows (a POCKET's plan can outweigh its moves). A node placed
    several times holds its plans once."""
    if isinstance(node, Piece):
        elements = 0
        for mill in node.mills:
            plan = mill.plan
            paths = [path for _, path in plan.outlines]
            if plan.pocket is not None:
                for cut in plan.pocket.passes:
                    paths += [cut.path, cut.entry.path]
            elements += sum(len(path.elements) for path in paths)
            elements += 0 if mill.finished is None else len(mill.finished.elements)
        return elements * PLAN_ELEMENT_ROWS
    if isinstance(node, Seq):
        return sum(plan_rows(child) for child in node.nodes)
    return plan_rows(node.node)


def placed_mills(node: Node, dx: int = 0, dy: int = 0, base: int = 0) -> Iterator[MillSpan]:
    """Every mill sequence of `node` in cutting order, where it is cut (blocks absolute,
    rows counted from the node's first), without placing the moves: for the consumers that
    read the plans (events, Verify's intended part, cleared areas), a LOOP of holes costs
    nothing here."""
    yield from _placed_mills(node, dx, dy, base, 0)


def _placed_mills(node: Node, dx: int, dy: int, base: int, row: int) -> Iterator[MillSpan]:
    if isinstance(node, Piece):
        shift = node.base + base
        for mill in node.mills:
            yield mill.moved(row, dx, dy, shift)
    elif isinstance(node, Seq):
        for child in node.nodes:
            yield from _placed_mills(child, dx, dy, base, row)
            row += size(child)
    elif _has_mills(node.node):
        per = size(node.node)
        for ox, oy in node.offsets.tolist():
            yield from _placed_mills(node.node, dx + ox, dy + oy, base + node.base, row)
            row += per


def _has_mills(node: Node) -> bool:
    if isinstance(node, Piece):
        return bool(node.mills)
    if isinstance(node, Seq):
        return any(_has_mills(child) for child in node.nodes)
    return _has_mills(node.node)


def distinct(values: npt.NDArray[np.integer]) -> npt.NDArray[np.integer]:
    """The different values of an integer array, in increasing order: `np.unique(values)`
    for the columns of a path. numpy's own asks whether its argument is a masked array,
    which imports numpy.ma (about 20 ms, most of it numpy.ma reading the signatures of
    numpy's functions) into every command that exports (issue 31.3)."""
    ordered = np.sort(values, axis=None)
    first = np.ones(len(ordered), dtype=bool)
    np.not_equal(ordered[1:], ordered[:-1], out=first[1:])
    return ordered[first]


def lowest_by_block(node: Node, base: int = 0, out: dict[int, int] | None = None) -> dict[int, int]:
    """The lowest Z (nm) any move of each block reaches, by block number. Z does not move
    with a LOOP's placements, so each repeated node is read once."""
    found: dict[int, int] = {} if out is None else out
    if isinstance(node, Piece):
        rows = node.rows
        moving = rows["op"] <= Op.ARC_CCW  # RAPID, FEED and the arcs
        if moving.any():
            blocks = rows["block"][moving] + (node.base + base)
            zs = rows["z"][moving]
            for block in distinct(blocks).tolist():
                low = int(zs[blocks == block].min())
                found[block] = min(low, found.get(block, low))
    elif isinstance(node, Seq):
        for child in node.nodes:
            lowest_by_block(child, base, found)
    else:
        lowest_by_block(node.node, base + node.base, found)
    return found


def _placed_holes(
    holes: npt.NDArray[np.void], n: int, offsets: npt.NDArray[np.int64]
) -> npt.NDArray[np.void]:
    """A piece's holes for each placement in turn (rows moved on by `n` each time)."""
    count = len(offsets)
    if not len(holes):
        return holes
    if count == 1:
        placed = holes.copy()
        dx, dy = offsets[0].tolist()
        placed["x"] += dx
        placed["y"] += dy
        return placed
    placed = np.tile(holes, count)
    per = len(holes)
    shift = np.repeat(np.arange(count, dtype=np.int64) * n, per)
    placed["start"] += shift
    placed["end"] += shift
    placed["x"] += np.repeat(offsets[:, 0], per)
    placed["y"] += np.repeat(offsets[:, 1], per)
    return placed


def _placed(piece: Piece, offsets: npt.NDArray[np.int64], base: int) -> Chunk:
    """`piece` placed at each of `offsets` in turn, as one chunk."""
    n = len(piece.rows)
    count = len(offsets)
    rows = np.tile(piece.rows, count) if count > 1 else piece.rows.copy()
    if count == 1:
        # One placement (the common case in a walk): scalars, and nothing where they are 0.
        dx, dy = offsets[0].tolist()
        if dx:
            rows["x"] += dx
            rows["cx"] += dx
        if dy:
            rows["y"] += dy
            rows["cy"] += dy
    else:
        steps_x = np.repeat(offsets[:, 0], n)
        steps_y = np.repeat(offsets[:, 1], n)
        rows["x"] += steps_x
        rows["y"] += steps_y
        rows["cx"] += steps_x
        rows["cy"] += steps_y
    shift = piece.base + base
    if shift:
        rows["block"] += shift
    holes = _placed_holes(piece.holes, n, offsets)
    if not piece.mills:
        return Chunk(rows, holes, [], piece.strings)
    return Chunk(rows, holes, None, piece.strings, (piece, offsets, shift))


@dataclass(slots=True)
class CompiledPath:
    """A program's moves (`root`), where they start, and what they are done with.

    `units` is the program's unit (for printing). `origin` the Data Block 0 offset of part
    zero from table zero (nm). `start` where the tool is before the first move: over part
    zero, Z RET above tool zero.
    """

    units: Units
    origin: tuple[int, int]
    start: tuple[int, int, int]
    initial_tool: int
    tools: dict[int, ToolInfo]
    root: Node

    def __len__(self) -> int:
        return size(self.root)

    def chunks(self) -> Iterator[Chunk]:
        return walk(self.root)

    def toolpath(self) -> Toolpath:
        """The whole path as the Toolpath of Move objects, LOOP patterns listed: for the
        consumers that need every move at once (small programs; the arrays are cheaper)."""
        patterns: list[Repetition] = []
        repetitions(self.root, 0, 0, 0, patterns)
        return Toolpath(
            units=self.units,
            origin=self.origin,
            start=self.start,
            initial_tool=self.initial_tool,
            tools=self.tools,
            moves=list(self.moves()),
            repetitions=patterns,
        )

    def moves(self) -> Iterator[Move]:
        """The moves as the Toolpath's objects, one at a time (for the consumers that
        walk moves; the arrays are cheaper)."""
        for chunk in self.chunks():
            strings = chunk.strings
            for row in chunk.rows.tolist():
                yield as_move(row, strings)


def repetitions(node: Node, start: int, depth: int, base: int, out: list[Repetition]) -> int:
    """Append the LOOP patterns of `node` (rows from `start`) to `out`; the rows it makes.
    A pattern's offset is from its LOOP's first pattern, as the Toolpath has it."""
    if isinstance(node, Piece):
        return len(node.rows)
    if isinstance(node, Seq):
        at = start
        for child in node.nodes:
            at += repetitions(child, at, depth, base, out)
        return at - start
    at = start
    is_loop = node.rep > 0
    origin = node.origin
    for k, (ox, oy) in enumerate(node.offsets.tolist()):
        number = node.first + k
        rows = repetitions(node.node, at, depth + is_loop, base + node.base, out)
        if is_loop:
            out.append(
                Repetition(
                    node.rep + base + node.base,
                    depth + 1,
                    number,
                    at,
                    at + rows,
                    (ox - origin[0], oy - origin[1]),
                )
            )
        at += rows
    return at - start


def as_move(row: Sequence[int], strings: Sequence[str]) -> Move:
    """A MOVE row (as a tuple) as the Toolpath's object."""
    op, tag, block, x, y, z, cx, cy, feed, value = row
    kind = Op(op)
    if kind is Op.RAPID:
        return Rapid(block, x, y, z, TAGS[tag])
    if kind is Op.FEED:
        return Feed(block, x, y, z, feed, TAGS[tag])
    if kind is Op.ARC_CW or kind is Op.ARC_CCW:
        return ArcFeed(block, x, y, z, cx, cy, kind is Op.ARC_CW, feed, TAGS[tag])
    if kind is Op.DWELL:
        return Dwell(block, Decimal(value) / 1000)
    if kind is Op.SPINDLE:
        return SpindleOn(block, bool(feed), None if value < 0 else value)
    if kind is Op.SPINDLE_OFF:
        return SpindleOff(block)
    if kind is Op.TOOL:
        return ToolChange(block, value, z)
    if kind is Op.STOP:
        return ProgramStop(block, strings[value])
    if kind is Op.COOLANT:
        return CoolantOn(block, "flood" if value == 1 else "mist")
    if kind is Op.COOLANT_OFF:
        return CoolantOff(block)
    if kind is Op.MESSAGE:
        return Message(block, strings[value])
    if kind is Op.INDEX:
        return IndexTable(block)
    return ProgramEnd(block)
