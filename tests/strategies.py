"""Hypothesis strategies for valid MillBlocks programs (seed 001, DESIGN.md §2-3).

`programs()` builds programs that `validate()` accepts without errors, by construction rather
than by filtering: every value is drawn at the programming resolution (0.001 in, 0.01 mm)
and inside the control's limits, and the blocks are put together the way the control
allows them to follow each other:

- nodes: POS, a standard DRILL/BORE/TAP hole, a bolt circle (a standard hole of the same
  operation giving the centre, then BOLT CIR), a mill sequence (a DRILL without cutter
  compensation followed by MILL STD lines), and LOOP … REP around a head node and a body
  of nodes, nested up to four deep;
- every block of a LOOP sequence is INC and every block of a LOOP or mill sequence uses one
  tool; the total pattern count of nested loops stays small (`MAX_PATTERNS`) so the tests
  run fast;
- the tool table lists 1-5 tools, at least one with an RPM (possibly negative), each with or
  without a diameter and a TCAL; tools without RPM are never used;
- STOP goes only where the control allows it (not on REP, not inside a mill sequence);
- some programs carry warnings: cutter compensation on a DRILL that no mill block follows,
  MILL STD lines that go nowhere, a trailing COPY still waiting for EXEC or CANCEL.

Programs are inch or metric, and some mix both units block by block (the INCH/MM field).

`post_programs()` writes G-code text as CAM posts do (issue 36): Fusion 360's and Haas's
header (G28 G91 Z0.), Mastercam's safety line (G0 G17 G40 G80 G90 G94 G98) at each tool, T M6,
G43 H, G54, S M3, M8, drilling cycles (G81, G83 with pecks that divide the depth, as the
blocks' evenly spaced pecks hold them) with G98/G99 and R, and a G98 on a G99 series' last
hole, contours of G1 and G2/G3 with I/J at one depth or two, feed words as posts write them
(only where they change), G0 Z retracts, M9 M5, M30 and %. Numbers are written to the post's
4 decimals (inch) or 3 (mm), whole numbers with a trailing point.

`shop_programs()` goes where a shop's programs go and the tests above never did (issue 16):
mill sequences of lines, quarter circles and arcs (some over 180°, some with the end off the
radius, a little or by a divot), cutter compensation, CIRCLE and FRAME routines (every
placement, two-pass), lines that go nowhere inside compensated contours, TCAL on most tools,
and tools without RPM in use (`rpm_optional`). It draws freely and leaves it to the test to
keep only what `validate` accepts (compensation limits are geometry, not worth rebuilding
here): `assume` on the errors that stop the tool path.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from decimal import Decimal
from functools import partial

from hypothesis import strategies as st

from app.cnc import limits
from app.cnc.blocks import (
    ArcEnd,
    Block,
    BoltCircle,
    Circle,
    Comp,
    Copy,
    DataBlock0,
    Direction,
    Frame,
    Hole,
    HoleOp,
    MillArc,
    MillingMode,
    MillLine,
    MillQcir,
    Mode,
    Placement,
    Pos,
    Program,
    Rep,
    Tool,
)
from app.cnc.units import Units

# At most this many patterns for one node, multiplied through nested LOOP/REP pairs.
MAX_PATTERNS = 24
# NX and NY are drawn from 0 to this (the control allows 999).
MAX_REPEAT_DRAWN = 3
# A bolt circle's holes × pecks × enclosing patterns stays under this, to keep tests fast.
MAX_HOLE_LEVELS = 600
# Nodes in one LOOP body (besides the LOOP block's own node) and at the top level.
MAX_BODY_NODES = 2
MAX_TOP_NODES = 5


@dataclass(frozen=True)
class _Context:
    """What the blocks of one program share: its unit, usable tools, unit mixing, and
    (shop programs) the kinds of node drawn and the tools with a diameter."""

    units: Units
    tools: tuple[int, ...]
    mixed_units: bool
    kinds: tuple[str, ...] = ("pos", "hole", "bolt", "mill")
    cutters: tuple[int, ...] = ()


def _other(units: Units) -> Units:
    return Units.MM if units is Units.INCH else Units.INCH


def lengths(units: Units, low_mils: int, high_mils: int) -> st.SearchStrategy[Decimal]:
    """Lengths at the programming resolution of `units`, from `low_mils` to `high_mils`.

    The bounds are in thousandths of an inch; for millimetres they are converted and rounded
    inwards (1 mil = 0.0254 mm), and values are drawn in 0.01 mm steps.
    """
    if units is Units.INCH:
        return st.integers(low_mils, high_mils).map(lambda n: Decimal(n).scaleb(-3))
    low = -((-low_mils * 254) // 100)
    high = (high_mils * 254) // 100
    return st.integers(low, high).map(lambda n: Decimal(n).scaleb(-2))


def feeds_z(units: Units) -> st.SearchStrategy[Decimal]:
    """FEEDR Z: 0.1-250.0 ipm in 0.1 steps, or 2-6350 mm/min in steps of 2."""
    if units is Units.INCH:
        return st.integers(1, 2500).map(lambda n: Decimal(n).scaleb(-1))
    return st.integers(1, 3175).map(lambda n: Decimal(2 * n))


def feeds_xy(units: Units) -> st.SearchStrategy[Decimal]:
    """FEEDR XY: 0.1-100.0 ipm in 0.1 steps, or 2-2540 mm/min in steps of 2."""
    if units is Units.INCH:
        return st.integers(1, 1000).map(lambda n: Decimal(n).scaleb(-1))
    return st.integers(1, 1270).map(lambda n: Decimal(2 * n))


def rpms() -> st.SearchStrategy[int]:
    """A spindle speed the control accepts: 60-4000, negative for counter-clockwise."""
    return st.builds(lambda n, ccw: -n if ccw else n, st.integers(60, 4000), st.booleans())


def angles() -> st.SearchStrategy[Decimal]:
    """A bolt-circle angle, 0 to 359.99° in 0.01° steps."""
    return st.integers(0, 35999).map(lambda n: Decimal(n).scaleb(-2))


def _stops() -> st.SearchStrategy[bool]:
    """The STOP qualifier, set now and then (shrinks to no STOP)."""
    return st.sampled_from((False, False, False, True))


@st.composite
def tool_tables(draw: st.DrawFn, units: Units) -> tuple[DataBlock0, tuple[int, ...]]:
    """Data Block 0 and the numbers of its tools that have an RPM (at least one)."""
    numbers = draw(st.lists(st.integers(1, 24), min_size=1, max_size=5, unique=True))
    usable = draw(st.integers(1, len(numbers)))
    tools = tuple(
        Tool(
            number=number,
            diameter=draw(st.none() | lengths(units, 1, 2000)),
            rpm=draw(rpms()) if k < usable else None,
            tcal=draw(st.none() | lengths(units, -10_000, 10_000)),
        )
        for k, number in enumerate(numbers)
    )
    block0 = DataBlock0(
        x_offset=draw(lengths(units, -50_000, 50_000)),
        y_offset=draw(lengths(units, -50_000, 50_000)),
        current_tool=draw(st.integers(0, 24)),
        milling=draw(st.sampled_from(MillingMode)),
        z_retract=draw(lengths(units, 0, 1000)),
        tools=tools,
    )
    return block0, tuple(numbers[:usable])


def _block_units(draw: st.DrawFn, ctx: _Context) -> Units:
    if ctx.mixed_units:
        return draw(st.sampled_from((ctx.units, _other(ctx.units))))
    return ctx.units


def _xy(draw: st.DrawFn, units: Units, mode: Mode) -> tuple[Decimal, Decimal]:
    """X and Y: a position within ±10 in (ABS) or a step within ±3 in (INC)."""
    span = 10_000 if mode is Mode.ABS else 3_000
    return draw(lengths(units, -span, span)), draw(lengths(units, -span, span))


@st.composite
def holes(
    draw: st.DrawFn,
    units: Units,
    *,
    op: HoleOp,
    tool: int,
    mode: Mode,
    max_pecks: int = limits.MAX_PECKS,
    allow_comp: bool = False,
) -> Hole:
    """A DRILL/BORE/TAP block with depths: Z DN below Z UP, pecks only on a DRILL.

    Z UP is within ±2 in (so sometimes negative), the hole up to 2 in deep. `allow_comp`
    lets a DRILL carry CUT RT/LT, which for a hole no mill block follows is a warning.
    """
    x, y = _xy(draw, units, mode)
    z_up = draw(lengths(units, -2000, 2000))
    z_dn = z_up - draw(lengths(units, 1, 2000))
    comp = Comp.NONE
    if allow_comp and op is HoleOp.DRILL:
        comp = draw(st.sampled_from((Comp.NONE, Comp.NONE, Comp.RIGHT, Comp.LEFT)))
    return Hole(
        op=op,
        x=x,
        y=y,
        z_up=z_up,
        z_dn=z_dn,
        feed_z=draw(feeds_z(units)),
        pecks=draw(st.integers(1, max_pecks)) if op is HoleOp.DRILL else 1,
        tool=tool,
        comp=comp,
        mode=mode,
        units=units,
    )


@st.composite
def _pos_node(draw: st.DrawFn, ctx: _Context, tool: int, mode: Mode, mult: int) -> list[Block]:
    units = _block_units(draw, ctx)
    x, y = _xy(draw, units, mode)
    pos = Pos(
        x=x,
        y=y,
        index=draw(st.booleans()),
        tool=tool,
        mode=mode,
        units=units,
        stop=draw(_stops()),
    )
    return [pos]


@st.composite
def _hole_node(draw: st.DrawFn, ctx: _Context, tool: int, mode: Mode, mult: int) -> list[Block]:
    op = draw(st.sampled_from(HoleOp))
    hole = draw(
        holes(_block_units(draw, ctx), op=op, tool=tool, mode=mode, allow_comp=True),
    )
    return [dataclasses.replace(hole, stop=draw(_stops()))]


@st.composite
def _bolt_node(draw: st.DrawFn, ctx: _Context, tool: int, mode: Mode, mult: int) -> list[Block]:
    op = draw(st.sampled_from(HoleOp))
    centre = draw(holes(_block_units(draw, ctx), op=op, tool=tool, mode=mode, allow_comp=True))
    max_holes = max(1, min(limits.MAX_BOLT_HOLES, MAX_HOLE_LEVELS // (centre.pecks * mult)))
    units = _block_units(draw, ctx)
    bolt = BoltCircle(
        op=op,
        holes=draw(st.integers(1, max_holes)),
        angle=draw(angles()),
        radius=draw(lengths(units, 1, 5000)),
        mode=mode,
        units=units,
    )
    # STOP may sit on either block of the pair; the control stops after the whole pattern.
    stop_on = draw(st.sampled_from((None, None, None, 0, 1)))
    pair: list[Block] = [centre, bolt]
    if stop_on is not None:
        pair[stop_on] = dataclasses.replace(pair[stop_on], stop=True)
    return pair


@st.composite
def _mill_node(draw: st.DrawFn, ctx: _Context, tool: int, mode: Mode, mult: int) -> list[Block]:
    """A DRILL starting a mill sequence, then 1-4 MILL STD lines (one unit, one tool)."""
    units = _block_units(draw, ctx)
    drill = draw(holes(units, op=HoleOp.DRILL, tool=tool, mode=mode))
    z_up = drill.z_up
    assert z_up is not None
    sequence: list[Block] = [drill]
    for _ in range(draw(st.integers(1, 4))):
        line_mode = mode if mode is Mode.INC else draw(st.sampled_from(Mode))
        x, y = _xy(draw, units, line_mode)
        if line_mode is Mode.INC and draw(st.sampled_from((False,) * 7 + (True,))):
            x = y = Decimal(0)  # a line that goes nowhere: a warning, and no motion
        # A mill block may change depth: anywhere below the drill's Z UP, down to 3 in under it.
        z_dn = draw(st.none() | lengths(units, 1, 3000).map(lambda d: z_up - d))
        sequence.append(
            MillLine(
                x=x,
                y=y,
                z_dn=z_dn,
                feed_xy=draw(feeds_xy(units)),
                tool=tool,
                mode=line_mode,
                units=units,
            )
        )
    if draw(_stops()):
        sequence[-1] = dataclasses.replace(sequence[-1], stop=True)
    return sequence


def _arc_end(
    draw: st.DrawFn, units: Units, centre: tuple[int, int], clockwise: bool
) -> tuple[int, int]:
    """An INC arc's end (steps of the programming resolution) from its start, about `centre`
    (steps, relative to the start): any sweep, over 180° too; the end rounded to the grid,
    now and then pushed off the radius by a step or two (within typing) or by a divot."""
    radius = math.hypot(*centre)
    start_angle = math.atan2(-centre[1], -centre[0])
    sweep = draw(st.integers(5, 355)) * math.pi / 180
    angle = start_angle - sweep if clockwise else start_angle + sweep
    off = draw(st.sampled_from((0, 0, 0, 0, 1, 2, 10)))  # steps off the radius
    r = radius + off
    return (
        round(centre[0] + r * math.cos(angle)),
        round(centre[1] + r * math.sin(angle)),
    )


@st.composite
def _contour_node(draw: st.DrawFn, ctx: _Context, tool: int, mode: Mode, mult: int) -> list[Block]:
    """A DRILL (with cutter compensation when its tool has a diameter) and 1-5 mill blocks:
    lines (some going nowhere, some changing depth), quarter circles and arcs, all INC."""
    units = _block_units(draw, ctx)
    comp = Comp.NONE
    if tool in ctx.cutters:
        comp = draw(st.sampled_from((Comp.NONE, Comp.RIGHT, Comp.LEFT)))
    drill = dataclasses.replace(
        draw(holes(units, op=HoleOp.DRILL, tool=tool, mode=mode)), comp=comp
    )
    z_up = drill.z_up
    assert z_up is not None
    step = units.resolution
    sequence: list[Block] = [drill]
    feed = draw(feeds_xy(units))
    for _ in range(draw(st.integers(1, 5))):
        kind = draw(st.sampled_from(("line", "line", "qcir", "arc", "nowhere")))
        z_dn = draw(st.none() | lengths(units, 1, 1000).map(lambda d: z_up - d))
        if kind in ("line", "nowhere"):
            x, y = _xy(draw, units, Mode.INC) if kind == "line" else (Decimal(0), Decimal(0))
            sequence.append(
                MillLine(x=x, y=y, z_dn=z_dn, feed_xy=feed, tool=tool, mode=Mode.INC, units=units)
            )
        elif kind == "qcir":
            d = draw(lengths(units, 10, 2000))
            sx, sy = draw(st.sampled_from((1, -1))), draw(st.sampled_from((1, -1)))
            direction = draw(st.sampled_from(Direction))
            sequence.append(
                MillQcir(
                    direction=direction,
                    x=sx * d,
                    y=sy * d,
                    z_dn=z_dn,
                    feed_xy=feed,
                    tool=tool,
                    mode=Mode.INC,
                    units=units,
                )
            )
        else:
            clockwise = draw(st.booleans())
            steps = 1000 if units is Units.INCH else 2540
            cx = draw(st.integers(-steps, steps))
            cy = draw(st.integers(-steps, steps))
            if math.hypot(cx, cy) < 20:
                cx = 20
            ex, ey = _arc_end(draw, units, (cx, cy), clockwise)
            direction = Direction.CW if clockwise else Direction.CCW
            sequence.append(
                MillArc(
                    direction=direction,
                    x=cx * step,
                    y=cy * step,
                    z_dn=z_dn,
                    feed_xy=feed,
                    tool=tool,
                    mode=Mode.INC,
                    units=units,
                )
            )
            sequence.append(ArcEnd(x=ex * step, y=ey * step, mode=Mode.INC, units=units))
    if draw(_stops()):
        sequence[-1] = dataclasses.replace(sequence[-1], stop=True)
    return sequence


@st.composite
def _routine_node(draw: st.DrawFn, ctx: _Context, tool: int, mode: Mode, mult: int) -> list[Block]:
    """A DRILL and a CIRCLE or FRAME routine (any placement, perhaps two-pass)."""
    units = _block_units(draw, ctx)
    drill = draw(holes(units, op=HoleOp.DRILL, tool=tool, mode=mode, max_pecks=3))
    placement = draw(st.sampled_from(Placement))
    two_pass, feed, stop = draw(st.booleans()), draw(feeds_xy(units)), draw(_stops())
    routine: Block
    if draw(st.booleans()):
        radius = draw(lengths(units, 50, 3000))
        routine = Circle(
            placement=placement,
            two_pass=two_pass,
            radius=radius,
            feed_xy=feed,
            tool=tool,
            units=units,
            stop=stop,
        )
    else:
        xl, yw = draw(lengths(units, 100, 4000)), draw(lengths(units, 100, 4000))
        corner = min(draw(lengths(units, 0, 1000)), xl / 2, yw / 2)
        routine = Frame(
            placement=placement,
            two_pass=two_pass,
            xl=xl,
            yw=yw,
            corner_radius=corner.quantize(units.resolution, rounding="ROUND_DOWN"),
            feed_xy=feed,
            tool=tool,
            units=units,
            stop=stop,
        )
    return [drill, routine]


_LEAF_NODES = {
    "pos": _pos_node,
    "hole": _hole_node,
    "bolt": _bolt_node,
    "mill": _mill_node,
    "contour": _contour_node,
    "routine": _routine_node,
}


@st.composite
def nodes(
    draw: st.DrawFn,
    ctx: _Context,
    *,
    tool: int | None,
    in_loop: bool,
    depth: int,
    budget: int,
    mult: int,
) -> list[Block]:
    """The blocks of one node.

    `tool` is the LOOP sequence's tool (None at the top level: any usable tool). `depth` is
    the number of LOOPs open around the node; `budget` the patterns a LOOP here may still
    multiply by; `mult` the patterns of the LOOPs around it.
    """
    # Inside a LOOP, another LOOP is likelier, so that nests three and four deep turn up.
    loops = 0 if depth == limits.MAX_LOOP_DEPTH else 1 if depth == 0 else 3
    kind = draw(st.sampled_from([*ctx.kinds, *["loop"] * loops]))
    if tool is None:
        tool = draw(st.sampled_from(ctx.tools))
    if kind in ("contour", "routine") and tool not in ctx.cutters:
        kind = "mill"  # a routine (or compensation) needs the cutter's diameter
    if kind != "loop":
        mode = Mode.INC if in_loop else draw(st.sampled_from(Mode))
        return draw(_LEAF_NODES[kind](ctx, tool, mode, mult))
    nx = draw(st.integers(0, min(MAX_REPEAT_DRAWN, budget - 1)))
    ny = draw(st.integers(0, min(MAX_REPEAT_DRAWN, budget // (nx + 1) - 1)))
    count = (nx + 1) * (ny + 1)
    head_kind = draw(
        st.sampled_from(sorted(k for k in ctx.kinds if k not in ("contour", "routine")))
    )
    head = draw(_LEAF_NODES[head_kind](ctx, tool, Mode.INC, mult * count))
    head[0] = dataclasses.replace(head[0], loop=True)
    body = draw(
        st.lists(
            nodes(
                ctx,
                tool=tool,
                in_loop=True,
                depth=depth + 1,
                budget=budget // count,
                mult=mult * count,
            ),
            max_size=MAX_BODY_NODES,
        )
    )
    units = _block_units(draw, ctx)
    step_x, step_y = _xy(draw, units, Mode.INC)
    rep = Rep(x=step_x, y=step_y, nx=nx, ny=ny, units=units)
    return [*head, *(block for node in body for block in node), rep]


@st.composite
def pending_copies(draw: st.DrawFn, blocks: tuple[Block, ...], tools: tuple[int, ...]) -> Copy:
    """A COPY of one earlier block, still waiting for EXEC or CANCEL (a warning only).

    A TOOL # it would change to is one with an RPM (`tools`), like any block's.
    """
    number = draw(st.integers(1, len(blocks)))
    units = blocks[number - 1].units
    return Copy(
        from_block=number,
        to_block=number,
        op=draw(st.none() | st.sampled_from(HoleOp)),
        pecks=draw(st.none() | st.integers(1, limits.MAX_PECKS)),
        xof=draw(st.none() | lengths(units, -3000, 3000)),
        yof=draw(st.none() | lengths(units, -3000, 3000)),
        feed_z=draw(st.none() | feeds_z(units)),
        feed_xy=draw(st.none() | feeds_xy(units)),
        tool=draw(st.none() | st.sampled_from(tools)),
        units=units,
    )


STORABLE = st.characters(exclude_categories=["Cs"], exclude_characters="\x00")
"""Any character the one text rule lets be stored (app.cnc.text: no NUL, no lone
surrogate); what it refuses is the hostile corpus's to try."""


