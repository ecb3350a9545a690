"""Offset regions in integer nanometres, with pyclipper (Clipper 6.4).

Why pyclipper and not shapely: Clipper works on integer coordinates, which are what the
tool path is made of (nanometres, DESIGN.md §2), with exact integer arithmetic for its
topology (no float robustness surprises when passes touch or regions split); its PolyTree
gives outer rings with their holes directly; its round joins take a stated arc tolerance;
and it is small, well kept and made for exactly this job (offsetting and clipping for CAM).
Keeping shapely out of the engine also keeps the tests honest: they measure the pocket with
shapely (GEOS), a different implementation from the one that planned it.

A region is a list of rings (lists of integer points). Clipper's convention, kept here:
outer rings run counter-clockwise (positive area), hole rings clockwise, so the region is
always on the left of a ring's travel. Curved contours become polylines whose chords stay
within `tolerance` nm of the arc (the chordal tolerance the planner states).
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
import numpy.typing as npt
import pyclipper

from app.cnc.cutter import offset_directions
from app.cnc.geometry import arc_sweep
from app.cnc.plane import Element, Path, Pt, add, cross, dot, left_normal, scale, sweep, tangent

IPt = tuple[int, int]
Ring = list[IPt]
TURN_EPS = 1e-9  # a turn (sine of the angle) smaller than this is a tangent joint
Region = Sequence[Sequence[Sequence[int]]]
"""A region as Clipper reads it: our rings of tuples, or Clipper's own answer as it gave it."""
Swept = list[list[list[int]]]
"""Clipper's answer as it gave it (lists of [x, y] lists): the sweeps, read only by Clipper."""


@dataclass(frozen=True)
class Component:
    """One connected piece of a region: its outer ring and the holes in it."""

    outer: Ring
    holes: tuple[Ring, ...]

    @property
    def rings(self) -> list[Ring]:
        return [self.outer, *self.holes]


def arc_steps(radius: float, turn: float, tolerance: float) -> int:
    """How many chords an arc of `radius` turning `turn` radians needs so that no chord is
    farther than `tolerance` from the arc (sagitta)."""
    if radius <= tolerance:
        return max(1, math.ceil(turn / (math.pi / 2)))
    step = 2 * math.acos(1 - tolerance / radius)
    return max(1, math.ceil(turn / step))


def element_points(start: Pt, element: Element, tolerance: float) -> list[Pt]:
    """Points along an element after `start`, ending at its end: chords within `tolerance`."""
    if element.centre is None:
        return [element.end]
    c = element.centre
    radius = math.dist(start, c)
    turn = sweep(start, element)
    n = arc_steps(radius, turn, tolerance)
    a0 = math.atan2(start[1] - c[1], start[0] - c[0])
    signed = -turn if element.clockwise else turn
    # Each angle made once for its cosine and sine (a pass's chords are thousands of
    # points); -turn * i is the same number as -1.0 * turn * i, so the same points.
    angles = [a0 + signed * i / n for i in range(1, n)]
    cx, cy = c
    points = [(cx + radius * math.cos(a), cy + radius * math.sin(a)) for a in angles]
    points.append(element.end)
    return points


def path_points(path: Path, tolerance: float) -> list[Pt]:
    """The start and every chord point of a path (float nm)."""
    points = [path.start]
    current = path.start
    for element in path.elements:
        points += element_points(current, element, tolerance)
        current = element.end
    return points


def to_ring(points: Iterable[Pt]) -> Ring:
    """Integer points with consecutive repeats (and a closing repeat) dropped."""
    ring: Ring = []
    for x, y in points:
        p = (round(x), round(y))
        if not ring or ring[-1] != p:
            ring.append(p)
    if len(ring) > 1 and ring[0] == ring[-1]:
        ring.pop()
    return ring


def polygon(path: Path, tolerance: float) -> Ring:
    """A closed path as a ring of integer points (in its own direction)."""
    return to_ring(path_points(path, tolerance))


def _rings(result: Any) -> list[Ring]:
    # pyclipper answers lists of [x, y] lists of Python ints: tuples made in C, not one
    # Python call per point (this was a tenth of a pocket's planning time).
    return [list(map(tuple, ring)) for ring in result]


