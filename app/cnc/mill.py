"""Milling geometry: tool-centre paths for contours and CIRCLE/FRAME routines.

Seed 001 §3.4.5.2 (MILL, cutter compensation, CIRCLE/FRAME, POCKET, two-pass) and
DESIGN.md §3 are the sources. Everything here is plane geometry in float nanometres; the
interpreter rounds once when it emits moves. Validation and the interpreter call the same
functions, so what is checked is what is cut.

A path is a start point and a list of elements (lines, or arcs with centre and direction),
each tagged with the block it comes from. Readings we chose (docs/readings.md):

- Compensated contour: the tool plunges at the start of the first offset element (the drill
  point moved one tool radius to the compensation side, perpendicular to the first
  segment) and leaves at the end of the last one. Outside corners are joined by an arc of
  the tool radius about the corner point; inside corners are trimmed to the intersection
  of the two offset elements. The control itself looks one segment ahead and leaves a
  divot at a non-blended inside corner with an arc; we cut the true trimmed path and warn.
- Routines start at the middle of the side nearest the operator (−Y): the bottom of a
  circle, the middle of a frame's lower side. INSIDE/OUTSIDE plunge 0.125 in further from
  the finished surface (less where an inside routine has no room: at most to the centre),
  feed in, go round once, feed back out the same way. IN/TAN and OUT/TAN enter and leave on
  a quarter arc of 0.125 in radius (less where there is no room) tangent to the path.
  POCKET starts like IN/TAN, goes round the wall, then steps toward the centre by the tool
  diameter less 0.050 in until nothing is left, and retracts from the centre.
- Two-pass: roughing 0.010 in off the wall and 0.005 in above Z DN, then the finishing
  pass (a pocket is cleared again).
- Direction: with a clockwise spindle, climb milling goes round an outside contour
  clockwise and an inside one counter-clockwise; conventional the reverse; a negative RPM
  (counter-clockwise spindle) flips both.
Metric blocks use the same constants converted and rounded to 0.01 mm: 3.18, 1.27, 0.25
and 0.13 mm.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from decimal import Decimal
from typing import TYPE_CHECKING, Any

from app.cnc.blocks import (
    ArcEnd,
    Block,
    Circle,
    Comp,
    DataBlock0,
    Direction,
    Entry,
    Frame,
    Hole,
    MillArc,
    MillingMode,
    MillLine,
    MillQcir,
    Placement,
)
from app.cnc.geometry import arc_sweep, resolve_xy
from app.cnc.kinds import REGISTRY, Mill
from app.cnc.problems import Rule, Severity
from app.cnc.ramp import Ramp, angle_of, helix_radius, helix_ramp
from app.cnc.units import Units, half_even, message_length, to_nm

if TYPE_CHECKING:
    from app.cnc.pocketing.model import PocketPlan

Pt = tuple[float, float]
EPS = 1e-6  # nm: points closer than this are the same point
BLEND_RADIANS = 1e-6  # a turn smaller than this is a tangent (blended) joint


def constant(inches: str, millimetres: str, units: Units) -> int:
    """A routine constant in nm, in the block's unit system."""
    return (
        to_nm(Decimal(inches), Units.INCH)
        if units is Units.INCH
        else to_nm(Decimal(millimetres), Units.MM)
    )


def clearance(units: Units) -> int:
    """How far INSIDE/OUTSIDE plunge from the finished surface (0.125 in)."""
    return constant("0.125", "3.18", units)


def pocket_overlap(units: Units) -> int:
    """Overlap of neighbouring pocket passes (0.050 in)."""
    return constant("0.050", "1.27", units)


def rough_wall(units: Units) -> int:
    """Stock left on the wall by the roughing pass of a 2P routine (0.010 in)."""
    return constant("0.010", "0.25", units)


def peck_levels(z_up: int, z_dn: int, pecks: int) -> list[int]:
    """The depths (nm) a drill feeds to: `pecks` levels evenly spaced, the last at Z DN.

    Level k (1…N) is Z UP − k·(Z UP − Z DN)/N, rounded once to the nanometre.
    """
    span = z_up - z_dn
    return [z_up - half_even(k * span, pecks) for k in range(1, pecks + 1)]


def rough_depth(units: Units) -> int:
    """Stock left on the floor by the roughing pass of a 2P routine (0.005 in)."""
    return constant("0.005", "0.13", units)


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


@dataclass(frozen=True, slots=True)
class Finding:
    """A problem the geometry found (validation reports it; the interpreter ignores it)."""

    block: int
    rule: Rule
    severity: Severity
    message: str
    field: str | None = None


@dataclass
class Geometry:
    """A path plus what was found while building it."""

    path: Path
    findings: list[Finding] = field(default_factory=list)


# -- vectors -----------------------------------------------------------------------------


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


# -- elements ------------------------------------------------------------------------------


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


# -- cutter compensation of a contour -----------------------------------------------------


def offset_element(start: Pt, element: Element, side: float, r: float) -> tuple[Pt, Element]:
    """The element moved `r` to the left (`side` +1) or right (−1) of its travel."""
    if element.centre is None:
        n = scale(left_normal(unit(sub(element.end, start))), side * r)
        return add(start, n), replace(element, end=add(element.end, n))
    c = element.centre

    def moved(p: Pt) -> Pt:
        radial = unit(sub(p, c))
        # Left of a counter-clockwise arc is toward its centre; of a clockwise one, away.
        toward_left = scale(radial, -1.0) if not element.clockwise else radial
        return add(p, scale(toward_left, side * r))

    return moved(start), replace(element, end=moved(element.end))


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


def is_zero_length(start: Pt, element: Element) -> bool:
    """A line that goes nowhere (a MILL STD that only changes depth, or does nothing)."""
    return element.centre is None and close(start, element.end)


