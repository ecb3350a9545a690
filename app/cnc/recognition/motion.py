"""Motion (from G-code or a tape) to a program: segment, recognise, build.

DESIGN.md §1: "G-code / 1704 tape → Toolpath → Program (recognised blocks)". The parsers
give the motion (`steps.py`); `segment` finds operations in it, `recognise` proposes the
blocks that make the same motion, `build` writes them, rounded once, with Data Block 0.
"""

from __future__ import annotations

from dataclasses import replace

from app.cnc import limits
from app.cnc.blocks import Program
from app.cnc.recognition.build import Builder, SetUp, block0, make_program
from app.cnc.recognition.common import ImportFailure, Notes, show
from app.cnc.recognition.ops import LoopOp, Op, z_up_of
from app.cnc.recognition.recognise import (
    RoutineFinder,
    find_bolt_circles,
    find_loops,
    merge_pecks,
)
from app.cnc.recognition.segment import Retract, Segmented, ToolUse, is_two_axis, segment
from app.cnc.recognition.steps import (
    Arc,
    Feed,
    Parsed,
    StepWindow,
    StreamSource,
    ToolChange,
)


def program_from_motion(parsed: Parsed) -> Program:
    """The program whose blocks make the motion of `parsed`; the report goes to its notes.

    Consumes `parsed.steps`: the list is emptied once segmented, so that the steps (the
    biggest part of a long file) are not held while the operations are recognised.

    Raises ImportFailure (from segmenting) for motion no block can make.
    """
    number_tools(parsed)
    found = segment(parsed)
    parsed.steps = []
    recognition = Recognition(parsed, {n: use.rpm for n, use in found.tools.items()})
    recognition.batch(found.ops, [], None)
    return recognition.program(found, found.retracts)


class Unstreamable(Exception):
    """A file that streaming would not read as the whole file is read: read it whole."""


def program_from_stream(stream: StreamSource) -> tuple[Program, Notes]:
    """The program of a file read as it streams (docs/imports.md, "Streaming"), and its
    report: the same program and report as `program_from_motion` of the whole file, in
    memory that does not grow with its length (the segmenter's look-ahead, one batch of
    BATCH_OPS operations, and the operations recognition leaves — for a repetitive file a
    few LOOPs).

    The segmenter starts once the file shows it is not a 2-axis program (its first cycle
    or second height; a 2-axis file is read whole first), with the set-up as far as the
    file has said it — units, the tolerance of its finest number, its first tool — and
    recognition takes the tools' diameters and speeds as they are at each batch. At the
    end each is checked against what the whole file says; where any differs (a finer
    number late in the file, a tool's diameter given after it cut), where the file names
    tools past 24 (renumbering needs them all), or where anything is refused, this raises
    Unstreamable and the caller reads the file whole (which then gives its error)."""
    notes = Notes()
    window = StepWindow(stream)
    try:
        is_two_axis(window)  # (reads on until it knows: the set-up is as the file starts)
        start = stream.so_far(notes)
        recognition = Recognition(start, {})
        found = segment(start, window, recognition.batch)
        whole = stream.read_all()
        if stream.renumbers():
            raise Unstreamable("tools past the control's 24")
        if (whole.units, whole.tolerance, whole.initial_tool) != (
            start.units,
            start.tolerance,
            start.initial_tool,
        ):
            raise Unstreamable("the set-up the file gave at its start changed")
        diameters = {n: t.diameter for n, t in whole.tools.items() if t.diameter is not None}
        if any(used != diameters for used in found.diameters_used):
            raise Unstreamable("a compensated cut read a diameter the file changed later")
        whole.notes, reader_notes = notes, whole.notes
        recognition.parsed = whole
        recognition.batch(found.ops, [], found.tools)
        rpms = {n: use.rpm for n, use in found.tools.items()}
        finals = {n: t.diameter for n, t in whole.tools.items() if t.diameter}
        if any(
            asked != (finals.get(n), rpms.get(n)) for n, asked in recognition.finder.asked.items()
        ):
            raise Unstreamable("a tool's diameter or speed changed after it was used")
        program = recognition.program(found, found.retracts)
        merge_notes(reader_notes, notes)
    except (ImportFailure, NotesOverlap) as exc:
        raise Unstreamable(str(exc)) from None
    return program, reader_notes