def clip(subject: Region, clip_rings: Region, operation: int) -> list[Ring]:
    """A boolean operation (pyclipper.CT_*) of two regions (non-zero fill)."""
    clipper = pyclipper.Pyclipper()
    if subject:
        clipper.AddPaths(subject, pyclipper.PT_SUBJECT, True)
    if clip_rings:
        clipper.AddPaths(clip_rings, pyclipper.PT_CLIP, True)
    if not subject and not clip_rings:
        return []
    try:
        result = clipper.Execute(operation, pyclipper.PFT_NONZERO, pyclipper.PFT_NONZERO)
    except pyclipper.ClipperException:
        return []  # an empty subject: nothing to clip
    return _rings(result)


def union(*regions: Region) -> list[Ring]:
    rings = [ring for region in regions for ring in region]
    return clip(rings, [], pyclipper.CT_UNION) if rings else []


def difference(a: Region, b: Region) -> list[Ring]:
    if not a:
        return []
    return clip(a, b, pyclipper.CT_DIFFERENCE) if b else union(a)


def intersection(a: Region, b: Region) -> list[Ring]:
    if not a or not b:
        return []
    return clip(a, b, pyclipper.CT_INTERSECTION)


def offset(region: Sequence[Ring], delta: float, tolerance: float) -> list[Ring]:
    """The region grown by `delta` nm (shrunk when negative), round joins within
    `tolerance` of the true arcs."""
    return _rings(offset_raw(region, delta, tolerance))


def offset_raw(region: Sequence[Ring], delta: float, tolerance: float) -> Swept:
    """`offset` as Clipper gave it, for a region only handed back to Clipper (making
    tuples of a level's offset points was a sixth of the cleanup search's time)."""
    if not region:
        return []
    offsetter = pyclipper.PyclipperOffset(2.0, float(tolerance))
    offsetter.AddPaths(region, pyclipper.JT_ROUND, pyclipper.ET_CLOSEDPOLYGON)
    return cast(Swept, offsetter.Execute(float(delta)))


def inset(contours: Sequence[Path], d: float, tolerance: float) -> list[Ring]:
    """The region on the left of closed `contours` (nm: a boundary counter-clockwise,
    islands clockwise) shrunk by `d` nm, its arcs within `tolerance`.

    Made from the exact elements, not from their polygons: each contour's raw offset (every
    element moved `d` to its left, `mill.offset_element`, an arc drawn with the chords its
    new radius needs; an arc of `d` about each right-turning corner; the corner itself
    where the moved elements overlap), and the region where those rings wind positively,
    as Clipper's own offset does with a polygon's raw offset. An arc whose radius `d`
    inverts becomes a small loop of negative winding, not the hundreds of crossing chords
    Clipper makes of its polygon: a level of a large pocket costs what its contours hold
    (issue 30), and its edges lie on the true offsets within `tolerance`."""
    rings = [_raw_inset(contour, d, tolerance) for contour in contours]
    rings = [ring for ring in rings if len(ring) > 2]
    if not rings:
        return []
    clipper = pyclipper.Pyclipper()
    clipper.AddPaths(rings, pyclipper.PT_SUBJECT, True)
    return _rings(
        clipper.Execute(pyclipper.CT_UNION, pyclipper.PFT_POSITIVE, pyclipper.PFT_POSITIVE)
    )


