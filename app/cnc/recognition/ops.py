"""Operations: what the recogniser finds in the motion, one step short of data blocks.

An operation is a positioning, a hole, a mill sequence (a plunge and the cuts at depth), a
bolt circle, a CIRCLE/FRAME routine or a LOOP/REP pattern of operations. Coordinates are
absolute nanometres as the file gave them; `emit.py` rounds them once into blocks.
Each operation keeps the source lines it was made from, for the report.

The operations a long file makes one of per line or per cut (a hole, a mill sequence and
its cuts) write their `__init__` out (`init=False`), as app.cnc.recognition.steps' motions
do and for the same reason: mypyc compiles a written one, not the one dataclasses makes.
An `Element` is therefore not frozen either; nothing changes one once it is made.
"""

from __future__ import annotations

from collections.abc import Hashable
from dataclasses import dataclass, field
from decimal import Decimal

from app.cnc.blocks import Circle, Comp, Face, Frame, Helix, HoleOp, ThreadMill
from app.cnc.recognition.common import XY
from app.cnc.units import Units


@dataclass(frozen=True)
class HoleSpec:
    """Hole parameters: operation, depths (None in a 2-axis program), feed, pecks, tool."""

    op: HoleOp
    z_up: int | None
    z_dn: int | None
    feed_z: int | None
    pecks: int
    tool: int
    units: Units

    @property
    def has_depth(self) -> bool:
        return self.z_up is not None and self.z_dn is not None


@dataclass
class PosOp:
    """The tool goes to (x, y) and nothing happens there: a POS block."""

    lines: list[int]
    at: XY
    tool: int
    units: Units
    stop: bool = False
    message: str = ""


@dataclass(init=False)
class HoleOpR:
    """One DRILL, BORE or TAP hole."""

    lines: list[int]
    at: XY
    spec: HoleSpec
    stop: bool = False
    message: str = ""

    def __init__(
        self, lines: list[int], at: XY, spec: HoleSpec, stop: bool = False, message: str = ""
    ) -> None:
        self.lines = lines
        self.at = at
        self.spec = spec
        self.stop = stop
        self.message = message


@dataclass(init=False)
class Element:
    """A cut of a mill sequence: a line to `end`, or an arc about `centre`.

    `z_dn` is a new depth the head feeds to before this cut (None: keep the depth);
    `conrad` the corner radius into the next cut (nm; None: a sharp corner), as the events'
    CR gives it.
    """

    line: int
    end: XY
    centre: XY | None
    clockwise: bool
    z_dn: int | None
    feed: int
    conrad: int | None = None

    def __init__(
        self,
        line: int,
        end: XY,
        centre: XY | None,
        clockwise: bool,
        z_dn: int | None,
        feed: int,
        conrad: int | None = None,
    ) -> None:
        self.line = line
        self.end = end
        self.centre = centre
        self.clockwise = clockwise
        self.z_dn = z_dn
        self.feed = feed
        self.conrad = conrad


@dataclass(init=False)
class MillOp:
    """A DRILL at `at` that plunges, then the cuts at depth (a mill sequence)."""

    lines: list[int]
    at: XY
    spec: HoleSpec
    comp: Comp
    elements: list[Element]
    stop: bool = False
    quill_stops: int = 0  # 2-axis: how many of the two quill stops the file has
    message: str = ""

    def __init__(
        self,
        lines: list[int],
        at: XY,
        spec: HoleSpec,
        comp: Comp,
        elements: list[Element],
        stop: bool = False,
        quill_stops: int = 0,
        message: str = "",
    ) -> None:
        self.lines = lines
        self.at = at
        self.spec = spec
        self.comp = comp
        self.elements = elements
        self.stop = stop
        self.quill_stops = quill_stops
        self.message = message


@dataclass
class BoltOp:
    """A standard hole at `centre` (not drilled) and a BOLT CIR: `holes` on `radius`,
    the first at `angle` (MillBlocks' angle, clockwise from below), taken clockwise."""

    lines: list[int]
    centre: XY
    spec: HoleSpec
    holes: int
    angle: Decimal
    radius: int
    stop: bool = False
    message: str = ""


@dataclass
class RoutineOp:
    """A DRILL at `at` (the circle's centre or the frame's lower-left corner) and the
    CIRCLE/FRAME block that cuts the same motion."""

    lines: list[int]
    at: XY
    spec: HoleSpec
    block: Circle | Frame
    stop: bool = False
    message: str = ""


@dataclass
class LoopOp:
    """LOOP … REP: `body` (pattern 0) repeated at (i·step_x, j·step_y), i ≤ nx, j ≤ ny."""

    lines: list[int]
    body: list[Op]
    step: XY
    nx: int
    ny: int
    head_added: bool = False  # a LOOP POS was put first to carry the LOOP qualifier


