"""Exact offset passes: Clipper's polyline rings turned back into lines and arcs.

The boundary of a region shrunk by `d` (every pass of an offset pocket) is made only of
(a) the contour's elements moved `d` into the region — a line stays a line, an arc stays an
arc about the same centre with its radius changed by `d` — and (b) arcs of radius `d` about
the contour's reflex corners (where the region wraps round a corner, e.g. an island's).
These are the "carriers" of a level. Clipper gives the topology (which pieces survive, where
the region splits); each of its ring points is matched to the carriers it lies on (within
the matching tolerance), the ring is split into the fewest runs each on one carrier, and the
exact element of each run ends where its carrier meets the next one. The result is checked
against Clipper's ring point by point; when it does not hold (or a point lies on no
carrier), the caller keeps the polyline ring, within the stated chordal tolerance.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from app.cnc.plane import (
    Element,
    Path,
    Pt,
    add,
    cross,
    distance_to_element,
    dot,
    intersections,
    left_normal,
    scale,
    sub,
    sweep,
    unit,
)
from app.cnc.pocketing import nearest
from app.cnc.pocketing.regions import TURN_EPS, Ring, corners


@dataclass(frozen=True)
class Carrier:
    """A line or circle a pass can run on, with the stretches of it that are real.

    Line: through `origin` along unit `direction`; `spans` are (from, to) distances along it.
    Circle: about `origin` with `radius`, travelled `clockwise` when the region is on the
    left; `spans` are (start angle, turn) in radians, turn > 0 in the travel direction.
    `sources` are the (contour, element) pairs it comes from: the element for a moved
    element, the element after the corner for a corner arc.
    """

    origin: Pt
    direction: Pt | None
    radius: float
    clockwise: bool
    spans: tuple[tuple[float, float], ...]
    sources: tuple[tuple[int, int], ...]

    @property
    def is_line(self) -> bool:
        return self.direction is not None

    def distance(self, p: Pt, slack: float) -> float:
        """Distance from `p` to the carrier, or inf when `p` is beyond every span by more
        than `slack`."""
        if self.direction is not None:
            q = sub(p, self.origin)
            along = dot(q, self.direction)
            if not any(lo - slack <= along <= hi + slack for lo, hi in self.spans):
                return math.inf
            return abs(cross(self.direction, q))
        if not _within_spans(self, p, slack):
            return math.inf
        return abs(math.dist(p, self.origin) - self.radius)

    def distances(self, points: npt.NDArray[np.float64], slack: float) -> npt.NDArray[np.float64]:
        """`distance` for every row (x, y) of `points` at once, the same numbers."""
        which = np.zeros(len(points), dtype=np.intp)
        return _pair_distances(points, which, _columns([self], slack))

    def box(self, tolerance: float) -> tuple[float, float, float, float]:
        """A box holding every point within `tolerance` of the carrier's spans (and of their
        `tolerance` of slack): points outside it are farther (x0, y0, x1, y1)."""
        reach = 2 * tolerance + 1.0
        if self.direction is None:
            r = self.radius + reach
            return (self.origin[0] - r, self.origin[1] - r, self.origin[0] + r, self.origin[1] + r)
        ends = [
            add(self.origin, scale(self.direction, along))
            for lo, hi in self.spans
            for along in (lo - tolerance, hi + tolerance)
        ]
        xs = [p[0] for p in ends]
        ys = [p[1] for p in ends]
        return (min(xs) - reach, min(ys) - reach, max(xs) + reach, max(ys) + reach)

    def element_stub(self) -> tuple[Pt, Element]:
        """A start and element on this carrier's full line/circle (for intersections)."""
        if self.direction is not None:
            return self.origin, Element(0, add(self.origin, self.direction))
        start = (self.origin[0] + self.radius, self.origin[1])
        return start, Element(0, start, centre=self.origin)

    def project(self, p: Pt) -> Pt:
        """The nearest point to `p` on the full line/circle."""
        if self.direction is not None:
            return add(self.origin, scale(self.direction, dot(sub(p, self.origin), self.direction)))
        return add(self.origin, scale(unit(sub(p, self.origin)), self.radius))


