"""Cutter compensation of a programmed contour (seed 001 §3.4.5.2, DESIGN.md §3) and the
gouges it finds. Readings we chose (docs/readings.md): the tool plunges at the start of the
first offset element (the drill point moved one tool radius to the compensation side,
perpendicular to the first segment) and leaves at the end of the last one. Outside corners
are joined by an arc of the tool radius about the corner point; inside corners are trimmed
to the intersection of the two offset elements. The control itself looks one segment ahead
and leaves a divot at a non-blended inside corner with an arc; we cut the true trimmed path
and warn. Validation and the compiler call the same functions, so what is checked is what
is cut."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from app.cnc.blocks import Comp
from app.cnc.plane import (
    BLEND_RADIANS,
    EPS,
    Element,
    Path,
    Pt,
    add,
    close,
    cross,
    dim,
    distance_to_element,
    dot,
    half_step,
    intersections,
    left_normal,
    sample,
    scale,
    sub,
    sweep,
    tangent,
    unit,
)
from app.cnc.problems import Rule, Severity
from app.cnc.units import Units


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


def offset_element(start: Pt, element: Element, side: float, r: float) -> tuple[Pt, Element]:
    """The element moved `r` to the left (`side` +1) or right (−1) of its travel."""
    at_start, at_end = offset_directions(start, element)
    return add(start, scale(at_start, side * r)), replace(
        element, end=add(element.end, scale(at_end, side * r))
    )


def offset_directions(start: Pt, element: Element) -> tuple[Pt, Pt]:
    """The unit directions (left of its travel) in which `offset_element` moves an
    element's start and end: the same for both ends of a line; for an arc, toward its
    centre or away. The same whatever the distance: a caller offsetting one contour by
    many distances makes them once."""
    if element.centre is None:
        n = left_normal(unit(sub(element.end, start)))
        return n, n
    c = element.centre
    # Left of a counter-clockwise arc is toward its centre; of a clockwise one, away.
    to_start, to_end = unit(sub(start, c)), unit(sub(element.end, c))
    if element.clockwise:
        return to_start, to_end
    return scale(to_start, -1.0), scale(to_end, -1.0)


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
                    f"the arc's radius {dim(radius, units)} is not more than the tool radius "
                    f"{dim(r, units)}; the tool cannot follow it on the inside",
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
                            f"events export) would leave a divot of about {dim(divot, units)} "
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
            f"{dim(depth, units)}"
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
                f"{max(blocks[k], blocks[j])} is {dim(width, units)} wide, narrower than "
                f"the {dim(2 * r, units)} tool: the tool does not fit; use a smaller tool "
                f"(under {dim(width, units)})"
            )
        findings.append(Finding(blocks[k], Rule.COMP_GOUGE, Severity.WARNING, f"{cut}; {advice}"))
    return findings
