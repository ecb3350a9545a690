"""The CIRCLE and FRAME routines (seed 001 §3.4.5.2: inside, outside, tangent, pocket,
two-pass) and the allowances they and POCKET share. Readings we chose (docs/readings.md):

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
and 0.13 mm."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from decimal import Decimal
from typing import Any

from app.cnc.blocks import Block, Circle, Entry, Frame, MillingMode, Placement
from app.cnc.cutter import Finding, is_zero_length
from app.cnc.plane import (
    EPS,
    Element,
    Path,
    Pt,
    add,
    close,
    cross,
    dim,
    reverse,
    scale,
    sub,
    tangent,
    unit,
)
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
from app.cnc.sequences import RoutineStart, SequencePlan
from app.cnc.units import Units, half_even, to_nm


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
                    f"corner radius {dim(routine.corner_radius, routine.units)} is too large "
                    f"for a {dim(routine.width, routine.units)} × "
                    f"{dim(routine.height, routine.units)} frame; allowed 0 to "
                    f"{dim(half_short, routine.units)} (the corners must meet)",
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
                    f"corner radius {dim(routine.corner_radius, routine.units)} is smaller "
                    f"than the tool radius {dim(r, routine.units)}; the tool leaves material "
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
                f"a {dim(2 * r, routine.units)} tool leaves no step-over: pocket passes "
                f"overlap by {dim(pocket_overlap(routine.units), routine.units)}, so the "
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
        f"the {what} ({dim(size, u)} across) is not larger than the "
        f"{dim(2 * routine.tool_radius, u)} tool; the tool cannot go inside it",
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
    ramp: Ramp | Zigzag | None = None
    problem = None
    if block.entry is Entry.HELIX:
        ramp, problem = _helix_entry(routine, passes[0], allowance, angle_of(block.ramp_angle))
    elif block.entry is Entry.ZIGZAG:
        ramp, problem = _zigzag_entry(routine, passes[0], allowance, angle_of(block.ramp_angle))
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
                "goes straight down: choose ENTRY HELIX or ZIGZAG, or leave RAMP ANGLE empty",
                "RAMP ANGLE",
            )
        ]
    return []


def largest_fitting(fits: Callable[[float], bool], wanted: float, halvings: int = 60) -> float:
    """The largest size up to `wanted` (which does not fit) that `fits`, by bisection
    (`halvings` of them: 60 reach the float's resolution): what a ramp's refusal says
    would fit."""
    low, high = 0.0, wanted
    for _ in range(halvings):
        mid = (low + high) / 2
        low, high = (mid, high) if fits(mid) else (low, mid)
    return low


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
    low = largest_fitting(fits, wanted)
    u = routine.units
    return None, Finding(
        routine.block,
        Rule.RAMP_ENTRY,
        Severity.ERROR,
        f"a HELIX ramp with a {dim(2 * r, u)} tool goes round a circle "
        f"{dim(2 * wanted, u)} across (half the tool's DIA), which does not fit inside the "
        f"first pass at its entry point: a circle at most {dim(2 * low, u)} across fits "
        "there; a larger pocket, a smaller tool, or ENTRY empty (PLUNGE)",
        "ENTRY",
    )


def _zigzag_entry(
    routine: Routine, first: Path, allowance: int, angle: Decimal
) -> tuple[Zigzag | None, Finding | None]:
    """The zigzag ramp at the entry point of the first pass `first`, its straight going
    straight in (as the helix's centre lies), or the error when the straight does not fit
    inside that pass (`allowance`: the stock the pass leaves on the wall)."""
    lead_in = first.elements[0]
    assert lead_in.centre is not None  # a POCKET routine enters on a lead-in arc
    r = float(routine.tool_radius)
    wall = r + allowance
    inward = unit(sub(lead_in.centre, lead_in.end))

    def ramp(length: float) -> Zigzag:
        return zigzag_ramp(first.start, inward, length, angle)

    # The region is convex and holds the entry point: the straight fits when its far end does.
    def fits(length: float) -> bool:
        return _room_inside(routine, wall, ramp(length).far) >= -EPS

    wanted = zigzag_length(r)
    if fits(wanted):
        return ramp(wanted), None
    low = largest_fitting(fits, wanted)
    u = routine.units
    return None, Finding(
        routine.block,
        Rule.RAMP_ENTRY,
        Severity.ERROR,
        f"a ZIGZAG ramp with a {dim(2 * r, u)} tool goes back and forth on a straight "
        f"{dim(wanted, u)} long (the tool's DIA), which does not fit inside the first pass "
        f"straight in from its entry point: a straight at most {dim(low, u)} long fits "
        "there; a larger pocket, a smaller tool, ENTRY HELIX, or ENTRY empty (PLUNGE)",
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
