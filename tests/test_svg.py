"""The SVG drawing: what it shows must be the tool path, and repeated patterns stay small.

The drawing is made from the compiled tree (a LOOP's patterns drawn once, placed with
`<use>`), trusting the compiler that every placement is the pattern moved. These tests
check that trust the slow way: every `<use>` expanded, the drawing's segments and holes
are exactly the moves' and the holes' of the compiled path, walked move by move.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import random
import re
import xml.etree.ElementTree as ET
from collections import Counter
from collections.abc import Iterator
from decimal import Decimal as D
from pathlib import Path
from typing import Any

import pytest

from app.cnc import document
from app.cnc.blocks import DataBlock0, Hole, HoleOp, Mode, Pos, Program, Rep, Stock, Tool
from app.cnc.compiler import compile_program
from app.cnc.copy import resolve_copies
from app.cnc.formats.svg import HOLE_LABELS, draw, render
from app.cnc.formats.targets import export
from app.cnc.path import Op
from bench.programs import editor_program, sized
from tests.export_support import traced_export

GOLDEN = Path(__file__).parent / "golden"
CASES = sorted(p.name for p in GOLDEN.iterdir() if (p / "program.json").exists())
SVG = "{http://www.w3.org/2000/svg}"
XLINK = "{http://www.w3.org/1999/xlink}href"
PLACES = 4

Segment = tuple[str, tuple[float, float], tuple[float, float]]


def load(name: str) -> Program:
    return resolve_copies(document.loads((GOLDEN / name / "program.json").read_text()))


def r(value: float) -> float:
    return round(value + 0.0, PLACES) + 0.0


def same(drawn: Counter[Segment], moves: Counter[Segment], places: int) -> bool:
    """True when the drawn segments are the moves, each coordinate within two steps of the
    last printed place (a placed pattern's point is its rounded offset plus its rounded
    position in the pattern, which may differ from the rounded sum in the last place)."""
    step = 10.0**-places
    tolerance = 2.5 * step

    def cell(segment: Segment) -> tuple[object, ...]:
        kind, a, b = segment
        return (kind, *(math.floor(v / (10 * step)) for v in (*a, *b)))

    pool: dict[tuple[object, ...], list[Segment]] = {}
    for segment, count in drawn.items():
        pool.setdefault(cell(segment), []).extend([segment] * count)
    for segment, count in moves.items():
        kind, a, b = segment
        for _ in range(count):
            base = cell(segment)
            for shift in itertools.product((-1, 0, 1), repeat=4):
                key = (kind, *(c + d for c, d in zip(base[1:], shift, strict=True)))  # type: ignore[operator]
                near = [
                    s
                    for s in pool.get(key, [])
                    if all(
                        abs(u - v) <= tolerance
                        for u, v in zip((*s[1], *s[2]), (*a, *b), strict=True)
                    )
                ]
                if near:
                    pool[key].remove(near[0])
                    break
            else:
                return False
    return not any(pool.values())


class Flat:
    """A drawing with every `<use>` expanded: its tool path segments and hole circles."""

    def __init__(self, svg: str) -> None:
        self.root = ET.fromstring(svg)
        self.shapes = {g.get("id"): g for g in self.root.iter(f"{SVG}g") if g.get("id")}
        self.segments: Counter[Segment] = Counter()
        self.holes: list[tuple[float, float]] = []
        self.blocks: set[int] = set()
        page = next(g for g in self.root if g.get("class") == "page")
        self.walk(page, 0.0, 0.0, None)

    def walk(self, element: ET.Element, dx: float, dy: float, block: int | None) -> None:
        for child in element:
            tag = child.tag.removeprefix(SVG)
            kind = child.get("class", "")
            if tag == "g":
                number = child.get("data-block")
                if number is not None:
                    self.blocks.add(int(number))
                shift = re.fullmatch(
                    r"translate\(([-\d.]+) ([-\d.]+)\)", child.get("transform", "")
                )
                ox, oy = (float(shift[1]), float(shift[2])) if shift else (0.0, 0.0)
                self.walk(child, dx + ox, dy + oy, int(number) if number else block)
            elif tag == "use":
                shape = self.shapes[child.get(XLINK, "").lstrip("#")]
                self.walk(
                    shape, dx + float(child.get("x", 0)), dy + float(child.get("y", 0)), block
                )
            elif tag == "circle" and kind == "hole":
                self.holes.append(
                    (r(float(child.get("cx", 0)) + dx), r(float(child.get("cy", 0)) + dy))
                )
            elif tag == "path" and kind == "hole":
                # A large drawing's holes: one path of circles, each two half circles.
                for start, end in _segments(child.get("d", ""))[::2]:
                    self.holes.append((r((start[0] + end[0]) / 2 + dx), r(start[1] + dy)))
            elif tag == "path" and kind in ("rapid", "feed"):
                for start, end in _segments(child.get("d", "")):
                    moved = ((r(start[0] + dx), r(start[1] + dy)), (r(end[0] + dx), r(end[1] + dy)))
                    self.segments[(kind, *moved)] += 1


def hole_marks(holes: list[tuple[float, float]]) -> Counter[Segment]:
    """Holes as zero-length segments (to compare them the same way)."""
    return Counter(("hole", h, h) for h in holes)


def _segments(d: str) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """The (start, end) of each line and arc of a path's `d`."""
    found = []
    at = (0.0, 0.0)
    for command, numbers in re.findall(r"([MLA])([^MLA]*)", d):
        values = [float(v) for v in numbers.split()]
        end = (values[-2], values[-1])
        if command != "M":
            found.append((at, end))
        at = end
    return found


