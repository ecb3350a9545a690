"""The program model: Data Block 0 and the numbered data blocks of a ProtoTRAK-style control.

Seed 001 §3.4.4-3.4.6 is the source. A program is a value: frozen dataclasses, edited by
building new ones (`dataclasses.replace`). Dimensions are kept exactly as typed (`Decimal`, in
the block's own units); conversion to the tool path's nanometres happens in the interpreter.

Data blocks are numbered from 1 by their position in `Program.blocks`. Fields carry the
control's prompt in their metadata (`label`), so messages, the JSON document and the editor
all name a field the way the control's screen does.
"""

from __future__ import annotations

import dataclasses
import enum
from dataclasses import dataclass, field
from decimal import Decimal
from typing import Any, ClassVar

from app.cnc.units import Units

MAX_TOOLS = 24


class Mode(enum.Enum):
    """Absolute or incremental X/Y (the INC pushbutton)."""

    ABS = "abs"
    INC = "inc"


class HoleOp(enum.Enum):
    """The hole operations a DRILL/BORE/TAP or BOLT CIR block performs."""

    DRILL = "DRILL"
    BORE = "BORE"
    TAP = "TAP"


class Comp(enum.Enum):
    """Cutter compensation chosen on the DRILL that starts a mill sequence (CUT RT / CUT LT)."""

    NONE = "none"
    RIGHT = "right"
    LEFT = "left"


class Direction(enum.Enum):
    """Travel direction of a quarter circle or arc, seen from above."""

    CW = "cw"
    CCW = "ccw"


class Placement(enum.Enum):
    """Where a CIRCLE/FRAME routine puts the cutter relative to the programmed contour."""

    INSIDE = "inside"
    OUTSIDE = "outside"
    IN_TAN = "in_tan"
    OUT_TAN = "out_tan"
    POCKET = "pocket"


class MillingMode(enum.Enum):
    """Data Block 0's "0 CONV 1 CLIMB" choice for circle and frame routines."""

    CONVENTIONAL = "conventional"
    CLIMB = "climb"


class Coolant(enum.Enum):
    """The coolant a tool runs with (Data Block 0 tool table)."""

    OFF = "off"
    FLOOD = "flood"
    MIST = "mist"


class CopyAction(enum.Enum):
    """The COPY block's final choice; `None` on the block means "step through again"."""

    EXEC = "exec"
    CANCEL = "cancel"


def _f(label: str, default: Any = dataclasses.MISSING) -> Any:
    """A dataclass field that remembers the control's prompt for it."""
    return field(default=default, metadata={"label": label})


@dataclass(frozen=True, kw_only=True)
class Block:
    """What every data block has: ABS/INC, inch/mm, the LOOP and STOP qualifiers, and an
    optional operator message shown when the block runs (where the target can show one)."""

    kind: ClassVar[str] = "BLOCK"
    mode: Mode = _f("ABS/INC", Mode.ABS)
    units: Units = _f("INCH/MM", Units.INCH)
    loop: bool = _f("LOOP", False)
    stop: bool = _f("STOP", False)
    message: str = _f("MESSAGE", "")

    @property
    def title(self) -> str:
        """The block's type as the control's screen shows it, e.g. `LOOP DRILL`."""
        qualifiers = ("LOOP " if self.loop else "") + ("STOP " if self.stop else "")
        return qualifiers + self.type_name

    @property
    def type_name(self) -> str:
        """The type and sub-type without qualifiers."""
        return self.kind

    @property
    def tool_number(self) -> int | None:
        """The tool this block uses, or None for blocks without a tool."""
        tool = getattr(self, "tool", None)
        return tool if isinstance(tool, int) else None


@dataclass(frozen=True, kw_only=True)
class Pos(Block):
    """POS: position the table at rapid with the spindle retracted and turning."""

    kind: ClassVar[str] = "POS"
    x: Decimal = _f("X")
    y: Decimal = _f("Y")
    index: bool = _f("INDEX", False)
    tool: int = _f("TOOL #")


@dataclass(frozen=True, kw_only=True)
class Hole(Block):
    """DRILL, BORE or TAP one hole (or, for DRILL, plunge to start a mill sequence).

    `z_up`, `z_dn` and `feed_z` are None in a 2-axis program (the quill is moved by hand).
    """

    kind: ClassVar[str] = "HOLE"
    op: HoleOp = _f("OPERATION")
    x: Decimal = _f("X")
    y: Decimal = _f("Y")
    z_up: Decimal | None = _f("Z UP", None)
    z_dn: Decimal | None = _f("Z DN", None)
    feed_z: Decimal | None = _f("FEEDR Z", None)
    pecks: int = _f("# PECK", 1)
    tool: int = _f("TOOL #")
    comp: Comp = _f("CUTTER COMP", Comp.NONE)

    @property
    def type_name(self) -> str:
        if self.comp is Comp.RIGHT:
            return f"{self.op.value} CUT RT"
        if self.comp is Comp.LEFT:
            return f"{self.op.value} CUT LT"
        return self.op.value

    @property
    def has_depth(self) -> bool:
        """False for a 2-axis hole block (no Z UP / Z DN)."""
        return self.z_up is not None and self.z_dn is not None


