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
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from decimal import Decimal

import numpy as np
import numpy.typing as npt

from app.cnc.geometry import arc_sweep
from app.cnc.limits import RAPID_IPM
from app.cnc.machine import MachineModel
from app.cnc.path import HOLE, MOVE, Chunk, CompiledPath, Op, Rows, row_batches
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

DEFAULT_TOOL_CHANGE_SECONDS = 30.0
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
    chunks = path.chunks() if isinstance(path, CompiledPath) else [chunk_of(path)]
    for rows, strings in row_batches(chunks):
        clock.add(rows, strings, result)
    result.per_block = clock.per_block.totals()
    result.per_tool = clock.per_tool.totals()
    result.operator = operator
    # Added in the order the blocks first came, as the figures always were.
    result.total = clock.per_block.total() + operator
    return result


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
    """The estimate's state between chunks: where the tool is, which tool, the sums."""

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
        self.per_block = _Sums()
        self.per_tool = _Sums()
        self.arcs: dict[tuple[int, int, int, int, bool], float] = {}

    def add(self, rows: Rows, strings: tuple[str, ...], result: Estimate) -> None:
        """Time a batch of moves (vectorised) and add them to `result` and the sums;
        `strings` are the texts of its STOP rows."""
        n = len(rows)
        if not n:
            return
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
            seconds[arcs] = _arc_lengths(rows[arcs], x[arcs], y[arcs], self.arcs) / rate[arcs]
        dwells = op == Op.DWELL
        seconds[dwells] = rows["value"][dwells] / 1000
        seconds[tool_rows] = self.tool_change_seconds
        result.rapid = _running(result.rapid, seconds[op == Op.RAPID])
        result.cutting = _running(result.cutting, seconds[(op == Op.FEED) | arc])
        result.dwell = _running(result.dwell, seconds[dwells])
        result.tool_changes += int(np.count_nonzero(tool_rows))
        waits = np.flatnonzero((op == Op.STOP) | (op == Op.INDEX))
        for k in waits.tolist():
            row = rows[k]
            reason = strings[row["value"]] if row["op"] == Op.STOP else INDEX_REASON
            result.operator_waits.append((int(row["block"]), reason))
        # The tool each row runs with: a tool change's own time is the new tool's.
        if tool_rows.any():
            changed = np.where(tool_rows, np.arange(n), -1)
            np.maximum.accumulate(changed, out=changed)
            tools = _take(rows["value"], changed, self.tool)
        else:
            tools = np.full(n, self.tool, dtype=np.int64)
        self.per_block.add(rows["block"].astype(np.int64), seconds)
        self.per_tool.add(tools, seconds)
        last = np.flatnonzero(motion)
        if len(last):
            self.x, self.y = int(rows["x"][last[-1]]), int(rows["y"][last[-1]])
        moved_z = np.flatnonzero(motion | tool_rows)
        if len(moved_z):
            self.z = int(rows["z"][moved_z[-1]])
        changes = np.flatnonzero(tool_rows)
        if len(changes):
            self.tool = int(rows["value"][changes[-1]])


def _arc_lengths(
    arcs: npt.NDArray[np.void],
    x: npt.NDArray[np.int64],
    y: npt.NDArray[np.int64],
    known: dict[tuple[int, int, int, int, bool], float],
) -> npt.NDArray[np.float64]:
    """60 × radius × sweep of each arc from (x, y): its time in seconds times its rate.

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
        strict=True,
    ):
        figure = known.get(arc)
        if figure is None:
            x0, y0, x1, y1, clockwise = arc
            sweep = arc_sweep((x0, y0), (x1, y1), (0, 0), clockwise)
            figure = known[arc] = 60.0 * math.hypot(x0, y0) * sweep
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
