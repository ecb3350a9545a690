"""Verify reads nested bosses as a machinist programs them: a boss roughed and then
finished is one boss, the smallest the program cuts to that depth; a stepped shaft is two.

CIRCLE/FRAME OUTSIDE puts the cutter outside the finished contour the block programs (seed
001, 3.4.5.2), and Verify takes everything outside a boss, to its Z DN, as waste, never
another boss's inside. A boss that holds a smaller one cut at least as deep is that one's
roughing: the smaller one's waste takes its wall, and its own wall is no finished surface
(before, the finish pass was a gouge of the roughing pass's wall). A larger boss cut deeper
than the smaller one it holds is the step the smaller one stands on: both walls are kept.

Verify cannot know the print: it reads the smallest boss as the one meant, so a finish pass
programmed too small is the part as programmed. The one diameter the program states twice
is a thread's: a shank turned under the thread's major diameter cuts its crests, and the
thread mill's cut past the shank's wall is still reported. A boss standing in a pocket (a
CIRCLE/FRAME INSIDE around it) is kept by the pocket, and the boss's waste ends at the
pocket's wall: a tool that cuts from one into the other is a gouge either way.
"""

from __future__ import annotations

import dataclasses
from decimal import Decimal

import pytest

from app.cnc.blocks import (
    Block,
    Circle,
    DataBlock0,
    Frame,
    Hole,
    HoleOp,
    Placement,
    Program,
    Stock,
    Tool,
)
from app.cnc.problems import has_errors
from app.cnc.simulate.verify import verify
from app.cnc.units import Units
from app.cnc.validate import validate

MM_CELL = 100_000  # 0.1 mm
INCH_CELL = 254_000  # 0.01 in


def drill(x: str, y: str, z_dn: str, units: Units = Units.MM, tool: int = 1) -> Hole:
    """The DRILL that starts a routine: its centre (a frame's lower-left corner) and Z DN."""
    metric = units is Units.MM
    return Hole(
        op=HoleOp.DRILL,
        x=Decimal(x),
        y=Decimal(y),
        z_up=Decimal(1) if metric else Decimal("0.1"),
        z_dn=Decimal(z_dn),
        feed_z=Decimal(100) if metric else Decimal(4),
        tool=tool,
        units=units,
    )


def circle(
    radius: str, placement: Placement = Placement.OUTSIDE, units: Units = Units.MM, tool: int = 1
) -> Circle:
    metric = units is Units.MM
    return Circle(
        placement=placement,
        radius=Decimal(radius),
        feed_xy=Decimal(400) if metric else Decimal(10),
        tool=tool,
        units=units,
    )


def frame(
    xl: str, yw: str, placement: Placement = Placement.OUTSIDE, corner: str = "0", tool: int = 1
) -> Frame:
    return Frame(
        placement=placement,
        xl=Decimal(xl),
        yw=Decimal(yw),
        corner_radius=Decimal(corner),
        feed_xy=Decimal(400),
        tool=tool,
        units=Units.MM,
    )


def part(
    blocks: tuple[Block, ...],
    tools: tuple[str, ...] = ("10",),
    units: Units = Units.MM,
    size: tuple[str, str, str] = ("80", "60", "20"),
) -> Program:
    """`blocks` on a saved stock from X0 Y0 of `size` (XL, YW, ZH), tools 1, 2, … of the
    diameters in `tools`."""
    return Program(
        name="boss",
        units=units,
        block0=DataBlock0(
            current_tool=1,
            tools=tuple(
                Tool(number=n, diameter=Decimal(d), rpm=1000, tcal=Decimal(0))
                for n, d in enumerate(tools, start=1)
            ),
        ),
        blocks=blocks,
        stock=Stock(
            x=Decimal(0),
            y=Decimal(0),
            xl=Decimal(size[0]),
            yw=Decimal(size[1]),
            zh=Decimal(size[2]),
            clear=Decimal(0),
        ),
    )


def found(program: Program) -> list[tuple[int, str, str]]:
    assert not has_errors(validate(program))
    cell = MM_CELL if program.units is Units.MM else INCH_CELL
    return [(f.block, f.kind, f.message) for f in verify(program, resolution=cell).findings]


def kinds(program: Program) -> list[tuple[int, str]]:
    return [(block, kind) for block, kind, _ in found(program)]


# -- no false alarm -------------------------------------------------------------------------


ROUGHED = {
    # DIA 10.5 then DIA 10 at the same centre and Z DN, a 10 mm end mill.
    "circle-mm": part(
        (drill("40", "30", "-6"), circle("5.25"), drill("40", "30", "-6"), circle("5"))
    ),
    # DIA 1.02 then DIA 1.0, the roughing 0.005 in above Z DN as CIR 2P leaves it.
    "circle-inch": part(
        (
            drill("1.5", "1.25", "-0.245", Units.INCH),
            circle("0.51", units=Units.INCH),
            drill("1.5", "1.25", "-0.25", Units.INCH),
            circle("0.5", units=Units.INCH),
        ),
        tools=("0.5",),
        units=Units.INCH,
        size=("3", "2.5", "0.75"),
    ),
    # 40.5 x 20.5 then 40 x 20 about the same middle, R3 corners then R2.75.
    "frame-mm": part(
        (
            drill("19.75", "19.75", "-6"),
            frame("40.5", "20.5", corner="3"),
            drill("20", "20", "-6"),
            frame("40", "20", corner="2.75"),
        ),
        size=("80", "60", "20"),
    ),
    # A larger boss to a shallower Z DN, a smaller one deeper: the smaller one's waste
    # takes all of the larger one, which goes only part way down.
    "circle-shallower-rough-mm": part(
        (drill("40", "30", "-3"), circle("10"), drill("40", "30", "-6"), circle("5"))
    ),
}


