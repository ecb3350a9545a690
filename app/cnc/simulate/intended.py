"""The intended part: what each block of the program means to remove, on the simulation's grid.

Verify measures the simulated part against this, not against bare contours: material
removed where no block means to remove it is a gouge, and material left where a block
means to clear it is rest material. A pocket beside an outside profile, a hole drilled
through a wall's band, a slot the program cuts are the program's intent, not damage.

What a block means to remove (its *waste*), each to its depth:

- a hole: the cylinder of its tool's diameter;
- a CIRCLE or FRAME routine: inside its finished contour for INSIDE, IN/TAN and POCKET,
  outside it for OUTSIDE and OUT/TAN (an external thread's minor diameter as an OUTSIDE
  circle), to the lowest it may cut (`Routine.deepest`: a thread's Z DN);
- an irregular POCKET: inside its wall, outside its islands;
- a closed compensated contour: the whole side the tool is on (outside an outer profile,
  inside an inner one);
- an open compensated contour or an uncompensated one (a slot): the tool's swath.

Bosses (OUTSIDE routines, outer profiles) keep each other: a boss's waste is never another
boss's inside. Of nested ones the part at each depth is the smallest boss cut to that
depth: a boss that holds another cut at least as deep is its roughing and drops out (its
wall is no finished surface), one cut deeper is the step the smaller stands on. A boss
standing in a pocket (a CIRCLE/FRAME INSIDE or IN/TAN, a closed contour cut from inside,
an irregular POCKET's wall) is kept by the pocket's wall pass, and its own waste ends at
that wall; a CIRCLE/FRAME POCKET clears it all the same.

Each waste is widened by the tolerance (a cut that meets the exact edge of one is no
gouge). `intended` draws them all at once: the shapes of one depth are filled together as a
union (scanlines with winding numbers, so thousands of a LOOP's pockets or a bolt circle's
holes cost their outlines' crossings of the rows plus one pass over the grid), and the
floor is the lowest depth over the unions. `clearing` draws what CIRCLE/FRAME POCKETs must
clear, the same way. Lengths in nm.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import pyclipper

from app.cnc.plane import Element, Path, signed_area
from app.cnc.pocketing.regions import (
    Ring,
    area,
    difference,
    offset,
    path_points,
    sweep_lines,
)
from app.cnc.simulate.programmed import Contour, PocketArea, Programmed, Routine
from app.cnc.simulate.segments import BOOL, F64
from app.cnc.simulate.stock import Grid

Pt = tuple[float, float]


def window_cells(grid: Grid, x0: float, y0: float, x1: float, y1: float) -> tuple[slice, slice]:
    """The rows and columns of cells whose centres lie in [x0, x1] × [y0, y1]."""
    res = grid.resolution
    j0 = max(0, math.ceil((x0 - grid.x0) / res - 0.5))
    j1 = min(grid.nx, math.floor((x1 - grid.x0) / res - 0.5) + 1)
    i0 = max(0, math.ceil((y0 - grid.y0) / res - 0.5))
    i1 = min(grid.ny, math.floor((y1 - grid.y0) / res - 0.5) + 1)
    return slice(i0, max(i0, i1)), slice(j0, max(j0, j1))


def window(grid: Grid, x0: float, y0: float, x1: float, y1: float) -> tuple[slice, slice, F64, F64]:
    """`window_cells`, and the centres' coordinates as (rows, columns) arrays."""
    rows, cols = window_cells(grid, x0, y0, x1, y1)
    xs = grid.x0 + (np.arange(cols.start, cols.stop) + 0.5) * grid.resolution
    ys = grid.y0 + (np.arange(rows.start, rows.stop) + 0.5) * grid.resolution
    qx, qy = np.meshgrid(xs, ys)
    return rows, cols, qx, qy


