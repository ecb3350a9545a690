"""The program model: Data Block 0 and the numbered data blocks of a ProtoTRAK-style control.

Seed 001 §3.4.4-3.4.6 is the source. A program is a value: frozen dataclasses, edited by
building new ones (`dataclasses.replace`). Dimensions are kept exactly as typed (`Decimal`, in
the block's own units); conversion to the tool path's nanometres happens in the interpreter.

Data blocks are numbered from 1 by their position in `Program.blocks`. Each block kind is
declared once, here: its fields with the control's prompt, value kind and limits
(`prompt()`), and its `KIND` (document names, editor sub-kinds, qualifiers, planner). The
document, the editor, validation, COPY and mirror all read these declarations through
app.cnc.kinds.REGISTRY, whose docstring has the checklist for adding a kind.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from decimal import Decimal
from typing import Any, ClassVar

from app.cnc import limits
from app.cnc.cutting import Workpiece
from app.cnc.kinds import REGISTRY, Document, Follows, Kind, Mill, Role, SubKind, Value, prompt
from app.cnc.problems import Rule
from app.cnc.tools import Hand, PitchUnit, ToolMaterial, ToolType
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


class Entry(enum.Enum):
    """How a pocketing routine goes down to each depth level instead of plunging (issue 33):
    on a helical or zigzag ramp (app/cnc/ramp.py). None on the block is the plunge."""

    HELIX = "helix"
    ZIGZAG = "zigzag"


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


# -- where the editor offers a sub-kind (SubKind.offered) ----------------------------------


def open_loops(blocks: tuple[Block, ...], before: int) -> int:
    """How many LOOPs are open before position `before` (0-based insertion index)."""
    depth = 0
    for block in blocks[:before]:
        if block.loop and REGISTRY.of(block).loopable:
            depth += 1
        elif isinstance(block, Rep) and depth:
            depth -= 1
    return depth


def _loop_open(blocks: tuple[Block, ...], at: int) -> str:
    return "" if open_loops(blocks, at - 1) else "closes an open LOOP; no LOOP is open here"


def _at_end(blocks: tuple[Block, ...], at: int) -> str:
    if at == len(blocks) + 1:
        return ""
    return "is entered only as a new block at the end, not inserted (ERROR: COPY 4)"


# -- what may follow what (Kind.follows) and what the compile finds (Kind.findings) ---------

# A contour: its first block follows the DRILL that sets the depth, the others each other.
# The MILL menu has always offered them anywhere: validation alone says one is out of place.
AFTER_MILL = Follows(
    ("DRILL", Mill.CONTOUR),
    "a DRILL block (which sets the depth) or another mill block",
    Rule.MILL_ORDER,
    in_menu=False,
)


def _after_drill(gives: str, *, in_menu: bool) -> Follows:
    """A routine follows the DRILL that gives its depths and its reference point."""
    return Follows(
        ("DRILL",),
        f"the DRILL block that gives its {gives}",
        Rule.MILL_ORDER,
        message="{type_name} must follow {what}",
        in_menu=in_menu,
    )


def _arc_end(message: str, centre: str) -> Follows:
    """An arc's XY-END follows its own XY-CENT block (the editor enters the two together)."""
    return Follows((centre,), "its XY-CENT block", Rule.ARC_END_ORDER, message=message)


# A POCKET's contour blocks follow it or each other.
IN_POCKET = Follows(
    ("POCKET", Mill.GEOMETRY), "a POCKET block or another of its contour blocks", Rule.POCKET_ORDER
)
# What the compile of a contour finds: cutter compensation and the moves themselves.
COMPENSATED = frozenset(
    {
        Rule.ZERO_LENGTH,
        Rule.INSIDE_ANGLE,
        Rule.COMP_DIVOT,
        Rule.COMP_GOUGE,
        Rule.COMP_ARC_TOO_SMALL,
        # Calculated geometry, conrads and chamfers (issue 33, app/cnc/solve.py).
        Rule.UNDER_DETERMINED,
        Rule.TANGENCY,
        Rule.CORNER,
    }
)
ROUTINE_FINDINGS = frozenset({Rule.ROUTINE_TOO_SMALL, Rule.POCKET_TOOL, Rule.RAMP_ENTRY})
# A pocketing routine's ramp entry (app/cnc/ramp.py): how it goes down, and how steeply.
ENTRY_HELP = (
    "empty: PLUNGE; HELIX ramps down on a circle half the tool's DIA across; "
    "ZIGZAG back and forth on a straight the tool's DIA long"
)
RAMP_HELP = "degrees below the horizontal, 0.5 to 30; empty: 3"
RAMP_LOW, RAMP_HIGH = Decimal("0.5"), 30
POCKET_ONLY = (("placement", Placement.POCKET),)
ENTERED = (("entry", frozenset(Entry)),)
RAMPED = (*POCKET_ONLY, *ENTERED)

# -- the kinds ------------------------------------------------------------------------------

LENGTH, FEED, ANGLE, COUNT = Value.LENGTH, Value.FEED, Value.ANGLE, Value.COUNT
TOOL, FLAG, CHOICE, TEXT = Value.TOOL, Value.FLAG, Value.CHOICE, Value.TEXT
TWO_AXIS = "empty in a 2-axis program"
DRILL_ONLY = (("op", HoleOp.DRILL),)


