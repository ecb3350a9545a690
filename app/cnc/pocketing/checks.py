"""What makes a pocket's contours unusable or its result imperfect, found before planning.

Each finding names the contour ("boundary", "island 2"), the element (1-based) and its
block, and says what is wrong. Lengths in nm; messages in the program's units.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from app.cnc.plane import Element, Path, Pt, cross, distance_to_element, intersections, signed_area
from app.cnc.pocketing import regions
from app.cnc.pocketing.model import PocketFinding, PocketIssue
from app.cnc.problems import Severity
from app.cnc.units import Units, format_length

CLOSE_NM = 1.0  # an end this close to the start closes the contour
ARC_RADII_NM = 2540.0  # an arc's start and end radii may differ by 0.0001 in (rounding)


def show(nm: float, units: Units) -> str:
    """A length for a message: `0.2500 in`, `6.350 mm`."""
    return f"{format_length(round(nm), units)} {units.symbol}"


def starts_of(path: Path) -> list[Pt]:
    return [path.start] + [e.end for e in path.elements[:-1]]


def contour_problems(name: str, path: Path, units: Units) -> list[PocketFinding]:
    """Open, degenerate or self-intersecting: each an error naming the element."""
    if not path.elements:
        return [_finding(PocketIssue.OPEN_CONTOUR, name, None, None, "the contour has no elements")]
    found: list[PocketFinding] = []
    last = path.elements[-1]
    gap = math.dist(last.end, path.start)
    if gap > CLOSE_NM:
        found.append(
            _finding(
                PocketIssue.OPEN_CONTOUR,
                name,
                len(path.elements),
                last,
                f"the contour is not closed: it ends {show(gap, units)} from where it starts; "
                "a pocket's boundary and islands must be closed",
                last.end,
            )
        )
    starts = starts_of(path)
    for k, (start, element) in enumerate(zip(starts, path.elements, strict=True), start=1):
        if element.centre is None:
            if math.dist(start, element.end) <= CLOSE_NM:
                found.append(
                    _finding(
                        PocketIssue.DEGENERATE, name, k, element, "a line of zero length", start
                    )
                )
            continue
        r0 = math.dist(start, element.centre)
        r1 = math.dist(element.end, element.centre)
        if min(r0, r1) <= CLOSE_NM or abs(r0 - r1) > ARC_RADII_NM:
            found.append(
                _finding(
                    PocketIssue.DEGENERATE,
                    name,
                    k,
                    element,
                    f"the arc's radius is {show(r0, units)} at its start and {show(r1, units)} "
                    f"at its end; they may differ by {show(ARC_RADII_NM, units)} at most",
                    start,
                )
            )
    if found:
        return found
    found = _crossings(name, path, starts, units)
    if not found and abs(signed_area(path)) <= CLOSE_NM * CLOSE_NM:
        return [_finding(PocketIssue.DEGENERATE, name, None, None, "the contour encloses no area")]
    return found


def _boxes(path: Path, starts: list[Pt]) -> npt.NDArray[np.float64]:
    """Each element's bounding box (x0, y0, x1, y1; an arc's whole circle's), grown by the
    distance at which two elements count as touching."""
    grow = 10 * CLOSE_NM
    boxes = []
    for start, element in zip(starts, path.elements, strict=True):
        if element.centre is None:
            xs, ys = (start[0], element.end[0]), (start[1], element.end[1])
            boxes.append((min(xs), min(ys), max(xs), max(ys)))
        else:
            (cx, cy), r = element.centre, math.dist(start, element.centre)
            boxes.append((cx - r, cy - r, cx + r, cy + r))
    found: npt.NDArray[np.float64] = np.array(boxes, dtype=np.float64).reshape(-1, 4)
    found += np.array([-grow, -grow, grow, grow])
    return found


def _crossings(name: str, path: Path, starts: list[Pt], units: Units) -> list[PocketFinding]:
    n = len(path.elements)
    # Only elements whose boxes overlap can meet: a contour of hundreds of blocks would
    # otherwise compare every pair (the pairs come in the same order as before).
    box = _boxes(path, starts)
    near = (
        (box[:, None, 0] <= box[None, :, 2])
        & (box[None, :, 0] <= box[:, None, 2])
        & (box[:, None, 1] <= box[None, :, 3])
        & (box[None, :, 1] <= box[:, None, 3])
    )
    for i, j in zip(*np.nonzero(np.triu(near, 1)), strict=True):
        i, j = int(i), int(j)
        a, b = path.elements[i], path.elements[j]
        shared = [
            p
            for p, adjacent in ((a.end, j == i + 1), (path.start, i == 0 and j == n - 1))
            if adjacent
        ]
        for p in _meets(starts[i], a, starts[j], b):
            if any(math.dist(p, q) <= 10 * CLOSE_NM for q in shared):
                continue
            return [
                _finding(
                    PocketIssue.SELF_INTERSECTING,
                    name,
                    j + 1,
                    b,
                    f"element {j + 1} crosses or touches element {i + 1} of the same "
                    f"contour at X {show(p[0], units)} Y {show(p[1], units)}; a pocket "
                    "contour must not cross itself",
                    p,
                )
            ]
    return []


def _meets(sa: Pt, a: Element, sb: Pt, b: Element) -> list[Pt]:
    """Points where two elements meet (ends of a collinear overlap included)."""
    points = [
        p
        for p in intersections(sa, a, sb, b)
        if distance_to_element(p, sa, a) <= CLOSE_NM and distance_to_element(p, sb, b) <= CLOSE_NM
    ]
    if a.centre is None and b.centre is None:
        da = (a.end[0] - sa[0], a.end[1] - sa[1])
        if abs(cross(da, (b.end[0] - sb[0], b.end[1] - sb[1]))) <= 1e-9 * math.hypot(*da) ** 2:
            # Parallel: an overlap shows as an end of one lying on the other.
            points += [p for p in (sb, b.end) if distance_to_element(p, sa, a) <= CLOSE_NM]
            points += [p for p in (sa, a.end) if distance_to_element(p, sb, b) <= CLOSE_NM]
    return points


def island_problems(
    boundary: regions.Ring, islands: Sequence[regions.Ring], tolerance: float
) -> list[PocketFinding]:
    """Islands outside the boundary (errors), touching or crossing the wall, or meeting
    each other (warnings: the pocket is cut around their union)."""
    found: list[PocketFinding] = []
    grown = [regions.offset([ring], 2 * tolerance, tolerance) for ring in islands]
    for k, ring in enumerate(islands, start=1):
        name = f"island {k}"
        if abs(regions.area(regions.intersection([ring], [boundary]))) <= tolerance * tolerance:
            found.append(
                _finding(
                    PocketIssue.ISLAND_OUTSIDE,
                    name,
                    None,
                    None,
                    f"{name} lies outside the pocket's boundary; an island must be inside it",
                    severity=Severity.ERROR,
                )
            )
            continue
        if regions.area(regions.difference(grown[k - 1], [boundary])) > tolerance * tolerance:
            found.append(
                _finding(
                    PocketIssue.ISLAND_TOUCHES_WALL,
                    name,
                    None,
                    None,
                    f"{name} touches or crosses the pocket's wall; the pocket is cut around "
                    "what is left of the boundary without it (the island joins the wall)",
                    severity=Severity.WARNING,
                )
            )
        for j in range(k, len(islands)):
            a, b = regions.box_of(grown[k - 1]), regions.box_of([islands[j]])
            if a is None or b is None or a[0] > b[2] or b[0] > a[2] or a[1] > b[3] or b[1] > a[3]:
                continue  # apart: islands far from each other are not clipped pairwise
            if regions.area(regions.intersection(grown[k - 1], [islands[j]])) > tolerance**2:
                found.append(
                    _finding(
                        PocketIssue.ISLANDS_OVERLAP,
                        name,
                        None,
                        None,
                        f"{name} touches or overlaps island {j + 1}; they are cut round as one",
                        severity=Severity.WARNING,
                    )
                )
    return found


def _finding(
    issue: PocketIssue,
    contour: str,
    index: int | None,
    element: Element | None,
    message: str,
    at: Pt | None = None,
    severity: Severity = Severity.ERROR,
) -> PocketFinding:
    where = contour if index is None else f"{contour}, element {index}"
    if element is not None and element.block:
        where += f" (block {element.block})"
    return PocketFinding(
        issue,
        severity,
        f"{where}: {message}",
        contour,
        index,
        None if element is None else element.block,
        at,
    )
