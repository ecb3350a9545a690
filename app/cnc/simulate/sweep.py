"""Stock removal: every segment's tool swept over the height map, in vectorised batches.

Each cell holds one int64: (height + Z_OFFSET) << KEY_SHIFT | order, where `order` is the
segment's number in program order, so the minimum keeps the deepest cut and, for equal
depths, the earliest segment that reached it: the block that cut there. Heights are rounded
to the nanometre. Removal is a minimum, so the order in which segments are folded in does
not change the part; it matters only for a rapid that may hit material (a crash), which is
checked against the map as it is at that moment, and for the volume each tool removes.

The work, in program order, one group of placements (placements.py) at a time:

- Segments that cannot change anything are skipped first: those whose tip stays above the
  stock, lifts (the tool was already lower there), rapids plunging to where the same tool
  has already been, and identical passes at a shallower depth than another (pecks, 2P
  floors). Every rapid left is checked for a crash before it is folded in.
- **Stamps.** A piece placed several times (a LOOP's patterns) cuts the same shape at each
  placement. Where the placements are whole cells apart (the usual case: REP steps are
  multiples of the resolution), the shape is the same on the grid too: it is cut once into
  a small map of its own (the stamp, orders counted from the piece's first segment) and
  folded into the part at each placement with one `np.minimum` over a window, the
  placement's first order added to the stamp's keys. Placements a fraction of a cell apart
  sample the shape differently: they are grouped by that fraction (the phase), one stamp
  per phase. A stamp is used only where it is cheaper than sweeping every placement, and
  only for groups with no rapid to check (the order of cuts then matters).
- **Sweeping** the rest: flat tools by runs of cells per grid row, the others by exact
  (segment, cell) pairs (cells.py).

Memory: the map (8 bytes a cell), the stamps kept for reuse (at most `STAMP_CELLS` cells
in all), the segments of each distinct piece, and temporaries bounded by the batch sizes
of cells.py; the block of each segment is kept per piece, not per placement (`OrderMap`).
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from app.cnc import sizes
from app.cnc.memo import Memo
from app.cnc.simulate.cells import (
    DISC,
    RAMP,
    bounding_cells,
    categories,
    evaluate,
    flat,
    flat_spans,
    plunges,
)
from app.cnc.simulate.placements import Group, Placed
from app.cnc.simulate.segments import BOOL, F64, I32, I64, Segments
from app.cnc.simulate.stock import Grid, Stock

KEY_SHIFT = 27
ORDER_MASK = (1 << KEY_SHIFT) - 1
UNCUT = ORDER_MASK
Z_OFFSET = 1 << 35
# A stamp's cell its piece never reaches: above every real key, even with an order added.
BLANK = np.iinfo(np.int64).max - (1 << 40)
STAMP_CELLS = 1 << 23  # cells of the stamps kept for reuse, all together
PLACE_ROWS = 1 << 15  # segments swept at once when placements are swept one by one
LEDGER_ROWS = 64  # grid rows per band of the per-tool volume ledger
_NEVER = np.iinfo(np.int64).max  # a key above every cell's: changes nothing
BAND_ROWS = 64  # grid rows a stamp is placed in at a time (so that they stay in the cache)


@dataclass(frozen=True)
class Crash:
    """A rapid move through material: `depth` nm of material at (x, y), the tool's bottom
    at `z` there; `segment` is the rapid's number in program order."""

    block: int
    segment: int
    depth: float
    x: float
    y: float
    z: float


@dataclass
class OrderMap:
    """The block of each segment by its number in program order: per group, its first
    number, its piece's segment count and the blocks of the piece's segments (the same for
    every placement)."""

    starts: list[int] = field(default_factory=list)
    sizes: list[int] = field(default_factory=list)
    blocks: list[I32] = field(default_factory=list)

    def add(self, start: int, blocks: I32) -> None:
        self.starts.append(start)
        self.sizes.append(len(blocks))
        self.blocks.append(blocks)

    def blocks_of(self, orders: I64) -> I32:
        """The block of each segment number in `orders`."""
        out = np.zeros(len(orders), dtype=np.int32)
        if not self.starts or not len(orders):
            return out
        starts = np.array(self.starts, dtype=np.int64)
        group = np.searchsorted(starts, orders, "right") - 1
        for g in np.unique(group).tolist():
            here = group == g
            local = (orders[here] - starts[g]) % self.sizes[g]
            out[here] = self.blocks[g][local]
        return out


