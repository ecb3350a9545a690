"""From the motion of a G-code file or tape to operations (positions, holes, mill sequences).

The data-block control works in operations: position at the retract height, go down to
Z UP at rapid, feed to Z DN, then either come back up (a hole) or cut in XY at that depth
(a mill sequence started by a DRILL). This module finds those operations in the motion:

- a **hole** is a feed straight down from where the tool arrived at rapid, perhaps in pecks
  (back up to where feeding began and down again to the level just reached), perhaps a
  dwell, then: rapid up (DRILL), feed back up to Z UP (BORE), or spindle reversed, feed up,
  spindle restored (TAP); a canned cycle (G73, G81-G89) is one hole each;
- a **mill sequence** is such a plunge followed by cuts in XY at depth (depth changes are
  feeds in Z between cuts), ending where the tool leaves (rapid, or feed up to Z UP);
- a **position** is a rapid in XY that no operation uses;
- in a **2-axis** program (Z never changes) the quill is moved by hand: a position where the
  program stops (M0) is a hole, feeds in XY are a mill sequence, and the stops for the
  quill around it are part of it.

What cannot be one of these is an error naming the line: a cut in XY in a 3-axis program
where the tool never fed down (it reached that height at rapid), a ramp (X/Y and Z fed
together). What is not carried (coolant, stray dwells, spindle stops) is reported.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from decimal import Decimal
from typing import Final, TypeGuard

from app.cnc import limits
from app.cnc.blocks import (
    Comp,
    Face,
    FacePattern,
    Helix,
    HoleOp,
    MillingMode,
    Placement,
    ThreadMill,
    ThreadPlace,
)
from app.cnc.geometry import arc_sweep
from app.cnc.operations.face import face_clear, face_rows
from app.cnc.operations.helix import helix_ends
from app.cnc.operations.thread import thread_clear, thread_depth, thread_lead, thread_passes
from app.cnc.recognition.common import (
    XY,
    ImportFailure,
    Notes,
    decimal_of,
    feed_decimal,
    quantize_nm,
    resolution_nm,
    show,
    show_feed,
)
from app.cnc.recognition.compensation import Part, Reading
from app.cnc.recognition.ops import (
    Element,
    HelixOp,
    HoleOpR,
    HoleSpec,
    LoopOp,
    MillOp,
    Op,
    PosOp,
    z_up_of,
)
from app.cnc.recognition.steps import (
    Arc,
    Coolant,
    Cycle,
    Dwell,
    End,
    Feed,
    Message,
    Parsed,
    QuillCycle,
    Rapid,
    SpindleOff,
    SpindleOn,
    Step,
    StepSource,
    StepWindow,
    Stop,
    ToolChange,
)
from app.cnc.routines import peck_levels, routine_clockwise
from app.cnc.tools import Hand
from app.cnc.units import Units, to_nm

DWELL: Final = limits.HOLE_DWELL_SECONDS
TAP_OUT: Final = {Units.INCH: to_nm(limits.TAP_FEED_OUT_INCH, Units.INCH), Units.MM: 7_620_000}

# Canned cycles and the hole operation each becomes, with what differs (seed 003's tables,
# seed 000 §4's fixed-cycle sequences). Dwell and feed-out details are reported per hole.
CYCLE_OPS: Final[dict[int, tuple[HoleOp, str]]] = {
    73: (HoleOp.DRILL, "G73 breaks chips with short retracts; MillBlocks pecks back to Z UP"),
    74: (HoleOp.TAP, "G74 taps left-hand; MillBlocks' TAP reverses the tool's own direction"),
    76: (HoleOp.BORE, "G76 fine boring orients the spindle and shifts; MillBlocks feeds out"),
    81: (HoleOp.DRILL, "G81 does not dwell; a MillBlocks DRILL dwells 0.8 s at the bottom"),
    82: (HoleOp.DRILL, ""),
    83: (HoleOp.DRILL, ""),
    84: (HoleOp.TAP, "G84 feeds out to R; a MillBlocks TAP feeds out to Z UP + 0.3 in"),
    85: (HoleOp.BORE, "G85 does not dwell; a MillBlocks BORE dwells 0.8 s at the bottom"),
    86: (HoleOp.BORE, "G86 stops the spindle and rapids out; a MillBlocks BORE feeds out"),
    87: (HoleOp.BORE, "G87 (back boring / manual out) is not a MillBlocks cycle: read as BORE"),
    88: (HoleOp.BORE, "G88 stops for a manual retract; a MillBlocks BORE feeds out"),
    89: (HoleOp.BORE, ""),
}

_OTHER_CYCLE: Final = (HoleOp.DRILL, "")  # (made once: a hole is made for every Cycle)

# What an operation's moves look like, where a file's are not what its block makes: the
# start of the import's refusal (`not_ours`).
_NOT_A_HELIX: Final = (
    "a helix (arcs going down in Z) that is not a MillBlocks HELIX (nor a THREAD MILL: its "
    "passes lead in and out along arcs)"
)
_NOT_A_THREAD_MILL: Final = (
    "helical arcs with a lead-in and lead-out (as a THREAD MILL cuts) that are not a "
    "MillBlocks THREAD MILL"
)
_NOT_A_FACE: Final = (
    "rows fed along X at one depth (as a FACE cuts them) that are not a MillBlocks FACE"
)

# An operation's retract: (its first line, its Z UP, the height the tool rapids up to,
# 0, 0); or a rapid across after it: (the operation's first line, its Z UP, the lowest
# height the tool goes across at, the rapid's line, the Z UP the next operation positions
# for — 0 for a POS —). The retract gives Data Block 0's Z RET; a rapid across may raise it
# (`Recognition.retracts`), so that the blocks never go across lower than the file.
Retract = tuple[int, int, int, int, int]

# `Segmenter.hole_spec`'s key: the HoleSpec's fields, its enums by identity.
SpecKey = tuple[int, int | None, int | None, int | None, int, int, int]


@dataclass
class ToolUse:
    """What the motion says about one tool: its first spindle speed (signed) and where, and
    the coolant it runs with."""

    rpm: int | None = None
    line: int | None = None
    other_speeds: list[tuple[int, int]] = field(default_factory=list)
    coolant: str | None = None


@dataclass
class Segmented:
    """The operations and what the set-up needs from them."""

    ops: list[Op]
    tools: dict[int, ToolUse]
    initial_tool: int
    retracts: list[Retract]
    two_axis: bool
    diameters_used: list[dict[int, int]] = field(default_factory=list)


def segment(
    parsed: Parsed,
    steps: StepWindow | None = None,
    batch: Batch | None = None,
) -> Segmented:
    """The operations of a parsed file. Raises ImportFailure naming the line at fault.

    `steps` (default: `parsed.steps`, whole) is where the steps come from: a window onto a
    reader still reading, when the file streams (docs/imports.md). With `batch`, every
    BATCH_OPS operations (from an operation on, nothing changes those before it) are
    handed to it with the retracts recorded since the last batch and the tools' use so
    far, and the result holds
    only the last batch's."""
    return _Segmenter(parsed, steps, batch).run()


# What takes each batch of operations (with their retracts, and the tools' use so far).
Batch = Callable[[list[Op], list[Retract], dict[int, ToolUse]], None]

# Operations the segmenter hands on at a time when the file streams: the window that
# recognition (pecks, routines, bolt circles, LOOPs) looks across.
BATCH_OPS: Final = 8192