@dataclass(frozen=True, kw_only=True)
class Block:
    """What every data block has: ABS/INC, inch/mm, the LOOP and STOP qualifiers, and an
    optional operator message shown when the block runs (where the target can show one).

    Each subclass with a `KIND` is a block kind, registered in `REGISTRY` (app.cnc.kinds).
    """

    kind: ClassVar[str] = "BLOCK"
    KIND: ClassVar[Kind]
    mode: Mode = prompt("ABS/INC", CHOICE, Mode.ABS, prompted=False)
    units: Units = prompt("INCH/MM", CHOICE, Units.INCH, prompted=False)
    loop: bool = prompt("LOOP", FLAG, False, prompted=False)
    stop: bool = prompt("STOP", FLAG, False, prompted=False)
    message: str = prompt("MESSAGE", TEXT, "", prompted=False)

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "KIND" in cls.__dict__:
            REGISTRY.add(cls)

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
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("POS"),),
        editor=(SubKind("POS", "POS", "POS", 1),),
        choices=((1, "POS"),),
        positioned=True,
        loopable=True,
    )
    x: Decimal = prompt("X", LENGTH, role=Role.X)
    y: Decimal = prompt("Y", LENGTH, role=Role.Y)
    index: bool = prompt("INDEX", FLAG, False)
    tool: int = prompt("TOOL #", TOOL, low=1, high=MAX_TOOLS)


@dataclass(frozen=True, kw_only=True)
class Hole(Block):
    """DRILL, BORE or TAP one hole (or, for DRILL, plunge to start a mill sequence).

    `z_up`, `z_dn` and `feed_z` are None in a 2-axis program (the quill is moved by hand).
    """

    kind: ClassVar[str] = "HOLE"
    KIND: ClassVar[Kind] = Kind(
        documents=tuple(Document(op.value, (("op", op),)) for op in HoleOp),
        editor=(
            SubKind("DRILL", "DRILL", "DRILL", 1, (*DRILL_ONLY, ("comp", Comp.NONE))),
            SubKind(
                "DRILL_CUT_RT", "DRILL CUT RT", "DRILL", 3, (*DRILL_ONLY, ("comp", Comp.RIGHT))
            ),
            SubKind("DRILL_CUT_LT", "DRILL CUT LT", "DRILL", 4, (*DRILL_ONLY, ("comp", Comp.LEFT))),
            SubKind("BORE", "BORE", "BORE", 1, (("op", HoleOp.BORE),)),
            SubKind("TAP", "TAP", "TAP", 1, (("op", HoleOp.TAP),)),
        ),
        choices=((2, "DRILL"), (3, "BORE"), (4, "TAP")),
        positioned=True,
        loopable=True,
    )
    op: HoleOp = prompt("OPERATION", CHOICE)
    x: Decimal = prompt("X", LENGTH, role=Role.X)
    y: Decimal = prompt("Y", LENGTH, role=Role.Y)
    z_up: Decimal | None = prompt("Z UP", LENGTH, None, help=TWO_AXIS)
    z_dn: Decimal | None = prompt("Z DN", LENGTH, None, help=TWO_AXIS)
    feed_z: Decimal | None = prompt("FEEDR Z", FEED, None, feed=limits.FEED_Z)
    pecks: int = prompt("# PECK", COUNT, 1, low=1, high=limits.MAX_PECKS, only_when=DRILL_ONLY)
    tool: int = prompt("TOOL #", TOOL, low=1, high=MAX_TOOLS)
    comp: Comp = prompt("CUTTER COMP", CHOICE, Comp.NONE, only_when=DRILL_ONLY)

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
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("BOLT_CIR"),),
        editor=tuple(
            SubKind(
                f"BOLT_CIR_{op.value}",
                f"BOLT CIR {op.value}",
                op.value,
                2,
                (("op", op),),
            )
            for op in HoleOp
        ),
        follows=Follows(
            tuple(op.value for op in HoleOp),
            "a standard {op.value} block, which gives the centre",
            Rule.BOLT_CIR_ORDER,
            same=("op",),
        ),
    )
    op: HoleOp = prompt("OPERATION", CHOICE)
    holes: int = prompt("# HOLES", COUNT, low=1, high=limits.MAX_BOLT_HOLES)
    angle: Decimal = prompt(
        "ANGLE", ANGLE, Decimal(0), role=Role.ANGLE, help="degrees clockwise from 6 o'clock"
    )
    radius: Decimal = prompt("RAD", LENGTH, positive=True)

    @property
    def type_name(self) -> str:
        return f"BOLT CIR {self.op.value}"


MILL_Z_HELP = "empty keeps the depth"
# Calculated geometry (issue 33, app/cnc/solve.py): a MILL block's X or Y the print does not
# give is left empty (null) and the compile calculates it.
CALCULATED_HELP = "empty: calculated from the blocks around it"
LINE_ANGLE_HELP = "the direction it travels, degrees counter-clockwise from +X (3 o'clock)"


@dataclass(frozen=True, kw_only=True)
class MillLine(Block):
    """MILL STD: a straight cut from the current position to X, Y."""

    kind: ClassVar[str] = "MILL_STD"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("MILL_STD"),),
        editor=(SubKind("MILL_STD", "MILL STD", "MILL", 1),),
        choices=((5, "MILL"),),
        positioned=True,
        mill=Mill.CONTOUR,
        follows=AFTER_MILL,
        findings=COMPENSATED,
    )
    x: Decimal | None = prompt("X", LENGTH, role=Role.X, help=CALCULATED_HELP, calculated=True)
    y: Decimal | None = prompt("Y", LENGTH, role=Role.Y, help=CALCULATED_HELP, calculated=True)
    z_dn: Decimal | None = prompt("Z DN", LENGTH, None, help=MILL_Z_HELP)
    feed_xy: Decimal = prompt("FEEDR XY", FEED, feed=limits.FEED_XY)
    tool: int = prompt("TOOL #", TOOL, low=1, high=MAX_TOOLS)
    angle: Decimal | None = prompt("ANGLE", ANGLE, None, prompted=False, help=LINE_ANGLE_HELP)
    tangent: bool = prompt("TANGENT", FLAG, False, prompted=False)
    conrad: Decimal | None = prompt("CONRAD", LENGTH, None, positive=True, prompted=False)
    chamfer: Decimal | None = prompt("CHAMFER", LENGTH, None, positive=True, prompted=False)

    @property
    def type_name(self) -> str:
        return "MILL STD"


