"""Mirror image: the mirrored program cuts the reflected part, measured on the finished
contour and the holes, with each cut's milling direction kept (signed area)."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import pytest
from shapely.geometry import LineString, Point

from app.cnc import document
from app.cnc.blocks import Hole, Program
from app.cnc.geometry import resolve_xy
from app.cnc.interpret import interpret
from app.cnc.mirror import Axis, mirror
from app.cnc.plane import sample
from app.cnc.problems import Severity
from app.cnc.sequences import programmed_contour
from app.cnc.structure import mill_sequence_end, starts_mill_sequence
from app.cnc.toolpath import ArcFeed, Dwell, Feed, Rapid, Toolpath
from app.cnc.units import to_nm
from app.cnc.validate import validate

GOLDEN = Path(__file__).parent / "golden"
CASES = [
    "contour-cut-right",
    "contour-cut-left-inside-corners",
    "mill-contour-uncompensated",
    "bolt-circle-drill",
    "loop-rep-grid",
    "loop-bolt-circle",
    "loop-nested-3-deep",
    "frame-pocket",
    "frame-out-tan",
    "circle-in-tan",
    "print-line-tangent-arc",
    "print-intersections",
    "print-arc-tangent-arc-mm",
    "print-conrad-chamfer",
    "print-conrad-chamfer-mm",
    "print-line-line-mm",
]
SIGN = {Axis.X: (-1, 1), Axis.Y: (1, -1), Axis.XY: (-1, -1)}


def load(name: str) -> Program:
    return document.loads((GOLDEN / name / "program.json").read_text())


def holes(toolpath: Toolpath) -> list[tuple[int, int]]:
    x, y = toolpath.start[:2]
    found = []
    for move in toolpath.moves:
        if isinstance(move, Rapid | Feed | ArcFeed):
            x, y = move.x, move.y
        elif isinstance(move, Dwell):
            found.append((x, y))
    return found


def cut_points(toolpath: Toolpath, tags: tuple[str, ...] = ("",)) -> list[tuple[float, float]]:
    """Points along the XY feed moves at depth, 0.002 in apart, in inches."""
    unit = toolpath.units.nm
    x, y, z = toolpath.start
    points: list[tuple[float, float]] = []
    for move in toolpath.moves:
        if not isinstance(move, Rapid | Feed | ArcFeed):
            continue
        cutting = not isinstance(move, Rapid) and move.tag in tags and move.z == z
        if cutting and ((move.x, move.y) != (x, y) or isinstance(move, ArcFeed)):
            if isinstance(move, ArcFeed):
                radius = math.dist((x, y), (move.cx, move.cy))
                a0 = math.atan2(y - move.cy, x - move.cx)
                a1 = math.atan2(move.y - move.cy, move.x - move.cx)
                turn = ((a0 - a1) if move.clockwise else (a1 - a0)) % (2 * math.pi) or 2 * math.pi
                n = max(2, math.ceil(radius * turn / unit / 0.002))
                sign = -1 if move.clockwise else 1
                points += [
                    (
                        (move.cx + radius * math.cos(a0 + sign * turn * i / n)) / unit,
                        (move.cy + radius * math.sin(a0 + sign * turn * i / n)) / unit,
                    )
                    for i in range(n + 1)
                ]
            else:
                n = max(1, math.ceil(math.dist((x, y), (move.x, move.y)) / unit / 0.002))
                points += [
                    ((x + (move.x - x) * i / n) / unit, (y + (move.y - y) * i / n) / unit)
                    for i in range(n + 1)
                ]
        x, y, z = move.x, move.y, move.z
    return points


def signed_area(points: list[tuple[float, float]]) -> float:
    return sum(a[0] * b[1] - b[0] * a[1] for a, b in itertools.pairwise(points)) / 2


@pytest.mark.parametrize("axis", list(Axis))
@pytest.mark.parametrize("name", CASES)
def test_mirrored_program_is_valid_and_drills_the_reflected_holes(name: str, axis: Axis) -> None:
    original = load(name)
    result = mirror(original, axis)
    assert [str(p) for p in validate(result.program) if p.severity is Severity.ERROR] == []
    sx, sy = SIGN[axis]
    expected = sorted((sx * x, sy * y) for x, y in holes(interpret(original)))
    actual = sorted(holes(interpret(result.program)))
    assert len(actual) == len(expected)
    for (ax, ay), (ex, ey) in zip(actual, expected, strict=True):
        assert abs(ax - ex) <= 2 and abs(ay - ey) <= 2  # nanometres: bolt-circle rounding


def finished_contours(program: Program) -> list[tuple[LineString, float]]:
    """Each compensated contour's finished surface (densified) and its tool radius, in in."""
    contours = []
    blocks = program.blocks
    reference = (0, 0)
    toolpath = interpret(program)
    unit = toolpath.units.nm
    for index, block in enumerate(blocks):
        if not (isinstance(block, Hole) and starts_mill_sequence(blocks, index)):
            continue
        start = resolve_xy(block.x, block.y, block.mode, block.units, reference)
        mills = tuple(range(index + 1, mill_sequence_end(blocks, index)))
        if block.comp.value == "none":
            continue
        path, _, _ = programmed_contour(blocks, mills, start)
        points = [(p[0] / unit, p[1] / unit) for p, _ in sample(path, unit * 0.0005)]
        tool = program.block0.tool(block.tool)
        assert tool is not None and tool.diameter is not None
        contours.append((LineString(points), float(tool.diameter) / 2))
    return contours