def _raw_inset(contour: Path, d: float, tolerance: float) -> list[list[int]]:
    """One closed contour's raw offset `d` to its left (see `inset`), as Clipper reads it
    (lists of [x, y]: only Clipper reads it, and tuples of its points were a third of a
    level's time)."""
    # Each piece: its points, or the number of an arc of `arcs` (all the arcs' points are
    # made in one numpy pass, not one small pass per arc and corner: a level has thousands).
    pieces: list[list[Pt] | int] = []
    arcs: list[_ArcRun] = []
    elements = contour.elements
    starts = [contour.start] + [e.end for e in elements[:-1]]
    turns = corners(contour)
    # Each element moved d to its left as `cutter.offset_element` moves it (the same
    # arithmetic, its directions made once for the contour's every level).
    moves = directions(contour)
    for k, (start, element) in enumerate(zip(starts, elements, strict=True)):
        at_start, at_end = moves[k]
        moved_start, moved_end = (
            add(start, scale(at_start, 1.0 * d)),
            add(element.end, scale(at_end, 1.0 * d)),
        )
        c = element.centre
        if c is None:
            pieces.append([moved_start, moved_end])
        elif math.dist(moved_start, c) < 1.0:
            pieces.append([c])  # an arc of radius d: its offset is its centre
        else:
            radius = math.dist(moved_start, c)
            turn = arc_sweep(moved_start, moved_end, c, element.clockwise)
            a0 = math.atan2(moved_start[1] - c[1], moved_start[0] - c[0])
            signed = -turn if element.clockwise else turn
            n = arc_steps(radius, turn, tolerance)
            pieces.append(len(arcs))
            arcs.append((c[0], c[1], radius, a0, signed, n, 0, n + 1))
        turn, a1 = turns[k]
        corner = element.end
        if turn < -TURN_EPS:  # a right turn: the moved elements part, joined by an arc of d
            n = arc_steps(d, -turn, tolerance)
            if n > 1:  # (its ends, on the moved elements, are theirs)
                pieces.append(len(arcs))
                arcs.append((corner[0], corner[1], d, a1, turn, n, 1, n))
        elif turn > TURN_EPS:  # a left turn: the moved elements overlap; the corner keeps
            pieces.append([corner])  # the winding of their loop (as Clipper does)
    on_arcs, first = _arcs(arcs)
    chunks = [
        on_arcs[first[p] : first[p + 1]] if isinstance(p, int) else np.array(p, dtype=np.float64)
        for p in pieces
    ]
    at = np.rint(np.concatenate(chunks)).astype(np.int64)
    # Consecutive repeats (and the closing one) dropped, as `to_ring` does.
    keep = np.ones(len(at), dtype=bool)
    keep[1:] = (at[1:] != at[:-1]).any(axis=1)
    at = at[keep]
    if len(at) > 1 and (at[0] == at[-1]).all():
        at = at[:-1]
    found: list[list[int]] = at.tolist()
    return found


@functools.lru_cache(maxsize=64)
def directions(contour: Path) -> tuple[tuple[Pt, Pt], ...]:
    """Each element's `cutter.offset_directions`: the same at every level, made once for a
    contour (kept for the last few)."""
    starts = [contour.start] + [e.end for e in contour.elements[:-1]]
    return tuple(
        offset_directions(start, element)
        for start, element in zip(starts, contour.elements, strict=True)
    )


@functools.lru_cache(maxsize=64)
def corners(contour: Path) -> tuple[tuple[float, float], ...]:
    """For each element of a closed contour, the turn at its end into the next element
    (radians, left positive) and the direction (radians) of the left normal of its end
    tangent, where a right turn's corner arc starts. The same at every level: made once
    for a contour (kept for the last few), not again for each offset and each level's
    carriers."""
    elements = contour.elements
    starts = [contour.start] + [e.end for e in elements[:-1]]
    found = []
    for k, (start, element) in enumerate(zip(starts, elements, strict=True)):
        t1 = tangent(start, element, at_end=True)
        t2 = tangent(element.end, elements[(k + 1) % len(elements)], at_end=False)
        n1 = left_normal(t1)
        found.append((math.atan2(cross(t1, t2), dot(t1, t2)), math.atan2(n1[1], n1[0])))
    return tuple(found)


_ArcRun = tuple[float, float, float, float, float, int, int, int]
"""An arc's points for `_arcs`: centre x, y, radius, start angle, turn (signed, radians),
chords n, and which of its n + 1 points (from, to: 0, n + 1 is all of them)."""


def _arcs(arcs: Sequence[_ArcRun]) -> tuple[npt.NDArray[np.float64], list[int]]:
    """The points of `arcs` one after another, and where each arc's begin (with the end
    after the last): point i of an arc is at angle a0 + turn i / n on its circle."""
    counts = [to - start for *_, start, to in arcs]
    first = [0, *itertools.accumulate(counts)]
    if not arcs:
        return np.zeros((0, 2)), first
    cx, cy, radius, a0, turn, n, start, _ = np.array(arcs, dtype=np.float64).T
    sizes = np.array(counts, dtype=np.intp)
    which = np.repeat(np.arange(len(arcs)), sizes)
    # Each point's number on its arc: its place in the whole less its arc's first place.
    i = np.arange(first[-1]) - np.repeat(np.array(first[:-1]), sizes) + start[which]
    angles = a0[which] + turn[which] * i / n[which]
    x = cx[which] + radius[which] * np.cos(angles)
    y = cy[which] + radius[which] * np.sin(angles)
    return np.column_stack((x, y)), first