def winding(grid: Grid, rings: Sequence[Sequence[Pt] | F64]) -> npt.NDArray[np.int32]:
    """Each cell centre's winding number over the closed rings (int32, (ny, nx)): for
    counter-clockwise rings, how many of them hold it. By scanlines, every ring's edges at
    once: the cost is the edges' crossings of the rows plus one pass over the cells."""
    arrays = [np.asarray(ring, dtype=np.float64).reshape(-1, 2) for ring in rings]
    arrays = [a for a in arrays if len(a) >= 3]
    if not arrays:
        return np.zeros((grid.ny, grid.nx), dtype=np.int32)
    pts = np.concatenate(arrays)
    sizes = np.array([len(a) for a in arrays])
    # Each vertex's next one round its own ring.
    nxt = np.arange(1, len(pts) + 1)
    ends = np.cumsum(sizes)
    nxt[ends - 1] = ends - sizes
    ax, ay = pts[:, 0], pts[:, 1]
    bx, by = ax[nxt], ay[nxt]
    res = grid.resolution
    lo, hi = np.minimum(ay, by), np.maximum(ay, by)
    # Rows whose centre y is in [lo, hi): each edge crosses those.
    first = np.clip(np.ceil((lo - grid.y0) / res - 0.5), 0, grid.ny).astype(np.int64)
    last = np.clip(np.ceil((hi - grid.y0) / res - 0.5), 0, grid.ny).astype(np.int64)
    counts = np.maximum(last - first, 0)
    total = int(counts.sum())
    if not total:
        return np.zeros((grid.ny, grid.nx), dtype=np.int32)
    edge = np.repeat(np.arange(len(pts)), counts)
    row = np.repeat(first, counts) + (
        np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)
    )
    yc = grid.y0 + (row + 0.5) * res
    t = (yc - ay[edge]) / (by[edge] - ay[edge])
    x = ax[edge] + t * (bx[edge] - ax[edge])
    up = np.where(by[edge] > ay[edge], 1, -1).astype(np.int32)
    # A crossing counts for the cells whose centres lie right of it: it toggles at the
    # first cell at or right of x. An upward edge (the right side of a counter-clockwise
    # ring) adds one to the cells left of it, so the count from the left is its negative.
    col = np.clip(np.ceil((x - grid.x0) / res - 0.5), 0, grid.nx).astype(np.int64)
    width = grid.nx + 1
    # int32 throughout, summed in place: on a 2000 x 2000 grid the float64 of a weighted
    # bincount was most of the cost.
    toggles = np.zeros(grid.ny * width, dtype=np.int32)
    np.add.at(toggles, row * width + col, up)
    table = toggles.reshape(grid.ny, width)
    np.cumsum(table, axis=1, dtype=np.int32, out=table)
    np.negative(table, out=table)
    counted: npt.NDArray[np.int32] = table[:, : grid.nx]
    return counted


def disc_rings(centres: F64, radius: float, chord: float) -> F64:
    """Counter-clockwise polygons holding discs of `radius` about each of `centres`
    ((k, 2) nm), within `chord`: a (k, n, 2) array."""
    unit = np.asarray(circle_ring(0.0, 0.0, radius, chord, outward=True))
    placed: F64 = centres[:, None, :] + unit[None, :, :]
    return placed


def fill(grid: Grid, rings: Sequence[Sequence[Pt]]) -> BOOL:
    """Which cell centres a closed ring holds (either direction; several rings: any
    cell whose winding number is not 0)."""
    held: BOOL = winding(grid, rings) != 0
    return held


def circle_ring(cx: float, cy: float, radius: float, chord: float, outward: bool) -> list[Pt]:
    """A counter-clockwise polygon of a circle within `chord`: around it (`outward`, the
    polygon holds the circle) or inside it (the circle holds the polygon)."""
    if radius <= 0:
        return []
    n = max(12, math.ceil(math.pi / math.acos(max(-1.0, 1 - min(chord / radius, 2.0)))))
    r = radius / math.cos(math.pi / n) if outward else radius
    return [
        (cx + r * math.cos(2 * math.pi * k / n), cy + r * math.sin(2 * math.pi * k / n))
        for k in range(n)
    ]