def compensate(
    path: Path, comp: Comp, r: float, blocks: list[int], units: Units = Units.INCH
) -> Geometry:
    """The tool-centre path of a contour whose finished surface is `path`.

    `blocks` gives, for each element, the block number used to name corners in findings.
    A line that goes nowhere keeps its place (and its depth change) where the tool is; the
    corner is made between the elements that go somewhere. A corner whose turn is too small
    to matter at the programming resolution (the tool radius times the turn, or the divot
    it would leave, under half a step) is joined as a tangent: rounding a fillet's points
    to 0.001 in must not create problems.
    """
    if comp is Comp.NONE or not path.elements:
        return Geometry(path)
    side = 1.0 if comp is Comp.LEFT else -1.0
    findings: list[Finding] = []
    starts = [path.start] + [e.end for e in path.elements[:-1]]
    real = [k for k, e in enumerate(path.elements) if not is_zero_length(starts[k], e)]
    if not real:
        return Geometry(path)
    for k in real:
        start, element = starts[k], path.elements[k]
        if element.centre is None:
            continue
        radius = math.dist(start, element.centre)
        # Left of a counter-clockwise arc (right of a clockwise one) is toward its centre.
        toward_centre = (side > 0) != element.clockwise
        if toward_centre and radius <= r + EPS:
            findings.append(
                Finding(
                    element.block,
                    Rule.COMP_ARC_TOO_SMALL,
                    Severity.ERROR,
                    f"the arc's radius {_len(radius, units)} is not more than the tool radius "
                    f"{_len(r, units)}; the tool cannot follow it on the inside",
                )
            )
    if any(f.severity is Severity.ERROR for f in findings):
        return Geometry(path, findings)
    offsets = {k: offset_element(starts[k], path.elements[k], side, r) for k in real}
    negligible = half_step(units)
    pieces: list[tuple[Pt, Element]] = []
    stays: list[Element] = []  # lines that go nowhere since the last real element
    last = -1  # the last real element joined, and its piece's index
    last_piece = -1
    for k, element in enumerate(path.elements):
        if k not in offsets:
            stays.append(element)
            continue
        next_start, nxt = offsets[k]
        if last < 0:
            # Lines before the first real one: the tool waits at the plunge point.
            pieces += [(next_start, replace(e, end=next_start)) for e in stays]
            stays = []
            pieces.append((next_start, nxt))
            last, last_piece = k, len(pieces) - 1
            continue
        prev_start, prev = pieces[last_piece]
        corner = starts[k]
        t1 = tangent(starts[last], path.elements[last], at_end=True)
        t2 = tangent(corner, element, at_end=False)
        turn = math.atan2(cross(t1, t2), dot(t1, t2))
        here = f"the corner between blocks {blocks[last]} and {blocks[k]}"
        outside = turn * side < 0
        divot = r * (1 - math.cos(turn))
        link = (
            [(prev.end, Element(prev.block, next_start))] if not close(prev.end, next_start) else []
        )
        joint: list[tuple[Pt, Element]]
        if abs(turn) < BLEND_RADIANS:
            joint = [(prev.end, nxt)]
        elif outside:
            if r * abs(turn) <= negligible:
                # A turn too small to matter: the arc would be shorter than half a step.
                joint = [*link, (next_start, nxt)]
            else:
                # Outside corner: an arc of the tool radius about the corner point.
                arc = Element(prev.block, next_start, centre=corner, clockwise=side > 0)
                joint = [(prev.end, arc), (next_start, nxt)]
        else:
            both_lines = path.elements[last].centre is None and element.centre is None
            inside_angle = math.degrees(math.pi - abs(turn))
            candidates = intersections(prev_start, prev, next_start, nxt)
            if both_lines and inside_angle < 20 - 1e-9:
                findings.append(
                    Finding(
                        blocks[k],
                        Rule.INSIDE_ANGLE,
                        Severity.ERROR,
                        f"{here} is an inside angle of {inside_angle:.1f}°; the tool cannot be "
                        "on the inside of a line-to-line angle under 20° (emergency stop)",
                    )
                )
                joint = [(prev.end, nxt)]
            elif not candidates:
                if divot > negligible:
                    findings.append(
                        Finding(
                            blocks[k],
                            Rule.COMP_GOUGE,
                            Severity.WARNING,
                            f"at {here} the offset path does not meet; the tool would cut "
                            "into the part",
                        )
                    )
                joint = [*link, (next_start, nxt)]
            else:
                if not both_lines and divot > negligible:
                    findings.append(
                        Finding(
                            blocks[k],
                            Rule.COMP_DIVOT,
                            Severity.WARNING,
                            f"{here} is a non-blended inside corner with an arc; MillBlocks "
                            "cuts the true trimmed path, but the original control (and an "
                            f"events export) would leave a divot of about {_len(divot, units)} "
                            "here",
                        )
                    )
                meet = min(candidates, key=lambda p: math.dist(p, corner))
                pieces[last_piece] = (prev_start, replace(prev, end=meet))
                joint = [(meet, nxt)]
        # The lines that went nowhere stay where the previous element ended.
        at = pieces[last_piece][1].end
        pieces += [(at, replace(e, end=at)) for e in stays]
        stays = []
        pieces += joint
        last, last_piece = k, len(pieces) - 1
    at = pieces[-1][1].end
    pieces += [(at, replace(e, end=at)) for e in stays]
    elements = tuple(e for _, e in pieces)
    result = Path(pieces[0][0], elements)
    if not any(f.severity is Severity.ERROR for f in findings):
        findings += gouges(path, result, r, blocks, units)
    return Geometry(result, findings)