@dataclass
class Simulation:
    """The simulated part: the height map (as keys), what each tool removed, the crashes.

    `removed_by_tool` is in nm³ per tool number; `upto` is the last block simulated (None:
    all); `segments` the segments in the program, `swept` those left to sweep after
    skipping; `pairs` the cells written (runs, pairs and stamp windows) and `stamps` the
    stamps made.
    """

    grid: Grid
    keys: I64
    orders: OrderMap
    removed_by_tool: dict[int, float] = field(default_factory=dict)
    crashes: list[Crash] = field(default_factory=list)
    upto: int | None = None
    segments: int = 0
    swept: int = 0
    pairs: int = 0
    stamps: int = 0

    def heights(self) -> F64:
        """The material's top per cell, nm, (ny, nx); the stock's bottom where cut through."""
        z = (self.keys >> KEY_SHIFT).astype(np.float64) - Z_OFFSET
        return np.maximum(z, self.grid.stock.bottom).reshape(self.grid.ny, self.grid.nx)

    def owner_blocks(self) -> I32:
        """The block that cut each cell (0 where nothing did), (ny, nx)."""
        order = self.keys & ORDER_MASK
        cut = order != UNCUT
        blocks = np.zeros(self.grid.cells, dtype=np.int32)
        blocks[cut] = self.orders.blocks_of(order[cut])
        return blocks.reshape(self.grid.ny, self.grid.nx)

    def owner_at(self, i: int, j: int) -> int:
        """The block that cut cell (i, j) (0 where nothing did): `owner_blocks` for one
        cell, without working out the whole grid."""
        order = int(self.keys[i * self.grid.nx + j]) & ORDER_MASK
        if order == UNCUT:
            return 0
        return int(self.orders.blocks_of(np.array([order], dtype=np.int64))[0])

    def removed_volume(self) -> float:
        """Material removed, nm³."""
        depth = self.grid.stock.top - self.heights()
        return float(depth.sum()) * self.grid.resolution**2


def unique_rows(table: np.ndarray) -> tuple[np.ndarray, I64, I64]:
    """`np.unique(table, axis=0)` with its inverse (flat) and counts, at once for one row:
    a program of many single pieces asks this for each (0.05 ms a call in numpy's own)."""
    if len(table) == 1:
        return table, np.zeros(1, dtype=np.int64), np.ones(1, dtype=np.int64)
    kinds, inverse, counts = np.unique(table, axis=0, return_inverse=True, return_counts=True)
    return kinds, inverse.reshape(-1), counts


# What of each group is worth sweeping, by (group key, stock top, upto), for every
# simulation in the process (a group's key names its motions).
SHAPES: Memo[_Shape] = Memo()


# The most segments one merged run of single pieces holds (see `_merged`).
MERGE_ROWS = 1 << 16


def _merged(groups: list[Group], stamped: Callable[[Group], bool]) -> list[Group]:
    """The groups in order, each run of groups placed once (a program's single pieces, one
    per top-level block) joined into one group in part coordinates: the sweep then folds a
    run in as few batches as its rapids to check and its tool changes allow, not one or more
    per block. Groups placed several times (a LOOP's patterns, a bolt circle's holes), and
    those a stamp will serve (`stamped`: the same motions cut at several places), stay as
    they are. The motions and their order are the same."""
    out: list[Group] = []
    run: list[Group] = []
    rows = 0

    def close() -> None:
        if len(run) == 1:
            out.append(run[0])
        elif run:
            segments = Segments.concatenate([g.absolute() for g in run])
            key = ("merged", *((g.key, tuple(g.offsets[0].tolist())) for g in run))
            out.append(Group(segments, np.zeros((1, 2), dtype=np.int64), key))
        run.clear()

    for group in groups:
        if len(group.offsets) != 1 or group.loose or stamped(group):
            close()
            rows = 0
            out.append(group)
            continue
        if rows + len(group.segments) > MERGE_ROWS:
            close()
            rows = 0
        run.append(group)
        rows += len(group.segments)
    close()
    return out