@dataclass(frozen=True, kw_only=True)
class MillQcir(Block):
    """MILL QCIR C/CC: a quarter circle from the current position to X, Y."""

    kind: ClassVar[str] = "MILL_QCIR"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("MILL_QCIR"),),
        editor=(
            SubKind("QCIR_C", "QCIR C", "MILL", 2, (("direction", Direction.CW),)),
            SubKind("QCIR_CC", "QCIR CC", "MILL", 3, (("direction", Direction.CCW),)),
        ),
        positioned=True,
        mill=Mill.CONTOUR,
        follows=AFTER_MILL,
        findings=COMPENSATED | {Rule.QCIR_CENTRE_LINES},
    )
    direction: Direction = prompt("DIRECTION", CHOICE, role=Role.TURN)
    x: Decimal | None = prompt("X", LENGTH, role=Role.X, help=CALCULATED_HELP, calculated=True)
    y: Decimal | None = prompt("Y", LENGTH, role=Role.Y, help=CALCULATED_HELP, calculated=True)
    z_dn: Decimal | None = prompt("Z DN", LENGTH, None, help=MILL_Z_HELP)
    feed_xy: Decimal = prompt("FEEDR XY", FEED, feed=limits.FEED_XY)
    tool: int = prompt("TOOL #", TOOL, low=1, high=MAX_TOOLS)
    tangent: bool = prompt("TANGENT", FLAG, False, prompted=False)
    conrad: Decimal | None = prompt("CONRAD", LENGTH, None, positive=True, prompted=False)
    chamfer: Decimal | None = prompt("CHAMFER", LENGTH, None, positive=True, prompted=False)

    @property
    def type_name(self) -> str:
        return "MILL QCIR " + ("C" if self.direction is Direction.CW else "CC")


@dataclass(frozen=True, kw_only=True)
class ArcEnd(Block):
    """MILL ARC XY-END: the arc's end point; in INC mode relative to the arc's start."""

    kind: ClassVar[str] = "MILL_ARC_END"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("MILL_ARC_END"),),
        editor=(SubKind("ARC_END", "MILL ARC XY-END", "MILL"),),
        positioned=True,
        part="XY-END",
        mill=Mill.CONTOUR,
        follows=_arc_end("XY-END without its XY-CENT block just before it", "MILL_ARC"),
        findings=COMPENSATED | {Rule.ARC_RADIUS},
    )
    x: Decimal | None = prompt("X", LENGTH, role=Role.X, help=CALCULATED_HELP, calculated=True)
    y: Decimal | None = prompt("Y", LENGTH, role=Role.Y, help=CALCULATED_HELP, calculated=True)
    conrad: Decimal | None = prompt("CONRAD", LENGTH, None, positive=True, prompted=False)
    chamfer: Decimal | None = prompt("CHAMFER", LENGTH, None, positive=True, prompted=False)

    @property
    def type_name(self) -> str:
        return "MILL ARC XY-END"


@dataclass(frozen=True, kw_only=True)
class MillArc(Block):
    """MILL ARC C/CC, the XY-CENT block: the arc's centre and direction.

    The next block is always its `ArcEnd` (the control generates it). In INC mode the centre
    is relative to the arc's start point.
    """

    kind: ClassVar[str] = "MILL_ARC"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("MILL_ARC"),),
        editor=(
            SubKind("ARC_C", "ARC C", "MILL", 4, (("direction", Direction.CW),), ArcEnd),
            SubKind("ARC_CC", "ARC CC", "MILL", 5, (("direction", Direction.CCW),), ArcEnd),
        ),
        positioned=True,
        stoppable=False,
        xy_is_centre=True,
        part="XY-CENT",
        mill=Mill.CONTOUR,
        follows=AFTER_MILL,
        findings=COMPENSATED | {Rule.ARC_RADIUS},
    )
    direction: Direction = prompt("DIRECTION", CHOICE, role=Role.TURN)
    x: Decimal | None = prompt("X", LENGTH, role=Role.X, help=CALCULATED_HELP, calculated=True)
    y: Decimal | None = prompt("Y", LENGTH, role=Role.Y, help=CALCULATED_HELP, calculated=True)
    z_dn: Decimal | None = prompt("Z DN", LENGTH, None, help=MILL_Z_HELP)
    feed_xy: Decimal = prompt("FEEDR XY", FEED, feed=limits.FEED_XY)
    tool: int = prompt("TOOL #", TOOL, low=1, high=MAX_TOOLS)
    radius: Decimal | None = prompt("RAD", LENGTH, None, positive=True, prompted=False)
    tangent: bool = prompt("TANGENT", FLAG, False, prompted=False)

    @property
    def type_name(self) -> str:
        return "MILL ARC " + ("C" if self.direction is Direction.CW else "CC") + " XY-CENT"


PLACEMENT_HELP = "INSIDE, OUTSIDE, IN/TAN, OUT/TAN or POCKET"


