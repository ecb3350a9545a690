"""Cutter compensation (G41/G42 with D) in imported G-code, held to LinuxCNC's `rs274`
(issue 36): a compensated contour where MillBlocks' CUT LT/RT cuts the control's path, the
tool-centre path otherwise, each said in the report; a change of compensation inside one
plunge starts a new mill sequence instead of refusing the file.

rs274 applies the compensation (its tool table gives the diameters), so what it cuts
reading the file is compared with what it cuts reading our LinuxCNC export of the imported
program — the tool-centre path MillBlocks plans — within 0.001 in (tests/referee.py
`referee_import`, `cut_path`: every feed move from where it starts to where it ends, at its
depth and feed; MillBlocks coming down again where compensation changes cuts nothing new).
"""

from __future__ import annotations

import math
import random
from dataclasses import replace
from decimal import Decimal
from pathlib import Path

import pytest

from app.cnc.blocks import Comp, Hole, Program
from app.cnc.formats.reading import ImportFailure, read_program
from app.cnc.formats.targets import export
from app.cnc.recognition.compensation import CompError, Cut, control_path
from app.cnc.units import Units
from app.cnc.validate import validate
from tests.referee import RS274, assert_same_cuts, cut_path, referee_import, rs274, rs274_reads

CORPUS = Path(__file__).parent / "imports" / "gcode-corpus" / "linuxcnc"
INCH = 25_400_000

needs_rs274 = pytest.mark.skipif(RS274 is None, reason="rs274 (linuxcnc-uspace) not installed")


def imported(text: str) -> tuple[Program, list[str]]:
    result = read_program(text.encode(), "comp", "gcode")
    return result.program, [str(n) for n in result.report]


def with_diameters(program: Program, diameters: dict[int, str]) -> Program:
    """The program with the DIA the operator enters for each tool (as the tool table has
    it)."""
    tools = tuple(
        replace(t, diameter=Decimal(diameters[t.number])) if t.number in diameters else t
        for t in program.block0.tools
    )
    return replace(program, block0=replace(program.block0, tools=tools))


def errors(program: Program) -> list[str]:
    return [str(p) for p in validate(program) if p.severity.value == "error"]


# -- LinuxCNC's own examples -----------------------------------------------------------------


@needs_rs274
def test_comp_g1_imports_its_change_of_compensation_as_a_new_sequence(tmp_path: Path) -> None:
    """Before: refused, "cutter compensation changes inside a mill sequence" (the G40 exit
    move after the contour). The file's tool 4 is 1 in across only in a comment: with that
    diameter known (G10 L1, as a tool table gives it) the control's entry cuts the first
    arc's offset short (a concave corner), which MillBlocks' CUT LT cannot do, so the
    contour is read as the tool-centre path rs274 cuts, and the report says so."""
    text = "G20\nG10 L1 P4 R0.5\n" + (CORPUS / "comp-g1.ngc").read_text()
    program, report = imported(text)
    assert any(
        "cutter compensation left (G41, tool 4 of diameter 1 in) read as the tool-centre path" in n
        for n in report
    ), report
    assert not any(isinstance(b, Hole) and b.comp is not Comp.NONE for b in program.blocks)
    assert [e for e in errors(program) if "RPM" not in e] == []
    referee_import(text.encode(), tmp_path, "comp", {4: 1.0})


@needs_rs274
def test_comp_g1_without_the_diameter_is_a_compensated_contour(tmp_path: Path) -> None:
    """As LinuxCNC ships it, the file leaves the diameter to the tool table: the contour is
    a DRILL CUT LT whose entry and exit moves are its first and last cuts, the report says
    the path cannot be checked and asks for the diameter. With DIA 1.0 entered, every cut
    between the entry and the exit is rs274's."""
    text = (CORPUS / "comp-g1.ngc").read_text()
    program, report = imported(text)
    assert any("the control's path cannot be checked" in n for n in report), report
    assert any("needs: line 28: tool 4's diameter (DIA in Data Block 0)" in n for n in report)
    [drill] = [b for b in program.blocks if isinstance(b, Hole) and b.comp is Comp.LEFT]
    assert (drill.x, drill.y) == (Decimal("0.000"), Decimal("3.500"))
    program = with_diameters(program, {4: "1.0"})
    assert [e for e in errors(program) if "RPM" not in e] == []
    original, ours = tmp_path / "original.ngc", tmp_path / "ours.ngc"
    original.write_text(text)
    ours.write_bytes(export(program, "gcode-linuxcnc", {"spindle-speeds": "by-hand"}).data)
    theirs = cut_path(rs274(original, diameters={4: 1.0}, in_mm=True, changes=True))
    mine = cut_path(rs274(ours, in_mm=True, changes=True))
    # The uncompensated outline (a plunge and 6 cuts), then the contour: the entry and exit
    # moves differ (the control starts and ends them on the programmed points), and
    # MillBlocks joins the last arc to the offset exit line (it trims the arc's end); every
    # cut between is rs274's.
    outline = 7
    assert_same_cuts(theirs[:outline], mine[:outline], 0.0254 + 1e-6, 2.54)
    assert_same_cuts(theirs[outline + 2 : -2], mine[outline + 2 : -2], 0.0254 + 1e-6, 2.54)


