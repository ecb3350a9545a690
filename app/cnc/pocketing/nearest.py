"""Distances from many points to many lines and arcs at once (numpy), as bounds.

The planner chooses points by exact Python arithmetic (`plan._closest_on_element`), and
its choices must stay the same to the last bit: a golden G-code file depends on them. Doing
that arithmetic for every pair of (point, element) is what made a large pocket plan for
minutes (a ring sampled every eighth of the tool radius against every element of the next
ring; a cleanup target against every element of every pass).

Here numpy gives, for all pairs at once, a lower and an upper bound on the distance the
exact function returns. They are the same number (to numpy's rounding) except for an arc
seen from a point whose nearest place on the circle is at one of the arc's ends, within the
exact function's tolerance: then the exact answer is either the distance to the circle or
to the nearer end, and the bounds are those two. A caller evaluates exactly only the pairs
whose lower bound is within `MARGIN` of the best upper bound — the only ones that can win
— in the order it always did, and so chooses what it chose before. Lengths are nm.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from app.cnc.plane import Element, Path, Pt, length, points_along, sweep

Array = npt.NDArray[np.float64]

MARGIN = 1.0
"""nm: a pair whose lower bound is farther than this beyond the best upper bound cannot
win. numpy and math differ by about 1e-6 nm at 100 in; the exact function's own tolerance
at an arc's end is in the bounds."""

_INSIDE = 1e-9  # rad: an angle this far inside an arc's sweep is on the arc, exactly too
_OUTSIDE = 1e-5  # rad: this far outside, the exact function takes the nearer end
PAIRS = 1 << 20  # (point, element) pairs per numpy pass: about 100 MB of temporaries


@dataclass(frozen=True)
class Elements:
    """Lines and arcs as columns: start, end, centre (arcs), radius, start angle and turn
    (radians, > 0 in the travel direction; a full circle is 2π)."""

    sx: Array
    sy: Array
    ex: Array
    ey: Array
    cx: Array
    cy: Array
    arc: npt.NDArray[np.bool_]
    clockwise: npt.NDArray[np.bool_]
    radius: Array
    a0: Array
    turn: Array

    def __len__(self) -> int:
        return len(self.sx)

    def take(self, rows: npt.NDArray[np.intp]) -> Elements:
        """The elements of `rows`, in that order."""
        return Elements(*(getattr(self, name)[rows] for name in _NAMES))

    def boxes(self, grow: float) -> Array:
        """Each element's box (x0, y0, x1, y1 rows; an arc's circle's) grown by `grow` and
        by the slack of its bounds: a point outside it is, by its lower bound too,
        farther than `grow` from the element."""
        # An arc seen from just past an end (within _OUTSIDE) is bounded by its circle.
        slack = 2.0 + np.where(self.arc, 2 * _OUTSIDE * self.radius, 0.0) + grow
        x0 = np.where(self.arc, self.cx - self.radius, np.minimum(self.sx, self.ex)) - slack
        y0 = np.where(self.arc, self.cy - self.radius, np.minimum(self.sy, self.ey)) - slack
        x1 = np.where(self.arc, self.cx + self.radius, np.maximum(self.sx, self.ex)) + slack
        y1 = np.where(self.arc, self.cy + self.radius, np.maximum(self.sy, self.ey)) + slack
        return np.column_stack((x0, y0, x1, y1))


def table(starts: Sequence[Pt], elements: Sequence[Element]) -> Elements:
    """The columns of `elements`, each starting at the point of `starts` beside it."""
    n = len(elements)
    sx, sy, ex, ey, cx, cy = (np.zeros(n) for _ in range(6))
    radius, a0, turn = np.zeros(n), np.zeros(n), np.zeros(n)
    arc = np.zeros(n, dtype=bool)
    clockwise = np.zeros(n, dtype=bool)
    for k, (start, element) in enumerate(zip(starts, elements, strict=True)):
        sx[k], sy[k] = start
        ex[k], ey[k] = element.end
        if element.centre is not None:
            c = element.centre
            arc[k], clockwise[k] = True, element.clockwise
            cx[k], cy[k] = c
            radius[k] = math.dist(start, c)
            a0[k] = math.atan2(start[1] - c[1], start[0] - c[0])
            turn[k] = sweep(start, element)
    return Elements(sx, sy, ex, ey, cx, cy, arc, clockwise, radius, a0, turn)