@dataclass(frozen=True, kw_only=True)
class Circle(Block):
    """CIRCLE / CIR 2P: a circle routine about the previous DRILL's X/Y."""

    kind: ClassVar[str] = "CIRCLE"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("CIRCLE"),),
        editor=(
            SubKind("CIRCLE", "CIRCLE", "MILL", 6, (("two_pass", False),)),
            SubKind("CIR_2P", "CIR 2P", "MILL", 7, (("two_pass", True),)),
        ),
        mill=Mill.ROUTINE,
        planner="app.cnc.routines:plan_circle",
        cost="app.cnc.cost:routine_size",
        follows=_after_drill("centre", in_menu=False),
        findings=ROUTINE_FINDINGS,
    )
    placement: Placement = prompt("PLACEMENT", CHOICE)
    two_pass: bool = prompt("2P", FLAG, False)
    radius: Decimal = prompt("RAD", LENGTH, positive=True)
    feed_xy: Decimal = prompt("FEEDR XY", FEED, feed=limits.FEED_XY)
    tool: int = prompt("TOOL #", TOOL, low=1, high=MAX_TOOLS)
    entry: Entry | None = prompt(
        "ENTRY", CHOICE, None, blank="PLUNGE", help=ENTRY_HELP, only_when=POCKET_ONLY
    )
    ramp_angle: Decimal | None = prompt(
        "RAMP ANGLE", ANGLE, None, low=RAMP_LOW, high=RAMP_HIGH, help=RAMP_HELP, only_when=RAMPED
    )

    @property
    def type_name(self) -> str:
        name = "CIR 2P" if self.two_pass else "CIRCLE"
        return f"{name} {self.placement.name.replace('_', '/')}"


@dataclass(frozen=True, kw_only=True)
class Frame(Block):
    """FRAME / FRM 2P: a rectangle whose lower-left corner is the previous DRILL's X/Y."""

    kind: ClassVar[str] = "FRAME"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("FRAME"),),
        editor=(
            SubKind("FRAME", "FRAME", "MILL", 8, (("two_pass", False),)),
            SubKind("FRM_2P", "FRM 2P", "MILL", 9, (("two_pass", True),)),
        ),
        mill=Mill.ROUTINE,
        planner="app.cnc.routines:plan_frame",
        cost="app.cnc.cost:routine_size",
        follows=_after_drill("lower left corner", in_menu=False),
        findings=ROUTINE_FINDINGS | {Rule.FRAME_CORNER, Rule.CORNER_UNREACHABLE},
    )
    placement: Placement = prompt("PLACEMENT", CHOICE)
    two_pass: bool = prompt("2P", FLAG, False)
    xl: Decimal = prompt("XL", LENGTH, positive=True, role=Role.SIZE_X)
    yw: Decimal = prompt("YW", LENGTH, positive=True, role=Role.SIZE_Y)
    corner_radius: Decimal = prompt("CORNER RAD", LENGTH, Decimal(0), low=Decimal(0))
    feed_xy: Decimal = prompt("FEEDR XY", FEED, feed=limits.FEED_XY)
    tool: int = prompt("TOOL #", TOOL, low=1, high=MAX_TOOLS)
    entry: Entry | None = prompt(
        "ENTRY", CHOICE, None, blank="PLUNGE", help=ENTRY_HELP, only_when=POCKET_ONLY
    )
    ramp_angle: Decimal | None = prompt(
        "RAMP ANGLE", ANGLE, None, low=RAMP_LOW, high=RAMP_HIGH, help=RAMP_HELP, only_when=RAMPED
    )

    @property
    def type_name(self) -> str:
        name = "FRM 2P" if self.two_pass else "FRAME"
        return f"{name} {self.placement.name.replace('_', '/')}"


# -- irregular pockets (issue 22) -----------------------------------------------------------


POCKET_GROUP = "POCKET"


@dataclass(frozen=True, kw_only=True)
class Pocket(Block):
    """POCKET: clear the inside of a closed contour around up to `MAX_ISLANDS` islands.

    The DRILL before it gives the boundary's start point (X/Y), the depths, the pecks and
    the tool; the PKT LINE / PKT ARC blocks after it draw the boundary back to that point,
    and each ISLAND block starts an island drawn the same way (app.cnc.pocketing).
    `step_over` (None: the tool's DIA less the 0.050 in overlap of the POCKET routines) is
    the distance between neighbouring passes; `finish` (None: 0.010 in, as 2P) the stock the
    roughing passes leave on the walls and islands for the finishing pass.
    """

    kind: ClassVar[str] = "POCKET"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("POCKET"),),
        editor=(SubKind("POCKET", "POCKET", POCKET_GROUP, 1),),
        choices=((10, POCKET_GROUP),),  # key 0 on the control
        stoppable=False,
        mill=Mill.ROUTINE,
        planner="app.cnc.pocketing.routine:plan_pocket_routine",
        cost="app.cnc.cost:pocket_size",
        geometry=True,
        follows=_after_drill("depths and the boundary's start point", in_menu=True),
        # What its planner finds in the boundary and islands (app.cnc.pocketing.routine).
        findings=frozenset(
            {
                Rule.POCKET_TOOL,
                Rule.POCKET_CONTOUR,
                Rule.POCKET_ISLAND,
                Rule.POCKET_ORDER,
                Rule.POCKET_NARROW,
                Rule.POCKET_STEP,
                Rule.RAMP_ENTRY,
            }
        ),
    )
    step_over: Decimal | None = prompt(
        "STEP", LENGTH, None, positive=True, help="empty: the tool's DIA less 0.050 in"
    )
    finish: Decimal | None = prompt(
        "FIN CUT", LENGTH, None, low=Decimal(0), help="empty: 0.010 in left for the finish pass"
    )
    feed_xy: Decimal = prompt("FEEDR XY", FEED, feed=limits.FEED_XY)
    tool: int = prompt("TOOL #", TOOL, low=1, high=MAX_TOOLS)
    # A POCKET has no placement: it is always a pocket, so ENTRY always applies.
    entry: Entry | None = prompt(
        "ENTRY", CHOICE, None, blank="PLUNGE", help=ENTRY_HELP, beside=True
    )
    ramp_angle: Decimal | None = prompt(
        "RAMP ANGLE", ANGLE, None, low=RAMP_LOW, high=RAMP_HIGH, help=RAMP_HELP, only_when=ENTERED
    )