def frame_ring(
    x0: float, y0: float, x1: float, y1: float, corner: float, chord: float, outward: bool
) -> list[Pt]:
    """A counter-clockwise polygon of a rectangle with round corners of `corner` (0:
    square), within `chord` like `circle_ring`."""
    if x1 <= x0 or y1 <= y0:
        return []
    c = min(corner, (x1 - x0) / 2, (y1 - y0) / 2)
    if c <= 0:
        return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    n = max(3, math.ceil((math.pi / 2) / math.acos(max(-1.0, 1 - min(chord / c, 2.0)))))
    r = c / math.cos(math.pi / (4 * n)) if outward else c
    points: list[Pt] = []
    for (cx, cy), start in (
        ((x1 - c, y0 + c), -math.pi / 2),
        ((x1 - c, y1 - c), 0.0),
        ((x0 + c, y1 - c), math.pi / 2),
        ((x0 + c, y0 + c), math.pi),
    ):
        if outward:  # the polygon's vertices off the arc, its edges tangent to it
            points.append((cx + c * math.cos(start), cy + c * math.sin(start)))
            points += [
                (cx + r * math.cos(a), cy + r * math.sin(a))
                for a in (start + (math.pi / 2) * (2 * k + 1) / (2 * n) for k in range(n))
            ]
            end = start + math.pi / 2
            points.append((cx + c * math.cos(end), cy + c * math.sin(end)))
        else:
            points += [
                (
                    cx + c * math.cos(start + (math.pi / 2) * k / n),
                    cy + c * math.sin(start + (math.pi / 2) * k / n),
                )
                for k in range(n + 1)
            ]
    return points


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


def distance_to(contours: Sequence[Contour], qx: F64, qy: F64) -> F64:
    """Each point's distance (nm) to the nearest element of any of `contours`."""
    nearest = np.full(qx.shape, np.inf)
    for contour in contours:
        starts = [contour.start] + [e.end for e in contour.elements[:-1]]
        for start, element in zip(starts, contour.elements, strict=True):
            nearest = np.minimum(nearest, element_measures(qx, qy, start, element)[0])
    return nearest


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
    """The lowest Z the program means to cut each cell to (`floor`, (ny, nx) nm; the
    stock's top where no block means to cut), and the bosses that rough a smaller one
    out (`roughing`: indices of `Programmed.routines`, `contours` the same for outer
    profiles): their walls are no finished surface."""

    floor: F64
    roughing: frozenset[int] = frozenset()
    contours: frozenset[int] = frozenset()


def _group(groups: dict[int, list[Any]], depth: int, ring: Sequence[Pt] | F64) -> None:
    if len(ring) >= 3:
        groups.setdefault(depth, []).append(ring)


@dataclass
class _Shape:
    """A boss (its outside is waste) or an enclosure (its inside is waste), to `depth`:
    `rings` its waste's outline (nm, moved by the tolerance), `form` for a boss what its
    part reaches out to (its rings, or an external thread's major diameter), `box` and
    `form_box` their bounds (x0, y0, x1, y1), `clears` for an enclosure that cleans all of
    its inside out (a POCKET) whatever stands there."""

    depth: int
    rings: list[Any]
    form: list[Any]
    box: tuple[float, float, float, float]
    form_box: tuple[float, float, float, float]
    clears: bool = False
    source: tuple[str, int] = ("", -1)  # ("routine" or "contour", its index)


def _bounds(rings: Sequence[Any]) -> tuple[float, float, float, float]:
    points = np.concatenate([np.asarray(r, dtype=np.float64).reshape(-1, 2) for r in rings])
    lo, hi = points.min(axis=0), points.max(axis=0)
    return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])


def _shape(
    depth: int,
    rings: list[Any],
    form: list[Any] | None = None,
    clears: bool = False,
    source: tuple[str, int] = ("", -1),
) -> _Shape:
    box = _bounds(rings)
    if form is None:
        return _Shape(depth, rings, rings, box, box, clears, source)
    return _Shape(depth, rings, form, box, _bounds(form), clears, source)


def _within(boxes: F64, box: tuple[float, float, float, float], slack: float) -> BOOL:
    """Which of `boxes` ((n, 4): x0, y0, x1, y1) lie inside `box` grown by `slack`."""
    held: BOOL = (
        (boxes[:, 0] >= box[0] - slack)
        & (boxes[:, 1] >= box[1] - slack)
        & (boxes[:, 2] <= box[2] + slack)
        & (boxes[:, 3] <= box[3] + slack)
    )
    return held


def _holds(outer: Sequence[Any], inner: Sequence[Any], chord: float) -> bool:
    """Whether the rings `outer` hold all of the rings `inner`: what is left of them
    outside is no more than polygons of one curve drawn `chord` apart leave along their
    edges."""
    held = [ccw_ring(r) for r in inner]
    left = difference(held, [ccw_ring(r) for r in outer])
    edges = sum(
        float(np.hypot(*np.diff(np.asarray([*r, r[0]], dtype=np.float64), axis=0).T).sum())
        for r in held
    )
    return abs(area(left)) <= chord * edges


