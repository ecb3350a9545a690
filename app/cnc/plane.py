"""Plane geometry of tool paths, in float nanometres: a path is a start point and
elements (lines, or arcs with centre and direction), each tagged with its block; vectors,
lengths, sweeps, samples and intersections. The compiler rounds once when it emits moves."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

from app.cnc.blocks import Direction
from app.cnc.geometry import arc_sweep
from app.cnc.units import Units

Pt = tuple[float, float]


EPS = 1e-6  # nm: points closer than this are the same point


BLEND_RADIANS = 1e-6  # a turn smaller than this is a tangent (blended) joint


@dataclass(frozen=True, slots=True)
class Element:
    """One piece of a path: a line to `end`, or an arc to `end` about `centre`.

    `z_dn` is the programmed depth of a contour block (None: keep the current depth).
    `corner` is, for a conrad or chamfer (`tag`) inserted by app.cnc.solve.corners, the
    sharp corner it rounds (the events writer writes a conrad as CR at that corner).
    """

    block: int
    end: Pt
    centre: Pt | None = None
    clockwise: bool = False
    tag: str = ""
    z_dn: int | None = None
    corner: Pt | None = None


@dataclass(frozen=True, slots=True)
class Path:
    """Where the tool goes down, and the elements it then cuts in order."""

    start: Pt
    elements: tuple[Element, ...]


def translated(path: Path, dx: float, dy: float, blocks: int = 0) -> Path:
    """`path` moved by (dx, dy), its elements' block numbers `blocks` on: every point an
    element holds moves (its end, an arc's centre, a conrad's or chamfer's corner)."""

    def at(p: Pt) -> Pt:
        return (p[0] + dx, p[1] + dy)

    elements = tuple(
        replace(
            e,
            block=e.block + blocks,
            end=at(e.end),
            centre=None if e.centre is None else at(e.centre),
            corner=None if e.corner is None else at(e.corner),
        )
        for e in path.elements
    )
    return Path(at(path.start), elements)


def sub(a: Pt, b: Pt) -> Pt:
    return (a[0] - b[0], a[1] - b[1])


def add(a: Pt, b: Pt) -> Pt:
    return (a[0] + b[0], a[1] + b[1])


def scale(a: Pt, k: float) -> Pt:
    return (a[0] * k, a[1] * k)


def unit(a: Pt) -> Pt:
    length = math.hypot(*a)
    return (a[0] / length, a[1] / length)


def cross(a: Pt, b: Pt) -> float:
    return a[0] * b[1] - a[1] * b[0]


def dot(a: Pt, b: Pt) -> float:
    return a[0] * b[0] + a[1] * b[1]


def left_normal(t: Pt) -> Pt:
    return (-t[1], t[0])


def close(a: Pt, b: Pt, eps: float = EPS) -> bool:
    return math.hypot(a[0] - b[0], a[1] - b[1]) <= eps


def tangent(start: Pt, element: Element, at_end: bool) -> Pt:
    """Unit direction of travel at the start or end of an element."""
    if element.centre is None:
        return unit(sub(element.end, start))
    point = element.end if at_end else start
    radial = unit(sub(point, element.centre))
    return (radial[1], -radial[0]) if element.clockwise else left_normal(radial)


def sweep(start: Pt, element: Element) -> float:
    """Angle (radians, > 0) an arc element turns through; 2π when it ends where it starts."""
    assert element.centre is not None
    return arc_sweep(start, element.end, element.centre, element.clockwise)


def length(start: Pt, element: Element) -> float:
    """Path length of an element, in nm."""
    if element.centre is None:
        return math.dist(start, element.end)
    return math.dist(start, element.centre) * sweep(start, element)


def sample(path: Path, step: float) -> list[tuple[Pt, Element]]:
    """Points along a path about `step` nm apart (both ends of each element included)."""
    points: list[tuple[Pt, Element]] = []
    current = path.start
    for element in path.elements:
        n = max(1, math.ceil(length(current, element) / step))
        along = points_along(current, element, [i / n for i in range(n + 1)])
        points += [(p, element) for p in along]
        current = element.end
    return points


def point_at(start: Pt, element: Element, fraction: float) -> Pt:
    """The point a `fraction` (0…1) of the way along an element."""
    return points_along(start, element, (fraction,))[0]


def points_along(start: Pt, element: Element, fractions: Sequence[float]) -> list[Pt]:
    """The points `fractions` (each 0…1) of the way along an element. An arc's centre,
    radius and turn are found once for all of them (a pocket samples thousands)."""
    if element.centre is None:
        d = sub(element.end, start)
        return [(start[0] + d[0] * f, start[1] + d[1] * f) for f in fractions]
    c = element.centre
    radius = math.dist(start, c)
    a0 = math.atan2(start[1] - c[1], start[0] - c[0])
    turn = (-1 if element.clockwise else 1) * sweep(start, element)
    return [
        (c[0] + radius * math.cos(a0 + turn * f), c[1] + radius * math.sin(a0 + turn * f))
        for f in fractions
    ]


def distance_to_element(p: Pt, start: Pt, element: Element) -> float:
    """Shortest distance from point `p` to an element (line segment or arc), in nm."""
    if element.centre is None:
        d = sub(element.end, start)
        denom = dot(d, d)
        t = 0.0 if denom == 0 else max(0.0, min(1.0, dot(sub(p, start), d) / denom))
        return math.dist(p, add(start, scale(d, t)))
    c = element.centre
    radius = math.dist(start, c)
    if close(p, c):
        return radius
    a0 = math.atan2(start[1] - c[1], start[0] - c[0])
    ap = math.atan2(p[1] - c[1], p[0] - c[0])
    along = (a0 - ap) if element.clockwise else (ap - a0)
    along %= 2 * math.pi
    if along <= sweep(start, element) + 1e-12:
        return abs(math.dist(p, c) - radius)
    return min(math.dist(p, start), math.dist(p, element.end))


def signed_area(path: Path) -> float:
    """Signed area enclosed by a closed path (positive counter-clockwise), in nm²."""
    total = 0.0
    current = path.start
    for element in path.elements:
        total += cross(current, element.end) / 2
        if element.centre is not None:
            # The circular segment between the chord and the arc.
            radius = math.dist(current, element.centre)
            theta = sweep(current, element)
            segment = radius * radius * (theta - math.sin(theta)) / 2
            total += -segment if element.clockwise else segment
        current = element.end
    return total


def intersections(a_start: Pt, a: Element, b_start: Pt, b: Element) -> list[Pt]:
    """Intersections of the full line/circle carrying element `a` with that carrying `b`."""
    if a.centre is None and b.centre is None:
        d1, d2 = sub(a.end, a_start), sub(b.end, b_start)
        denom = cross(d1, d2)
        if abs(denom) < 1e-12 * math.hypot(*d1) * math.hypot(*d2):
            return []
        t = cross(sub(b_start, a_start), d2) / denom
        return [add(a_start, scale(d1, t))]
    if a.centre is None or b.centre is None:
        line_start, line, circle_start, circle = (
            (a_start, a, b_start, b) if a.centre is None else (b_start, b, a_start, a)
        )
        assert circle.centre is not None
        return _line_circle(
            line_start, line.end, circle.centre, math.dist(circle_start, circle.centre)
        )
    return _circle_circle(
        a.centre, math.dist(a_start, a.centre), b.centre, math.dist(b_start, b.centre)
    )


def _line_circle(p: Pt, q: Pt, c: Pt, radius: float) -> list[Pt]:
    d = unit(sub(q, p))
    f = sub(p, c)
    b = dot(f, d)
    disc = b * b - (dot(f, f) - radius * radius)
    if disc < 0:
        return []
    root = math.sqrt(disc)
    return [add(p, scale(d, -b - root)), add(p, scale(d, -b + root))]


def _circle_circle(c1: Pt, r1: float, c2: Pt, r2: float) -> list[Pt]:
    d = math.dist(c1, c2)
    if d < EPS or d > r1 + r2 or d < abs(r1 - r2):
        return []
    a = (r1 * r1 - r2 * r2 + d * d) / (2 * d)
    h = math.sqrt(max(r1 * r1 - a * a, 0.0))
    u = unit(sub(c2, c1))
    mid = add(c1, scale(u, a))
    n = left_normal(u)
    return [add(mid, scale(n, h)), add(mid, scale(n, -h))]


def half_step(units: Units) -> float:
    """Half the programming resolution (0.0005 in, 0.005 mm) in nm: a difference smaller
    than this can come from rounding typed values alone, so it is no problem to report."""
    return units.resolution_nm / 2


def reverse(path: Path) -> Path:
    """The same closed path travelled the other way."""
    points = [path.start] + [e.end for e in path.elements]
    elements = []
    for k in range(len(path.elements) - 1, -1, -1):
        e = path.elements[k]
        elements.append(replace(e, end=points[k], clockwise=not e.clockwise))
    return Path(points[-1], tuple(elements))


def dim(nm: float, units: Units = Units.INCH) -> str:
    """A length in nm as a message about a path states it: 4 places in inches, 3 in mm."""
    places = 4 if units is Units.INCH else 3
    return f"{nm / units.nm:.{places}f} {units.symbol}"


def true_arc(start: Pt, end: Pt, centre: Pt, units: Units) -> tuple[Pt, Pt | None]:
    """The arc the control cuts for a typed start, end and centre (nm): (centre, None) when
    the end is on the arc's radius, or (centre, where the arc ends) when it is not.

    An end off the start's radius by no more than half the programming resolution is
    typing, not a mistake (0.001 in cannot place it better), and every reader takes it
    (LinuxCNC allows 0.002 in; our importers the same): the arc is cut as typed. Farther
    off, the start and centre define the radius (seed 001 §3.4.5.2 NOTE): the arc ends on
    that radius at the end's angle, and the returned point is where the divot line, to the
    programmed end, begins. No export then writes an arc whose end is off its radius.
    """
    r_start = math.dist(start, centre)
    if r_start < EPS or close(start, end) or math.dist(end, centre) < EPS:
        return centre, None  # no arc to cut: validation names the zero radius
    if abs(r_start - math.dist(end, centre)) <= half_step(units):
        return centre, None
    radial = unit(sub(end, centre))
    return centre, add(centre, scale(radial, r_start))


def qcir_centre(
    start: tuple[int, int], end: tuple[int, int], direction: Direction
) -> tuple[int, int]:
    """The centre of the quarter circle from `start` to `end` in `direction`.

    The centre lines are parallel to the axes (seed 001 Fig. 3-4), so the centre is one of
    the corners (start.x, end.y) or (end.x, start.y): the one about which the quarter turn
    goes the requested way.
    """
    for centre in ((start[0], end[1]), (end[0], start[1])):
        turn = (start[0] - centre[0]) * (end[1] - centre[1]) - (start[1] - centre[1]) * (
            end[0] - centre[0]
        )
        if (turn > 0) == (direction is Direction.CCW):
            return centre
    raise ValueError("a quarter circle needs equal, non-zero X and Y moves")


def fpt(p: tuple[int, int]) -> Pt:
    """An integer nm point as a path's float point."""
    return (float(p[0]), float(p[1]))
