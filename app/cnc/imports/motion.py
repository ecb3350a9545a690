"""Motion (from G-code or a tape) to a program: segment, recognise, build.

DESIGN.md §1: "G-code / 1704 tape → Toolpath → Program (recognised blocks)". The parsers
give the motion (`steps.py`); `segment` finds operations in it, `recognise` proposes the
blocks that make the same motion, `build` writes them, rounded once, with Data Block 0.
"""

from __future__ import annotations

from dataclasses import replace

from app.cnc import limits
from app.cnc.blocks import Program
from app.cnc.imports.build import Builder, SetUp, block0, make_program
from app.cnc.imports.common import show
from app.cnc.imports.ops import HelixOp, LoopOp, Op, PosOp
from app.cnc.imports.recognise import (
    RoutineFinder,
    find_bolt_circles,
    find_loops,
    merge_pecks,
)
from app.cnc.imports.segment import segment
from app.cnc.imports.steps import Arc, Feed, Parsed, ToolChange


def program_from_motion(parsed: Parsed) -> Program:
    """The program whose blocks make the motion of `parsed`; the report goes to its notes.

    Consumes `parsed.steps`: the list is emptied once segmented, so that the steps (the
    biggest part of a long file) are not held while the operations are recognised.

    Raises ImportFailure (from segmenting) for motion no block can make.
    """
    notes = parsed.notes
    number_tools(parsed)
    found = segment(parsed)
    parsed.steps = []
    tol = parsed.tolerance
    diameters = {n: t.diameter for n, t in parsed.tools.items() if t.diameter}
    rpms = {n: use.rpm for n, use in found.tools.items()}
    finder = RoutineFinder(diameters, rpms, tol, notes)
    ops = finder.two_pass_with_pecks(found.ops)
    ops = merge_pecks(ops, tol)
    ops = finder.run(ops)
    ops = find_bolt_circles(ops, tol, notes)
    ops = find_loops(ops, tol, notes)
    builder = Builder(notes)
    builder.run(ops)
    builder.flush_rounding()
    units = parsed.units
    z_retract = None
    # A retract's Z UP is its operation's: a level of pecks merged into one DRILL retracts
    # above the DRILL's Z UP, not above the level it was re-entered at.
    z_ups = _z_ups(ops)
    for line, z_up, height in found.retracts:
        z_up = z_ups.get(line, z_up)
        value = height - max(z_up, 0)
        if value < 0:
            continue
        if z_retract is None:
            z_retract = value
            notes.became(
                line,
                f"the tool retracts to {show(height, units)} above tool zero: Z RET "
                f"{show(value, units)} (Data Block 0)",
            )
        elif abs(value - z_retract) > tol:
            notes.assumed(
                line,
                f"the tool retracts {show(value, units)} above Z UP here; Data Block 0 holds "
                f"one Z RET ({show(z_retract, units)}): Z moves between operations differ",
            )
    if z_retract is None and parsed.start_z is not None and parsed.start_z >= 0:
        # No operation retracted (one hole, a tap that feeds out above it...): a MillBlocks
        # tool path starts Z RET above tool zero, and the file said where it started.
        z_retract = parsed.start_z
        notes.became(
            None,
            f"the tool starts {show(z_retract, units)} above tool zero: Z RET "
            f"{show(z_retract, units)} (Data Block 0)",
        )
    for number, use in sorted(found.tools.items()):
        for line, rpm in use.other_speeds:
            notes.assumed(
                line,
                f"tool {number} also runs at {rpm} rpm; Data Block 0 keeps one speed per tool "
                f"({use.rpm} rpm from line {use.line})",
            )
    setup = SetUp(
        units=units,
        offsets=parsed.offsets,
        initial_tool=parsed.initial_tool,
        milling=finder.milling,
        z_retract=z_retract,
        rpms=rpms,
        tools=parsed.tools,
        coolants={n: use.coolant for n, use in found.tools.items() if use.coolant},
    )
    db0 = block0(setup, ops, notes)
    source = {"gcode": "G-code", "tape": "1704 tape", "boss": "BOSS tape"}.get(
        parsed.format, parsed.format
    )
    return make_program(
        parsed.name,
        parsed.part_number,
        units,
        f"imported from {source}",
        db0,
        builder.blocks,
    )


def _z_ups(ops: list[Op]) -> dict[int, int]:
    """The Z UP of the operation each source line belongs to (operations with depths)."""
    found: dict[int, int] = {}
    for op in ops:
        if isinstance(op, LoopOp):
            found |= _z_ups(op.body)
        elif isinstance(op, HelixOp):
            found |= dict.fromkeys(op.lines, op.z_up)
        elif not isinstance(op, PosOp) and op.spec.z_up is not None:
            found |= dict.fromkeys(op.lines, op.spec.z_up)
    return found


def number_tools(parsed: Parsed) -> None:
    """Tools numbered past the control's 24 (a CAM library's T32) take the lowest numbers
    the file leaves free, in the order the file first names them, each reported; their
    diameter, length and name go with them. Past 24 tools in all, the rest keep their
    numbers (Data Block 0 then asks for them)."""
    named: list[int] = []
    lines: dict[int, int | None] = {}

    def name(number: int, line: int | None) -> None:
        if number and number not in lines:
            named.append(number)
            lines[number] = line

    name(parsed.initial_tool, None)
    for step in parsed.steps:
        if isinstance(step, ToolChange):
            name(step.tool, step.line)
        elif isinstance(step, Feed | Arc):
            name(step.comp_tool, step.line)
    for number in parsed.tools:
        name(number, None)
    outside = [n for n in named if not 1 <= n <= limits.MAX_TOOL]
    free = [n for n in range(1, limits.MAX_TOOL + 1) if n not in lines]
    given = dict(zip(outside, free, strict=False))
    if not given:
        return
    for old, new in given.items():
        parsed.notes.assumed(
            lines[old],
            f"tool {old} is tool {new} here: the control has tools 1 to {limits.MAX_TOOL} "
            f"(the file's T{old}, its diameter and length)",
        )
    steps = parsed.steps
    for k, step in enumerate(steps):
        if isinstance(step, ToolChange) and step.tool in given:
            steps[k] = replace(step, tool=given[step.tool])
        elif isinstance(step, Feed | Arc) and step.comp_tool in given:
            steps[k] = replace(step, comp_tool=given[step.comp_tool])
    parsed.initial_tool = given.get(parsed.initial_tool, parsed.initial_tool)
    parsed.tools = {given.get(n, n): data for n, data in parsed.tools.items()}