def names() -> st.SearchStrategy[str]:
    """A program name: any storable text that is not blank."""
    return st.text(STORABLE, min_size=1, max_size=20).filter(lambda s: bool(s.strip()))


@st.composite
def programs(draw: st.DrawFn, max_nodes: int = MAX_TOP_NODES) -> Program:
    """A program that `validate()` accepts without errors (it may have warnings)."""
    units = draw(st.sampled_from(Units))
    block0, usable = draw(tool_tables(units))
    ctx = _Context(units=units, tools=usable, mixed_units=draw(st.booleans()))
    top = draw(
        st.lists(
            nodes(ctx, tool=None, in_loop=False, depth=0, budget=MAX_PATTERNS, mult=1),
            min_size=1,
            max_size=max_nodes,
        )
    )
    blocks: tuple[Block, ...] = tuple(block for node in top for block in node)
    if draw(st.sampled_from((False, False, False, True))):
        blocks = (*blocks, draw(pending_copies(blocks, usable)))
    return Program(
        name=draw(names()),
        part_number=draw(st.text(alphabet="0123456789", max_size=8)),
        units=units,
        notes=draw(st.text(STORABLE, max_size=40)),
        block0=block0,
        blocks=blocks,
    )


@st.composite
def shop_programs(draw: st.DrawFn, max_nodes: int = 4, *, rpm_optional: bool = False) -> Program:
    """A program as a shop writes it (see the module docstring); it may not validate."""
    units = draw(st.sampled_from(Units))
    numbers = draw(st.lists(st.integers(1, 24), min_size=1, max_size=4, unique=True))
    tools = tuple(
        Tool(
            number=number,
            diameter=draw(st.none() | lengths(units, 62, 1000))
            if k
            else draw(lengths(units, 62, 1000)),
            rpm=draw(st.none() | rpms()) if rpm_optional else draw(rpms()),
            tcal=draw(lengths(units, -3000, 3000)) if draw(st.integers(0, 3)) else None,
        )
        for k, number in enumerate(numbers)
    )
    block0 = DataBlock0(
        x_offset=draw(lengths(units, -20_000, 20_000)),
        y_offset=draw(lengths(units, -20_000, 20_000)),
        current_tool=draw(st.sampled_from((0, *numbers))),
        milling=draw(st.sampled_from(MillingMode)),
        z_retract=draw(lengths(units, 0, 500)),
        tools=tools,
    )
    ctx = _Context(
        units=units,
        tools=tuple(numbers),
        mixed_units=draw(st.sampled_from((False, False, True))),
        kinds=("pos", "hole", "bolt", "contour", "contour", "routine"),
        cutters=tuple(t.number for t in tools if t.diameter is not None),
    )
    top = draw(
        st.lists(
            nodes(ctx, tool=None, in_loop=False, depth=0, budget=6, mult=1),
            min_size=1,
            max_size=max_nodes,
        )
    )
    return Program(
        name="shop",
        part_number="1704",
        units=units,
        block0=block0,
        blocks=tuple(block for node in top for block in node),
    )