def nearest_on_element(p: Pt, start: Pt, element: Element) -> Pt:
    """The point of an element (line segment or arc) nearest to `p`."""
    if element.centre is None:
        d = sub(element.end, start)
        denom = dot(d, d)
        t = 0.0 if denom == 0 else max(0.0, min(1.0, dot(sub(p, start), d) / denom))
        return add(start, scale(d, t))
    c = element.centre
    if close(p, c):
        return start
    a0 = math.atan2(start[1] - c[1], start[0] - c[0])
    ap = math.atan2(p[1] - c[1], p[0] - c[0])
    along = (a0 - ap) if element.clockwise else (ap - a0)
    along %= 2 * math.pi
    if along <= sweep(start, element) + 1e-12:
        return add(c, scale(sub(p, c), math.dist(start, c) / math.dist(p, c)))
    return min((start, element.end), key=lambda q: math.dist(p, q))


def _notch(
    finished: Path, starts: list[Pt], k: int, centre: Pt, r: float, tolerance: float
) -> tuple[float, int] | None:
    """The notch the tool at `centre` is wedged in, if it is one: (width, the other wall's
    index) when the tool overlaps element k and another element on its opposite side (the two
    walls face each other across the tool, closer together than its diameter)."""
    wall = nearest_on_element(centre, starts[k], finished.elements[k])
    towards = sub(centre, wall)
    best: tuple[float, int] | None = None
    for j, (s, e) in enumerate(zip(starts, finished.elements, strict=True)):
        if j == k:
            continue
        other = nearest_on_element(centre, s, e)
        if r - math.dist(centre, other) <= tolerance or dot(towards, sub(centre, other)) >= 0:
            continue
        width = math.dist(wall, other)
        if width < 2 * r and (best is None or width < best[0]):
            best = (width, j)
    return best


def gouges(finished: Path, tool: Path, r: float, blocks: list[int], units: Units) -> list[Finding]:
    """Where the tool centre comes closer than its radius to another part of the contour.

    One warning per contour block cut into, naming the block whose path does it and the
    deepest cut found at samples an eighth of the tool radius apart. Where the tool is wedged
    between two walls closer together than its diameter, the warning says the tool does not
    fit (no starting point helps); otherwise it is the control's one-segment look-ahead.
    """
    worst: dict[int, tuple[float, int, Pt]] = {}
    starts = [finished.start] + [e.end for e in finished.elements[:-1]]
    tolerance = max(r * 1e-4, half_step(units))
    for point, element in sample(tool, max(r / 8, 1000.0)):
        for k, (s, e) in enumerate(zip(starts, finished.elements, strict=True)):
            depth = r - distance_to_element(point, s, e)
            if depth > tolerance and depth > worst.get(k, (0.0, 0, point))[0]:
                worst[k] = (depth, element.block, point)
    findings = []
    for k, (depth, source, centre) in sorted(worst.items()):
        cut = (
            f"the compensated path from block {source} cuts into block {blocks[k]} by "
            f"{_len(depth, units)}"
        )
        notch = _notch(finished, starts, k, centre, r, tolerance)
        if notch is None:
            advice = (
                "the control looks only one segment ahead, so choose another starting point "
                "or split the contour"
            )
        else:
            width, j = notch
            advice = (
                f"the notch between blocks {min(blocks[k], blocks[j])} and "
                f"{max(blocks[k], blocks[j])} is {_len(width, units)} wide, narrower than "
                f"the {_len(2 * r, units)} tool: the tool does not fit; use a smaller tool "
                f"(under {_len(width, units)})"
            )
        findings.append(Finding(blocks[k], Rule.COMP_GOUGE, Severity.WARNING, f"{cut}; {advice}"))
    return findings


# -- CIRCLE and FRAME routines ------------------------------------------------------------


@dataclass(frozen=True)
class Routine:
    """What a CIRCLE/FRAME routine needs: the finished contour and how to cut it.

    Lengths in nm. For a circle `centre` and `radius`; for a frame `corner` (lower left),
    `width` (XL), `height` (YW) and `corner_radius`.
    """

    block: int
    placement: Placement
    clockwise: bool
    tool_radius: int
    units: Units
    centre: Pt = (0.0, 0.0)
    radius: int = 0
    corner: Pt = (0.0, 0.0)
    width: int = 0
    height: int = 0
    corner_radius: int = 0
    is_frame: bool = False


def routine_problems(routine: Routine) -> list[Finding]:
    """What makes a routine impossible (errors) or imperfect (warnings)."""
    r = routine.tool_radius
    findings: list[Finding] = []
    inside = routine.placement in (Placement.INSIDE, Placement.IN_TAN, Placement.POCKET)
    n = routine.block
    size = (routine.width, routine.height) if routine.is_frame else (routine.radius,)
    if r <= 0 or min(size) <= 0:
        return findings  # no tool diameter, or a size out of range: reported by the field checks
    if routine.is_frame:
        half_short = min(routine.width, routine.height) / 2
        if routine.corner_radius > half_short:
            findings.append(
                Finding(
                    n,
                    Rule.FRAME_CORNER,
                    Severity.ERROR,
                    f"corner radius {_len(routine.corner_radius, routine.units)} is too large "
                    f"for a {_len(routine.width, routine.units)} × "
                    f"{_len(routine.height, routine.units)} frame; allowed 0 to "
                    f"{_len(half_short, routine.units)} (the corners must meet)",
                    "CORNER RAD",
                )
            )
        if inside and half_short <= r:
            findings.append(_too_small(routine, "frame", half_short * 2))
        elif (inside and 0 < routine.corner_radius < r) or (inside and routine.corner_radius == 0):
            findings.append(
                Finding(
                    n,
                    Rule.CORNER_UNREACHABLE,
                    Severity.WARNING,
                    f"corner radius {_len(routine.corner_radius, routine.units)} is smaller "
                    f"than the tool radius {_len(r, routine.units)}; the tool leaves material "
                    f"in the four corners",
                    "CORNER RAD",
                )
            )
    elif inside and routine.radius <= r:
        findings.append(_too_small(routine, "circle", routine.radius * 2))
    if routine.placement is Placement.POCKET and 2 * r <= pocket_overlap(routine.units):
        findings.append(
            Finding(
                n,
                Rule.POCKET_TOOL,
                Severity.ERROR,
                f"a {_len(2 * r, routine.units)} tool leaves no step-over: pocket passes "
                f"overlap by {_len(pocket_overlap(routine.units), routine.units)}, so the "
                "tool must be larger than that",
                "TOOL #",
            )
        )
    return findings


