"""Cycle-time estimate per block, per tool and in total.

Not a trajectory planner. What it assumes, stated with every estimate (`ASSUMPTIONS`):
- rapids are straight lines at the control's 250 ipm (XY and Z, seed 001 §3.4.5.2 POS/DRILL);
- feeds run at the programmed rate along the path (line or arc length); acceleration and
  deceleration are not modelled, so short moves are estimated slightly fast;
- hole dwells are 0.8 s; a tool change costs a fixed allowance (default 30 s, the operator
  changes tools by hand on this control);
- program stops, STOP blocks and manual quill moves wait for the operator: counted as 0 s
  and listed, since the operator's time cannot be known;
- rotary-table indexing is counted as 0 s and listed;
- a machine's operator time (seed 002 OTIME: "the additional operator time to be added to
  the printed cycle time") is added once to the total.

It reads the compiled path's chunks (numpy arrays of moves), each chunk at once, and gives
the same figures to the last bit as adding one move at a time in Python floats: lengths
are the exact integer sums of squares rounded once, arcs use the math module, and every
sum adds its terms in move order (tests/test_estimate.py keeps the one-move-at-a-time
estimate as the reference).

Each top-level node's per-move figures are kept (`TIMED`, bounded) by the node the compiler
handed out and where the tool enters it, so the estimate after an edit times only the nodes
the edit changed. Within one estimate a LOOP's pattern is timed once per place the tool
enters it from (relative to the placement): its other placements take the same per-move
figures (`_Placed`). The sums are still added move by move over the whole program.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from decimal import Decimal
from typing import Protocol

import numpy as np
import numpy.typing as npt

from app.cnc.geometry import arc_sweep
from app.cnc.limits import DEFAULT_TOOL_CHANGE_SECONDS, RAPID_IPM
from app.cnc.machine import MachineModel
from app.cnc.memo import Memo
from app.cnc.path import (
    FLAT_ROWS,
    HOLE,
    MOVE,
    Chunk,
    CompiledPath,
    Node,
    Op,
    Piece,
    Rows,
    Run,
    Seq,
    row_batches,
    size,
    walk,
)
from app.cnc.toolpath import (
    ArcFeed,
    Dwell,
    Feed,
    IndexTable,
    Move,
    ProgramStop,
    Rapid,
    ToolChange,
    Toolpath,
)
from app.cnc.units import NM_PER_INCH

RAPID_NM_PER_MIN = int(RAPID_IPM) * NM_PER_INCH


def assumptions(tool_change_seconds: float, machine: MachineModel | None = None) -> list[str]:
    """The estimate's assumptions, in words, for printing beside it."""
    rapid = "250 ipm"
    feeds = "programmed rate along the path; acceleration not modelled"
    operator = "operator stops, STOP blocks, manual quill moves and indexing: 0 s (listed)"
    if machine is not None:
        unit = machine.units.feed_symbol
        if machine.rapid is not None:
            rapid = f"{machine.rapid} {unit} ({machine.name or 'the machine'})"
        if machine.max_feed is not None:
            feeds += f"; limited to the machine's {machine.max_feed} {unit}"
        if machine.operator_seconds is not None:
            operator = (
                f"operator time (OTIME): {machine.operator_seconds} s added once to the total; "
                "operator stops, STOP blocks, manual quill moves and indexing: 0 s (listed)"
            )
    return [
        f"rapids: straight lines at {rapid} (XY and Z)",
        f"feeds: {feeds}",
        "hole dwell: 0.8 s",
        f"tool change: {tool_change_seconds:g} s allowance each",
        operator,
    ]


@dataclass
class Estimate:
    """Seconds per block number, per tool number, in total; operator waits listed."""

    per_block: dict[int, float] = field(default_factory=dict)
    per_tool: dict[int, float] = field(default_factory=dict)
    total: float = 0.0
    rapid: float = 0.0
    cutting: float = 0.0
    dwell: float = 0.0
    tool_changes: int = 0
    operator: float = 0.0  # OTIME, in the total but no block's
    operator_waits: list[tuple[int, str]] = field(default_factory=list)
    assumptions: list[str] = field(default_factory=list)


