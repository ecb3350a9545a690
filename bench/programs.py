"""The programs the benchmarks run: built from blocks, valid, deterministic.

Three families expand to a chosen number of canonical moves by repeating an outer LOOP:

- `grid`: nested LOOP/REP drilling (a 10 x 10 grid of pecked holes inside an outer grid);
- `bolts`: a LOOP of 250-hole bolt circles;
- `pockets`: a LOOP of circle pockets (2P, pecked) and frame pockets, inside an outer LOOP.

Patterns are spaced closely (they may overlap: the interpreter does not care) so that even
10^6 moves stay inside the control's ±99.999 in. The outer repeat count is found by
interpreting the program once with one outer pattern, so the move count lands within a
few per cent of the target; the benchmarks report the real count.

`editor_program(n)` is a realistic n-block program (holes, bolt circles, pockets, contours,
LOOPs) for the editor and load benchmarks.
"""

from __future__ import annotations

from collections.abc import Callable
from decimal import Decimal

from app.cnc.blocks import (
    Block,
    BoltCircle,
    Circle,
    DataBlock0,
    Frame,
    Hole,
    HoleOp,
    MillLine,
    Mode,
    Placement,
    Pos,
    Program,
    Rep,
    Tool,
)
from app.cnc.interpret import interpret

D = Decimal
INC = Mode.INC

TOOLS = (
    Tool(number=1, diameter=D("0.25"), rpm=1200, tcal=D(0)),
    Tool(number=2, diameter=D("0.5"), rpm=800, tcal=D("-1.25")),
    Tool(number=3, diameter=D("0.201"), rpm=-400, tcal=D("0.375")),
)
BLOCK0 = DataBlock0(x_offset=D("4.5"), y_offset=D("3.25"), current_tool=1, tools=TOOLS)


def _grid_split(patterns: int) -> tuple[int, int]:
    """NX, NY of a REP grid with as close to `patterns` patterns as a grid allows (each of
    NX, NY at most 999), as square as that allows."""
    best = (patterns, patterns, 1, 1)
    for columns in range(1, min(patterns, 1000) + 1):
        rows = min(1000, max(1, round(patterns / columns)))
        key = (abs(columns * rows - patterns), abs(columns - rows), columns, rows)
        best = min(best, key)
    return best[2] - 1, best[3] - 1


def grid(patterns: int) -> Program:
    """`patterns` outer patterns, each a 10 x 10 grid of 3-peck holes (about 11 moves each)."""
    nx, ny = _grid_split(patterns)
    return Program(
        name=f"bench grid {patterns}",
        block0=BLOCK0,
        blocks=(
            Pos(x=D(1), y=D(1), tool=1),
            Pos(mode=INC, loop=True, x=D(0), y=D(0), tool=1),
            Hole(
                mode=INC,
                loop=True,
                op=HoleOp.DRILL,
                x=D(0),
                y=D(0),
                z_up=D("0.1"),
                z_dn=D("-0.5"),
                feed_z=D(5),
                pecks=3,
                tool=1,
            ),
            Rep(x=D("0.05"), y=D("0.05"), nx=9, ny=9),
            Rep(x=D("0.6"), y=D("0.6"), nx=nx, ny=ny),
        ),
    )


def bolts(patterns: int) -> Program:
    """`patterns` bolt circles of 250 holes each (about 1 250 moves each)."""
    nx, ny = _grid_split(patterns)
    return Program(
        name=f"bench bolts {patterns}",
        block0=BLOCK0,
        blocks=(
            Pos(x=D(2), y=D(2), tool=1),
            Hole(
                mode=INC,
                loop=True,
                op=HoleOp.DRILL,
                x=D(0),
                y=D(0),
                z_up=D("0.1"),
                z_dn=D("-0.2"),
                feed_z=D(5),
                tool=1,
            ),
            BoltCircle(mode=INC, op=HoleOp.DRILL, holes=250, radius=D("0.5")),
            Rep(x=D("0.1"), y=D("0.1"), nx=nx, ny=ny),
        ),
    )


def pockets(patterns: int) -> Program:
    """`patterns` outer patterns of 5 x (circle pocket 2P + frame pocket), ~500 moves each."""
    nx, ny = _grid_split(patterns)
    return Program(
        name=f"bench pockets {patterns}",
        block0=BLOCK0,
        blocks=(
            Pos(x=D(2), y=D(2), tool=2),
            Pos(mode=INC, loop=True, x=D(0), y=D(0), tool=2),
            Hole(
                mode=INC,
                loop=True,
                op=HoleOp.DRILL,
                x=D(0),
                y=D(0),
                z_up=D("0.1"),
                z_dn=D("-0.3"),
                feed_z=D(4),
                pecks=3,
                tool=2,
            ),
            Circle(
                placement=Placement.POCKET,
                two_pass=True,
                radius=D("1.25"),
                feed_xy=D(9),
                tool=2,
            ),
            Hole(
                mode=INC,
                op=HoleOp.DRILL,
                x=D(3),
                y=D(0),
                z_up=D("0.1"),
                z_dn=D("-0.3"),
                feed_z=D(4),
                pecks=2,
                tool=2,
            ),
            Frame(
                placement=Placement.POCKET,
                xl=D(3),
                yw=D(2),
                corner_radius=D("0.375"),
                feed_xy=D(9),
                tool=2,
            ),
            Rep(x=D("0.02"), y=D(0), nx=4, ny=0),
            Rep(x=D("0.2"), y=D("0.2"), nx=nx, ny=ny),
        ),
    )