def _too_small(routine: Routine, what: str, size: float) -> Finding:
    u = routine.units
    return Finding(
        routine.block,
        Rule.ROUTINE_TOO_SMALL,
        Severity.ERROR,
        f"the {what} ({_len(size, u)} across) is not larger than the "
        f"{_len(2 * routine.tool_radius, u)} tool; the tool cannot go inside it",
    )


def routine_path(routine: Routine, wall_allowance: int = 0) -> Path:
    """Lead-in, the pass (or pocket passes) and lead-out of a routine at one depth.

    `wall_allowance` leaves that much stock on the wall (the roughing pass of a 2P routine).
    """
    inside = routine.placement in (Placement.INSIDE, Placement.IN_TAN, Placement.POCKET)
    r = routine.tool_radius + wall_allowance
    offset = -r if inside else r
    wall = _closed_pass(routine, offset)
    start = wall.start
    away = _away(routine, inside)
    room = _room(routine, r) if inside else math.inf
    if not wall.elements:
        return Path(start, ())
    n = routine.block
    if routine.placement in (Placement.INSIDE, Placement.OUTSIDE):
        reach = min(float(clearance(routine.units)), room)
        plunge = add(start, scale(away, reach))
        elements = [Element(n, start, tag="lead-in"), *wall.elements]
        elements.append(Element(n, plunge, tag="lead-out"))
        return Path(plunge, tuple(elements))
    lead = min(float(clearance(routine.units)), room / 2 if inside else math.inf)
    t = tangent(start, wall.elements[0], at_end=False)
    lead_centre = add(start, scale(away, lead))
    lead_cw = cross(t, away) < 0
    plunge = add(lead_centre, scale(t, -lead))
    lead_in = Element(n, start, centre=lead_centre, clockwise=lead_cw, tag="lead-in")
    if routine.placement is not Placement.POCKET:
        exit_point = add(lead_centre, scale(t, lead))
        lead_out = Element(n, exit_point, centre=lead_centre, clockwise=lead_cw, tag="lead-out")
        return Path(plunge, (lead_in, *wall.elements, lead_out))
    elements = [lead_in, *wall.elements]
    step = 2 * routine.tool_radius - pocket_overlap(routine.units)
    depth = float(r)
    while True:
        depth += step
        inner = _closed_pass(routine, -depth, -(depth - step)) if _fits(routine, depth) else None
        if inner is None:
            elements.extend(_pocket_finish(routine, depth - step))
            break
        elements.append(Element(n, inner.start, tag="step-over"))
        elements.extend(inner.elements)
    return Path(plunge, tuple(elements))


def _away(routine: Routine, inside: bool) -> Pt:
    """Unit vector at the routine's start pointing away from the finished surface."""
    # The start is at the bottom of the contour: inside means up (+Y), outside down (−Y).
    return (0.0, 1.0) if inside else (0.0, -1.0)


def _room(routine: Routine, offset: float) -> float:
    """How far the tool centre can move inward from the wall pass's start point."""
    if routine.is_frame:
        return min(routine.width, routine.height) / 2 - offset
    return routine.radius - offset


def _fits(routine: Routine, depth: float) -> bool:
    """True when an inner pass `depth` in from the wall still encloses an area."""
    if routine.is_frame:
        return min(routine.width, routine.height) / 2 - depth > EPS
    return routine.radius - depth > EPS


def _pocket_finish(routine: Routine, last: float) -> list[Element]:
    """What clears the middle after the last full pass, `last` in from the wall.

    A circle's middle is cleared by a move to the centre; a frame's by a line along its
    centre line (the long way), which leaves no point farther than half a step from a cut.
    """
    n = routine.block
    if not routine.is_frame:
        if routine.radius - last <= routine.tool_radius + EPS:
            return []
        return [Element(n, routine.centre, tag="step-over")]
    x0, y0 = routine.corner
    w, h = routine.width, routine.height
    if min(w, h) / 2 - last <= routine.tool_radius + EPS:
        return []
    cx, cy = x0 + w / 2, y0 + h / 2
    if w >= h:
        return [
            Element(n, (cx, cy), tag="step-over"),
            Element(n, (x0 + h / 2, cy)),
            Element(n, (x0 + w - h / 2, cy)),
        ]
    return [Element(n, (cx, y0 + w / 2), tag="step-over"), Element(n, (cx, y0 + h - w / 2))]