@dataclass(frozen=True, kw_only=True)
class BoltCircle(Block):
    """BOLT CIR: holes equally spaced on a circle about the previous block's X/Y.

    The previous block (a standard block of the same operation) gives the centre and every
    hole parameter and is not itself drilled. `angle` is in degrees, measured clockwise
    from the lower vertical centre line (seed 001 Fig. 3-3).
    """

    kind: ClassVar[str] = "BOLT_CIR"
    op: HoleOp = _f("OPERATION")
    holes: int = _f("# HOLES")
    angle: Decimal = _f("ANGLE", Decimal(0))
    radius: Decimal = _f("RAD")

    @property
    def type_name(self) -> str:
        return f"BOLT CIR {self.op.value}"


@dataclass(frozen=True, kw_only=True)
class MillLine(Block):
    """MILL STD: a straight cut from the current position to X, Y."""

    kind: ClassVar[str] = "MILL_STD"
    x: Decimal = _f("X")
    y: Decimal = _f("Y")
    z_dn: Decimal | None = _f("Z DN", None)
    feed_xy: Decimal = _f("FEEDR XY")
    tool: int = _f("TOOL #")

    @property
    def type_name(self) -> str:
        return "MILL STD"


@dataclass(frozen=True, kw_only=True)
class MillQcir(Block):
    """MILL QCIR C/CC: a quarter circle from the current position to X, Y."""

    kind: ClassVar[str] = "MILL_QCIR"
    direction: Direction = _f("DIRECTION")
    x: Decimal = _f("X")
    y: Decimal = _f("Y")
    z_dn: Decimal | None = _f("Z DN", None)
    feed_xy: Decimal = _f("FEEDR XY")
    tool: int = _f("TOOL #")

    @property
    def type_name(self) -> str:
        return "MILL QCIR " + ("C" if self.direction is Direction.CW else "CC")


@dataclass(frozen=True, kw_only=True)
class MillArc(Block):
    """MILL ARC C/CC, the XY-CENT block: the arc's centre and direction.

    The next block is always its `ArcEnd` (the control generates it). In INC mode the centre
    is relative to the arc's start point.
    """

    kind: ClassVar[str] = "MILL_ARC"
    direction: Direction = _f("DIRECTION")
    x: Decimal = _f("X")
    y: Decimal = _f("Y")
    z_dn: Decimal | None = _f("Z DN", None)
    feed_xy: Decimal = _f("FEEDR XY")
    tool: int = _f("TOOL #")

    @property
    def type_name(self) -> str:
        return "MILL ARC " + ("C" if self.direction is Direction.CW else "CC") + " XY-CENT"


@dataclass(frozen=True, kw_only=True)
class ArcEnd(Block):
    """MILL ARC XY-END: the arc's end point; in INC mode relative to the arc's start."""

    kind: ClassVar[str] = "MILL_ARC_END"
    x: Decimal = _f("X")
    y: Decimal = _f("Y")

    @property
    def type_name(self) -> str:
        return "MILL ARC XY-END"


@dataclass(frozen=True, kw_only=True)
class Circle(Block):
    """CIRCLE / CIR 2P: a circle routine about the previous DRILL's X/Y."""

    kind: ClassVar[str] = "CIRCLE"
    placement: Placement = _f("PLACEMENT")
    two_pass: bool = _f("2P", False)
    radius: Decimal = _f("RAD")
    feed_xy: Decimal = _f("FEEDR XY")
    tool: int = _f("TOOL #")

    @property
    def type_name(self) -> str:
        name = "CIR 2P" if self.two_pass else "CIRCLE"
        return f"{name} {self.placement.name.replace('_', '/')}"


@dataclass(frozen=True, kw_only=True)
class Frame(Block):
    """FRAME / FRM 2P: a rectangle whose lower-left corner is the previous DRILL's X/Y."""

    kind: ClassVar[str] = "FRAME"
    placement: Placement = _f("PLACEMENT")
    two_pass: bool = _f("2P", False)
    xl: Decimal = _f("XL")
    yw: Decimal = _f("YW")
    corner_radius: Decimal = _f("CORNER RAD", Decimal(0))
    feed_xy: Decimal = _f("FEEDR XY")
    tool: int = _f("TOOL #")

    @property
    def type_name(self) -> str:
        name = "FRM 2P" if self.two_pass else "FRAME"
        return f"{name} {self.placement.name.replace('_', '/')}"


@dataclass(frozen=True, kw_only=True)
class Rep(Block):
    """REP: closes the innermost open LOOP; X/Y step between patterns, NX/NY extra copies."""

    kind: ClassVar[str] = "REP"
    mode: Mode = _f("ABS/INC", Mode.INC)
    x: Decimal = _f("X", Decimal(0))
    y: Decimal = _f("Y", Decimal(0))
    nx: int = _f("NX", 0)
    ny: int = _f("NY", 0)