def _within_spans(carrier: Carrier, p: Pt, slack: float) -> bool:
    angle = math.atan2(p[1] - carrier.origin[1], p[0] - carrier.origin[0])
    slack_angle = slack / max(carrier.radius, 1.0) + 1e-9
    for start, turn in carrier.spans:
        if turn >= 2 * math.pi - 1e-9:
            return True
        along = (start - angle) if carrier.clockwise else (angle - start)
        along %= 2 * math.pi
        if along <= turn + slack_angle or along >= 2 * math.pi - slack_angle:
            return True
    return False


def carriers(contours: Sequence[Path], d: float, tolerance: float) -> list[Carrier]:
    """The carriers of the level `d` nm into the region, for contours oriented with the
    region on their left. Identical lines/circles are merged (their spans joined)."""
    level = _Level()
    for ci, contour in enumerate(contours):
        starts = [contour.start] + [e.end for e in contour.elements[:-1]]
        turns = corners(contour)
        for ei, (start, element) in enumerate(zip(starts, contour.elements, strict=True)):
            moved = _moved(start, element, d, tolerance, (ci, ei))
            if moved is not None:
                level.merge(moved)
            nxt = (ei + 1) % len(contour.elements)
            turn, normal = turns[ei]
            if turn < -TURN_EPS:  # a right turn: a reflex corner of the region
                corner = element.end
                level.merge(Carrier(corner, None, d, True, ((normal, -turn),), ((ci, nxt),)))
    return level.found


def _moved(
    start: Pt, element: Element, d: float, tolerance: float, source: tuple[int, int]
) -> Carrier | None:
    if element.centre is None:
        length = math.dist(start, element.end)
        if length <= 0:
            return None
        u = unit(sub(element.end, start))
        return Carrier(
            add(start, scale(left_normal(u), d)), u, 0.0, False, ((0.0, length),), (source,)
        )
    c = element.centre
    radius = math.dist(start, c)
    # Left of a counter-clockwise arc is toward its centre; of a clockwise one, away.
    moved = radius + d if element.clockwise else radius - d
    if moved <= tolerance:
        return None
    return Carrier(
        c,
        None,
        moved,
        element.clockwise,
        ((math.atan2(start[1] - c[1], start[0] - c[0]), sweep(start, element)),),
        (source,),
    )


def _same(old: Carrier, new: Carrier) -> bool:
    """True when `new` lies on `old`'s line or circle (travelled the same way)."""
    if new.direction is not None and old.direction is not None:
        return (
            abs(cross(old.direction, new.direction)) < TURN_EPS
            and dot(old.direction, new.direction) > 0
            and abs(cross(old.direction, sub(new.origin, old.origin))) <= 1.0
        )
    if new.direction is None and old.direction is None:
        return (
            math.dist(old.origin, new.origin) <= 1.0
            and abs(old.radius - new.radius) <= 1.0
            and old.clockwise == new.clockwise
        )
    return False


_ANGLE_STEP = 1e-6  # rad: lines the same within TURN_EPS fall in one bucket or the next
_ANGLES = round(2 * math.pi / _ANGLE_STEP)
_LENGTH_STEP = 1_000.0  # nm: lines, circles the same within 1 nm (a few at 99 in) likewise


def _keys(carrier: Carrier) -> list[tuple[object, ...]]:
    """The index buckets a carrier the same as `carrier` can be in (its own first): of the
    neighbouring buckets (a step either way in each number), only those the numbers of a
    carrier within `_same`'s limits of this one round into (one bucket, as a rule, not 9 or
    27: gathering a level's carriers asked every neighbour, a twentieth of a large pocket's
    planning). The bucket a same carrier is in is always among them, so the carriers
    compared, and the one merged into, are the same as when every neighbour was asked."""
    if carrier.direction is not None:
        dx, dy = carrier.direction
        angle = math.atan2(dy, dx)
        a = round(angle / _ANGLE_STEP) % _ANGLES
        along = cross(carrier.direction, carrier.origin)
        c = round(along / _LENGTH_STEP)
        # Same lines: directions within about 1e-9 rad, and numbers `along` within 1 nm
        # and the turn times the distance from the origin (and rounding) of each other.
        if abs(angle) + _ANGLE_SLACK < math.pi:
            low = round((angle - _ANGLE_SLACK) / _ANGLE_STEP) - round(angle / _ANGLE_STEP)
            high = round((angle + _ANGLE_SLACK) / _ANGLE_STEP) - round(angle / _ANGLE_STEP)
            turns = [0] + [i for i in (-1, 1) if low <= i <= high]
        else:  # (where the angle wraps round, every neighbour)
            turns = [0, -1, 1]
        slack = 2.0 + 4e-9 * (abs(carrier.origin[0]) + abs(carrier.origin[1]))
        return [("line", (a + i) % _ANGLES, c + j) for i in turns for j in _steps(along, c, slack)]
    x = round(carrier.origin[0] / _LENGTH_STEP)
    y = round(carrier.origin[1] / _LENGTH_STEP)
    r = round(carrier.radius / _LENGTH_STEP)
    # Same circles: centres within 1 nm (each coordinate), radii within 1 nm.
    return [
        ("circle", carrier.clockwise, x + i, y + j, r + k)
        for i in _steps(carrier.origin[0], x, 2.0)
        for j in _steps(carrier.origin[1], y, 2.0)
        for k in _steps(carrier.radius, r, 2.0)
    ]