def _closed_pass(routine: Routine, offset: float, previous: float | None = None) -> Path:
    """One closed pass `offset` outside (+) or inside (−) the finished contour.

    It starts and ends at the bottom (the middle of a frame's lower side) and runs in the
    routine's direction. A frame's corners are arcs of radius corner radius + offset, or
    sharp where an inside offset uses the radius up. An inner pocket pass (`previous` is the
    offset of the pass before it) reaches out from each sharp corner along the diagonal to
    the previous pass's corner (or its arc) and back: along the diagonal two passes are
    farther apart than the step-over, and this spike clears what lies between them.
    """
    n = routine.block
    if not routine.is_frame:
        radius = routine.radius + offset
        cx, cy = routine.centre
        start = (cx, cy - radius)
        return Path(start, (Element(n, start, centre=routine.centre, clockwise=routine.clockwise),))
    x0, y0 = routine.corner[0] - offset, routine.corner[1] - offset
    x1 = routine.corner[0] + routine.width + offset
    y1 = routine.corner[1] + routine.height + offset
    rad = max(routine.corner_radius + offset, 0.0)
    start = ((x0 + x1) / 2, y0)
    # Counter-clockwise from the bottom middle: along the bottom, up, along the top, down.
    turns = [
        ((x1 - rad, y0), (x1 - rad, y0 + rad), (x1, y0 + rad)),
        ((x1, y1 - rad), (x1 - rad, y1 - rad), (x1 - rad, y1)),
        ((x0 + rad, y1), (x0 + rad, y1 - rad), (x0, y1 - rad)),
        ((x0, y0 + rad), (x0 + rad, y0 + rad), (x0 + rad, y0)),
    ]
    elements: list[Element] = []
    prev_rad = 0.0 if previous is None else max(routine.corner_radius + previous, 0.0)
    for before, centre, after in turns:
        elements.append(Element(n, before))
        if rad > EPS:
            elements.append(Element(n, after, centre=centre, clockwise=False))
        elif previous is not None:
            fixed = _corner_centre(routine, before)
            if prev_rad > EPS:
                # Every round pass has this corner's arc about the finished corner's centre.
                outward = sub(before, fixed)
                if close(before, fixed):
                    # The sharp corner sits on that centre: out along the corner's diagonal.
                    mid = (
                        routine.corner[0] + routine.width / 2,
                        routine.corner[1] + routine.height / 2,
                    )
                    outward = (
                        math.copysign(1.0, before[0] - mid[0]),
                        math.copysign(1.0, before[1] - mid[1]),
                    )
                reach = add(fixed, scale(unit(outward), prev_rad))
            else:
                # The previous pass's sharp corner, one step out along the diagonal.
                step = previous - offset
                out_x = math.copysign(step, fixed[0] - before[0])
                out_y = math.copysign(step, fixed[1] - before[1])
                reach = (before[0] + out_x, before[1] + out_y)
            elements.append(Element(n, reach, tag="corner"))
            elements.append(Element(n, before, tag="corner"))
    elements.append(Element(n, start))
    # A side whose corner arcs meet (a corner radius of half the side) has no straight part.
    kept: list[Element] = []
    here = start
    for element in elements:
        if not is_zero_length(here, element):
            kept.append(element)
            here = element.end
    ccw = Path(start, tuple(kept))
    return reverse(ccw) if routine.clockwise else ccw


def _corner_centre(routine: Routine, near: Pt) -> Pt:
    """The centre of the finished frame's corner arc nearest to `near`."""
    x0, y0 = routine.corner
    cr = routine.corner_radius
    cx = x0 + cr if near[0] < x0 + routine.width / 2 else x0 + routine.width - cr
    cy = y0 + cr if near[1] < y0 + routine.height / 2 else y0 + routine.height - cr
    return (cx, cy)


def reverse(path: Path) -> Path:
    """The same closed path travelled the other way."""
    points = [path.start] + [e.end for e in path.elements]
    elements = []
    for k in range(len(path.elements) - 1, -1, -1):
        e = path.elements[k]
        elements.append(replace(e, end=points[k], clockwise=not e.clockwise))
    return Path(points[-1], tuple(elements))


def _len(nm: float, units: Units = Units.INCH) -> str:
    places = 4 if units is Units.INCH else 3
    return f"{nm / units.nm:.{places}f} {units.symbol}"


# -- from blocks to paths -------------------------------------------------------------------


@dataclass
class SequencePlan:
    """How a mill sequence is cut: one path per pass, all starting at the same depth rules.

    `passes` holds the contour's tool path, or a routine's passes (the roughing pass first
    for 2P). `rough_allowance` is how far above Z DN the roughing levels stop (0 without 2P).
    `end` is the programmed end point, the reference for a following INC block.
    What the sequence is programmed to make, whatever its errors (the compile keeps it, so
    no consumer plans again): `finished` a contour's path; `routine` a CIRCLE/FRAME's
    circle or frame; `outlines` a POCKET's wall ("boundary") and islands ("island 1", …).
    """

    passes: list[Path]
    rough_allowance: int
    end: tuple[int, int]
    findings: list[Finding]
    finished: Path | None = None  # a contour's programmed path (None for a routine)
    pocket: PocketPlan | None = None  # a POCKET's plan: its passes with their links
    routine: Routine | None = None  # a CIRCLE/FRAME routine's size and direction
    outlines: tuple[tuple[str, Path], ...] = ()  # a POCKET's contours, by name
    ramp: Ramp | None = None  # a pocketing routine's ramp entry (None: it plunges)
    # Values calculated from the print (app.cnc.solve): (block number, field) → value.
    calculated: dict[tuple[int, str], Decimal] = field(default_factory=dict)


