"""The motion a G-code file or a 1704 tape describes, before it becomes data blocks.

Both parsers read their dialect into this one small vocabulary (in the manner of the
Toolpath's canonical moves) and `recognise` turns it into blocks. Conventions:

- Lengths are integer nanometres in part coordinates; feeds nm per minute. `z` is None
  where the file never gave one (a 2-axis tape, or before the first Z move).
- A motion's coordinates are its end point; it starts where the previous one ended.
- `line` is the source line (a tape's block number for a punch image), for the report.
- `units` is the unit the file was in at that line: a block made from it keeps it.
- Steps are not changed once made (a reader that corrects one makes a new one with
  `dataclasses.replace`). They are not `frozen`: a frozen dataclass sets each field through
  `object.__setattr__`, and a long file makes a step per line — with the importer compiled
  (app.cnc.native) a plain one costs a third as much to make.
- The motions (a step per line of a long file) write their `__init__` out (`init=False`):
  mypyc compiles a written one to C, while the one dataclasses makes runs as Python even
  in a compiled module (mypyc/mypyc#671), at twice the cost. Same parameters, same order.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from decimal import Decimal

from app.cnc.recognition.common import XY, Notes
from app.cnc.units import Units


@dataclass(slots=True, init=False)
class Rapid:
    """A move at the machine's rapid rate (G0 / tape G50)."""

    line: int
    x: int
    y: int
    z: int | None
    units: Units

    def __init__(self, line: int, x: int, y: int, z: int | None, units: Units) -> None:
        self.line = line
        self.x = x
        self.y = y
        self.z = z
        self.units = units


@dataclass(slots=True, init=False)
class Feed:
    """A straight move at `feed` (G1; tape G00/G01, which are feed moves on the 1704)."""

    line: int
    x: int
    y: int
    z: int | None
    feed: int
    units: Units
    comp: str = ""  # "left"/"right" while G41/G42 is on: the contour, not the tool centre
    comp_tool: int = 0  # the tool whose diameter G41/G42 offsets by (D; 0: the one in use)

    def __init__(
        self,
        line: int,
        x: int,
        y: int,
        z: int | None,
        feed: int,
        units: Units,
        comp: str = "",
        comp_tool: int = 0,
    ) -> None:
        self.line = line
        self.x = x
        self.y = y
        self.z = z
        self.feed = feed
        self.units = units
        self.comp = comp
        self.comp_tool = comp_tool


@dataclass(slots=True, init=False)
class Arc:
    """A circular move about (cx, cy) in the XY plane to (x, y, z); `clockwise` seen from
    above. An arc that ends where it starts in X/Y is a full circle; one whose `z` differs
    from where it starts is helical (Z in proportion to the angle turned)."""

    line: int
    x: int
    y: int
    z: int | None
    cx: int
    cy: int
    clockwise: bool
    feed: int
    units: Units
    comp: str = ""
    comp_tool: int = 0

    def __init__(
        self,
        line: int,
        x: int,
        y: int,
        z: int | None,
        cx: int,
        cy: int,
        clockwise: bool,
        feed: int,
        units: Units,
        comp: str = "",
        comp_tool: int = 0,
    ) -> None:
        self.line = line
        self.x = x
        self.y = y
        self.z = z
        self.cx = cx
        self.cy = cy
        self.clockwise = clockwise
        self.feed = feed
        self.units = units
        self.comp = comp
        self.comp_tool = comp_tool


@dataclass(slots=True, init=False)
class Cycle:
    """One hole of a canned cycle (G73, G81-G89).

    The tool goes to (x, y) at its height, down to `r` at rapid, into `bottom` (at `feed`,
    in pecks of `peck` when that is not 0), dwells `dwell` seconds, and comes back up to
    `clear` (the R plane, or the height it started from).
    """

    line: int
    code: int
    x: int
    y: int
    r: int
    bottom: int
    clear: int
    feed: int
    peck: int
    dwell: Decimal | None
    units: Units

    def __init__(
        self,
        line: int,
        code: int,
        x: int,
        y: int,
        r: int,
        bottom: int,
        clear: int,
        feed: int,
        peck: int,
        dwell: Decimal | None,
        units: Units,
    ) -> None:
        self.line = line
        self.code = code
        self.x = x
        self.y = y
        self.r = r
        self.bottom = bottom
        self.clear = clear
        self.feed = feed
        self.peck = peck
        self.dwell = dwell
        self.units = units


@dataclass(slots=True)
class Dwell:
    line: int
    seconds: Decimal


@dataclass(slots=True)
class SpindleOn:
    """The spindle starts (or changes) to `rpm` (None: the file gives no speed)."""

    line: int
    rpm: int | None
    clockwise: bool


@dataclass(slots=True)
class SpindleOff:
    line: int


@dataclass(slots=True)
class ToolChange:
    line: int
    tool: int


@dataclass(slots=True)
class Stop:
    """M0 / M1: the program stops for the operator. `comment` is the block's comment."""

    line: int
    optional: bool
    comment: str = ""