_ANGLE_SLACK = 1e-8  # rad: more than the turn between same lines and atan2's rounding


def _steps(value: float, bucket: int, slack: float) -> list[int]:
    """Of the steps 0, -1, 1 from `bucket` (`value`'s), those a number within `slack` of
    `value` can round into (0 first)."""
    low = round((value - slack) / _LENGTH_STEP) - bucket
    high = round((value + slack) / _LENGTH_STEP) - bucket
    return [0] + [i for i in (-1, 1) if low <= i <= high]


class _Level:
    """A level's carriers being gathered: identical lines/circles merged (their spans
    joined into the first), found through buckets, not by comparing with every carrier."""

    def __init__(self) -> None:
        self.found: list[Carrier] = []
        self.buckets: dict[tuple[object, ...], list[int]] = {}

    def merge(self, new: Carrier) -> None:
        keys = _keys(new)
        buckets = self.buckets
        candidates = sorted({k for key in keys if key in buckets for k in buckets[key]})
        for k in candidates:
            old = self.found[k]
            if not _same(old, new):
                continue
            spans = new.spans
            if old.direction is not None:
                shift = dot(sub(new.origin, old.origin), old.direction)
                spans = tuple((lo + shift, hi + shift) for lo, hi in spans)
            # (made directly: `dataclasses.replace` reads the fields' descriptions each time)
            self.found[k] = Carrier(
                old.origin,
                old.direction,
                old.radius,
                old.clockwise,
                old.spans + spans,
                old.sources + new.sources,
            )
            return
        self.buckets.setdefault(keys[0], []).append(len(self.found))
        self.found.append(new)


IntArray = npt.NDArray[np.intp]


FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class _Columns:
    """Carriers as numpy reads them for `_pair_distances` with one slack: a row per carrier
    (origin, direction of a line, radius and slack angle of a circle; which are lines,
    clockwise, full circles) and one per span (`span_of`: its carrier, ascending; `span_a`,
    `span_b`: a line's from and to with the slack, a circle's start angle and turn with
    the slack)."""

    ox: FloatArray
    oy: FloatArray
    dx: FloatArray
    dy: FloatArray
    radius: FloatArray
    slack_angle: FloatArray
    line: npt.NDArray[np.bool_]
    clockwise: npt.NDArray[np.bool_]
    full: npt.NDArray[np.bool_]
    span_of: IntArray
    span_a: FloatArray
    span_b: FloatArray


def _columns(level: Sequence[Carrier], slack: float) -> _Columns:
    """The `_Columns` of `level` for `slack` (nm)."""
    ox, oy, dx, dy, radius, slack_angle = (np.zeros(len(level)) for _ in range(6))
    line = np.zeros(len(level), dtype=bool)
    clockwise = np.zeros(len(level), dtype=bool)
    full = np.zeros(len(level), dtype=bool)
    span_of: list[int] = []
    span_a: list[float] = []
    span_b: list[float] = []
    for k, carrier in enumerate(level):
        ox[k], oy[k] = carrier.origin
        if carrier.direction is not None:
            line[k] = True
            dx[k], dy[k] = carrier.direction
            for lo, hi in carrier.spans:
                span_of.append(k)
                span_a.append(lo - slack)
                span_b.append(hi + slack)
            continue
        radius[k], clockwise[k] = carrier.radius, carrier.clockwise
        angle_slack = slack / max(carrier.radius, 1.0) + 1e-9
        slack_angle[k] = angle_slack
        for start, turn in carrier.spans:
            if turn >= 2 * math.pi - 1e-9:
                full[k] = True
                break
            span_of.append(k)
            span_a.append(start)
            span_b.append(turn + angle_slack)
    return _Columns(
        ox,
        oy,
        dx,
        dy,
        radius,
        slack_angle,
        line,
        clockwise,
        full,
        np.array(span_of, dtype=np.intp),
        np.array(span_a, dtype=np.float64),
        np.array(span_b, dtype=np.float64),
    )


