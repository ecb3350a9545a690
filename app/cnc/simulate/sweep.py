"""Stock removal: sweep every segment's tool over the height map, in vectorised batches.

Exact at the cell centres, for every segment this package produces:

- A straight move of a flat end mill removes, at a point q, everything above the lowest
  tip height z(t) over the t where the tool's axis is within its radius of q. z is linear
  in t, and those t are one interval [t_lo, t_hi] (where the line is within R of q), so the
  lowest is at one of its ends.
- A drill point adds slope·d (d: distance from the axis), so the bottom over q along the
  move is f(t) = z0 + t·dz + slope·√(c·(t − tc)² + e²), a convex function of t: its least
  value on [t_lo, t_hi] is at an end or at the stationary point clipped into it.
- An arc piece (at most 90°, constant Z) is at distance |ρ − r| from q where q's angle is
  inside the sector, else at the nearer end point.

Each segment is evaluated over the cells of its bounding box; segments are grouped into
batches of about `BATCH_PAIRS` (segment, cell) pairs so numpy, not Python, does the work per
pair, and one `np.minimum.at` folds a batch into the map. Removal is a minimum, so the order
of segments does not change the final part; it matters only for a rapid that may hit
material (a crash), which is checked against the map as it is at that moment, and for the
volume each tool removes. Segments that cannot change anything are skipped first: those
whose tip stays above the stock, upward plunges (the tool was already lower there), rapids
down to where the same tool has already been, and identical passes at a shallower depth
than another one (pecks). Milling moves are then folded in deepest first, and a move is
skipped when the highest material left in every tile of cells under its box is no higher
than its tip (overlapping pocket passes, a pocket cut again): the order changes nothing but
the work, since the result is a minimum.

Per (segment, cell) pair the work is a few float32 operations on coordinates relative to
the segment (small numbers: float32 keeps them to a few nanometres), with each segment's
values repeated over its pairs rather than gathered; plunges of one tool share a footprint
and are computed as blocks of row and column terms.

Each cell holds one int64: (height + Z_OFFSET) << KEY_SHIFT | segment, so the minimum keeps
the deepest cut and, for equal depths, the earliest segment that reached it: the block that
cut there. Heights are rounded to the nanometre.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import TypeVar

import numpy as np
import numpy.typing as npt

from app.cnc.simulate.segments import BOOL, F64, I32, I64, Segments
from app.cnc.simulate.stock import Grid

KEY_SHIFT = 27
ORDER_MASK = (1 << KEY_SHIFT) - 1
UNCUT = ORDER_MASK
Z_OFFSET = 1 << 35
BATCH_PAIRS = 1 << 19
TILE = 16  # cells along a side of the tiles that skip moves over cleared material
CULL_AFTER = 64  # milling moves in a stage before skipping is worth its bookkeeping

_T = TypeVar("_T", bound=np.generic)
_NEVER = np.iinfo(np.int64).max  # a key larger than any cell's: changes nothing
DISC, LINE, RAMP, ARC = 0, 1, 2, 3


@dataclass(frozen=True)
class Crash:
    """A rapid move through material: `depth` nm of material at (x, y), the tool's bottom
    at `z` there."""

    block: int
    segment: int
    depth: float
    x: float
    y: float
    z: float


@dataclass
class Simulation:
    """The simulated part: the height map (as keys), what each tool removed, the crashes.

    `removed_by_tool` is in nm³ per tool number, in program order of first use; `upto` is
    the last block simulated (None: all); `pairs` the (segment, cell) pairs evaluated.
    """

    grid: Grid
    keys: I64
    segments: Segments
    removed_by_tool: dict[int, float] = field(default_factory=dict)
    crashes: list[Crash] = field(default_factory=list)
    upto: int | None = None
    pairs: int = 0

    def heights(self) -> F64:
        """The material's top per cell, nm, (ny, nx); the stock's bottom where cut through."""
        z = (self.keys >> KEY_SHIFT).astype(np.float64) - Z_OFFSET
        return np.maximum(z, self.grid.stock.bottom).reshape(self.grid.ny, self.grid.nx)

    def owner_blocks(self) -> I32:
        """The block that cut each cell (0 where nothing did), (ny, nx)."""
        order = self.keys & ORDER_MASK
        cut = order != UNCUT
        blocks = np.zeros(self.grid.cells, dtype=np.int32)
        blocks[cut] = self.segments.block[order[cut]]
        return blocks.reshape(self.grid.ny, self.grid.nx)

    def removed_volume(self) -> float:
        """Material removed, nm³."""
        stock = self.grid.stock
        depth = stock.top - self.heights()
        return float(depth.sum()) * self.grid.resolution**2


def simulate(
    grid: Grid, segments: Segments, upto: int | None = None, crash_tolerance: float = 0.0
) -> Simulation:
    """Cut `grid`'s stock with `segments` (those of blocks up to `upto` when given).

    A rapid that meets more than `crash_tolerance` nm of material is a crash.
    """
    if len(segments) >= UNCUT:
        raise ValueError(f"{len(segments)} segments: the simulation takes fewer than {UNCUT}")
    stock = grid.stock
    keys = np.full(grid.cells, ((stock.top + Z_OFFSET) << KEY_SHIFT) | UNCUT, dtype=np.int64)
    result = Simulation(grid, keys, segments, upto=upto)
    rows = _useful(grid, segments, upto)
    checks = segments.rapid[rows]
    tools = segments.tool[rows]
    # Stages: runs of one tool, each rapid that needs checking on its own.
    edge = np.flatnonzero(checks[1:] | checks[:-1] | (tools[1:] != tools[:-1])) + 1
    starts = np.concatenate([[0], edge]) if len(rows) else np.zeros(0, dtype=np.int64)
    ends = np.concatenate([edge, [len(rows)]]) if len(rows) else np.zeros(0, dtype=np.int64)
    for a, b in zip(starts.tolist(), ends.tolist(), strict=True):
        stage = rows[a:b]
        if checks[a]:
            crash = _check_rapid(grid, keys, segments, int(stage[0]), crash_tolerance)
            if crash is not None:
                result.crashes.append(crash)
        tool = int(tools[a])
        removed, pairs = _apply(grid, keys, segments, _collapse(segments, stage))
        result.pairs += pairs
        result.removed_by_tool[tool] = result.removed_by_tool.get(tool, 0.0) + removed
    return result


# -- which segments matter ------------------------------------------------------------------


def categories(segments: Segments, rows: I64 | None = None) -> npt.NDArray[np.int8]:
    """DISC (a plunge or lift: no XY motion), LINE (flat end, constant Z), RAMP (any
    other straight move) or ARC, per segment (of `rows`, when given)."""
    s = segments

    def pick(a: npt.NDArray[_T]) -> npt.NDArray[_T]:
        return a if rows is None else a[rows]

    arc = pick(s.arc)
    still = (pick(s.x0) == pick(s.x1)) & (pick(s.y0) == pick(s.y1)) & ~arc
    level = (pick(s.z0) == pick(s.z1)) & (pick(s.slope) == 0)
    cat = np.full(len(arc), RAMP, dtype=np.int8)
    cat[level] = LINE
    cat[still] = DISC
    cat[arc] = ARC
    return cat


def _useful(grid: Grid, segments: Segments, upto: int | None) -> I64:
    """Indices of the segments that may remove material or hit it, in program order;
    rapids among them are the ones to check for a crash."""
    s = segments
    keep = np.minimum(s.z0, s.z1) < grid.stock.top
    if upto is not None:
        keep &= s.block <= upto
    i0, i1, j0, j1 = bounding_cells(grid, s)
    keep &= (i1 > i0) & (j1 > j0)
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
    _, group = np.unique(table, axis=0, return_inverse=True)
    group = group.reshape(-1)
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


def _collapse(s: Segments, stage: I64) -> I64:
    """`stage` without passes that repeat another's XY path higher up (pecks, 2P floors):
    the deepest of identical level passes removes all the others do."""
    if len(stage) < 2:
        return stage
    cat = categories(s, stage)
    level = np.flatnonzero(cat != RAMP)
    if len(level) < 2:
        return stage
    rows = stage[level]
    table = np.stack(
        [
            *(s.x0[rows], s.y0[rows], s.x1[rows], s.y1[rows], s.cx[rows], s.cy[rows]),
            *(s.ccw[rows].astype(np.float64), s.radius[rows], s.slope[rows]),
        ],
        axis=1,
    )
    # A plunge is a point: its start height does not matter, only how deep it goes.
    plunge = cat[level] == DISC
    table[plunge, 0:2] = table[plunge, 2:4]
    _, group = np.unique(table, axis=0, return_inverse=True)
    group = group.reshape(-1)
    depth = np.minimum(s.z0[rows], s.z1[rows])
    order = np.lexsort((rows, depth, group))
    first = np.ones(len(order), dtype=np.bool_)
    first[1:] = group[order][1:] != group[order][:-1]
    kept = np.zeros(len(stage), dtype=np.bool_)
    kept[cat == RAMP] = True
    kept[level[order[first]]] = True
    return stage[kept]


# -- bounding boxes and (segment, cell) pairs -------------------------------------------------


def bounding_cells(grid: Grid, s: Segments) -> tuple[I64, I64, I64, I64]:
    """Per segment, the rows i0…i1 and columns j0…j1 (end exclusive) of the cells whose
    centres its tool can reach, clipped to the grid."""
    r = s.radius
    xmin, xmax = np.minimum(s.x0, s.x1), np.maximum(s.x0, s.x1)
    ymin, ymax = np.minimum(s.y0, s.y1), np.maximum(s.y0, s.y1)
    if s.arc.any():
        # An arc piece of at most 90° lies in the triangle of its ends and the meeting
        # point of its end tangents.
        a = s.arc
        ux, uy = s.x0[a] - s.cx[a], s.y0[a] - s.cy[a]
        vx, vy = s.x1[a] - s.cx[a], s.y1[a] - s.cy[a]
        mx, my = ux + vx, uy + vy
        norm = np.hypot(mx, my)
        ra = np.hypot(ux, uy)
        cos_half = np.where(norm > 0, norm / (2 * np.maximum(ra, 1e-9)), 1.0)
        scale = np.where(norm > 0, ra / np.maximum(cos_half, 1e-9) / np.maximum(norm, 1e-9), 0)
        tx, ty = s.cx[a] + mx * scale, s.cy[a] + my * scale
        xmin[a], xmax[a] = np.minimum(xmin[a], tx), np.maximum(xmax[a], tx)
        ymin[a], ymax[a] = np.minimum(ymin[a], ty), np.maximum(ymax[a], ty)
    res = grid.resolution
    j0 = np.ceil((xmin - r - grid.x0) / res - 0.5)
    j1 = np.floor((xmax + r - grid.x0) / res - 0.5) + 1
    i0 = np.ceil((ymin - r - grid.y0) / res - 0.5)
    i1 = np.floor((ymax + r - grid.y0) / res - 0.5) + 1
    return (
        np.clip(i0, 0, grid.ny).astype(np.int64),
        np.clip(i1, 0, grid.ny).astype(np.int64),
        np.clip(j0, 0, grid.nx).astype(np.int64),
        np.clip(j1, 0, grid.nx).astype(np.int64),
    )


@dataclass
class _Batch:
    """(segment, cell) pairs: the cells, and per pair the segment (an index into the rows
    evaluated) and the cell centre relative to the segment's reference point (its start, or
    an arc's centre), in float32 nm: small numbers, so float32 keeps them to a few nm.
    `count` is how many consecutive pairs each chunk has and `chunk` its segment, so
    per-segment values reach the pairs by `np.repeat` instead of a gather per pair."""

    cells: I64
    seg: I64
    wx: npt.NDArray[np.float32]
    wy: npt.NDArray[np.float32]
    chunk: I64
    count: I64

    def per_pair(self, values: npt.NDArray[_T]) -> npt.NDArray[_T]:
        """A value per chunk's segment (indexed like `chunk`), repeated for its pairs."""
        return np.repeat(values[self.chunk], self.count)


