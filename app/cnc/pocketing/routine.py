"""The POCKET block kind's planner: its contour blocks become paths, the engine plans them.

A POCKET follows the DRILL that gives the boundary's start point, the depths, the pecks
and the tool. Its contour blocks follow it: PKT LINE and PKT ARC (XY-CENT + XY-END) draw
the boundary from the DRILL's point back to it; each ISLAND block starts an island at its
own point, drawn the same way. INC values are from the point before, as for every
positioned block: a PKT LINE's end from the contour's last point, an arc's centre and end
from the arc's start, an ISLAND's start from the point the contour before it closed at.
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Callable
from dataclasses import dataclass

from app.cnc import limits
from app.cnc.blocks import (
    Block,
    Direction,
    Entry,
    Island,
    Placement,
    Pocket,
    PocketArc,
    PocketArcEnd,
    PocketLine,
)
from app.cnc.cutter import Finding
from app.cnc.geometry import resolve_xy
from app.cnc.kinds import REGISTRY, Mill
from app.cnc.plane import Element, Path, Pt, dim, half_step, tangent
from app.cnc.pocketing import regions
from app.cnc.pocketing.model import LinkKind, PocketFinding, PocketIssue, PocketPlan
from app.cnc.pocketing.plan import plan_pocket
from app.cnc.problems import Rule, Severity
from app.cnc.ramp import (
    Ramp,
    Zigzag,
    angle_of,
    helix_radius,
    helix_ramp,
    zigzag_length,
    zigzag_ramp,
)
from app.cnc.routines import largest_fitting, pocket_overlap, rough_wall, routine_clockwise
from app.cnc.sequences import RoutineStart, SequencePlan
from app.cnc.units import Units, message_length, to_nm

RULES = {
    PocketIssue.OPEN_CONTOUR: Rule.POCKET_CONTOUR,
    PocketIssue.DEGENERATE: Rule.POCKET_CONTOUR,
    PocketIssue.SELF_INTERSECTING: Rule.POCKET_CONTOUR,
    PocketIssue.ISLAND_OUTSIDE: Rule.POCKET_ISLAND,
    PocketIssue.ISLAND_TOUCHES_WALL: Rule.POCKET_ISLAND,
    PocketIssue.ISLANDS_OVERLAP: Rule.POCKET_ISLAND,
    PocketIssue.TOOL_TOO_LARGE: Rule.POCKET_TOOL,
    PocketIssue.NARROW: Rule.POCKET_NARROW,
    PocketIssue.STEP_OVER: Rule.POCKET_STEP,
}


@dataclass(frozen=True)
class Contour:
    """One contour drawn by a POCKET's blocks: its name ("boundary", "island 2"), the
    block that starts it (the DRILL or the ISLAND), its path (nm) and its last block."""

    name: str
    first: int
    path: Path
    last: int


def pocket_contours(
    geometry: tuple[tuple[int, Block], ...], start: tuple[int, int], pocket: int
) -> list[Contour]:
    """The boundary (from `start`, the DRILL's point) and the islands drawn by a POCKET's
    contour blocks (`geometry`: block number and block, in order). `pocket` is the POCKET's
    block number, the first block of the boundary when it has no contour blocks."""
    contours: list[Contour] = []
    name, first, origin = "boundary", pocket, start
    elements: list[Element] = []
    reference = start
    last = pocket
    pending: tuple[int, PocketArc, tuple[int, int]] | None = None

    def close() -> None:
        contours.append(Contour(name, first, Path(_f(origin), tuple(elements)), last))

    for number, block in geometry:
        if isinstance(block, Island):
            close()
            reference = resolve_xy(block.x, block.y, block.mode, block.units, reference)
            name, first, origin = f"island {len(contours)}", number, reference
            elements, last = [], number
        elif isinstance(block, PocketLine):
            reference = resolve_xy(block.x, block.y, block.mode, block.units, reference)
            elements.append(Element(number, _f(reference)))
            last = number
        elif isinstance(block, PocketArc):
            centre = resolve_xy(block.x, block.y, block.mode, block.units, reference)
            pending = (number, block, centre)
        elif isinstance(block, PocketArcEnd) and pending is not None:
            arc_number, arc, centre = pending
            begin = reference
            reference = resolve_xy(block.x, block.y, block.mode, block.units, reference)
            elements.append(
                Element(
                    arc_number,
                    _f(reference),
                    centre=_typed_centre(begin, reference, centre, half_step(block.units)),
                    clockwise=arc.direction is Direction.CW,
                )
            )
            pending, last = None, number
    close()
    return contours


def _typed_centre(
    start: tuple[int, int], end: tuple[int, int], centre: tuple[int, int], tolerance: float
) -> tuple[float, float]:
    """The centre of the arc the machinist meant: an end typed within half the programming
    resolution of the start's radius (0.001 in cannot place it better) is on the arc, and
    the centre moves onto the line of points as far from both ends (by at most that much);
    farther off, the centre as typed, and the arc is refused (`arc_findings`)."""
    r_start, r_end = math.dist(start, centre), math.dist(end, centre)
    if r_start == r_end or abs(r_start - r_end) > tolerance or start == end:
        return _f(centre)
    # The foot of the perpendicular from the typed centre to the bisector of start-end.
    mx, my = (start[0] + end[0]) / 2, (start[1] + end[1]) / 2
    dx, dy = end[0] - start[0], end[1] - start[1]
    along = ((centre[0] - mx) * dx + (centre[1] - my) * dy) / (dx * dx + dy * dy)
    return (centre[0] - along * dx, centre[1] - along * dy)


def arc_findings(contours: list[Contour], units: Units) -> list[Finding]:
    """An arc about its own start; an arc whose XY-END is off the radius of its start by
    more than half the programming resolution (the control would cut a divot, MILL ARC; a
    pocket's wall cannot have one); a block after its contour closed (an ISLAND missing)."""
    found: list[Finding] = []
    for contour in contours:
        at = contour.path.start
        closed_at = 0
        for element in contour.path.elements:
            if closed_at:
                kind = "PKT ARC" if element.centre is not None else "PKT LINE"
                found.append(
                    Finding(
                        element.block,
                        Rule.POCKET_ORDER,
                        Severity.ERROR,
                        f"the {contour.name} closes at block {closed_at}, so {kind} starts "
                        "nothing: begin an island with an ISLAND block first",
                    )
                )
                break
            if element.centre is not None and math.dist(at, element.centre) < 1:
                found.append(
                    Finding(
                        element.block,
                        Rule.POCKET_CONTOUR,
                        Severity.ERROR,
                        "the arc's centre is its start point; the radius would be zero",
                    )
                )
            elif element.centre is not None:
                r_start = math.dist(at, element.centre)
                r_end = math.dist(element.end, element.centre)
                if abs(r_start - r_end) > half_step(units):
                    found.append(
                        Finding(
                            element.block + 1,
                            Rule.POCKET_CONTOUR,
                            Severity.ERROR,
                            f"the arc's end is {message_length(round(abs(r_start - r_end)), units)}"
                            f" off its radius: start to centre "
                            f"{message_length(round(r_start), units)}, centre to end "
                            f"{message_length(round(r_end), units)}; the end must lie on the "
                            "circle through the start (within half the programming resolution)",
                        )
                    )
            at = element.end
            if math.dist(at, contour.path.start) < 1:
                closed_at = element.block + (1 if element.centre is not None else 0)
    return found


def contours_at(blocks: tuple[Block, ...], pocket: int, start: tuple[int, int]) -> list[Contour]:
    """The contours of POCKET block `pocket` (1-based) of a program, its boundary starting
    at `start` (its DRILL's point where the pocket is cut: a LOOP's pattern moves it)."""
    geometry = []
    for index in range(pocket, len(blocks)):
        if REGISTRY.of(blocks[index]).mill is not Mill.GEOMETRY:
            break
        geometry.append((index + 1, blocks[index]))
    return pocket_contours(tuple(geometry), start, pocket)


def plan_pocket_routine(block: Block, at: RoutineStart) -> SequencePlan:
    """The passes of a POCKET (one path per pass; `SequencePlan.pocket` holds the plan with
    its links, `SequencePlan.outlines` its wall and islands, errors or not). Problems are
    in the plan, not raised; the reference after it is the DRILL's point."""
    contours = pocket_contours(at.geometry, at.start, at.number)
    plan = _planned(block, at, contours)
    plan.outlines = tuple((c.name, c.path) for c in contours)
    return plan


def _planned(block: Block, at: RoutineStart, contours: list[Contour]) -> SequencePlan:
    assert isinstance(block, Pocket)
    units = block.units
    findings: list[Finding] = []
    if len(contours) - 1 > limits.MAX_ISLANDS:
        findings.append(
            Finding(
                contours[limits.MAX_ISLANDS + 1].first,
                Rule.POCKET_ISLAND,
                Severity.ERROR,
                f"a POCKET takes at most {limits.MAX_ISLANDS} islands; this one has "
                f"{len(contours) - 1}",
            )
        )
    if any(not c.path.elements for c in contours):
        # A POCKET without its boundary, or an ISLAND without its contour: the order of
        # the blocks is at fault, which validation reports (Rule.POCKET_ORDER).
        return SequencePlan([], 0, at.start, findings)
    findings += arc_findings(contours, units)
    if findings:
        return SequencePlan([], 0, at.start, findings)
    if at.tool_radius == 0:
        # No DIA: validation reports it on the TOOL # (check_tools).
        return SequencePlan([], 0, at.start, findings)
    diameter = 2 * at.tool_radius
    if block.step_over is None:
        step = diameter - pocket_overlap(units)
    else:
        step = to_nm(block.step_over, units)
    if step <= 0 or step >= diameter:
        findings.append(
            Finding(
                at.number,
                Rule.POCKET_STEP,
                Severity.ERROR,
                f"the step-over {message_length(step, units)} must be more than 0 and less "
                f"than the tool's DIA {message_length(diameter, units)}"
                + (", less the 0.050 in overlap" if block.step_over is None else ""),
                "STEP" if block.step_over is not None else "TOOL #",
            )
        )
        return SequencePlan([], 0, at.start, findings)
    finish = rough_wall(units) if block.finish is None else to_nm(block.finish, units)
    if finish > at.tool_radius:
        findings.append(
            Finding(
                at.number,
                Rule.POCKET_STEP,
                Severity.ERROR,
                f"{message_length(finish, units)} is more than the finishing pass can take: "
                f"at most the tool's radius, {message_length(at.tool_radius, units)}",
                "FIN CUT",
            )
        )
        return SequencePlan([], 0, at.start, findings)
    plan = plan_pocket(
        contours[0].path,
        [c.path for c in contours[1:]],
        tool_radius=at.tool_radius,
        step_over=step,
        finish_allowance=finish,
        milling=at.block0.milling,
        rpm=at.rpm,
        block=at.number,
        units=units,
    )
    findings += [_finding(f, contours, at.number) for f in plan.findings]
    if plan.has_errors:
        return SequencePlan([], 0, at.start, findings)
    ramps: tuple[Ramp | Zigzag | None, ...] = ()
    if block.entry is not None:
        clockwise = routine_clockwise(Placement.POCKET, at.block0.milling, at.rpm)
        ramps, problem = _ramps(block, plan, float(at.tool_radius), clockwise, at.number)
        if problem is not None:
            return SequencePlan([], 0, at.start, [*findings, problem])
    return SequencePlan(
        [p.path for p in plan.passes], 0, at.start, findings, pocket=plan, ramps=ramps
    )


# The directions a ramp is tried in at an entry point after square to the way the tool
# moves on from it: eight, 45 degrees apart, turning counter-clockwise (deterministic).
_TURNS = tuple(k * math.pi / 4 for k in range(8))
# A helix's circle is checked as this many straights (chords; the planner's region is
# already the chordal tolerance generous, app.cnc.pocketing.plan).
_CHORDS = 72


def _ramps(
    block: Pocket, plan: PocketPlan, r: float, clockwise: bool, number: int
) -> tuple[tuple[Ramp | Zigzag | None, ...], Finding | None]:
    """A ramp (app.cnc.ramp, the geometry CIRCLE/FRAME use) at every point the POCKET's
    plan goes down (the first pass's PLUNGE, each RETRACT's re-entry), its path inside the
    region the tool centre may feed in (`PocketPlan.centres`); or the error naming ENTRY
    at the first point none fits, with the largest that does fit there."""
    angle = angle_of(block.ramp_angle)
    region = [list(ring) for ring in plan.centres]
    boxes = [regions.box_of([ring]) for ring in region]
    helix = block.entry is Entry.HELIX
    wanted = helix_radius(r) if helix else zigzag_length(r)

    def make(entry: Pt, inward: Pt, size: float) -> Ramp | Zigzag:
        if helix:
            return helix_ramp(entry, inward, clockwise, size, angle)
        return zigzag_ramp(entry, inward, size, angle)

    def fits(ramp: Ramp | Zigzag) -> bool:
        if isinstance(ramp, Zigzag):
            return regions.segment_inside(region, ramp.entry, ramp.far, boxes)
        (cx, cy), rad = ramp.centre, ramp.radius
        points = [
            (
                cx + rad * math.cos(2 * math.pi * k / _CHORDS),
                cy + rad * math.sin(2 * math.pi * k / _CHORDS),
            )
            for k in range(_CHORDS + 1)
        ]
        pairs = itertools.pairwise(points)
        return all(regions.segment_inside(region, a, b, boxes) for a, b in pairs)

    ramps: list[Ramp | Zigzag | None] = []
    for cut in plan.passes:
        link = cut.entry
        if link.kind not in (LinkKind.PLUNGE, LinkKind.RETRACT):
            ramps.append(None)
            continue
        entry = link.path.start
        # First square off the way the tool moves on from the entry point (a pass's entry
        # lies on the edge of the region: in from it is to one side), then round from it.
        path = link.path if link.path.elements else cut.path
        along = tangent(path.start, path.elements[0], at_end=False)
        way = math.atan2(along[1], along[0])
        turns = (math.pi / 2, -math.pi / 2, *_TURNS)
        directions = [(math.cos(way + t), math.sin(way + t)) for t in turns]
        found = next((ramp for d in directions if fits(ramp := make(entry, d, wanted))), None)
        if found is None:
            return (), _no_fit(block, number, r, wanted, entry, directions, make, fits)
        ramps.append(found)
    return tuple(ramps), None


def _no_fit(
    block: Pocket,
    number: int,
    r: float,
    wanted: float,
    entry: Pt,
    directions: list[Pt],
    make: Callable[[Pt, Pt, float], Ramp | Zigzag],
    fits: Callable[[Ramp | Zigzag], bool],
) -> Finding:
    """ENTRY's error when no ramp of the `wanted` size fits at `entry`: the largest that
    fits there in any direction tried (bisection to a nanometre's order)."""
    best = 0.0
    for d in directions:
        # 30 halvings: each tries a whole ramp against the region, and a nanometre's order
        # is all the message shows.

        def fits_along(size: float, d: Pt = d) -> bool:
            return fits(make(entry, d, size))

        best = max(best, largest_fitting(fits_along, wanted, 30))
    u = block.units
    at = f"({dim(entry[0], u)}, {dim(entry[1], u)})"
    if block.entry is Entry.HELIX:
        message = (
            f"a HELIX ramp with a {dim(2 * r, u)} tool goes round a circle "
            f"{dim(2 * wanted, u)} across (half the tool's DIA), which does not fit inside the "
            f"pocket where the tool goes down at X, Y {at}: a circle at most "
            f"{dim(2 * best, u)} across fits there; a smaller tool, ENTRY ZIGZAG, or ENTRY "
            "empty (PLUNGE)"
        )
    else:
        message = (
            f"a ZIGZAG ramp with a {dim(2 * r, u)} tool goes back and forth on a straight "
            f"{dim(wanted, u)} long (the tool's DIA), which does not fit inside the pocket "
            f"where the tool goes down at X, Y {at}: a straight at most {dim(best, u)} long "
            "fits there; a smaller tool, ENTRY HELIX, or ENTRY empty (PLUNGE)"
        )
    return Finding(number, Rule.RAMP_ENTRY, Severity.ERROR, message, "ENTRY")


def _finding(found: PocketFinding, contours: list[Contour], pocket: int) -> Finding:
    """The engine's finding on the block it names (else the block that starts its contour:
    the POCKET for the boundary, the ISLAND for an island; the POCKET for the tool and the
    step-over), in block numbers rather than the engine's element numbers, with the rule
    the bad-input corpus refers to."""
    contour = next((c for c in contours if c.name == found.contour), None)
    field: str | None = None
    block = found.block or (pocket if contour is None else contour.first)
    if found.issue is PocketIssue.OPEN_CONTOUR and contour is not None:
        block = contour.last  # where the contour ends: an arc's XY-END, not its XY-CENT
    if found.issue in (PocketIssue.STEP_OVER, PocketIssue.TOOL_TOO_LARGE):
        block, field = pocket, "STEP" if found.issue is PocketIssue.STEP_OVER else "TOOL #"
    message = found.message
    head, colon, rest = message.partition(": ")
    if colon and found.contour and head.startswith(found.contour):
        message = rest  # "boundary, element 3 (block 5): ..." — the block says where
    message = re.sub(r"element \d+ \(block (\d+)\)", r"block \1", message)
    if contour is not None:
        elements = contour.path.elements
        message = re.sub(
            r"element (\d+)",
            lambda m: (
                f"block {elements[int(m[1]) - 1].block}" if 0 < int(m[1]) <= len(elements) else m[0]
            ),
            message,
        )
    return Finding(block, RULES[found.issue], found.severity, message, field)


def _f(p: tuple[int, int]) -> tuple[float, float]:
    return (float(p[0]), float(p[1]))
