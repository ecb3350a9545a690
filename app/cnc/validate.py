"""Validation: every problem in a program at once, each tied to its block and field.

Validation is separate from interpretation (LinuxCNC's read/check/convert split): the
interpreter assumes a program this module accepted without errors. Messages use the
control's words where seed 001 has them (COPY 1-4, the emergency stop for a tool without
RPM, the divot of an arc whose end is off its radius).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from decimal import Decimal
from fractions import Fraction
from typing import Any

from app.cnc import cost, limits, sizes, spindle
from app.cnc.blocks import (
    ARC_PAIRS,
    Block,
    Comp,
    Copy,
    CopyAction,
    DataBlock0,
    Engrave,
    EngraveLayout,
    Face,
    Helix,
    Hole,
    HoleOp,
    Island,
    Mode,
    Pocket,
    PocketArc,
    PocketLine,
    Program,
    Rep,
    ThreadMill,
    ThreadPlace,
    Tool,
    field_label,
)
from app.cnc.compiler import compile_program
from app.cnc.cutting import tap_feed, tap_speeds_text, workpiece_faults
from app.cnc.kinds import REGISTRY, Mill, Value
from app.cnc.memo import ByObject, Recent
from app.cnc.needs import unmet
from app.cnc.problems import CONTROL_NEEDS, Problem, Rule, Severity
from app.cnc.process import process_problems
from app.cnc.structure import is_mill, mill_sequence_end, starts_mill_sequence
from app.cnc.tools import (
    MAX_FLUTES,
    MAX_NUMBER,
    Hand,
    ToolType,
    lead_per_rev,
    pitch_text,
    thread_faults,
    tool_name_fault,
)
from app.cnc.units import Units, format_decimal, message_length, to_nm

ERROR = Severity.ERROR
WARNING = Severity.WARNING

# Beyond this a value is only out of range: its resolution is not worth checking (and
# Decimal cannot quantize 1e30 to 0.001).
LARGEST = Decimal(10) ** 9

# Operator messages go into tape comments and G-code (MSG,…) lines: upper-case ASCII
# letters after conversion, and no parentheses or semicolons, which end comments.
MESSAGE_LENGTH = 60
MESSAGE_CHARACTERS = frozenset(
    "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789 .,-:/#+=*"
)

WHOLE = (Value.COUNT, Value.TOOL)


class _Shown:
    """A value with its unit as a message shows it, formatted only if a message uses it."""

    def __init__(self, value: Decimal, symbol: str) -> None:
        self.value = value
        self.symbol = symbol

    def __format__(self, spec: str) -> str:
        return f"{format_decimal(self.value)} {self.symbol}"


def validate(program: Program) -> list[Problem]:
    """Every problem of `program`, in block order (program and Data Block 0 first).

    A program is a value: the same Program object validated again (the editor does, several
    times per request) gets the answer it got, from a small memo of recent programs."""
    key = _identity(program)
    hit = _RECENT.get(key)
    if hit is not None and _identity(hit[0]) == key:
        return list(hit[1])
    checker = _Checker(program)
    checker.run()
    _RECENT.keep(key, (program, tuple(checker.problems)))
    return checker.problems


def _identity(program: Program) -> tuple[Any, ...]:
    """What validation reads of a program, by object for its parts: a copy with the same
    blocks, Data Block 0 and stock (the preview makes one) is the same program to it."""
    return (
        id(program.blocks),
        id(program.block0),
        id(program.stock),
        program.name,
        program.part_number,
        program.units,
        sizes.move_limit(),  # the limit validation holds it to (a command line may lift it)
    )


# The memo keeps each program it answers for alive, so no id in a key is reused while the
# entry is in.
RECENT_PROGRAMS = 8
_NOTHING = Program(name="")
_RECENT: Recent[tuple[Program, tuple[Problem, ...]]] = Recent(RECENT_PROGRAMS, lru=True)
OWN_BLOCKS = 1 << 15
_OWN: Recent[tuple[Problem, ...]] = Recent(OWN_BLOCKS)
# The same block objects come back (a program is edited one block at a time): by identity.
_SEEN: ByObject[tuple[Problem, ...]] = ByObject(OWN_BLOCKS)


def _own_problems(block: Block) -> tuple[Problem, ...]:
    """What is wrong with a block by itself (its values, qualifiers and message), as
    problems of block 0. A block says the same wherever it stands, so each distinct block is
    checked once. The key keeps each value as typed: 1.0 and 1.00 are equal Decimals, but a
    message shows the one typed."""
    seen = _SEEN.get(block)
    if seen is not None:
        return seen
    key = (type(block), *(_as_typed(getattr(block, f.name)) for f in REGISTRY.fields(type(block))))
    found = _OWN.get(key)
    if found is None:
        checker = _Checker(_NOTHING)
        checker.check_fields(0, block)
        checker.check_kind_rules(0, block)
        checker.check_message(0, block)
        found = tuple(checker.problems)
        _OWN.keep(key, found)
    _SEEN.keep(block, found)
    return found


def _as_typed(value: Any) -> Any:
    return (value.as_tuple(), str(value)) if isinstance(value, Decimal) else value


class _Checker:
    def __init__(self, program: Program) -> None:
        self.program = program
        self.blocks = program.blocks
        self.problems: list[Problem] = []

    def add(
        self, block: int | None, field: str | None, severity: Severity, rule: Rule, message: str
    ) -> None:
        self.problems.append(Problem(block, field, severity, message, rule))

    def run(self) -> None:
        self.check_program()
        self.check_block0(self.program.block0, self.program.units)
        for number, block in enumerate(self.blocks, start=1):
            self.problems += [replace(p, block=number) for p in _own_problems(block)]
        self.check_size()
        self.check_geometry()
        self.check_loops()
        self.check_order()
        self.check_tools()
        self.check_copy()
        self.check_two_axis()
        self.check_process()
        self.problems.sort(key=lambda p: -1 if p.block is None else p.block)

    # -- program and Data Block 0 -------------------------------------------------------

    def check_program(self) -> None:
        if not self.program.name.strip():
            self.add(None, "NAME", ERROR, Rule.NAME, "missing; every program needs a name")
        part = self.program.part_number
        if part and not (part.isdigit() and part.isascii() and len(part) <= 8):
            self.add(
                None,
                "PART NO",
                ERROR,
                Rule.PART_NUMBER,
                f"'{part}' is not a part number; allowed up to 8 digits",
            )

        if self.program.material is not None:
            for fault in workpiece_faults(self.program.material, self.program.units):
                self.add(None, "MATERIAL", ERROR, Rule.MATERIAL, fault)

    def check_block0(self, db0: DataBlock0, units: Units) -> None:
        for name in ("x_offset", "y_offset"):
            self.check_length(0, field_label(db0, name), getattr(db0, name), units)
        self.check_length(0, "Z RET", db0.z_retract, units, minimum=Decimal(0))
        if not 0 <= db0.current_tool <= 24:
            self.add(
                0,
                "CUR-TOOL",
                ERROR,
                Rule.RANGE,
                f"{db0.current_tool} is outside the allowed range 0 to 24 (0 = no tool)",
            )
        seen: set[int] = set()
        for tool in db0.tools:
            where = f"TOOL {tool.number}"
            if not 1 <= tool.number <= 24:
                self.add(
                    0,
                    "TOOL #",
                    ERROR,
                    Rule.RANGE,
                    f"{tool.number} is outside the allowed range 1 to 24",
                )
            if tool.number in seen:
                self.add(
                    0,
                    where,
                    ERROR,
                    Rule.TOOL_DUPLICATE,
                    f"tool {tool.number} is listed twice; each tool number once",
                )
            seen.add(tool.number)
            fault = tool_name_fault(tool.name)
            if fault:
                self.add(0, f"{where} NAME", ERROR, Rule.TOOL_NAME, fault)
            if tool.diameter is not None:
                self.check_length(0, f"{where} DIA", tool.diameter, units, positive=True)
            if tool.tcal is not None:
                self.check_length(0, f"{where} TCAL", tool.tcal, units)
            self.check_tool_copy(tool, where, units)
            if tool.rpm is not None and not 1 <= abs(tool.rpm) <= spindle.FIELD_MAX_RPM:
                self.add(
                    0,
                    f"{where} RPM",
                    ERROR,
                    Rule.RANGE,
                    f"{tool.rpm} is not a spindle speed; allowed 1 to {spindle.FIELD_MAX_RPM}, "
                    f"or -1 to -{spindle.FIELD_MAX_RPM} to run in reverse",
                )
            elif tool.rpm is not None and not spindle.CONTROL.runs(tool.rpm):
                # The machine's spindle decides (the export checks it); typed for the
                # control's, the program is warned.
                self.add(
                    0,
                    f"{where} RPM",
                    WARNING,
                    Rule.RANGE,
                    f"{tool.rpm} is outside the control's spindle range, "
                    f"{spindle.CONTROL.range_text()}; an export is refused unless the machine "
                    "chosen runs it (the spindle range in its profile)",
                )

    def check_tool_copy(self, tool: Tool, where: str, units: Units) -> None:
        """The program's copy of a crib tool: its ranges, and a pitch and hand only on a
        tap or thread mill (app.cnc.tools.thread_faults, the crib's own rule)."""
        if tool.crib is not None and not 1 <= tool.crib <= MAX_NUMBER:
            message = f"{tool.crib} is outside the allowed range 1 to {MAX_NUMBER}"
            self.add(0, f"{where} CRIB #", ERROR, Rule.RANGE, message)
        if tool.flutes is not None and not 1 <= tool.flutes <= MAX_FLUTES:
            message = f"{tool.flutes} is outside the allowed range 1 to {MAX_FLUTES}"
            self.add(0, f"{where} FLUTES", ERROR, Rule.RANGE, message)
        if tool.length is not None:
            self.check_length(0, f"{where} LENGTH OUT", tool.length, units, positive=True)
        for label, message in thread_faults(tool.kind, tool.pitch, tool.pitch_unit, tool.hand):
            if label == "PITCH" and tool.pitch is None:
                continue  # a tap copied without its pitch is only unchecked (check_taps)
            self.add(0, f"{where} {label}", ERROR, Rule.TOOL_THREAD, message)

    # -- fields -------------------------------------------------------------------------

    def check_fields(self, number: int, block: Block) -> None:
        """Each value against its declaration (app.cnc.kinds: value kind and limits)."""
        units = block.units
        for f in REGISTRY.fields(type(block)):
            value = getattr(block, f.name)
            if value is None or isinstance(value, bool):
                continue
            declared = f.prompt
            label = declared.label
            if declared.value is Value.LENGTH:
                minimum = None if declared.low is None else Decimal(declared.low)
                self.check_length(
                    number, label, value, units, positive=declared.positive, minimum=minimum
                )
            elif declared.value is Value.FEED and declared.feed is not None:
                self.check_feed(number, label, value, declared.feed[units], units)
            elif declared.value is Value.ANGLE:
                least = Decimal(0) if declared.low is None else Decimal(declared.low)
                most = limits.MAX_ANGLE if declared.high is None else Decimal(declared.high)
                self.check_angle(number, label, value, least, most)
            elif declared.value in WHOLE and declared.low is not None and declared.high is not None:
                low, high = declared.low, declared.high
                if not low <= value <= high:
                    self.add(
                        number,
                        label,
                        ERROR,
                        Rule.RANGE,
                        f"{value} is outside the allowed range {low} to {high}",
                    )

    def check_length(
        self,
        block: int,
        label: str,
        value: Decimal,
        units: Units,
        *,
        positive: bool = False,
        minimum: Decimal | None = None,
    ) -> None:
        high = limits.MAX_DIMENSION[units]
        shown = _Shown(value, units.symbol)
        low = minimum if minimum is not None else -high
        if positive and value <= 0:
            self.add(
                block,
                label,
                ERROR,
                Rule.RANGE,
                f"{shown} must be more than 0; allowed up to {high} {units.symbol}",
            )
        elif not low <= value <= high:
            self.add(
                block,
                label,
                ERROR,
                Rule.RANGE,
                f"{shown} is outside the allowed range {low} to {high} {units.symbol}",
            )
        if abs(value) <= LARGEST and value != value.quantize(units.resolution):
            self.add(
                block,
                label,
                ERROR,
                Rule.RESOLUTION,
                f"{shown} has too many decimals; "
                f"dimensions go to {units.resolution} {units.symbol}",
            )

    def check_feed(
        self, block: int, label: str, value: Decimal, feed: limits.FeedLimits, units: Units
    ) -> None:
        shown = _Shown(value, units.feed_symbol)
        if not feed.low <= value <= feed.high:
            self.add(
                block,
                label,
                ERROR,
                Rule.RANGE,
                f"{shown} is outside the allowed range {feed.low} to {feed.high} "
                f"{units.feed_symbol}",
            )
        if abs(value) <= LARGEST and value % feed.step != 0:
            if units is Units.MM:
                message = f"{shown} is not a step of 2; metric feeds go in steps of 2 mm/min"
                self.add(block, label, ERROR, Rule.FEED_STEP, message)
            else:
                message = f"{shown} has too many decimals; feeds go to 0.1 ipm"
                self.add(block, label, ERROR, Rule.RESOLUTION, message)

    def check_angle(
        self,
        block: int,
        label: str,
        value: Decimal,
        low: Decimal = Decimal(0),
        high: Decimal = limits.MAX_ANGLE,
    ) -> None:
        """An angle (degrees) within its declared range, to 0.01°."""
        if not low <= value <= high:
            self.add(
                block,
                label,
                ERROR,
                Rule.RANGE,
                f"{format_decimal(value)}° is outside the allowed range "
                f"{format_decimal(low)} to {format_decimal(high)}°",
            )
        if abs(value) <= LARGEST and value != value.quantize(limits.ANGLE_RESOLUTION):
            self.add(
                block,
                label,
                ERROR,
                Rule.RESOLUTION,
                f"{format_decimal(value)}° has too many decimals; angles go to 0.01°",
            )

    # -- per-block rules ----------------------------------------------------------------

    def check_message(self, number: int, block: Block) -> None:
        text = block.message
        if not text:
            return
        bad = sorted({c for c in text if c not in MESSAGE_CHARACTERS})
        if bad or len(text) > MESSAGE_LENGTH:
            what = (
                f"{len(text)} characters is too long"
                if len(text) > MESSAGE_LENGTH
                else "has characters a control cannot show: " + " ".join(repr(c) for c in bad)
            )
            self.add(
                number,
                "MESSAGE",
                ERROR,
                Rule.MESSAGE,
                f"{what}; allowed up to {MESSAGE_LENGTH} letters, digits, spaces "
                "and . , - : / # + = *",
            )

    def check_kind_rules(self, number: int, block: Block) -> None:
        kind = REGISTRY.of(block)
        if block.loop and not kind.loopable:
            self.add(
                number,
                "LOOP",
                ERROR,
                Rule.LOOP_QUALIFIER,
                f"a {block.type_name} block {REGISTRY.loop_refusal()}",
            )
        if block.stop and not kind.stoppable:
            self.add(
                number,
                "STOP",
                ERROR,
                Rule.STOP_QUALIFIER,
                f"a {block.type_name} block cannot carry STOP",
            )
        if isinstance(block, Rep) and block.mode is Mode.ABS:
            self.add(
                number,
                "ABS/INC",
                ERROR,
                Rule.ABS_IN_LOOP,
                "REP increments are always incremental (INC)",
            )
        if isinstance(block, Hole):
            self.check_hole(number, block)
        if isinstance(block, Helix):
            self.check_helix(number, block)
        if isinstance(block, ThreadMill):
            self.check_thread_mill(number, block)
        if isinstance(block, Engrave):
            self.check_engrave(number, block)
        if isinstance(block, Face) and block.z_dn >= block.z_up:
            u = block.units.symbol
            self.add(
                number,
                "Z DN",
                ERROR,
                Rule.DEPTH_ORDER,
                f"{format_decimal(block.z_dn)} {u} is not below Z UP "
                f"{format_decimal(block.z_up)} {u}; FACE takes the stock from Z UP down to Z DN",
            )

    def check_engrave(self, number: int, engrave: Engrave) -> None:
        """Text the font has, Z DN below Z UP, and an arc's radius."""
        # An operation's module loads with a program that has the operation, as the kinds
        # name them (app.cnc.kinds): not with every validation (issue 31.3).
        from app.cnc.operations.engrave import missing

        u = engrave.units.symbol
        if not engrave.text:
            self.add(number, "TEXT", ERROR, Rule.ENGRAVE_TEXT, "missing; ENGRAVE needs a text")
        bad = missing(engrave.text)
        if bad is not None:
            self.add(
                number,
                "TEXT",
                ERROR,
                Rule.ENGRAVE_TEXT,
                f"{bad!r} is not in the engraving font; allowed: letters, digits, space and "
                "the ASCII signs ! \" # $ % & ' ( ) * + , - . / : ; < = > ? @ [ \\ ] ^ _ ` "
                "{ | } ~",
            )
        if engrave.z_dn >= engrave.z_up:
            self.add(
                number,
                "Z DN",
                ERROR,
                Rule.DEPTH_ORDER,
                f"{format_decimal(engrave.z_dn)} {u} is not below Z UP "
                f"{format_decimal(engrave.z_up)} {u}; each stroke feeds down from Z UP to Z DN",
            )
        if engrave.layout is EngraveLayout.ARC and engrave.radius is None:
            self.add(
                number, "RAD", ERROR, Rule.MISSING, "missing; ENGRAVE ARC needs the arc's radius"
            )

    def check_thread_mill(self, number: int, thread: ThreadMill) -> None:
        """Z DN below Z UP by more than half a lead: the lead-in and lead-out take a
        quarter each (the tool's size is `check_thread_tool`'s)."""
        from app.cnc.operations.thread import thread_lead

        u = thread.units.symbol
        lead = thread_lead(thread)
        if to_nm(thread.z_up, thread.units) - to_nm(thread.z_dn, thread.units) <= lead // 2:
            self.add(
                number,
                "Z DN",
                ERROR,
                Rule.DEPTH_ORDER,
                f"{format_decimal(thread.z_dn)} {u} is not below Z UP "
                f"{format_decimal(thread.z_up)} {u} by more than half the thread's "
                f"{message_length(lead, thread.units)} lead: the thread runs from Z UP down "
                "to Z DN, and its lead-in and lead-out take a quarter of the lead each",
            )

    def check_helix(self, number: int, helix: Helix) -> None:
        """Z DN below Z UP (the tool's size is `check_helix_tool`'s)."""
        u = helix.units.symbol
        if helix.z_dn >= helix.z_up:
            self.add(
                number,
                "Z DN",
                ERROR,
                Rule.DEPTH_ORDER,
                f"{format_decimal(helix.z_dn)} {u} is not below Z UP "
                f"{format_decimal(helix.z_up)} {u}; the helix goes down from Z UP to Z DN",
            )

    def check_hole(self, number: int, hole: Hole) -> None:
        op = hole.op.value
        if hole.pecks != 1 and hole.op is not HoleOp.DRILL:
            self.add(
                number,
                "# PECK",
                ERROR,
                Rule.PECKS_NOT_DRILL,
                f"{hole.pecks} pecks on a {op} block; no pecks are allowed in {op} (only DRILL)",
            )
        if hole.comp is not Comp.NONE and hole.op is not HoleOp.DRILL:
            self.add(
                number,
                "CUTTER COMP",
                ERROR,
                Rule.COMP_NOT_DRILL,
                f"cutter compensation on a {op} block; only the DRILL that starts a mill "
                "sequence carries CUT RT or CUT LT",
            )
        depth = (hole.z_up, hole.z_dn, hole.feed_z)
        if any(v is not None for v in depth) and any(v is None for v in depth):
            missing = [
                label
                for label, value in zip(("Z UP", "Z DN", "FEEDR Z"), depth, strict=True)
                if value is None
            ]
            self.add(
                number,
                missing[0],
                ERROR,
                Rule.MISSING,
                f"missing; a {op} with depths needs Z UP, Z DN and FEEDR Z "
                "(leave all three empty for a 2-axis program)",
            )
        if hole.z_up is not None and hole.z_dn is not None and hole.z_dn >= hole.z_up:
            u = hole.units.symbol
            self.add(
                number,
                "Z DN",
                ERROR,
                Rule.DEPTH_ORDER,
                f"{format_decimal(hole.z_dn)} {u} is not below Z UP "
                f"{format_decimal(hole.z_up)} {u}; the tool feeds down from Z UP to Z DN",
            )

    # -- LOOP / REP ---------------------------------------------------------------------

    def check_loops(self) -> None:
        open_loops: list[int] = []
        for number, block in enumerate(self.blocks, start=1):
            if block.loop and REGISTRY.of(block).loopable:
                if len(open_loops) == limits.MAX_LOOP_DEPTH:
                    self.add(
                        number,
                        "LOOP",
                        ERROR,
                        Rule.LOOP_TOO_DEEP,
                        "a fifth LOOP inside four open ones; LOOP sequences nest at most 4 deep",
                    )
                open_loops.append(number)
            if open_loops and block.mode is Mode.ABS and _has_position(block):
                if open_loops[-1] == number:
                    message = (
                        "a LOOP block is incremental (INC): each pattern starts from where "
                        "the one before it started, shifted by the REP increments"
                    )
                else:
                    message = (
                        f"ABS block inside the LOOP sequence of block {open_loops[0]}; "
                        "blocks in a LOOP sequence are incremental (INC)"
                    )
                self.add(number, "ABS/INC", ERROR, Rule.ABS_IN_LOOP, message)
            if isinstance(block, Rep):
                if open_loops:
                    open_loops.pop()
                else:
                    self.add(
                        number,
                        None,
                        ERROR,
                        Rule.REP_WITHOUT_LOOP,
                        "REP without an open LOOP before it; REP closes an unmatched LOOP block",
                    )
        for number in open_loops:
            self.add(
                number,
                "LOOP",
                ERROR,
                Rule.LOOP_WITHOUT_REP,
                "LOOP without a matching REP; add a REP block to close the pattern",
            )

    # -- block order ----------------------------------------------------------------------

    def check_order(self) -> None:
        blocks = self.blocks
        for index, block in enumerate(blocks):
            number = index + 1
            previous = blocks[index - 1] if index else None
            self.check_arc_pair(index, block)
            # What may follow what is each kind's declaration (Kind.follows).
            message = REGISTRY.out_of_order(previous, block, number)
            follows = REGISTRY.of(block).follows
            if message and follows is not None:
                self.add(number, None, ERROR, follows.rule, message)
            self.check_pocket_order(index, block, previous, in_order=not message)
            if (
                isinstance(block, Hole)
                and block.comp is not Comp.NONE
                and block.op is HoleOp.DRILL
                and not (index + 1 < len(blocks) and is_mill(blocks[index + 1]))
            ):
                self.add(
                    number,
                    "CUTTER COMP",
                    WARNING,
                    Rule.COMP_WITHOUT_MILL,
                    "cutter compensation on a DRILL that no mill block follows; it has no effect",
                )
            if (
                block.stop
                and REGISTRY.of(block).stoppable  # else refused as it is, once
                and self.inside_mill_sequence(index)
                and _in_sequence(blocks[index + 1])
            ):
                self.add(
                    number,
                    "STOP",
                    ERROR,
                    Rule.STOP_QUALIFIER,
                    "STOP inside a mill sequence; the head retracts at a STOP, so put it on "
                    "the sequence's last block",
                )

    def check_arc_pair(self, index: int, block: Block) -> None:
        """An arc's XY-CENT block has its XY-END right after it (MILL ARC and PKT ARC alike,
        ARC_PAIRS); that an XY-END follows its XY-CENT is the XY-END's order rule."""
        nxt = self.blocks[index + 1] if index + 1 < len(self.blocks) else None
        for centre, end, centre_name, _ in ARC_PAIRS:
            if isinstance(block, centre) and not isinstance(nxt, end):
                message = f"{centre_name} without its XY-END block just after it"
                self.add(index + 1, None, ERROR, Rule.ARC_END_ORDER, message)

    def check_pocket_order(
        self, index: int, block: Block, previous: Block | None, *, in_order: bool
    ) -> None:
        """Beyond the order rules of the kinds: a POCKET's boundary follows it and an
        ISLAND's contour the ISLAND, islands after the boundary; a POCKET needs depths (it
        retracts between passes). `in_order`: the block meets its kind's order rule."""
        number = index + 1
        nxt = self.blocks[index + 1] if index + 1 < len(self.blocks) else None
        if isinstance(block, Pocket):
            drill = previous
            if isinstance(drill, Hole) and drill.op is HoleOp.DRILL and not drill.has_depth:
                self.add(
                    index,
                    "Z DN",
                    WARNING,
                    Rule.POCKET_TWO_AXIS,
                    "a 2-axis POCKET: the program stops for the quill to be lowered by hand "
                    "at each place the tool goes down and raised before the table moves on; "
                    "# PECK is the operator's",
                )
            if nxt is None or REGISTRY.of(nxt).mill is not Mill.GEOMETRY:
                self.add(
                    number,
                    None,
                    ERROR,
                    Rule.POCKET_ORDER,
                    "POCKET without its boundary: PKT LINE and PKT ARC blocks follow it and "
                    "draw the boundary from the DRILL's X/Y back to that point",
                )
            return
        if not isinstance(block, Island):
            return
        if in_order and not isinstance(nxt, PocketLine | PocketArc):
            self.add(
                number,
                None,
                ERROR,
                Rule.POCKET_ORDER,
                "ISLAND without its contour: PKT LINE and PKT ARC blocks follow it and draw "
                "the island back to its start point",
            )
        if isinstance(previous, Pocket):
            self.add(
                number,
                None,
                ERROR,
                Rule.POCKET_ORDER,
                "ISLAND right after its POCKET: the boundary's PKT LINE and PKT ARC blocks "
                "come first, then each island",
            )

    def check_helix_tool(self, number: int, helix: Helix, tool: Tool) -> None:
        """A HELIX's tool smaller than its diameter."""
        if tool.diameter is None:
            return
        u = helix.units.symbol
        tool_diameter = to_nm(tool.diameter, self.program.units)
        if tool_diameter >= to_nm(helix.diameter, helix.units):
            self.add(
                number,
                "DIA",
                ERROR,
                Rule.HELIX_TOOL,
                f"{format_decimal(helix.diameter)} {u} is not larger than tool "
                f"{helix.tool}'s DIA {message_length(tool_diameter, helix.units)}; the "
                "tool's centre goes round at half their difference: give a larger DIA or a "
                "smaller tool",
            )

    def check_thread_tool(self, number: int, thread: ThreadMill, tool: Tool) -> None:
        """An internal thread's tool goes down the bore's centre: smaller than the minor
        diameter."""
        if tool.diameter is None or thread.place is not ThreadPlace.INTERNAL:
            return
        from app.cnc.operations.thread import thread_depth, thread_lead

        tool_diameter = to_nm(tool.diameter, self.program.units)
        lead = thread_lead(thread)
        minor = to_nm(thread.diameter, thread.units) - round(2 * thread_depth(lead, True))
        if tool_diameter >= minor:
            self.add(
                number,
                "TOOL #",
                ERROR,
                Rule.HELIX_TOOL,
                f"tool {thread.tool}'s DIA {message_length(tool_diameter, thread.units)} is not "
                f"smaller than the thread's minor diameter "
                f"{message_length(minor, thread.units)}: the tool goes down the bore's "
                "centre and out to the thread; give a smaller thread mill",
            )

    def inside_mill_sequence(self, index: int) -> bool:
        """True when block `index` is a DRILL starting a sequence or one of its mill blocks."""
        return index + 1 < len(self.blocks) and (
            starts_mill_sequence(self.blocks, index) or _in_sequence(self.blocks[index])
        )

    # -- tools ----------------------------------------------------------------------------

    def check_tools(self) -> None:
        # The control's own needs (a tool without RPM is its emergency stop), once per tool.
        self.problems += unmet(self.program, CONTROL_NEEDS)
        db0 = self.program.block0
        for number, block in enumerate(self.blocks, start=1):
            tool_number = block.tool_number
            if tool_number is None or not 1 <= tool_number <= 24:
                continue
            tool = db0.tool(tool_number)
            # A routine keeps the tool off its contour by itself, and a HELIX goes round
            # at its DIA less the tool's: they need the diameter.
            needs_diameter = (
                REGISTRY.of(block).mill is Mill.ROUTINE
                or isinstance(block, Helix | ThreadMill | Face)
                or (
                    isinstance(block, Hole)
                    and block.comp is not Comp.NONE
                    and starts_mill_sequence(self.blocks, number - 1)
                )
            )
            if isinstance(block, Helix) and tool is not None:
                self.check_helix_tool(number, block, tool)
            if isinstance(block, ThreadMill) and tool is not None:
                self.check_thread_tool(number, block, tool)
            if needs_diameter and (tool is None or tool.diameter is None):
                self.add(
                    number,
                    "TOOL #",
                    ERROR,
                    Rule.TOOL_NO_DIAMETER,
                    f"tool {tool_number} has no DIA in Data Block 0; "
                    + (
                        "a POCKET needs the cutter's measured diameter to keep off its wall "
                        "and islands"
                        if isinstance(block, Pocket)
                        else "a HELIX goes round at the finished DIA less the cutter's"
                        if isinstance(block, Helix)
                        else "a THREAD MILL cuts the thread to size with the cutter's diameter"
                        if isinstance(block, ThreadMill)
                        else "a FACE spaces its passes by a share of the cutter's diameter"
                        if isinstance(block, Face)
                        else "cutter-compensated milling needs the cutter's measured diameter"
                    ),
                )
        self.check_taps()
        for first, last, what in self.sequences():
            sequence_tool = self.blocks[first].tool_number
            for index in range(first + 1, last + 1):
                other = self.blocks[index].tool_number
                if other is not None and sequence_tool is not None and other != sequence_tool:
                    self.add(
                        index + 1,
                        "TOOL #",
                        ERROR,
                        Rule.TOOL_CHANGE_IN_SEQUENCE,
                        f"tool {other} differs from tool {sequence_tool} of the {what} starting at "
                        f"block {first + 1}; one tool is used for the whole {what}",
                    )

    def check_taps(self) -> None:
        """A tap feeds exactly one pitch per turn: a TAP block's FEEDR Z is its tool's RPM ×
        pitch, and a left-hand tap turns in reverse (a negative RPM), a right-hand one
        forward. Checked where Data Block 0 knows the tool is a tap (its type or pitch,
        copied from the crib)."""
        db0 = self.program.block0
        for number, block in enumerate(self.blocks, start=1):
            if not (isinstance(block, Hole) and block.op is HoleOp.TAP):
                continue
            tool = db0.tool(block.tool)
            if tool is None or tool.rpm is None:
                continue
            is_tap = tool.kind is ToolType.TAP or (tool.kind is None and tool.pitch is not None)
            if not is_tap:
                continue
            what = f"tool {tool.number}" + (f" ({tool.name})" if tool.name else "")
            if tool.hand is Hand.LEFT and tool.rpm > 0:
                self.add(
                    number,
                    "TOOL #",
                    ERROR,
                    Rule.TAP_HAND,
                    f"{what} is a left-hand tap but turns forward at {tool.rpm} rpm; a left-hand "
                    f"tap runs in reverse: make its RPM negative ({-tool.rpm}) in Data Block 0",
                )
            elif tool.hand is Hand.RIGHT and tool.rpm < 0:
                self.add(
                    number,
                    "TOOL #",
                    ERROR,
                    Rule.TAP_HAND,
                    f"{what} is a right-hand tap but turns in reverse at {tool.rpm} rpm; a "
                    f"right-hand tap runs forward: make its RPM positive ({-tool.rpm}) in "
                    "Data Block 0",
                )
            if tool.pitch is None or block.feed_z is None or tool.pitch <= 0:
                continue
            lead = lead_per_rev(tool.pitch, tool.pitch_unit, block.units)
            needed = tap_feed(tool.rpm, lead, block.units)
            if Fraction(block.feed_z) == needed:
                continue
            u = block.units.feed_symbol
            pitch = pitch_text(tool.pitch, tool.pitch_unit)
            step = Fraction(limits.FEED_Z[block.units].step)
            shown = format_decimal(block.feed_z)
            product = f"{abs(tool.rpm)} rpm × {pitch} = {_feed(needed, block.units)} {u}"
            if (needed / step).denominator == 1:
                fix = f"change FEEDR Z to {_feed(needed, block.units)} or the tool's RPM"
            else:
                fix = (
                    f"FEEDR Z cannot hold that ({limits.FEED_Z[block.units].step} {u} steps): "
                    + tap_speeds_text(tool.rpm, lead, block.units)
                )
            self.add(
                number,
                "FEEDR Z",
                ERROR,
                Rule.TAP_FEED,
                f"{shown} {u} does not match {what}: a tap feeds one pitch per turn, "
                f"{product}; {fix}",
            )

    def sequences(self) -> Iterator[tuple[int, int, str]]:
        """(first, last, name) index ranges of mill sequences and outermost LOOP sequences."""
        blocks = self.blocks
        for index in range(len(blocks)):
            if starts_mill_sequence(blocks, index):
                yield index, mill_sequence_end(blocks, index) - 1, "mill sequence"
        depth = 0
        start = 0
        for index, block in enumerate(blocks):
            if block.loop and REGISTRY.of(block).loopable:
                if depth == 0:
                    start = index
                depth += 1
            elif isinstance(block, Rep) and depth:
                depth -= 1
                if depth == 0:
                    yield start, index, "LOOP sequence"

    # -- size -------------------------------------------------------------------------------

    def check_size(self) -> None:
        """A program past the moves it may expand to, or a POCKET past the planning it may
        take (app/cnc/cost.py): an error on the outermost block that takes it there, before
        anything compiles it."""
        found = cost.estimate(self.program)
        if found.over is not None:
            self.add(
                found.over,
                "LOOP" if found.rep is not None else "STEP" if found.levels else None,
                ERROR,
                Rule.TOO_LARGE,
                found.message(sizes.move_limit()),
            )

    # -- geometry ------------------------------------------------------------------------

    def check_geometry(self) -> None:
        """The geometry's problems are the compile's (the same plan the tool path is cut
        from: quarter circles, arcs off their radius, zero-length moves, compensation and
        routine limits). Compiled only when every value is in range: a count out of range
        (pecks, holes, repeats) would be work without bound, and a length out of range has
        no geometry worth reporting until it is fixed."""
        blocks = self.blocks
        for index, block in enumerate(blocks):
            if (
                isinstance(block, Hole)
                and block.comp is not Comp.NONE
                and starts_mill_sequence(blocks, index)
                and REGISTRY.of(blocks[index + 1]).mill is Mill.ROUTINE
            ):
                self.add(
                    index + 1,
                    "CUTTER COMP",
                    WARNING,
                    Rule.COMP_ON_ROUTINE,
                    f"cutter compensation on the DRILL before a {blocks[index + 1].type_name}; "
                    + (
                        "a POCKET keeps the tool off its wall and islands by itself"
                        if isinstance(blocks[index + 1], Pocket)
                        else "CIRCLE and FRAME routines compensate by themselves"
                    )
                    + ", so it has no effect",
                )
        if any(p.severity is ERROR for p in self.problems):
            return
        for finding in compile_program(self.program).findings:
            self.add(finding.block, finding.field, finding.severity, finding.rule, finding.message)

    def check_process(self) -> None:
        """What a machinist checks before the first chip (a tap's pilot, the stock's bottom),
        from the compiled path: only for a program without errors, whose path is whole."""
        if not any(p.severity is ERROR for p in self.problems):
            self.problems += process_problems(self.program, compile_program(self.program))

    # -- COPY -------------------------------------------------------------------------------

    def check_copy(self) -> None:
        for index, block in enumerate(self.blocks):
            if isinstance(block, Copy) and block.action is not CopyAction.CANCEL:
                for code, message in copy_errors(self.program, index + 1):
                    self.add(index + 1, None, ERROR, code, message)
                if block.action is None:
                    self.add(
                        index + 1,
                        "EXEC/CANCEL",
                        WARNING,
                        Rule.COPY_PENDING,
                        "COPY is waiting for EXEC or CANCEL; until then it makes no blocks "
                        "and the program runs without it",
                    )

    # -- 2-axis and 3-axis ------------------------------------------------------------------

    def check_two_axis(self) -> None:
        holes = [(n, b) for n, b in enumerate(self.blocks, start=1) if isinstance(b, Hole)]
        with_depth = [n for n, b in holes if b.has_depth]
        without = [n for n, b in holes if not b.has_depth and b.z_up is None and b.z_dn is None]
        if with_depth and without:
            self.add(
                without[0],
                "Z DN",
                WARNING,
                Rule.TWO_AXIS_MIXED,
                f"no depths here but block {with_depth[0]} has them; the control will stop "
                "for the quill to be moved by hand at each block without depths",
            )


COPY_MESSAGES = {
    Rule.COPY_1: "ERROR: COPY 1 FROM or TO block does not exist.",
    Rule.COPY_2: "ERROR: COPY 2 INCH and METRIC blocks are mixed in the COPY range and COPY block.",
    Rule.COPY_3: (
        "ERROR: COPY 3 All blocks in the range are not in incremental mode; "
        "the first block is incremental."
    ),
    Rule.COPY_4: "ERROR: COPY 4 COPY is being selected in an inserted data block.",
}


def copy_errors(program: Program, number: int) -> list[tuple[Rule, str]]:
    """The COPY errors (seed 001 §3.4.6, in the control's words) of COPY block `number`."""
    copy = program.block(number)
    assert isinstance(copy, Copy)
    errors: list[tuple[Rule, str]] = []
    if number != len(program.blocks):
        errors.append((Rule.COPY_4, COPY_MESSAGES[Rule.COPY_4]))
    last_existing = number - 1
    if not (1 <= copy.from_block <= last_existing and 1 <= copy.to_block <= last_existing):
        errors.append((Rule.COPY_1, COPY_MESSAGES[Rule.COPY_1]))
        return errors
    if copy.from_block > copy.to_block:
        errors.append(
            (
                Rule.COPY_RANGE_ORDER,
                f"FROM block {copy.from_block} is after TO block {copy.to_block}; "
                "the range runs from the first block to the last",
            )
        )
        return errors
    span = program.blocks[copy.from_block - 1 : copy.to_block]
    if any(b.units is not copy.units for b in span):
        errors.append((Rule.COPY_2, COPY_MESSAGES[Rule.COPY_2]))
    if span[0].mode is Mode.INC and any(b.mode is Mode.ABS for b in span if _has_position(b)):
        errors.append((Rule.COPY_3, COPY_MESSAGES[Rule.COPY_3]))
    return errors


def _feed(value: Fraction, units: Units) -> str:
    """A feed worked out exactly, as a message shows it: 25.0 (ipm), 500 (mm/min), 16.65."""
    if units is Units.MM and value.denominator == 1:
        return str(value.numerator)
    text = f"{float(value):.4f}".rstrip("0")
    return text + "0" if text.endswith(".") else text


def _in_sequence(block: Block) -> bool:
    """True for the blocks of a mill sequence after its DRILL (a POCKET's contour too)."""
    return REGISTRY.of(block).mill is not None


def _has_position(block: Block) -> bool:
    """True for blocks whose X/Y is a position (ABS/INC matters for them)."""
    return REGISTRY.of(block).positioned