def _batches(grid: Grid, s: Segments, rows: I64, rx: F64, ry: F64) -> Iterator[_Batch]:
    """Pairs (segment, cell) over the bounding boxes of segments `rows`, in batches of about
    BATCH_PAIRS; a box larger than that is cut into bands of rows. `seg` indexes `rows`;
    (rx, ry) is each row's reference point."""
    i0, i1, j0, j1 = bounding_cells(grid, s.select(rows))
    width = j1 - j0
    height = i1 - i0
    live = np.flatnonzero((width > 0) & (height > 0))
    if not len(live):
        return
    width, height, i0, j0 = width[live], height[live], i0[live], j0[live]
    band = np.maximum(1, BATCH_PAIRS // width)
    pieces = -(-height // band)
    owner = np.repeat(live, pieces)
    first = np.repeat(np.cumsum(pieces) - pieces, pieces)
    k = np.arange(len(owner)) - first
    w = np.repeat(width, pieces)
    top = np.repeat(i0, pieces) + k * np.repeat(band, pieces)
    bottom = np.minimum(top + np.repeat(band, pieces), np.repeat(i0 + height, pieces))
    left = np.repeat(j0, pieces)
    area = (bottom - top) * w
    res = grid.resolution
    # The centre of each chunk's first cell relative to its segment's reference point.
    base_x = grid.x0 + (left + 0.5) * res - rx[owner]
    base_y = grid.y0 + (top + 0.5) * res - ry[owner]
    total = np.cumsum(area)
    cut = np.searchsorted(total, np.arange(BATCH_PAIRS, int(total[-1]), BATCH_PAIRS), "right")
    for a, b in zip([0, *cut.tolist()], [*cut.tolist(), len(area)], strict=True):
        if a >= b:
            continue
        part = slice(a, b)
        yield _pairs(
            grid,
            owner[part],
            top[part],
            left[part],
            w[part],
            area[part],
            base_x[part],
            base_y[part],
        )


def _pairs(
    grid: Grid,
    owner: I64,
    top: I64,
    left: I64,
    width: I64,
    area: I64,
    base_x: F64,
    base_y: F64,
) -> _Batch:
    """The pairs of some chunks, made row by row: each (chunk, row) strip is a run of
    consecutive cells, so a pair costs a few repeats and adds (no division)."""
    res = grid.resolution
    height = area // width
    strips = int(height.sum())
    chunk_of = np.repeat(np.arange(len(owner)), height)
    line = np.arange(strips) - np.repeat(np.cumsum(height) - height, height)
    w = width[chunk_of]
    first = (top[chunk_of] + line) * grid.nx + left[chunk_of]
    strip_x = base_x[chunk_of].astype(np.float32)
    strip_y = (base_y[chunk_of] + line * res).astype(np.float32)
    n = int(w.sum())
    col = np.arange(n, dtype=np.int64) - np.repeat(np.cumsum(w) - w, w)
    cells = np.repeat(first, w) + col
    wx = np.repeat(strip_x, w) + col.astype(np.float32) * np.float32(res)
    wy = np.repeat(strip_y, w)
    strip_owner = owner[chunk_of]
    return _Batch(cells, np.repeat(strip_owner, w), wx, wy, strip_owner, w)


# -- the tool's bottom over each cell ------------------------------------------------------------


def _line_bottom(s: Segments, rows: I64, cat: int, b: _Batch) -> F64:
    """The lowest the tool's bottom gets over each pair's cell along a straight move (nm;
    +inf out of reach). (wx, wy) are relative to the move's start."""
    f32 = np.float32
    g = rows
    dx = (s.x1[g] - s.x0[g]).astype(f32)
    dy = (s.y1[g] - s.y0[g]).astype(f32)
    c = dx * dx + dy * dy
    r2 = b.per_pair((s.radius[g] ** 2).astype(f32))
    wx, wy = b.wx, b.wy
    pdx, pdy = b.per_pair(dx), b.per_pair(dy)
    tc = (wx * pdx + wy * pdy) * b.per_pair(1 / c)
    z0 = b.per_pair(s.z0[g])
    if cat == LINE:
        t = np.clip(tc, 0, 1)
        ex, ey = wx - t * pdx, wy - t * pdy
        return np.where(ex * ex + ey * ey <= r2, z0, np.inf)
    pc = b.per_pair(c)
    slope = b.per_pair(s.slope[g].astype(f32))
    dz = b.per_pair((s.z1[g] - s.z0[g]).astype(f32))
    e2 = np.maximum(wx * wx + wy * wy - tc * tc * pc, 0)
    reach = np.sqrt(np.maximum(r2 - e2, 0) / pc)
    lo = np.maximum(tc - reach, 0)
    hi = np.minimum(tc + reach, 1)
    ok = (e2 <= r2) & (lo <= hi)
    denom = slope * slope * pc - dz * dz
    stationary = np.where(
        denom > 0, tc - dz * np.sqrt(e2) / np.sqrt(pc * np.maximum(denom, 1e-30)), lo
    )
    stationary = np.clip(stationary, lo, hi)

    def rise(t: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
        out: npt.NDArray[np.float32] = t * dz + slope * np.sqrt(pc * (t - tc) ** 2 + e2)
        return out

    lowest = np.minimum(np.minimum(rise(lo), rise(hi)), rise(stationary))
    return np.where(ok, z0 + lowest, np.inf)


def _arc_bottom(s: Segments, rows: I64, b: _Batch) -> F64:
    """As `_line_bottom` for arc pieces of at most 90°; (wx, wy) relative to the centre."""
    f32 = np.float32
    g = rows
    ux0, uy0 = (s.x0[g] - s.cx[g]).astype(f32), (s.y0[g] - s.cy[g]).astype(f32)
    ux1, uy1 = (s.x1[g] - s.cx[g]).astype(f32), (s.y1[g] - s.cy[g]).astype(f32)
    sign = np.where(s.ccw[g], f32(1), f32(-1))
    vx, vy = b.wx, b.wy
    p0x, p0y, p1x, p1y = (b.per_pair(a) for a in (ux0, uy0, ux1, uy1))
    psign = b.per_pair(sign)
    inside = (psign * (p0x * vy - p0y * vx) >= 0) & (psign * (vx * p1y - vy * p1x) >= 0)
    ra = b.per_pair(np.sqrt(ux0 * ux0 + uy0 * uy0))
    rho = np.sqrt(vx * vx + vy * vy)
    to_ends = np.minimum((vx - p0x) ** 2 + (vy - p0y) ** 2, (vx - p1x) ** 2 + (vy - p1y) ** 2)
    d2 = np.where(inside, (rho - ra) ** 2, to_ends)
    r2 = b.per_pair((s.radius[g] ** 2).astype(f32))
    z = b.per_pair(s.z0[g])
    slope = s.slope[g]
    value = z + b.per_pair(slope) * np.sqrt(d2) if slope.any() else z
    return np.where(d2 <= r2, value, np.inf)


def evaluate(
    grid: Grid, s: Segments, rows: I64, compress: bool = True
) -> Iterator[tuple[I64, F64, I64]]:
    """(cells, tool bottom in nm, segment index) for the cells the segments `rows` reach
    (with `compress` False, for every cell of their boxes: +inf out of reach)."""
    cat = categories(s, rows)
    for kind in (DISC, LINE, RAMP, ARC):
        part = rows[cat == kind]
        if not len(part):
            continue
        if kind == DISC:
            found = _discs(grid, s, part)
        elif kind == ARC:
            found = (
                (b.cells, _arc_bottom(s, part, b), part[b.seg])
                for b in _batches(grid, s, part, s.cx[part], s.cy[part])
            )
        else:
            found = (
                (b.cells, _line_bottom(s, part, kind, b), part[b.seg])
                for b in _batches(grid, s, part, s.x0[part], s.y0[part])
            )
        for cells, value, seg in found:
            if compress:
                reach = np.isfinite(value)
                yield cells[reach], value[reach], seg[reach]
            else:
                yield cells, value, seg


def _discs(grid: Grid, s: Segments, rows: I64) -> Iterator[tuple[I64, F64, I64]]:
    """`evaluate` for plunges: the tool's footprint is the same shape wherever it goes
    down, so plunges whose boxes have the same size are computed together as one
    (plunges × rows × columns) block of squared distances, one row and one column term
    each, with no per-cell gathering."""
    i0, i1, j0, j1 = bounding_cells(grid, s.select(rows))
    h, w = i1 - i0, j1 - j0
    live = (h > 0) & (w > 0)
    rows, i0, j0, h, w = rows[live], i0[live], j0[live], h[live], w[live]
    if not len(rows):
        return
    shapes = np.stack([h, w], axis=1)
    kinds, which = np.unique(shapes, axis=0, return_inverse=True)
    which = which.reshape(-1)
    res = grid.resolution
    for k, (hh, ww) in enumerate(kinds.tolist()):
        members = np.flatnonzero(which == k)
        step = max(1, BATCH_PAIRS // (hh * ww))
        for a in range(0, len(members), step):
            m = members[a : a + step]
            g = rows[m]
            cols = j0[m][:, None] + np.arange(ww)
            lines = i0[m][:, None] + np.arange(hh)
            dx2 = ((cols + 0.5) * res + grid.x0 - s.x1[g][:, None]) ** 2
            dy2 = ((lines + 0.5) * res + grid.y0 - s.y1[g][:, None]) ** 2
            d2 = dy2[:, :, None] + dx2[:, None, :]
            z = np.minimum(s.z0[g], s.z1[g])[:, None, None]
            slope = s.slope[g][:, None, None]
            value = z + slope * np.sqrt(d2) if slope.any() else np.broadcast_to(z, d2.shape)
            value = np.where(d2 <= (s.radius[g] ** 2)[:, None, None], value, np.inf)
            cells = (lines * grid.nx)[:, :, None] + cols[:, None, :]
            seg = np.broadcast_to(g[:, None, None], d2.shape)
            yield cells.reshape(-1), value.reshape(-1), seg.reshape(-1)


def _apply(grid: Grid, keys: I64, s: Segments, rows: I64) -> tuple[float, int]:
    """Fold segments `rows` into the map; the volume they removed (nm³), the pairs made."""
    if not len(rows):
        return 0.0, 0
    i0, i1, _, _ = bounding_cells(grid, s.select(rows))
    lo, hi = int(i0.min()) * grid.nx, int(i1.max()) * grid.nx
    if hi <= lo:
        return 0.0, 0
    before = _volume(grid, keys[lo:hi])
    cat = categories(s, rows)
    sweeps = rows[cat != DISC]
    if len(sweeps) >= CULL_AFTER:
        pairs = _fold(grid, keys, s, rows[cat == DISC]) + _fold_culled(grid, keys, s, sweeps)
    else:
        pairs = _fold(grid, keys, s, rows)
    return before - _volume(grid, keys[lo:hi]), pairs


def _fold(grid: Grid, keys: I64, s: Segments, rows: I64) -> int:
    """Fold segments `rows` into the map; how many pairs that took."""
    pairs = 0
    # A flat end's bottom is its tip everywhere (ramps aside): one key per segment.
    level = not s.slope[rows].any() and not (categories(s, rows) == RAMP).any()
    if level:
        flat = np.full(len(s), _NEVER, dtype=np.int64)
        low = np.rint(np.minimum(s.z0[rows], s.z1[rows])).astype(np.int64)
        flat[rows] = ((low + Z_OFFSET) << KEY_SHIFT) | rows
    for cells, value, seg in evaluate(grid, s, rows, compress=False):
        pairs += len(cells)
        reach = np.isfinite(value)
        if level:
            np.minimum.at(keys, cells, np.where(reach, flat[seg], _NEVER))
            continue
        depth = np.rint(np.where(reach, value, 0.0)).astype(np.int64)
        key = np.where(reach, ((depth + Z_OFFSET) << KEY_SHIFT) | seg, _NEVER)
        np.minimum.at(keys, cells, key)
    return pairs


def _fold_culled(grid: Grid, keys: I64, s: Segments, rows: I64) -> int:
    """`_fold` for many milling moves, deepest first (earliest first at equal depth), each
    skipped when the material under its whole box is already no higher than its tip: a
    pocket cleared before, pecks, overlapping passes. The test is against the highest
    material per tile of TILE × TILE cells, kept up to date after each batch; it only ever
    errs towards cutting (heights only fall), so the part is the same as without it."""
    i0, i1, j0, j1 = bounding_cells(grid, s.select(rows))
    low = np.minimum(s.z0[rows], s.z1[rows])
    area = ((i1 - i0) * (j1 - j0)).tolist()
    order = np.lexsort((rows, low)).tolist()
    ti0, ti1 = (i0 // TILE).tolist(), ((i1 - 1) // TILE + 1).tolist()
    tj0, tj1 = (j0 // TILE).tolist(), ((j1 - 1) // TILE + 1).tolist()
    lows = low.tolist()
    highest = _tile_max(grid, keys, 0, -(-grid.ny // TILE), 0, -(-grid.nx // TILE))
    batch: list[int] = []
    pairs = 0
    made = 0
    box = [grid.ny, 0, grid.nx, 0]

    def flush() -> int:
        done = _fold(grid, keys, s, rows[np.array(batch, dtype=np.int64)])
        a, b, c, d = box[0], box[1], box[2], box[3]
        highest[a:b, c:d] = _tile_max(grid, keys, a, b, c, d)
        return done

    for k in order:
        if area[k] <= 0 or highest[ti0[k] : ti1[k], tj0[k] : tj1[k]].max() <= lows[k]:
            continue
        batch.append(k)
        pairs += area[k]
        box = [min(box[0], ti0[k]), max(box[1], ti1[k]), min(box[2], tj0[k]), max(box[3], tj1[k])]
        if pairs >= BATCH_PAIRS:
            made += flush()
            batch, pairs, box = [], 0, [grid.ny, 0, grid.nx, 0]
    if batch:
        made += flush()
    return made


def _tile_max(grid: Grid, keys: I64, a: int, b: int, c: int, d: int) -> F64:
    """The highest material (nm) in each tile of rows a…b, columns c…d (tile units)."""
    top = keys.reshape(grid.ny, grid.nx)[a * TILE : b * TILE, c * TILE : d * TILE] >> KEY_SHIFT
    rows_max = np.maximum.reduceat(top, np.arange(0, top.shape[0], TILE), axis=0)
    tiles = np.maximum.reduceat(rows_max, np.arange(0, top.shape[1], TILE), axis=1)
    return (tiles - Z_OFFSET).astype(np.float64)


def _volume(grid: Grid, keys: I64) -> float:
    """Material in the cells of `keys`, nm³ above the stock's bottom."""
    z = (keys >> KEY_SHIFT) - Z_OFFSET
    material = np.maximum(z, grid.stock.bottom) - grid.stock.bottom
    return float(material.sum()) * grid.resolution**2


def _check_rapid(grid: Grid, keys: I64, s: Segments, row: int, tolerance: float) -> Crash | None:
    """The deepest material a rapid move meets, if more than `tolerance` nm."""
    # The deepest to the nanometre; of cells equally deep, the first (lowest row, column).
    worst: tuple[float, int, float] | None = None
    bottom = grid.stock.bottom
    for cells, value, _ in evaluate(grid, s, np.array([row], dtype=np.int64)):
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
    return Crash(
        block=int(s.block[row]),
        segment=row,
        depth=amount,
        x=grid.x0 + (j + 0.5) * res,
        y=grid.y0 + (i + 0.5) * res,
        z=z,
    )