# -- G-code as CAM posts write it (issue 36) -------------------------------------------------


def _post_number(steps: int, units: Units) -> str:
    """A length of `steps` file steps (0.0001 in, 0.001 mm) written as posts write it: no
    trailing zeros, a whole number with its point (`1.`, `-0.25`, `12.5`)."""
    places = 4 if units is Units.INCH else 3
    return f"{Decimal(steps).scaleb(-places):f}".rstrip("0")


def _post_feed(tenths: int) -> str:
    """A feed of `tenths` tenths (ipm or mm/min) as posts write it (`5.`, `12.5`)."""
    return f"{Decimal(tenths).scaleb(-1):f}".rstrip("0")


@st.composite
def _post_drilling(draw: st.DrawFn, units: Units, clear: int, scale: int) -> list[str]:
    """A drilling operation: G81 or G83 at 1-4 holes, G98 or G99 (perhaps G98 on the last)."""
    n = draw(st.integers(1, 4))
    points = draw(
        st.lists(
            st.tuples(st.integers(-400, 400), st.integers(-400, 400)),
            min_size=n,
            max_size=n,
            unique=True,
        )
    )
    holes = [(x * 100 * scale, y * 100 * scale) for x, y in points]  # 0.01 in apart at least
    r = draw(st.integers(1, 10)) * 100 * scale  # R 0.01-0.1 in above the top
    depth = draw(st.integers(5, 60)) * 100 * scale
    code = draw(st.sampled_from(("81", "83")))
    peck = ""
    if code == "83":
        pecks = draw(st.integers(2, 4))
        depth -= (r + depth) % pecks  # pecks that divide R to Z evenly
        peck = f" Q{_post_number((r + depth) // pecks, units)}"
    mode = draw(st.sampled_from(("G98", "G99")))
    feed = draw(st.integers(10, 200)) * (1 if units is Units.INCH else 25)
    w = partial(_post_number, units=units)
    x0, y0 = holes[0]
    lines = [f"G0 X{w(x0)} Y{w(y0)}", f"G43 Z{w(clear)} H{{tool}}"]
    if draw(st.booleans()):
        lines.append(f"G0 Z{w(clear // 2)}")
    lines.append(f"{mode} G{code} X{w(x0)} Y{w(y0)} Z{w(-depth)} R{w(r)}{peck} F{_post_feed(feed)}")
    for k, (x, y) in enumerate(holes[1:], start=2):
        last = k == len(holes) and mode == "G99" and draw(st.booleans())
        lines.append(f"{'G98 ' if last else ''}X{w(x)} Y{w(y)}")
    lines += ["G80", f"G0 Z{w(clear)}"]
    return lines