def bounds(points: Array, elements: Elements) -> tuple[Array, Array]:
    """(lower, upper): for each point (a row x, y) and element, bounds on the distance from
    the point to the element's nearest point as the planner finds it (P × E arrays)."""
    return _bounds(points[:, 0:1], points[:, 1:2], elements)


def pair_bounds(points: Array, elements: Elements) -> tuple[Array, Array]:
    """(lower, upper) as `bounds` gives them, of each point (row i) to element i alone
    (P arrays, P points and P elements): many small questions in one numpy pass."""
    return _bounds(points[:, 0], points[:, 1], elements)


def _bounds(px: Array, py: Array, elements: Elements) -> tuple[Array, Array]:
    """`bounds` for point columns `px`, `py` broadcast against the elements' columns."""
    # Lines: the nearest point of the segment.
    dx, dy = elements.ex - elements.sx, elements.ey - elements.sy
    denom = dx * dx + dy * dy
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(denom > 0, ((px - elements.sx) * dx + (py - elements.sy) * dy) / denom, 0.0)
    t = np.clip(t, 0.0, 1.0)
    line = np.hypot(px - (elements.sx + t * dx), py - (elements.sy + t * dy))
    if not elements.arc.any():
        return line, line
    # Arcs: the circle, or the nearer end, by where the point is seen from the centre.
    qx, qy = px - elements.cx, py - elements.cy
    circle = np.abs(np.hypot(qx, qy) - elements.radius)
    ends = np.minimum(
        np.hypot(px - elements.sx, py - elements.sy), np.hypot(px - elements.ex, py - elements.ey)
    )
    angle = np.arctan2(qy, qx)
    turned = np.where(elements.clockwise, elements.a0 - angle, angle - elements.a0)
    along = np.mod(turned, 2 * np.pi)
    inside = along <= elements.turn - _INSIDE
    outside = (along > elements.turn + _OUTSIDE) & (along < 2 * np.pi - _OUTSIDE)
    lower = np.where(elements.arc, np.where(outside, ends, circle), line)
    upper = np.where(elements.arc, np.where(inside, circle, ends), line)
    return lower, upper