def uncut_key(grid: Grid) -> int:
    """The key of a cell nothing has cut: the stock's top, no segment."""
    return ((grid.stock.top + Z_OFFSET) << KEY_SHIFT) | UNCUT


def simulate(
    grid: Grid, placed: Placed, upto: int | None = None, crash_tolerance: float = 0.0
) -> Simulation:
    """Cut `grid`'s stock with the placed segments (those of blocks up to `upto` when
    given). A rapid that meets more than `crash_tolerance` nm of material is a crash."""
    total = len(placed)
    if total >= UNCUT:
        raise ValueError(f"{total} segments: the simulation takes fewer than {UNCUT}")
    keys = np.full(grid.cells, uncut_key(grid), dtype=np.int64)
    result = Simulation(grid, keys, OrderMap(), upto=upto, segments=total)
    run = _Run(grid, keys, result, crash_tolerance)
    # How often each shape is placed at each phase in the whole program: what a stamp of
    # it would serve.
    for group in placed.groups:
        shape = run.shape(group)
        if shape.stampable:
            kinds, _, counts = unique_rows(run.phases(group.offsets))
            for (fx, fy), count in zip(kinds.tolist(), counts.tolist(), strict=True):
                key = (shape.digest, fx, fy)
                run.uses[key] = run.uses.get(key, 0) + count

    def stamped(group: Group) -> bool:
        shape = run.shape(group)
        if not shape.stampable:
            return False
        ((fx, fy),) = run.phases(group.offsets).tolist()
        return run.uses.get((shape.digest, fx, fy), 0) > 1

    groups = _merged(placed.groups, stamped)
    first = 0
    for group in groups:
        # The time budget (sizes.spend) is the last line of defence behind the limit on
        # Verify's work (verify.check_work): here, in every batch and every band.
        sizes.spend()
        result.orders.add(first, group.segments.block)
        run.group(group, first)
        first += group.count
    run.flush()
    run.ledger.close()
    return result


@dataclass
class _Shape:
    """What of a group's segments is worth sweeping (`useful`, indices into them), named
    by `digest` (equal digests, equal segments at equal indices); `stampable` when they
    have no rapid to check and one tool."""

    useful: I64
    digest: bytes
    stampable: bool


@dataclass
class _Pending:
    """Placements of a stamp not yet folded into the part: their first segment numbers and
    shifts (lattice cells)."""

    stamp: _Stamp
    firsts: I64
    mx: I64
    my: I64


