"""Which cells a segment's tool reaches, and how low its bottom gets over each.

Two ways, both exact at the cell centres:

- **Spans** (`flat_spans`), for a flat-bottomed tool moving at one height (a level line, an
  arc piece, a plunge): its bottom is its tip wherever it reaches, so all that matters is
  *which* cells it reaches, and on each row of the grid those are runs of consecutive
  cells found in closed form — a straight move sweeps a capsule (a disc at each end and the
  band between), convex, so one run per row; an arc piece of at most 90° sweeps a ring
  sector (at most two runs per row: the ring's left and right parts within the sector's
  wedge) with a disc at each end; a plunge a disc. A run costs a few operations whatever
  its length, and folding it into the map is a write per cell, no arithmetic.
- **Pairs** (`evaluate`), for everything else (ramps and drill points, whose bottom varies
  over the cells, and the crash check): each segment over the cells of its bounding box,
  with the closed-form lowest position of the tool's bottom over the cell along the move:

  - a straight move of a flat end mill removes, at a point q, everything above the lowest
    tip height z(t) over the t where the tool's axis is within its radius of q; z is linear
    in t and those t are one interval [t_lo, t_hi], so the lowest is at one of its ends;
  - a drill point adds slope·d (d: distance from the axis), so the bottom over q along the
    move is f(t) = z0 + t·dz + slope·√(c·(t − tc)² + e²), convex in t: its least value on
    [t_lo, t_hi] is at an end or at the stationary point clipped into it;
  - an arc piece (at most 90°, constant Z) is at distance |ρ − r| from q where q's angle
    is inside the sector, else at the nearer end point.

  Pairs are made in batches of about `BATCH_PAIRS`, in float32 relative to the segment
  (small numbers: float32 keeps them to a few nanometres), each segment's values repeated
  over its pairs rather than gathered; plunges of one tool share a footprint and are
  computed as blocks of row and column terms.

Cells are those of a `Grid` (stock.py): centre of cell (i, j) at (x0 + (j + ½)·res,
y0 + (i + ½)·res).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
import numpy.typing as npt

from app.cnc.simulate.segments import BOOL, F64, I64, Segments
from app.cnc.simulate.stock import Grid

BATCH_PAIRS = 1 << 17  # (segment, cell) pairs, or cells of runs, handled at once (in the cache)
BATCH_ROWS = 1 << 14  # (segment, row) runs made at once
DISC, LINE, RAMP, ARC = 0, 1, 2, 3

_T = TypeVar("_T", bound=np.generic)


def categories(s: Segments) -> npt.NDArray[np.int8]:
    """DISC (a plunge or lift: no XY motion), LINE (flat end, constant Z), RAMP (any
    other straight move) or ARC, per segment."""
    still = (s.x0 == s.x1) & (s.y0 == s.y1) & ~s.arc
    level = (s.z0 == s.z1) & (s.slope == 0)
    cat = np.full(len(s), RAMP, dtype=np.int8)
    cat[level] = LINE
    cat[still] = DISC
    cat[s.arc] = ARC
    return cat


def flat(s: Segments) -> BOOL:
    """The segments whose tool bottom is one height wherever it reaches: flat ends moving
    level, along an arc or straight down (see the module's note)."""
    cat = categories(s)
    out: BOOL = (s.slope == 0) & (cat != RAMP)
    return out


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


# -- spans: flat tools ---------------------------------------------------------------------------


@dataclass
class Spans:
    """Runs of cells: row `row`, columns `lo` … `hi` (end exclusive), reached by segment
    `seg` (an index into the segments given)."""

    seg: I64
    row: I64
    lo: I64
    hi: I64

    def parts(self, most: int = BATCH_PAIRS) -> Iterator[Spans]:
        """These runs in consecutive parts of about `most` cells each."""
        total = np.cumsum(self.hi - self.lo)
        if not len(total) or total[-1] <= most:
            yield self
            return
        stops = np.searchsorted(total, np.arange(most, int(total[-1]), most), "right")
        for part in np.split(np.arange(len(total)), stops):
            if len(part):
                yield Spans(self.seg[part], self.row[part], self.lo[part], self.hi[part])

    def cells(self, nx: int) -> I64:
        """Every cell of every run, run after run, as flat indices into a grid of `nx`
        columns."""
        length = self.hi - self.lo
        start_of = np.cumsum(length) - length
        first = self.row * nx + self.lo
        cells: I64 = np.arange(int(length.sum()), dtype=np.int64)
        cells += np.repeat(first - start_of, length)
        return cells


def _slab(a: F64, b: F64, lo: float | F64, hi: float | F64) -> tuple[F64, F64]:
    """The X where lo ≤ a·X + b ≤ hi (an interval; empty as lo > hi)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        p = (lo - b) / a
        q = (hi - b) / a
    inside = (lo <= b) & (b <= hi)
    left = np.where(a > 0, p, np.where(a < 0, q, np.where(inside, -np.inf, np.inf)))
    right = np.where(a > 0, q, np.where(a < 0, p, np.where(inside, np.inf, -np.inf)))
    return left, right


def _disc(r: F64, v: F64, centre: F64) -> tuple[F64, F64]:
    """The X within `r` of (centre, 0) on the line at height v above it."""
    h2 = r * r - v * v
    h = np.sqrt(np.maximum(h2, 0.0))
    ok = h2 >= 0
    return np.where(ok, centre - h, np.inf), np.where(ok, centre + h, -np.inf)


def flat_spans(grid: Grid, s: Segments) -> Iterator[Spans]:
    """The runs of cells that flat segments `s` (see `flat`) reach, in batches of about
    BATCH_ROWS (segment, row) pairs; `seg` indexes `s`."""
    i0, i1, j0, j1 = bounding_cells(grid, s)
    height = np.where(j1 > j0, i1 - i0, 0)
    live = np.flatnonzero(height > 0)
    if not len(live):
        return
    cut = np.cumsum(height[live])
    stops = np.searchsorted(cut, np.arange(BATCH_ROWS, int(cut[-1]), BATCH_ROWS), "right")
    for part in np.split(live, stops):
        if len(part):
            yield _spans(grid, s, part, i0[part], height[part], j0[part], j1[part])


def _spans(grid: Grid, s: Segments, segs: I64, i0: I64, height: I64, j0: I64, j1: I64) -> Spans:
    res = grid.resolution
    pair = np.repeat(np.arange(len(segs)), height)
    start_of = np.cumsum(height) - height
    row = np.repeat(i0, height) + np.arange(len(pair)) - np.repeat(start_of, height)
    seg = segs[pair]
    y = grid.y0 + (row + 0.5) * res
    r = s.radius[seg]
    cat = categories(s.select(seg))
    lows: list[F64] = []
    highs: list[F64] = []
    # Straight moves and plunges: the capsule (a disc when the move has no length).
    x0, y0, x1, y1 = s.x0[seg], s.y0[seg], s.x1[seg], s.y1[seg]
    lo_a, hi_a = _disc(r, y - y0, x0)
    lo_b, hi_b = _disc(r, y - y1, x1)
    dx, dy = x1 - x0, y1 - y0
    length = np.hypot(dx, dy)
    moving = (cat == LINE) & (length > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        ux, uy = np.where(moving, dx / length, 0.0), np.where(moving, dy / length, 0.0)
    v = y - y0
    along = _slab(ux, v * uy, 0.0, length)
    across = _slab(uy, -v * ux, -r, r)
    band_lo = np.maximum(along[0], across[0])
    band_hi = np.minimum(along[1], across[1])
    band = moving & (band_lo <= band_hi)
    straight = cat != ARC
    # The capsule is convex: on a row, its parts overlap into one run.
    capsule_lo = np.minimum(np.minimum(lo_a, lo_b), np.where(band, band_lo + x0, np.inf))
    capsule_hi = np.maximum(np.maximum(hi_a, hi_b), np.where(band, band_hi + x0, -np.inf))
    lows.append(np.where(straight, capsule_lo, np.inf))
    highs.append(np.where(straight, capsule_hi, -np.inf))
    # Arc pieces: the ring sector, left and right of the centre, and the end discs.
    arc = cat == ARC
    if arc.any():
        cx, cy = s.cx[seg], s.cy[seg]
        p0x, p0y, p1x, p1y = x0 - cx, y0 - cy, x1 - cx, y1 - cy
        ra = np.hypot(p0x, p0y)
        w = y - cy
        outer = _disc(ra + r, w, np.zeros_like(w))
        inner_r = np.maximum(ra - r, 0.0)
        hole = np.sqrt(np.maximum(inner_r * inner_r - w * w, 0.0))
        sign = np.where(s.ccw[seg], 1.0, -1.0)
        first = _slab(-sign * p0y, sign * p0x * w, 0.0, np.inf)
        second = _slab(sign * p1y, -sign * w * p1x, 0.0, np.inf)
        wedge_lo, wedge_hi = np.maximum(first[0], second[0]), np.minimum(first[1], second[1])
        for part_lo, part_hi in ((outer[0], -hole), (hole, outer[1])):
            lows.append(np.where(arc, np.maximum(part_lo, wedge_lo) + cx, np.inf))
            highs.append(np.where(arc, np.minimum(part_hi, wedge_hi) + cx, -np.inf))
        lows += [np.where(arc, lo_a, np.inf), np.where(arc, lo_b, np.inf)]
        highs += [np.where(arc, hi_a, -np.inf), np.where(arc, hi_b, -np.inf)]
    left = np.concatenate(lows)
    right = np.concatenate(highs)
    k = len(lows)
    lo = np.ceil((left - grid.x0) / res - 0.5)
    hi = np.floor((right - grid.x0) / res - 0.5) + 1
    bound_lo, bound_hi = np.tile(np.repeat(j0, height), k), np.tile(np.repeat(j1, height), k)
    with np.errstate(invalid="ignore"):
        lo = np.clip(np.nan_to_num(lo, nan=0.0, posinf=grid.nx, neginf=0.0), bound_lo, bound_hi)
        hi = np.clip(np.nan_to_num(hi, nan=0.0, posinf=grid.nx, neginf=0.0), bound_lo, bound_hi)
    keep = hi > lo
    return Spans(
        np.tile(seg, k)[keep],
        np.tile(row, k)[keep],
        lo[keep].astype(np.int64),
        hi[keep].astype(np.int64),
    )


# -- pairs: every cell of the bounding box -----------------------------------------------------


@dataclass
class _Batch:
    """(segment, cell) pairs: the cells, and per pair the segment (an index into the rows
    evaluated) and the cell centre relative to the segment's reference point (its start, or
    an arc's centre), in float32 nm. `count` is how many consecutive pairs each chunk has and
    `chunk` its segment, so per-segment values reach the pairs by `np.repeat` instead of a
    gather per pair."""

    cells: I64
    seg: I64
    wx: npt.NDArray[np.float32]
    wy: npt.NDArray[np.float32]
    chunk: I64
    count: I64

    def per_pair(self, values: npt.NDArray[_T]) -> npt.NDArray[_T]:
        """A value per chunk's segment (indexed like `chunk`), repeated for its pairs."""
        return np.repeat(values[self.chunk], self.count)


def _batches(grid: Grid, s: Segments, rx: F64, ry: F64) -> Iterator[_Batch]:
    """Pairs (segment, cell) over the bounding boxes of `s`, in batches of about
    BATCH_PAIRS; a box larger than that is cut into bands of rows. (rx, ry) is each
    segment's reference point."""
    i0, i1, j0, j1 = bounding_cells(grid, s)
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


def _line_bottom(s: Segments, ramp: bool, b: _Batch) -> F64:
    """The lowest the tool's bottom gets over each pair's cell along a straight move (nm;
    +inf out of reach). (wx, wy) are relative to the move's start."""
    f32 = np.float32
    dx = (s.x1 - s.x0).astype(f32)
    dy = (s.y1 - s.y0).astype(f32)
    c = dx * dx + dy * dy
    r2 = b.per_pair((s.radius**2).astype(f32))
    wx, wy = b.wx, b.wy
    pdx, pdy = b.per_pair(dx), b.per_pair(dy)
    tc = (wx * pdx + wy * pdy) * b.per_pair(1 / c)
    z0 = b.per_pair(s.z0)
    if not ramp:
        t = np.clip(tc, 0, 1)
        ex, ey = wx - t * pdx, wy - t * pdy
        return np.where(ex * ex + ey * ey <= r2, z0, np.inf)
    pc = b.per_pair(c)
    slope = b.per_pair(s.slope.astype(f32))
    dz = b.per_pair((s.z1 - s.z0).astype(f32))
    # The squared distance to the line as a difference of points, not of squares (which
    # loses micrometres to cancellation in float32 on long moves).
    e2 = (wx - tc * pdx) ** 2 + (wy - tc * pdy) ** 2
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


def _arc_bottom(s: Segments, b: _Batch) -> F64:
    """As `_line_bottom` for arc pieces of at most 90°; (wx, wy) relative to the centre."""
    f32 = np.float32
    ux0, uy0 = (s.x0 - s.cx).astype(f32), (s.y0 - s.cy).astype(f32)
    ux1, uy1 = (s.x1 - s.cx).astype(f32), (s.y1 - s.cy).astype(f32)
    sign = np.where(s.ccw, f32(1), f32(-1))
    vx, vy = b.wx, b.wy
    p0x, p0y, p1x, p1y = (b.per_pair(a) for a in (ux0, uy0, ux1, uy1))
    psign = b.per_pair(sign)
    inside = (psign * (p0x * vy - p0y * vx) >= 0) & (psign * (vx * p1y - vy * p1x) >= 0)
    ra = b.per_pair(np.sqrt(ux0 * ux0 + uy0 * uy0))
    rho = np.sqrt(vx * vx + vy * vy)
    to_ends = np.minimum((vx - p0x) ** 2 + (vy - p0y) ** 2, (vx - p1x) ** 2 + (vy - p1y) ** 2)
    d2 = np.where(inside, (rho - ra) ** 2, to_ends)
    r2 = b.per_pair((s.radius**2).astype(f32))
    z = b.per_pair(s.z0)
    value = z + b.per_pair(s.slope) * np.sqrt(d2) if s.slope.any() else z
    return np.where(d2 <= r2, value, np.inf)


def evaluate(grid: Grid, s: Segments, compress: bool = True) -> Iterator[tuple[I64, F64, I64]]:
    """(cells, tool bottom in nm, segment index into `s`) for the cells segments `s`
    reach (with `compress` False, for every cell of their boxes: +inf out of reach)."""
    cat = categories(s)
    for kind in (DISC, LINE, RAMP, ARC):
        part = np.flatnonzero(cat == kind)
        if not len(part):
            continue
        sub = s.select(part)
        if kind == DISC:
            found = _discs(grid, sub)
        elif kind == ARC:
            found = (
                (b.cells, _arc_bottom(sub, b), b.seg) for b in _batches(grid, sub, sub.cx, sub.cy)
            )
        else:
            found = (
                (b.cells, _line_bottom(sub, kind == RAMP, b), b.seg)
                for b in _batches(grid, sub, sub.x0, sub.y0)
            )
        for cells, value, seg in found:
            if compress:
                reach = np.isfinite(value)
                yield cells[reach], value[reach], part[seg[reach]]
            else:
                yield cells, value, part[seg]


@dataclass
class Plunges:
    """Plunges `seg` (indices into the segments given) over the cells of one box shape:
    `cells` and `rise` are (plunges × rows × columns) — the cell and how far the tool's
    bottom is above its tip there, in whole nm (−1 out of reach)."""

    seg: I64
    cells: I64
    rise: I64


def plunges(grid: Grid, s: Segments) -> Iterator[Plunges]:
    """The cells plunges `s` reach, in blocks: the tool's footprint is the same shape
    wherever it goes down, so plunges whose boxes have the same size are computed together
    as one block of squared distances, one row and one column term each, with no per-cell
    gathering. Their tips are at min(z0, z1)."""
    i0, i1, j0, j1 = bounding_cells(grid, s)
    h, w = i1 - i0, j1 - j0
    rows = np.flatnonzero((h > 0) & (w > 0))
    if not len(rows):
        return
    i0, j0, h, w = i0[rows], j0[rows], h[rows], w[rows]
    shapes = np.stack([h, w], axis=1)
    if len(shapes) == 1:  # one plunge: numpy's unique costs more than the plunge
        kinds, which = shapes, np.zeros(1, dtype=np.int64)
    else:
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
            inside = d2 <= (s.radius[g] ** 2)[:, None, None]
            slope = s.slope[g]
            if slope.any():
                np.sqrt(d2, out=d2)
                d2 *= slope[:, None, None]
                rise = np.rint(d2).astype(np.int64)
            else:
                rise = np.zeros(d2.shape, dtype=np.int64)
            rise[~inside] = -1
            cells = (lines * grid.nx)[:, :, None] + cols[:, None, :]
            yield Plunges(g, cells, rise)


def _discs(grid: Grid, s: Segments) -> Iterator[tuple[I64, F64, I64]]:
    """`evaluate` for plunges (see `plunges`)."""
    for block in plunges(grid, s):
        tip = np.minimum(s.z0[block.seg], s.z1[block.seg])[:, None, None]
        value = np.where(block.rise >= 0, tip + block.rise, np.inf)
        seg = np.broadcast_to(block.seg[:, None, None], value.shape)
        yield block.cells.reshape(-1), value.reshape(-1), seg.reshape(-1)