@pytest.mark.parametrize("axis", [Axis.X, Axis.Y])
@pytest.mark.parametrize("name", ["contour-cut-right", "contour-cut-left-inside-corners"])
def test_mirrored_contour_is_cut_one_radius_from_the_reflected_surface(
    name: str, axis: Axis
) -> None:
    """The original finished contour, reflected, is where the mirrored tool path keeps its
    radius: the part is the mirror image, compensation side kept."""
    original = load(name)
    sx, sy = SIGN[axis]
    [(contour, radius)] = finished_contours(original)
    reflected = LineString([(sx * x, sy * y) for x, y in contour.coords])
    mirrored = interpret(mirror(original, axis).program)
    points = cut_points(mirrored)
    distances = [reflected.distance(Point(p)) for p in points]
    assert min(distances) == pytest.approx(radius, abs=1e-4)
    assert max(distances) == pytest.approx(radius, abs=1e-4)


@pytest.mark.parametrize("axis", [Axis.X, Axis.Y])
@pytest.mark.parametrize(
    "name", ["contour-cut-right", "frame-pocket", "frame-out-tan", "circle-in-tan"]
)
def test_each_cut_keeps_its_milling_direction(name: str, axis: Axis) -> None:
    """A pure reflection would flip the travel direction (the 1704's mirror switches turn
    climb into conventional); the mirrored program goes round the same way as the original,
    seen from above: the signed area keeps its sign."""
    original = cut_points(interpret(load(name)))
    mirrored = cut_points(interpret(mirror(load(name), axis).program))
    assert signed_area(original) != 0
    assert (signed_area(original) > 0) == (signed_area(mirrored) > 0)


def test_notes_say_what_was_done() -> None:
    result = mirror(load("contour-cut-right"), Axis.X)
    assert result.program.name == "contour-cut-right (mirror X)"
    assert "climb and conventional cuts stay as they were" in result.notes[0]
    assert any("runs backwards" in note for note in result.notes)


@pytest.mark.parametrize("axis", list(Axis))
@pytest.mark.parametrize("name", ["print-conrad-chamfer", "print-conrad-chamfer-mm"])
def test_mirrored_conrads_are_the_reflected_fillets(name: str, axis: Axis) -> None:
    """Issue 33: calculated points are written typed (to the programming resolution), and
    run backwards each conrad moves to the block that now ends at its corner: the mirrored
    program cuts the reflected fillets, each about the reflected centre (within the 0.001 in
    / 0.01 mm the typed points were rounded to) and of the same radius."""
    original = load(name)
    sx, sy = SIGN[axis]
    step = 2 * to_nm(original.units.resolution, original.units)

    def fillets(program: Program) -> list[tuple[int, int, int]]:
        return sorted(
            (m.cx, m.cy, round(math.hypot(m.x - m.cx, m.y - m.cy)))
            for m in interpret(program).moves
            if isinstance(m, ArcFeed) and m.tag == "conrad"
        )

    expected = sorted((sx * cx, sy * cy, r) for cx, cy, r in fillets(original))
    actual = fillets(mirror(original, axis).program)
    assert len(actual) == len(expected) == 3
    for got, wanted in zip(actual, expected, strict=True):
        assert all(abs(a - b) <= step for a, b in zip(got, wanted, strict=True)), (got, wanted)