@dataclass
class PocketOp:
    """A DRILL at `at` (the boundary's start point) and a POCKET clearing the inside of the
    closed `boundary` (elements from `at`) round each island (its start point and elements),
    at `feed` (nm/min)."""

    lines: list[int]
    at: XY
    spec: HoleSpec
    feed: int
    boundary: list[Element]
    islands: list[tuple[XY, list[Element]]]
    stop: bool = False
    message: str = ""


@dataclass
class HelixOp:
    """A HELIX, FACE or THREAD MILL about `at` (one block whose moves the file gives whole): `block`
    is the block with X/Y 0 (placed when it is written), `z_up` its Z UP in nm."""

    lines: list[int]
    at: XY
    block: Helix | Face | ThreadMill
    z_up: int
    stop: bool = False
    message: str = ""


Op = PosOp | HoleOpR | MillOp | BoltOp | RoutineOp | PocketOp | HelixOp | LoopOp


def anchor(op: Op) -> XY:
    """The point an operation starts from: where its first block puts the tool."""
    if isinstance(op, BoltOp):
        return op.centre
    if isinstance(op, LoopOp):
        return anchor(op.body[0])
    return op.at


def units_of(op: Op) -> Units:
    """The units an operation's blocks are in."""
    if isinstance(op, LoopOp):
        return units_of(op.body[0])
    if isinstance(op, PosOp):
        return op.units
    if isinstance(op, HelixOp):
        return op.block.units
    return op.spec.units


def z_up_of(op: Op) -> int | None:
    """An operation's Z UP (nm): None for a POS, a LOOP (its body has its own) and a
    2-axis hole."""
    if isinstance(op, PosOp | LoopOp):
        return None
    if isinstance(op, HelixOp):
        return op.z_up
    return op.spec.z_up


def tool_of(op: Op) -> int:
    if isinstance(op, PosOp):
        return op.tool
    if isinstance(op, LoopOp):
        return tool_of(op.body[0])
    if isinstance(op, HelixOp):
        return op.block.tool
    return op.spec.tool


def tools_of(op: Op) -> set[int]:
    if isinstance(op, LoopOp):
        return {t for body in op.body for t in tools_of(body)}
    return {tool_of(op)}


def all_lines(op: Op) -> list[int]:
    if isinstance(op, LoopOp):
        return sorted({*op.lines, *[line for body in op.body for line in all_lines(body)]})
    return op.lines


@dataclass(init=False)
class Signature:
    """An operation seen from its anchor: `labels` must be equal and `numbers` (nm) close
    for two operations to be the same pattern translated."""

    labels: list[Hashable] = field(default_factory=list)
    numbers: list[int] = field(default_factory=list)

    def __init__(self) -> None:
        self.labels = []
        self.numbers = []


def signature(op: Op) -> Signature:
    """What must be equal, and what must be close, for `op` to repeat as a pattern."""
    sig = Signature()
    _sign(op, anchor(op), sig)
    return sig


def _sign(op: Op, origin: XY, sig: Signature) -> None:
    ax, ay = anchor(op)
    sig.numbers += [ax - origin[0], ay - origin[1]]
    if isinstance(op, PosOp):
        sig.labels.append(("pos", op.tool, op.units, op.stop, op.message))
    elif isinstance(op, HoleOpR):
        sig.labels.append(("hole", op.spec, op.stop, op.message))
    elif isinstance(op, MillOp):
        sig.labels.append(("mill", op.spec, op.comp, op.stop, op.message, len(op.elements)))
        for e in op.elements:
            sig.labels.append((e.centre is None, e.clockwise, e.z_dn, e.feed))
            sig.numbers += [e.end[0] - ax, e.end[1] - ay]
            if e.centre is not None:
                sig.numbers += [e.centre[0] - ax, e.centre[1] - ay]
    elif isinstance(op, BoltOp):
        sig.labels.append(("bolt", op.spec, op.holes, op.angle, op.radius, op.stop, op.message))
    elif isinstance(op, RoutineOp):
        sig.labels.append(("routine", op.spec, op.block, op.stop, op.message))
    elif isinstance(op, HelixOp):
        sig.labels.append(("helix", op.block, op.stop, op.message))
    elif isinstance(op, PocketOp):
        # A pocket is not repeated as a LOOP pattern: its own identity is its signature.
        sig.labels.append(("pocket", id(op)))
    else:
        sig.labels.append(("loop", op.step, op.nx, op.ny, len(op.body), op.head_added))
        for body in op.body:
            _sign(body, (ax, ay), sig)


def close_numbers(a: list[int], b: list[int], tolerance: int) -> bool:
    """As many numbers in `a` as in `b`, each within `tolerance` of its own."""
    if a == b:  # a pattern repeated by exact steps (the usual case): no loop needed
        return True
    return len(a) == len(b) and all(abs(p - q) <= tolerance for p, q in zip(a, b, strict=True))