FAMILIES: dict[str, Callable[[int], Program]] = {
    "grid": grid,
    "bolts": bolts,
    "pockets": pockets,
}
FAMILY_TITLES = {
    "grid": "nested LOOP/REP drilling grid (3 pecks)",
    "bolts": "LOOP of 250-hole bolt circles",
    "pockets": "nested LOOPs of circle 2P and frame pockets",
}


def sized(family: str, moves: int) -> Program:
    """A `family` program that expands to about `moves` canonical moves."""
    build = FAMILIES[family]
    one = len(interpret(build(1)).moves)
    two = len(interpret(build(2)).moves)
    per_pattern = max(1, two - one)
    patterns = max(1, round((moves - (one - per_pattern)) / per_pattern))
    return build(patterns)


def _hole(op: HoleOp, x: str, y: str, tool: int, pecks: int = 1, **kw: object) -> Hole:
    z_dn = {"DRILL": "-0.5", "BORE": "-0.4", "TAP": "-0.375"}[op.value]
    return Hole(
        op=op,
        x=D(x),
        y=D(y),
        z_up=D("0.1"),
        z_dn=D(z_dn),
        feed_z=D(5),
        pecks=pecks,
        tool=tool,
        **kw,  # type: ignore[arg-type]
    )


def _unit(k: int) -> list[Block]:
    """Ten blocks of a shop program, placed by `k` (every block valid on its own)."""
    x = D(k % 10) + D("0.5")
    y = D((k // 10) % 10) + D("0.5")
    # The bolt circle's first hole (seed 001: angle 0 below the centre, 90 to its left...),
    # bored out: a boring bar needs a smaller hole first.
    quarter = k % 4
    dx, dy = ((D(0), D("-0.2")), (D("-0.2"), D(0)), (D(0), D("0.2")), (D("0.2"), D(0)))[quarter]
    first = (x + dx, y + D("0.25") + dy)
    return [
        _hole(HoleOp.DRILL, f"{x}", f"{y}", 1, pecks=2),
        _hole(HoleOp.DRILL, f"{x}", f"{y + D('0.25')}", 1),
        BoltCircle(op=HoleOp.DRILL, holes=6, radius=D("0.2"), angle=D(90 * quarter)),
        _hole(HoleOp.BORE, f"{first[0]}", f"{first[1]}", 2),
        _hole(HoleOp.DRILL, f"{x + D('0.1')}", f"{y + D('0.1')}", 2),
        Circle(placement=Placement.POCKET, radius=D("0.4"), feed_xy=D(9), tool=2),
        _hole(HoleOp.DRILL, f"{x}", f"{y}", 2),
        MillLine(x=x + D("0.75"), y=y, feed_xy=D(8), tool=2),
        Hole(
            mode=INC,
            loop=True,
            op=HoleOp.DRILL,
            x=D("0.1"),
            y=D("0.1"),
            z_up=D("0.1"),
            z_dn=D("-0.25"),
            feed_z=D(5),
            tool=1,
        ),
        Rep(x=D("0.1"), y=D(0), nx=2, ny=0),
    ]


def editor_program(blocks: int = 500, name: str = "bench editor") -> Program:
    """A valid program of exactly `blocks` blocks (a multiple of 10 works best)."""
    body: list[Block] = []
    k = 0
    while len(body) < blocks:
        body.extend(_unit(k))
        k += 1
    body = body[:blocks]
    # A cut-off unit must not leave a LOOP open or a DRILL waiting for its mill block.
    while body and (isinstance(body[-1], Hole) and body[-1].loop):
        body.pop()
    while len(body) < blocks:
        body.append(Pos(x=D(1), y=D(len(body) % 10), tool=1))
    return Program(name=name, part_number="500", block0=BLOCK0, blocks=tuple(body))


# Where an edit goes: the first DRILL of each ten-block unit (block 1, 11, 21...).
EDITABLE_STRIDE = 10


def drill_form(x: Decimal, y: Decimal) -> dict[str, str]:
    """The editor's form fields for the standalone DRILL at the start of each unit."""
    return {
        "kind": "DRILL",
        "units": "inch",
        "mode": "abs",
        "x": f"{x}",
        "y": f"{y}",
        "z_up": "0.1",
        "z_dn": "-0.5",
        "feed_z": "5",
        "pecks": "2",
        "tool": "1",
    }