def estimate(
    path: CompiledPath | Toolpath,
    tool_change_seconds: float | None = None,
    machine: MachineModel | None = None,
) -> Estimate:
    """Estimate the run time of `path` (see the module docstring for the model).

    A `machine` sets the rapid rate, caps feeds at its maximum, and supplies its tool-change
    and operator times (OTIME); `tool_change_seconds` overrides the tool-change time. A
    compiled path is read chunk by chunk (memory stays flat); a Toolpath of move objects
    is read as one chunk.
    """
    if tool_change_seconds is None:
        known = machine.tool_change_seconds if machine is not None else None
        tool_change_seconds = float(known) if known is not None else DEFAULT_TOOL_CHANGE_SECONDS
    rapid_rate = RAPID_NM_PER_MIN
    max_feed = None
    operator = 0.0
    if machine is not None:
        if machine.rapid is not None:
            rapid_rate = machine.nm(machine.rapid)
        if machine.max_feed is not None:
            max_feed = machine.nm(machine.max_feed)
        if machine.operator_seconds is not None:
            operator = float(machine.operator_seconds)
    result = Estimate(assumptions=assumptions(tool_change_seconds, machine))
    clock = _Clock(path.start, path.initial_tool, rapid_rate, max_feed, tool_change_seconds)
    totals = _Totals(result)
    if isinstance(path, CompiledPath):
        placed = _Placed()
        for node, base, shared in _top_level(path.root):
            _time_node(node, base, shared, clock, totals, placed)
    else:
        for rows, strings in row_batches([chunk_of(path)]):
            totals.add(clock.time(rows, strings), 0)
    totals.flush()
    result.per_block = totals.per_block.totals()
    result.per_tool = totals.per_tool.totals()
    result.operator = operator
    # Added in the order the blocks first came, as the figures always were.
    result.total = totals.per_block.total() + operator
    return result


# -- each top-level node timed once per entry state ----------------------------------------
#
# The compiler caches each top-level node by its blocks and entry state and hands out the
# same node object again after an edit (compiler.py). A node's moves take the same seconds
# whenever the tool enters it at the same place with the same tool and rates, so each
# node's per-move figures are kept here by (node, entry, rates) and an edit re-times only
# the nodes it changed. The sums are still added move by move over the whole program
# (`_Totals`): the figures do not depend on what was kept.


def _top_level(root: Node) -> Iterator[tuple[Node, int, bool]]:
    """(node, base, shared) for each top-level stretch of a compiled path: `shared` when
    the node is one the compiler keeps (a top-level Run placed once where it stands, block
    numbers relative to `base`); else the node as it is, blocks absolute (base 0)."""
    nodes = root.nodes if isinstance(root, Seq) else [root]
    for node in nodes:
        if isinstance(node, Run) and node.offsets.tolist() == [[0, 0]]:
            yield node.node, node.base, True
        else:
            yield node, 0, False


def _time_node(
    node: Node, base: int, shared: bool, clock: _Clock, totals: _Totals, placed: _Placed
) -> None:
    """Time `node`'s moves from where `clock` stands (from the memo when it was timed from
    there before) and add them to `totals`, its block numbers + `base`."""
    if not shared or size(node) + 1 > TIMED.budget // 10:
        # Not one the compiler keeps, or too large to keep: timed as it is placed.
        _time_tree(node, 0, 0, base, clock, totals, placed)
        return
    key = (id(node), clock.entry(), clock.rates())
    found = TIMED.get(key)
    if found is None or found[0] is not node:
        parts = _Parts()
        _time_tree(node, 0, 0, 0, clock, parts, placed)
        timed = parts.joined(clock.entry())
        # The node is kept with its figures, so no other node can take its id meanwhile.
        TIMED.keep(key, (node, timed), size(node) + 1)
    else:
        timed = found[1]
        clock.enter(timed.exit)
    totals.add(timed, base)


# -- each pattern timed once per place the tool enters it from -----------------------------
#
# A move's seconds depend only on the move and on where the tool stands before it (and the
# tool, the rates): every length is an integer difference of nm, every arc's figure a
# function of its ends' places from its centre. A LOOP's placed pattern is its pattern
# moved, so its moves take the same seconds as the pattern's whenever the tool enters it
# from the same place relative to it; only a placement entered from elsewhere (the first
# of a row, say) is timed again. The per-move seconds are the same numbers in the same
# order, so the sums (added move by move in `_Totals`) are the same to the last bit.