@pytest.mark.parametrize("name", sorted(ROUGHED))
def test_a_boss_roughed_then_finished_reports_nothing(name: str) -> None:
    """Before: the finish pass was a gouge past the roughing pass's wall (block 4 'cuts
    0.246 mm past the finished wall of block 2' for the circle in mm)."""
    assert found(ROUGHED[name]) == []


def stepped(small: str = "5", large: str = "10") -> Program:
    """A stepped shaft: DIA 10 from the top down to Z -5, standing on DIA 20 down to Z -10."""
    return part(
        (drill("40", "30", "-5"), circle(small), drill("40", "30", "-10"), circle(large)),
        tools=("10", "10"),
    )


def test_a_stepped_shaft_reports_nothing_and_keeps_both_walls() -> None:
    """The larger boss is cut deeper than the smaller one it holds: it is the step, not a
    roughing. A DIA 16 boss beside it, cut to Z -10 with the 10 mm end mill, goes round 13
    mm from its centre at X 15: the tool's edge at X 33, 3 mm past the step's wall (and
    the step's tool 3 mm past the neighbour's)."""
    assert found(stepped()) == []
    neighbour = (*stepped().blocks, drill("15", "30", "-10"), circle("8"))
    into_step = found(dataclasses.replace(stepped(), blocks=neighbour))
    assert [(b, k) for b, k, _ in into_step] == [(4, "gouge"), (6, "gouge")]
    assert "past the finished wall of block 6" in into_step[0][2]
    assert "past the finished wall of block 4" in into_step[1][2]


# -- no miss --------------------------------------------------------------------------------


def test_two_bosses_roughed_together_then_finished_apart_keep_each_other() -> None:
    """A FRAME OUTSIDE roughs round two pins; each pin is then finished on its own with a
    tool too big for the 6 mm gap: the frame is the pins' roughing, not a boss that holds
    them, and each finish pass still cuts into the other pin's wall."""
    pins = (
        drill("14", "14", "-6"),
        frame("52", "32"),
        drill("28", "30", "-6"),
        circle("8"),
        drill("50", "30", "-6"),
        circle("8"),
    )
    assert kinds(part(pins, tools=("6",))) == []
    found_big = found(part(pins, tools=("12",)))
    assert [(b, k) for b, k, _ in found_big] == [(4, "gouge"), (6, "gouge")]
    assert "past the finished wall of block 6" in found_big[0][2]
    assert "past the finished wall of block 4" in found_big[1][2]


def pocket_with_boss(boss_x: str, wall_tool: int = 1, boss_tool: int = 1) -> Program:
    """An 80 x 60 FRAME INSIDE from X10 Y10 (R12 corners) to Z -6 round a DIA 10 boss at
    Y 40; tool 1 a 10 mm end mill, tool 2 a 24 mm one."""
    return part(
        (
            drill("10", "10", "-6", tool=wall_tool),
            frame("80", "60", Placement.INSIDE, corner="12", tool=wall_tool),
            drill(boss_x, "40", "-6", tool=boss_tool),
            circle("5", tool=boss_tool),
        ),
        tools=("10", "24"),
        size=("100", "80", "20"),
    )


def test_a_boss_standing_in_a_pocket_reports_nothing() -> None:
    assert found(pocket_with_boss("50")) == []


def test_a_boss_whose_tool_reaches_the_pocket_s_wall_gouges_it() -> None:
    """The boss at X 30, its wall 15 mm from the pocket's, cut with the 24 mm end mill: the
    tool goes round 17 mm from its centre, 9 mm past the pocket's wall at X 10 (the
    pocket's own 10 mm tool stays 5 mm clear of the boss), and plunges 3.175 mm farther
    out (block 3, the DRILL that starts it), 2.15 mm past the wall at Y 10. Before: the
    boss's waste (all outside it) took the wall."""
    result = found(pocket_with_boss("30", boss_tool=2))
    assert [(b, k) for b, k, _ in result] == [(3, "gouge"), (4, "gouge")]
    assert "cuts 2.150 mm past the finished wall of block 2" in result[0][2]
    assert "cuts 8.950 mm past the finished wall of block 2" in result[1][2]


def test_a_pocket_s_wall_pass_that_reaches_the_boss_gouges_it() -> None:
    """The pocket's wall cut with a 24 mm end mill reaches X 34: 1 mm into the boss at X 38
    (its wall from X 33). Before: the pocket's waste (all inside it) took the boss."""
    result = found(pocket_with_boss("38", wall_tool=2))
    assert [(b, k) for b, k, _ in result] == [(2, "gouge")]
    assert "past the finished wall of block 4" in result[0][2]


def test_a_groove_round_a_boss_reports_nothing() -> None:
    """A CIRCLE INSIDE DIA 40 and a CIRCLE OUTSIDE DIA 20 about one centre, both to Z -6,
    with a 6 mm end mill: a face groove, the boss kept by the bore round it."""
    groove = (
        drill("40", "30", "-6"),
        circle("20", Placement.INSIDE),
        drill("40", "30", "-6"),
        circle("10"),
    )
    assert found(part(groove, tools=("6",))) == []


def test_a_finish_pass_below_the_stock_is_still_reported() -> None:
    """The finish pass goes to Z -21 in a 20 mm stock on the vise: the process rule names
    its DRILL's plunge and its circle. Before, the circle was also a gouge of the roughing
    pass's wall."""
    deep = part((drill("40", "30", "-6"), circle("5.25"), drill("40", "30", "-21"), circle("5")))
    assert kinds(deep) == [(3, "process"), (4, "process")]