def nearest_pairs(points: Array, elements: Elements, reach: float) -> list[tuple[int, list[int]]]:
    """The (point, element) pairs that can hold the smallest distance from a point to an
    element: each point (row index, in order) whose lower bound to some element is within
    `MARGIN` of the best upper bound over all pairs, with the elements (indexes, in order)
    whose lower bound is. `reach` (nm): a distance some pair is known to be within.

    The same pairs as bounding every point against every element, at the cost of the
    pairs near each other: the points are filed in a grid of cells about `reach` square,
    each element under the cells its box grown by `reach` meets, and a point is bounded
    against the elements of its cell alone; any other is farther than `reach` and
    `MARGIN` from it, so can be neither the best pair nor within `MARGIN` of it. A ring
    sampled every eighth of the tool radius against the next ring's elements costs their
    sum, not their product (issue 30)."""
    if not len(points) or not len(elements):
        return []
    grow = reach + MARGIN + 2.0
    boxes = elements.boxes(grow)
    extent = float(max(np.ptp(points[:, 0]), np.ptp(points[:, 1]), 1.0))
    cell = max(grow, extent / 128)  # (not thousands of cells under one large element)
    keys = np.floor(points / cell).astype(np.int64)
    # Cells numbered x-major within the points' cells' box: the points filed by number
    # (rows ascending in each), and every element under each numbered cell its box meets
    # (elements ascending), in numpy passes rather than one Python step per point and cell.
    low, high = keys.min(axis=0), keys.max(axis=0)
    width = int(high[1] - low[1]) + 1
    codes = (keys[:, 0] - low[0]) * width + (keys[:, 1] - low[1])
    cells = np.unique(codes)
    spans = np.floor(boxes / cell).astype(np.int64)
    kx0, ky0 = np.maximum(spans[:, 0], low[0]), np.maximum(spans[:, 1], low[1])
    kx1, ky1 = np.minimum(spans[:, 2], high[0]), np.minimum(spans[:, 3], high[1])
    nx, ny = np.maximum(kx1 - kx0 + 1, 0), np.maximum(ky1 - ky0 + 1, 0)
    count = nx * ny
    element = np.repeat(np.arange(len(elements)), count)
    place = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    per_row = ny[element]
    met = (kx0[element] + place // np.maximum(per_row, 1) - low[0]) * width + (
        ky0[element] + place % np.maximum(per_row, 1) - low[1]
    )
    there = np.isin(met, cells)
    met, element = met[there], element[there]
    if not len(met):
        return []
    by_cell = np.argsort(met, kind="stable")
    met, element = met[by_cell], element[by_cell]
    # Each point's elements: the run of `element` under its cell (ascending).
    firsts = np.concatenate(([0], np.flatnonzero(np.diff(met)) + 1))
    heads = met[firsts]
    sizes = np.diff(np.concatenate((firsts, [len(met)])))
    at = np.minimum(np.searchsorted(heads, codes), len(heads) - 1)
    point_count = np.where(heads[at] == codes, sizes[at], 0)
    # Every (point, element) pair of a point's cell, point by point (rows ascending, each
    # one's elements ascending), bounded in numpy passes over every cell's pairs at once
    # (a pass per cell was most of the search's time: its arrays are a few dozen long).
    owner = np.repeat(np.arange(len(points)), point_count)
    if not len(owner):
        return []
    place = np.arange(len(owner)) - np.repeat(np.cumsum(point_count) - point_count, point_count)
    which = element[firsts[at][owner] + place]
    best = math.inf
    lows: list[Array] = []
    for k in range(0, len(owner), PAIRS):  # (memory bounded, however many are near)
        rows, near = owner[k : k + PAIRS], which[k : k + PAIRS]
        lower, upper = pair_bounds(points[rows], elements.take(near))
        best = min(best, float(upper.min()))
        lows.append(lower)
    kept = np.concatenate(lows) <= best + MARGIN  # (the best pair's among them)
    owner, which = owner[kept], which[kept]
    breaks = np.flatnonzero(np.diff(owner)) + 1
    rows_ = owner[np.concatenate(([0], breaks))].tolist()
    return [(row, run.tolist()) for row, run in zip(rows_, np.split(which, breaks), strict=True)]


def segment_distances(point: Pt, rings: Sequence[Sequence[tuple[int, int]]]) -> Array:
    """The distance from `point` to every segment of closed `rings` (each ring's segments
    in order, from its first point, the rings one after another)."""
    starts = np.concatenate([np.asarray(r, dtype=np.float64).reshape(-1, 2) for r in rings])
    ends = np.concatenate(
        [np.roll(np.asarray(r, dtype=np.float64).reshape(-1, 2), -1, axis=0) for r in rings]
    )
    return _to_segments(point, starts, ends)


def stretch_distances(
    ring: Array, points: Array, firsts: Sequence[int], counts: Sequence[int]
) -> Array:
    """For each k, the distance from `points[k]` to the open polyline of `counts[k]`
    segments of the closed `ring` (rows x, y) from its point `firsts[k]` on, as
    `mill.distance_to_element` measures each segment: every stretch in one numpy pass."""
    n = len(ring)
    sizes = np.asarray(counts, dtype=np.intp)
    owner = np.repeat(np.arange(len(sizes), dtype=np.intp), sizes)
    first_segment = np.cumsum(sizes) - sizes
    rows = (
        np.asarray(firsts, dtype=np.intp)[owner] + np.arange(len(owner)) - first_segment[owner]
    ) % n
    found: Array = np.minimum.reduceat(
        _to_segments(points[owner], ring[rows], ring[(rows + 1) % n]), first_segment
    )
    return found


