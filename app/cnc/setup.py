"""The set-up sheet: what the operator needs on paper to set up and run a program.

The 1704 manual's programming manuscript (seed 000 Fig. 1-3) brought up to date: part zero
and the Data Block 0 offsets, the stock to put in the vise (the program's own, or the one
the simulation sizes from the program's extent: app/cnc/simulate's rule), the tool list
with each tool's name, type and length out of the holder (the crib's, as the program
copied it), diameter, RPM (and the gear range on the machine's spindle; the control's,
seed 001 §3.4.4: 60-500 low, 500-4000 high), calibration, coolant and the first block each
tool cuts; the hole table (every hole in cutting order with its block, position,
tool, depth and operation, read from the compiled path's hole spans); cycle time per tool
and in total; for a target, its compatibility report (with the tape length for tape); and
the tool path picture. A pure
function of the program, the target's report and the machine: the web page and the CLI
render the same content.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from app.cnc.blocks import HoleOp, Program
from app.cnc.compiler import compile_program
from app.cnc.estimate import Estimate, estimate, format_seconds
from app.cnc.formats.targets import Report
from app.cnc.interpret import interpret
from app.cnc.machine import MachineModel
from app.cnc.motions import motions
from app.cnc.path import CompiledPath, Op
from app.cnc.simulate.placements import place
from app.cnc.simulate.stock import StockError
from app.cnc.simulate.verify import stock_of
from app.cnc.spindle import CONTROL, Spindle
from app.cnc.units import Units, format_decimal, format_length

# The hole table lists this many holes; a program with more says how many more there are.
HOLE_ROWS = 500


@dataclass(frozen=True)
class ToolLine:
    """One tool to set up: its name, type (the crib's, as the program copied it) and
    length out of the holder, diameter, RPM and gear, calibration, coolant, first cut."""

    number: int
    name: str
    diameter: str
    rpm: str
    gear: str
    tcal: str
    coolant: str
    first_block: int | None
    seconds: str
    kind: str = ""
    length: str = ""

    def description(self) -> str:
        """`1/4-20 TAP (tap, 1.250 in out of the holder)`, or the name alone."""
        details = [self.kind] if self.kind else []
        if self.length:
            details.append(f"{self.length} out of the holder")
        if not details:
            return self.name
        return (f"{self.name} " if self.name else "") + f"({', '.join(details)})"


@dataclass(frozen=True)
class HoleLine:
    """One hole as the compiled path cuts it: its place in cutting order, the block that
    made it, X/Y (part coordinates), the tool, Z DN and the operation."""

    number: int
    block: int
    x: str
    y: str
    tool: int
    tool_name: str
    depth: str
    operation: str


@dataclass(frozen=True)
class StockLine:
    """The stock to set up: its size (XL × YW × ZH), where it lies, and whose it is."""

    size: str
    where: str
    given: bool


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
    stock: StockLine | None = None
    stock_error: str = ""
    tools: list[ToolLine] = field(default_factory=list)
    holes: list[HoleLine] = field(default_factory=list)
    more_holes: int = 0
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


def operation(op: HoleOp, pecks: int) -> str:
    """How a hole is made, as the machinist says it: `drill, 3 pecks`, `bore`, `tap`."""
    text = op.value.lower()
    return f"{text}, {pecks} pecks" if pecks > 1 else text


def _walk(
    path: CompiledPath, units: Units, names: dict[int, str]
) -> tuple[dict[int, int], list[HoleLine], int]:
    """The first block each tool cuts in, the holes in cutting order (up to HOLE_ROWS) and
    how many holes there are: one walk over the compiled path's motions and hole spans."""
    found: dict[int, int] = {}
    holes: list[HoleLine] = []
    count = 0
    for m in motions(path):
        rows = m.rows
        cutting = np.flatnonzero(rows["op"] != Op.RAPID)
        tools = m.tool[cutting]
        distinct, first = np.unique(tools, return_index=True)
        blocks = rows["block"][cutting][first]
        for tool, block in zip(distinct.tolist(), blocks.tolist(), strict=True):
            found.setdefault(tool, block)
        spans = m.chunk.holes
        if not len(spans):
            continue
        if count + len(spans) > HOLE_ROWS:
            shown = m.chunk.hole_spans()[: max(0, HOLE_ROWS - count)]
        else:
            shown = m.chunk.hole_spans()
        for span in shown:
            tool = span.tool
            count += 1
            holes.append(
                HoleLine(
                    number=count,
                    block=int(m.chunk.rows["block"][span.start]),
                    x=format_length(span.x, units),
                    y=format_length(span.y, units),
                    tool=tool,
                    tool_name=names.get(tool, ""),
                    depth=format_length(span.bottom, units),
                    operation=operation(span.op, span.pecks),
                )
            )
        count += len(spans) - len(shown)
    return found, holes, count


def stock_line(program: Program, path: CompiledPath) -> StockLine:
    """The stock the simulation cuts (the program's, else sized from its extent: the
    simulate package's rule). Raises StockError for a stock it cannot take."""
    stock = stock_of(program, place(program, path))
    u = program.units

    def f(nm: int) -> str:
        return format_length(nm, u)

    size = (
        f"XL {f(stock.x1 - stock.x0)} × YW {f(stock.y1 - stock.y0)} × "
        f"ZH {f(stock.top - stock.bottom)} {u.symbol}"
    )
    where = f"lower-left corner X {f(stock.x0)}, Y {f(stock.y0)}; top Z {f(stock.top)} {u.symbol}"
    if stock.clear:
        # Through cuts go this far below the stock: it must stand on parallels that high.
        where += f"; on parallels, {f(stock.clear)} {u.symbol} clear below it"
    return StockLine(size, where, stock.given)


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
    path = compile_program(program).path
    names = {tool.number: tool.name for tool in db0.tools}
    cuts, holes, count = _walk(path, program.units, names)
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
        holes=holes,
        more_holes=count - len(holes),
    )
    try:
        sheet.stock = stock_line(program, path)
    except StockError as exc:
        sheet.stock_error = str(exc)
    for tool in db0.tools:
        if tool.number not in used:
            continue
        sheet.tools.append(
            ToolLine(
                number=tool.number,
                name=tool.name,
                diameter="—" if tool.diameter is None else f"{format_decimal(tool.diameter)} {u}",
                rpm="—" if tool.rpm is None else str(tool.rpm),
                gear=gear(tool.rpm, (machine.spindle if machine else None) or CONTROL),
                tcal="****" if tool.tcal is None else f"{format_decimal(tool.tcal)} {u}",
                coolant=tool.coolant.value,
                first_block=cuts.get(tool.number),
                seconds=format_seconds(result.per_tool.get(tool.number, 0.0)),
                kind=tool.kind.label if tool.kind is not None else "",
                length="" if tool.length is None else f"{format_decimal(tool.length)} {u}",
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
    ]
    if sheet.stock is not None:
        whose = "the program's stock" if sheet.stock.given else "sized from the program's extent"
        lines.append(f"Stock {sheet.stock.size} ({whose}); {sheet.stock.where}")
    else:
        lines.append(f"Stock: {sheet.stock_error}")
    lines += [
        "",
        "TOOL  DIA          RPM    GEAR                      TCAL         COOLANT  FIRST CUT  TIME",
    ]
    for t in sheet.tools:
        first = f"block {t.first_block}" if t.first_block else "-"
        lines.append(
            f"{t.number:>4}  {t.diameter:<12} {t.rpm:>5}  {t.gear:<25} {t.tcal:<12} "
            f"{t.coolant:<8} {first:<10} {t.seconds}"
        )
        if t.description():
            lines.append(f"      {t.description()}")
    if sheet.holes:
        lines += ["", "HOLE  BLOCK  X           Y           TOOL  Z DN        OPERATION"]
        for h in sheet.holes:
            lines.append(
                f"{h.number:>4}  {h.block:>5}  {h.x:<11} {h.y:<11} {h.tool:>4}  {h.depth:<11} "
                f"{h.operation}" + (f" ({h.tool_name})" if h.tool_name else "")
            )
        if sheet.more_holes:
            lines.append(f"  … {sheet.more_holes} more holes")
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