def expected(program: Program) -> tuple[Counter[Segment], list[tuple[float, float]]]:
    """Every XY motion of the compiled path, move by move (a full circle as two halves,
    as SVG draws it), and every hole."""
    path = compile_program(program).path
    unit = path.units.nm
    x, y = path.start[0], path.start[1]
    segments: Counter[Segment] = Counter()
    holes: list[tuple[float, float]] = []

    def p(a: float, b: float) -> tuple[float, float]:
        return (r(a / unit), r(b / unit))

    for chunk in path.chunks():
        holes += [p(h.x, h.y) for h in chunk.hole_spans()]
        for op, _tag, _block, nx, ny, _z, cx, cy, _feed, _value in chunk.rows.tolist():
            if op > Op.ARC_CCW:
                continue
            kind = "rapid" if op == Op.RAPID else "feed"
            if op >= Op.ARC_CW and (nx, ny) == (x, y):
                segments[(kind, p(x, y), p(2 * cx - x, 2 * cy - y))] += 1
                segments[(kind, p(2 * cx - x, 2 * cy - y), p(nx, ny))] += 1
            elif (nx, ny) != (x, y):
                segments[(kind, p(x, y), p(nx, ny))] += 1
            x, y = nx, ny
    return segments, holes


@pytest.mark.parametrize("name", CASES)
def test_drawing_is_exactly_the_compiled_moves(name: str) -> None:
    program = load(name)
    flat = Flat(draw(program))
    segments, holes = expected(program)
    assert same(flat.segments, segments, program.units.dump_places)
    assert same(hole_marks(flat.holes), hole_marks(holes), program.units.dump_places)


@pytest.mark.parametrize("family", ["grid", "bolts", "pockets"])
def test_looped_families_draw_every_pattern_in_place(family: str) -> None:
    program = sized(family, 30_000)
    svg = draw(program)
    flat = Flat(svg)
    segments, holes = expected(program)
    assert same(flat.segments, segments, program.units.dump_places)
    assert same(hole_marks(flat.holes), hole_marks(holes), program.units.dump_places)
    # Drawn once, placed many times: the drawing is a small fraction of the moves.
    assert svg.count("<use") > 10 and len(svg) < 30_000 * 10