@needs_rs274
@pytest.mark.parametrize("name", ["comp311.ngc", "comp311_2.ngc"])
def test_a_tangent_entry_is_a_compensated_contour_that_cuts_as_rs274(
    name: str, tmp_path: Path
) -> None:
    """LinuxCNC's Figure 3 entry moves, a line (comp311) and an arc (comp311_2) into the
    contour: the control's entry ends where MillBlocks' CUT LT goes down, so the contour is
    a compensated DRILL CUT LT of its own after the entry move, and the whole cut is
    rs274's."""
    text = "G20\nG10 L1 P4 R0.5\n" + (CORPUS / name).read_text()
    program, report = imported(text)
    assert any(
        "a compensated contour, DRILL CUT LT, which cuts the control's path" in n for n in report
    )
    assert [b.comp for b in program.blocks if isinstance(b, Hole)] == [
        Comp.NONE,
        Comp.NONE,
        Comp.LEFT,
    ]
    referee_import(text.encode(), tmp_path, "comp", {4: 1.0})


# -- compensation changing inside one plunge ------------------------------------------------

POCKET_AND_PROFILE = """G20 G90 G17
G10 L1 P2 R0.125
T2 M6
S1200 M3
G0 X-1 Y-1 Z0.1
G1 Z-0.2 F5
G41 D2 G1 X0 Y0 F20
G1 X3
G1 Y2
G1 X0
G1 Y0
G40 G1 X-1 Y-1
G1 X-0.5 Y-1.5
G42 D2 G1 X0.5 Y0.5
G1 Y1.5
G1 X2.5
G1 Y0.5
G1 X0.5
G40 G1 X1 Y1
G0 Z1
M30
"""


@needs_rs274
def test_each_change_of_compensation_starts_a_sequence_and_cuts_as_rs274(
    tmp_path: Path,
) -> None:
    """Left round the outside, then (still at depth) right round a window: each compensated
    contour is a DRILL of its own, the moves between them the tool centre's, all cut where
    rs274 cuts them."""
    program, report = imported(POCKET_AND_PROFILE)
    comps = [b.comp for b in program.blocks if isinstance(b, Hole)]
    assert comps == [Comp.NONE, Comp.LEFT, Comp.NONE, Comp.RIGHT, Comp.NONE], report
    assert sum("which cuts the control's path" in n for n in report) == 2
    assert [e for e in errors(program) if "RPM" not in e] == []
    referee_import(POCKET_AND_PROFILE.encode(), tmp_path, "comp", {2: 0.25})


def test_g41_while_compensating_is_refused_as_rs274_refuses_it() -> None:
    with pytest.raises(ImportFailure, match="line 4, column 1: G42 while cutter compensation"):
        read_program(b"G20\nG0 X0 Y0 Z0\nG41 G1 Z-1 F5\nG42 X1\n", "t", "gcode")


def test_an_arc_right_after_g40_is_refused_as_rs274_refuses_it() -> None:
    text = "G20\nG0 X-1 Y0 Z0\nG1 Z-0.1 F5\nG41 X0 Y0\nX1\nG40 G2 X2 Y0 I0.5 J0\nM30\n"
    with pytest.raises(ImportFailure, match="line 6, column 5: an arc right after G40"):
        read_program(text.encode(), "t", "gcode")


def test_a_rapid_across_with_compensation_on_is_refused_naming_the_line() -> None:
    text = "G20\nG0 X-1 Y0 Z0.1\nG41 D1\nG0 X0 Y0\nG1 Z-0.1 F5\nX1\nG40\nM30\n"
    with pytest.raises(ImportFailure, match="line 4, column 1: a rapid move in X/Y with cutter"):
        read_program(text.encode(), "t", "gcode")


def test_what_rs274_refuses_is_refused_naming_the_line() -> None:
    """An entry move no longer than the tool radius (rs274: "Length of cutter compensation
    entry move is not greater than the tool radius")."""
    text = "G20\nG10 L1 P1 R0.5\nG0 X-0.3 Y0 Z0.1\nG1 Z-0.1 F5\nG41 X0 Y0\nX1\nG40\nM30\n"
    with pytest.raises(ImportFailure, match=r"line 5: cutter compensation .*entry move is not"):
        read_program(text.encode(), "t", "gcode")


def test_the_existing_reading_of_a_compensated_plunge_is_kept() -> None:
    """G42 on the plunge with no diameter in the file: the compensated contour with the
    entry move as its first cut (docs/imports.md), reported as not checked."""
    text = (
        "G20 G90 G17\nG43 H1\nS1000 M3\nG0 Z0.1\nG0 X0 Y0\nG42 G1 Z-0.2 F4\nX2 F10\nY1\n"
        "G40 G0 Z0.1\nM30\n"
    )
    program, report = imported(text)
    [drill, *_] = program.blocks
    assert isinstance(drill, Hole) and drill.comp is Comp.RIGHT
    assert any("cannot be checked" in n for n in report)