@dataclass(frozen=True)
class LevelTable:
    """A level's carriers as `exact_ring` reads them with one tolerance, made once for the
    level's many rings (they are the same for each): each carrier's `box(tolerance)` as a
    row (x0, y0, x1, y1), and its numbers for measuring distances to it."""

    boxes: FloatArray
    columns: _Columns


def level_table(level: Sequence[Carrier], tolerance: float) -> LevelTable:
    """The `LevelTable` of `level` for `tolerance` (nm)."""
    boxes = np.array([c.box(tolerance) for c in level], dtype=np.float64).reshape(-1, 4)
    return LevelTable(boxes, _columns(level, tolerance))


def _carriers_at(
    at: npt.NDArray[np.float64], tolerance: float, table: LevelTable
) -> tuple[IntArray, IntArray]:
    """(rows, carriers): every pair of a point (a row of `at`) and a carrier it lies on
    within `tolerance` (`table`'s), by carrier in the level's order, rows ascending (numpy
    passes over the (point, carrier) pairs whose carrier's box holds the point: a contour
    of hundreds of blocks has as many carriers, and one pass per carrier cost more in
    calls than in arithmetic)."""
    boxes = table.boxes
    low, high = at.min(axis=0), at.max(axis=0)
    x0, y0, x1, y1 = boxes.T
    meets = np.flatnonzero((x0 <= high[0]) & (x1 >= low[0]) & (y0 <= high[1]) & (y1 >= low[1]))
    # The points by x: a carrier's box holds a run of them, found by bisection, and only
    # that run is compared in y (not every point of the ring for every carrier).
    by_x = np.argsort(at[:, 0], kind="stable")
    xs, ys = at[by_x, 0], at[by_x, 1]
    box = boxes[meets]
    first = np.searchsorted(xs, box[:, 0], side="left")
    counts = np.maximum(np.searchsorted(xs, box[:, 2], side="right") - first, 0)
    owner = np.repeat(np.arange(len(meets)), counts)
    place = np.arange(len(owner)) - np.repeat(np.cumsum(counts) - counts, counts) + first[owner]
    inside = (ys[place] >= box[owner, 1]) & (ys[place] <= box[owner, 3])
    owner, rows = owner[inside], by_x[place[inside]]
    order = np.lexsort((rows, owner))  # by carrier, rows ascending
    rows, found = rows[order], meets[owner[order]]
    close = _pair_distances(at[rows], found, table.columns) <= tolerance
    return rows[close], found[close]


def _pair_distances(points: FloatArray, which: IntArray, columns: _Columns) -> FloatArray:
    """`Carrier.distance` of each row of `points` to the carrier `which` names beside it
    (the same numbers as `Carrier.distances`, by the same arithmetic), in numpy passes
    over every pair at once rather than one pass per carrier. `columns`: the carriers'
    (`_columns`, with the slack of `distance`)."""
    result = np.full(len(which), math.inf)
    if not len(which):
        return result
    c = columns
    ox, oy, dx, dy, radius, slack_angle = c.ox, c.oy, c.dx, c.dy, c.radius, c.slack_angle
    line, clockwise, full = c.line, c.clockwise, c.full
    qx, qy = points[:, 0] - ox[which], points[:, 1] - oy[which]
    is_line = line[which]
    angle = np.arctan2(qy, qx)
    # Each pair against each span of its carrier: rows of (pair, span), the spans by
    # carrier (ascending) as `_columns` made them.
    starts = np.searchsorted(c.span_of, which, side="left")
    counts = np.searchsorted(c.span_of, which, side="right") - starts
    pair = np.repeat(np.arange(len(which)), counts)
    first = np.repeat(np.cumsum(counts) - counts, counts)
    span = np.arange(len(pair)) - first + starts[pair]
    a, b = c.span_a[span], c.span_b[span]
    k = which[pair]
    along_line = qx[pair] * dx[k] + qy[pair] * dy[k]
    on_line = (a <= along_line) & (along_line <= b)
    turned = np.where(clockwise[k], a - angle[pair], angle[pair] - a)
    along = np.mod(turned, 2 * math.pi)
    on_circle = (along <= b) | (along >= 2 * math.pi - slack_angle[k])
    hit = np.where(line[k], on_line, on_circle)
    within = full[which].copy()
    within[pair[hit]] = True
    lines = within & is_line
    result[lines] = np.abs(dx[which][lines] * qy[lines] - dy[which][lines] * qx[lines])
    circles = within & ~is_line
    result[circles] = np.abs(np.hypot(qx[circles], qy[circles]) - radius[which][circles])
    return result