@st.composite
def _post_contour(draw: st.DrawFn, units: Units, clear: int, scale: int) -> list[str]:
    """A contour: down at one X/Y, then lines and arcs (I, J) at one depth, perhaps a second
    depth, and up at rapid."""
    w = partial(_post_number, units=units)
    x, y = (draw(st.integers(-300, 300)) * 100 * scale for _ in range(2))
    depth = draw(st.integers(5, 50)) * 100 * scale
    plunge = draw(st.integers(10, 100)) * (1 if units is Units.INCH else 25)
    feed = draw(st.integers(20, 800)) * (1 if units is Units.INCH else 25)
    lines = [f"G0 X{w(x)} Y{w(y)}", f"G43 Z{w(clear)} H{{tool}}"]
    lines += [f"G0 Z{w(clear // 3)}", f"G1 Z{w(-depth)} F{_post_feed(plunge)}"]
    written_feed = None
    for _ in range(draw(st.integers(1, 2))):
        for _ in range(draw(st.integers(1, 6))):
            if draw(st.booleans()):
                nx = x + draw(st.integers(-200, 200)) * 100 * scale
                ny = y + draw(st.integers(-200, 200)) * 100 * scale
                if abs(nx - x) + abs(ny - y) < 500 * scale:
                    continue
                move = f"G1 X{w(nx)} Y{w(ny)}"
            else:
                radius = draw(st.integers(1000, 20000)) * scale  # 0.1-2 in
                start = draw(st.integers(0, 359))
                sweep = draw(st.integers(10, 300))
                clockwise = draw(st.booleans())
                cx = x - round(radius * math.cos(math.radians(start)))
                cy = y - round(radius * math.sin(math.radians(start)))
                end = math.radians(start - sweep if clockwise else start + sweep)
                nx = cx + round(radius * math.cos(end))
                ny = cy + round(radius * math.sin(end))
                code = "G2" if clockwise else "G3"
                move = f"{code} X{w(nx)} Y{w(ny)} I{w(cx - x)} J{w(cy - y)}"
            if written_feed != feed:
                move, written_feed = f"{move} F{_post_feed(feed)}", feed
            lines.append(move)
            x, y = nx, ny
            if draw(st.integers(0, 4)) == 0:
                feed = draw(st.integers(20, 800)) * (1 if units is Units.INCH else 25)
        depth += draw(st.integers(5, 30)) * 100 * scale
        lines.append(f"G1 Z{w(-depth)} F{_post_feed(plunge)}")
        written_feed = plunge
    lines[-1:] = [f"G0 Z{w(clear)}"]
    return lines