@dataclass(frozen=True, kw_only=True)
class PocketLine(Block):
    """PKT LINE: a line of a POCKET's boundary or island, from the point before to X, Y."""

    kind: ClassVar[str] = "PKT_LINE"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("PKT_LINE"),),
        editor=(SubKind("PKT_LINE", "PKT LINE", POCKET_GROUP, 2),),
        positioned=True,
        mill=Mill.GEOMETRY,
        follows=IN_POCKET,
    )
    x: Decimal = prompt("X", LENGTH, role=Role.X)
    y: Decimal = prompt("Y", LENGTH, role=Role.Y)

    @property
    def type_name(self) -> str:
        return "PKT LINE"


@dataclass(frozen=True, kw_only=True)
class PocketArcEnd(Block):
    """PKT ARC XY-END: the arc's end point; in INC mode relative to the arc's start."""

    kind: ClassVar[str] = "PKT_ARC_END"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("PKT_ARC_END"),),
        editor=(SubKind("PKT_ARC_END", "PKT ARC XY-END", POCKET_GROUP),),
        positioned=True,
        part="XY-END",
        mill=Mill.GEOMETRY,
        follows=_arc_end("PKT ARC XY-END without its XY-CENT block just before it", "PKT_ARC"),
    )
    x: Decimal = prompt("X", LENGTH, role=Role.X)
    y: Decimal = prompt("Y", LENGTH, role=Role.Y)

    @property
    def type_name(self) -> str:
        return "PKT ARC XY-END"


@dataclass(frozen=True, kw_only=True)
class PocketArc(Block):
    """PKT ARC C/CC, the XY-CENT block of an arc of a POCKET's boundary or island: its
    centre (INC: from the arc's start) and direction; the next block is its XY-END."""

    kind: ClassVar[str] = "PKT_ARC"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("PKT_ARC"),),
        editor=(
            SubKind(
                "PKT_ARC_C",
                "PKT ARC C",
                POCKET_GROUP,
                3,
                (("direction", Direction.CW),),
                PocketArcEnd,
            ),
            SubKind(
                "PKT_ARC_CC",
                "PKT ARC CC",
                POCKET_GROUP,
                4,
                (("direction", Direction.CCW),),
                PocketArcEnd,
            ),
        ),
        positioned=True,
        stoppable=False,
        xy_is_centre=True,
        part="XY-CENT",
        mill=Mill.GEOMETRY,
        follows=IN_POCKET,
    )
    direction: Direction = prompt("DIRECTION", CHOICE, role=Role.TURN)
    x: Decimal = prompt("X", LENGTH, role=Role.X)
    y: Decimal = prompt("Y", LENGTH, role=Role.Y)

    @property
    def type_name(self) -> str:
        return "PKT ARC " + ("C" if self.direction is Direction.CW else "CC") + " XY-CENT"


@dataclass(frozen=True, kw_only=True)
class Island(Block):
    """ISLAND: the start point of an island of the POCKET above; the PKT LINE / PKT ARC
    blocks after it draw the island back to this point."""

    kind: ClassVar[str] = "ISLAND"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("ISLAND"),),
        editor=(SubKind("ISLAND", "ISLAND", POCKET_GROUP, 5),),
        positioned=True,
        mill=Mill.GEOMETRY,
        follows=IN_POCKET,
    )
    x: Decimal = prompt("X", LENGTH, role=Role.X)
    y: Decimal = prompt("Y", LENGTH, role=Role.Y)


# -- operations of a modern conversational control (issue 33) -------------------------------

MILLING_HELP = "empty: Data Block 0's 0 CONV 1 CLIMB"


@dataclass(frozen=True, kw_only=True)
class Helix(Block):
    """HELIX: helical interpolation about X, Y (helical entry, helical boring).

    `diameter` is the finished bore (as BORE and CIRCLE take the part's size): the tool's
    centre goes round at (DIA − the tool's DIA) / 2, the tool's DIA from Data Block 0. The
    tool comes down at rapid to Z UP on the circle (at 3 o'clock), goes down `pitch` per
    turn to Z DN, makes a whole turn at Z DN to finish the bottom and the wall, leaves the
    wall towards the centre (to the centre when the tool covers it; no core is left), and
    rapids up. Round counter-clockwise for climb with a clockwise spindle, as CIRCLE
    INSIDE; `milling` None takes Data Block 0's choice. Lengths in the block's units.
    """

    kind: ClassVar[str] = "HELIX"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("HELIX"),),
        editor=(SubKind("HELIX", "HELIX", "BORE", 3),),
        cost="app.cnc.operations.helix:estimate_moves",
        cut="app.cnc.operations.helix:cut",
        positioned=True,
        loopable=True,
    )
    x: Decimal = prompt("X", LENGTH, role=Role.X)
    y: Decimal = prompt("Y", LENGTH, role=Role.Y)
    diameter: Decimal = prompt("DIA", LENGTH, positive=True, help="the finished diameter")
    z_up: Decimal = prompt("Z UP", LENGTH)
    z_dn: Decimal = prompt("Z DN", LENGTH)
    pitch: Decimal = prompt("PITCH", LENGTH, positive=True, help="depth per turn")
    milling: MillingMode | None = prompt("0 CONV 1 CLIMB", CHOICE, None, blank=MILLING_HELP)
    feed_xy: Decimal = prompt("FEEDR XY", FEED, feed=limits.FEED_XY)
    tool: int = prompt("TOOL #", TOOL, low=1, high=MAX_TOOLS)


class ThreadPlace(enum.Enum):
    """Where a THREAD MILL cuts: a nut's thread inside a bore, or a bolt's outside a boss."""

    INTERNAL = "internal"
    EXTERNAL = "external"


