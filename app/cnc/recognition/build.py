"""Operations to data blocks: the one place imported numbers are rounded.

Every length becomes a block value at the programming resolution (0.001 in / 0.01 mm,
rounded half-even) in the unit the file used at that line; every value that moves is
reported once per source line. Blocks are absolute (ABS) — an imported program does not
depend on the control's reference-point rules — except inside a LOOP, where the control
requires INC: those values are differences of already rounded points, so they add up
exactly. An arc's centre is rounded to whichever neighbouring grid point keeps its two
radii closest (the divot validation would otherwise warn about).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field, replace
from decimal import Decimal

from app.cnc import limits
from app.cnc.blocks import (
    ArcEnd,
    Block,
    BoltCircle,
    Coolant,
    DataBlock0,
    Direction,
    Hole,
    Island,
    MillArc,
    MillingMode,
    MillLine,
    MillQcir,
    Mode,
    Pocket,
    PocketArc,
    PocketArcEnd,
    PocketLine,
    Pos,
    Program,
    Rep,
    Tool,
)
from app.cnc.geometry import bolt_circle_points
from app.cnc.plane import qcir_centre
from app.cnc.recognition.common import (
    XY,
    Notes,
    decimal_of,
    feed_decimal,
    feed_nm,
    quantize_nm,
    resolution_nm,
    show,
    show_feed,
)
from app.cnc.recognition.ops import (
    BoltOp,
    Element,
    HelixOp,
    HoleOpR,
    HoleSpec,
    LoopOp,
    MillOp,
    Op,
    PocketOp,
    PosOp,
    RoutineOp,
    all_lines,
    anchor,
    tool_of,
    units_of,
)
from app.cnc.recognition.steps import ToolData
from app.cnc.text import NAME_LENGTH, NOTES_LENGTH
from app.cnc.tools import tool_name_fault
from app.cnc.units import Units, format_decimal, format_length

# Values a rounding note lists for one line; past them, a count (a line a loop runs 800
# times rounds 1 600 values).
ROUNDED_SHOWN = 8


@dataclass
class SetUp:
    """What Data Block 0 is made from."""

    units: Units
    offsets: XY | None = None
    initial_tool: int = 0
    milling: MillingMode | None = None
    z_retract: int | None = None  # nm
    rpms: dict[int, int | None] = field(default_factory=dict)
    tools: dict[int, ToolData] = field(default_factory=dict)
    coolants: dict[int, str] = field(default_factory=dict)


class Builder:
    """Writes operations as blocks, in order, keeping the control's reference point."""

    def __init__(self, notes: Notes) -> None:
        self.notes = notes
        self.blocks: list[Block] = []
        self.ref: XY = (0, 0)
        # line → the values rounded on it, in order (a dict as an ordered set: a line a
        # subroutine or loop runs many times can round hundreds)
        self.rounding: dict[int, dict[str, None]] = {}

    # -- numbers --------------------------------------------------------------------------

    def length(self, nm: int, units: Units, line: int, label: str) -> int:
        """`nm` rounded to the resolution (still nm); a change is logged for `line`."""
        rounded = quantize_nm(nm, units)
        if rounded != nm:
            self.log(
                line, f"{label} {show(nm, units, 6)} → {format_decimal(decimal_of(rounded, units))}"
            )
        return rounded

    def log(self, line: int, text: str) -> None:
        self.rounding.setdefault(line, {})[text] = None

    def point(self, at: XY, units: Units, line: int) -> XY:
        return (self.length(at[0], units, line, "X"), self.length(at[1], units, line, "Y"))

    def place(
        self, raw: XY, units: Units, inc: bool, line: int, origin: XY | None = None
    ) -> tuple[Decimal, Decimal, XY]:
        """Block X/Y for the point `raw` and where the control then is: absolute values
        rounded, or (incremental) the move from `origin` (the reference point by default)
        rounded — so that rounding never adds up along a LOOP's incremental blocks."""
        if not inc:
            at = self.point(raw, units, line)
            return decimal_of(at[0], units), decimal_of(at[1], units), at
        ox, oy = self.ref if origin is None else origin
        dx = self.length(raw[0] - ox, units, line, "X increment")
        dy = self.length(raw[1] - oy, units, line, "Y increment")
        return decimal_of(dx, units), decimal_of(dy, units), (ox + dx, oy + dy)

    def z(self, nm: int | None, units: Units, line: int, label: str) -> Decimal | None:
        if nm is None:
            return None
        return decimal_of(self.length(nm, units, line, label), units)

    def feed(self, nm_per_min: int, units: Units, line: int, label: str) -> Decimal:
        value = feed_decimal(nm_per_min, units)
        if feed_nm(value, units) != nm_per_min:
            self.log(line, f"{label} {show_feed(nm_per_min, units)} → {format_decimal(value)}")
        return value

    def flush_rounding(self) -> None:
        for line in sorted(self.rounding):
            values = list(self.rounding[line])
            rest = len(values) - ROUNDED_SHOWN
            self.notes.rounded(
                line,
                "to the programming resolution (0.001 in / 0.01 mm, feeds 0.1 ipm / 2 mm/min): "
                + ", ".join(values[:ROUNDED_SHOWN])
                + (f" and {rest} more" if rest > 0 else ""),
            )

    # -- operations -------------------------------------------------------------------------

    def run(self, ops: list[Op]) -> None:
        for op in ops:
            self.op(op, inc=False, loop=False)

    def op(self, op: Op, inc: bool, loop: bool) -> None:
        first = len(self.blocks) + 1
        if isinstance(op, LoopOp):
            self.loop(op, inc)
            return
        if isinstance(op, PosOp):
            self.pos(op, inc, loop)
        elif isinstance(op, HoleOpR):
            self.hole(op.spec, op.at, op.lines[0], inc, loop, op.stop)
        elif isinstance(op, MillOp):
            self.mill(op, inc, loop)
        elif isinstance(op, BoltOp):
            self.bolt(op, inc, loop)
        elif isinstance(op, PocketOp):
            self.pocket(op, inc, loop)
        elif isinstance(op, HelixOp):
            self.helix(op, inc, loop)
        else:
            self.routine(op, inc, loop)
        if op.message:
            self.blocks[first - 1] = replace(self.blocks[first - 1], message=op.message)
        last = len(self.blocks)
        if not loop and not inc:
            titles = block_titles(self.blocks[first - 1 :])
            where = f"block {first}" if first == last else f"blocks {first}-{last}"
            self.notes.became(op.lines[0], f"{self.notes.span(op.lines)} → {where}: {titles}")

    def helix(self, op: HelixOp, inc: bool, loop: bool) -> None:
        x, y, at = self.place(op.at, op.block.units, inc, op.lines[0])
        mode = Mode.INC if inc else Mode.ABS
        self.blocks.append(replace(op.block, x=x, y=y, mode=mode, loop=loop, stop=op.stop))
        self.ref = at

    def pos(self, op: PosOp, inc: bool, loop: bool) -> None:
        x, y, at = self.place(op.at, op.units, inc, op.lines[0])
        mode = Mode.INC if inc else Mode.ABS
        self.blocks.append(
            Pos(x=x, y=y, tool=op.tool, mode=mode, units=op.units, loop=loop, stop=op.stop)
        )
        self.ref = at

    def hole(
        self,
        spec: HoleSpec,
        at_nm: XY,
        line: int,
        inc: bool,
        loop: bool,
        stop: bool,
    ) -> Hole:
        u = spec.units
        x, y, at = self.place(at_nm, u, inc, line)
        block = Hole(
            op=spec.op,
            x=x,
            y=y,
            z_up=self.z(spec.z_up, u, line, "Z UP"),
            z_dn=self.z(spec.z_dn, u, line, "Z DN"),
            feed_z=None if spec.feed_z is None else self.feed(spec.feed_z, u, line, "FEEDR Z"),
            pecks=spec.pecks,
            tool=spec.tool,
            mode=Mode.INC if inc else Mode.ABS,
            units=u,
            loop=loop,
            stop=stop,
        )
        self.blocks.append(block)
        self.ref = at
        return block

    def mill(self, op: MillOp, inc: bool, loop: bool) -> None:
        u = op.spec.units
        drill = self.hole(op.spec, op.at, op.lines[0], inc, loop, stop=False)
        self.blocks[-1] = replace(drill, comp=op.comp)
        here = self.ref
        raw = op.at  # where the file's tool is, before rounding
        mode = Mode.INC if inc else Mode.ABS
        tool = op.spec.tool
        for e in op.elements:
            x, y, end = self.place(e.end, u, inc, e.line, here)
            z_dn = self.z(e.z_dn, u, e.line, "Z DN")
            feed = self.feed(e.feed, u, e.line, "FEEDR XY")
            start, raw = raw, e.end
            grid = here if inc else (0, 0)
            centre = (
                None if e.centre is None else self.arc_centre(here, end, e.centre, u, e.line, grid)
            )
            kept = self.arc_kept(start, here, e, end, centre, u)
            if kept == "drop":
                continue
            conrad = (
                None if not e.conrad else decimal_of(self.length(e.conrad, u, e.line, "CONRAD"), u)
            )
            if centre is None or kept == "line":
                self.blocks.append(
                    MillLine(
                        x=x,
                        y=y,
                        z_dn=z_dn,
                        feed_xy=feed,
                        tool=tool,
                        mode=mode,
                        units=u,
                        conrad=conrad,
                    )
                )
            else:
                direction = Direction.CW if e.clockwise else Direction.CCW
                if _quarter(here, end, centre, direction):
                    # A quarter circle on axis-parallel centre lines: the control's QCIR.
                    self.blocks.append(
                        MillQcir(
                            direction=direction,
                            x=x,
                            y=y,
                            z_dn=z_dn,
                            feed_xy=feed,
                            tool=tool,
                            mode=mode,
                            units=u,
                            conrad=conrad,
                        )
                    )
                    here = end
                    continue
                cx, cy, _ = self.place(centre, u, inc, e.line, here)
                self.blocks.append(
                    MillArc(
                        direction=direction,
                        x=cx,
                        y=cy,
                        z_dn=z_dn,
                        feed_xy=feed,
                        tool=tool,
                        mode=mode,
                        units=u,
                    )
                )
                self.blocks.append(ArcEnd(x=x, y=y, mode=mode, units=u, conrad=conrad))
            here = end
        if op.stop:
            self.blocks[-1] = replace(self.blocks[-1], stop=True)
        self.ref = here

    def pocket(self, op: PocketOp, inc: bool, loop: bool) -> None:
        """DRILL + POCKET + the boundary's PKT blocks, then each ISLAND and its blocks
        (absolute: a pocket's contour is a shape). The reference after it is the DRILL's
        point, as after a routine."""
        u = op.spec.units
        self.hole(op.spec, op.at, op.lines[0], inc, loop, stop=False)
        start = self.ref
        feed = self.feed(op.feed, u, op.lines[0], "FEEDR XY")
        self.blocks.append(Pocket(feed_xy=feed, tool=op.spec.tool, units=u))
        self.pocket_contour(op.boundary, start, u, op.at)
        for at, elements in op.islands:
            x, y, here = self.place(at, u, False, elements[0].line if elements else op.lines[0])
            self.blocks.append(Island(x=x, y=y, units=u))
            self.pocket_contour(elements, here, u, at)
        if op.stop:
            self.blocks[-1] = replace(self.blocks[-1], stop=True)
        self.ref = start

    def pocket_contour(
        self, elements: list[Element], here: XY, u: Units, raw: XY | None = None
    ) -> None:
        """PKT LINE and PKT ARC blocks of one closed contour from `here` (nm, on the grid;
        `raw`, the file's point before rounding)."""
        raw = here if raw is None else raw
        for e in elements:
            x, y, end = self.place(e.end, u, False, e.line)
            start, raw = raw, e.end
            centre = None if e.centre is None else self.arc_centre(here, end, e.centre, u, e.line)
            kept = self.arc_kept(start, here, e, end, centre, u)
            if kept == "drop":
                continue
            if centre is None or kept == "line":
                self.blocks.append(PocketLine(x=x, y=y, units=u))
            else:
                cx, cy, _ = self.place(centre, u, False, e.line)
                direction = Direction.CW if e.clockwise else Direction.CCW
                self.blocks.append(PocketArc(direction=direction, x=cx, y=cy, units=u))
                self.blocks.append(PocketArcEnd(x=x, y=y, units=u))
            here = end

    def arc_kept(
        self, raw_start: XY, start: XY, e: Element, end: XY, centre: XY | None, units: Units
    ) -> str:
        """How an element is written once its points are rounded: "as is", or, for an arc
        that rounding would turn into another arc (a 0.0001 in arc whose ends round onto one
        point reads as a full circle; one whose ends round across each other sweeps the
        other way round), "line" (a straight move to its end) or "drop" (its ends are one
        point at the resolution). Never an arc that sweeps other than the file's; each
        change is reported with its line."""
        if e.centre is None or centre is None:
            return "as is"
        before = arc_turn(raw_start, e.end, e.centre, e.clockwise)
        # A centre rounded onto an end makes no arc at all (its radius there is 0).
        degenerate = centre in (start, end) and start != end
        after = 0.0 if degenerate else arc_turn(start, end, centre, e.clockwise)
        if abs(after - before) <= ARC_TURN_SLACK:
            return "as is"
        length = before * math.dist(raw_start, e.centre)
        what = (
            f"the arc to X {format_length(e.end[0], units)} Y {format_length(e.end[1], units)} "
            f"({show(round(length), units, 6)} long, {math.degrees(before):.2f}°)"
        )
        if start == end:
            self.notes.became(
                e.line,
                f"{what}: its ends are one point at the programming resolution, so it is "
                "left out (rounded, it would read as a full circle)",
            )
            return "drop"
        turned = (
            "its centre would fall on an end"
            if degenerate
            else f"it would sweep {math.degrees(after):.2f}°"
        )
        self.notes.became(
            e.line,
            f"{what}: rounded to the resolution {turned}, so it is written as a straight "
            "move to its end",
        )
        return "line"

    def arc_centre(
        self, start: XY, end: XY, centre: XY, units: Units, line: int, grid: XY = (0, 0)
    ) -> XY:
        """The point of the grid (steps of the resolution from `grid`) next to `centre`
        that keeps the arc's two radii closest."""
        step = resolution_nm(units)
        cx, cy = centre[0] - grid[0], centre[1] - grid[1]
        if cx % step == 0 and cy % step == 0:
            return centre
        xs = sorted({grid[0] + (cx // step) * step, grid[0] - ((-cx) // step) * step})
        ys = sorted({grid[1] + (cy // step) * step, grid[1] - ((-cy) // step) * step})

        def badness(c: XY) -> tuple[float, float]:
            mismatch = abs(math.dist(start, c) - math.dist(end, c))
            return (round(mismatch), math.dist(c, centre))

        best = min(itertools.product(xs, ys), key=badness)
        self.log(
            line,
            f"arc centre X{show(centre[0], units, 6)} Y{show(centre[1], units, 6)} → "
            f"X{show(best[0], units)} Y{show(best[1], units)}",
        )
        return best

    def bolt(self, op: BoltOp, inc: bool, loop: bool) -> None:
        u = op.spec.units
        self.hole(op.spec, op.centre, op.lines[0], inc, loop, stop=False)
        centre = self.ref
        radius = self.length(op.radius, u, op.lines[0], "RAD")
        self.blocks.append(
            BoltCircle(
                op=op.spec.op,
                holes=op.holes,
                angle=op.angle,
                radius=decimal_of(radius, u),
                mode=Mode.INC if inc else Mode.ABS,
                units=u,
                stop=op.stop,
            )
        )
        self.ref = bolt_circle_points(centre, radius, op.holes, op.angle)[-1]

    def routine(self, op: RoutineOp, inc: bool, loop: bool) -> None:
        self.hole(op.spec, op.at, op.lines[0], inc, loop, stop=False)
        at = self.ref
        mode = Mode.INC if inc else Mode.ABS
        self.blocks.append(replace(op.block, mode=mode, stop=op.stop))
        self.ref = at

    def loop(self, op: LoopOp, inc: bool) -> None:
        first = len(self.blocks) + 1
        units = _units_of(op)
        lines = all_lines(op)
        if op.head_added:
            x, y, at = self.place(anchor(op), units, True, lines[0])
            tool = tool_of(op)
            self.blocks.append(Pos(x=x, y=y, tool=tool, mode=Mode.INC, units=units, loop=True))
            self.ref = at
            self.notes.assumed(
                lines[0],
                "a LOOP POS at the pattern's first point carries the outer LOOP (the inner "
                "LOOP block cannot carry both); it moves to where the pattern starts",
            )
        for k, body in enumerate(op.body):
            self.op(body, inc=True, loop=(k == 0 and not op.head_added))
        end = self.ref
        step = (
            quantize_nm(op.step[0], units),
            quantize_nm(op.step[1], units),
        )
        self.blocks.append(
            Rep(
                x=decimal_of(step[0], units),
                y=decimal_of(step[1], units),
                nx=op.nx,
                ny=op.ny,
                units=units,
            )
        )
        self.ref = (end[0] + op.nx * step[0], end[1] + op.ny * step[1])
        if not inc:
            last = len(self.blocks)
            self.notes.became(
                lines[0],
                f"{self.notes.span(lines)}: the same operations {op.nx + 1} × {op.ny + 1} "
                f"times, shifted X{show(step[0], units)} Y{show(step[1], units)} → blocks "
                f"{first}-{last}: "
                "LOOP … REP",
            )


# A report line names at most this many runs of blocks (two more are named rather than
# counted), then counts the rest.
TITLE_RUNS = 6


def block_titles(blocks: list[Block]) -> str:
    """The blocks' titles for a report line, runs of one title counted (`MILL STD × 40`),
    and past TITLE_RUNS runs only how many more blocks: a 1 000-line contour is a short
    line, not 40 kB."""
    runs: list[tuple[str, int]] = []
    for block in blocks:
        if runs and runs[-1][0] == block.title:
            runs[-1] = (block.title, runs[-1][1] + 1)
        else:
            runs.append((block.title, 1))
    kept = runs if len(runs) <= TITLE_RUNS + 2 else runs[:TITLE_RUNS]
    shown = [f"{title} × {count}" if count > 1 else title for title, count in kept]
    rest = sum(count for _, count in runs[len(kept) :])
    if rest:
        shown.append(f"and {rest} more block{'s' if rest > 1 else ''}")
    return ", ".join(shown)


# An arc whose sweep rounding changes by more than this (radians, 10°) is no longer the
# file's arc: rounding moves an end by at most half a resolution step, which turns an arc
# of a few steps' radius by less, and turns a tiny one into a full circle or the other way.
ARC_TURN_SLACK = math.radians(10)


def arc_turn(start: XY, end: XY, centre: XY, clockwise: bool) -> float:
    """The sweep of an arc (radians, in (0, 2π]): a full circle when its ends meet."""
    if start == end:
        return 2 * math.pi
    a0 = math.atan2(start[1] - centre[1], start[0] - centre[0])
    a1 = math.atan2(end[1] - centre[1], end[0] - centre[0])
    turn = ((a0 - a1) if clockwise else (a1 - a0)) % (2 * math.pi)
    return turn or 2 * math.pi


def _quarter(start: XY, end: XY, centre: XY, direction: Direction) -> bool:
    """True when the arc is the control's QCIR: |dx| = |dy| ≠ 0 and the centre on the
    corner of its axis-parallel centre lines that turns the arc's way (seed 001 Fig. 3-4)."""
    dx, dy = end[0] - start[0], end[1] - start[1]
    if dx == 0 or abs(dx) != abs(dy):
        return False
    return qcir_centre(start, end, direction) == centre


def _units_of(op: Op) -> Units:
    return units_of(op)


def used_tools(ops: list[Op]) -> list[tuple[int, int]]:
    """(tool, first line) of every tool the operations use, in order of first use."""
    seen: dict[int, int] = {}
    for op in ops:
        if isinstance(op, LoopOp):
            for tool, line in used_tools(op.body):
                seen.setdefault(tool, line)
        else:
            seen.setdefault(tool_of(op), op.lines[0])
    return list(seen.items())


def block0(setup: SetUp, ops: list[Op], notes: Notes) -> DataBlock0:
    """Data Block 0 from what the file said: offsets, tools, Z RET, climb/conventional."""
    units = setup.units
    used = used_tools(ops)
    numbers = sorted({t for t, _ in used} | set(setup.tools) | set(setup.rpms))
    if setup.initial_tool:
        numbers = sorted({*numbers, setup.initial_tool})
    tools: list[Tool] = []
    first_use = dict(used)
    for number in numbers:
        data = setup.tools.get(number, ToolData())
        rpm = setup.rpms.get(number)
        diameter = None
        if data.diameter is not None:
            diameter = decimal_of(quantize_nm(data.diameter, units), units)
            if quantize_nm(data.diameter, units) != data.diameter:
                notes.rounded(
                    None,
                    f"tool {number} diameter {show(data.diameter, units, 6)} → "
                    f"{format_decimal(diameter)}",
                )
        tcal = None
        if data.tcal is not None:
            tcal = decimal_of(quantize_nm(data.tcal, units), units)
        coolant = Coolant(setup.coolants.get(number, "off"))
        tools.append(
            Tool(
                number=number,
                diameter=diameter,
                rpm=rpm,
                tcal=tcal,
                coolant=coolant,
                name=data.name if not tool_name_fault(data.name) else "",
            )
        )
        if number in first_use and rpm is None:
            notes.needs(
                first_use[number],
                f"tool {number} has no spindle speed in the file: enter its RPM in Data Block "
                "0 (the control stops when a tool without RPM is used)",
            )
        if not 1 <= number <= limits.MAX_TOOL:
            notes.needs(
                first_use.get(number),
                f"tool {number}: the control has tools 1 to {limits.MAX_TOOL}",
            )
    offsets = setup.offsets or (0, 0)
    x_off = decimal_of(quantize_nm(offsets[0], units), units)
    y_off = decimal_of(quantize_nm(offsets[1], units), units)
    z_retract = Decimal("0.1") if units is Units.INCH else Decimal("2.54")
    if setup.z_retract is not None:
        z_retract = decimal_of(quantize_nm(setup.z_retract, units), units)
    initial = setup.initial_tool if 0 <= setup.initial_tool <= limits.MAX_TOOL else 0
    return DataBlock0(
        x_offset=x_off,
        y_offset=y_off,
        current_tool=initial,
        milling=setup.milling or MillingMode.CLIMB,
        z_retract=z_retract,
        tools=tuple(tools),
    )


def make_program(
    name: str,
    part_number: str,
    units: Units,
    notes_text: str,
    db0: DataBlock0,
    blocks: list[Block],
) -> Program:
    part = part_number if part_number.isascii() and part_number.isdigit() else ""
    # A file's title comment may be of any length: the name and notes are cut to what the
    # library stores (app.cnc.text), so such a file still imports.
    return Program(
        name=name[:NAME_LENGTH] or "imported",
        part_number=part if len(part) <= 8 else "",
        units=units,
        notes=notes_text[:NOTES_LENGTH],
        block0=db0,
        blocks=tuple(blocks),
    )