class _Sink(Protocol):
    def add(self, timed: _Timed, base: int) -> None: ...


class _Parts:
    """Timed stretches gathered into one (`joined`), block numbers + their base."""

    def __init__(self) -> None:
        self.parts: list[_Timed] = []

    def add(self, timed: _Timed, base: int) -> None:
        if base:
            blocks = timed.blocks + base
            waits = [(block + base, why) for block, why in timed.waits]
            timed = replace(timed, blocks=blocks, waits=waits)
        self.parts.append(timed)

    def joined(self, entry: tuple[int, int, int, int]) -> _Timed:
        return _Timed.joined(self.parts, entry)


# A node as it stands wherever it is placed: a run is its pattern and its offsets from the
# first one (the compiler makes a run per row of a LOOP's grid, each its own object).
_Shape = tuple[int, int, bytes]
_Entry = tuple[int, int, int, int]


def _shape(node: Node) -> tuple[_Shape, Node, int, int]:
    """`node`'s shape, the node to walk for it (placed at its own origin) and that origin
    (x, y nm: where the node places it; 0, 0 but for a run, its first offset)."""
    if not isinstance(node, Run) or not len(node.offsets):
        return (id(node), 0, b""), node, 0, 0
    fx, fy = node.offsets[0].tolist()
    steps = node.offsets - node.offsets[0]
    shape = (id(node.node), node.base, steps.tobytes())
    return shape, Run(node.node, steps, node.base), fx, fy


class _Placed:
    """The figures of shapes timed during one estimate, by shape and entry (relative to the
    shape's origin); bounded (beyond `ROWS` moves in all, no more are kept)."""

    ROWS = 1 << 17

    def __init__(self) -> None:
        self.held = 0
        self.timed: dict[tuple[_Shape, _Entry], _Timed] = {}
        self.nodes: list[Node] = []  # kept alive, so no id in a shape is reused meanwhile

    def time(self, node: Node, dx: int, dy: int, clock: _Clock) -> _Timed:
        """The figures of `node` placed at (dx, dy), from where `clock` stands; the clock
        ends where the node leaves the tool."""
        shape, unplaced, fx, fy = _shape(node)
        ox, oy = dx + fx, dy + fy
        x, y, z, tool = clock.entry()
        key = (shape, (x - ox, y - oy, z, tool))
        timed = self.timed.get(key)
        if timed is None:
            # Timed where the shape stands at its origin, from the same place relative to it.
            clock.enter(key[1])
            parts = [clock.time(rows, strings) for rows, strings in row_batches(walk(unplaced))]
            timed = _Timed.joined(parts, clock.entry())
            if self.held + len(timed.seconds) <= self.ROWS:
                self.held += len(timed.seconds)
                self.timed[key] = timed
                self.nodes.append(node)
        ex, ey, ez, et = timed.exit
        clock.enter((ex + ox, ey + oy, ez, et))
        return timed


def _time_tree(
    node: Node, dx: int, dy: int, base: int, clock: _Clock, sink: _Sink, placed: _Placed
) -> None:
    """Time `node` placed at (dx, dy), its block numbers + `base`, from where `clock`
    stands, and add its moves to `sink` in order; the clock ends where the node leaves the
    tool. A node of at most FLAT_ROWS moves (or a piece) is timed in one go (`_Placed`)
    and kept by its shape and where the tool enters it relative to the shape's origin; a
    larger one is timed child by child and placement by placement, so each placement of a
    pattern entered as one before it takes that one's figures."""
    if isinstance(node, Piece) or size(node) <= FLAT_ROWS:
        sink.add(placed.time(node, dx, dy, clock), base)
    elif not _repeats(node):
        # Nothing in it is placed twice: timed as it streams by, in batches.
        for rows, strings in row_batches(walk(node, dx, dy, base)):
            sink.add(clock.time(rows, strings), 0)
    elif isinstance(node, Seq):
        for child in node.nodes:
            _time_tree(child, dx, dy, base, clock, sink, placed)
    else:
        for ox, oy in node.offsets.tolist():
            _time_tree(node.node, dx + ox, dy + oy, base + node.base, clock, sink, placed)