# -- the control's compensation, generated contours ------------------------------------------


def _contour(rng: random.Random) -> tuple[str, list[Cut], tuple[float, float], bool, float]:
    """A closed contour of 3-7 lines and arcs round the origin, entered from outside."""
    k = rng.randint(3, 7)
    points = []
    for i in range(k):
        a = 2 * math.pi * i / k + rng.uniform(-0.3, 0.3)
        radius = rng.uniform(1.0, 2.5)
        points.append((round(radius * math.cos(a), 4), round(radius * math.sin(a), 4)))
    if rng.random() < 0.5:
        points.reverse()
    a = rng.uniform(0, 2 * math.pi)
    start = (round(4 * math.cos(a), 4), round(4 * math.sin(a), 4))
    left = rng.random() < 0.5
    radius = rng.choice([0.05, 0.125, 0.25])

    def nm(v: float) -> int:
        return round(v * INCH)

    lines = [f"G4{1 if left else 2} D1 G1 X{points[0][0]} Y{points[0][1]}"]
    cuts = [Cut(0, (nm(points[0][0]), nm(points[0][1])), None, False)]
    prev = points[0]
    for p in [*points[1:], points[0]]:
        if rng.random() < 0.4:
            mx, my = (prev[0] + p[0]) / 2, (prev[1] + p[1]) / 2
            dx, dy = p[0] - prev[0], p[1] - prev[1]
            length = math.hypot(dx, dy)
            h = rng.uniform(-1.5, 1.5) * length
            ci = round(mx - dy / length * h - prev[0], 4)
            cj = round(my + dx / length * h - prev[1], 4)
            clockwise = rng.random() < 0.5
            lines.append(f"G{2 if clockwise else 3} X{p[0]} Y{p[1]} I{ci} J{cj}")
            centre = (nm(prev[0] + ci), nm(prev[1] + cj))
            cuts.append(Cut(len(cuts), (nm(p[0]), nm(p[1])), centre, clockwise))
        else:
            lines.append(f"G1 X{p[0]} Y{p[1]}")
            cuts.append(Cut(len(cuts), (nm(p[0]), nm(p[1])), None, False))
        prev = p
    text = (
        f"G20 G17 G90\nG10 L1 P1 R{radius}\nT1 M6\nS1000 M3\n"
        f"G0 X{start[0]} Y{start[1]} Z0.1\nG1 Z-0.1 F10\n"
        + "\n".join(lines)
        + "\nG40\nG0 Z1\nM30\n"
    )
    return text, cuts, start, left, radius


@needs_rs274
@pytest.mark.parametrize("seed", range(24))
def test_generated_contours_cut_as_rs274_cuts_them(seed: int, tmp_path: Path) -> None:
    """Contours of lines and arcs in every mix, compensated either side with three tool
    sizes: each imports (as a compensated contour or the tool-centre path) and cuts as
    rs274 does, or both refuse it."""
    text, _, _, _, radius = _contour(random.Random(seed))
    path = tmp_path / "comp.ngc"
    path.write_text(text)
    if rs274_reads(path, {1: 2 * radius}):
        referee_import(text.encode(), tmp_path, "comp", {1: 2 * radius})
    else:
        with pytest.raises(ImportFailure):
            read_program(text.encode(), "t", "gcode")


@needs_rs274
@pytest.mark.parametrize("seed", range(100, 160))
def test_the_controls_compensation_is_rs274s(seed: int, tmp_path: Path) -> None:
    """`control_path`, the importer's model of the control's compensation, gives rs274's
    tool-centre moves within 0.0002 in, or refuses what rs274 refuses."""
    text, cuts, start, left, radius = _contour(random.Random(seed))
    path = tmp_path / "comp.ngc"
    path.write_text(text)
    origin = (round(start[0] * INCH), round(start[1] * INCH))
    try:
        theirs = rs274(path, diameters={1: 2 * radius})
    except AssertionError:
        with pytest.raises(CompError):
            control_path(origin, cuts, left, radius * INCH, Units.INCH)
        return
    pieces = control_path(origin, cuts, left, radius * INCH, Units.INCH)
    moves = [m for m in theirs if m.kind != "T" and m.end[2] == -0.1]
    moves = [m for m in moves if (m.end[0], m.end[1]) != start]
    assert len(moves) == len(pieces)
    for m, p in zip(moves, pieces, strict=True):
        assert (m.kind == "A") == (p.centre is not None)
        assert math.dist(m.end[:2], (p.end[0] / INCH, p.end[1] / INCH)) < 2e-4
        if p.centre is not None:
            assert m.centre is not None
            assert math.dist(m.centre, (p.centre[0] / INCH, p.centre[1] / INCH)) < 2e-4