def intended(grid: Grid, geometry: Programmed, tol: int, default_radius: int) -> Intent:
    """What the program means to remove, on `grid` (see the module's note)."""
    floor = np.full((grid.ny, grid.nx), float(grid.stock.top))
    chord = max(min(grid.resolution / 8, tol / 2), 100.0)
    inside: dict[int, list[Any]] = {}
    # Shapes whose outside is waste (bosses: OUTSIDE routines, outer profiles), each as its
    # rings (an offset may part one); shapes whose inside is waste and that may hold them.
    bosses: list[_Shape] = []
    enclosures: list[_Shape] = []
    # Holes of one tool and depth (a LOOP's, a bolt circle's) as one array of discs.
    discs: dict[tuple[int, int], list[tuple[int, int]]] = {}
    for hole in geometry.holes:
        discs.setdefault((hole.depth, hole.radius or default_radius), []).append((hole.x, hole.y))
    for (depth, radius), points in discs.items():
        array = disc_rings(np.asarray(points, dtype=np.float64), radius + tol, chord)
        inside.setdefault(depth, []).extend(list(array))
    for index, routine in enumerate(geometry.routines):
        deepest = routine.deepest  # its waste goes as low as it may cut
        if deepest is None:
            continue
        grow = tol if routine.inside else -tol
        shape = routine_ring(routine, grow, chord, outward=routine.inside)
        if len(shape) < 3:
            continue
        if routine.inside:
            enclosures.append(_shape(deepest, [shape], clears=routine.pocket))
        else:
            form = None
            if routine.crest:  # a thread: the shank turned for it holds its crests
                crest = dataclasses.replace(routine, radius=routine.crest)
                form = [routine_ring(crest, grow, chord, outward=False)]
            bosses.append(_shape(deepest, [shape], form, source=("routine", index)))
    for index, contour in enumerate(geometry.contours):
        if contour.depth is None or any(contour in p.contours for p in geometry.pockets):
            continue
        depth = _deepest(contour)
        if is_closed(contour):
            ring = path_points(Path(contour.start, contour.elements), chord)
            if part_inside(contour):
                shrunk = offset([ccw_ring(ring)], -tol, chord)
                if shrunk:
                    pieces = [[(float(x), float(y)) for x, y in piece] for piece in shrunk]
                    bosses.append(_shape(depth, pieces, source=("contour", index)))
            else:
                grown = offset([ccw_ring(ring)], tol, chord)
                pieces = [[(float(x), float(y)) for x, y in piece] for piece in grown]
                if [p for p in pieces if len(p) >= 3]:
                    enclosures.append(_shape(depth, [p for p in pieces if len(p) >= 3]))
        elif contour.swept:
            radius = (contour.tool_radius or default_radius) + tol
            for swath in sweep_lines(contour.swept, radius, chord):
                _group(inside, depth, [(float(x), float(y)) for x, y in swath])
    for slot in geometry.slots:
        if slot.depth is not None and slot.swept:
            radius = (slot.tool_radius or default_radius) + tol
            for swath in sweep_lines(slot.swept, radius, chord):
                _group(inside, _deepest(slot), [(float(x), float(y)) for x, y in swath])
    roughings = _roughings(bosses, chord)
    rough = [bosses[k].source for k in sorted(roughings)]
    bosses = [boss for k, boss in enumerate(bosses) if k not in roughings]
    # An irregular POCKET's wall holds a boss too; its islands are already kept.
    walls = [
        _shape(pocket.depth, [[(float(x), float(y)) for x, y in r] for r in grown], clears=True)
        for pocket in geometry.pockets
        if pocket.depth is not None
        for grown in [_pocket_wall(pocket, tol, chord)]
        if grown
    ]
    holders = enclosures + walls
    # Which enclosures hold each boss: a boss standing in a pocket.
    around = _around(bosses, holders, chord)
    for k, enclosure in enumerate(enclosures):
        held = [b.rings for b, holding in zip(bosses, around, strict=True) if k in holding]
        if enclosure.clears or not held:
            for ring in enclosure.rings:
                _group(inside, enclosure.depth, ring)
            continue
        # A pocket's wall pass round a boss: its inside is waste, the boss is not.
        waste = fill(grid, enclosure.rings) & ~(winding(grid, [r for h in held for r in h]) > 0)
        np.minimum(floor, float(enclosure.depth), out=floor, where=waste)
    for depth, rings in sorted(inside.items()):
        np.minimum(floor, float(depth), out=floor, where=winding(grid, rings) > 0)
    _outside_wastes(grid, bosses, around, holders, floor)
    for pocket in geometry.pockets:
        if pocket.depth is not None:
            cleared = _pocket_area(grid, pocket, tol, chord)
            np.minimum(floor, float(pocket.depth), out=floor, where=cleared)
    return Intent(
        floor,
        frozenset(k for kind, k in rough if kind == "routine"),
        frozenset(k for kind, k in rough if kind == "contour"),
    )


