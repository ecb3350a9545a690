"""The Toolpath: the canonical moves every output is made from.

In the manner of LinuxCNC's canonical interface (canon.hh), a small vocabulary that every
consumer understands. Conventions, fixed for all moves:

- Lengths are integer nanometres. X and Y are part coordinates (part zero is X0 Y0; the
  Data Block 0 offsets travel separately, in `Toolpath.origin`). Z is measured from the
  calibrated zero of the tool in the spindle (seed 001 §3.4.5.1 "Z DN"), positive up.
- A motion's coordinates are its end point; it starts where the previous motion ended
  (the first at `Toolpath.start`).
- Feeds are integer nanometres per minute. Rapids carry no feed: the control's rapid rate
  (250 ipm on the data-block control) is a property of the machine.
- `block` is the data block a move came from (0 for set-up, before block 1).
- `tag` says what a move is for where consumers care: `peck-reentry`, `retract`,
  `lead-in`, `lead-out`; empty otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from decimal import Decimal

from app.cnc.units import Units

Point = tuple[int, int, int]


@dataclass(frozen=True, slots=True)
class Rapid:
    """STRAIGHT_TRAVERSE: a straight move at the rapid rate to (x, y, z)."""

    block: int
    x: int
    y: int
    z: int
    tag: str = ""


@dataclass(frozen=True, slots=True)
class Feed:
    """STRAIGHT_FEED: a straight move at `feed` nm/min to (x, y, z)."""

    block: int
    x: int
    y: int
    z: int
    feed: int
    tag: str = ""


@dataclass(frozen=True, slots=True)
class ArcFeed:
    """ARC_FEED: a circular move about (cx, cy) in the XY plane to (x, y, z).

    `clockwise` is seen from above (+Z looking down). An arc whose end equals its start in
    X/Y is a full circle. When `z` differs from the start's Z the arc is helical: Z changes
    in proportion to the angle turned; such an arc turns at most once around (app/cnc/path.py).
    """

    block: int
    x: int
    y: int
    z: int
    cx: int
    cy: int
    clockwise: bool
    feed: int
    tag: str = ""


@dataclass(frozen=True, slots=True)
class Dwell:
    """DWELL: the spindle stays where it is for `seconds`."""

    block: int
    seconds: Decimal


@dataclass(frozen=True, slots=True)
class SpindleOn:
    """Start the spindle at `rpm` (always positive); `clockwise` seen from above.

    `rpm` is None for a tool without RPM in Data Block 0 (a 2-axis program from ProtoTRAK
    Plus events): the speed is set by hand, and the direction taken as clockwise."""

    block: int
    clockwise: bool
    rpm: int | None


@dataclass(frozen=True, slots=True)
class SpindleOff:
    """Stop the spindle."""

    block: int


@dataclass(frozen=True, slots=True)
class ToolChange:
    """Put tool `tool` in the spindle; the head does not move.

    Z is measured from each tool's calibrated zero, so the same head height reads
    differently with the new tool: `z` is it, old Z + old TCAL − new TCAL (an uncalibrated
    tool counts as TCAL 0, as a control without its length would).
    """

    block: int
    tool: int
    z: int


@dataclass(frozen=True, slots=True)
class ProgramStop:
    """The control stops and waits for the operator (`reason` says why)."""

    block: int
    reason: str


@dataclass(frozen=True, slots=True)
class CoolantOn:
    """Start the coolant: `mode` is "flood" (M08) or "mist" (M07)."""

    block: int
    mode: str


@dataclass(frozen=True, slots=True)
class CoolantOff:
    """Stop the coolant (M09)."""

    block: int


@dataclass(frozen=True, slots=True)
class Message:
    """Show `text` to the operator as the block starts (a comment; no stop)."""

    block: int
    text: str


@dataclass(frozen=True, slots=True)
class IndexTable:
    """Signal the rotary fixture to index to its next position (POS INDEX)."""

    block: int


@dataclass(frozen=True, slots=True)
class ProgramEnd:
    """End of program: head retracted, spindle stopped."""

    block: int


Motion = Rapid | Feed | ArcFeed
Move = (
    Rapid
    | Feed
    | ArcFeed
    | Dwell
    | SpindleOn
    | SpindleOff
    | ToolChange
    | ProgramStop
    | IndexTable
    | ProgramEnd
    | CoolantOn
    | CoolantOff
    | Message
)
MOTION_TYPES = (Rapid, Feed, ArcFeed)


@dataclass(frozen=True, slots=True)
class Repetition:
    """One pattern of a LOOP/REP: moves[start:end] of the tool path.

    `offset` (nm) is where this pattern starts relative to the first pattern of the same
    LOOP run; `depth` is 1 for an outermost LOOP. Emitters that draw or write repeated
    patterns once (the SVG preview, ProtoTRAK repeats) use these, after checking that the
    moves really are the first pattern's moved by `offset`.
    """

    rep_block: int
    depth: int
    number: int
    start: int
    end: int
    offset: tuple[int, int]


@dataclass(frozen=True, slots=True)
class ToolInfo:
    """What the tool path knows of a tool: diameter and calibration in nm, signed RPM,
    and its name (Data Block 0 NAME, "" for none) for the set-up comments."""

    number: int
    diameter: int | None
    rpm: int | None
    tcal: int | None
    coolant: str = "off"
    name: str = ""


@dataclass(slots=True)
class Toolpath:
    """The interpreter's result.

    `units` is the program's unit, used for printing only. `origin` is the Data Block 0
    offset of part zero from table zero, in nm. `start` is where the tool is before the first
    move: over part zero at the first retract height (Z RET above tool zero).
    """

    units: Units
    origin: tuple[int, int]
    start: Point
    initial_tool: int
    tools: dict[int, ToolInfo]
    moves: list[Move] = field(default_factory=list)
    repetitions: list[Repetition] = field(default_factory=list)