PITCH_HELP = "threads per inch in an inch block, mm per thread in a mm block"


@dataclass(frozen=True, kw_only=True)
class ThreadMill(Block):
    """THREAD MILL: a 60° thread of major diameter `diameter` about X, Y, from Z UP down to
    Z DN, cut with a single-point thread mill whose DIA (Data Block 0) is its cutting
    diameter (app/cnc/operations/thread.py has the motion).

    `pitch` is threads per inch in an inch block and mm per thread in a mm block. The thread
    is cut in `passes` radial passes evenly spaced to the full depth of an ISO/UN basic
    profile (internal 5/8 H, external 17/24 H, H = 0.866 × pitch); each pass enters and
    leaves along half-circle arcs tangent to the thread, a quarter of a pitch along Z each.
    Climb unless the block says conventional (`milling`); the direction of travel and the
    hand of the thread decide whether it goes up or down (a right-hand internal thread cut
    climb is cut bottom-up with G3). Lengths in the block's units.
    """

    kind: ClassVar[str] = "THREAD_MILL"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("THREAD_MILL"),),
        editor=(
            SubKind(
                "THREAD_MILL_INT",
                "THREAD MILL INT",
                "TAP",
                3,
                (("place", ThreadPlace.INTERNAL),),
            ),
            SubKind(
                "THREAD_MILL_EXT",
                "THREAD MILL EXT",
                "TAP",
                4,
                (("place", ThreadPlace.EXTERNAL),),
            ),
        ),
        cost="app.cnc.operations.thread:estimate_moves",
        cut="app.cnc.operations.thread:cut",
        positioned=True,
        loopable=True,
    )
    place: ThreadPlace = prompt("INT/EXT", CHOICE)
    x: Decimal = prompt("X", LENGTH, role=Role.X)
    y: Decimal = prompt("Y", LENGTH, role=Role.Y)
    diameter: Decimal = prompt("MAJOR DIA", LENGTH, positive=True, help="the thread's size")
    pitch: Decimal = prompt("PITCH", LENGTH, positive=True, help=PITCH_HELP)
    hand: Hand = prompt("HAND", CHOICE, Hand.RIGHT)
    z_up: Decimal = prompt("Z UP", LENGTH, help="the top of the thread")
    z_dn: Decimal = prompt("Z DN", LENGTH, help="the bottom of the thread")
    passes: int = prompt("# PASS", COUNT, 1, low=1, high=limits.MAX_THREAD_PASSES)
    milling: MillingMode = prompt("0 CONV 1 CLIMB", CHOICE, MillingMode.CLIMB)
    feed_xy: Decimal = prompt("FEEDR XY", FEED, feed=limits.FEED_XY)
    tool: int = prompt("TOOL #", TOOL, low=1, high=MAX_TOOLS)

    @property
    def type_name(self) -> str:
        return "THREAD MILL " + ("INT" if self.place is ThreadPlace.INTERNAL else "EXT")


class FacePattern(enum.Enum):
    """How FACE's passes go: back and forth, or each the same way (up and back between)."""

    ZIGZAG = "zigzag"
    ONE_WAY = "one_way"


@dataclass(frozen=True, kw_only=True)
class Face(Block):
    """FACE: face the XL × YW rectangle centred on X, Y down to Z DN (app/cnc/operations/face.py).

    Passes along X, `step` percent of the tool's DIA (Data Block 0) apart in Y, the tool
    running off both ends of each pass by `clear` beyond its edge (None: 0.050 in / 1.27 mm)
    and past both long edges; `passes` levels evenly spaced from Z UP (the stock's top) to
    Z DN, coming down at rapid beside the part. Zig-zag goes back and forth; one-way cuts
    each pass in +X and goes up and back between. Lengths in the block's units.
    """

    kind: ClassVar[str] = "FACE"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("FACE"),),
        editor=(
            SubKind("FACE", "FACE", POCKET_GROUP, 6, (("pattern", FacePattern.ZIGZAG),)),
            SubKind(
                "FACE_ONE_WAY",
                "FACE ONE WAY",
                POCKET_GROUP,
                7,
                (("pattern", FacePattern.ONE_WAY),),
            ),
        ),
        cost="app.cnc.operations.face:estimate_moves",
        cut="app.cnc.operations.face:cut",
        positioned=True,
        # Not a LOOP carrier: its menu is POCKET's, and a LOOP is a POS, DRILL, BORE or TAP.
        loopable=False,
    )
    pattern: FacePattern = prompt("PATTERN", CHOICE)
    x: Decimal = prompt("X", LENGTH, role=Role.X, help="the rectangle's centre")
    y: Decimal = prompt("Y", LENGTH, role=Role.Y, help="the rectangle's centre")
    xl: Decimal = prompt("XL", LENGTH, positive=True)
    yw: Decimal = prompt("YW", LENGTH, positive=True)
    z_up: Decimal = prompt("Z UP", LENGTH, help="the stock's top")
    z_dn: Decimal = prompt("Z DN", LENGTH, help="the faced height")
    passes: int = prompt("# PASS", COUNT, 1, low=1, high=limits.MAX_PECKS)
    step: int = prompt("STEP %", COUNT, 70, low=1, high=100, help="percent of the tool's DIA")
    clear: Decimal | None = prompt(
        "CLEAR", LENGTH, None, low=Decimal(0), help="empty: 0.050 in past each edge"
    )
    feed_xy: Decimal = prompt("FEEDR XY", FEED, feed=limits.FEED_XY)
    tool: int = prompt("TOOL #", TOOL, low=1, high=MAX_TOOLS)

    @property
    def type_name(self) -> str:
        return "FACE" if self.pattern is FacePattern.ZIGZAG else "FACE ONE WAY"


