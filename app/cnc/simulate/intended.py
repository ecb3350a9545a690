"""The intended part: what each block of the program means to remove, on the simulation's grid.

Verify measures the simulated part against this, not against bare contours: a cut inside a
finished contour's band is a gouge only where no other block means to remove that material
(a pocket beside an outside profile, a hole drilled through a wall's band, an island's
pocket are the program's intent, not damage).

What a block means to remove (its *waste*), each to its depth and owned by the sequence
(the DRILL that starts it) or hole block that cuts it:

- a hole: the cylinder of its tool's diameter;
- a CIRCLE or FRAME routine: inside its finished contour for INSIDE, IN/TAN and POCKET,
  outside it for OUTSIDE and OUT/TAN;
- an irregular POCKET: inside its wall, outside its islands;
- a closed compensated contour: the whole side the tool is on (inside an inner profile,
  outside an outer one);
- an open compensated contour or an uncompensated one (a slot): the tool's swath.

Each waste is widened by the tolerance, so a cut that reaches the exact edge of what
another block removes is not a gouge. `Intent.allowed_besides(owner)` is, for each cell,
the lowest Z some *other* owner means to cut there (the stock's top where none does): a
surface's own sequence cannot excuse a cut into that surface. Lengths in nm.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pyclipper

from app.cnc.mill import Element, Path, signed_area
from app.cnc.pocketing.regions import Ring, offset, path_points, sweep_lines
from app.cnc.simulate.programmed import Contour, PocketArea, Programmed, Routine
from app.cnc.simulate.segments import BOOL, F64
from app.cnc.simulate.stock import Grid

Pt = tuple[float, float]


def window(grid: Grid, x0: float, y0: float, x1: float, y1: float) -> tuple[slice, slice, F64, F64]:
    """The rows and columns of cells whose centres lie in [x0, x1] × [y0, y1], and the
    centres' coordinates as (rows, columns) arrays."""
    res = grid.resolution
    j0 = max(0, math.ceil((x0 - grid.x0) / res - 0.5))
    j1 = min(grid.nx, math.floor((x1 - grid.x0) / res - 0.5) + 1)
    i0 = max(0, math.ceil((y0 - grid.y0) / res - 0.5))
    i1 = min(grid.ny, math.floor((y1 - grid.y0) / res - 0.5) + 1)
    j1, i1 = max(j0, j1), max(i0, i1)
    xs = grid.x0 + (np.arange(j0, j1) + 0.5) * res
    ys = grid.y0 + (np.arange(i0, i1) + 0.5) * res
    qx, qy = np.meshgrid(xs, ys)
    return slice(i0, i1), slice(j0, j1), qx, qy


def fill(grid: Grid, rings: Sequence[Sequence[Pt]]) -> BOOL:
    """Which cell centres of the whole grid the rings hold (even-odd), by scanlines: the
    cost is the rings' crossings of the rows plus one pass over the cells."""
    res = grid.resolution
    rows_list: list[np.ndarray] = []
    xs_list: list[np.ndarray] = []
    for ring in rings:
        if len(ring) < 3:
            continue
        pts = np.asarray(ring, dtype=np.float64)
        ax, ay = pts[:, 0], pts[:, 1]
        bx, by = np.roll(ax, -1), np.roll(ay, -1)
        lo, hi = np.minimum(ay, by), np.maximum(ay, by)
        # Rows whose centre y is in [lo, hi): each edge crosses those.
        first = np.ceil((lo - grid.y0) / res - 0.5).astype(np.int64)
        last = np.ceil((hi - grid.y0) / res - 0.5).astype(np.int64)  # exclusive
        first = np.clip(first, 0, grid.ny)
        last = np.clip(last, 0, grid.ny)
        counts = np.maximum(last - first, 0)
        if not counts.any():
            continue
        edge = np.repeat(np.arange(len(pts)), counts)
        starts = np.repeat(first, counts)
        offsets = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
        row = starts + offsets
        yc = grid.y0 + (row + 0.5) * res
        t = (yc - ay[edge]) / (by[edge] - ay[edge])
        rows_list.append(row)
        xs_list.append(ax[edge] + t * (bx[edge] - ax[edge]))
    inside = np.zeros((grid.ny, grid.nx), dtype=bool)
    if not rows_list:
        return inside
    row = np.concatenate(rows_list)
    xcross = np.concatenate(xs_list)
    # Cells left of a crossing: centres < x. Toggle at the first cell right of it.
    col = np.clip(np.ceil((xcross - grid.x0) / res - 0.5), 0, grid.nx).astype(np.int64)
    toggles = np.zeros((grid.ny, grid.nx + 1), dtype=np.int32)
    np.add.at(toggles, (row, col), 1)
    # Crossings at or left of a cell's column, counted from the left: odd = inside.
    np.cumsum(toggles, axis=1, out=toggles)
    inside[:] = (toggles[:, : grid.nx] & 1).astype(bool)
    return inside