def plan_sequence(
    blocks: tuple[Block, ...],
    block0: DataBlock0,
    program_units: Units,
    drill_index: int,
    mills: tuple[int, ...],
    start: tuple[int, int],
) -> SequencePlan:
    """The tool paths of the mill sequence started by DRILL `drill_index` at `start` (nm).

    Problems found (compensation limits, routine sizes) are returned, not raised: the
    interpreter is only called on programs whose plan has no errors.
    """
    drill = blocks[drill_index]
    assert isinstance(drill, Hole)
    tool = block0.tool(drill.tool)
    diameter = None if tool is None or tool.diameter is None else tool.diameter
    radius = 0 if diameter is None else to_nm(diameter, program_units) // 2
    first = blocks[mills[0]]
    if REGISTRY.of(first).mill is Mill.ROUTINE:
        # A routine kind declares its planner (app.cnc.kinds): the signature of plan_circle.
        rpm = None if tool is None else tool.rpm
        planner = REGISTRY.planner(type(first))
        contours = tuple((i + 1, blocks[i]) for i in mills[1:])
        at = RoutineStart(mills[0] + 1, block0, rpm, radius, start, contours)
        plan: SequencePlan = planner(first, at)
        if plan.ramp is not None and not drill.has_depth:
            # A 2-axis sequence's depth is the operator's quill: no ramp, and no silent plunge.
            message = (
                "a ramp entry goes down along X and Y, and this sequence's depth is the "
                "quill's (its DRILL has no Z UP/Z DN): leave ENTRY empty (PLUNGE)"
            )
            finding = Finding(mills[0] + 1, Rule.RAMP_ENTRY, Severity.ERROR, message, "ENTRY")
            return SequencePlan([], 0, start, [*plan.findings, finding])
        return plan
    findings: list[Finding] = []
    depth = None if drill.z_dn is None else to_nm(drill.z_dn, drill.units)
    calculated: dict[tuple[int, str], Decimal] = {}
    path, numbers, end = programmed_contour(
        blocks, mills, start, findings, depth, calculated=calculated
    )
    if any(f.severity is Severity.ERROR for f in findings):
        return SequencePlan([], 0, end, findings, path, calculated=calculated)
    if drill.comp is Comp.NONE or diameter is None:
        return SequencePlan([path], 0, end, findings, path, calculated=calculated)
    geometry = compensate(path, drill.comp, float(radius), numbers, drill.units)
    return SequencePlan(
        [geometry.path], 0, end, findings + geometry.findings, path, calculated=calculated
    )


INSIDE_PLACEMENTS = (Placement.INSIDE, Placement.IN_TAN, Placement.POCKET)


def routine_clockwise(placement: Placement, milling: MillingMode, rpm: int | None) -> bool:
    """The direction a CIRCLE/FRAME routine goes round, seen from above (DESIGN.md §3).

    With a clockwise spindle (RPM positive, or not entered), climb milling goes round an
    outside contour clockwise and an inside one (and a pocket) counter-clockwise;
    conventional the reverse; a negative RPM (counter-clockwise spindle) flips both.
    """
    spindle_cw = rpm is None or rpm > 0
    outside_cw = (milling is MillingMode.CLIMB) == spindle_cw
    return not outside_cw if placement in INSIDE_PLACEMENTS else outside_cw


@dataclass(frozen=True)
class RoutineStart:
    """What a mill routine's planner is given (the hook a routine kind declares, see
    app.cnc.kinds): its block number, Data Block 0, the tool's RPM (its sign gives the
    spindle direction), the tool's radius in nm (0: no DIA, which validation reports) and
    the start point in nm (the previous DRILL's X/Y); for a routine that takes contour
    blocks (POCKET), those blocks with their numbers."""

    number: int
    block0: DataBlock0
    rpm: int | None
    tool_radius: int
    start: tuple[int, int]
    geometry: tuple[tuple[int, Block], ...] = ()


def plan_circle(block: Block, at: RoutineStart) -> SequencePlan:
    """The passes of a CIRCLE about `at.start`. Problems are in the plan, not raised."""
    assert isinstance(block, Circle)
    routine = Routine(
        **_routine_common(block, at),
        centre=(float(at.start[0]), float(at.start[1])),
        radius=to_nm(block.radius, block.units),
    )
    return _plan_routine(routine, block, at.start)


def plan_frame(block: Block, at: RoutineStart) -> SequencePlan:
    """The passes of a FRAME whose lower-left corner is `at.start`; as `plan_circle`."""
    assert isinstance(block, Frame)
    units = block.units
    routine = Routine(
        **_routine_common(block, at),
        corner=(float(at.start[0]), float(at.start[1])),
        width=to_nm(block.xl, units),
        height=to_nm(block.yw, units),
        corner_radius=to_nm(block.corner_radius, units),
        is_frame=True,
    )
    return _plan_routine(routine, block, at.start)


def _routine_common(block: Circle | Frame, at: RoutineStart) -> dict[str, Any]:
    return {
        "block": at.number,
        "placement": block.placement,
        "clockwise": routine_clockwise(block.placement, at.block0.milling, at.rpm),
        "tool_radius": at.tool_radius,
        "units": block.units,
    }


def _plan_routine(routine: Routine, block: Circle | Frame, start: tuple[int, int]) -> SequencePlan:
    findings = routine_problems(routine) + _entry_problems(routine, block)
    if any(f.severity is Severity.ERROR for f in findings) or routine.tool_radius == 0:
        return SequencePlan([], 0, start, findings, routine=routine)
    passes = [routine_path(routine)]
    allowance = 0
    if block.two_pass:
        allowance = rough_wall(routine.units)
        passes.insert(0, routine_path(routine, wall_allowance=allowance))
    ramp = None
    if block.entry is Entry.HELIX:
        ramp, problem = _helix_entry(routine, passes[0], allowance, angle_of(block.ramp_angle))
        if problem is not None:
            return SequencePlan([], 0, start, [*findings, problem], routine=routine)
    depth = rough_depth(routine.units) if block.two_pass else 0
    return SequencePlan(passes, depth, start, findings, ramp=ramp, routine=routine)


