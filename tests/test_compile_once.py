"""Compile once, read everywhere (issue 32): what a mill sequence is programmed to make is
planned once, by the compile, and every consumer reads it from the compiled path.

The events writer, the SVG drawing, Verify's programmed geometry, the cleared areas of the
pilot rule and the cycle time each run on a program already compiled; none may call a
planner again (the events export of `pocket-islands` spent 97 % of its time re-planning
the POCKET). What they read must still be where each sequence is cut: a LOOP's placements
move the plan with them.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from types import CodeType, FrameType
from typing import Any

import pytest

from app.cnc import cost, document, routines, sequences
from app.cnc.blocks import Program
from app.cnc.compiler import Cache, compile_program
from app.cnc.copy import resolve_copies
from app.cnc.estimate import estimate
from app.cnc.formats.svg import render
from app.cnc.formats.targets import export
from app.cnc.path import PLAN_ELEMENT_ROWS, placed_mills
from app.cnc.pocketing import plan as pocket_plan
from app.cnc.pocketing import routine as pocket_routine
from app.cnc.process import cleared_areas
from app.cnc.setup import setup_sheet
from app.cnc.simulate.programmed import programmed_geometry

GOLDEN = Path(__file__).parent / "golden"
# Every kind of mill sequence: contours (compensated and not), CIRCLE and FRAME routines,
# POCKETs with islands, and a POCKET inside a LOOP.
CASES = (
    "contour-cut-right",
    "mill-contour-uncompensated",
    "circle-pocket",
    "circle-in-tan-mm",
    "frame-2p-outside-mm",
    "frame-pocket",
    "pocket-islands",
    "pocket-loop",
)
PLANNERS: dict[str, Callable[..., Any]] = {
    "plan_sequence": sequences.plan_sequence,
    "programmed_contour": sequences.programmed_contour,
    "routine_path": routines.routine_path,
    "pocket_contours": pocket_routine.pocket_contours,
    "plan_pocket": pocket_plan.plan_pocket,
}
CONSUMERS: dict[str, Callable[[Program], object]] = {
    "events export": lambda p: export(p, "events"),
    "svg export": lambda p: export(p, "svg"),
    "preview drawing": lambda p: render(p),
    "verify's programmed geometry": programmed_geometry,
    "cleared areas (pilot rule)": lambda p: cleared_areas(compile_program(p).path),
    "cycle time": lambda p: estimate(compile_program(p).path),
}


def load(name: str) -> Program:
    return resolve_copies(document.loads((GOLDEN / name / "program.json").read_text()))


def _costing(frame: FrameType | None) -> bool:
    """True inside the cost estimate: it reads a POCKET's contours from the blocks before
    anything is compiled, by design (DESIGN.md §1 "Cost before work": it bounds the
    compile), so it is no consumer of the compile."""
    while frame is not None:
        if frame.f_code is cost.estimate.__code__:
            return True
        frame = frame.f_back
    return False


@contextmanager
def planner_calls() -> Iterator[dict[str, int]]:
    """Count the calls of every planner function while the block runs (a profile hook on
    their code objects: the real functions run, nothing is replaced)."""
    codes: dict[CodeType, str] = {f.__code__: name for name, f in PLANNERS.items()}
    calls = dict.fromkeys(PLANNERS, 0)

    def hook(frame: FrameType, event: str, _: object) -> None:
        if event == "call" and frame.f_code in codes and not _costing(frame.f_back):
            calls[codes[frame.f_code]] += 1

    sys.setprofile(hook)
    try:
        yield calls
    finally:
        sys.setprofile(None)


@pytest.mark.parametrize("consumer", CONSUMERS)
@pytest.mark.parametrize("case", CASES)
def test_no_consumer_plans_a_compiled_program_again(case: str, consumer: str) -> None:
    program = load(case)
    compile_program(program)  # as the editor, `check` and every export do first
    with planner_calls() as calls:
        CONSUMERS[consumer](program)
    assert {name: n for name, n in calls.items() if n} == {}, f"{consumer} planned {case} again"


def test_the_compile_plans_each_sequence_once() -> None:
    # The counter counts: a fresh compile of a POCKET plans it (and nothing else does).
    program = load("pocket-islands")
    with planner_calls() as calls:
        compile_program(program, cache=Cache())
    assert calls["plan_pocket"] == 1


def test_a_loops_placements_carry_the_plan_where_each_pattern_is_cut() -> None:
    program = load("pocket-loop")
    spans = [m for m in placed_mills(compile_program(program).path.root) if m.outlines()]
    assert len(spans) > 1
    first = spans[0]
    for span in spans[1:]:
        dx, dy = span.x - first.x, span.y - first.y
        assert (dx, dy) != (0, 0)
        # The outline, the passes and the programmed end moved by the pattern's offset.
        for (name, moved), (_, there) in zip(span.outlines(), first.outlines(), strict=True):
            assert name in ("boundary",) or name.startswith("island")
            assert moved.start == (there.start[0] + dx, there.start[1] + dy)
        moved_plan, plan = span.pocket(), first.pocket()
        assert moved_plan is not None and plan is not None
        start, origin = moved_plan.passes[0].path.start, plan.passes[0].path.start
        assert start == (origin[0] + dx, origin[1] + dy)
        assert span.exit() == (first.exit()[0] + dx, first.exit()[1] + dy)
        # Block numbers are the placed span's own (the same blocks in every pattern here).
        assert {e.block for _, p in span.outlines() for e in p.elements} == {
            e.block for _, p in first.outlines() for e in p.elements
        }


def test_the_compile_cache_counts_the_plans_it_keeps() -> None:
    # A POCKET's kept plan outweighs its moves (pocket-islands: 172 elements, about 65 kB,
    # against 378 rows, 23 kB): the cache's budget must count it, or it bounds nothing.
    program = load("pocket-islands")
    cache = Cache()
    moves = len(compile_program(program, cache=cache).path)
    # Before: the moves of each node kept, and one for the entry (a few nodes here).
    assert cache.held > moves + 100 * PLAN_ELEMENT_ROWS


def test_each_compiled_hole_carries_its_tool() -> None:
    # A bolt circle's holes are cut by the tool of the block that gives their parameters
    # (BORE with tool 2, then TAP with tool 3): the pilot rule, Verify, the set-up sheet's
    # hole table and the drawing read it from the hole, not from the blocks.
    program = load("bolt-circle-bore-tap")
    path = compile_program(program).path
    tools = [span.tool for chunk in path.chunks() for span in chunk.hole_spans()]
    assert set(tools) == {2, 3} and tools == sorted(tools)  # the bores, then the taps
    sheet = setup_sheet(program)
    assert {line.tool for line in sheet.holes} == {2, 3}


def test_a_conrad_in_a_loop_is_written_where_the_pattern_cuts_it() -> None:
    # A LOOP's body is compiled once about its pattern's reference and placed: the events
    # read its contour placed, and the conrad's corner (where the Plus puts the CR) must
    # move with it. The first pattern starts at X1 Y1: the corner of the 2 in line along X
    # is X3 Y1, not X2 Y0 (where the body was compiled). A compensated contour is the
    # Plus's to offset, so no self-check would catch it: the file was simply wrong.
    def block(kind: str, **values: object) -> dict[str, object]:
        return {"type": kind, "mode": "inc", "units": "inch", "loop": False, **values}

    cut = {"z_dn": None, "feed_xy": 10, "tool": 2}
    data = {
        "format": "millblocks-program",
        "version": 1,
        "name": "conrad loop",
        "units": "inch",
        "data_block_0": {
            "current_tool": 2,
            "z_retract": 0.1,
            "tools": [{"number": 2, "diameter": 0.25, "rpm": 1500}],
        },
        "blocks": [
            {**block("POS", x=1, y=1, tool=2), "mode": "abs"},
            {
                **block("DRILL", x=0, y=0, z_up=0.1, z_dn=-0.1, feed_z=4, pecks=1, tool=2),
                "loop": True,
                "comp": "right",
            },
            block("MILL_STD", x=2, y=0, conrad=0.25, **cut),
            block("MILL_STD", x=0, y=1, **cut),
            block("REP", x=4, y=0, nx=1, ny=0),
        ],
    }
    program = document.loads(json.dumps(data))
    text = export(program, "events").data.decode()
    rounded = [line for line in text.splitlines() if " CR0.25" in line]
    assert len(rounded) == 1, text
    assert "XE3.0A YE1.0A" in rounded[0], text