def _repeats(node: Node) -> bool:
    """Whether `node` places anything more than once."""
    if isinstance(node, Piece):
        return False
    if isinstance(node, Run):
        return len(node.offsets) > 1 or _repeats(node.node)
    return any(_repeats(child) for child in node.nodes)


# Per-move figures of top-level nodes: (node, figures) by (id(node), entry, rates).
TIMED: Memo[tuple[Node, _Timed]] = Memo()

# What each move's seconds count towards besides its block and tool.
_OTHER, _RAPID, _CUTTING, _DWELL = 0, 1, 2, 3


@dataclass(slots=True)
class _Timed:
    """Moves timed: per move its seconds, block, tool and kind (_RAPID…); the tool changes
    and operator waits among them, and where the clock stands after them (x, y, z, tool)."""

    seconds: npt.NDArray[np.float64]
    blocks: npt.NDArray[np.int64]
    tools: npt.NDArray[np.int64]
    kinds: npt.NDArray[np.int8]
    tool_changes: int
    waits: list[tuple[int, str]]
    exit: tuple[int, int, int, int]

    @staticmethod
    def joined(parts: list[_Timed], entry: tuple[int, int, int, int]) -> _Timed:
        """`parts` one after another (nothing timed: where the clock was, `entry`)."""
        if len(parts) == 1:
            return parts[0]
        if not parts:
            empty = np.zeros(0, dtype=np.int64)
            return _Timed(np.zeros(0), empty, empty, np.zeros(0, np.int8), 0, [], entry)
        return _Timed(
            np.concatenate([p.seconds for p in parts]),
            np.concatenate([p.blocks for p in parts]),
            np.concatenate([p.tools for p in parts]),
            np.concatenate([p.kinds for p in parts]),
            sum(p.tool_changes for p in parts),
            [w for p in parts for w in p.waits],
            parts[-1].exit,
        )


# Moves summed per batch: a few MB of temporaries at most.
SUM_ROWS = 1 << 16


class _Totals:
    """The sums, added in move order over stretches of timed moves: stretches are gathered
    into batches of at least SUM_ROWS moves (numpy's cost per call, not per move, would
    dominate a program of many small nodes; the stretches of a placed pattern are the
    pattern's figures again, so gathering them costs nothing until the batch is summed)."""

    def __init__(self, result: Estimate) -> None:
        self.result = result
        self.per_block = _Sums()
        self.per_tool = _Sums()
        self.pending: list[tuple[_Timed, int]] = []
        self.count = 0

    def add(self, timed: _Timed, base: int) -> None:
        """Add `timed`, its block numbers + `base`."""
        self.result.tool_changes += timed.tool_changes
        if timed.waits:
            self.result.operator_waits += [(block + base, why) for block, why in timed.waits]
        self.pending.append((timed, base))
        self.count += len(timed.seconds)
        if self.count >= SUM_ROWS:
            self.flush()

    def flush(self) -> None:
        if not self.pending:
            return
        parts, self.pending, self.count = self.pending, [], 0
        seconds = np.concatenate([t.seconds for t, _ in parts])
        kinds = np.concatenate([t.kinds for t, _ in parts])
        blocks = np.concatenate([t.blocks for t, _ in parts])
        if any(base for _, base in parts):
            blocks = blocks + np.repeat(
                np.array([base for _, base in parts], dtype=np.int64),
                [len(t.blocks) for t, _ in parts],
            )
        result = self.result
        result.rapid = _running(result.rapid, seconds[kinds == _RAPID])
        result.cutting = _running(result.cutting, seconds[kinds == _CUTTING])
        result.dwell = _running(result.dwell, seconds[kinds == _DWELL])
        self.per_block.add(blocks, seconds)
        self.per_tool.add(np.concatenate([t.tools for t, _ in parts]), seconds)