def routine_outline(routine: Routine) -> Path:
    """A CIRCLE's or FRAME's finished contour as a path (float nm): a circle clockwise from
    its top, a frame counter-clockwise from its bottom edge (corner arcs where it has a
    corner radius, limited to half the shorter side)."""
    ox, oy = routine.corner if routine.is_frame else routine.centre
    if not routine.is_frame:
        r = float(routine.radius)
        top = (ox, oy + r)
        bottom = (ox, oy - r)
        return Path(top, (Element(0, bottom, (ox, oy), True), Element(0, top, (ox, oy), True)))
    w, h = float(routine.width), float(routine.height)
    c = min(float(routine.corner_radius), w / 2, h / 2)
    corners = [
        ((ox + w - c, oy), (ox + w, oy + c), (ox + w - c, oy + c)),
        ((ox + w, oy + h - c), (ox + w - c, oy + h), (ox + w - c, oy + h - c)),
        ((ox + c, oy + h), (ox, oy + h - c), (ox + c, oy + h - c)),
        ((ox, oy + c), (ox + c, oy), (ox + c, oy + c)),
    ]
    elements = []
    for line_end, arc_end, centre in corners:
        elements.append(Element(0, line_end))
        if c > 0:
            elements.append(Element(0, arc_end, centre, False))
    return Path((ox + c, oy), tuple(elements))


def _entry_problems(routine: Routine, block: Circle | Frame) -> list[Finding]:
    """ENTRY and RAMP ANGLE where they do not apply: a ramp is a pocket's way down."""
    if block.entry is not None and routine.placement is not Placement.POCKET:
        return [
            Finding(
                routine.block,
                Rule.RAMP_ENTRY,
                Severity.ERROR,
                f"ENTRY {block.entry.name} applies only to a POCKET routine; "
                f"{block.type_name} goes down beside the wall and enters on its lead-in: "
                "leave ENTRY empty (PLUNGE)",
                "ENTRY",
            )
        ]
    if block.ramp_angle is not None and block.entry is None:
        return [
            Finding(
                routine.block,
                Rule.RAMP_ENTRY,
                Severity.ERROR,
                "a RAMP ANGLE applies only to a ramp entry; with ENTRY empty (PLUNGE) the tool "
                "goes straight down: choose ENTRY HELIX or leave RAMP ANGLE empty",
                "RAMP ANGLE",
            )
        ]
    return []


def _helix_entry(
    routine: Routine, first: Path, allowance: int, angle: Decimal
) -> tuple[Ramp | None, Finding | None]:
    """The helical ramp at the entry point of the first pass `first` (its lead-in arc's
    start), or the error when its circle does not fit inside that pass (`allowance`: the
    stock the pass leaves on the wall)."""
    lead_in = first.elements[0]
    assert lead_in.centre is not None  # a POCKET routine enters on a lead-in arc
    r = float(routine.tool_radius)
    wall = r + allowance
    # Into the pocket: from where the lead-in meets the wall pass towards its centre.
    inward = unit(sub(lead_in.centre, lead_in.end))

    def ramp(radius: float) -> Ramp:
        return helix_ramp(first.start, inward, routine.clockwise, radius, angle)

    def fits(radius: float) -> bool:
        return _room_inside(routine, wall, ramp(radius).centre) >= radius - EPS

    wanted = helix_radius(r)
    if fits(wanted):
        return ramp(wanted), None
    low, high = 0.0, wanted
    for _ in range(60):
        mid = (low + high) / 2
        low, high = (mid, high) if fits(mid) else (low, mid)
    u = routine.units
    return None, Finding(
        routine.block,
        Rule.RAMP_ENTRY,
        Severity.ERROR,
        f"a HELIX ramp with a {_len(2 * r, u)} tool goes round a circle "
        f"{_len(2 * wanted, u)} across (half the tool's DIA), which does not fit inside the "
        f"first pass at its entry point: a circle at most {_len(2 * low, u)} across fits "
        "there; a larger pocket, a smaller tool, or ENTRY empty (PLUNGE)",
        "ENTRY",
    )


def _room_inside(routine: Routine, wall: float, point: Pt) -> float:
    """How far `point` is inside the region a tool centre may reach in the routine's
    contour, `wall` (nm) in from it (negative: outside it)."""
    if not routine.is_frame:
        return routine.radius - wall - math.dist(point, routine.centre)
    x0, y0 = routine.corner[0] + wall, routine.corner[1] + wall
    x1 = routine.corner[0] + routine.width - wall
    y1 = routine.corner[1] + routine.height - wall
    rad = max(routine.corner_radius - wall, 0.0)
    px, py = point
    # In a corner's square the rounded corner is what is nearest.
    cx = x0 + rad if px < x0 + rad else x1 - rad if px > x1 - rad else None
    cy = y0 + rad if py < y0 + rad else y1 - rad if py > y1 - rad else None
    if cx is not None and cy is not None and rad > 0:
        return rad - math.dist(point, (cx, cy))
    return min(px - x0, x1 - px, py - y0, y1 - py)