def _to_segments(point: Pt | Array, starts: Array, ends: Array) -> Array:
    """The distance from `point` (or from each row of `point`) to each segment."""
    d = ends - starts
    denom = (d * d).sum(axis=1)
    at = np.broadcast_to(np.asarray(point, dtype=np.float64), starts.shape)
    q = at - starts
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(denom > 0, (q * d).sum(axis=1) / denom, 0.0)
    t = np.clip(t, 0.0, 1.0)
    foot = starts + d * t[:, None]
    found: Array = np.hypot(at[:, 0] - foot[:, 0], at[:, 1] - foot[:, 1])
    return found


@dataclass(frozen=True)
class Samples:
    """The points `plane.sample` takes along a path, to numpy's rounding (`at`, rows x, y,
    in the same order), and each one exactly (`exact`, the same arithmetic as
    `plane.sample`): a caller bounds them all with numpy and measures the few that can
    win, as the rest of this module does with distances."""

    at: Array
    starts: tuple[Pt, ...]
    elements: tuple[Element, ...]
    owner: npt.NDArray[np.intp]
    fraction: Array

    def exact(self, k: int) -> Pt:
        """The `k`th sample as `plane.sample` makes it, to the last bit."""
        e = int(self.owner[k])
        return points_along(self.starts[e], self.elements[e], (float(self.fraction[k]),))[0]


def samples(path: Path, step: float) -> Samples:
    """The points of `plane.sample(path, step)`: each element cut into the same n pieces,
    fractions i / n (both ends included), the points made for all elements at once."""
    starts: list[Pt] = []
    counts: list[int] = []
    current = path.start
    for element in path.elements:
        starts.append(current)
        counts.append(max(1, math.ceil(length(current, element) / step)))
        current = element.end
    table_ = table(starts, path.elements)
    sizes = np.array(counts, dtype=np.intp) + 1
    owner = np.repeat(np.arange(len(counts), dtype=np.intp), sizes)
    first = np.cumsum(sizes) - sizes
    steps = np.arange(len(owner), dtype=np.intp) - first[owner]
    fraction = steps / np.array(counts, dtype=np.float64)[owner]
    sx, sy = table_.sx[owner], table_.sy[owner]
    x = sx + (table_.ex[owner] - sx) * fraction
    y = sy + (table_.ey[owner] - sy) * fraction
    arc = table_.arc[owner]
    if arc.any():
        signed = np.where(table_.clockwise, -table_.turn, table_.turn)[owner]
        angle = table_.a0[owner] + signed * fraction
        x = np.where(arc, table_.cx[owner] + table_.radius[owner] * np.cos(angle), x)
        y = np.where(arc, table_.cy[owner] + table_.radius[owner] * np.sin(angle), y)
    return Samples(np.column_stack((x, y)), tuple(starts), path.elements, owner, fraction)


def joined(tables: Sequence[Elements]) -> Elements:
    """Several tables as one, in order."""
    return Elements(*(np.concatenate([getattr(t, name) for t in tables]) for name in _NAMES))


def spliced(table: Elements, start: int, end: int, rows: Elements) -> Elements:
    """`table` with its rows `start` to `end` (not included) replaced by `rows`."""
    return Elements(
        *(
            np.concatenate((getattr(table, n)[:start], getattr(rows, n), getattr(table, n)[end:]))
            for n in _NAMES
        )
    )


_NAMES = ("sx", "sy", "ex", "ey", "cx", "cy", "arc", "clockwise", "radius", "a0", "turn")