class _Sums:
    """Seconds per key (block or tool number), added in move order.

    The figures must be the same sums, to the last bit, as adding one move at a time, so
    each key's running total enters the chunk's `bincount` first and its moves follow in
    order (bincount adds its weights one after another, unlike `sum`'s pairwise adding).
    """

    def __init__(self) -> None:
        self.seconds = np.zeros(0, dtype=np.float64)
        self.seen = np.zeros(0, dtype=np.bool_)
        self.order: list[int] = []  # the keys in the order their first move came

    def add(self, keys: npt.NDArray[np.int64], seconds: npt.NDArray[np.float64]) -> None:
        if not len(keys):
            return
        size = max(int(keys.max()) + 1, len(self.seconds))
        if size > len(self.seconds):
            self.seconds = np.concatenate([self.seconds, np.zeros(size - len(self.seconds))])
            self.seen = np.concatenate([self.seen, np.zeros(size - len(self.seen), np.bool_)])
        order = np.concatenate([np.arange(size, dtype=np.int64), keys])
        weights = np.concatenate([self.seconds, seconds])
        self.seconds = np.bincount(order, weights=weights, minlength=size).astype(np.float64)
        present = np.bincount(keys, minlength=size) > 0
        if (present & ~self.seen).any():
            distinct, first = np.unique(keys, return_index=True)
            new = ~self.seen[distinct]
            self.order += distinct[new][np.argsort(first[new])].tolist()
            self.seen |= present

    def totals(self) -> dict[int, float]:
        """Seconds per key, in key order."""
        keys = np.flatnonzero(self.seen)
        return dict(zip(keys.tolist(), self.seconds[keys].tolist(), strict=True))

    def total(self) -> float:
        """The sum of every key's seconds, added in the order the keys first came."""
        return float(sum(self.seconds[self.order].tolist()))


def _running(total: float, seconds: npt.NDArray[np.float64]) -> float:
    """`total` plus each of `seconds` in turn (sequential, as a loop would add them)."""
    if not len(seconds):
        return total
    return float(np.cumsum(np.concatenate([[total], seconds]))[-1])


# Beyond this many nm on an axis the squares of a move's length may not fit in 64 bits.
_SQUARE_SAFE = 1 << 30


class _Clock:
    """Where the tool is between stretches of moves and which tool it is; the rates."""

    def __init__(
        self,
        start: tuple[int, int, int],
        tool: int,
        rapid_rate: int,
        max_feed: int | None,
        tool_change_seconds: float,
    ) -> None:
        self.x, self.y, self.z = start
        self.tool = tool
        self.rapid_rate = rapid_rate
        self.max_feed = max_feed
        self.tool_change_seconds = tool_change_seconds
        self.arcs: dict[tuple[int, int, int, int, bool, int], float] = {}

    def entry(self) -> tuple[int, int, int, int]:
        """Where the clock stands: x, y, z, tool."""
        return self.x, self.y, self.z, self.tool

    def enter(self, state: tuple[int, int, int, int]) -> None:
        """Stand where `entry()` said (after moves timed before)."""
        self.x, self.y, self.z, self.tool = state

    def rates(self) -> tuple[int, int | None, float]:
        """What a move's seconds depend on besides where it starts."""
        return self.rapid_rate, self.max_feed, self.tool_change_seconds

    def time(self, rows: Rows, strings: tuple[str, ...]) -> _Timed:
        """Time a batch of moves (vectorised) from where the clock stands, and move the
        clock to their end; `strings` are the texts of its STOP rows."""
        n = len(rows)
        if not n:
            return _Timed.joined([], self.entry())
        op = rows["op"]
        motion = op <= Op.ARC_CCW
        line = op <= Op.FEED
        arc = motion & ~line
        tool_rows = op == Op.TOOL
        # Where the tool is before each row: the last motion's end (Z also after a tool
        # change: the head stays, its Z reads differently with the new tool).
        moved = _previous(motion)
        x = _take(rows["x"], moved, self.x)
        y = _take(rows["y"], moved, self.y)
        z = _take(rows["z"], _previous(motion | tool_rows), self.z)
        seconds = np.zeros(n, dtype=np.float64)
        rate = np.where(op == Op.RAPID, self.rapid_rate, rows["feed"])
        if self.max_feed is not None:
            rate = np.where(op == Op.RAPID, rate, np.minimum(rate, self.max_feed))
        lines = np.flatnonzero(line)
        dx = rows["x"][lines] - x[lines]
        dy = rows["y"][lines] - y[lines]
        dz = rows["z"][lines] - z[lines]
        big = np.flatnonzero(
            (np.abs(dx) > _SQUARE_SAFE) | (np.abs(dy) > _SQUARE_SAFE) | (np.abs(dz) > _SQUARE_SAFE)
        )
        far = [(dx[big].tolist(), dy[big].tolist(), dz[big].tolist())] if len(big) else []
        for d in (dx, dy, dz):
            d[big] = 0
        # The exact integer sum of squares, rounded once to a float, then the root: what
        # math.sqrt of the Python integer gives. Longer moves take Python's integers.
        length = np.sqrt((dx * dx + dy * dy + dz * dz).astype(np.float64))
        for xs, ys, zs in far:
            length[big] = [
                math.sqrt(a * a + b * b + c * c) for a, b, c in zip(xs, ys, zs, strict=True)
            ]
        seconds[lines] = 60.0 * length / rate[lines]
        arcs = np.flatnonzero(arc)
        if len(arcs):
            seconds[arcs] = (
                _arc_lengths(rows[arcs], x[arcs], y[arcs], z[arcs], self.arcs) / rate[arcs]
            )
        dwells = op == Op.DWELL
        seconds[dwells] = rows["value"][dwells] / 1000
        seconds[tool_rows] = self.tool_change_seconds
        kinds = np.zeros(n, dtype=np.int8)
        kinds[op == Op.RAPID] = _RAPID
        kinds[(op == Op.FEED) | arc] = _CUTTING
        kinds[dwells] = _DWELL
        waits = []
        for k in np.flatnonzero((op == Op.STOP) | (op == Op.INDEX)).tolist():
            row = rows[k]
            reason = strings[row["value"]] if row["op"] == Op.STOP else INDEX_REASON
            waits.append((int(row["block"]), reason))
        # The tool each row runs with: a tool change's own time is the new tool's.
        if tool_rows.any():
            changed = np.where(tool_rows, np.arange(n), -1)
            np.maximum.accumulate(changed, out=changed)
            tools = _take(rows["value"], changed, self.tool)
        else:
            tools = np.full(n, self.tool, dtype=np.int64)
        last = np.flatnonzero(motion)
        if len(last):
            self.x, self.y = int(rows["x"][last[-1]]), int(rows["y"][last[-1]])
        moved_z = np.flatnonzero(motion | tool_rows)
        if len(moved_z):
            self.z = int(rows["z"][moved_z[-1]])
        changes = np.flatnonzero(tool_rows)
        if len(changes):
            self.tool = int(rows["value"][changes[-1]])
        return _Timed(
            seconds,
            rows["block"].astype(np.int64),
            tools,
            kinds,
            len(changes),
            waits,
            self.entry(),
        )