def sweep_lines(
    paths: Sequence[Sequence[Pt]], radius: float, tolerance: float, round_ends: bool = True
) -> Swept:
    """The area a round tool of `radius` covers moving along polylines (round ends), as
    Clipper gave it: a sweep is only handed back to Clipper, and making tuples of its
    points was a tenth of a large pocket's planning. `round_ends` False: square-cut ends
    at the first and last points (a piece of a longer move, whose ends lie inside the
    move's sweep; a round end is half the points of a short piece's sweep)."""
    offsetter = pyclipper.PyclipperOffset(2.0, float(tolerance))
    ends = pyclipper.ET_OPENROUND if round_ends else pyclipper.ET_OPENBUTT
    added = False
    for points in paths:
        ring = [(round(x), round(y)) for x, y in points]
        if len(ring) == 1 or all(p == ring[0] for p in ring):
            ring = [ring[0], (ring[0][0] + 1, ring[0][1])]
            offsetter.AddPath(ring, pyclipper.JT_ROUND, pyclipper.ET_OPENROUND)
        else:
            offsetter.AddPath(ring, pyclipper.JT_ROUND, ends)
        added = True
    return cast(Swept, offsetter.Execute(float(radius))) if added else []


def components(region: Sequence[Ring]) -> list[Component]:
    """The connected pieces of a region (outer rings with their holes), in Clipper's order."""
    if not region:
        return []
    clipper = pyclipper.Pyclipper()
    clipper.AddPaths(region, pyclipper.PT_SUBJECT, True)
    tree = clipper.Execute2(pyclipper.CT_UNION, pyclipper.PFT_NONZERO, pyclipper.PFT_NONZERO)
    found: list[Component] = []
    _gather(tree, found)
    _let_go(tree)
    return found


def _gather(node: Any, found: list[Component]) -> None:
    """The components under a PolyTree node, depth first, into `found` (a function of the
    module: a nested recursive one is a reference cycle, its closure and itself)."""
    for child in node.Childs:
        if not child.IsHole:
            holes = tuple(_rings(h.Contour for h in child.Childs))
            found.append(Component(_rings([child.Contour])[0], holes))
        _gather(child, found)


def _let_go(tree: Any) -> None:
    """Unlink a PolyTree's nodes from their parents once it is read. pyclipper's nodes
    name their parent and their children, a reference cycle that only the garbage
    collector frees; while a pocket is planned it is paused (`sizes.collector_paused`),
    and every tree, its points as Python lists, would stay until the plan is made (121 000
    objects for the 8-island pocket). Unlinked, each is freed as soon as it is read."""
    stack = [tree]
    while stack:
        node = stack.pop()
        node.Parent = None
        stack.extend(node.Childs)


def area(region: Sequence[Ring]) -> float:
    """Signed area in nm² (holes subtract)."""
    return sum(float(pyclipper.Area(ring)) for ring in region)


def inside(region: Sequence[Ring], point: IPt) -> bool:
    """True when `point` is inside (or on the edge of) the region (non-zero winding)."""
    winding = 0
    for ring in region:
        where = cast(int, pyclipper.PointInPolygon(point, ring))
        if where == -1:
            return True
        if where == 1:
            winding += 1 if pyclipper.Orientation(ring) else -1
    return winding != 0


def segment_inside(
    region: Sequence[Ring], a: Pt, b: Pt, boxes: Sequence[Box | None] | None = None
) -> bool:
    """True when the straight move from `a` to `b` stays inside the region (within 2 nm).

    `boxes`: each ring's box (`box_of`), when the caller asks often of one region. Only
    the rings whose box meets the move's are read then: a ring whose box does not cannot
    cross the move nor hold it, so it changes nothing (a move among a few islands reads
    those, not every island of the pocket)."""
    ia, ib = (round(a[0]), round(a[1])), (round(b[0]), round(b[1]))
    if boxes is not None:
        move = (min(ia[0], ib[0]), min(ia[1], ib[1]), max(ia[0], ib[0]), max(ia[1], ib[1]))
        region = [ring for ring, box in zip(region, boxes, strict=True) if box and _meet(box, move)]
    if ia == ib:
        return inside(region, ia)
    if not region:
        return False
    clipper = pyclipper.Pyclipper()
    clipper.AddPath([ia, ib], pyclipper.PT_SUBJECT, False)
    clipper.AddPaths(region, pyclipper.PT_CLIP, True)
    tree = clipper.Execute2(pyclipper.CT_INTERSECTION, pyclipper.PFT_NONZERO, pyclipper.PFT_NONZERO)
    pieces = pyclipper.OpenPathsFromPolyTree(tree)
    _let_go(tree)
    kept = 0.0
    for piece in pieces:
        kept += sum(math.dist(piece[k], piece[k + 1]) for k in range(len(piece) - 1))
    return kept >= math.dist(ia, ib) - 2.0