def programmed_contour(
    blocks: tuple[Block, ...],
    mills: tuple[int, ...],
    start: tuple[int, int],
    findings: list[Finding] | None = None,
    depth: int | None = None,
    *,
    with_corners: bool = True,
    calculated: dict[tuple[int, str], Decimal] | None = None,
) -> tuple[Path, list[int], tuple[int, int]]:
    """The finished contour of line, quarter-circle and arc blocks from `start` (nm).

    Empty coordinates, tangencies and radii are solved first (app.cnc.solve: the values
    it calculates go into `calculated`); conrads and chamfers are inserted last
    (`with_corners`), tagged with the block of their corner.

    Returns the path, the block number of each element, and the end point. What is wrong
    with the geometry is appended to `findings`: a quarter circle whose moves are not equal
    (error; cut as a line so the path stays whole), an arc about its own start (error), an
    arc's end off its radius (warning: the divot the control cuts), a MILL STD that goes
    nowhere (warning). `depth` (nm) is the depth the tool is at when the contour starts
    (the DRILL's Z DN): a MILL STD to a new Z DN is a plunge, not a zero-length cut.
    """
    from app.cnc import solve  # solve builds on this module's geometry

    found: list[Finding] = [] if findings is None else findings
    solution = None
    if solve.needs_solving(blocks, mills):
        # Calculated geometry (issue 33): solved once, here, where every reader of a
        # contour gets it; what cannot be solved leaves the contour uncut.
        solution = solve.solve_contour(blocks, mills, start)
        found += solution.findings
        if calculated is not None:
            calculated.update(solution.calculated)
        if solution.failed:
            return Path(_f(start), ()), [], start
    reference = start
    elements: list[Element] = []
    numbers: list[int] = []
    for index in mills:
        block = blocks[index]
        if isinstance(block, ArcEnd):
            continue
        assert isinstance(block, MillLine | MillQcir | MillArc)
        number = index + 1
        units = block.units
        z_dn = None if block.z_dn is None else to_nm(block.z_dn, units)
        if solution is not None:
            end = solution.ends[index]
        else:
            end = resolve_xy(*_typed(block), block.mode, units, reference)
        centre: tuple[int, int] | None = None
        clockwise = False
        if isinstance(block, MillQcir):
            dx, dy = end[0] - reference[0], end[1] - reference[1]
            if dx == 0 or abs(dx) != abs(dy):
                found.append(
                    Finding(
                        number,
                        Rule.QCIR_CENTRE_LINES,
                        Severity.ERROR,
                        "QCIR end point is not a quarter circle from the start: its X and Y "
                        f"moves must be equal and not zero (X move {message_length(dx, units)}, "
                        f"Y move {message_length(dy, units)}); the centre lines must be "
                        "parallel to the X and Y axes",
                    )
                )
            else:
                centre = qcir_centre(reference, end, block.direction)
                clockwise = block.direction is Direction.CW
        elif isinstance(block, MillArc):
            end_block = blocks[index + 1]
            assert isinstance(end_block, ArcEnd)
            if solution is not None:
                centre = solution.centres[index]
            else:
                centre = end
                end = resolve_xy(*_typed(end_block), end_block.mode, end_block.units, reference)
            clockwise = block.direction is Direction.CW
            if z_dn is not None:
                depth = z_dn
            if centre == reference:
                found.append(
                    Finding(
                        number,
                        Rule.ZERO_LENGTH,
                        Severity.ERROR,
                        "the arc's centre is its start point; the radius would be zero",
                        "X",
                    )
                )
            elif centre == end:
                found.append(
                    Finding(
                        number + 1,
                        Rule.ZERO_LENGTH,
                        Severity.ERROR,
                        "the arc's end is its centre; an arc cannot end at its centre (the "
                        "XY-END point must lie on the circle through the start)",
                        "X",
                    )
                )
            true_centre, divot_at = true_arc(_f(reference), _f(end), _f(centre), units)
            if divot_at is not None:
                r_start = math.dist(reference, centre)
                r_end = math.dist(centre, end)
                divot = round(abs(r_start - r_end))
                found.append(
                    Finding(
                        number + 1,
                        Rule.ARC_RADIUS,
                        Severity.WARNING,
                        f"the arc's end is {message_length(divot, units)} off its radius: start "
                        f"to centre {message_length(round(r_start), units)}, centre to end "
                        f"{message_length(round(r_end), units)}; the cutter path will produce "
                        f"a divot of {message_length(divot, units)}",
                    )
                )
                # What the control cuts (seed 001 §3.4.5.2 NOTE): the arc on the radius of
                # its start, then the divot, a line to the programmed end.
                elements.append(
                    Element(number, divot_at, centre=true_centre, clockwise=clockwise, z_dn=z_dn)
                )
                elements.append(Element(number, _f(end), tag="divot"))
                numbers += [number, number]
                reference = end
                continue
            elements.append(
                Element(number, _f(end), centre=true_centre, clockwise=clockwise, z_dn=z_dn)
            )
            numbers.append(number)
            reference = end
            continue
        plunge = z_dn is not None and z_dn != depth
        if z_dn is not None:
            depth = z_dn
        if end == reference and centre is None:
            if isinstance(block, MillLine) and not plunge:
                found.append(
                    Finding(
                        number,
                        Rule.ZERO_LENGTH,
                        Severity.WARNING,
                        "MILL STD ends where it starts; the block cuts nothing",
                    )
                )
            elements.append(Element(number, _f(end), z_dn=z_dn))
            numbers.append(number)
            continue
        elements.append(
            Element(
                number,
                _f(end),
                centre=None if centre is None else _f(centre),
                clockwise=clockwise,
                z_dn=z_dn,
            )
        )
        numbers.append(number)
        reference = end
    path = Path(_f(start), tuple(elements))
    if with_corners:
        path, numbers = solve.corners(path, numbers, blocks, found)
    return path, numbers, reference


def _typed(block: Block) -> tuple[Decimal, Decimal]:
    """A contour block's X and Y as typed (both given: nothing was left to calculate)."""
    x: Decimal | None = getattr(block, "x")  # noqa: B009 - every contour block has x and y
    y: Decimal | None = getattr(block, "y")  # noqa: B009
    assert x is not None and y is not None, "an empty X/Y is solved first (app.cnc.solve)"
    return x, y


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


def _f(p: tuple[int, int]) -> Pt:
    return (float(p[0]), float(p[1]))