# Steps the walk goes on between telling the window what it has passed (`StepWindow.release`,
# which drops steps in batches of DROP_BATCH).
RELEASE_EVERY: Final = 256

# The kinds of step, as functions with the classes written out: a tuple of classes held in a
# variable is a Python tuple built and walked on every test once compiled (app.cnc.native),
# where the classes written out are a test of the type each.


def is_motion(step: Step) -> TypeGuard[Rapid | Feed | Arc]:
    return isinstance(step, (Rapid, Feed, Arc))


def is_cut(step: Step) -> TypeGuard[Feed | Arc]:
    return isinstance(step, (Feed, Arc))


def is_quiet(step: Step) -> bool:
    """A step a spindle stop allows after it (the stop is then not reported)."""
    return isinstance(step, (SpindleOff, Stop, ToolChange, End, Coolant, Message))


def is_two_axis(steps: StepWindow) -> bool:
    """True when Z never changes and there are no canned cycles: the quill is by hand.
    Reads on only until it knows: the first cycle or second height says no (a 3-axis
    file shows it in its first moves); a 2-axis file is read to its end."""
    heights: set[int] = set()
    i = steps.start()
    while steps.has(i):
        step = steps[i]
        if isinstance(step, Cycle):
            return False
        if is_motion(step) and step.z is not None:
            heights.add(step.z)
            if len(heights) > 1:
                return False
        i += 1
    return True


def _cut_follows(steps: StepWindow, j: int, at: XY) -> bool:
    """True when steps[j:] go on cutting in XY from `at` (after more feeds in Z there): a
    feed in Z before it is a depth change, not the end of the sequence."""
    # Indexing, not `steps[j:]`: a slice copies the rest of the file's steps on every
    # call, which made reading a long file quadratic.
    k = j
    step = steps.at(k)
    while step is not None:
        if (isinstance(step, Feed) and (step.x, step.y) == at) or isinstance(step, Coolant):
            k += 1
            step = steps.at(k)
            continue
        return is_cut(step)
    return False


@dataclass(init=False)
class _Pending:
    """A rapid in XY no operation has used yet."""

    line: int
    at: XY
    units: Units
    tool: int
    rose: bool = False  # the tool went up after it (and has not come down yet)

    def __init__(self, line: int, at: XY, units: Units, tool: int, rose: bool = False) -> None:
        self.line = line
        self.at = at
        self.units = units
        self.tool = tool
        self.rose = rose


# A FACE's row as a file cuts it: (y, x from, x to, the line that set the row, feed).
FaceRow = tuple[int, int, int, int, int]