class EngraveLayout(enum.Enum):
    """What ENGRAVE's text follows: a line from X, Y, or an arc about X, Y."""

    LINE = "line"
    ARC = "arc"


ON_ARC = (("layout", EngraveLayout.ARC),)


@dataclass(frozen=True, kw_only=True)
class Engrave(Block):
    """ENGRAVE: `text` in a single-stroke font (operations/engrave.py) along a line from X, Y
    at ANGLE, or along an arc of RAD about X, Y from ANGLE (degrees counter-clockwise from
    +X), clockwise (letters standing outward) or counter-clockwise (inward); capitals
    `height` high, cut from Z UP down to Z DN. Each stroke is a plunge at FEEDR Z and cuts
    at FEEDR XY, the tool up to the retract height between strokes (as a DRILL and its MILL
    STD blocks would cut it). Lengths in the block's units.
    """

    kind: ClassVar[str] = "ENGRAVE"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("ENGRAVE"),),
        editor=(
            SubKind(
                "ENGRAVE_LINE", "ENGRAVE LINE", POCKET_GROUP, 8, (("layout", EngraveLayout.LINE),)
            ),
            SubKind("ENGRAVE_ARC", "ENGRAVE ARC", POCKET_GROUP, 9, ON_ARC),
        ),
        cost="app.cnc.operations.engrave:estimate_moves",
        cut="app.cnc.operations.engrave:cut",
        positioned=True,
        loopable=False,  # as FACE: in POCKET's menu
    )
    layout: EngraveLayout = prompt("LINE/ARC", CHOICE)
    text: str = prompt("TEXT", TEXT, help="letters, digits and ASCII signs")
    x: Decimal = prompt("X", LENGTH, role=Role.X, help="the line's start, or the arc's centre")
    y: Decimal = prompt("Y", LENGTH, role=Role.Y)
    angle: Decimal = prompt(
        "ANGLE", ANGLE, Decimal(0), help="degrees counter-clockwise from +X where the text starts"
    )
    radius: Decimal | None = prompt("RAD", LENGTH, None, positive=True, only_when=ON_ARC)
    direction: Direction = prompt("DIRECTION", CHOICE, Direction.CW, only_when=ON_ARC)
    height: Decimal = prompt("HEIGHT", LENGTH, positive=True, help="the capitals' height")
    z_up: Decimal = prompt("Z UP", LENGTH)
    z_dn: Decimal = prompt("Z DN", LENGTH)
    feed_z: Decimal = prompt("FEEDR Z", FEED, feed=limits.FEED_Z)
    feed_xy: Decimal = prompt("FEEDR XY", FEED, feed=limits.FEED_XY)
    tool: int = prompt("TOOL #", TOOL, low=1, high=MAX_TOOLS)

    @property
    def type_name(self) -> str:
        return "ENGRAVE " + self.layout.name


# Seed 001 §3.4.5.3: NX and NY count the repeats after the pattern is done once, so a REP makes
# (NX + 1) × (NY + 1) patterns.
REPEATS = "repeats in {axis} after the first pattern, not the number of patterns (2: three in all)"


@dataclass(frozen=True, kw_only=True)
class Rep(Block):
    """REP: closes the innermost open LOOP; X/Y step between patterns, NX/NY the repeats after
    the first pattern ((NX + 1) × (NY + 1) patterns in all)."""

    kind: ClassVar[str] = "REP"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("REP"),),
        editor=(SubKind("REP", "REP", "REP", 1, offered=_loop_open),),
        choices=((8, "REP"),),
        stoppable=False,
    )
    mode: Mode = prompt("ABS/INC", CHOICE, Mode.INC, prompted=False)
    x: Decimal = prompt("X", LENGTH, Decimal(0), role=Role.STEP_X)
    y: Decimal = prompt("Y", LENGTH, Decimal(0), role=Role.STEP_Y)
    nx: int = prompt("NX", COUNT, 0, low=0, high=limits.MAX_REPEAT, help=REPEATS.format(axis="X"))
    ny: int = prompt("NY", COUNT, 0, low=0, high=limits.MAX_REPEAT, help=REPEATS.format(axis="Y"))


@dataclass(frozen=True, kw_only=True)
class Copy(Block):
    """COPY: an editing operation that exists only while entering (seed 001 §3.4.6).

    Every change field is None when the COPY leaves that parameter as it is. `action` None
    means the operator has not chosen EXEC or CANCEL yet.
    """

    kind: ClassVar[str] = "COPY"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("COPY"),),
        editor=(SubKind("COPY", "COPY", "COPY", 1, offered=_at_end),),
        choices=((9, "COPY"),),
        stoppable=False,
    )
    from_block: int = prompt("FROM", COUNT)
    to_block: int = prompt("TO", COUNT)
    op: HoleOp | None = prompt("OPERATION", CHOICE, None, blank="unchanged", changes="op")
    pecks: int | None = prompt("# PECK", COUNT, None, low=1, high=limits.MAX_PECKS, changes="pecks")
    xof: Decimal | None = prompt("XOF", LENGTH, None, role=Role.STEP_X, changes="x")
    yof: Decimal | None = prompt("YOF", LENGTH, None, role=Role.STEP_Y, changes="y")
    z_up: Decimal | None = prompt("Z UP", LENGTH, None, changes="z_up")
    z_dn: Decimal | None = prompt("Z DN", LENGTH, None, changes="z_dn")
    feed_z: Decimal | None = prompt("FEEDR Z", FEED, None, feed=limits.FEED_Z, changes="feed_z")
    feed_xy: Decimal | None = prompt("FEEDR XY", FEED, None, feed=limits.FEED_XY, changes="feed_xy")
    tool: int | None = prompt("TOOL #", TOOL, None, low=1, high=MAX_TOOLS, changes="tool")
    action: CopyAction | None = prompt("EXEC/CANCEL", CHOICE, None, prompted=False)


