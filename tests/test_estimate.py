"""Cycle time over the compiled path's chunks: the same figures as the estimate that walked
the Toolpath's move objects one by one (kept here as the reference), to the last bit."""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import replace
from decimal import Decimal
from pathlib import Path

import pytest

from app.cnc import document
from app.cnc.blocks import Hole, Pos, Program
from app.cnc.compiler import compile_program
from app.cnc.copy import resolve_copies
from app.cnc.estimate import RAPID_NM_PER_MIN, Estimate, estimate
from app.cnc.geometry import arc_sweep
from app.cnc.interpret import interpret
from app.cnc.limits import DEFAULT_TOOL_CHANGE_SECONDS
from app.cnc.machine import PRESETS, MachineModel, read_machine
from app.cnc.toolpath import (
    ArcFeed,
    Dwell,
    Feed,
    IndexTable,
    ProgramStop,
    Rapid,
    ToolChange,
    Toolpath,
)
from app.cnc.units import Units
from bench.programs import editor_program, sized

TESTS = Path(__file__).parent
CORPUS = sorted(
    p
    for folder in ("golden", "verify")
    for p in (TESTS / folder).iterdir()
    if (p / "program.json").exists()
)
MACHINES: dict[str, MachineModel | None] = {
    "no machine": None,
    "kt-800": PRESETS["kt-800"],
    "capped feed, OTIME": read_machine({"max_feed": "2", "operator_seconds": "60"}),
}


def load(case: Path) -> Program:
    return resolve_copies(document.loads((case / "program.json").read_text(encoding="utf-8")))


def reference(toolpath: Toolpath, machine: MachineModel | None = None) -> Estimate:
    """The estimate as it was before the chunks (app/cnc/estimate.py until issue 18's
    preview work): one move object at a time, in Python floats."""
    known = machine.tool_change_seconds if machine is not None else None
    tool_change_seconds = float(known) if known is not None else DEFAULT_TOOL_CHANGE_SECONDS
    rapid_rate = RAPID_NM_PER_MIN
    max_feed = None
    operator = 0.0
    if machine is not None:
        if machine.rapid is not None:
            rapid_rate = machine.nm(machine.rapid)
        if machine.max_feed is not None:
            max_feed = machine.nm(machine.max_feed)
        if machine.operator_seconds is not None:
            operator = float(machine.operator_seconds)
    per_block: dict[int, float] = defaultdict(float)
    per_tool: dict[int, float] = defaultdict(float)
    result = Estimate()
    x, y, z = toolpath.start
    tool = toolpath.initial_tool
    for move in toolpath.moves:
        seconds = 0.0
        if isinstance(move, Rapid | Feed):
            length = math.sqrt((move.x - x) ** 2 + (move.y - y) ** 2 + (move.z - z) ** 2)
            rate = rapid_rate if isinstance(move, Rapid) else move.feed
            if max_feed is not None and not isinstance(move, Rapid):
                rate = min(rate, max_feed)
            seconds = 60.0 * length / rate
            if isinstance(move, Rapid):
                result.rapid += seconds
            else:
                result.cutting += seconds
            x, y, z = move.x, move.y, move.z
        elif isinstance(move, ArcFeed):
            radius = math.hypot(x - move.cx, y - move.cy)
            sweep = arc_sweep((x, y), (move.x, move.y), (move.cx, move.cy), move.clockwise)
            rate = move.feed if max_feed is None else min(move.feed, max_feed)
            if move.z != z:  # a helix: the hypotenuse of its unrolled length and its drop
                seconds = 60.0 * math.hypot(radius * sweep, move.z - z) / rate
            else:
                seconds = 60.0 * radius * sweep / rate
            result.cutting += seconds
            x, y, z = move.x, move.y, move.z
        elif isinstance(move, Dwell):
            seconds = float(move.seconds)
            result.dwell += seconds
        elif isinstance(move, ToolChange):
            seconds = tool_change_seconds
            result.tool_changes += 1
            tool = move.tool
            z = move.z
        elif isinstance(move, ProgramStop):
            result.operator_waits.append((move.block, move.reason))
        elif isinstance(move, IndexTable):
            result.operator_waits.append((move.block, "index the rotary table"))
        per_block[move.block] += seconds
        per_tool[tool] += seconds
    result.per_block = dict(sorted(per_block.items()))
    result.per_tool = dict(sorted(per_tool.items()))
    result.operator = operator
    result.total = sum(per_block.values()) + operator
    return result