def thicker_than(region: Region, width: float, tolerance: float) -> bool:
    """True when some part of the region is wider than `width` (survives shrinking by half).
    A region whose box is narrower than `width` is not, without asking Clipper: the
    slivers between passes are thousands."""
    box = box_of(region)
    if box is None or box[2] - box[0] < width or box[3] - box[1] < width:
        return False
    offsetter = pyclipper.PyclipperOffset(2.0, float(tolerance))
    offsetter.AddPaths(region, pyclipper.JT_ROUND, pyclipper.ET_CLOSEDPOLYGON)
    return bool(offsetter.Execute(-width / 2))  # (whether, not what: not read into tuples)


def deep_point(component: Component, tolerance: float) -> IPt:
    """A point well inside a component, about as far from its edges as any: the component
    is shrunk by the largest amount that leaves something (found by halving, to within a
    sixteenth of the depth), and the vertex-average of what is left is taken (or one of its
    vertices, when the average falls outside it)."""
    xs = [p[0] for p in component.outer]
    ys = [p[1] for p in component.outer]
    low, high = 0.0, (min(max(xs) - min(xs), max(ys) - min(ys)) / 2) + tolerance
    rings = component.rings
    while high - low > max(4 * tolerance, high / 16):
        middle = (low + high) / 2
        pieces = components(offset(component.rings, -middle, tolerance))
        if pieces:
            low, rings = middle, pieces[0].rings
        else:
            high = middle
    outer = rings[0]
    cx = round(sum(p[0] for p in outer) / len(outer))
    cy = round(sum(p[1] for p in outer) / len(outer))
    if inside(rings, (cx, cy)):
        return (cx, cy)
    return outer[0]


Box = tuple[float, float, float, float]
"""x0, y0, x1, y1 (nm)."""


def box_of(region: Region) -> Box | None:
    """The smallest box around a region (None for an empty one)."""
    if not region:
        return None
    xs = [p[0] for ring in region for p in ring]
    ys = [p[1] for ring in region for p in ring]
    return (min(xs), min(ys), max(xs), max(ys))


