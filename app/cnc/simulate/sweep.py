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
than another one (pecks).

Each cell holds one int64: (height + Z_OFFSET) << KEY_SHIFT | segment, so the minimum keeps
the deepest cut and, for equal depths, the earliest segment that reached it: the block that
cut there. Heights are rounded to the nanometre.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from app.cnc.simulate.segments import BOOL, F64, I32, I64, Segments
from app.cnc.simulate.stock import Grid

KEY_SHIFT = 27
ORDER_MASK = (1 << KEY_SHIFT) - 1
UNCUT = ORDER_MASK
Z_OFFSET = 1 << 35
BATCH_PAIRS = 1 << 19

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
    the last block simulated (None: all).
    """

    grid: Grid
    keys: I64
    segments: Segments
    removed_by_tool: dict[int, float] = field(default_factory=dict)
    crashes: list[Crash] = field(default_factory=list)
    upto: int | None = None

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
        removed = _apply(grid, keys, segments, _collapse(segments, stage))
        result.removed_by_tool[tool] = result.removed_by_tool.get(tool, 0.0) + removed
    return result


# -- which segments matter ------------------------------------------------------------------


def categories(segments: Segments) -> npt.NDArray[np.int8]:
    """DISC (a plunge or lift: no XY motion), LINE (flat end, constant Z), RAMP (any
    other straight move) or ARC, per segment."""
    still = (segments.x0 == segments.x1) & (segments.y0 == segments.y1) & ~segments.arc
    level = (segments.z0 == segments.z1) & (segments.slope == 0)
    cat = np.full(len(segments), RAMP, dtype=np.int8)
    cat[level] = LINE
    cat[still] = DISC
    cat[segments.arc] = ARC
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
    cat = categories(s.select(stage))
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
    cells: I64  # flat cell index per pair
    seg: I64  # row in the category's segment list per pair
    qx: F64
    qy: F64


def _batches(grid: Grid, s: Segments, rows: I64) -> Iterator[_Batch]:
    """Pairs (segment, cell) over the bounding boxes of segments `rows`, in batches of about
    BATCH_PAIRS; a box larger than that is cut into bands of rows. `seg` indexes `rows`."""
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
    total = np.cumsum(area)
    cut = np.searchsorted(total, np.arange(BATCH_PAIRS, int(total[-1]), BATCH_PAIRS), "right")
    for a, b in zip([0, *cut.tolist()], [*cut.tolist(), len(area)], strict=True):
        if a >= b:
            continue
        yield _pairs(grid, owner[a:b], top[a:b], left[a:b], w[a:b], area[a:b])


def _pairs(grid: Grid, owner: I64, top: I64, left: I64, width: I64, area: I64) -> _Batch:
    n = int(area.sum())
    seg = np.repeat(owner, area)
    local = np.arange(n, dtype=np.int64) - np.repeat(np.cumsum(area) - area, area)
    w = np.repeat(width, area)
    row = local // w
    i = np.repeat(top, area) + row
    j = np.repeat(left, area) + (local - row * w)
    res = grid.resolution
    qx = (j + 0.5).astype(np.float64) * res + grid.x0
    qy = (i + 0.5).astype(np.float64) * res + grid.y0
    return _Batch(cells=i * grid.nx + j, seg=seg, qx=qx, qy=qy)


# -- the tool's bottom over each cell ------------------------------------------------------------


def _bottom(s: Segments, rows: I64, cat: int, b: _Batch) -> F64:
    """The lowest the tool's bottom gets over each pair's cell (nm; +inf out of reach)."""
    g = rows[b.seg]
    r2 = s.radius[g] ** 2
    slope = s.slope[g]
    wx = b.qx - s.x0[g]
    wy = b.qy - s.y0[g]
    if cat == DISC:
        d2 = wx * wx + wy * wy
        z = np.minimum(s.z0[g], s.z1[g])
        value = z + slope * np.sqrt(d2) if slope.any() else z
        return np.where(d2 <= r2, value, np.inf)
    if cat == ARC:
        return _arc_bottom(s, g, b, r2, slope)
    dx = s.x1[g] - s.x0[g]
    dy = s.y1[g] - s.y0[g]
    c = dx * dx + dy * dy
    tc = (wx * dx + wy * dy) / c
    if cat == LINE:
        t = np.clip(tc, 0.0, 1.0)
        ex, ey = wx - t * dx, wy - t * dy
        return np.where(ex * ex + ey * ey <= r2, s.z0[g], np.inf)
    e2 = np.maximum(wx * wx + wy * wy - tc * tc * c, 0.0)
    reach = np.sqrt(np.maximum(r2 - e2, 0.0) / c)
    lo = np.maximum(tc - reach, 0.0)
    hi = np.minimum(tc + reach, 1.0)
    ok = (e2 <= r2) & (lo <= hi)
    z0 = s.z0[g]
    dz = s.z1[g] - z0
    denom = slope * slope * c - dz * dz
    stationary = np.where(
        denom > 0,
        tc - dz * np.sqrt(e2) / np.sqrt(c * np.maximum(denom, 1e-300)),
        lo,
    )
    stationary = np.clip(stationary, lo, hi)

    def f(t: F64) -> F64:
        return z0 + t * dz + slope * np.sqrt(c * (t - tc) ** 2 + e2)

    value = np.minimum(np.minimum(f(lo), f(hi)), f(stationary))
    return np.where(ok, value, np.inf)


def _arc_bottom(s: Segments, g: I64, b: _Batch, r2: F64, slope: F64) -> F64:
    vx = b.qx - s.cx[g]
    vy = b.qy - s.cy[g]
    ux0, uy0 = s.x0[g] - s.cx[g], s.y0[g] - s.cy[g]
    ux1, uy1 = s.x1[g] - s.cx[g], s.y1[g] - s.cy[g]
    sign = np.where(s.ccw[g], 1.0, -1.0)
    inside = (sign * (ux0 * vy - uy0 * vx) >= 0) & (sign * (vx * uy1 - vy * ux1) >= 0)
    rho = np.sqrt(vx * vx + vy * vy)
    ra = np.sqrt(ux0 * ux0 + uy0 * uy0)
    to_ends = np.minimum(
        (b.qx - s.x0[g]) ** 2 + (b.qy - s.y0[g]) ** 2,
        (b.qx - s.x1[g]) ** 2 + (b.qy - s.y1[g]) ** 2,
    )
    d2 = np.where(inside, (rho - ra) ** 2, to_ends)
    value = s.z0[g] + slope * np.sqrt(d2) if slope.any() else s.z0[g]
    return np.where(d2 <= r2, value, np.inf)


def evaluate(
    grid: Grid, s: Segments, rows: I64, compress: bool = True
) -> Iterator[tuple[I64, F64, I64]]:
    """(cells, tool bottom in nm, segment index) for the cells the segments `rows` reach
    (with `compress` False, for every cell of their boxes: +inf out of reach)."""
    cat = categories(s)[rows]
    for kind in (DISC, LINE, RAMP, ARC):
        part = rows[cat == kind]
        if not len(part):
            continue
        if kind == DISC:
            found = _discs(grid, s, part)
        else:
            found = (
                (b.cells, _bottom(s, part, kind, b), part[b.seg]) for b in _batches(grid, s, part)
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


def _apply(grid: Grid, keys: I64, s: Segments, rows: I64) -> float:
    """Fold segments `rows` into the map; the volume they removed (nm³)."""
    if not len(rows):
        return 0.0
    i0, i1, _, _ = bounding_cells(grid, s.select(rows))
    lo, hi = int(i0.min()) * grid.nx, int(i1.max()) * grid.nx
    if hi <= lo:
        return 0.0
    before = _volume(grid, keys[lo:hi])
    for cells, value, seg in evaluate(grid, s, rows, compress=False):
        reach = np.isfinite(value)
        depth = np.rint(np.where(reach, value, 0.0)).astype(np.int64)
        key = np.where(reach, ((depth + Z_OFFSET) << KEY_SHIFT) | seg, _NEVER)
        np.minimum.at(keys, cells, key)
    return before - _volume(grid, keys[lo:hi])


def _volume(grid: Grid, keys: I64) -> float:
    """Material in the cells of `keys`, nm³ above the stock's bottom."""
    z = (keys >> KEY_SHIFT) - Z_OFFSET
    material = np.maximum(z, grid.stock.bottom) - grid.stock.bottom
    return float(material.sum()) * grid.resolution**2


def _check_rapid(grid: Grid, keys: I64, s: Segments, row: int, tolerance: float) -> Crash | None:
    """The deepest material a rapid move meets, if more than `tolerance` nm."""
    worst: tuple[float, int, float] | None = None
    bottom = grid.stock.bottom
    for cells, value, _ in evaluate(grid, s, np.array([row], dtype=np.int64)):
        top = ((keys[cells] >> KEY_SHIFT) - Z_OFFSET).astype(np.float64)
        depth = top - np.maximum(value, bottom)
        depth[top <= bottom] = 0.0
        k = int(np.argmax(depth)) if len(depth) else -1
        if k >= 0 and depth[k] > tolerance and (worst is None or depth[k] > worst[0]):
            worst = (float(depth[k]), int(cells[k]), float(value[k]))
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