def figures(result: Estimate) -> tuple[object, ...]:
    """Everything an estimate says but its assumptions' wording (exact floats)."""
    return (
        result.per_block,
        result.per_tool,
        result.total,
        result.rapid,
        result.cutting,
        result.dwell,
        result.tool_changes,
        result.operator,
        result.operator_waits,
    )


@pytest.mark.parametrize("case", CORPUS, ids=[f"{c.parent.name}/{c.name}" for c in CORPUS])
def test_chunks_give_the_same_figures_as_the_move_objects(case: Path) -> None:
    program = load(case)
    path = compile_program(program).path
    for name, machine in MACHINES.items():
        wanted = figures(reference(interpret(program), machine))
        assert figures(estimate(path, machine=machine)) == wanted, name
        # A Toolpath of objects (tests, small callers) is estimated the same way.
        assert figures(estimate(interpret(program), machine=machine)) == wanted, name


@pytest.mark.parametrize("family", ["grid", "bolts", "pockets"])
def test_large_looped_programs_match_too(family: str) -> None:
    """Tens of thousands of moves, chunked and tiled, each LOOP pattern timed once per
    place the tool enters it from (the rest its figures again, the moves up to its first
    motion re-timed): every per-block sum is still the same sequence of additions as one
    move at a time, at every machine's rates."""
    program = sized(family, 40_000)
    path = compile_program(program).path
    toolpath = interpret(program)
    for name, machine in MACHINES.items():
        wanted = figures(reference(toolpath, machine))
        assert figures(estimate(path, machine=machine)) == wanted, name


def test_lengths_too_large_to_square_in_64_bits() -> None:
    """A rapid across ±99.999 in on X, Y and Z at once: the squares' sum passes 2^63 nm²,
    so those moves are measured with Python's exact integers, as before."""
    far = 2_539_974_600  # 99.999 in
    toolpath = Toolpath(
        units=Units.INCH,
        origin=(0, 0),
        start=(far, far, far),
        initial_tool=0,
        tools={},
        moves=[Rapid(1, -far, -far, -far), Feed(2, far, -far, far, 254_000_000)],
    )
    assert figures(estimate(toolpath)) == figures(reference(toolpath))


def test_an_edit_gives_the_figures_of_the_edited_program() -> None:
    """The figures of the top-level nodes an edit leaves alone are kept from the estimate
    before it; the edited program's figures are still its own, to the last bit: a block
    moved (the nodes after it enter at another place), one inserted at the front (every
    node keeps its figures under new block numbers), a tool change added."""
    program = editor_program(200)
    first = program.blocks[0]
    assert isinstance(first, Hole)
    moved = replace(first, x=first.x + Decimal("0.25"))
    edits = [
        replace(program, blocks=(moved, *program.blocks[1:])),
        replace(program, blocks=(Pos(x=Decimal(1), y=Decimal(2), tool=1), *program.blocks)),
        replace(program, blocks=(*program.blocks[:3], replace(first, tool=2), *program.blocks[3:])),
    ]
    for machine in (None, MACHINES["capped feed, OTIME"]):
        estimate(compile_program(program).path, machine=machine)
        for edited in edits:
            assert figures(estimate(compile_program(edited).path, machine=machine)) == figures(
                reference(interpret(edited), machine)
            )