BLOCK_CLASSES: tuple[type[Block], ...] = REGISTRY.classes
MILL_CONTOUR_CLASSES: tuple[type[Block], ...] = REGISTRY.mill_classes(Mill.CONTOUR)
MILL_ROUTINE_CLASSES: tuple[type[Block], ...] = REGISTRY.mill_classes(Mill.ROUTINE)
POCKET_GEOMETRY_CLASSES: tuple[type[Block], ...] = REGISTRY.mill_classes(Mill.GEOMETRY)
# The arcs entered as two blocks: (XY-CENT kind, XY-END kind, their names in messages).
ARC_PAIRS: tuple[tuple[type[Block], type[Block], str, str], ...] = (
    (MillArc, ArcEnd, "ARC XY-CENT", "XY-END"),
    (PocketArc, PocketArcEnd, "PKT ARC XY-CENT", "PKT ARC XY-END"),
)
LOOP_CAPABLE_CLASSES: tuple[type[Block], ...] = tuple(
    cls for cls in BLOCK_CLASSES if REGISTRY.kind(cls).loopable
)


def field_label(block: Block | type[Block] | DataBlock0 | Tool | Stock, name: str) -> str:
    """The control's prompt for field `name` of a block (e.g. `feed_z` → `FEEDR Z`).

    Read from a table made once per class. Raises KeyError for an unknown field."""
    return REGISTRY.label(block if isinstance(block, type) else type(block), name)


@dataclass(frozen=True, kw_only=True)
class Tool:
    """One line of Data Block 0's tool table.

    `rpm` may be negative (spindle counter-clockwise, e.g. left-hand taps); None means no RPM
    was entered, which makes the tool unusable (the control's emergency stop). `tcal` is the
    tool's calibrated Z zero; None shows as "****" (uncalibrated). `name` is what the
    machinist calls it ("#7 DRILL", "1/4-20 TAP"; "" for none): for the set-up sheet and
    the G-code set-up comments, never a control setting (app.cnc.tools.tool_name_fault says
    what it may hold, checked by validation).

    `crib` … `hand` are the program's own copy of the crib tool it was picked from (the
    crib's number, the tool's type, flutes, tool material, length out of the holder in the
    program's units, a tap's pitch and hand): what the set-up sheet lists, the speeds and
    feeds are offered from and the TAP rule checks; None where not known.
    """

    number: int = prompt("TOOL #", TOOL)
    diameter: Decimal | None = prompt("DIA", LENGTH, None)
    rpm: int | None = prompt("RPM", COUNT, None)
    tcal: Decimal | None = prompt("TCAL", LENGTH, None)
    coolant: Coolant = prompt("COOLANT", CHOICE, Coolant.OFF)
    name: str = prompt("NAME", TEXT, "")
    # The program's copy of the crib tool it picked (app.cnc.crib; None: not picked or not
    # known). Written to the document only when set, so documents without them read and
    # write as before.
    crib: int | None = prompt("CRIB #", COUNT, None)
    kind: ToolType | None = prompt("TYPE", CHOICE, None)
    flutes: int | None = prompt("FLUTES", COUNT, None)
    tool_material: ToolMaterial | None = prompt("TOOL MATERIAL", CHOICE, None)
    length: Decimal | None = prompt("LENGTH OUT", LENGTH, None)
    pitch: Decimal | None = prompt("PITCH", LENGTH, None)
    pitch_unit: PitchUnit = prompt("PITCH UNIT", CHOICE, PitchUnit.TPI)
    hand: Hand = prompt("HAND", CHOICE, Hand.RIGHT)


@dataclass(frozen=True, kw_only=True)
class DataBlock0:
    """Data Block 0: part zero offsets, current tool, milling mode, Z retract and tools.

    Lengths are in the program's units.
    """

    x_offset: Decimal = prompt("X", LENGTH, Decimal(0))
    y_offset: Decimal = prompt("Y", LENGTH, Decimal(0))
    current_tool: int = prompt("CUR-TOOL", COUNT, 0)
    milling: MillingMode = prompt("0 CONV 1 CLIMB", CHOICE, MillingMode.CLIMB)
    z_retract: Decimal = prompt("Z RET", LENGTH, Decimal("0.1"))
    tools: tuple[Tool, ...] = prompt("TOOLS", TEXT, (), prompted=False)

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
    `zh` its size along X, Y and Z (down from the top). `clear` is the room under it (the
    height of the parallels it sits on): a cut may go that far below its bottom, as a
    through hole does; 0 when it sits on the vise or the table. Lengths in the program's units.
    """

    x: Decimal = prompt("X", LENGTH)
    y: Decimal = prompt("Y", LENGTH)
    z: Decimal = prompt("Z TOP", LENGTH, Decimal(0))
    xl: Decimal = prompt("XL", LENGTH)
    yw: Decimal = prompt("YW", LENGTH)
    zh: Decimal = prompt("ZH", LENGTH)
    clear: Decimal = prompt("CLEAR", LENGTH, Decimal(0))


@dataclass(frozen=True, kw_only=True)
class Program:
    """A whole part program: identification, Data Block 0 and data blocks 1…n.

    `stock` is None when the simulation should size the stock from the program's extent;
    `material` None when the program states no workpiece material (no feeds and speeds are
    offered: app.cnc.cutting).
    """

    name: str
    part_number: str = ""
    units: Units = Units.INCH
    notes: str = ""
    block0: DataBlock0 = field(default_factory=DataBlock0)
    blocks: tuple[Block, ...] = ()
    stock: Stock | None = None
    material: Workpiece | None = None

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
