"""The SVG drawing: what it shows must be the tool path, and repeated patterns stay small."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from decimal import Decimal as D
from pathlib import Path

import pytest

from app.cnc import document
from app.cnc.blocks import DataBlock0, Hole, HoleOp, Mode, Pos, Program, Rep, Tool
from app.cnc.copy import resolve_copies
from app.cnc.emit.svg import draw
from app.cnc.emit.target import export
from app.cnc.interpret import interpret
from app.cnc.toolpath import Dwell, Feed, Rapid, Toolpath

GOLDEN = Path(__file__).parent / "golden"
SVG = "{http://www.w3.org/2000/svg}"
XLINK = "{http://www.w3.org/1999/xlink}href"


def load(name: str) -> Program:
    return resolve_copies(document.loads((GOLDEN / name / "program.json").read_text()))


def flatten_holes(svg: str) -> list[tuple[float, float]]:
    """Every hole circle of the drawing, with each <use> expanded at its offset."""
    root = ET.fromstring(svg)
    symbols = {s.get("id"): s for s in root.iter(f"{SVG}symbol")}

    def walk(element: ET.Element, dx: float, dy: float) -> list[tuple[float, float]]:
        found = []
        for child in element:
            if child.tag == f"{SVG}circle" and child.get("class") == "hole":
                found.append(
                    (
                        round(float(child.get("cx", 0)) + dx, 4),
                        round(float(child.get("cy", 0)) + dy, 4),
                    )
                )
            elif child.tag == f"{SVG}use":
                target = symbols[child.get(XLINK, "").lstrip("#")]
                found += walk(target, dx + float(child.get("x", 0)), dy + float(child.get("y", 0)))
            elif child.tag in (f"{SVG}g",):
                found += walk(child, dx, dy)
        return found

    page = next(g for g in root if g.tag == f"{SVG}g")
    return walk(page, 0.0, 0.0)


def toolpath_holes(toolpath: Toolpath) -> list[tuple[float, float]]:
    unit = toolpath.units.nm
    x, y = toolpath.start[:2]
    holes = []
    for move in toolpath.moves:
        if isinstance(move, Rapid | Feed):
            x, y = move.x, move.y
        elif isinstance(move, Dwell):
            holes.append((round(x / unit, 4), round(y / unit, 4)))
    return holes


@pytest.mark.parametrize(
    "name", ["loop-nested-3-deep", "loop-rep-grid", "loop-bolt-circle", "bolt-circle-250"]
)
def test_drawing_shows_every_hole_where_the_tool_path_makes_it(name: str) -> None:
    toolpath = interpret(load(name))
    assert sorted(flatten_holes(draw(toolpath))) == sorted(toolpath_holes(toolpath))


def test_every_block_that_moves_is_linkable() -> None:
    program = load("contour-cut-right")
    svg = draw(interpret(program))
    blocks = {int(g.get("data-block", 0)) for g in ET.fromstring(svg).iter(f"{SVG}g")}
    blocks.discard(0)
    moving = {m.block for m in interpret(program).moves if isinstance(m, Rapid | Feed)}
    assert moving - {0} <= blocks


def test_arcs_stay_arcs_with_the_right_sweep() -> None:
    """contour-cut-right: the QCIR CC of block 3 (offset: radius 0.75) ends at (3.75, 0.5).

    The page is flipped (scale(1,-1)), so a counter-clockwise arc has SVG sweep flag 1.
    """
    svg = draw(interpret(load("contour-cut-right")))
    assert "A0.75 0.75 0 0 1 3.75 0.5" in svg


def test_swept_width_and_grid_are_options() -> None:
    plain = export(load("contour-cut-right"), "svg").data.decode()
    rich = export(load("contour-cut-right"), "svg", {"swept": "yes", "grid": "yes"}).data.decode()
    assert 'class="swept"' not in plain and 'class="swept"' in rich
    assert 'class="grid"' in rich


def ten_thousand() -> Program:
    """Four nested LOOP/REP pairs of 10 patterns: 10 000 holes."""
    tools = (Tool(number=1, diameter=D("0.05"), rpm=3000, tcal=D(0)),)
    inc = Mode.INC

    def loop_pos() -> Pos:
        return Pos(mode=inc, x=D(0), y=D(0), tool=1, loop=True)

    drill = Hole(
        op=HoleOp.DRILL,
        mode=inc,
        x=D(0),
        y=D(0),
        z_up=D("0.05"),
        z_dn=D("-0.05"),
        feed_z=D(50),
        tool=1,
        loop=True,
    )
    return Program(
        name="grid",
        block0=DataBlock0(current_tool=1, z_retract=D("0.05"), tools=tools),
        blocks=(
            Pos(x=D(1), y=D(1), tool=1),
            loop_pos(),
            loop_pos(),
            loop_pos(),
            drill,
            Rep(x=D("0.1"), y=D(0), nx=9, ny=0),
            Rep(x=D(0), y=D("0.1"), nx=0, ny=9),
            Rep(x=D(1), y=D(0), nx=9, ny=0),
            Rep(x=D(0), y=D(1), nx=0, ny=9),
        ),
    )


def test_ten_thousand_patterns_preview_under_200_kb() -> None:
    toolpath = interpret(ten_thousand())
    svg = draw(toolpath)
    assert len(svg.encode()) < 200_000, f"{len(svg.encode())} bytes"
    assert svg.count("<symbol") == 4
    assert sorted(flatten_holes(svg)) == sorted(toolpath_holes(toolpath))


def test_same_program_same_bytes() -> None:
    program = load("circle-pocket")
    assert draw(interpret(program)) == draw(interpret(program))
