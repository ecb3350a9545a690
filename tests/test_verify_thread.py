"""Verify's intended part for a thread (issue 33): a thread mill's helix goes down one lead a
turn, so only the end of its last turn reaches Z DN. The thread has its full form all round
down to a lead and a quarter above Z DN (the helix stops a quarter of the lead short, where
the lead-out takes over); below that it runs out, partly cut, and nothing is cut below Z DN.

Material left above the full form's depth is rest material; a cut below Z DN is a gouge.
Reading the thread as cut flat to Z DN called its run-out rest material (346 mm² on the
golden M20); reading it as flat at the full form's depth would call the cut down to Z DN a
gouge. The misses below are programs as a machinist would write them (two threaded bosses
too close for the tool), and the golden thread's path edited at the control so it stops a
turn short or goes a turn too deep, measured against the program as written.
"""

from __future__ import annotations

import dataclasses
from decimal import Decimal
from pathlib import Path

import pytest

from app.cnc import document
from app.cnc.blocks import (
    Circle,
    Hole,
    HoleOp,
    MillingMode,
    Placement,
    Program,
    Stock,
    ThreadMill,
    Tool,
)
from app.cnc.compiler import compile_program
from app.cnc.simulate.placements import place
from app.cnc.simulate.programmed import programmed_geometry
from app.cnc.simulate.stock import make_grid
from app.cnc.simulate.sweep import simulate
from app.cnc.simulate.verify import Verification, check_part, default_tolerance, stock_of, verify
from app.cnc.tools import Hand

GOLDEN = Path(__file__).parent / "golden"
MM = 1_000_000
RESOLUTION = 100_000  # 0.1 mm cells
STOCK = Stock(
    x=Decimal(0), y=Decimal(0), xl=Decimal(80), yw=Decimal(50), zh=Decimal(20), clear=Decimal(0)
)


def golden(name: str) -> Program:
    return document.loads((GOLDEN / name / "program.json").read_text(encoding="utf-8"))


def external(**changes: object) -> Program:
    """The golden M20x1.5 external thread (12 mm long) on a saved stock, changed."""
    program = golden("thread-mill-external-mm")
    (thread,) = program.blocks
    assert isinstance(thread, ThreadMill)
    changed = dataclasses.replace(thread, **changes)  # type: ignore[arg-type]
    return dataclasses.replace(program, blocks=(changed,), stock=STOCK)


def turned(program: Program, diameter: Decimal | None = None) -> Program:
    """`program`'s thread on a shank turned first to its major diameter (or `diameter`) and
    to its Z DN (a 16 mm end mill, tool 2, CIRCLE OUTSIDE): a thread cut from the bottom up
    comes down at rapid beside the shank, where solid stock would make a crash. The shank
    is the thread's roughing: the thread mill's cut inside it is the thread's waste."""
    (thread,) = program.blocks
    assert isinstance(thread, ThreadMill)
    end_mill = Tool(number=2, diameter=Decimal(16), rpm=1500, tcal=Decimal(0))
    boss = (
        Hole(
            op=HoleOp.DRILL,
            x=thread.x,
            y=thread.y,
            z_up=Decimal(1),
            z_dn=thread.z_dn,
            feed_z=Decimal(100),
            tool=2,
            units=thread.units,
        ),
        Circle(
            placement=Placement.OUTSIDE,
            radius=(diameter or thread.diameter) / 2,
            feed_xy=Decimal(400),
            tool=2,
            units=thread.units,
        ),
    )
    block0 = dataclasses.replace(program.block0, tools=(*program.block0.tools, end_mill))
    return dataclasses.replace(program, block0=block0, blocks=(*boss, thread))


def findings(program: Program, resolution: int = RESOLUTION) -> list[tuple[int, str]]:
    return [(f.block, f.kind) for f in verify(program, resolution=resolution).findings]


def cut_against(cut: Program, meant: Program) -> Verification:
    """`cut`'s tool path simulated (a program edited at the control) and measured against
    the part `meant` asks for, on `meant`'s stock: what verify does with one program."""
    tol = default_tolerance(meant.units)
    placed = place(cut, compile_program(cut).path)
    grid = make_grid(stock_of(meant, placed), RESOLUTION)
    result = Verification(meant, simulate(grid, placed, None, tol), tolerance=tol)
    check_part(result, programmed_geometry(meant), tol)
    return result


# -- no false alarm -------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["thread-mill-external-mm", "thread-mill-internal"])
def test_a_golden_thread_reports_nothing(name: str) -> None:
    """Before: the external one's last turn was 346 mm² of rest material above Z DN."""
    result = verify(golden(name))
    assert [f"block {f.block}: {f.kind}: {f.message}" for f in result.findings] == []