class _Segmenter:
    def __init__(
        self,
        parsed: Parsed,
        steps: StepWindow | None,
        batch: Batch | None,
    ) -> None:
        self.parsed = parsed
        self.steps = StepWindow(StepSource(parsed.steps)) if steps is None else steps
        self.batch = batch
        self.first_tool: int | None = None  # the tool of the first change walked past
        # The tools' diameters as compensation read them (a file that streams checks at the
        # end that they were the file's).
        self.diameters_used: list[dict[int, int]] = []
        self.notes: Notes = parsed.notes
        self.units = parsed.units
        self.tol = parsed.tolerance
        self.x, self.y = 0, 0
        self.z: int | None = None
        self.tool = parsed.initial_tool
        self.spindle_cw: bool | None = None
        self.tools: dict[int, ToolUse] = {}
        self.ops: list[Op] = []
        self.pending: _Pending | None = None
        self.retracts: list[Retract] = []
        self.awaiting_retract: tuple[int, int] | None = None  # (line, Z UP) of the last op
        self.last_op: tuple[int, int] | None = None  # (line, Z UP): since the last tool change
        # The height the last operation left the tool at (a TAP feeds out above Z UP), once
        # the next step shows it: the blocks leave from there too.
        self.left_at: int | None = None
        self.leaving = False
        # A rapid across since the last operation, waiting for the operation it positions
        # for: (the last op's line, its Z UP, the height across, the rapid's line).
        self.across: tuple[int, int, int, int] | None = None
        self.spindle_off_line: int | None = None
        self.quill_cycle = False
        self.quill_stop: int | None = None  # 2-axis: a stop that lowers the quill
        self.two_axis = is_two_axis(self.steps)
        self.ended = False
        self.message: tuple[int, str] | None = None
        self.specs: dict[SpecKey, HoleSpec] = {}

    # -- the walk --------------------------------------------------------------------------

    def run(self) -> Segmented:
        if self.two_axis and self.any_cut():
            self.notes.assumed(
                None,
                "Z never changes: a 2-axis program, the quill moved by hand (a position where "
                "the program stops is a hole; cuts in XY are mill sequences)",
            )
        i = 0
        steps = self.steps
        release_at = 0
        while True:
            # One look-up a step (`at`), and the window told to let go of the steps passed
            # only now and then: this loop runs for every step of the file.
            step = steps.at(i)
            if step is None:
                break
            if i >= release_at:
                steps.release(i)
                release_at = i + RELEASE_EVERY
            if self.ended:
                self.notes.ignored(step.line, "after the end of the program: not imported")
                i += 1
                continue
            if self.spindle_off_line is not None and not is_quiet(step):
                self.note_spindle_off()
            if isinstance(step, Rapid):
                self.rapid(step)
            elif isinstance(step, Cycle):
                self.cycle(step)
            elif isinstance(step, (Feed, Arc)):
                i = self.feed(i)
                continue
            elif isinstance(step, Dwell):
                self.notes.ignored(
                    step.line,
                    f"dwell {step.seconds} s outside a hole: MillBlocks has no dwell block",
                )
            elif isinstance(step, SpindleOn):
                self.spindle(step)
            elif isinstance(step, SpindleOff):
                self.spindle_cw = None
                self.spindle_off_line = step.line
            elif isinstance(step, ToolChange):
                self.spindle_off_line = None
                self.change_tool(step)
            elif isinstance(step, Stop):
                i = self.stop(i)
                continue
            elif isinstance(step, QuillCycle):
                self.quill_cycle = step.active
            elif isinstance(step, Coolant):
                self.coolant(step)
            elif isinstance(step, Message):
                if self.message is not None:
                    self.notes.ignored(
                        self.message[0],
                        f"message {self.message[1]!r}: another follows before any block; "
                        "not imported",
                    )
                self.message = (step.line, step.text)
            else:
                self.spindle_off_line = None
                self.flush_pending()
                self.ended = True
            i += 1
        self.flush_pending()
        if self.message is not None:
            self.notes.ignored(
                self.message[0], f"message {self.message[1]!r} with no block after it"
            )
        return Segmented(
            self.ops,
            self.tools,
            self.parsed.initial_tool,
            self.retracts,
            self.two_axis,
            self.diameters_used,
        )

    def any_cut(self) -> bool:
        steps = self.steps
        i = steps.start()
        while steps.has(i):
            if is_cut(steps[i]):
                return True
            i += 1
        return False

    def note_spindle_off(self) -> None:
        if self.spindle_off_line is not None:
            self.notes.ignored(
                self.spindle_off_line,
                "spindle stop (M5) with motion after it: MillBlocks stops the spindle only "
                "for a STOP, a tool change and at the end",
            )
            self.spindle_off_line = None

    # -- positioning -------------------------------------------------------------------------

    def rapid(self, step: Rapid) -> None:
        moved = step.x != self.x or step.y != self.y
        self.left(self.z)
        if step.z is not None and self.z is not None and step.z > self.z and not moved:
            self.record_retract(step.line, step.z)
            if self.pending is not None:
                self.pending.rose = True
        elif (
            step.z is not None
            and self.z is not None
            and step.z < self.z
            and not moved
            and self.pending is not None
            and self.pending.rose
        ):
            # Across, up to a retract height and down again: a block's own positioning
            # rises before it goes across, so that move was a POS.
            self.flush_pending()
        if moved:
            self.awaiting_retract = None
            self.flush_pending()
            low = self.z if step.z is None or self.z is None else min(self.z, step.z)
            if (
                self.last_op is not None
                and low is not None
                and (self.left_at is None or low > self.left_at)
            ):
                # Across higher than the operation left the tool: the file rose first.
                self.across = (*self.last_op, low, step.line)
            self.pending = _Pending(step.line, (step.x, step.y), step.units, self.tool)
        self.x, self.y = step.x, step.y
        if step.z is not None:
            self.z = step.z
        if moved and self.quill_cycle:
            # Seed 000 §4: G99 makes a complete down-up quill cycle at every position.
            self.pending = None
            spec = self.hole_spec(HoleOp.DRILL, None, None, None, 1, self.tool, step.units)
            self.add(HoleOpR([step.line], (step.x, step.y), spec))
            self.notes.became(step.line, "G99 quill cycle at this position: a 2-axis DRILL")

    def operation_done(self, line: int, z_up: int) -> None:
        """An operation (first line `line`, Z UP `z_up`) has been cut: the tool's next rise
        is its retract, and its next rapids across are measured from its Z UP."""
        self.awaiting_retract = (line, z_up)
        self.last_op = (line, z_up)
        self.leaving = True

    def left(self, z: int | None) -> None:
        """The first move after an operation starts from `z`: where it left the tool."""
        if self.leaving:
            self.left_at, self.leaving = z, False

    def record_retract(self, line: int, height: int) -> None:
        if self.awaiting_retract is not None:
            op_line, z_up = self.awaiting_retract
            self.retracts.append((op_line, z_up, height, 0, 0))
            self.awaiting_retract = None

    def flush_pending(self) -> None:
        """A rapid to a point where nothing happened: the tool went there, a POS block."""
        if self.pending is None:
            return
        pending, self.pending = self.pending, None
        tool = pending.tool or self.next_tool()
        self.add(PosOp([pending.line], pending.at, tool, pending.units))

    def take_pending(self, at: XY) -> list[int]:
        """The lines of the rapid that brought the tool to `at` (now used by an operation)."""
        if self.pending is None:
            return []
        if self.pending.at != at:
            self.flush_pending()
            return []
        line = self.pending.line
        self.pending = None
        return [line]

    def next_tool(self) -> int:
        """The first tool the program uses, for a position before any tool is named."""
        if self.first_tool is not None:
            return self.first_tool  # (the steps before the window's start are gone)
        steps = self.steps
        i = steps.start()
        while steps.has(i):
            step = steps[i]
            if isinstance(step, ToolChange):
                return step.tool
            i += 1
        return 1

    def hole_spec(
        self,
        op: HoleOp,
        z_up: int | None,
        z_dn: int | None,
        feed_z: int | None,
        pecks: int,
        tool: int,
        units: Units,
    ) -> HoleSpec:
        """The HoleSpec of these parameters, one object for all the holes that share them
        (a file drills thousands of holes alike; a frozen dataclass is dear to make)."""
        # The enums by identity: an Enum's hash is a Python call, and they are singletons.
        key = (id(op), z_up, z_dn, feed_z, pecks, tool, id(units))
        spec = self.specs.get(key)
        if spec is None:
            spec = self.specs[key] = HoleSpec(op, z_up, z_dn, feed_z, pecks, tool, units)
        return spec

    def add(self, op: Op) -> None:
        if self.message is not None and not isinstance(op, LoopOp):
            op.message = self.message[1]
            self.notes.became(
                self.message[0], f"message {op.message!r}: the MESSAGE of the next block"
            )
            self.message = None
        if self.across is not None:
            # The rapid across positioned for this operation: the blocks go across at its
            # retract height or the last one's, whichever is higher.
            op_line, z_up, height, line = self.across
            self.retracts.append((op_line, z_up, height, line, max(z_up_of(op) or 0, 0)))
            self.across = None
        if self.batch is not None and len(self.ops) >= BATCH_OPS:
            # Nothing changes an operation once another follows it (a STOP marks the last).
            self.batch(self.ops, self.retracts, self.tools)
            self.ops, self.retracts = [], []
        self.ops.append(op)
        self.spindle_off_line = None

    # -- cuts --------------------------------------------------------------------------------

    def feed(self, i: int) -> int:
        step = self.steps[i]
        assert is_cut(step)
        same_xy = isinstance(step, Feed) and step.x == self.x and step.y == self.y
        if same_xy:
            if step.z is not None and self.z is None and not self.two_axis:
                raise ImportFailure(
                    self.notes.where(step.line),
                    "a feed in Z before the file gives any height: where it starts (Z UP) "
                    "is not known; give the height first with a rapid (G0 Z…)",
                    step.line,
                )
            if step.z is None or self.z is None or step.z == self.z:
                return i + 1  # a feed that goes nowhere
            if step.z < self.z:
                if self.two_axis:
                    return i + 1
                return self.plunge(i)
            self.notes.ignored(
                step.line,
                f"feed up to Z{show(step.z, step.units)} with no cut: MillBlocks retracts at rapid",
            )
            self.left(self.z)
            self.record_retract(step.line, step.z)
            self.z = step.z
            return i + 1
        if self.two_axis:
            return self.two_axis_sequence(i)
        if isinstance(step, Arc) and step.z is not None and self.z is not None and self.leads_in(i):
            return self.thread(i)
        if isinstance(step, Arc) and step.z is not None and self.z is not None and step.z < self.z:
            return self.helix(i)
        if isinstance(step, Arc) and step.z is not None and self.z is not None and step.z > self.z:
            raise ImportFailure(
                self.notes.where(step.line),
                "an arc going up in Z (a helix cut upwards, as a thread is milled from the "
                "bottom) with no lead-in arc: MillBlocks reads a helix going down as a HELIX, "
                "and a THREAD MILL's passes by their lead-in and lead-out arcs",
                step.line,
            )
        if (
            isinstance(step, Feed)
            and not step.comp
            and step.y == self.y
            and self.z is not None
            and step.z in (None, self.z)
            and self.tool_diameter() is not None
        ):
            # Fed along X at the depth the tool came down to at rapid: a FACE's rows.
            return self.face(i)
        if (
            isinstance(step, Feed)
            and step.z is not None
            and self.z is not None
            and step.z != self.z
        ):
            into = "into the work" if step.z < self.z else "up from where the tool came down"
            raise ImportFailure(
                self.notes.where(step.line),
                f"X/Y and Z fed together {into} (a ramp): MillBlocks plunges straight "
                "down, then cuts in XY at one depth; have the CAM plunge (no ramp or helical "
                "entry)",
                step.line,
            )
        z = "" if self.z is None else f" at Z{show(self.z, self.units)}"
        raise ImportFailure(
            self.notes.where(step.line),
            f"a cut in XY{z}, but the tool has not fed down to it (it got there at rapid): "
            "MillBlocks mills only after a DRILL feeds to depth — is the plunge (a G1 Z "
            "move down) missing?",
            step.line,
        )

    def helix(self, i: int) -> int:
        """Arcs going down about one centre, from where the tool came down at rapid: a
        HELIX (blocks.Helix) when they are one — the same centre, direction and feed, the
        same depth a turn, then a whole turn at the bottom and, where the tool covers the
        centre, a feed to it. The helix's blocks must cut the file's arcs within its
        rounding. Raises ImportFailure naming the line otherwise."""
        steps = self.steps
        first = steps[i]
        assert isinstance(first, Arc) and first.z is not None and self.z is not None
        line = first.line
        where = self.notes.where(line)
        centre = (first.cx, first.cy)
        start = (self.x, self.y, self.z)
        units = first.units

        refuse = functools.partial(self.not_ours, _NOT_A_HELIX, line)

        down: list[Arc] = []
        j = i
        x, y, z = start
        turned = 0.0
        while steps.has(j):
            s = steps[j]
            if not (
                isinstance(s, Arc)
                and s.z is not None
                and s.z < z
                and (s.cx, s.cy) == centre
                and s.clockwise == first.clockwise
                and s.feed == first.feed
            ):
                break
            turned += arc_sweep((x, y), (s.x, s.y), centre, s.clockwise)
            down.append(s)
            x, y, z = s.x, s.y, s.z
            j += 1
        finish = steps.at(j)
        if not (
            isinstance(finish, Arc)
            and (finish.x, finish.y) == (x, y)
            and finish.z in (None, z)
            and (finish.cx, finish.cy) == centre
            and finish.clockwise == first.clockwise
        ):
            raise refuse("a HELIX ends with a whole turn at its bottom, and this one does not")
        j += 1
        radius = math.dist(start[:2], centre)
        pitch = quantize_nm(round((start[2] - z) * 2 * math.pi / turned), units)
        if pitch <= 0:
            raise refuse("it goes down less than the programming resolution a turn")
        made = helix_ends(start, centre, z, pitch, first.clockwise)
        if len(made) != len(down) or any(
            math.dist(end, (s.x, s.y, s.z or 0)) > 2 * self.tol + resolution_nm(units)
            for end, s in zip(made, down, strict=False)
        ):
            raise refuse(
                f"its turns do not go down the same {show(pitch, units)} each, as a HELIX's do"
            )
        tool = self.tool or self.next_tool()
        data = self.parsed.tools.get(tool)
        if data is None or not data.diameter:
            raise ImportFailure(
                where,
                f"a helix cut with tool {tool}, whose diameter the file does not give: a "
                "HELIX is its finished diameter, the tool's DIA added to the path's; give "
                "the tool's diameter in a set-up comment",
                line,
            )
        lines = [*self.take_pending(start[:2]), line]
        leave = steps.at(j)
        if isinstance(leave, Feed) and (leave.x, leave.y) == centre and leave.z in (None, z):
            lines.append(leave.line)
            x, y = centre
            j += 1
        diameter = quantize_nm(round(2 * radius) + data.diameter, units)
        inside_climb = routine_clockwise(
            Placement.INSIDE, MillingMode.CLIMB, None if self.spindle_cw is not False else -1
        )
        block = Helix(
            x=Decimal(0),
            y=Decimal(0),
            diameter=decimal_of(diameter, units),
            z_up=decimal_of(quantize_nm(start[2], units), units),
            z_dn=decimal_of(quantize_nm(z, units), units),
            pitch=decimal_of(pitch, units),
            milling=(
                MillingMode.CLIMB if first.clockwise == inside_climb else MillingMode.CONVENTIONAL
            ),
            feed_xy=feed_decimal(first.feed, units),
            tool=tool,
            units=units,
        )
        self.add(HelixOp(lines, centre, block, start[2]))
        self.operation_done(line, start[2])
        self.x, self.y, self.z = x, y, z
        return j

    def leads_in(self, i: int) -> bool:
        """Whether the arc at step i is a THREAD MILL pass's lead-in: a helical arc from where
        the tool came down at rapid, into helical arcs about another centre."""
        step, turn = self.steps[i], self.steps.at(i + 1)
        return (
            isinstance(step, Arc)
            and isinstance(turn, Arc)
            and turn.z is not None
            and step.z != self.z
            and (turn.cx, turn.cy) != (step.cx, step.cy)
            and self.tool_diameter() is not None
        )

    def thread(self, i: int) -> int:
        """THREAD MILL passes (blocks.ThreadMill): each down at rapid at its approach point,
        a lead-in arc, helical turns about the thread's centre, a lead-out arc, and up to one
        retract height between passes; a THREAD MILL when operations/thread.py's
        `thread_passes` makes exactly these arcs (within the file's rounding). Lengths in nm.
        Raises ImportFailure naming the line whose move no THREAD MILL makes."""
        steps = self.steps
        first = steps[i]
        assert isinstance(first, Arc) and self.z is not None
        units = first.units
        near = 2 * self.tol + resolution_nm(units)

        refuse = functools.partial(self.not_ours, _NOT_A_THREAD_MILL)

        # The file's passes: (approach, Z it came down to, its arcs).
        seen: list[tuple[XY, int, list[Arc]]] = []
        approach, z = (self.x, self.y), self.z
        lifts: set[int] = set()
        j = i
        centre = (0, 0)
        while True:
            arcs: list[Arc] = []
            arc = steps.at(j)
            while isinstance(arc, Arc):
                arcs.append(arc)
                j += 1
                arc = steps.at(j)
            if len(arcs) < 3:
                raise refuse(arcs[-1].line, "a pass is a lead-in, turns and a lead-out")
            if not seen:
                centre = (arcs[1].cx, arcs[1].cy)
            seen.append((approach, z, arcs))
            up = steps.at(j)
            end = arcs[-1]
            if not (
                isinstance(up, Rapid)
                and up.z is not None
                and end.z is not None
                and up.z > end.z
                and (up.x, up.y) == (end.x, end.y)
            ):
                break
            k = j + 1
            across = steps.at(k)
            if (
                isinstance(across, Rapid)
                and across.z in (None, up.z)
                and (across.x, across.y)
                != (
                    up.x,
                    up.y,
                )
            ):
                k += 1
            else:
                across = up
            drop, entry, turn = steps.at(k), steps.at(k + 1), steps.at(k + 2)
            if not (
                isinstance(drop, Rapid)
                and isinstance(across, Rapid)
                and (drop.x, drop.y) == (across.x, across.y)
                and drop.z is not None
                and drop.z < up.z
                and isinstance(entry, Arc)
                and isinstance(turn, Arc)
                and (turn.cx, turn.cy) == centre
            ):
                break
            lifts.add(up.z)
            approach, z = (drop.x, drop.y), drop.z
            j = k + 1
        if len(lifts) > 1:
            raise refuse(first.line, "it rises to more than one height between passes")
        tool = self.tool or self.next_tool()
        diameter = self.tool_diameter()
        assert diameter is not None
        approach0, z_start, arcs0 = seen[0]
        lead_in0, turns0 = arcs0[0], arcs0[1:-1]
        clockwise = turns0[0].clockwise
        rising = (lead_in0.z or 0) > z_start
        z_end = seen[0][2][-1].z
        assert z_end is not None
        # The lead from the whole turns (each ends over where it began): their rise each.
        whole = [t for t in turns0 if (t.x, t.y) == (lead_in0.x, lead_in0.y)]
        if not whole:
            raise refuse(turns0[0].line, "its turns are not whole turns of one lead")
        lead_est = abs((whole[-1].z or 0) - (lead_in0.z or 0)) / len(whole)
        internal = approach0 == centre
        # PITCH as a programmer types it: threads per inch to 0.1, a mm lead to 0.01 mm.
        if units is Units.INCH:
            pitch = Decimal(round(10 * units.nm / lead_est)).scaleb(-1)
        else:
            pitch = Decimal(round(100 * lead_est / units.nm)).scaleb(-2)
        pitch = (
            pitch.quantize(Decimal(1)) if pitch == pitch.to_integral_value() else pitch.normalize()
        )
        if pitch <= 0:
            raise refuse(first.line, "its turns do not rise")
        radius = math.dist((seen[-1][2][0].x, seen[-1][2][0].y), centre)
        probe = ThreadMill(
            place=ThreadPlace.INTERNAL,
            x=Decimal(0),
            y=Decimal(0),
            diameter=Decimal(1),
            pitch=pitch,
            z_up=Decimal(0),
            z_dn=Decimal(-1),
            feed_xy=Decimal(1),
            tool=tool,
            units=units,
        )
        lead = thread_lead(probe)
        if internal:
            major = 2 * radius + diameter
        else:
            major = 2 * (radius + thread_depth(lead, False)) - diameter
        z_up, z_dn = (z_end, z_start) if rising else (z_start, z_end)
        right = rising != clockwise
        placement = Placement.INSIDE if internal else Placement.OUTSIDE
        climb = routine_clockwise(
            placement, MillingMode.CLIMB, None if self.spindle_cw is not False else -1
        )
        block = ThreadMill(
            place=ThreadPlace.INTERNAL if internal else ThreadPlace.EXTERNAL,
            x=Decimal(0),
            y=Decimal(0),
            diameter=decimal_of(quantize_nm(round(major), units), units),
            pitch=pitch,
            hand=Hand.RIGHT if right else Hand.LEFT,
            z_up=decimal_of(quantize_nm(z_up, units), units),
            z_dn=decimal_of(quantize_nm(z_dn, units), units),
            passes=len(seen),
            milling=MillingMode.CLIMB if clockwise == climb else MillingMode.CONVENTIONAL,
            feed_xy=feed_decimal(first.feed, units),
            tool=tool,
            units=units,
        )
        made = thread_passes(
            centre,
            to_nm(block.diameter, units),
            diameter,
            lead,
            to_nm(block.z_up, units),
            to_nm(block.z_dn, units),
            block.passes,
            internal,
            clockwise,
            right,
            thread_clear(),
        )
        for (at, down, arcs), cut in zip(seen, made, strict=True):
            wanted = [cut.lead_in, *cut.turns, cut.lead_out]
            if math.dist(at, cut.approach) > near or abs(down - cut.z_start) > near:
                raise refuse(arcs[0].line, "a pass does not start where a THREAD MILL's does")
            if len(arcs) != len(wanted):
                raise refuse(
                    arcs[0].line, f"a pass of {len(wanted)} arcs, this one has {len(arcs)}"
                )
            for arc, want in zip(arcs, wanted, strict=True):
                if (
                    arc.clockwise != want.clockwise
                    or arc.feed != first.feed
                    or math.dist((arc.x, arc.y, arc.z or 0), want.end) > near
                    or math.dist((arc.cx, arc.cy), want.centre) > near
                ):
                    raise refuse(
                        arc.line,
                        f"this arc is not where a THREAD MILL of {show(major, units)}, "
                        f"{pitch} {'TPI' if units is Units.INCH else 'mm lead'}, puts it (to X"
                        f"{show(want.end[0], units)} Y{show(want.end[1], units)} Z"
                        f"{show(want.end[2], units)})",
                    )
        lines = [*self.take_pending(approach0), first.line]
        self.add(HelixOp(lines, centre, block, to_nm(block.z_up, units)))
        self.operation_done(first.line, to_nm(block.z_up, units))
        last = seen[-1][2][-1]
        self.x, self.y, self.z = last.x, last.y, last.z
        return j

    def not_ours(self, shape: str, line: int, why: str) -> ImportFailure:
        """The refusal of moves from `line` that have the `shape` an operation cuts but are
        not what the MillBlocks block makes (`why`), named at its line."""
        return ImportFailure(self.notes.where(line), f"{shape}: {why}", line)

    def tool_diameter(self) -> int | None:
        """The diameter (nm) the file gives the tool in use, or None."""
        data = self.parsed.tools.get(self.tool or self.next_tool())
        return data.diameter if data is not None and data.diameter else None

    def face(self, i: int) -> int:
        """Rows fed along X at a depth the tool came down to at rapid: a FACE (blocks.Face)
        when the file's moves are exactly what one cuts. Its rows are operations/face.py's
        (`face_rows`) and its levels `peck_levels`, each level's rows alike, joined by a
        feed in Y (zig-zag) or up to the retract height and across (one-way), the levels by
        a retract, across to the first row's start and down. What the file cannot say (it
        cuts the same either way) comes back as the prompts' defaults: CLEAR empty, the
        rectangle's XL and YW from it, STEP % 70 or the nearest that gives the same rows, and Z UP 0
        for a FACE of one level below 0. Lengths in nm. Raises ImportFailure naming the
        line whose move no FACE makes."""
        steps = self.steps
        first = steps[i]
        assert isinstance(first, Feed) and self.z is not None
        units = first.units
        near = 2 * self.tol + resolution_nm(units)

        refuse = functools.partial(self.not_ours, _NOT_A_FACE)

        # The file's rows (y, x from, x to, the line that set the row, feed) level by level.
        levels: list[list[FaceRow]] = [[]]
        depths = [self.z]
        level_lines = [first.line]  # where each level comes down (the first: its first row)
        joins: set[str] = set()
        lifts: set[int] = set()
        feeds: set[int] = set()
        x, y, z = self.x, self.y, self.z
        set_by = first.line
        j = i
        while True:
            s = steps.at(j)
            if isinstance(s, Feed) and not s.comp and s.z in (None, z):
                if s.y == y and s.x != x:
                    levels[-1].append((y, x, s.x, set_by, s.feed))
                    x = s.x
                elif s.x == x and s.y != y and levels[-1]:
                    joins.add("feed")
                    y, set_by = s.y, s.line
                else:
                    break
                feeds.add(s.feed)
                j += 1
                continue
            if isinstance(s, Rapid) and s.z is not None and s.z > z and (s.x, s.y) == (x, y):
                across, down, cut = steps.at(j + 1), steps.at(j + 2), steps.at(j + 3)
                if (
                    isinstance(across, Rapid)
                    and across.z in (None, s.z)
                    and (across.x, across.y) != (x, y)
                    and isinstance(down, Rapid)
                    and (down.x, down.y) == (across.x, across.y)
                    and down.z is not None
                    and down.z < s.z
                    and isinstance(cut, Feed)
                ):
                    lifts.add(s.z)
                    if down.z == z:
                        joins.add("lift")
                    else:
                        levels.append([])
                        depths.append(down.z)
                        level_lines.append(down.line)
                    x, y, z = across.x, across.y, down.z
                    set_by = across.line
                    j += 3
                    continue
            break
        rows = levels[0]
        if len(feeds) > 1:
            raise refuse(first.line, "its rows are fed at more than one rate (one FEEDR XY)")
        if len(lifts) > 1:
            raise refuse(first.line, "it rises to more than one height between its rows")
        if joins == {"feed", "lift"}:
            raise refuse(first.line, "some rows are joined by a feed, others by a rapid")
        zigzag = "lift" not in joins
        for level in levels:
            for k, (_, x0, x1, line, _) in enumerate(level):
                if (x1 > x0) != (not zigzag or k % 2 == 0):
                    raise refuse(
                        line,
                        "a FACE's rows go +X first and then "
                        + ("alternate" if zigzag else "all go +X"),
                    )
        # The candidate FACE from the first level's outer rows; every row of every level
        # must then be one of its rows.
        plain = [(ry, min(x0, x1), max(x0, x1)) for ry, x0, x1, _, _ in rows]
        diameter = self.tool_diameter()
        assert diameter is not None
        radius = diameter // 2
        clear = face_clear(None, units)
        overhang = min(clear, radius)
        low, x_from, x_to = plain[0]
        high = plain[-1][0]
        xl = quantize_nm(x_to - x_from - 2 * radius - 2 * clear, units)
        yw = quantize_nm(high - low + 2 * radius - 2 * overhang, units)
        if xl <= 0 or yw <= 0:
            raise refuse(
                first.line,
                "its rows run off the part less than a FACE's (the tool's radius and "
                f"{show(clear, units)} beyond the edges along X, and over them in Y)",
            )
        centre = (
            quantize_nm(x_from + xl // 2 + radius + clear, units),
            quantize_nm(low + yw // 2 - radius + overhang, units),
        )
        made: list[tuple[int, int, int]] = []
        step = 70
        for step in sorted(range(1, 101), key=lambda s: abs(s - 70)):  # 70 first
            if (high - low) // max(1, diameter * step // 100) > len(plain):
                continue  # more rows than the file's (and a fine step would make millions)
            made = face_rows(centre, xl, yw, radius, diameter * step // 100, clear)
            if len(made) == len(plain):
                break
        for level, down_line in zip(levels, level_lines, strict=True):
            for (ry, x0, x1, line, _), want in zip(level, made, strict=False):
                if any(
                    abs(a - b) > near
                    for a, b in zip((ry, min(x0, x1), max(x0, x1)), want, strict=True)
                ):
                    raise refuse(
                        line,
                        f"this row at Y{show(ry, units)} is not where a FACE's evenly spaced "
                        f"rows put it (Y{show(want[0], units)} from X{show(want[1], units)} to "
                        f"X{show(want[2], units)})",
                    )
            if len(level) != len(plain):
                raise refuse(down_line, "each level of a FACE cuts as many rows as the first")
        if len(made) != len(plain):
            raise refuse(first.line, f"no STEP % spaces {len(plain)} rows so")
        z_dn = quantize_nm(depths[-1], units)
        if len(depths) > 1:
            z_up = quantize_nm(2 * depths[0] - depths[1], units)
        elif z_dn < 0:
            z_up = 0  # one level: the stock's top is not in the file; part zero's
        else:
            raise refuse(
                first.line,
                "one level at or above Z0: the stock's top (Z UP) is not in the file",
            )
        wanted = peck_levels(z_up, z_dn, len(depths))
        for depth, target, line in zip(depths, wanted, level_lines, strict=True):
            if abs(depth - target) > near:
                raise refuse(
                    line,
                    f"its levels are not evenly spaced to Z{show(z_dn, units)}, as a "
                    f"FACE's # PASS are (Z{show(target, units)} here)",
                )
        block = Face(
            pattern=FacePattern.ZIGZAG if zigzag else FacePattern.ONE_WAY,
            x=Decimal(0),
            y=Decimal(0),
            xl=decimal_of(xl, units),
            yw=decimal_of(yw, units),
            z_up=decimal_of(z_up, units),
            z_dn=decimal_of(z_dn, units),
            passes=len(depths),
            step=step,
            clear=None,
            feed_xy=feed_decimal(first.feed, units),
            tool=self.tool or self.next_tool(),
            units=units,
        )
        start = (plain[0][1], plain[0][0])
        lines = [*self.take_pending(start), first.line]
        self.add(HelixOp(lines, centre, block, z_up))
        self.operation_done(first.line, z_up)
        self.x, self.y, self.z = x, y, z
        return j

    def plunge(self, i: int) -> int:
        """A feed straight down at (x, y): a hole, or the DRILL of a mill sequence."""
        steps = self.steps
        first = steps[i]
        assert isinstance(first, Feed) and first.z is not None and self.z is not None
        at = (self.x, self.y)
        lines = self.take_pending(at)
        z_up = self.z
        feed_z = first.feed
        levels: list[int] = []
        j = i
        while True:
            # Feed down (perhaps in several moves) to the next level.
            bottom = self.z
            while True:
                s = steps.at(j)
                if isinstance(s, Feed) and (s.x, s.y) == at and s.z is not None and s.z < bottom:
                    if s.feed != feed_z and not levels:
                        # Down to a feed height at one rate, into the work at another (a
                        # CAM's approach; Fusion for Personal Use writes its rapids down so):
                        # the tool enters the work at the last rate, from where it begins.
                        # A DRILL rapids to Z UP and feeds from there at its one FEEDR Z.
                        self.notes.assumed(
                            lines[-1] if lines else s.line,
                            f"feed {show_feed(feed_z, s.units)} down to Z"
                            f"{show(bottom, s.units)} above the plunge: read as the rapid "
                            f"to Z UP; the plunge from there at {show_feed(s.feed, s.units)} "
                            f"(line {s.line}) is the FEEDR Z",
                        )
                        z_up, feed_z = bottom, s.feed
                    elif s.feed != feed_z:
                        self.notes.ignored(
                            s.line,
                            f"feed {show_feed(s.feed, s.units)} in Z differs from "
                            f"{show_feed(feed_z, s.units)}: MillBlocks has one FEEDR Z",
                        )
                    bottom = s.z
                    lines.append(s.line)
                    j += 1
                    continue
                break
            levels.append(bottom)
            self.z = bottom
            # A peck: rapid back up to where feeding began, down to the level, feed on.
            up = steps.at(j)
            down = steps.at(j + 1)
            deeper = steps.at(j + 2)
            if (
                isinstance(up, Rapid)
                and (up.x, up.y) == at
                and up.z is not None
                and up.z > bottom
                and isinstance(down, Rapid)
                and (down.x, down.y) == at
                and down.z is not None
                and bottom <= down.z < up.z
                and isinstance(deeper, Feed)
                and (deeper.x, deeper.y) == at
                and deeper.z is not None
                and deeper.z < down.z
            ):
                if abs(up.z - z_up) > self.tol or abs(down.z - bottom) > self.tol:
                    self.notes.assumed(
                        up.line,
                        f"peck retract to Z{show(up.z, up.units)} and back to "
                        f"Z{show(down.z, down.units)}: MillBlocks pecks back to Z UP "
                        "and down to the level just reached",
                    )
                lines += [up.line, down.line]
                self.z = down.z
                j += 2
                continue
            break
        spec_units = first.units
        dwell: Decimal | None = None
        nxt = steps.at(j)
        if isinstance(nxt, Dwell):
            dwell = nxt.seconds
            lines.append(nxt.line)
            j += 1
            nxt = steps.at(j)
        bottom = levels[-1]
        # A mill sequence: cuts in XY at this depth (perhaps after a depth change).
        if _cut_follows(steps, j, at):
            if dwell is not None:
                self.notes.ignored(
                    lines[-1], f"dwell {dwell} s before milling: MillBlocks does not dwell there"
                )
            return self.mill_sequence(j, at, lines, z_up, levels, feed_z, spec_units)
        op = HoleOp.DRILL
        how = ""
        # TAP: spindle reversed at the bottom, feed up, spindle restored.
        if (
            isinstance(nxt, SpindleOn)
            and self.spindle_cw is not None
            and nxt.clockwise != self.spindle_cw
        ):
            out = steps.at(j + 1)
            if isinstance(out, Feed) and (out.x, out.y) == at and out.z is not None:
                op = HoleOp.TAP
                lines += [nxt.line, out.line]
                expected = z_up + TAP_OUT[spec_units]
                if abs(out.z - expected) > self.tol:
                    how = (
                        f"the tap feeds out to Z{show(out.z, out.units)}; a MillBlocks TAP "
                        f"feeds out to Z UP + {show(TAP_OUT[spec_units], spec_units)}"
                    )
                self.z = out.z
                j += 2
                restore = steps.at(j)
                if isinstance(restore, SpindleOn) and restore.clockwise == self.spindle_cw:
                    lines.append(restore.line)
                    j += 1
                else:
                    self.spindle_cw = not self.spindle_cw
                if len(levels) > 1:
                    how = "pecks in a tap: MillBlocks taps in one feed"
                if dwell is not None:
                    how = f"dwell {dwell} s at the bottom of a tap: MillBlocks does not dwell"
        # BORE: feed back up to Z UP.
        elif (
            isinstance(nxt, Feed) and (nxt.x, nxt.y) == at and nxt.z is not None and nxt.z > bottom
        ):
            op = HoleOp.BORE
            lines.append(nxt.line)
            self.z = nxt.z
            j += 1
            if abs(nxt.z - z_up) > self.tol:
                how = (
                    f"the bore feeds out to Z{show(nxt.z, nxt.units)}; a MillBlocks BORE feeds "
                    f"out to Z UP (Z{show(z_up, spec_units)})"
                )
            elif dwell is None:
                how = "no dwell at the bottom; a MillBlocks BORE dwells 0.8 s"
            elif dwell != DWELL:
                how = f"dwell {dwell} s; a MillBlocks BORE dwells 0.8 s"
            if len(levels) > 1:
                how = "pecks in a bore: MillBlocks bores in one feed"
        elif dwell is None:
            how = "no dwell at the bottom; a MillBlocks DRILL dwells 0.8 s"
        elif dwell != DWELL:
            how = f"dwell {dwell} s; a MillBlocks DRILL dwells 0.8 s"
        pecks = 1
        if op is HoleOp.DRILL and len(levels) > 1:
            pecks = min(len(levels), limits.MAX_PECKS)
            even = peck_levels(z_up, bottom, pecks)
            if len(levels) > pecks:
                self.notes.assumed(
                    lines[0],
                    f"{len(levels)} peck levels: MillBlocks drills at most {pecks}, so {pecks} "
                    f"even pecks of {show((z_up - bottom) / pecks, spec_units)}",
                )
            elif any(abs(a - b) > self.tol for a, b in zip(even, levels, strict=True)):
                shown = ", ".join(f"Z{show(z, spec_units)}" for z in levels)
                self.notes.assumed(
                    lines[0],
                    f"peck levels {shown}: a MillBlocks DRILL with {pecks} pecks spaces them "
                    "evenly from Z UP to Z DN",
                )
        spec = self.hole_spec(op, z_up, bottom, feed_z, pecks, self.tool, spec_units)
        self.add(HoleOpR(sorted(set(lines)), at, spec))
        if how:
            self.notes.assumed(lines[0], how)
        self.operation_done(lines[0], z_up)
        return j

    def mill_sequence(
        self,
        j: int,
        at: XY,
        lines: list[int],
        z_up: int,
        levels: list[int],
        feed_z: int,
        units: Units,
    ) -> int:
        steps = self.steps
        bottom = levels[-1]
        if len(levels) > 1:
            self.notes.assumed(
                lines[0],
                "pecks before the first cut of a mill sequence: read as one plunge to the "
                "last level",
            )
        depth = bottom
        new_depth: int | None = None
        elements: list[Element] = []
        sides: list[tuple[str, int]] = []  # each cut's compensation (G41/G42) and its D
        x, y = at
        while True:
            s = steps.at(j)
            if s is None:
                break
            if isinstance(s, Feed):
                if (s.x, s.y) == (x, y):
                    if s.z is None or s.z == depth:
                        j += 1
                        continue
                    if not _cut_follows(steps, j + 1, (x, y)):
                        break  # a feed in Z with no cut after it: the sequence ends
                    if s.feed != feed_z:
                        self.notes.ignored(
                            s.line,
                            f"depth change at {show_feed(s.feed, s.units)}: MillBlocks "
                            "feeds to a new Z DN at the DRILL's FEEDR Z",
                        )
                    depth = s.z
                    new_depth = s.z
                    j += 1
                    continue
                if s.z is not None and s.z != depth:
                    raise ImportFailure(
                        self.notes.where(s.line),
                        "X/Y and Z fed together (a ramp): MillBlocks cuts in XY at one "
                        "depth at a time; have the CAM plunge to each depth (no ramp or "
                        "helical entry)",
                        s.line,
                    )
                elements.append(Element(s.line, (s.x, s.y), None, False, new_depth, s.feed))
                sides.append((s.comp, s.comp_tool))
            elif isinstance(s, Arc):
                if s.z is not None and s.z != depth:
                    raise ImportFailure(
                        self.notes.where(s.line),
                        "an arc at another depth (a helix) in a mill sequence: MillBlocks cuts "
                        "a sequence's arcs at one depth, and reads a helix as a HELIX block "
                        "where the tool comes down to its start at rapid",
                        s.line,
                    )
                elements.append(
                    Element(s.line, (s.x, s.y), (s.cx, s.cy), s.clockwise, new_depth, s.feed)
                )
                sides.append((s.comp, s.comp_tool))
            elif isinstance(s, Coolant):
                # Coolant on with a cut (`G1 Y40 M8`): the tool's COOLANT, and the cuts go on.
                self.coolant(s)
                j += 1
                continue
            else:
                break
            new_depth = None
            x, y = s.x, s.y
            j += 1
        self.z = depth
        self.x, self.y = x, y
        if any(side for side, _ in sides):
            diameters = {
                n: t.diameter for n, t in self.parsed.tools.items() if t.diameter is not None
            }
            if diameters not in self.diameters_used:
                self.diameters_used.append(diameters)
            reading = Reading(self.tool, diameters, units, self.notes)
            parts = reading.parts(at, bottom, elements, sides)
        else:
            parts = [Part(at, Comp.NONE, bottom, elements)]
        for k, part in enumerate(parts):
            if k == 0:
                spec = self.hole_spec(HoleOp.DRILL, z_up, bottom, feed_z, 1, self.tool, units)
                part_lines = sorted({*lines, *[e.line for e in part.elements]})
            else:
                spec = self.hole_spec(HoleOp.DRILL, z_up, part.depth, feed_z, 1, self.tool, units)
                part_lines = sorted({e.line for e in part.elements})
            self.add(MillOp(part_lines, part.at, spec, part.comp, part.elements))
        self.operation_done(lines[0], z_up)
        return j

    def two_axis_sequence(self, i: int) -> int:
        """Cuts in XY in a 2-axis program: a DRILL without depths and its mill blocks."""
        steps = self.steps
        at = (self.x, self.y)
        lines = self.take_pending(at)
        first = steps[i]
        assert isinstance(first, Feed | Arc)
        stops = 0
        if self.quill_stop is not None:
            lines.append(self.quill_stop)
            stops += 1
            self.quill_stop = None
        elements: list[Element] = []
        x, y = at
        j = i
        while steps.has(j):
            s = steps[j]
            if is_cut(s) and s.comp:
                raise ImportFailure(
                    self.notes.where(s.line),
                    "cutter compensation (G41/G42) in a program whose Z never changes: "
                    "MillBlocks reads it only where a cut starts with a plunge (a 3-axis mill "
                    "sequence)",
                    s.line,
                )
            if isinstance(s, Feed):
                if (s.x, s.y) != (x, y):
                    elements.append(Element(s.line, (s.x, s.y), None, False, None, s.feed))
            elif isinstance(s, Arc):
                elements.append(
                    Element(s.line, (s.x, s.y), (s.cx, s.cy), s.clockwise, None, s.feed)
                )
            else:
                break
            x, y = s.x, s.y
            j += 1
        nxt = steps.at(j)
        if isinstance(nxt, Stop) and not nxt.optional:
            lines.append(nxt.line)
            stops += 1
            j += 1
        if stops < 2:
            self.notes.assumed(
                first.line,
                "a 2-axis mill sequence: MillBlocks stops for the operator to lower the quill "
                "before it and to raise it after it"
                + ("" if stops else " (the file has no stops there)"),
            )
        self.x, self.y = x, y
        spec = self.hole_spec(HoleOp.DRILL, None, None, None, 1, self.tool, first.units)
        all_lines = sorted({*lines, *[e.line for e in elements]})
        self.add(MillOp(all_lines, at, spec, Comp.NONE, elements, quill_stops=stops))
        return j

    # -- canned cycles -----------------------------------------------------------------------

    def cycle(self, step: Cycle) -> None:
        at = (step.x, step.y)
        pending = self.pending
        if pending is not None and pending.rose and self.z is not None and step.r < self.z:
            self.flush_pending()  # across, up, and the cycle goes down again: a POS
        lines = [*self.take_pending(at), step.line]
        op, how = CYCLE_OPS.get(step.code, _OTHER_CYCLE)
        pecks = 1
        if step.peck > 0 and op is HoleOp.DRILL:
            depth = step.r - step.bottom
            pecks = max(1, math.ceil(depth / step.peck))
            if pecks > limits.MAX_PECKS:
                how = (
                    f"{pecks} pecks of Q{show(step.peck, step.units)}: MillBlocks drills at "
                    f"most {limits.MAX_PECKS}, so {limits.MAX_PECKS} even pecks of "
                    f"{show(depth / limits.MAX_PECKS, step.units)}"
                )
                pecks = limits.MAX_PECKS
            elif depth % step.peck:
                how = (
                    f"pecks of Q{show(step.peck, step.units)} do not divide the depth "
                    f"{show(depth, step.units)}: {pecks} even pecks"
                )
            elif step.code == 83:
                how = (
                    "G83 backs off a little above each level; MillBlocks rapids back to the "
                    "level just cut"
                )
        if step.code in (82, 89) and step.dwell != DWELL:
            dwell = "no dwell" if step.dwell is None else f"dwell {step.dwell} s"
            how = f"G{step.code} with {dwell}; MillBlocks dwells 0.8 s at the bottom"
        spec = self.hole_spec(op, step.r, step.bottom, step.feed, pecks, self.tool, step.units)
        self.add(HoleOpR(lines, at, spec))
        if how:
            self.notes.assumed(step.line, how)
        self.retracts.append((step.line, step.r, step.clear, 0, 0))
        self.awaiting_retract = None
        self.last_op = (step.line, step.r)
        self.left_at, self.leaving = step.clear, False
        self.x, self.y, self.z = step.x, step.y, step.clear

    # -- spindle, tools, stops ---------------------------------------------------------------

    def spindle(self, step: SpindleOn) -> None:
        self.spindle_cw = step.clockwise
        if step.rpm is None or self.tool == 0:
            return
        signed = step.rpm if step.clockwise else -step.rpm
        use = self.tools.setdefault(self.tool, ToolUse())
        if use.rpm is None:
            use.rpm, use.line = signed, step.line
        elif use.rpm != signed:
            use.other_speeds.append((step.line, signed))

    def coolant(self, step: Coolant) -> None:
        if step.mode == "off":
            return
        if self.tool == 0:
            self.notes.ignored(step.line, "coolant on before any tool: not imported")
            return
        use = self.tools.setdefault(self.tool, ToolUse())
        if use.coolant is None:
            use.coolant = step.mode
            self.notes.became(step.line, f"{step.mode} coolant: tool {self.tool}'s COOLANT")
        elif use.coolant != step.mode:
            self.notes.ignored(
                step.line,
                f"{step.mode} coolant for tool {self.tool}, which has {use.coolant} already: "
                "Data Block 0 keeps one coolant per tool",
            )

    def change_tool(self, step: ToolChange) -> None:
        if self.first_tool is None:
            self.first_tool = step.tool
        self.tool = step.tool
        self.tools.setdefault(step.tool, ToolUse())
        # A new tool's Z words are its own (G43): its first rapids are not measured against
        # the last tool's operation (the export rises at a tool change, as at the start).
        self.last_op = None
        self.across = None
        self.spindle_cw = None

    def stop(self, i: int) -> int:
        step = self.steps[i]
        assert isinstance(step, Stop)
        after_spindle_stop = self.spindle_off_line is not None
        self.spindle_off_line = None
        if self.two_axis and self.pending is not None and not after_spindle_stop:
            # The quill: a hole by hand here, or the quill lowered for the cuts that follow.
            j = i + 1
            while isinstance(self.steps.at(j), Dwell):
                j += 1
            nxt = self.steps.at(j)
            if isinstance(nxt, Feed | Arc) and (nxt.x, nxt.y) != self.pending.at:
                self.quill_stop = step.line
                return i + 1
            pending, self.pending = self.pending, None
            spec = self.hole_spec(HoleOp.DRILL, None, None, None, 1, self.tool, pending.units)
            self.add(HoleOpR([pending.line, step.line], pending.at, spec))
            if step.optional:
                self.notes.assumed(step.line, "M1 (optional stop) read as the stop for the quill")
            return i + 1
        self.flush_pending()
        last = self.ops[-1] if self.ops else None
        if last is None or isinstance(last, LoopOp):
            self.notes.ignored(step.line, "a stop before any block: nothing to put STOP on")
            return i + 1
        last.stop = True
        self.notes.became(step.line, f"STOP on the block before ({self.notes.span(last.lines)})")
        if step.optional:
            self.notes.assumed(step.line, "M1 (optional stop) read as STOP")
        if not after_spindle_stop:
            self.notes.assumed(
                step.line, "the spindle keeps turning in the file; at a STOP MillBlocks stops it"
            )
        return i + 1