class _Run:
    """One simulation's state while groups are folded in."""

    def __init__(self, grid: Grid, keys: I64, result: Simulation, tolerance: float) -> None:
        self.grid = grid
        self.keys = keys
        self.result = result
        self.tolerance = tolerance
        self.ledger = _Ledger(grid, keys, result.removed_by_tool)
        self.shapes: dict[tuple[object, ...], _Shape] = {}
        self.stamps: OrderedDict[tuple[object, ...], _Stamp | None] = OrderedDict()
        self.uses: dict[tuple[object, ...], int] = {}
        # Stamp placements wait here until something needs the part as it is (a crash
        # check, another tool's volume, the end), then go in together, band by band.
        self.pending: list[_Pending] = []
        self.scratch = np.zeros(0, dtype=np.int64)

    def shape(self, group: Group) -> _Shape:
        found = self.shapes.get(group.key)
        if found is None:
            # Kept between simulations too (Verify after an edit): a group's key names its
            # motions, and what of them is useful depends only on the stock's top and upto.
            key = (group.key, self.grid.stock.top, self.result.upto)
            found = SHAPES.get(key)
            if found is None:
                s = group.segments
                useful = _useful(self.grid, s, self.result.upto)
                tools = s.tool[useful]
                stampable = bool(len(useful)) and not s.rapid[useful].any()
                stampable = stampable and bool((tools == tools[0]).all())
                found = _Shape(useful, _digest(s, useful), stampable)
                SHAPES.keep(key, found, len(s) + 1)
            self.shapes[group.key] = found
        return found

    def phases(self, offsets: I64) -> I64:
        """Per placement (k × 2): where the grid's cell centres fall on the placed piece,
        as the fraction of a cell (nm) its lattice starts at; equal phases, equal
        sampling."""
        res = round(self.grid.resolution)
        stock = self.grid.stock
        return np.stack([(stock.x0 - offsets[:, 0]) % res, (stock.y0 - offsets[:, 1]) % res], 1)

    def use(self, tool: int) -> None:
        """The segments folded in next are `tool`'s."""
        if tool != self.ledger.tool:
            self.flush()
            self.ledger.use(tool)

    def group(self, group: Group, first: int) -> None:
        shape = self.shape(group)
        useful = shape.useful
        if not len(useful):
            return
        s = group.segments
        k = len(group.offsets)
        n = len(s)
        if shape.stampable:
            self.use(int(s.tool[useful[0]]))
            self._stamped(group, shape, first)
            return
        # One placement after another, a crash check before each rapid, each change of
        # tool told to the volume ledger.
        tools = s.tool[useful]
        checks = s.rapid[useful]
        edge = np.flatnonzero(checks[1:] | checks[:-1] | (tools[1:] != tools[:-1])) + 1
        stages = np.split(np.arange(len(useful)), edge)
        if len(stages) == 1:
            self.use(int(tools[0]))
            everywhere = np.arange(k, dtype=np.int64)
            self._sweep_placements(s.select(useful), useful, group.offsets, everywhere, first, n)
            return
        for p, (ox, oy) in enumerate(group.offsets.tolist()):
            placed = s.translated(ox, oy)
            for stage in stages:
                rows = useful[stage]
                self.use(int(s.tool[rows[0]]))
                orders = first + p * n + rows
                if s.rapid[rows[0]]:
                    self.flush()
                    self._check(placed.select(rows[:1]), int(orders[0]))
                self._sweep(placed.select(rows), orders)

    # -- sweeping --------------------------------------------------------------------------

    def _sweep_placements(
        self, s: Segments, local: I64, offsets: I64, index: I64, first: int, n: int
    ) -> None:
        """Segments `s` (numbered `local` in their piece of `n`) at each of `offsets`, the
        placements `index` of a group numbered from `first`, swept in batches."""
        per = max(1, PLACE_ROWS // max(1, len(s)))
        for a in range(0, len(offsets), per):
            part = slice(a, a + per)
            orders = (first + index[part, None] * n + local).reshape(-1)
            self._sweep(s.tiled(offsets[part]), orders)

    def _sweep(self, s: Segments, orders: I64) -> None:
        """Fold segments `s` (numbered `orders`) into the map."""
        sizes.spend()
        rows = _collapse(s)
        s, orders = s.select(rows), orders[rows]
        i0, i1, j0, j1 = bounding_cells(self.grid, s)
        live = (i1 > i0) & (j1 > j0)
        if not live.any():
            return
        self.ledger.touch(int(i0[live].min()), int(i1[live].max()))
        self.result.swept += len(s)
        self.result.pairs += fold(self.grid, self.keys, s, orders)

    def _stamped(self, group: Group, shape: _Shape, first: int) -> None:
        """A group without rapids to check, of one tool: by stamps where they pay."""
        grid = self.grid
        useful = shape.useful
        s = group.segments.select(useful)
        res = round(grid.resolution)
        offsets = group.offsets
        n = len(group.segments)
        kinds, which, _ = unique_rows(self.phases(offsets))
        # Placements whose phase has no stamp are swept together, not a phase at a time (a
        # bolt circle's holes each fall at a phase of their own).
        swept: list[I64] = []
        for k, (fx, fy) in enumerate(kinds.tolist()):
            members = np.flatnonzero(which == k)
            stamp = self._stamp(shape, s, fx, fy)
            if stamp is None:
                swept.append(members)
                continue
            mx = (grid.stock.x0 - offsets[members, 0] - fx) // res
            my = (grid.stock.y0 - offsets[members, 1] - fy) // res
            self.pending.append(_Pending(stamp, first + members * n, mx, my))
            if sum(p.stamp.keys.size for p in self.pending) > STAMP_CELLS:
                self.flush()
        if swept:
            members = np.sort(np.concatenate(swept))
            self._sweep_placements(s, useful, offsets[members], members, first, n)

    def _stamp(self, shape: _Shape, s: Segments, fx: int, fy: int) -> _Stamp | None:
        """The stamp of `s` (a group's useful segments, piece coordinates) for placements
        of phase (fx, fy); None where sweeping each placement is cheaper."""
        key = (shape.digest, fx, fy)
        if key in self.stamps:
            self.stamps.move_to_end(key)
            return self.stamps[key]
        uses = self.uses.get(key, 1)
        stamp = _Stamp.make(self.grid, s, shape.useful, fx, fy, uses) if uses > 1 else None
        if stamp is not None:
            self.result.stamps += 1
            self.result.swept += stamp.swept
            self.result.pairs += stamp.pairs
        self.stamps[key] = stamp
        while sum(v.keys.size for v in self.stamps.values() if v) > STAMP_CELLS:
            self.stamps.popitem(last=False)
        return stamp

    def flush(self) -> None:
        """Fold the waiting stamp placements into the part."""
        if self.pending:
            self.result.pairs += _place(self, self.pending)
            self.pending = []

    def _check(self, rapid: Segments, order: int) -> None:
        crash = check_rapid(self.grid, self.keys, rapid, self.tolerance)
        if crash is not None:
            self.result.crashes.append(
                Crash(int(rapid.block[0]), order, crash[0], crash[1], crash[2], crash[3])
            )


def _digest(s: Segments, useful: I64) -> bytes:
    """A name for segments `useful` of `s` (equal names, equal segments at equal
    indices)."""
    sub = s.select(useful)
    h = hashlib.blake2b(useful.tobytes(), digest_size=16)
    for name in Segments.__dataclass_fields__:
        h.update(np.ascontiguousarray(getattr(sub, name)).tobytes())
    return h.digest()


@dataclass
class _Stamp:
    """A piece's cut on a map of its own: `keys` (rows × columns, BLANK where it does not
    reach) over lattice cells from (`row`, `col`) on — lattice cell L of a placement whose
    shift is m is the part's cell L − m. `swept` and `pairs` are what making it took."""

    keys: I64
    row: int
    col: int
    swept: int
    pairs: int

    @staticmethod
    def make(grid: Grid, s: Segments, local: I64, fx: int, fy: int, count: int) -> _Stamp | None:
        """The stamp of segments `s` (numbered `local`) on the lattice of phase (fx, fy),
        or None when sweeping its `count` placements directly costs less."""
        res = round(grid.resolution)
        reach = s.radius + np.where(s.arc, np.hypot(s.x0 - s.cx, s.y0 - s.cy), 0.0)
        xs = np.concatenate([s.x0, s.x1, np.where(s.arc, s.cx, s.x0)])
        ys = np.concatenate([s.y0, s.y1, np.where(s.arc, s.cy, s.y0)])
        far = np.concatenate([s.radius, s.radius, reach])
        col = int(np.floor((float((xs - far).min()) - fx) / res)) - 1
        row = int(np.floor((float((ys - far).min()) - fy) / res)) - 1
        nx = int(np.ceil((float((xs + far).max()) - fx) / res)) + 1 - col
        ny = int(np.ceil((float((ys + far).max()) - fy) / res)) + 1 - row
        lattice = _lattice(grid, fx + col * res, fy + row * res, nx, ny)
        i0, i1, j0, j1 = bounding_cells(lattice, s)
        pairs = int(((i1 - i0) * (j1 - j0)).sum())
        # Sweeping costs every placement its pairs; a stamp, its pairs once and a window
        # per placement.
        if nx * ny > grid.cells or nx * ny * count + pairs >= pairs * count:
            return None
        keys = np.full(lattice.cells, BLANK, dtype=np.int64)
        rows = _collapse(s)
        made = fold(lattice, keys, s.select(rows), local[rows])
        plane = keys.reshape(ny, nx)
        cut = plane != BLANK
        used_rows = np.flatnonzero(cut.any(axis=1))
        used_cols = np.flatnonzero(cut.any(axis=0))
        if not len(used_rows):
            return _Stamp(np.zeros((0, 0), dtype=np.int64), row, col, len(rows), made)
        r0, r1 = int(used_rows[0]), int(used_rows[-1]) + 1
        c0, c1 = int(used_cols[0]), int(used_cols[-1]) + 1
        cropped = np.ascontiguousarray(plane[r0:r1, c0:c1])
        return _Stamp(cropped, row + r0, col + c0, len(rows), made)


def _place(run: _Run, pending: list[_Pending]) -> int:
    """Fold stamp placements into the part; the cells written. The part is visited in
    bands of rows, each band taking every placement that reaches it while it is in the
    cache (the minimum does not care about the order)."""
    grid = run.grid
    stamps = [p.stamp for p in pending for _ in range(len(p.firsts))]
    firsts = np.concatenate([p.firsts for p in pending])
    heights = np.array([s.keys.shape[0] for s in stamps], dtype=np.int64)
    widths = np.array([s.keys.shape[1] for s in stamps], dtype=np.int64)
    tops = np.array([s.row for s in stamps], dtype=np.int64) - np.concatenate(
        [p.my for p in pending]
    )
    lefts = np.array([s.col for s in stamps], dtype=np.int64) - np.concatenate(
        [p.mx for p in pending]
    )
    r0, r1 = np.maximum(tops, 0), np.minimum(tops + heights, grid.ny)
    c0, c1 = np.maximum(lefts, 0), np.minimum(lefts + widths, grid.nx)
    live = np.flatnonzero((r0 < r1) & (c0 < c1))
    if not len(live):
        return 0
    low, high = int(r0[live].min()), int(r1[live].max())
    run.ledger.touch(low, high)
    width = int(widths[live].max())
    if len(run.scratch) < BAND_ROWS * width:
        run.scratch = np.empty(BAND_ROWS * width, dtype=np.int64)
    part = run.keys.reshape(grid.ny, grid.nx)
    made = 0
    for band in range(low, high, BAND_ROWS):
        sizes.spend()
        end = band + BAND_ROWS
        here = live[(r0[live] < end) & (r1[live] > band)]
        for p in here.tolist():
            a, b = max(int(r0[p]), band), min(int(r1[p]), end)
            c, d = int(c0[p]), int(c1[p])
            top, left = int(tops[p]), int(lefts[p])
            piece = stamps[p].keys[a - top : b - top, c - left : d - left]
            # The stamp's keys numbered for this placement (in a buffer kept between
            # calls), then the minimum with the part.
            numbered = run.scratch[: piece.size].reshape(piece.shape)
            np.add(piece, int(firsts[p]), out=numbered)
            window = part[a:b, c:d]
            np.minimum(window, numbered, out=window)
            made += piece.size
    return made


def _lattice(grid: Grid, x0: int, y0: int, nx: int, ny: int) -> Grid:
    """A grid of `grid`'s cell size whose first cell's corner is (x0, y0) (nm)."""
    res = round(grid.resolution)
    stock = grid.stock
    box = Stock(
        x0, y0, x0 + nx * res, y0 + ny * res, stock.bottom, stock.top, stock.given, stock.clear
    )
    return Grid(box, grid.resolution, nx, ny)


# -- folding segments into a map -------------------------------------------------------------


def fold(grid: Grid, keys: I64, s: Segments, orders: I64) -> int:
    """Fold segments `s` (numbered `orders`) into `keys`, a map over `grid`: flat tools by
    runs of cells, the others by pairs. The cells written."""
    made = 0
    level = flat(s)
    if level.any():
        rows = np.flatnonzero(level)
        sub = s.select(rows)
        low = np.rint(np.minimum(sub.z0, sub.z1)).astype(np.int64)
        key = ((low + Z_OFFSET) << KEY_SHIFT) | orders[rows]
        for spans in flat_spans(grid, sub):
            for part in spans.parts():
                cells = part.cells(grid.nx)
                np.minimum.at(keys, cells, np.repeat(key[part.seg], part.hi - part.lo))
                made += len(cells)
    cone = ~level & (categories(s) == DISC)
    if cone.any():
        # Drill points going down: the key of the tip, raised by the cone per cell.
        rows = np.flatnonzero(cone)
        sub = s.select(rows)
        tip = np.rint(np.minimum(sub.z0, sub.z1)).astype(np.int64)
        base = ((tip + Z_OFFSET) << KEY_SHIFT) | orders[rows]
        for block in plunges(grid, sub):
            key = (block.rise << KEY_SHIFT) + base[block.seg][:, None, None]
            key[block.rise < 0] = _NEVER
            np.minimum.at(keys, block.cells.reshape(-1), key.reshape(-1))
            made += key.size
    rest = ~level & ~cone
    if rest.any():
        rows = np.flatnonzero(rest)
        for cells, value, seg in evaluate(grid, s.select(rows)):
            depth = np.rint(value).astype(np.int64)
            np.minimum.at(keys, cells, ((depth + Z_OFFSET) << KEY_SHIFT) | orders[rows[seg]])
            made += len(cells)
    return made


# -- which segments matter ------------------------------------------------------------------


def _useful(grid: Grid, s: Segments, upto: int | None) -> I64:
    """Indices of the segments that may remove material or hit it, in program order;
    rapids among them are the ones to check for a crash."""
    keep = np.minimum(s.z0, s.z1) < grid.stock.top
    if upto is not None:
        keep &= s.block <= upto
    cat = categories(s)
    keep &= ~((cat == DISC) & (s.z1 > s.z0))
    # A rapid plunge to where the same tool has been at this XY before clears nothing new.
    disc = np.flatnonzero(keep & (cat == DISC))
    if len(disc):
        keep[disc[_been_there(s, disc)]] = False
    return np.flatnonzero(keep)


def _been_there(s: Segments, disc: I64) -> BOOL:
    """For plunges `disc` (program order), True for the rapids whose end is no lower than
    an earlier plunge of the same tool at the same XY reached."""
    table = np.stack([s.x1[disc], s.y1[disc], s.radius[disc], s.slope[disc]], axis=1)
    _, group, _ = unique_rows(table)
    order = np.lexsort((np.arange(len(disc)), group))
    z = s.z1[disc][order]
    g = group[order]
    # Running minimum within each group: offset groups so earlier groups never win.
    span = float(np.ptp(z)) + 1.0 if len(z) else 1.0
    shifted = z - g * span * 4
    running = np.minimum.accumulate(shifted) + g * span * 4
    before = np.full(len(z), np.inf)
    same = g[1:] == g[:-1]
    before[1:][same] = running[:-1][same]
    seen = np.zeros(len(disc), dtype=np.bool_)
    seen[order] = (before <= z) & s.rapid[disc][order]
    return seen


def _collapse(s: Segments) -> I64:
    """Indices of `s` without the passes that repeat another's XY path higher up (pecks,
    2P floors): the deepest of identical level passes removes all the others do."""
    if len(s) < 2:
        return np.arange(len(s))
    cat = categories(s)
    level = np.flatnonzero(cat != RAMP)
    if len(level) < 2:
        return np.arange(len(s))
    table = np.stack(
        [
            *(s.x0[level], s.y0[level], s.x1[level], s.y1[level], s.cx[level], s.cy[level]),
            *(s.ccw[level].astype(np.float64), s.radius[level], s.slope[level]),
        ],
        axis=1,
    )
    # A plunge is a point: its start height does not matter, only how deep it goes.
    plunge = cat[level] == DISC
    table[plunge, 0:2] = table[plunge, 2:4]
    _, group, _ = unique_rows(table)
    depth = np.minimum(s.z0[level], s.z1[level])
    order = np.lexsort((level, depth, group))
    first = np.ones(len(order), dtype=np.bool_)
    first[1:] = group[order][1:] != group[order][:-1]
    kept = np.zeros(len(s), dtype=np.bool_)
    kept[cat == RAMP] = True
    kept[level[order[first]]] = True
    return np.flatnonzero(kept)


# -- what each tool removed ------------------------------------------------------------------


class _Ledger:
    """The volume each tool removes: the material in the bands of rows a tool run touches,
    measured when it first touches them and again when the run ends."""

    def __init__(self, grid: Grid, keys: I64, removed: dict[int, float]) -> None:
        self.grid = grid
        self.keys = keys
        self.removed = removed
        self.tool: int | None = None
        self.counted = np.zeros(-(-grid.ny // LEDGER_ROWS), dtype=np.bool_)
        self.before = 0.0

    def use(self, tool: int) -> None:
        """The segments folded in next are `tool`'s."""
        if tool != self.tool:
            self.close()
            self.tool = tool

    def touch(self, i0: int, i1: int) -> None:
        """Rows i0 … i1 are about to be cut (by the tool in use)."""
        if self.tool is not None:
            self.removed.setdefault(self.tool, 0.0)
        b0, b1 = i0 // LEDGER_ROWS, -(-i1 // LEDGER_ROWS)
        fresh = np.flatnonzero(~self.counted[b0:b1]) + b0
        for band in fresh.tolist():
            self.before += self._band(band)
        self.counted[fresh] = True

    def close(self) -> None:
        """The current tool's run has ended: add what it removed."""
        if self.tool is None or not self.counted.any():
            return
        after = sum(self._band(b) for b in np.flatnonzero(self.counted).tolist())
        self.removed[self.tool] += self.before - after
        self.counted[:] = False
        self.before = 0.0

    def _band(self, band: int) -> float:
        nx = self.grid.nx
        lo = band * LEDGER_ROWS * nx
        return volume(self.grid, self.keys[lo : lo + LEDGER_ROWS * nx])


def volume(grid: Grid, keys: I64) -> float:
    """Material in the cells of `keys`, nm³ above the stock's bottom."""
    z = (keys >> KEY_SHIFT) - Z_OFFSET
    material = np.maximum(z, grid.stock.bottom) - grid.stock.bottom
    return float(material.sum()) * grid.resolution**2


# -- crashes ---------------------------------------------------------------------------------


def check_rapid(
    grid: Grid, keys: I64, rapid: Segments, tolerance: float
) -> tuple[float, float, float, float] | None:
    """(depth, x, y, z): the deepest material the one rapid move `rapid` meets, where, and
    its tool's bottom there, if more than `tolerance` nm."""
    # The deepest to the nanometre; of cells equally deep, the first (lowest row, column).
    worst: tuple[float, int, float] | None = None
    bottom = grid.stock.bottom
    for cells, value, _ in evaluate(grid, rapid):
        top = ((keys[cells] >> KEY_SHIFT) - Z_OFFSET).astype(np.float64)
        depth = np.rint(top - np.maximum(value, bottom))
        depth[top <= bottom] = 0.0
        if not len(depth) or depth.max() <= tolerance:
            continue
        deepest = depth == depth.max()
        k = int(np.flatnonzero(deepest)[np.argmin(cells[deepest])])
        candidate = (float(depth[k]), int(cells[k]), float(value[k]))
        if worst is None or (candidate[0], -candidate[1]) > (worst[0], -worst[1]):
            worst = candidate
    if worst is None:
        return None
    amount, cell, z = worst
    i, j = divmod(cell, grid.nx)
    res = grid.resolution
    return amount, grid.x0 + (j + 0.5) * res, grid.y0 + (i + 0.5) * res, z