@pytest.mark.parametrize(
    ("hand", "milling"),
    [
        (Hand.RIGHT, MillingMode.CLIMB),  # top-down
        (Hand.RIGHT, MillingMode.CONVENTIONAL),  # bottom-up: the lead-in at Z DN
        (Hand.LEFT, MillingMode.CLIMB),
        (Hand.LEFT, MillingMode.CONVENTIONAL),
    ],
)
def test_an_external_thread_cut_either_way_up_reports_nothing(
    hand: Hand, milling: MillingMode
) -> None:
    assert findings(turned(external(hand=hand, milling=milling))) == []


def test_a_shank_turned_under_the_thread_s_major_diameter_is_reported() -> None:
    """Turned to DIA 19.5 for an M20: the thread's crests would be cut off. The shank holds
    the minor diameter but not the major one the THREAD MILL block states, so it is no
    roughing of the thread, and the thread mill's cut inside it (down to the minor
    diameter, 18.16 mm) is a gouge of the shank's finished wall."""
    found = verify(turned(external(), Decimal("19.5")), resolution=RESOLUTION).findings
    assert [(f.block, f.kind) for f in found] == [(3, "gouge")]
    assert "past the finished wall of block 2" in found[0].message


@pytest.mark.parametrize(
    ("diameter", "pitch", "z_dn"),
    [("20", "1.5", "-7.3"), ("16", "2", "-5"), ("30", "3.5", "-12"), ("30", "3.5", "-5")],
)
def test_external_threads_of_other_sizes_and_lengths_report_nothing(
    diameter: str, pitch: str, z_dn: str
) -> None:
    """Lengths that are whole leads and not (the helix ends part way round a turn). The
    M30x3.5 5 mm long is shorter than a lead and a half: its helix goes less than a turn,
    so no depth has the full form all round and none is required."""
    program = external(
        x=Decimal(40), diameter=Decimal(diameter), pitch=Decimal(pitch), z_dn=Decimal(z_dn)
    )
    assert findings(program) == []


def test_the_helix_goldens_report_only_the_core_their_notes_describe() -> None:
    """A HELIX ends with a whole turn at Z DN: flat to Z DN all round, no run-out. The
    helical entry reports nothing; helix-bore's second bore leaves the core its notes say
    (tests/test_helix.py pins that message)."""
    assert findings(golden("helix-entry-mm"), 0) == []
    assert findings(golden("helix-bore"), 0) == [(2, "hole depth")]


# -- no miss --------------------------------------------------------------------------------


def test_a_thread_path_that_stops_a_turn_short_leaves_rest_material() -> None:
    """The golden thread's path edited to stop at Z -10.5 (one lead short) or Z -11.25 (half
    a turn short), measured against the block's Z DN -12: its full form ends too high."""
    meant = external()
    assert cut_against(meant, meant).findings == []
    for short in ("-10.5", "-11.25"):
        found = cut_against(external(z_dn=Decimal(short)), meant).findings
        assert [(f.block, f.kind) for f in found] == [(1, "rest material")], short
        assert "above Z -10.125" in found[0].message
        assert "Z DN -12.000" in found[0].message


def test_a_thread_path_that_goes_a_turn_too_deep_is_a_gouge() -> None:
    """The same path edited to go down to Z -13.5, one lead below the block's Z DN."""
    found = cut_against(external(z_dn=Decimal("-13.5")), external()).findings
    assert [(f.block, f.kind) for f in found] == [(1, "gouge")]
    assert "removes material no block means to remove" in found[0].message


def test_a_thread_mill_too_big_for_the_gap_cuts_into_the_next_thread() -> None:
    """Two M20x1.5 bosses 32 mm apart, their minor diameters (18.16 mm) 22.92 mm from the
    other's centre. A 10 mm thread mill comes in from 21.27 mm (its edge 1.27 mm beyond the
    major diameter, `thread_clear`): it passes between them. A 16 mm one comes in from
    27.27 mm and goes round reaching 25.08 mm: into the other's minor diameter, a gouge of
    that thread's wall by each block."""

    def pair(tool_diameter: str) -> Program:
        first = external(x=Decimal(24))
        (thread,) = first.blocks
        assert isinstance(thread, ThreadMill)
        tools = tuple(
            dataclasses.replace(t, diameter=Decimal(tool_diameter)) for t in first.block0.tools
        )
        return dataclasses.replace(
            first,
            block0=dataclasses.replace(first.block0, tools=tools),
            blocks=(thread, dataclasses.replace(thread, x=Decimal(56))),
        )

    assert findings(pair("10")) == []
    found = verify(pair("16"), resolution=RESOLUTION).findings
    assert [(f.block, f.kind) for f in found] == [(1, "gouge"), (2, "gouge")]
    assert "past the finished wall of block 2" in found[0].message
    assert "past the finished wall of block 1" in found[1].message