@dataclass(frozen=True, kw_only=True)
class Copy(Block):
    """COPY: an editing operation that exists only while entering (seed 001 §3.4.6).

    Every change field is None when the COPY leaves that parameter as it is. `action` None
    means the operator has not chosen EXEC or CANCEL yet.
    """

    kind: ClassVar[str] = "COPY"
    from_block: int = _f("FROM")
    to_block: int = _f("TO")
    op: HoleOp | None = _f("OPERATION", None)
    pecks: int | None = _f("# PECK", None)
    xof: Decimal | None = _f("XOF", None)
    yof: Decimal | None = _f("YOF", None)
    z_up: Decimal | None = _f("Z UP", None)
    z_dn: Decimal | None = _f("Z DN", None)
    feed_z: Decimal | None = _f("FEEDR Z", None)
    feed_xy: Decimal | None = _f("FEEDR XY", None)
    tool: int | None = _f("TOOL #", None)
    action: CopyAction | None = _f("EXEC/CANCEL", None)


BLOCK_CLASSES: tuple[type[Block], ...] = (
    Pos,
    Hole,
    BoltCircle,
    MillLine,
    MillQcir,
    MillArc,
    ArcEnd,
    Circle,
    Frame,
    Rep,
    Copy,
)
MILL_CONTOUR_CLASSES: tuple[type[Block], ...] = (MillLine, MillQcir, MillArc, ArcEnd)
MILL_ROUTINE_CLASSES: tuple[type[Block], ...] = (Circle, Frame)
LOOP_CAPABLE_CLASSES: tuple[type[Block], ...] = (Pos, Hole)


def field_label(block: Block | type[Block] | DataBlock0 | Tool | Stock, name: str) -> str:
    """The control's prompt for field `name` of a block (e.g. `feed_z` → `FEEDR Z`)."""
    for f in dataclasses.fields(block):
        if f.name == name:
            return str(f.metadata.get("label", name.upper()))
    raise KeyError(name)


@dataclass(frozen=True, kw_only=True)
class Tool:
    """One line of Data Block 0's tool table.

    `rpm` may be negative (spindle counter-clockwise, e.g. left-hand taps); None means no RPM
    was entered, which makes the tool unusable (the control's emergency stop). `tcal` is the
    tool's calibrated Z zero; None shows as "****" (uncalibrated).
    """

    number: int = _f("TOOL #")
    diameter: Decimal | None = _f("DIA", None)
    rpm: int | None = _f("RPM", None)
    tcal: Decimal | None = _f("TCAL", None)
    coolant: Coolant = _f("COOLANT", Coolant.OFF)


@dataclass(frozen=True, kw_only=True)
class DataBlock0:
    """Data Block 0: part zero offsets, current tool, milling mode, Z retract and tools.

    Lengths are in the program's units.
    """

    x_offset: Decimal = _f("X", Decimal(0))
    y_offset: Decimal = _f("Y", Decimal(0))
    current_tool: int = _f("CUR-TOOL", 0)
    milling: MillingMode = _f("0 CONV 1 CLIMB", MillingMode.CLIMB)
    z_retract: Decimal = _f("Z RET", Decimal("0.1"))
    tools: tuple[Tool, ...] = _f("TOOLS", ())

    def tool(self, number: int) -> Tool | None:
        """The tool table entry for `number`, or None when the tool is not defined."""
        for tool in self.tools:
            if tool.number == number:
                return tool
        return None


@dataclass(frozen=True, kw_only=True)
class Stock:
    """The raw stock the part is cut from, for the simulation (not a control setting).

    `x`, `y` are its lower-left corner and `z` its top face, in part coordinates; `xl`, `yw`,
    `zh` its size along X, Y and Z (down from the top). Lengths in the program's units.
    """

    x: Decimal = _f("X")
    y: Decimal = _f("Y")
    z: Decimal = _f("Z TOP", Decimal(0))
    xl: Decimal = _f("XL")
    yw: Decimal = _f("YW")
    zh: Decimal = _f("ZH")


@dataclass(frozen=True, kw_only=True)
class Program:
    """A whole part program: identification, Data Block 0 and data blocks 1…n.

    `stock` is None when the simulation should size the stock from the program's extent.
    """

    name: str
    part_number: str = ""
    units: Units = Units.INCH
    notes: str = ""
    block0: DataBlock0 = field(default_factory=DataBlock0)
    blocks: tuple[Block, ...] = ()
    stock: Stock | None = None

    def block(self, number: int) -> Block:
        """Data block `number` (1-based). Raises IndexError when it does not exist."""
        if not 1 <= number <= len(self.blocks):
            raise IndexError(f"block {number} does not exist")
        return self.blocks[number - 1]

    @property
    def is_two_axis(self) -> bool:
        """True when no hole block has depths: the quill is moved by hand (ProtoTRAK Plus)."""
        holes = [b for b in self.blocks if isinstance(b, Hole)]
        return bool(holes) and not any(h.has_depth for h in holes)
