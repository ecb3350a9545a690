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
"""

from __future__ import annotations

from dataclasses import dataclass, field
from decimal import Decimal

from app.cnc.imports.common import XY, Notes
from app.cnc.units import Units


@dataclass(slots=True)
class Rapid:
    """A move at the machine's rapid rate (G0 / tape G50)."""

    line: int
    x: int
    y: int
    z: int | None
    units: Units


@dataclass(slots=True)
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


@dataclass(slots=True)
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


@dataclass(slots=True)
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