def _sets(rows: IntArray, values: IntArray, n: int) -> list[set[int]]:
    """For each of `n` rows, the set of `values` paired with it (most rows have one: made
    in one comprehension, not one Python call per pair)."""
    order = np.lexsort((values, rows))
    rows, values = rows[order], values[order]
    count = np.bincount(rows, minlength=n)
    first = np.searchsorted(rows, np.arange(n))
    picked = values[np.minimum(first, max(len(values) - 1, 0))] if len(values) else first
    found = [{v} for v in picked.tolist()]
    for i in np.flatnonzero(count != 1).tolist():
        found[i] = set(values[first[i] : first[i] + count[i]].tolist())
    return found


def _edge_labels(
    at: npt.NDArray[np.float64],
    rows: IntArray,
    carriers_of: IntArray,
    tolerance: float,
    table: LevelTable,
) -> list[set[int]]:
    """For each edge of the ring (point i to point i + 1), the carriers its two ends and its
    middle lie on within `tolerance` (nm); for an edge across a junction (Clipper kept no
    point there), where no carrier holds all three, the carriers of either end: either
    may take it. `rows`, `carriers_of`: the (point, carrier) pairs (`_carriers_at`). The
    middles are measured in one numpy pass over the pairs (`_pair_distances`, the numbers
    `distance` gives), not one Python call per edge and carrier."""
    n = len(at)
    middles = (at + np.roll(at, -1, axis=0)) / 2
    # An edge can lie on a carrier both its ends lie on: the pair (i + 1, k) is there too.
    # The pairs come by carrier, rows ascending, so their codes k n + i ascend: (i + 1, k)
    # is the next pair, or for the last point (i + 1 = 0) found by bisection.
    codes = carriers_of * n + rows
    both = np.zeros(len(codes), dtype=bool)
    both[:-1] = codes[1:] == codes[:-1] + 1
    last = np.flatnonzero(rows == n - 1)
    wanted = carriers_of[last] * n
    found = np.minimum(np.searchsorted(codes, wanted), len(codes) - 1)
    both[last] = codes[found] == wanted
    edges, edge_carriers = rows[both], carriers_of[both]
    close = _pair_distances(middles[edges], edge_carriers, table.columns) <= tolerance
    label_rows, label_carriers = edges[close], edge_carriers[close]
    labels = _sets(label_rows, label_carriers, n)
    unlabelled = np.flatnonzero(np.bincount(label_rows, minlength=n) == 0).tolist()
    if unlabelled:
        # The carriers of each point, as sets, only for the ends of these edges.
        order = np.lexsort((carriers_of, rows))
        by_row, values = rows[order], carriers_of[order]
        first = np.searchsorted(by_row, np.arange(n + 1))

        def on(i: int) -> set[int]:
            return set(values[first[i] : first[i + 1]].tolist())

        for i in unlabelled:
            labels[i] = on(i) | on((i + 1) % n)
    return labels


@dataclass(frozen=True)
class ExactRing:
    """A closed pass of exact lines and arcs and the carriers it runs on."""

    path: Path
    sources: tuple[tuple[int, int], ...]


