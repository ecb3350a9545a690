"""FreeCAD's LinuxCNC post, drilling (issue 36): what it writes imports as a program
without errors, that can be written as the JSON document, with its holes where rs274
drills them.

The two files are written here exactly as the post writes a Drilling operation
(tests/imports/gcode-corpus/SOURCES.md): the current post, inches, `G0 X Y` before each
cycle line and a tool from FreeCAD's library numbered 32; the older post, millimetres, a
G83 whose Q makes 70 pecks and a G81 operation.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from app.cnc import document
from app.cnc.blocks import BoltCircle, Hole, Program
from app.cnc.formats.reading import ImportFailure, read_program
from app.cnc.formats.targets import export
from app.cnc.interpret import interpret
from app.cnc.toolpath import Feed
from app.cnc.validate import validate
from tests.referee import RS274, rs274

CORPUS = Path(__file__).parent / "imports" / "gcode-corpus" / "freecad-linuxcnc"
CURRENT = CORPUS / "drilling-g83-inch.ngc"
OLDER = CORPUS / "drilling-g83-g81-mm.ngc"


def imported(path: Path) -> tuple[Program, list[str]]:
    result = read_program(path.read_bytes(), path.stem)
    assert result.format == "gcode"
    return result.program, [str(n) for n in result.report]


def errors(program: Program) -> list[str]:
    return [str(p) for p in validate(program) if p.severity.value == "error"]


def holes(program: Program) -> list[tuple[float, float, float]]:
    """Where the tool path feeds deepest at each X/Y, in the program's unit."""
    toolpath = interpret(program)
    unit = program.units.nm
    deepest: dict[tuple[float, float], float] = {}
    for move in toolpath.moves:
        if isinstance(move, Feed):
            at = (round(move.x / unit, 3), round(move.y / unit, 3))
            deepest[at] = min(deepest.get(at, 0.0), round(move.z / unit, 3))
    return sorted((x, y, z) for (x, y), z in deepest.items())


def rs274_holes(path: Path, tmp_path: Path) -> list[tuple[float, float, float]]:
    copy = tmp_path / path.name
    copy.write_bytes(path.read_bytes())
    deepest: dict[tuple[float, float], float] = {}
    for m in rs274(copy, diameters={32: 0.1875}):
        if m.kind == "F":
            at = (round(m.end[0], 3), round(m.end[1], 3))
            deepest[at] = min(deepest.get(at, 0.0), round(m.end[2], 3))
    return sorted((x, y, z) for (x, y), z in deepest.items())


@pytest.mark.parametrize("path", [CURRENT, OLDER], ids=["current", "older"])
def test_freecad_drilling_imports_as_a_program_without_errors(path: Path) -> None:
    """Before: the current post's file was refused at its first `G0 X Y` after a cycle (read
    as the ProtoTRAK's hole-on-every-line ambiguity, though the next line drills there),
    and the older one imported with errors: # PECK 70 (G83 Q0.1 from R2 to Z-5; the control
    has at most 40) — as did tool 32 in the current one (the control has tools 1-24)."""
    program, report = imported(path)
    assert errors(program) == [], report
    text = document.dumps(program)
    assert document.loads(text) == program
    export(program, "json")


def test_the_current_posts_file_reads_its_tool_32_as_tool_1_and_pecks_at_most_40() -> None:
    program, report = imported(CURRENT)
    drills = [b for b in program.blocks if isinstance(b, Hole)]
    assert {b.tool for b in drills} == {1} and {b.pecks for b in drills} == {40}
    assert [t.number for t in program.block0.tools] == [1]
    assert any("tool 32 is tool 1 here: the control has tools 1 to 24" in n for n in report)
    assert any("57 pecks of Q0.015 in: MillBlocks drills at most 40" in n for n in report)


def test_the_older_posts_g83_pecks_at_most_40_and_says_so() -> None:
    program, report = imported(OLDER)
    pecks = {b.z_dn: b.pecks for b in program.blocks if isinstance(b, Hole)}
    assert pecks == {-5: 40, -3: 1}, pecks
    assert any("70 pecks of Q0.1 mm: MillBlocks drills at most 40" in n for n in report)
    assert not any(isinstance(b, BoltCircle) for b in program.blocks)


@pytest.mark.skipif(RS274 is None, reason="rs274 (linuxcnc-uspace) not installed")
@pytest.mark.parametrize("path", [CURRENT, OLDER], ids=["current", "older"])
def test_freecad_holes_are_where_rs274_drills_them(path: Path, tmp_path: Path) -> None:
    program, _ = imported(path)
    assert holes(program) == rs274_holes(path, tmp_path)


def test_a_g0_after_a_cycle_that_goes_elsewhere_is_still_refused_naming_its_line() -> None:
    """`G0 X Y` after a cycle, then a move elsewhere: no cycle follows at that point, so
    whether the ProtoTRAK's hole on every line is meant still cannot be told."""
    text = "G20\nG0 X0 Y0 Z1\nG81 X1 Y1 R0.1 Z-0.5 F5\nG0 X2 Y2\nG0 X3 Y3\nM30\n"
    with pytest.raises(ImportFailure, match="line 4, column 1: G0 right after a canned cycle"):
        read_program(text.encode(), "t", "gcode")


def test_a_g0_after_a_cycle_at_the_end_of_the_file_is_still_refused() -> None:
    text = "G20\nG0 X0 Y0 Z1\nG81 X1 Y1 R0.1 Z-0.5 F5\nG0 X2 Y2\nM30\n"
    with pytest.raises(ImportFailure, match="line 4, column 1: G0 right after a canned cycle"):
        read_program(text.encode(), "t", "gcode")