class Recognition:
    """Operations to blocks: each batch of operations (the whole file's, or a streaming
    segmenter's BATCH_OPS at a time) through peck, routine, bolt-circle and LOOP
    recognition, then, at the end, the LOOPs across batches, the blocks and Data Block 0.

    `rpms` is the spindle speed of each tool as far as the motion has said (the streaming
    segmenter's, kept up to date by its caller); the finder records what it asked of it
    (`finder.asked_rpms`) so that a stream can check the answers still hold at the end.
    Retracts given with a batch are weighed against Data Block 0's one Z RET as they come
    (only the first and the values that differ are kept), their notes held in `later` to
    follow the builder's, as they always have."""

    def __init__(self, parsed: Parsed, rpms: dict[int, int | None]) -> None:
        self.parsed = parsed
        self.notes = parsed.notes
        self.tol = parsed.tolerance
        self.rpms = rpms
        diameters = {n: t.diameter for n, t in parsed.tools.items() if t.diameter}
        self.finder = RoutineFinder(diameters, rpms, self.tol, self.notes)
        self.ops: list[Op] = []
        self.batches = 0
        self.z_retract: int | None = None
        # The highest Z RET a rapid across asks for: (value, the rapid's line, its height).
        self.across: tuple[int, int, int] | None = None
        self.later = Notes(labels=self.notes.labels, unit=self.notes.unit)

    def batch(
        self, ops: list[Op], retracts: list[Retract], tools: dict[int, ToolUse] | None
    ) -> None:
        """Recognise one batch of operations (in file order, after those before it).
        `tools`: the tools' use so far, when the file is still being read (their speeds and
        diameters are then taken as they are now)."""
        tol, notes, finder = self.tol, self.notes, self.finder
        if tools is not None:
            self.rpms.clear()
            self.rpms.update({n: use.rpm for n, use in tools.items()})
            finder.diameters = {n: t.diameter for n, t in self.parsed.tools.items() if t.diameter}
        ops = finder.two_pass_with_pecks(ops)
        ops = merge_pecks(ops, tol)
        ops = finder.run(ops)
        ops = find_bolt_circles(ops, tol, notes)
        ops = find_loops(ops, tol, notes)
        if retracts:
            self.retracts(retracts, ops, self.later)
        self.ops += ops
        self.batches += 1

    def retracts(self, retracts: list[Retract], ops: list[Op], notes: Notes) -> None:
        """Data Block 0's Z RET from the heights the tool retracts to after operations
        (the first), and a note for each that differs; and the Z RET the rapids across
        after operations ask for (the highest: `program` raises Z RET to it)."""
        units = self.parsed.units
        # A retract's Z UP is its operation's: a level of pecks merged into one DRILL
        # retracts above the DRILL's Z UP, not above the level it was re-entered at.
        z_ups = _z_ups(ops)
        for line, z_up, height, across_line, next_z_up in retracts:
            z_up = z_ups.get(line, z_up)
            if across_line:
                # The blocks go across at Z RET above the higher of the two operations'
                # Z UPs (or tool zero): never lower than the file's rapid, it must be this.
                wanted = height - max(z_up, next_z_up, 0)
                if self.across is None or wanted > self.across[0]:
                    self.across = (wanted, across_line, height)
                continue
            value = height - max(z_up, 0)
            if value < 0:
                continue
            if self.z_retract is None:
                self.z_retract = value
                notes.became(
                    line,
                    f"the tool retracts to {show(height, units)} above tool zero: Z RET "
                    f"{show(value, units)} (Data Block 0)",
                )
            elif abs(value - self.z_retract) > self.tol:
                notes.assumed(
                    line,
                    f"the tool retracts {show(value, units)} above Z UP here; Data Block 0 "
                    f"holds one Z RET ({show(self.z_retract, units)}): Z moves between "
                    "operations differ",
                )

    def program(self, found: Segmented, retracts: list[Retract]) -> Program:
        """The program: the batches' operations (LOOPs sought again across batches), their
        blocks and Data Block 0. `retracts` are those not yet given with a batch."""
        parsed, notes, finder = self.parsed, self.notes, self.finder
        ops = self.ops
        if self.batches > 1:
            # Rows of a pattern that batches cut apart (each batch's own LOOPs found).
            ops = find_loops(ops, self.tol, notes)
        self.ops = []
        builder = Builder(notes)
        builder.run(ops)
        builder.flush_rounding()
        merge_notes(notes, self.later)
        if retracts:
            self.retracts(retracts, ops, notes)
        units = parsed.units
        z_retract = self.z_retract
        if z_retract is None and parsed.start_z is not None and parsed.start_z >= 0:
            # No operation retracted (one hole, a tap that feeds out above it...): a
            # MillBlocks tool path starts Z RET above tool zero, and the file said where it
            # started.
            z_retract = parsed.start_z
            notes.became(
                None,
                f"the tool starts {show(z_retract, units)} above tool zero: Z RET "
                f"{show(z_retract, units)} (Data Block 0)",
            )
        if self.across is not None and self.across[0] > (z_retract or 0):
            # One Z RET for every operation: the highest a rapid across needs, so that no
            # rapid across is lower than the file's (a file that rises to go home at its end
            # makes every operation retract that far).
            value, line, height = self.across
            was = "none" if z_retract is None else show(z_retract, units)
            z_retract = value
            notes.became(
                line,
                f"the tool goes across at Z{show(height, units)}, {show(value, units)} above "
                f"the operations' Z UP: Z RET {show(value, units)} (Data Block 0; was {was}), "
                "so that no rapid across is lower than the file's: every operation retracts "
                f"{show(value, units)} above its Z UP",
            )
        for number, use in sorted(found.tools.items()):
            for line, rpm in use.other_speeds:
                notes.assumed(
                    line,
                    f"tool {number} also runs at {rpm} rpm; Data Block 0 keeps one speed per "
                    f"tool ({use.rpm} rpm from line {use.line})",
                )
        rpms = {n: use.rpm for n, use in found.tools.items()}
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


def merge_notes(notes: Notes, more: Notes) -> None:
    """`more`'s notes after those of `notes`, as if each had been added there in turn.
    Exact when no message is in both (each note's lines are then replayed as kept);
    raises NotesOverlap otherwise, for a caller that must then read the file again."""
    if not more.entries:
        return
    overlap = next((key for key in more._index if key in notes._index), None)
    if overlap is not None:
        raise NotesOverlap(str(overlap))
    notes.merge(more)


class NotesOverlap(Exception):
    """Two parts of an import wrote the same note, and their order cannot be restored."""


def _z_ups(ops: list[Op]) -> dict[int, int]:
    """The Z UP of the operation each source line belongs to (operations with depths)."""
    found: dict[int, int] = {}
    for op in ops:
        if isinstance(op, LoopOp):
            found |= _z_ups(op.body)
        else:
            z_up = z_up_of(op)
            if z_up is not None:
                found |= dict.fromkeys(op.lines, z_up)
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