def exact_ring(
    ring: Ring,
    level: Sequence[Carrier],
    tolerance: float,
    block: int,
    tag: str,
    table: LevelTable | None = None,
) -> ExactRing | None:
    """The exact lines and arcs of a Clipper ring (region on its left), or None when the
    ring cannot be matched to the level's carriers within `tolerance` nm. `table`:
    `level_table(level, tolerance)`, when the caller asks of many rings of one level.

    Each edge of the ring (between consecutive points) is labelled with the carriers its
    two ends and its middle lie on; the ring is split into the fewest runs of edges on one
    carrier, and consecutive runs meet where their carriers intersect.
    """
    n = len(ring)
    if n < 3:
        return None
    at = np.array(ring, dtype=np.float64)
    if table is None:
        table = level_table(level, tolerance)
    rows, carriers_of = _carriers_at(at, tolerance, table)
    if (np.bincount(rows, minlength=n) == 0).any():
        return None
    # The pairs come by carrier, rows ascending: their codes k n + i ascend (`_has`).
    codes = carriers_of * n + rows
    labels = _edge_labels(at, rows, carriers_of, tolerance, table)
    runs = _runs(labels)
    if len(runs) == 1:
        carrier = level[runs[0][0]]
        if carrier.is_line:
            return None
        start = carrier.project(_lowest(ring))
        element = Element(block, start, centre=carrier.origin, clockwise=carrier.clockwise, tag=tag)
        path = Path(start, (element,))
        every = np.arange(n)
        return _checked(
            path,
            at,
            ring,
            every,
            np.zeros(n, dtype=np.intp),
            [element],
            [start],
            tolerance,
            [carrier],
        )
    junctions: list[Pt] = []
    for k, (label, first, length) in enumerate(runs):
        nxt_label = runs[(k + 1) % len(runs)][0]
        last, after = _point(ring, first + length), _point(ring, first + length + 1)
        meet = _junction(level[label], level[nxt_label], last, after, tolerance)
        if meet is None:
            return None
        junctions.append(meet)
    # Each junction lies near its run and the point after it (one numpy pass for all).
    far = nearest.stretch_distances(
        at,
        np.array(junctions, dtype=np.float64),
        [first for _, first, _ in runs],
        [length + 1 for _, _, length in runs],
    )
    if (far > 4 * tolerance).any():
        return None
    elements: list[Element] = []
    element_starts: list[Pt] = []
    kept: list[tuple[int, int, int]] = []
    used: list[Carrier] = []
    for k, (label, first, length) in enumerate(runs):
        start, end = junctions[k - 1], junctions[k]
        carrier = level[label]
        if math.dist(start, end) < 1.0:
            continue
        if carrier.is_line:
            element = Element(block, end, tag=tag)
        else:
            element = Element(
                block, end, centre=carrier.origin, clockwise=carrier.clockwise, tag=tag
            )
        elements.append(element)
        element_starts.append(start)
        kept.append((label, first, length))
        used.append(carrier)
    if not elements:
        return None
    # Each element's run's points that lie on its carrier (in order), found among the
    # pairs for every run at once: the rows of `at` and the element of each.
    on_carrier, firsts, lengths = (
        np.array(column, dtype=np.intp) for column in zip(*kept, strict=True)
    )
    sizes = lengths + 1
    owner = np.repeat(np.arange(len(kept)), sizes)
    rows = (firsts[owner] + np.arange(len(owner)) - np.repeat(np.cumsum(sizes) - sizes, sizes)) % n
    on = _has(codes, on_carrier[owner] * n + rows)
    path = Path(junctions[-1], tuple(elements))
    return _checked(path, at, ring, rows[on], owner[on], elements, element_starts, tolerance, used)


def _has(codes: IntArray, wanted: IntArray) -> npt.NDArray[np.bool_]:
    """Whether each of `wanted` is among `codes` (ascending)."""
    if not len(codes):
        return np.zeros(len(wanted), dtype=bool)
    found = np.minimum(np.searchsorted(codes, wanted), len(codes) - 1)
    there: npt.NDArray[np.bool_] = codes[found] == wanted
    return there