def _around(bosses: list[_Shape], holders: list[_Shape], chord: float) -> list[tuple[int, ...]]:
    """For each boss, the enclosures among `holders` that hold it (their indices)."""
    around: list[list[int]] = [[] for _ in bosses]
    if not bosses or not holders:
        return [()] * len(bosses)
    boxes = np.array([boss.box for boss in bosses])
    for k, holder in enumerate(holders):
        for i in np.flatnonzero(_within(boxes, holder.box, chord)).tolist():
            if _holds(holder.rings, bosses[i].rings, chord):
                around[i].append(k)
    return [tuple(a) for a in around]


def _roughings(bosses: list[_Shape], chord: float) -> set[int]:
    """Which of the bosses are roughings (their indices). A boss that holds another cut at
    least as deep (a CIRCLE OUTSIDE DIA 10.5 before DIA 10, a shank turned before its
    thread is milled) is roughing, its wall no finished surface; the smaller one's waste
    takes it: the part is the smallest boss the program cuts to that depth. Of equal
    bosses the last is kept. A larger boss cut deeper than a smaller one it holds is the
    step that one stands on (a stepped shaft), and stays."""
    rough: set[int] = set()
    if len(bosses) < 2:
        return rough
    forms = np.array([boss.form_box for boss in bosses])
    depths = np.array([boss.depth for boss in bosses])
    for i, outer in enumerate(bosses):
        candidates = np.flatnonzero(_within(forms, outer.box, chord) & (depths <= outer.depth))
        for j in candidates.tolist():
            inner = bosses[j]
            if j == i or not _holds(outer.rings, inner.form, chord):
                continue
            same = inner.depth == outer.depth and _holds(inner.rings, outer.form, chord)
            if not (same and j < i):
                rough.add(i)
                break
    return rough


def _outside_wastes(
    grid: Grid,
    bosses: list[_Shape],
    around: list[tuple[int, ...]],
    holders: list[_Shape],
    floor: F64,
) -> None:
    """Lower `floor` where outer profiles and OUTSIDE routines (bosses) mean to cut: the
    outside of each, to its depth, but never into another boss, nor past the wall of an
    enclosure that holds it (`around`, indices into `holders`: a boss standing in a
    pocket). The waste at depth d is outside every boss cut no deeper than d, and outside
    every deeper boss that stands apart from those (two bosses side by side keep each
    other); a deeper boss that holds a shallower one is the step it stands on, and its
    top between them is waste."""
    if not bosses:
        return
    boxes = np.array([boss.box for boss in bosses])
    depths = np.array([boss.depth for boss in bosses])
    for depth in sorted(set(depths.tolist())):
        level = depths >= depth  # this depth's bosses and the shallower ones
        b = boxes[level]
        deeper = np.flatnonzero(~level)
        apart = [
            k
            for k in deeper.tolist()
            if not (
                (boxes[k, 0] <= b[:, 2])
                & (b[:, 0] <= boxes[k, 2])
                & (boxes[k, 1] <= b[:, 3])
                & (b[:, 1] <= boxes[k, 3])
            ).any()
        ]
        kept = [ring for k in np.flatnonzero(level).tolist() + apart for ring in bosses[k].rings]
        waste = ~(winding(grid, kept) > 0)
        # Bosses of this depth standing in pockets: their waste ends at the pockets' walls.
        bounds = {around[k] for k in np.flatnonzero(depths == depth).tolist()}
        if () not in bounds:
            within = np.zeros_like(waste)
            for holding in bounds:
                inner = np.ones_like(waste)
                for k in holding:
                    inner &= fill(grid, holders[k].rings)
                within |= inner
            waste &= within
        np.minimum(floor, float(depth), out=floor, where=waste)