def element_measures(qx: F64, qy: F64, start: Pt, element: Element) -> tuple[F64, F64, BOOL]:
    """(distance, signed distance to the left of travel, beside the element's interior)
    of each point to a contour element."""
    sx, sy = start
    ex, ey = element.end
    if element.centre is None:
        dx, dy = ex - sx, ey - sy
        length = math.hypot(dx, dy) or 1.0
        t = ((qx - sx) * dx + (qy - sy) * dy) / (length * length)
        left = (dx * (qy - sy) - dy * (qx - sx)) / length
        tc = np.clip(t, 0.0, 1.0)
        dist = np.hypot(qx - (sx + tc * dx), qy - (sy + tc * dy))
        return dist, left, (t >= 0) & (t <= 1)
    cx, cy = element.centre
    ra = math.hypot(sx - cx, sy - cy)
    rho = np.hypot(qx - cx, qy - cy)
    a0 = math.atan2(sy - cy, sx - cx)
    a1 = math.atan2(ey - cy, ex - cx)
    sweep = ((a0 - a1) if element.clockwise else (a1 - a0)) % (2 * math.pi) or 2 * math.pi
    ap = np.arctan2(qy - cy, qx - cx)
    along = ((a0 - ap) if element.clockwise else (ap - a0)) % (2 * math.pi)
    interior = along <= sweep
    ends = np.minimum(np.hypot(qx - sx, qy - sy), np.hypot(qx - ex, qy - ey))
    dist = np.where(interior, np.abs(rho - ra), ends)
    left = (rho - ra) if element.clockwise else (ra - rho)
    return dist, left, interior


def routine_sdf(routine: Routine, qx: F64, qy: F64, corner: float) -> F64:
    """Signed distance (nm; negative inside) to the routine's finished contour, a frame's
    corners rounded to `corner` where that is more than its own corner radius."""
    if not routine.is_frame:
        return np.hypot(qx - routine.centre[0], qy - routine.centre[1]) - routine.radius
    hx, hy = routine.width / 2, routine.height / 2
    cx, cy = routine.corner[0] + hx, routine.corner[1] + hy
    r = min(max(corner, routine.corner_radius), hx, hy)
    px = np.abs(qx - cx) - (hx - r)
    py = np.abs(qy - cy) - (hy - r)
    outside = np.hypot(np.maximum(px, 0), np.maximum(py, 0))
    return outside + np.minimum(np.maximum(px, py), 0) - r


def is_closed(contour: Contour) -> bool:
    """A contour that ends where it starts (within a nanometre)."""
    return math.dist(contour.start, contour.elements[-1].end) < 1.0


def part_inside(contour: Contour) -> bool:
    """For a closed contour: the part is inside it (an outer profile), not outside (an
    inner profile, a pocket's wall)."""
    ccw = signed_area(Path(contour.start, contour.elements)) > 0
    return contour.part_left == ccw


@dataclass
class Intent:
    """The lowest Z each cell is meant to be cut to, twice: `first` over every owner (and
    `owner`, whose it is) and `second` over every owner but that one."""

    top: float
    first: F64
    owner: np.ndarray
    second: F64

    @staticmethod
    def empty(grid: Grid) -> Intent:
        shape = (grid.ny, grid.nx)
        top = float(grid.stock.top)
        return Intent(top, np.full(shape, top), np.zeros(shape, np.int32), np.full(shape, top))

    def add(self, owner: int, depth: float, where: BOOL, rows: slice, cols: slice) -> None:
        """Owner `owner` means to cut to `depth` in the cells `where` of the window."""
        first = self.first[rows, cols]
        second = self.second[rows, cols]
        own = self.owner[rows, cols]
        mine = where & (own == owner)
        np.minimum(first, depth, out=first, where=mine)
        takes = where & ~mine & (depth < first)
        np.copyto(second, first, where=takes)
        np.copyto(first, depth, where=takes)
        np.copyto(own, owner, where=takes)
        others = where & ~mine & ~takes
        np.minimum(second, depth, out=second, where=others)

    def allowed_besides(self, owner: int, rows: slice, cols: slice) -> F64:
        """The lowest Z any owner but `owner` means to cut each cell of the window to."""
        first = self.first[rows, cols]
        return np.where(self.owner[rows, cols] == owner, self.second[rows, cols], first)