class SweptIndex:
    """Where a round tool of `radius` has moved (polylines, nm), found by place: the area
    swept near a box comes from the moves there alone, so a question about one place costs
    what is near it, not everything cut so far (a pocket's links asked it of the union of
    every pass before, which grew with each pass).

    Each move is cut into pieces of `PIECE` segments (and the next piece's first segment:
    neighbours share a segment), kept with its box (the boxes as one numpy array, which a
    question compares with its own boxes in one pass: a grid of cells, each piece filed
    under every cell its box met, took a tenth of a large pocket's planning to fill), and
    swept the first time a question needs it (`sweeps` keeps the sweeps by
    (id of the points, piece), for indexes over the same moves). The area near a box is
    the union of the sweeps of the pieces there: the same area as the sweep of whole moves
    (a round tool's sweep along a polyline is the union of its sweeps along the pieces),
    its round ends within `tolerance` as every sweep here. Only the move's first and last
    pieces have round ends: each point where a piece is cut is inside the piece that
    shares the segment either side of it, whose sweep holds the round join there, so a
    square end is enough (a round end was half the points handed to Clipper)."""

    PIECE = 32

    def __init__(
        self,
        radius: float,
        tolerance: float,
        sweeps: dict[tuple[int, int], Swept] | None = None,
    ) -> None:
        self.radius = radius
        self.tolerance = tolerance
        self.sweeps: dict[tuple[int, int], Swept] = {} if sweeps is None else sweeps
        self.pieces: list[tuple[Sequence[Pt], int]] = []
        self._piece_boxes: list[Box] = []
        self._box_array = np.zeros((0, 4), dtype=np.float64)  # the first rows of those
        # The boxes of a move's pieces by the id of its points (kept with them, so the id
        # is not reused): a pass is asked about as the one a link leads to, then recorded.
        self._boxes: dict[int, tuple[Sequence[Pt], list[Box]]] = {}
        self._segments: dict[
            tuple[int, int], tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]
        ] = {}

    def add(self, points: Sequence[Pt]) -> None:
        """Record a move along `points` (one point: the tool went down there). The list
        must stay alive and unchanged while the index is used (its id names its sweeps)."""
        for k, box in enumerate(self.boxes(points)):
            self.pieces.append((points, k))
            self._piece_boxes.append(box)

    def boxes(self, points: Sequence[Pt]) -> list[Box]:
        """The box of each piece of a move along `points`, grown by the tool's reach: the
        tool's sweep along the piece lies inside it."""
        kept = self._boxes.get(id(points))
        if kept is not None and kept[0] is points:
            return kept[1]
        reach = self.radius + self.tolerance
        found = []
        for piece in _pieces(points, self.PIECE):
            xs = [p[0] for p in piece]
            ys = [p[1] for p in piece]
            found.append((min(xs) - reach, min(ys) - reach, max(xs) + reach, max(ys) + reach))
        self._boxes[id(points)] = (points, found)
        return found

    def near(self, boxes: Sequence[Box], also: Sequence[Sequence[Pt]] = ()) -> Swept:
        """The area swept by the recorded moves and by the moves `also` (not recorded; the
        same rule as `add` for their lists) wherever it lies within `boxes`; beyond them
        it may be cut short. The rings of the pieces' sweeps, overlapping: the area is
        where their winding is positive (as a union reads them), not yet united.

        Only the pieces whose own box meets one of `boxes` are read: a piece's sweep lies
        in its box, so the others cannot reach into `boxes`. Asked with the boxes of a
        move's pieces (`boxes`), a long move along a ring reads the passes beside it, not
        every pass within its bounding box."""
        # Kept by the same key: the move asked about (`also`) is recorded next, as a rule,
        # and its pieces' sweeps are then made already.
        return [
            ring for points, k in self._pieces_near(boxes, also) for ring in self._sweep(points, k)
        ]

    def segments_near(
        self, boxes: Sequence[Box], also: Sequence[Sequence[Pt]] = ()
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """(starts, ends): the segments (rows x, y; a point alone is a segment of no length)
        of the pieces `near` reads for the same question, whose sweeps are its answer."""
        starts: list[npt.NDArray[np.float64]] = []
        ends: list[npt.NDArray[np.float64]] = []
        for points, k in self._pieces_near(boxes, also):
            key = (id(points), k)
            kept = self._segments.get(key)
            if kept is None:
                at = np.rint(np.array(_piece(points, self.PIECE, k), dtype=np.float64))
                at = at.reshape(-1, 2)
                kept = (at[:-1], at[1:]) if len(at) > 1 else (at, at)
                self._segments[key] = kept
            starts.append(kept[0])
            ends.append(kept[1])
        if not starts:
            empty = np.zeros((0, 2), dtype=np.float64)
            return empty, empty
        return np.concatenate(starts), np.concatenate(ends)

    def _pieces_near(
        self, boxes: Sequence[Box], also: Sequence[Sequence[Pt]]
    ) -> list[tuple[Sequence[Pt], int]]:
        """The (move, piece) pairs, recorded or in `also`, whose piece's box meets one of
        `boxes`: the only pieces whose sweeps can reach into them."""
        found: list[tuple[Sequence[Pt], int]] = []
        if len(self._box_array) < len(self._piece_boxes):
            added = np.array(self._piece_boxes[len(self._box_array) :], dtype=np.float64)
            self._box_array = np.concatenate((self._box_array, added.reshape(-1, 4)))
        if len(self._box_array) and boxes:
            have, asked = self._box_array[:, None, :], np.array(boxes, dtype=np.float64)[None]
            meets = (
                (have[..., 0] <= asked[..., 2])
                & (have[..., 2] >= asked[..., 0])
                & (have[..., 1] <= asked[..., 3])
                & (have[..., 3] >= asked[..., 1])
            ).any(axis=1)
            found += [self.pieces[number] for number in np.flatnonzero(meets).tolist()]
        for points in also:
            for k, piece_box in enumerate(self.boxes(points)):
                if any(_meet(piece_box, box) for box in boxes):
                    found.append((points, k))
        return found

    def _sweep(self, points: Sequence[Pt], k: int) -> Swept:
        key = (id(points), k)
        swept = self.sweeps.get(key)
        if swept is None:
            last = k == _piece_count(points, self.PIECE) - 1
            piece = _piece(points, self.PIECE, k)
            swept = sweep_lines([piece], self.radius, self.tolerance, k == 0 or last)
            self.sweeps[key] = swept
        return swept


def _meet(a: Box, b: Box) -> bool:
    """True when two boxes overlap or touch."""
    return a[0] <= b[2] and a[2] >= b[0] and a[1] <= b[3] and a[3] >= b[1]


def _piece_count(points: Sequence[Pt], size: int) -> int:
    """How many pieces `_piece` cuts `points` into."""
    return 1 if len(points) <= size + 1 else math.ceil((len(points) - 1) / size)


def _piece(points: Sequence[Pt], size: int, k: int) -> Sequence[Pt]:
    """The `k`th run of `size` segments of `points` and the segment after it (the next
    run's first): every point but the first and last is between two segments of one run."""
    if len(points) <= size + 1:
        return points
    return points[k * size : k * size + size + 2]


def _pieces(points: Sequence[Pt], size: int) -> list[Sequence[Pt]]:
    """`points` cut by `_piece`, in order."""
    return [_piece(points, size, k) for k in range(_piece_count(points, size))]


def move_covered(
    a: Pt,
    b: Pt,
    radius: float,
    reach: float,
    starts: npt.NDArray[np.float64],
    ends: npt.NDArray[np.float64],
    width: float,
    tolerance: float,
) -> bool | None:
    """Whether the straight move from `a` to `b`, swept by `radius`, leaves nothing wider
    than `width` outside the sweeps by `reach` of the segments `starts`-`ends` (rows x, y),
    as `thicker_than` reads the difference of those sweeps made by Clipper within
    `tolerance` (nm): True when nothing is left, False when something is, None when this
    cannot tell (the answer is near the limit: ask Clipper).

    Why: the sweeps of every pass beside a long link, made and united for one yes or no,
    were a quarter of a large pocket's planning. Something wider than `width` is left
    where a point within `radius` - `width`/2 of the move is farther than `reach` +
    `width`/2 from every segment (the margins take in Clipper's chords, within
    `tolerance` of the true arcs, and rounding to whole nm). The distance to the nearest
    segment changes no faster than the point moves, so over a rectangle it is at most
    its value at a point plus the rectangle's farthest corner from that point: the
    rectangles covering the move's band are bounded from their centres and from the
    move's ends (on the passes it joins), and only those neither bound nor a centre
    decides are halved, a few times. The round ends of the band are within
    `radius` of the move's ends."""
    ax, ay = float(a[0]), float(a[1])
    dx, dy = float(b[0]) - ax, float(b[1]) - ay
    span = math.hypot(dx, dy)
    if span < 1.0 or not len(starts):
        return None
    ux, uy = dx / span, dy / span
    # Clipper's sweeps hold the true sweeps by reach - tolerance, and its move's sweep
    # lies within the true one by radius; its erosion by width/2 is true within tolerance.
    band = radius - width / 2 + tolerance + 10.0
    covered = reach + width / 2 - 2 * tolerance - 10.0
    left = reach + width / 2 + tolerance + 10.0
    inner = radius - width / 2 - 2 * tolerance - 10.0
    # The segments in the move's frame (along u from a, across v); only those that can
    # come within `left` of the band matter.
    su = (starts[:, 0] - ax) * ux + (starts[:, 1] - ay) * uy
    sv = (starts[:, 1] - ay) * ux - (starts[:, 0] - ax) * uy
    eu = (ends[:, 0] - ax) * ux + (ends[:, 1] - ay) * uy
    ev = (ends[:, 1] - ay) * ux - (ends[:, 0] - ax) * uy
    u_lo, u_hi = np.minimum(su, eu), np.maximum(su, eu)
    v_lo, v_hi = np.minimum(sv, ev), np.maximum(sv, ev)
    pad = band + left
    keep = (u_lo <= span + pad) & (u_hi >= -pad) & (v_lo <= pad) & (v_hi >= -pad)
    if not keep.any():
        return None
    frame = np.column_stack((su, sv, eu, ev))[keep]
    u_lo, u_hi = u_lo[keep], u_hi[keep]
    # Stretches of the move a tool diameter long, each with the segments near it.
    chunk = 2 * reach
    count = max(1, math.ceil(span / chunk))
    near = [
        frame[(u_lo <= (k + 1) * chunk + left) & (u_hi >= k * chunk - left)] for k in range(count)
    ]
    # The stretches' segments one after another (`first`, `sizes`: where each begins, how
    # many): a point is measured against its stretch's, every point in one numpy pass.
    sizes = np.array([len(segments) for segments in near], dtype=np.intp)
    first = np.cumsum(sizes) - sizes
    near_all = np.concatenate(near)

    def far(cu: npt.NDArray[np.float64], cv: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        which = np.clip((cu // chunk).astype(np.intp), 0, count - 1)
        return _nearest_of_runs(cu, cv, near_all, first[which], sizes[which])

    fa, fb = far(np.array([0.0, span]), np.zeros(2)).tolist()
    # The round ends of the band lie within `band` of the move's ends.
    ends_covered = fa + band < covered and fb + band < covered
    # Rectangles (u0, u1) along the move x (v0, v1) across it, tiling the band's middle.
    nu = max(1, math.ceil(span / (reach / 2)))
    nv = max(1, math.ceil(2 * band / (reach / 2)))
    u_edges = np.linspace(0.0, span, nu + 1)
    v_edges = np.linspace(-band, band, nv + 1)
    u0, v0 = (g.ravel() for g in np.meshgrid(u_edges[:-1], v_edges[:-1]))
    u1, v1 = (g.ravel() for g in np.meshgrid(u_edges[1:], v_edges[1:]))
    for _ in range(10):
        cu, cv = (u0 + u1) / 2, (v0 + v1) / 2
        f = far(cu, cv)
        if ((f >= left) & (np.abs(cv) <= inner)).any():
            return False
        wide = np.maximum(np.abs(v0), np.abs(v1))
        bound = np.minimum(
            f + np.hypot(u1 - u0, v1 - v0) / 2,
            np.minimum(
                fa + np.hypot(np.maximum(np.abs(u0), np.abs(u1)), wide),
                fb + np.hypot(np.maximum(np.abs(span - u0), np.abs(span - u1)), wide),
            ),
        )
        open_ = bound >= covered
        if not open_.any():
            return True if ends_covered else None
        if 4 * int(open_.sum()) > 4096:
            return None
        u0, u1, v0, v1 = u0[open_], u1[open_], v0[open_], v1[open_]
        um, vm = (u0 + u1) / 2, (v0 + v1) / 2
        u0, u1 = np.concatenate((u0, um, u0, um)), np.concatenate((um, u1, um, u1))
        v0, v1 = np.concatenate((v0, v0, vm, vm)), np.concatenate((vm, vm, v1, v1))
    return None


def _nearest_of_runs(
    px: npt.NDArray[np.float64],
    py: npt.NDArray[np.float64],
    segments: npt.NDArray[np.float64],
    first: npt.NDArray[np.intp],
    sizes: npt.NDArray[np.intp],
) -> npt.NDArray[np.float64]:
    """The distance from each point (`px`, `py`) to the nearest of its run of `segments`
    (rows x0, y0, x1, y1; the run of point i: `sizes[i]` rows from `first[i]`; inf for an
    empty run), every point and run in one numpy pass: a pass per stretch of a move was
    most of `move_covered`'s time, its arrays a few dozen long."""
    found = np.full(len(px), np.inf)
    owner = np.repeat(np.arange(len(px)), sizes)
    if not len(owner):
        return found
    heads = np.cumsum(sizes) - sizes
    row = first[owner] + np.arange(len(owner)) - heads[owner]
    sx, sy = segments[row, 0], segments[row, 1]
    dx, dy = segments[row, 2] - sx, segments[row, 3] - sy
    denom = dx * dx + dy * dy
    safe = np.where(denom > 0, denom, 1.0)
    qx, qy = px[owner] - sx, py[owner] - sy
    t = np.clip((qx * dx + qy * dy) / safe, 0.0, 1.0)
    t = np.where(denom > 0, t, 0.0)
    ex, ey = qx - t * dx, qy - t * dy
    measured = np.flatnonzero(sizes)
    found[measured] = np.sqrt(np.minimum.reduceat(ex * ex + ey * ey, heads[measured]))
    return found