@dataclass(slots=True)
class Coolant:
    """M7 (mist), M8 (flood), M9 (off)."""

    line: int
    mode: str


@dataclass(slots=True)
class Message:
    """An operator message (G-code `(MSG,…)`, a comment-only tape block) for what follows."""

    line: int
    text: str


@dataclass(slots=True)
class QuillCycle:
    """1704 quill actuator (seed 000 §4): G99 turns the drill cycle on (a down-up cycle
    at every position), G98 off."""

    line: int
    active: bool


@dataclass(slots=True)
class End:
    line: int


Motion = Rapid | Feed | Arc
Step = (
    Rapid
    | Feed
    | Arc
    | Cycle
    | Dwell
    | SpindleOn
    | SpindleOff
    | ToolChange
    | Stop
    | Coolant
    | Message
    | QuillCycle
    | End
)


@dataclass(frozen=True)
class ToolData:
    """What a file says about a tool besides its number: diameter and TCAL in nm, and the
    name MillBlocks' set-up comments give it ("" for none)."""

    diameter: int | None = None
    tcal: int | None = None
    name: str = ""


@dataclass
class Parsed:
    """A parsed G-code file or tape: its steps and what it says about the set-up.

    `tolerance` (nm) is how far a written point may be from the true one: half a step of
    the finest numbers in the file. Recognised blocks must reproduce the motion within it.
    `initial_tool` is the tool in the spindle at the start (0: unknown). `start_z` is the
    height (nm above tool zero) the file says the tool starts at, where a MillBlocks tool
    path starts: Z RET above tool zero (None: not said).
    """

    format: str
    units: Units
    steps: list[Step]
    notes: Notes
    tolerance: int
    name: str = ""
    part_number: str = ""
    offsets: XY | None = None
    tools: dict[int, ToolData] = field(default_factory=dict)
    initial_tool: int = 0
    start_z: int | None = None


class StepSource:
    """Steps as a reader makes them: `steps` holds those not yet dropped (the first
    `dropped` of the file's steps are gone). This one is a whole list; a reader that is
    still reading (app.cnc.formats.gcode.reader's stream) reads on in `more`."""

    def __init__(self, steps: list[Step]) -> None:
        self.steps = steps
        self.dropped = 0

    def settled(self) -> int:
        """How many of the file's steps (counted from its first) are made and will not
        change: all of them here; a reader holds back a tool change it may still correct."""
        return self.dropped + len(self.steps)

    def more(self) -> bool:
        """Read on (at least a line); False when there is nothing more to read."""
        return False

    def drop(self, count: int) -> None:
        """Forget the first `count` steps still held (the walk has passed them)."""
        del self.steps[:count]
        self.dropped += count


class StreamSource(StepSource):
    """A StepSource that is still reading its file (app.cnc.recognition.motion's
    `program_from_stream` walks it): what the file has said so far, and all it says."""

    def so_far(self, notes: Notes) -> Parsed:
        """The set-up as far as the file has said it, its report going to `notes`."""
        raise NotImplementedError

    def read_all(self) -> Parsed:
        """The file read to its end: its set-up, and its own report (the reader's)."""
        raise NotImplementedError

    def renumbers(self) -> bool:
        """Whether the file names a tool the control does not have (past 24: renumbering
        it needs every number the whole file names)."""
        raise NotImplementedError


# Steps passed by the walk are dropped in batches of at least this many: `del list[:k]`
# moves what is left, so dropping one at a time would be quadratic.
DROP_BATCH = 4096


class StepWindow:
    """The steps as the segmenter walks them, by their index in the file: `has(i)` reads on
    until step i is made (or the file ends), `release(i)` lets go of the steps before i.
    Over a whole list (`StepSource`) it is that list; over a reader that is still reading
    it holds only the steps from the walk's position to the furthest it has looked ahead
    (docs/imports.md, "Streaming")."""

    def __init__(self, source: StepSource) -> None:
        self.source = source
        # The steps before this one are settled: the source said so once, and a settled
        # step does not change, so `has` answers for them without asking it again (the
        # walk asks for nearly every step several times).
        self.known = 0

    def has(self, i: int) -> bool:
        """Whether the file has a step i (reading on as far as that needs)."""
        if i < self.known:
            return True
        source = self.source
        while True:
            settled = source.settled()
            if i < settled:
                self.known = settled
                return True
            if not source.more():
                return i < source.settled()

    def __getitem__(self, i: int) -> Step:
        """Step i; `has(i)` must have said it exists."""
        source = self.source
        return source.steps[i - source.dropped]

    def at(self, i: int) -> Step | None:
        """Step i, or None past the end of the file."""
        if i < self.known or self.has(i):
            source = self.source
            return source.steps[i - source.dropped]
        return None

    def start(self) -> int:
        """The index of the first step still held."""
        return self.source.dropped

    def release(self, i: int) -> None:
        """Let go of the steps before step i (the walk will not look back at them)."""
        source = self.source
        passed = i - source.dropped
        if passed >= DROP_BATCH:
            source.drop(passed)