def _arc_lengths(
    arcs: npt.NDArray[np.void],
    x: npt.NDArray[np.int64],
    y: npt.NDArray[np.int64],
    z: npt.NDArray[np.int64],
    known: dict[tuple[int, int, int, int, bool, int], float],
) -> npt.NDArray[np.float64]:
    """60 × the length of each arc from (x, y, z): its time in seconds times its rate.

    A flat arc's length is radius × sweep; a helical one's (its Z changes by dz) is
    sqrt((radius × sweep)² + dz²), the hypotenuse of the helix unrolled.
    In Python floats, with the math module, as one arc at a time always was (numpy's hypot
    and, on some processors, its arctan2 differ in the last bit). An arc's figure depends
    only on where its ends are from its centre, and a LOOP repeats the same arcs, so each
    distinct one is worked out once (`known` keeps them between chunks).
    """
    figures = []
    for arc in zip(
        (x - arcs["cx"]).tolist(),
        (y - arcs["cy"]).tolist(),
        (arcs["x"] - arcs["cx"]).tolist(),
        (arcs["y"] - arcs["cy"]).tolist(),
        (arcs["op"] == _ARC_CW).tolist(),
        (arcs["z"] - z).tolist(),
        strict=True,
    ):
        figure = known.get(arc)
        if figure is None:
            x0, y0, x1, y1, clockwise, dz = arc
            sweep = arc_sweep((x0, y0), (x1, y1), (0, 0), clockwise)
            if dz:
                figure = 60.0 * math.hypot(math.hypot(x0, y0) * sweep, dz)
            else:
                figure = 60.0 * math.hypot(x0, y0) * sweep
            known[arc] = figure
        figures.append(figure)
    return np.array(figures, dtype=np.float64)