def intended(grid: Grid, geometry: Programmed, tol: int, default_radius: int) -> Intent:
    """What the program means to remove, on `grid` (see the module's note)."""
    intent = Intent.empty(grid)
    everywhere = (slice(0, grid.ny), slice(0, grid.nx))
    chord = max(min(grid.resolution / 8, tol / 2), 100.0)
    for hole in geometry.holes:
        r = (hole.radius or default_radius) + tol
        rows, cols, qx, qy = window(grid, hole.x - r, hole.y - r, hole.x + r, hole.y + r)
        if qx.size:
            intent.add(hole.block, hole.depth, np.hypot(qx - hole.x, qy - hole.y) <= r, rows, cols)
    for routine in geometry.routines:
        if routine.depth is None:
            continue
        if routine.inside:
            x0, y0, x1, y1 = _routine_box(routine)
            rows, cols, qx, qy = window(grid, x0 - tol, y0 - tol, x1 + tol, y1 + tol)
            if qx.size:
                intent.add(
                    routine.drill,
                    routine.depth,
                    routine_sdf(routine, qx, qy, 0.0) <= tol,
                    rows,
                    cols,
                )
        else:
            qx, qy = _centres(grid)
            intent.add(
                routine.drill, routine.depth, routine_sdf(routine, qx, qy, 0.0) >= -tol, *everywhere
            )
    for pocket in geometry.pockets:
        if pocket.depth is not None:
            intent.add(
                pocket.contours[0].drill,
                pocket.depth,
                _pocket_area(grid, pocket, tol, chord),
                *everywhere,
            )
    for contour in geometry.contours:
        if contour.depth is None or any(contour in p.contours for p in geometry.pockets):
            continue
        if is_closed(contour):
            ring = path_points(Path(contour.start, contour.elements), chord)
            if part_inside(contour):
                where = ~fill(grid, offset([_int_ring(ring)], -tol, chord))
            else:
                where = fill(grid, offset([_int_ring(ring)], tol, chord))
            intent.add(contour.drill, contour.depth, where, *everywhere)
        elif contour.swept:
            radius = (contour.tool_radius or default_radius) + tol
            intent.add(
                contour.drill,
                contour.depth,
                fill(grid, sweep_lines(contour.swept, radius, chord)),
                *everywhere,
            )
    for slot in geometry.slots:
        if slot.depth is not None and slot.swept:
            radius = (slot.tool_radius or default_radius) + tol
            intent.add(
                slot.drill,
                slot.depth,
                fill(grid, sweep_lines(slot.swept, radius, chord)),
                *everywhere,
            )
    return intent


def _centres(grid: Grid) -> tuple[F64, F64]:
    xs = grid.x0 + (np.arange(grid.nx) + 0.5) * grid.resolution
    ys = grid.y0 + (np.arange(grid.ny) + 0.5) * grid.resolution
    qx, qy = np.meshgrid(xs, ys)
    return qx, qy


def _routine_box(routine: Routine) -> tuple[float, float, float, float]:
    if routine.is_frame:
        x0, y0 = routine.corner
        return x0, y0, x0 + routine.width, y0 + routine.height
    (cx, cy), rad = routine.centre, routine.radius
    return cx - rad, cy - rad, cx + rad, cy + rad


def _int_ring(points: Sequence[Pt]) -> Ring:
    """Integer points, counter-clockwise (Clipper grows those by a positive offset)."""
    ring = [(round(x), round(y)) for x, y in points]
    return ring if pyclipper.Orientation(ring) else ring[::-1]


def _pocket_area(grid: Grid, pocket: PocketArea, tol: int, chord: float) -> BOOL:
    """Inside a POCKET's wall and outside its islands, each edge moved `tol` outward of
    the area."""
    wall, *islands = (
        _int_ring(path_points(Path(c.start, c.elements), chord)) for c in pocket.contours
    )
    area = fill(grid, offset([wall], tol, chord))
    for island in islands:
        area &= ~fill(grid, offset([island], -tol, chord))
    return area
