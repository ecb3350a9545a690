"""From blocks to paths: a mill sequence (a contour of MILL blocks, or a routine and its
geometry) planned as the tool-centre path the compiler emits, and the programmed contour
(calculated geometry solved, conrads and chamfers inserted) it is made from."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from decimal import Decimal
from typing import TYPE_CHECKING

from app.cnc.blocks import (
    ArcEnd,
    Block,
    Comp,
    DataBlock0,
    Direction,
    Hole,
    MillArc,
    MillLine,
    MillQcir,
)
from app.cnc.cutter import Finding, compensate
from app.cnc.geometry import resolve_xy
from app.cnc.kinds import REGISTRY, Mill
from app.cnc.plane import Element, Path, fpt, qcir_centre, true_arc
from app.cnc.problems import Rule, Severity
from app.cnc.ramp import Ramp, Zigzag
from app.cnc.units import Units, message_length, to_nm

if TYPE_CHECKING:
    from app.cnc.pocketing.model import PocketPlan
    from app.cnc.routines import Routine


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
    ramp: Ramp | Zigzag | None = None  # a pocketing routine's ramp entry (None: it plunges)
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
            return Path(fpt(start), ()), [], start
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
            true_centre, divot_at = true_arc(fpt(reference), fpt(end), fpt(centre), units)
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
                elements.append(Element(number, fpt(end), tag="divot"))
                numbers += [number, number]
                reference = end
                continue
            elements.append(
                Element(number, fpt(end), centre=true_centre, clockwise=clockwise, z_dn=z_dn)
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
            elements.append(Element(number, fpt(end), z_dn=z_dn))
            numbers.append(number)
            continue
        elements.append(
            Element(
                number,
                fpt(end),
                centre=None if centre is None else fpt(centre),
                clockwise=clockwise,
                z_dn=z_dn,
            )
        )
        numbers.append(number)
        reference = end
    path = Path(fpt(start), tuple(elements))
    if with_corners:
        path, numbers = solve.corners(path, numbers, blocks, found)
    return path, numbers, reference


def _typed(block: Block) -> tuple[Decimal, Decimal]:
    """A contour block's X and Y as typed (both given: nothing was left to calculate)."""
    x: Decimal | None = getattr(block, "x")  # noqa: B009 - every contour block has x and y
    y: Decimal | None = getattr(block, "y")  # noqa: B009
    assert x is not None and y is not None, "an empty X/Y is solved first (app.cnc.solve)"
    return x, y