def test_every_block_that_moves_is_linkable() -> None:
    program = load("contour-cut-right")
    drawing = render(program)
    moving = set()
    for chunk in compile_program(program).path.chunks():
        rows = chunk.rows[chunk.rows["op"] <= Op.ARC_CCW]
        moving |= set(rows["block"].tolist())
    assert moving - {0} <= Flat(drawing.svg).blocks == set(drawing.blocks)


def test_arcs_stay_arcs_with_the_right_sweep() -> None:
    """contour-cut-right: the QCIR CC of block 3 (offset: radius 0.75) ends at (3.75, 0.5).

    The page is flipped (scale(1,-1)), so a counter-clockwise arc has SVG sweep flag 1.
    """
    svg = draw(load("contour-cut-right"))
    assert "A0.75 0.75 0 0 1 3.75 0.5" in svg


def test_the_programmed_contour_is_drawn_with_the_tool_centre() -> None:
    """contour-cut-right: the tool (0.5 in, CUT RT) runs 0.25 in off the contour; the
    contour itself is block 3's quarter circle of radius 0.5 to (3.5, 0.5)."""
    svg = draw(load("contour-cut-right"))
    block3 = re.search(r'<g class="block" data-block="3">(.*?)</g>', svg)
    assert block3 is not None
    assert '<path class="contour" d="M3 0 A0.5 0.5 0 0 1 3.5 0.5"/>' in block3[1]
    pocket = draw(load("circle-pocket"))
    assert re.search(r'<circle class="contour" cx="[-\d.]+" cy="[-\d.]+" r="[\d.]+"/>', pocket)


def test_part_zero_and_the_stock_outline() -> None:
    """Without a stock the outline is the reach of the cuts (tool radius included) plus
    the simulation's 0.1 in margin, rounded out to 0.05 in; with one, it is the stock."""
    program = load("contour-cut-right")
    svg = draw(program)
    assert '<g class="zero">' in svg
    # The 0.5 in tool's centre reaches x -0.25…3.75 and y -0.25…3.5: ± 0.25, + 0.1.
    assert '<rect x="-0.65" y="-0.6" width="4.75" height="4.7"/>' in svg
    stock = Stock(x=D(-1), y=D(-1), z=D(0), xl=D(6), yw=D(5), zh=D(1))
    given = draw(Program(**{**program.__dict__, "stock": stock}))
    assert '<rect x="-1" y="-1" width="6" height="5"/>' in given


def test_holes_are_numbered_in_the_order_they_are_cut() -> None:
    svg = draw(load("loop-rep-grid"))
    labels = re.findall(r'<text x="([-\d.]+)" y="([-\d.]+)">(\d+)</text>', svg)
    holes = expected(load("loop-rep-grid"))[1]
    assert [int(k) for _, _, k in labels] == list(range(1, len(holes) + 1))
    # Each number sits up and right of its hole (the text is outside the flipped page).
    for (x, y, _), (hx, hy) in zip(labels, holes, strict=True):
        assert float(x) > hx and -float(y) > hy
    many = draw(sized("grid", 20_000))
    assert "<text" not in many
    assert HOLE_LABELS < 1_000


def test_a_problem_block_is_red_with_its_messages() -> None:
    svg = draw(load("drill-single"), problems={1: ["FEEDR Z: 900 ipm is above the limit"]})
    assert (
        '<g class="block problem" data-block="1"><title>block 1: FEEDR Z: 900 ipm is above '
        "the limit</title>" in svg
    )


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
    program = ten_thousand()
    svg = draw(program)
    assert len(svg.encode()) < 200_000, f"{len(svg.encode())} bytes"
    holes = Flat(svg).holes
    assert len(holes) == 10_000
    assert same(hole_marks(holes), hole_marks(expected(program)[1]), 4)


def test_same_program_same_bytes() -> None:
    program = load("circle-pocket")
    assert draw(program) == draw(program)


