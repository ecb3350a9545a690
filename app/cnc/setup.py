"""The set-up sheet: what the operator needs on paper to set up and run a program.

The 1704 manual's programming manuscript (seed 000 Fig. 1-3) brought up to date: part zero
and the Data Block 0 offsets, the tool list with diameter, RPM (and the gear range on the
machine's spindle; the control's, seed 001 §3.4.4: 60-500 low, 500-4000 high), calibration,
coolant and the first block each tool cuts; cycle time per tool and in total; for a target,
its compatibility report (with the tape length for tape); and the tool path picture. A pure
function of the program, the target's report and the machine: the web page and the CLI
render the same content.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from app.cnc.blocks import Program
from app.cnc.compiler import compile_program
from app.cnc.emit.target import Report
from app.cnc.estimate import Estimate, estimate, format_seconds
from app.cnc.interpret import interpret
from app.cnc.machine import MachineModel
from app.cnc.motions import motions
from app.cnc.path import CompiledPath, Op
from app.cnc.spindle import CONTROL, Spindle
from app.cnc.units import format_decimal


@dataclass(frozen=True)
class ToolLine:
    number: int
    diameter: str
    rpm: str
    gear: str
    tcal: str
    coolant: str
    first_block: int | None
    seconds: str


@dataclass
class SetupSheet:
    name: str
    part_number: str
    units: str
    notes: str
    x_offset: str
    y_offset: str
    z_retract: str
    milling: str
    current_tool: int
    blocks: int
    tools: list[ToolLine] = field(default_factory=list)
    total: str = ""
    waits: list[str] = field(default_factory=list)
    assumptions: list[str] = field(default_factory=list)
    target: str = ""
    tape_length: str = ""
    report: list[str] = field(default_factory=list)


def gear(rpm: int | None, spindle: Spindle = CONTROL) -> str:
    """The gear range an RPM needs on the machine's spindle (the control's: seed 001 §3.4.4),
    and the direction."""
    if rpm is None:
        return "no RPM: the control stops if this tool is used"
    direction = "reverse" if rpm < 0 else "forward"
    if not spindle.runs(rpm):
        return f"outside the spindle's range ({spindle.text()} rpm), {direction}"
    named = spindle.gear(rpm)
    return f"{named}, {direction}" if named else direction


def first_cuts(path: CompiledPath) -> dict[int, int]:
    """The first block each tool feeds in (cuts), by tool number."""
    found: dict[int, int] = {}
    for m in motions(path):
        cutting = np.flatnonzero(m.rows["op"] != Op.RAPID)
        tools = m.tool[cutting]
        distinct, first = np.unique(tools, return_index=True)
        blocks = m.rows["block"][cutting][first]
        for tool, block in zip(distinct.tolist(), blocks.tolist(), strict=True):
            found.setdefault(tool, block)
    return found


def setup_sheet(
    program: Program,
    report: Report | None = None,
    machine: MachineModel | None = None,
    result: Estimate | None = None,
) -> SetupSheet:
    """The sheet for a valid program (and, with `report`, for one export of it)."""
    if result is None:
        result = estimate(interpret(program), machine=machine)
    db0 = program.block0
    u = program.units.symbol
    cuts = first_cuts(compile_program(program).path)
    used = set(result.per_tool) | set(cuts)
    sheet = SetupSheet(
        name=program.name,
        part_number=program.part_number,
        units=program.units.value,
        notes=program.notes,
        x_offset=f"{format_decimal(db0.x_offset)} {u}",
        y_offset=f"{format_decimal(db0.y_offset)} {u}",
        z_retract=f"{format_decimal(db0.z_retract)} {u}",
        milling=db0.milling.value,
        current_tool=db0.current_tool,
        blocks=len(program.blocks),
        total=format_seconds(result.total),
        waits=[f"block {b}: {reason}" for b, reason in result.operator_waits],
        assumptions=list(result.assumptions),
    )
    for tool in db0.tools:
        if tool.number not in used:
            continue
        sheet.tools.append(
            ToolLine(
                number=tool.number,
                diameter="—" if tool.diameter is None else f"{format_decimal(tool.diameter)} {u}",
                rpm="—" if tool.rpm is None else str(tool.rpm),
                gear=gear(tool.rpm, (machine.spindle if machine else None) or CONTROL),
                tcal="****" if tool.tcal is None else f"{format_decimal(tool.tcal)} {u}",
                coolant=tool.coolant.value,
                first_block=cuts.get(tool.number),
                seconds=format_seconds(result.per_tool.get(tool.number, 0.0)),
            )
        )
    if report is not None:
        sheet.target = report.target
        sheet.report = [line.strip() for line in report.text().splitlines()[1:]]
        for entry in report.entries:
            if "tape length" in entry.message:
                sheet.tape_length = entry.message.split("tape length", 1)[1].strip()
    return sheet


def render_text(sheet: SetupSheet) -> str:
    """The sheet as plain text (for printing from the CLI, and the golden files)."""
    lines = [
        f"SET-UP SHEET  {sheet.name}  part {sheet.part_number or '-'}  ({sheet.units})",
        "",
        f"Part zero from table zero: X {sheet.x_offset}  Y {sheet.y_offset}",
        f"Z RET {sheet.z_retract}   milling {sheet.milling}   "
        f"tool in the spindle at start: {sheet.current_tool or 'none'}",
        f"{sheet.blocks} data blocks",
        "",
        "TOOL  DIA          RPM    GEAR                      TCAL         COOLANT  FIRST CUT  TIME",
    ]
    for t in sheet.tools:
        first = f"block {t.first_block}" if t.first_block else "-"
        lines.append(
            f"{t.number:>4}  {t.diameter:<12} {t.rpm:>5}  {t.gear:<25} {t.tcal:<12} "
            f"{t.coolant:<8} {first:<10} {t.seconds}"
        )
    lines += ["", f"Cycle time {sheet.total}"]
    lines += [f"  operator: {w}" for w in sheet.waits]
    lines += [f"  assumes {a}" for a in sheet.assumptions]
    if sheet.target:
        lines += ["", f"Export: {sheet.target}"]
        if sheet.tape_length:
            lines.append(f"Tape length {sheet.tape_length}")
        lines += [f"  {entry}" for entry in sheet.report]
    if sheet.notes:
        lines += ["", f"Notes: {sheet.notes}"]
    return "\n".join(lines) + "\n"