def _previous(sets: npt.NDArray[np.bool_]) -> npt.NDArray[np.int64]:
    """For each row, the index of the last earlier row in `sets` (-1 when none)."""
    n = len(sets)
    index = np.where(sets, np.arange(n), -1)
    np.maximum.accumulate(index, out=index)
    earlier = np.empty(n, dtype=np.int64)
    earlier[0] = -1
    earlier[1:] = index[:-1]
    return earlier


def _take(
    values: npt.NDArray[np.int64], index: npt.NDArray[np.int64], initial: int
) -> npt.NDArray[np.int64]:
    """`values` at each index; `initial` where the index is -1."""
    found = np.where(index >= 0, values[np.maximum(index, 0)], initial)
    return found.astype(np.int64)


INDEX_REASON = "index the rotary table"
_ARC_CW = int(Op.ARC_CW)


def chunk_of(toolpath: Toolpath) -> Chunk:
    """A Toolpath's move objects as one chunk of MOVE rows (what the estimate reads)."""
    strings: list[str] = []
    rows = [_row(move, strings) for move in toolpath.moves]
    array = np.array(rows, dtype=MOVE) if rows else np.zeros(0, dtype=MOVE)
    return Chunk(array, np.zeros(0, dtype=HOLE), [], tuple(strings))


def _row(move: Move, strings: list[str]) -> tuple[int, ...]:
    """One move object as a MOVE row (the inverse of path.as_move, tags left out)."""
    b = move.block
    if isinstance(move, Rapid):
        return (Op.RAPID, 0, b, move.x, move.y, move.z, 0, 0, 0, 0)
    if isinstance(move, Feed):
        return (Op.FEED, 0, b, move.x, move.y, move.z, 0, 0, move.feed, 0)
    if isinstance(move, ArcFeed):
        op = Op.ARC_CW if move.clockwise else Op.ARC_CCW
        return (op, 0, b, move.x, move.y, move.z, move.cx, move.cy, move.feed, 0)
    if isinstance(move, Dwell):
        return (Op.DWELL, 0, b, 0, 0, 0, 0, 0, 0, int(move.seconds * 1000))
    if isinstance(move, ToolChange):
        return (Op.TOOL, 0, b, 0, 0, move.z, 0, 0, 0, move.tool)
    if isinstance(move, ProgramStop):
        strings.append(move.reason)
        return (Op.STOP, 0, b, 0, 0, 0, 0, 0, 0, len(strings) - 1)
    if isinstance(move, IndexTable):
        return (Op.INDEX, 0, b, 0, 0, 0, 0, 0, 0, 0)
    # Spindle, coolant, messages, the end: no time, but their block is in the figures.
    return (Op.END, 0, b, 0, 0, 0, 0, 0, 0, 0)


def format_seconds(seconds: float) -> str:
    """`1:02:03.4` style: hours only when needed, tenths of a second."""
    tenths = round(Decimal(repr(seconds)) * 10)
    whole, tenth = divmod(int(tenths), 10)
    minutes, secs = divmod(whole, 60)
    hours, minutes = divmod(minutes, 60)
    if hours:
        return f"{hours}:{minutes:02d}:{secs:02d}.{tenth}"
    return f"{minutes}:{secs:02d}.{tenth}"


def report(result: Estimate) -> str:
    """The estimate as text: assumptions first, then per block, per tool, total."""
    lines = ["Cycle time estimate", "Assumptions:"]
    lines += [f"  - {a}" for a in result.assumptions]
    lines.append("Per block:")
    for block, seconds in result.per_block.items():
        name = "set-up" if block == 0 else f"block {block}"
        lines.append(f"  {name:<10} {format_seconds(seconds):>10}")
    lines.append("Per tool:")
    for tool, seconds in result.per_tool.items():
        name = "no tool" if tool == 0 else f"tool {tool}"
        lines.append(f"  {name:<10} {format_seconds(seconds):>10}")
    lines.append(
        f"Rapid {format_seconds(result.rapid)}, cutting {format_seconds(result.cutting)}, "
        f"dwell {format_seconds(result.dwell)}, tool changes {result.tool_changes}"
    )
    for block, reason in result.operator_waits:
        lines.append(f"Operator wait (not timed): block {block}: {reason}")
    if result.operator:
        lines.append(f"Operator time (OTIME) {format_seconds(result.operator)}")
    lines.append(f"Total {format_seconds(result.total)}")
    return "\n".join(lines) + "\n"