def test_the_svg_export_of_a_large_program_keeps_no_list_of_its_moves() -> None:
    # Issue 18: every export's memory stays flat in program size. The svg target drew from
    # the compiled tree but was handed every move as an object first (218 MB at 10^6 moves).
    # 100 000 moves as objects are more than 20 MB; the drawing and the tree's arrays are
    # well under 5 MB.
    made, peak = traced_export(sized("grid", 100_000), "svg")
    assert b"<svg" in made.head(200)
    assert peak < 5_000_000, f"the svg export allocated {peak / 1e6:.1f} MB at its peak"


def _edits(program: Program, count: int, seed: int) -> Iterator[tuple[str, Program]]:
    """`count` edits in turn, as an editor makes them: a block moved (an ABS one, or an INC
    one that moves every block after it), a feed out of range (an error: the block is
    drawn in red, or left out) and back, two blocks swapped, one deleted, one inserted."""
    rng = random.Random(seed)
    blocks = list(program.blocks)
    for _ in range(count):
        how = rng.choice(["move", "move", "feed", "swap", "delete", "insert"])
        k = rng.randrange(len(blocks))
        block = blocks[k]
        x = getattr(block, "x", None)
        if how == "move" and x is not None:
            step = D(rng.randrange(1, 9)) / 10
            moved: dict[str, Any] = {"x": x + step}  # not every kind has X: mypy cannot know
            blocks[k] = dataclasses.replace(block, **moved)
        elif how == "feed" and getattr(block, "feed_z", None) is not None:
            feed = D(900) if rng.random() < 0.5 else D(5)
            fed: dict[str, Any] = {"feed_z": feed}
            blocks[k] = dataclasses.replace(block, **fed)
        elif how == "swap" and k + 1 < len(blocks):
            blocks[k], blocks[k + 1] = blocks[k + 1], blocks[k]
        elif how == "delete" and len(blocks) > 2:
            del blocks[k]
        else:
            blocks.insert(k, blocks[rng.randrange(len(blocks))])
        yield how, dataclasses.replace(program, blocks=tuple(blocks))


def test_a_drawing_kept_per_node_is_the_drawing_made_afresh() -> None:
    """The editor's preview keeps each top-level node's drawing (render(keep=True)) and an
    edit draws only the nodes it changed. After every edit of a sequence (blocks moved,
    INC blocks moving all after them, errors made and fixed, swaps, deletes, inserts; LOOPs
    whose patterns are <defs> numbered in order), the drawing is byte for byte the one
    drawn with nothing kept, problems and all."""
    from app.web.preview import preview

    program = editor_program(60)
    for k, (how, edited) in enumerate(_edits(program, 60, seed=32)):
        assert preview(edited).svg == preview(edited, keep=False).svg, (k, how)


@pytest.mark.parametrize("name", CASES)
def test_a_drawing_splits_into_what_a_patch_compares(name: str) -> None:
    """An edit's reply compares drawings by their containers' children (app/web/preview.py
    `parts`): every golden program's preview drawing, and its golden SVG export (embedded
    style) where there is one, splits into parts that put together again are the drawing,
    byte for byte."""
    from app.web.preview import CONTAINERS, parts, preview

    drawings = [preview(load(name)).svg]
    export = GOLDEN / name / "expected.svg"
    if export.exists():
        drawings.append(export.read_text())
    for svg in drawings:
        split = parts(svg)
        again = split.head
        for container in CONTAINERS:
            if container in split.containers:
                open_tag, children = split.containers[container]
                close = "</defs>" if container == "defs" else "</g>"
                again += open_tag + "".join(children) + close
        assert again + "</svg>\n" == svg


def test_a_kept_drawing_is_drawn_again_for_other_problems() -> None:
    """The same nodes with other messages for their blocks (say an error found elsewhere
    names block 3): the kept drawing is not used, block 3 is red with the new message."""
    program = editor_program(20)
    path = compile_program(program).path
    plain = render(program, path, keep=True).svg
    said = {3: ["FEEDR Z: too fast"]}
    red = render(program, path, keep=True, problems=said).svg
    assert red == render(program, path, problems=said).svg != plain
    assert "block 3: FEEDR Z: too fast" in red
    assert render(program, path, keep=True).svg == plain