@st.composite
def post_programs(draw: st.DrawFn) -> str:
    """G-code text as a CAM post writes it (see the module docstring)."""
    units = draw(st.sampled_from(Units))
    # File steps: 0.0001 in, or 0.001 mm scaled so the same draws make mm parts of a size.
    scale = 1 if units is Units.INCH else 3
    clear = 6000 if units is Units.INCH else 15_000
    safety = draw(st.booleans())
    lines = ["%", "O1001", "(T1 D=0.25 CR=0. - ZMIN=-0.5 - FLAT END MILL)", "G90 G94 G17"]
    lines += ["G20" if units is Units.INCH else "G21", "G28 G91 Z0.", "G90"]
    operations = draw(st.integers(1, 3))
    for k in range(1, operations + 1):
        tool = draw(st.integers(1, 24))
        lines += ["", f"(OPERATION {k})"]
        if k > 1:
            lines.append("M9")
        lines.append(f"T{tool} M6")
        if safety:
            lines.append("G0 G17 G40 G80 G90 G94 G98")
        lines += [f"S{draw(st.integers(500, 4000))} M3", "G54", "M8"]
        kind = _post_drilling if draw(st.booleans()) else _post_contour
        body = draw(kind(units, clear, scale))
        lines += [line.replace("{tool}", str(tool)) for line in body]
        lines.append("M9")
        if draw(st.booleans()):
            lines.append("M5")
        lines += ["G28 G91 Z0.", "G90"]
    lines += ["M30", "%"]
    return "\n".join(lines) + "\n"