def clearing(grid: Grid, routines: Sequence[Routine], tol: int) -> tuple[F64, BOOL]:
    """What CIRCLE/FRAME POCKETs must clear: the floor each cell must come down to (nm)
    and where (every cell more than `tol` inside a pocket's finished contour, its corners
    as programmed: a tool too big for them leaves material there)."""
    floor = np.full((grid.ny, grid.nx), -np.inf)
    where = np.zeros((grid.ny, grid.nx), dtype=bool)
    chord = max(min(grid.resolution / 8, tol / 2), 100.0)
    groups: dict[int, list[Any]] = {}
    for routine in routines:
        if routine.pocket and routine.depth is not None and routine.tool_radius > 0:
            _group(groups, routine.depth, routine_ring(routine, -tol, chord, outward=False))
    for depth, rings in sorted(groups.items(), reverse=True):
        mask = winding(grid, rings) > 0
        # The deepest pocket over a cell decides how low it must be.
        np.copyto(floor, float(depth), where=mask)
        where |= mask
    return floor, where


def routine_ring(routine: Routine, grow: float, chord: float, outward: bool) -> F64:
    """A routine's finished contour moved `grow` outward (inward when negative), as a
    counter-clockwise polygon within `chord` (see `circle_ring`): an (n, 2) array. A LOOP's
    copies of one routine share the polygon, moved."""
    if not routine.is_frame:
        unit = _unit_ring(False, routine.radius, 0, 0, grow, chord, outward)
        moved: F64 = unit + np.asarray(routine.centre)
        return moved
    unit = _unit_ring(
        True, routine.width, routine.height, routine.corner_radius, grow, chord, outward
    )
    placed: F64 = unit + np.asarray(routine.corner)
    return placed


@functools.lru_cache(maxsize=256)
def _unit_ring(
    is_frame: bool, a: int, b: int, corner: int, grow: float, chord: float, outward: bool
) -> F64:
    """A circle of radius `a` about the origin, or an `a` × `b` frame with its lower-left
    corner there, grown by `grow` (read only: shared)."""
    if not is_frame:
        ring = np.asarray(circle_ring(0.0, 0.0, a + grow, chord, outward), dtype=np.float64)
    else:
        ring = np.asarray(
            frame_ring(-grow, -grow, a + grow, b + grow, max(corner + grow, 0.0), chord, outward),
            dtype=np.float64,
        )
    ring = ring.reshape(-1, 2)
    ring.flags.writeable = False
    return ring


def _deepest(contour: Contour) -> int:
    """A contour's lowest Z DN: the DRILL's, or a MILL block's own where it goes deeper."""
    assert contour.depth is not None
    return min([contour.depth] + [e.z_dn for e in contour.elements if e.z_dn is not None])


def ccw_ring(points: Sequence[Pt]) -> Ring:
    """Integer points, counter-clockwise (Clipper grows those by a positive offset)."""
    ring = [(round(x), round(y)) for x, y in points]
    return ring if pyclipper.Orientation(ring) else ring[::-1]


def _pocket_wall(pocket: PocketArea, tol: int, chord: float) -> list[Ring]:
    """A POCKET's wall moved `tol` outward, as rings."""
    contour = pocket.contours[0]
    return offset([ccw_ring(path_points(Path(contour.start, contour.elements), chord))], tol, chord)


def _pocket_area(grid: Grid, pocket: PocketArea, tol: int, chord: float) -> BOOL:
    """Inside a POCKET's wall and outside its islands, each edge moved `tol` outward of
    the area."""
    wall, *islands = (
        ccw_ring(path_points(Path(c.start, c.elements), chord)) for c in pocket.contours
    )
    area = fill(grid, offset([wall], tol, chord))
    for island in islands:
        area &= ~fill(grid, offset([island], -tol, chord))
    return area


def centres(grid: Grid) -> tuple[F64, F64]:
    """The cell centres' X and Y (nm), as (ny, nx) arrays."""
    xs = grid.x0 + (np.arange(grid.nx) + 0.5) * grid.resolution
    ys = grid.y0 + (np.arange(grid.ny) + 0.5) * grid.resolution
    qx, qy = np.meshgrid(xs, ys)
    return qx, qy