def _checked(
    path: Path,
    at: npt.NDArray[np.float64],
    ring: Ring,
    which: IntArray,
    owner: IntArray,
    elements: list[Element],
    starts: list[Pt],
    tolerance: float,
    used: list[Carrier],
) -> ExactRing | None:
    # numpy bounds the exact distance of every point to its element at once (one pass for
    # the ring); only a point whose bounds straddle the limit (beside an arc's end) is
    # measured exactly. `which`, `owner`: the points of the elements, as rows of `at`
    # (the ring's points, `ring` the same as tuples), and the element of each.
    if len(which):
        lower, upper = nearest.pair_bounds(at[which], nearest.table(starts, elements).take(owner))
        if (lower > 2 * tolerance + nearest.MARGIN).any():
            return None
        for i in np.flatnonzero(upper > 2 * tolerance - nearest.MARGIN).tolist():
            k = int(owner[i])
            if (
                distance_to_element(_point(ring, int(which[i])), starts[k], elements[k])
                > 2 * tolerance
            ):
                return None
    sources = tuple(sorted({s for c in used for s in c.sources}))
    return ExactRing(path, sources)


def _point(ring: Ring, i: int) -> Pt:
    """Point `i` of the closed `ring` (any whole number: taken round the ring) as floats,
    the numbers numpy reads (a ring's points are made floats only where they are read:
    a ring has thousands)."""
    x, y = ring[i % len(ring)]
    return (float(x), float(y))


def _lowest(ring: Ring) -> Pt:
    x, y = min(ring, key=lambda p: (p[1], p[0]))
    return (float(x), float(y))


def _runs(labels: list[set[int]]) -> list[tuple[int, int, int]]:
    """The fewest runs (carrier, first edge, number of edges) covering the cyclic sequence
    of edge labels, each run's edges all on its carrier (greedy longest run from a place
    where no carrier continues; optimal for this covering)."""
    n = len(labels)
    common = set.intersection(*labels)
    if common:
        return [(min(common), 0, n)]
    start = next((i for i in range(n) if not labels[i] & labels[i - 1]), None)
    if start is None:
        start = min(range(n), key=lambda i: (len(labels[i]), i))
    runs: list[tuple[int, int, int]] = []
    i = 0
    while i < n:
        best, best_len = -1, 0
        for label in sorted(labels[(start + i) % n]):
            j = i
            while j < n and label in labels[(start + j) % n]:
                j += 1
            if j - i > best_len:
                best, best_len = label, j - i
        runs.append((best, (start + i) % n, best_len))
        i += best_len
    if len(runs) > 1 and runs[0][0] == runs[-1][0]:
        label, first, length = runs.pop()
        runs[0] = (label, first, length + runs[0][2])
    return runs


def _junction(a: Carrier, b: Carrier, near: Pt, after: Pt, tolerance: float) -> Pt | None:
    """Where carrier `a` meets carrier `b`, near the ring's change from one to the other."""
    a_start, a_element = a.element_stub()
    b_start, b_element = b.element_stub()
    candidates = intersections(a_start, a_element, b_start, b_element)
    middle = near
    if candidates:
        best = min(candidates, key=lambda p: math.dist(p, middle))
        if math.dist(best, middle) <= 64 * tolerance:
            return best
    # Tangent carriers (a line into a corner arc, touching circles): the touching point.
    if a.direction is not None and b.direction is not None:
        return None
    circle, other = (b, a) if a.direction is not None else (a, b)
    foot = other.project(circle.origin)
    if other.direction is None and math.dist(circle.origin, other.origin) > 0:
        toward = unit(sub(other.origin, circle.origin))
        options = [
            add(circle.origin, scale(toward, circle.radius)),
            add(circle.origin, scale(toward, -circle.radius)),
        ]
        touch = min(options, key=lambda p: math.dist(p, middle))
    elif math.dist(foot, circle.origin) > 0:
        touch = add(circle.origin, scale(unit(sub(foot, circle.origin)), circle.radius))
    else:
        return None
    if (
        a.distance(touch, 64 * tolerance) <= 2 * tolerance
        and b.distance(touch, 64 * tolerance) <= 2 * tolerance
    ):
        return touch
    return None


def matched_sources(
    ring: Ring, level: Sequence[Carrier], tolerance: float
) -> tuple[tuple[int, int], ...]:
    """The (contour, element) sources of every carrier some ring point lies on."""
    found: set[tuple[int, int]] = set()
    at = np.array(ring, dtype=np.float64).reshape(-1, 2)
    for carrier in level:
        if (carrier.distances(at, tolerance) <= tolerance).any():
            found.update(carrier.sources)
    return tuple(sorted(found))
