"""G-code import (RS274/NGC and Fanuc, seed 003's tables), held to seed 003's samples.

§2.2.6.1 (a standard Fanuc 6 post) and §2.2.6.2 (the same post "modified" for the
ProtoTRAK) are the sample part of §2.2.6: two tools drill five holes each on a 1.125 in
radius, a third cuts a circular pocket and a contour. The expected programs are worked out
by hand from the listings, next to each test; the fixture files are the listings as printed
(tests/imports/seed003-2.2.6.*.ngc, the scan's page furniture left out).
"""

from __future__ import annotations

import math
from decimal import Decimal as D
from fractions import Fraction
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.cnc.blocks import ArcEnd, Comp, Hole, HoleOp, MillArc, MillLine, Program
from app.cnc.formats.gcode.reader import USUAL, text_nm, usual_words
from app.cnc.formats.reading import ImportFailure, NoteKind, read_program
from app.cnc.formats.targets import export
from app.cnc.interpret import interpret
from app.cnc.problems import Severity
from app.cnc.toolpath import Feed
from app.cnc.units import Units, half_even
from app.cnc.validate import validate
from tests.imports.support import describe_all, fixture_text
from tests.referee import Motion, referee_import, rs274


def gcode(text: str) -> Program:
    return read_program(text.encode(), "t", "gcode").program


def report(text: str) -> list[str]:
    return [str(n) for n in read_program(text.encode(), "t", "gcode").report]


def failure(text: str) -> str:
    with pytest.raises(ImportFailure) as caught:
        read_program(text.encode(), "t", "gcode")
    return str(caught.value)


# -- seed 003 §2.2.6.1 --------------------------------------------------------------------

# The scan printed N37/N38 as `X0Y-0.510J-0.5`: the I0 between Y-0.5 and J was read as
# part of the number (`-0.5I0` → `-0.510`), as §2.2.6.2 (`Y-0.5 IO J-0.5`) shows.
SCAN_FIX_2_2_6_1 = [
    ("N37G03X0Y-0.510J-0.5F8.0", "N37G03X0Y-0.5I0J-0.5F8.0"),
    ("N38X0Y0.510J0.5", "N38X0Y0.5I0J0.5"),
]

# Worked out from the listing:
# - N1 G92 X0 Y0 Z0: the tool starts at part zero. No G20/G21: inches (§2.2.6.3 is G20).
# - N3-N9: tool 1 (N4 G45 H1) at S1000 M03; G81 R0.05 Z-0.1 F5 from Z0.05 (the initial
#   level is R): DRILL Z UP 0.05, Z DN -0.1, FEEDR Z 5. The holes X0.7955 Y0.7955,
#   X-0.5107 Y1.0024, X-1.1111 Y-0.176, X-0.176 Y-1.1111, X1.0024 Y-0.5107 are
#   1.125·(cos, sin) of 45°, 117°, 189°, 261°, 333°: five holes 72° apart about X0 Y0,
#   taken counter-clockwise. A BOLT CIR (clockwise from the lower centre line) with the
#   same first hole: θ0 = 270° − 45° = 225° (DESIGN.md §3), R 1.125, 5 holes.
# - N13-N20: M06, then G45 H2: tool 2 (the listing writes T1 on every G45 line; the length
#   offset names the tool), Z DN -0.6: the same bolt circle.
# - N24-N33: tool 3 at X0 Y0, G01 Z-0.25 F5 from Z0.05: a DRILL starting a mill sequence;
#   G01 Y0.115 F8; two G03 half circles of radius 0.115 about X0 Y0; G01 Y0.49; two half
#   circles of 0.49: MILL STD, two ARCs, MILL STD, two ARCs.
# - N34-N38: up, over to X0 Y0.5, down again: a new DRILL, two half circles of 0.5.
# - N39-N47: up, over to X0 Y-2.7, down to Z-0.5: a DRILL and the contour: a half circle
#   of 2.7 about X0 Y0 to X0 Y2.7; an arc of 0.25 about X0 Y2.45 to Y2.6611; a line
#   to X-2.2953 Y1.2887; an arc about X-1.7105 Y0.3677 (I0.5848 J-0.921, radius 1.091)
#   to X-2.4678 Y-0.4177; a line to X-0.1735 Y-2.63; an arc of 0.25 about X0 Y-2.45 back
#   to X0 Y-2.7. Values to 0.0001 in become 0.001 in blocks (reported): 2.6611 → 2.661,
#   -2.2953 → -2.295, 1.2887 → 1.289, -2.4678 → -2.468, -0.4177 → -0.418, -0.1735 →
#   -0.174 (half-even); the fillet's centre to Y0.367, the grid point that keeps its
#   two radii closest.
# - N50 G28 X0 Y0: the tool goes to X0 Y0 (the intermediate point) with tool 3: a POS.
EXPECTED_2_2_6_1 = [
    "DRILL X0 Y0 Z0.05/-0.1 F5 T1",
    "BOLT CIR DRILL 5 x R1.125 from 225",
    "DRILL X0 Y0 Z0.05/-0.6 F5 T2",
    "BOLT CIR DRILL 5 x R1.125 from 225",
    "DRILL X0 Y0 Z0.05/-0.25 F5 T3",
    "MILL STD X0 Y0.115 F8",
    "MILL ARC CC XY-CENT X0 Y0 F8",
    "MILL ARC XY-END X0 Y-0.115",
    "MILL ARC CC XY-CENT X0 Y0 F8",
    "MILL ARC XY-END X0 Y0.115",
    "MILL STD X0 Y0.49 F8",
    "MILL ARC CC XY-CENT X0 Y0 F8",
    "MILL ARC XY-END X0 Y-0.49",
    "MILL ARC CC XY-CENT X0 Y0 F8",
    "MILL ARC XY-END X0 Y0.49",
    "DRILL X0 Y0.5 Z0.05/-0.25 F5 T3",
    "MILL ARC CC XY-CENT X0 Y0 F8",
    "MILL ARC XY-END X0 Y-0.5",
    "MILL ARC CC XY-CENT X0 Y0 F8",
    "MILL ARC XY-END X0 Y0.5",
    "DRILL X0 Y-2.7 Z0.05/-0.5 F5 T3",
    "MILL ARC CC XY-CENT X0 Y0 F8",
    "MILL ARC XY-END X0 Y2.7",
    "MILL ARC CC XY-CENT X0 Y2.45 F8",
    "MILL ARC XY-END X-0.134 Y2.661",
    "MILL STD X-2.295 Y1.289 F8",
    "MILL ARC CC XY-CENT X-1.71 Y0.367 F8",
    "MILL ARC XY-END X-2.468 Y-0.418",
    "MILL STD X-0.174 Y-2.63 F8",
    "MILL ARC CC XY-CENT X0 Y-2.45 F8",
    "MILL ARC XY-END X0 Y-2.7",
    "POS X0 Y0 T3",
]


def sample_2_2_6_1() -> str:
    text = fixture_text("seed003-2.2.6.1.ngc")
    for printed, meant in SCAN_FIX_2_2_6_1:
        text = text.replace(printed, meant)
    return text


def test_2_2_6_1_as_printed_refuses_the_scan_damaged_arc() -> None:
    """N37 as printed ends at Y-0.510: 0.51 from the centre X0 Y0 (J-0.5 from X0 Y0.5),
    where it starts 0.5 from it — beyond LinuxCNC's 0.0005 in and 0.1 %: an error naming
    the line (38, as N1 is on line 2) and the column of J."""
    message = failure(fixture_text("seed003-2.2.6.1.ngc"))
    assert message.startswith("line 38, column 16: the arc's end is 0.01 in off its radius")


def test_2_2_6_1_imports_to_ten_holes_and_the_contours() -> None:
    result = read_program(sample_2_2_6_1().encode(), "sample.ngc")
    assert result.format == "gcode"
    program = result.program
    assert program.name == "SAMPLE P/N" and program.units is Units.INCH
    assert describe_all(program) == EXPECTED_2_2_6_1
    db0 = program.block0
    assert db0.current_tool == 1 and db0.z_retract == 0
    assert [(t.number, t.rpm, t.diameter) for t in db0.tools] == [
        (1, 1000, None),
        (2, 1000, None),
        (3, 1000, None),
    ]
    assert [p for p in validate(program) if p.severity is Severity.ERROR] == []
    # The contours' radii, from the blocks (start to centre): 0.115, 0.49, 0.5, 2.7, the
    # corner 0.25, the fillet 1.091 (0.841 + the 0.25 tool radius), the corner 0.25.
    radii = []
    x = y = D(0)
    centre: tuple[D, D] | None = None
    for block in program.blocks:
        if isinstance(block, Hole | MillLine | ArcEnd):
            if isinstance(block, ArcEnd):
                assert centre is not None
                radii.append(round(math.dist((x, y), centre), 3))
            assert block.x is not None and block.y is not None  # an import gives both
            x, y = block.x, block.y
        elif isinstance(block, MillArc):
            assert block.x is not None and block.y is not None
            centre = (block.x, block.y)
    # (1.092 for the fillet: its points rounded to 0.001 in; the file's is 1.0910.)
    assert radii == [0.115, 0.115, 0.49, 0.49, 0.5, 0.5, 2.7, 0.25, 1.092, 0.25]


def test_2_2_6_1_report_says_how_it_was_read() -> None:
    notes = [str(n) for n in read_program(sample_2_2_6_1().encode(), "s").report]
    assert any("no G20/G21" in n and "inches" in n for n in notes)
    assert any("line 5: G45 H1" in n and "§2.2.6.1" in n for n in notes)
    assert any("line 16:" in n and "T1 selected, then H2: read as tool 2" in n for n in notes)
    assert any("line 3: M16: not a code MillBlocks knows" in n for n in notes)
    assert any("G81 does not dwell" in n and "also lines 7, 8, 9, 10" in n for n in notes)
    assert any("counter-clockwise (the ProtoTRAK Plus's order)" in n for n in notes)
    assert any("line 45" in n and "X -2.2953 in → -2.295" in n for n in notes)
    assert any(
        "line 13: G28" in n and "intermediate point" in n and "also lines 24, 50, 51" in n
        for n in notes
    )


# -- seed 003 §2.2.6.2 --------------------------------------------------------------------

# How each odd line of the ProtoTRAK dialect reads, and what makes it readable. Each is an
# error naming the line (the first error stops the import: words are read before motion,
# so the typos come before the missing moves); the fix is what the line is taken to mean.
# Applied in order, they give §2.2.6.1's program.
WALK_2_2_6_2 = [
    # N6-N9, N17-N20: `G00 X… Y…` after `G81`. In RS274 the G00 ends the drilling cycle
    # (no hole); the ProtoTRAK post writes the modal code on every line (§2.1 rule 1) and
    # means a hole. Refused; with the G00 taken out the cycle drills there (§2.2.6.1).
    (
        "line 7, column 4: G0 right after a canned cycle",
        [(f"N{n} G00 X", f"N{n} X") for n in (6, 7, 8, 9, 17, 19, 20)],
    ),
    # N18 `GOO`: the letter O twice where 00 belongs.
    ("line 19, column 5: G needs a number; found 'OO ' (the letter O", [("N18 GOO X", "N18 X")]),
    # N29 `IO`: the letter O where 0 belongs (also N30, N37).
    (
        "line 29, column 20: I needs a number; found 'O J' (the letter O",
        [(" IO ", " I0 ")],
    ),
    # N27 is missing: N26 brings tool 3 down to Z0.05 at rapid and N28 cuts in XY there
    # (the post left out the Z moves for the 2-axis Plus; a 3-axis mill would cut air).
    (
        "line 28: a cut in XY at Z0.05 in, but the tool has not fed down to it",
        [("N28 G01", "N27 G01 Z-0.25 F5.0;\nN28 G01")],
    ),
    # N36 and N41 are missing: the same as N27.
    (
        "line 37: a cut in XY at Z0.05 in",
        [("N37 G03", "N36 G01 Z-0.25 F5.0;\nN37 G03"), ("N42 G03", "N41 G01 Z-0.5 F5.0;\nN42 G03")],
    ),
]


def test_2_2_6_2_each_odd_line_is_an_error_naming_it_and_how_it_reads() -> None:
    text = fixture_text("seed003-2.2.6.2.ngc")
    for expected, fixes in WALK_2_2_6_2:
        message = failure(text)
        assert message.startswith(expected), message
        for printed, meant in fixes:
            assert printed in text
            text = text.replace(printed, meant)
    program = gcode(text)
    assert describe_all(program) == EXPECTED_2_2_6_1


def test_2_2_6_2_dialect_label_and_semicolons() -> None:
    """`%:SAMPLE P/N;` names the program; `;` ends each block (§2.1 rule 3)."""
    program = gcode("%:SAMPLE P/N;\nN1 G00 G90 G92 X0 Y0 Z0;\nN2 G00 X1.0 Y2.0;\n%;\n")
    assert program.name == "SAMPLE P/N"
    assert describe_all(program) == ["POS X1 Y2 T1"]


# -- codes --------------------------------------------------------------------------------

HEAD = "G20 G90 G17\nG43 H1\nS1000 M3\nG0 Z0.1\n"


def test_canned_cycles_become_hole_blocks() -> None:
    """G81/G82/G83 → DRILL (G83's Q dividing the depth → that many pecks), G84 → TAP,
    G85/G89 → BORE; R is Z UP, Z is Z DN, F is FEEDR Z; G98 returns to the start height,
    whose height above Z UP is Data Block 0's Z RET."""
    text = HEAD + (
        "G98 G82 X1 Y1 R0.1 Z-0.5 P0.8 F5\n"
        "G83 X2 Y1 R0.1 Z-0.5 Q0.2 F5\n"
        "G84 X3 Y1 R0.1 Z-0.5 F20\n"
        "G89 X4 Y1 R0.1 Z-0.5 P0.8 F3\n"
        "G80\nM30\n"
    )
    result = read_program(text.encode(), "t", "gcode")
    assert describe_all(result.program) == [
        "DRILL X1 Y1 Z0.1/-0.5 F5 T1",
        "DRILL X2 Y1 Z0.1/-0.5 F5 x3 T1",
        "TAP X3 Y1 Z0.1/-0.5 F20 T1",
        "BORE X4 Y1 Z0.1/-0.5 F3 T1",
    ]
    assert result.program.block0.z_retract == 0
    notes = [str(n) for n in result.report]
    assert any("line 6: G83 backs off" in n for n in notes)
    assert any("line 7: G84 feeds out to R" in n for n in notes)


def test_explicit_drill_moves_with_pecks_are_one_drill() -> None:
    """Rapid to Z UP, feed, back up to Z UP, down to the level, feed on, dwell 0.8 s, up:
    a MillBlocks DRILL with 2 pecks (DESIGN.md §3), levels -0.1 and -0.3."""
    text = HEAD + ("X1 Y1\nZ0.1\nG1 Z-0.1 F5\nG0 Z0.1\nZ-0.1\nG1 Z-0.3\nG4 P0.8\nG0 Z0.2\nM30\n")
    assert describe_all(gcode(text)) == ["DRILL X1 Y1 Z0.1/-0.3 F5 x2 T1"]


def test_arcs_in_i_j_and_r_forms() -> None:
    """G2 X1 Y1 R1 from X0 Y0: the centre of the short clockwise arc is X1 Y0 — a quarter
    circle on axis-parallel centre lines, the control's QCIR. G3 X2 Y2 R-1 from X1 Y1 is
    the long way round (270°): centre X2 Y1, not X1 Y2. G90.1 makes I J absolute: G3 X3 Y1
    I3 J2 from X2 Y2 is a counter-clockwise quarter about X3 Y2."""
    text = HEAD + (
        "G0 X0 Y0\nG1 Z-0.1 F5\nG2 X1 Y1 R1 F10\nG3 X2 Y2 R-1\nG90.1\nG3 X3 Y1 I3 J2\n"
        "G0 Z0.1\nM30\n"
    )
    assert describe_all(gcode(text)) == [
        "DRILL X0 Y0 Z0.1/-0.1 F5 T1",
        "MILL QCIR C X1 Y1 F10",
        "MILL ARC CC XY-CENT X2 Y1 F10",
        "MILL ARC XY-END X2 Y2",
        "MILL QCIR CC X3 Y1 F10",
    ]


def test_incremental_moves_g92_and_units() -> None:
    """G91 moves add up; a G92 after a move shifts later coordinates (the point called X0 Y0
    there is X3 Y1 in part coordinates); G21 makes the blocks from there millimetre
    blocks (X25.4 Y10 mm is X101.6 mm, Y35.4 mm in part coordinates)."""
    text = HEAD + "G91 G0 X1 Y1\nX2\nG90 G92 X0 Y0\nG0 X1 Y0\nG21 G0 X25.4 Y10\nM30\n"
    program = gcode(text)
    assert describe_all(program) == [
        "POS X1 Y1 T1",
        "POS X3 Y1 T1",
        "POS X4 Y1 T1",
        "POS X101.6 Y35.4 T1",
    ]
    assert program.blocks[-1].units is Units.MM and program.units is Units.INCH


def test_set_up_words_fill_data_block_0() -> None:
    """G10 L2 P1: part zero on the table; G10 L1: each tool's length (TCAL) and radius
    (half the diameter); M7/M8: the tool's coolant; G43 H before any M6: CUR-TOOL."""
    text = (
        "G20\nG10 L2 P1 X4.5 Y3.25 Z0\nG10 L1 P2 Z-1.25 R0.25\nG43 H2\nS800 M3\nM8\n"
        "G0 Z0.2\nG98 G82 X1 Y1 R0.1 Z-0.5 P0.8 F5\nG80\nM9\nM30\n"
    )
    db0 = gcode(text).block0
    assert (db0.x_offset, db0.y_offset, db0.current_tool) == (D("4.5"), D("3.25"), 2)
    tool = db0.tool(2)
    assert tool is not None
    assert (tool.diameter, tool.tcal, tool.rpm, tool.coolant.value) == (
        D("0.5"),
        D("-1.25"),
        800,
        "flood",
    )


# Work offsets. A fixture program (LinuxCNC's nc_files/mmount.ngc selects G55/G56/G57, one
# per station; stcline/CNC_Training NC_Files/Writing_A_Program_Example.nc cuts in G55)
# switches G54-G59.3 between cuts; LinuxCNC's tests/interp/g10/g10-l2-while-active/test.ngc
# sets the offsets with G10 L2.
FIXTURES = (
    "G20 G17 G90 G40 G80\n{setup}T1 M6\nS1000 M3\nG54\nG0 X0 Y0 Z0.1\nG1 Z-0.1 F5\n"
    "G1 X1\nG0 Z0.1\nG55\nG0 X0 Y0\nG1 Z-0.1 F5\nG1 X1 Y1\nG0 Z0.1\nM30\n"
)


def test_two_fixtures_whose_offsets_are_not_in_the_file_are_refused() -> None:
    """A G54 cut, then a G55 cut at the same coordinates: both were read in G54, the first
    part cut twice and the second not at all (only `G55: coordinates read as part
    coordinates` said so). Where G55 is from G54 is on the machine's offset table: the
    G55 is refused, naming it."""
    assert failure(FIXTURES.format(setup="")) == (
        "line 9, column 1: G55: a second work offset; part zero is G54's (the moves from "
        "line 5) and where G55's zero is from it is on the machine's offset table, not in "
        "the file (give both with G10 L2, or import each fixture's moves on their own)"
    )
    # Back in G54 before the next move: nothing is cut in G55, nothing to refuse.
    assert describe_all(gcode(FIXTURES.format(setup="").replace("G55\n", "G55\nG54\n")))[:2] == [
        "DRILL X0 Y0 Z0.1/-0.1 F5 T1",
        "MILL STD X1 Y0 F5",
    ]


def test_fixture_offsets_the_file_gives_are_applied() -> None:
    """G10 L2 P1/P2 give both fixtures' zeros (G10 L2 was "ignored: G10 with this L/P"): the
    G55 cut is moved by G55's zero from G54's, where rs274 cuts it (its SET_G5X_OFFSET);
    G10 L20 (the tool's point made a system's zero) alike."""
    text = FIXTURES.format(setup="G10 L2 P1 X0 Y0\nG10 L2 P2 X3 Y0.5\n")
    result = read_program(text.encode(), "t", "gcode")
    assert describe_all(result.program) == [
        "DRILL X0 Y0 Z0.1/-0.1 F5 T1",
        "MILL STD X1 Y0 F5",
        "DRILL X3 Y0.5 Z0.1/-0.1 F5 T1",
        "MILL STD X4 Y1.5 F5",
    ]
    assert "assumed: line 11: G55: its Z zero read as G54's (neither is in the file)" in [
        str(n) for n in result.report
    ]
    l20 = (
        "G20\nT1 M6\nS1000 M3\nG0 X2 Y2 Z0.1\nG10 L20 P1 X0 Y0\nG0 X0 Y0\nG1 Z-0.1 F5\n"
        "G1 X1 Y0\nG0 Z0.1\nM30\n"
    )
    assert describe_all(gcode(l20)) == ["DRILL X2 Y2 Z0.1/-0.1 F5 T1", "MILL STD X3 Y2 F5"]


def test_the_one_work_offset_the_file_gives_is_part_zero_on_the_table() -> None:
    """`G10 L2 P2 X1 Y0.5` then G55 throughout: G55's zero is part zero, on the table at X1
    Y0.5 (Data Block 0), as G10 L2 P1 for G54; the blocks keep the file's coordinates. A
    rotated system (G10 L2 R) is refused."""
    text = (
        "G20\nT1 M6\nS1000 M3\nG10 L2 P2 X1.0 Y0.5\nG55\nG0 X0 Y0 Z0.1\nG1 Z-0.1 F5\n"
        "G1 X1 Y0\nG0 Z0.1\nM30\n"
    )
    result = read_program(text.encode(), "t", "gcode")
    db0 = result.program.block0
    assert (db0.x_offset, db0.y_offset) == (D("1"), D("0.5"))
    assert describe_all(result.program)[:1] == ["DRILL X0 Y0 Z0.1/-0.1 F5 T1"]
    assert (
        "became: line 6: G55 holds part zero: its zero on the table, as the file's G10 gives "
        "it, is Data Block 0 X, Y"
    ) in [str(n) for n in result.report]
    assert failure(text.replace("Y0.5\n", "Y0.5 R45\n")) == (
        "line 4, column 21: G10 L2 R: a rotated coordinate system is not supported"
    )


def test_a_feed_past_the_control_s_range_is_cut_at_its_end() -> None:
    """enier290188/cnc src/mill/240811/square-block-face-4-and-5.nc plunges `G01 Z-1.0
    F108.0` and feeds across at it: the import said nothing, and the export refused "block
    5, FEEDR XY: 108.0 ipm is outside the allowed range" — a program held that could not
    be exported. As pecks past 40 and tools past 24, the feed is brought inside the
    control's range and reported at its F word; down in Z 108 ipm is within FEEDR Z."""
    text = "G20\nT1 M6\nS1000 M3\nG0 X6.5 Y1.5 Z0.1\nG01 Z-1.0 F108.0\nY-3.0\nG0 Z1\nM30\n"
    result = read_program(text.encode(), "t", "gcode")
    assert describe_all(result.program) == [
        "DRILL X6.5 Y1.5 Z0.1/-1 F108 T1",
        "MILL STD X6.5 Y-3 F100",
    ]
    assert (
        "assumed: line 5: F108.0 (column 11): 108 ipm across is outside FEEDR XY's 0.1 to 100 "
        "ipm (2 to 2540 mm/min in an mm block), the control's: cut at 100 ipm"
    ) in [str(n) for n in result.report]
    assert [p for p in validate(result.program) if p.severity is Severity.ERROR] == []


def test_a_feed_an_mm_block_may_have_is_read_as_written_in_an_inch_file() -> None:
    """A program in inch with an mm BORE at FEEDR Z 2 mm/min (the slowest an mm block
    takes) exports as an inch file with F0.0787: within the control's range, so read as
    written, as rs274 reads it (the referee's round trip found it cut to 0.1 ipm). A feed
    slower than any block takes is still brought to the range's end, reported."""
    text = "G20\nT1 M6\nS1000 M3\nG0 X1 Y1 Z0.1\nG1 Z-0.1 F0.0787\nG0 Z1\nM30\n"
    result = read_program(text.encode(), "t", "gcode")
    assert not [str(n) for n in result.report if "outside FEEDR" in str(n)]
    slow = read_program(text.replace("F0.0787", "F0.05").encode(), "t", "gcode")
    assert (
        "assumed: line 5: F0.05 (column 10): 0.05 ipm in Z is outside FEEDR Z's 0.1 to 250 "
        "ipm (2 to 6350 mm/min in an mm block), the control's: cut at 0.0787 ipm"
    ) in [str(n) for n in slow.report]


def test_two_axis_gcode_stops_are_the_quill() -> None:
    """Z never moves: a 2-axis program. A position where the program stops (M0) is a hole
    made by hand (DRILL without depths); M0, cuts, M0 is a mill sequence with its quill
    stops; M5 then M0 is a STOP."""
    text = (
        "G20 G90\nG43 H1\nS1200 M3\nG0 Z0.1\nX1 Y1\nX2\nM0\nX0 Y0\nM0\nG1 X1 F10\nY1\nM0\n"
        "M5\nM0\nM30\n"
    )
    assert describe_all(gcode(text)) == [
        "POS X1 Y1 T1",
        "DRILL X2 Y1 T1",
        "DRILL X0 Y0 T1",
        "MILL STD X1 Y0 F10",
        "STOP MILL STD X1 Y1 F10",
    ]


def test_cutter_compensation_keeps_the_programmed_contour() -> None:
    text = HEAD + "G0 X0 Y0\nG42 G1 Z-0.2 F4\nX2 F10\nY1\nG40 G0 Z0.1\nM30\n"
    program = gcode(text)
    drill = program.blocks[0]
    assert isinstance(drill, Hole) and drill.comp is Comp.RIGHT
    assert describe_all(program)[1:] == ["MILL STD X2 Y0 F10", "MILL STD X2 Y1 F10"]


def test_operator_messages_and_comments() -> None:
    text = HEAD + "(MSG,CHECK CLAMPS)\nG98 G82 X1 Y1 R0.1 Z-0.5 P0.8 F5 ; first hole\nM30\n"
    result = read_program(text.encode(), "t", "gcode")
    assert result.program.blocks[0].message == "CHECK CLAMPS"
    assert any("text after ';' read as a comment: 'first hole'" in str(n) for n in result.report)


def test_unknown_codes_are_listed_with_their_line() -> None:
    notes = report(HEAD + "G64\nM16\nG0 X1 Y1\nM123\nM30\n")
    assert "ignored: line 5: G64: continuous mode: not carried" in notes
    assert "ignored: line 6: M16: not a code MillBlocks knows; not imported" in notes
    assert "ignored: line 8: M123: not a code MillBlocks knows; not imported" in notes


def test_block_delete_numbers_and_percent() -> None:
    result = read_program(b"%\nN10 G20 G90\n/N20 G0 X1 Y1\nN30 M30\n%\nG0 X9\n", "t", "gcode")
    assert describe_all(result.program) == ["POS X1 Y1 T1"]
    notes = [str(n) for n in result.report]
    assert any("line 3: block delete" in n for n in notes)
    assert any("line 6: after the program end: not imported" in n for n in notes)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("G20\nG0 X1 Y1 (open\n", "line 2, column 10: comment not closed"),
        ("G20\nG0 G1 X1\n", "line 2, column 4: G0 and G1 in one block are both motion codes"),
        ("G20\nG0 X1 X2\n", "line 2, column 7: X given twice in one block (X1 and X2)"),
        ("G20\nG0 X#<depth>\n", "line 2, column 5: #<depth> is read before it is set"),
        ("G20\nG0 A10\n", "line 2, column 4: A: a rotary axis; MillBlocks has X, Y, Z"),
        ("G20\nO100 sub\n", "line 2, column 1: o100 sub has no o100 endsub"),
        ("G20\nG0 X1 $\n", "line 2, column 7: unexpected character '$'"),
        ("G20\nG33 X1 K0.1\n", "line 2, column 1: G33: thread cutting is not supported"),
        # Fanuc's codes that change what X and Y mean: ignored before, and the next
        # G1 X1. Y45. was cut as a straight move to X1 Y45.
        ("G20\nG0 X0 Y0\nG16\nG1 X1. Y45. F10\n", "line 3, column 1: G16: polar coordinates"),
        ("G20\nG51.1 X0\nG1 X1 Y1 F10\n", "line 2, column 1: G51.1: a programmable mirror"),
        ("G20\nG12.1\nG1 X1 Y1 F10\n", "line 2, column 1: G12.1: polar coordinate interp"),
        ("G20\nG7.1\nG1 X1 Y1 F10\n", "line 2, column 1: G7.1: cylindrical interpolation"),
        ("G20\nG0 X1 Y1\nG12 I0.5 D1 F10\n", "line 3, column 1: G12: a circle cutting cycle"),
        ("G20\nG68.2 X0 Y0 Z0 I0 J45 K0\n", "line 2, column 1: G68.2: a tilted working plane"),
        ("G20\nG0 Z0.1\nG1 X1 Y1\n", "line 3, column 1: a feed move with no F given yet"),
        ("G20\nM98 P100\n", "line 2, column 1: M98 P100: the file has no O100"),
        ("G20\nG0 X1 M98 P100\n", "line 2, column 7: M98: a subprogram call not at the beg"),
        ("G20\nG0 X1 O100\n", "line 2, column 7: an O-word (O number or subroutine) must "),
        (
            "G20\nG0 Z0.1\nG1 Z-0.1 F5\nX1 Z-0.2\n",
            "line 4: X/Y and Z fed together (a ramp)",
        ),
        ("G20\nG0 Z0.1\nG1 X1 Z-0.2 F5\n", "line 3: X/Y and Z fed together into the work"),
        ("G20\nG0 X1 Y1\nG1 Z-0.2 F5\nX2\nG0 Z1\n", "line 3: a feed in Z before the file gives"),
        (
            "G20\nG0 Z0.1\nG1 Z-0.1 F5\nG2 X1 Y0 Z-0.2 I0.5 J0\n",
            "line 4: an arc at another depth (a helix) in a mill sequence",
        ),
        ("G20\nG18\nG0 Z0.1\nG1 Z-0.1 F5\nG2 X1 I0.5\n", "line 5, column 1: an arc in the G18"),
        ("G20\nG0 Z0.1\nG81 X1 Y1 Z-0.5 F5\n", "line 3, column 1: G81 with no R plane"),
        ("G20\nG0 Z0.1\nG81 X1 Y1 R-0.6 Z-0.5 F5\n", "line 3, column 17: G81: Z is not below R"),
    ],
)
def test_errors_name_line_and_column(text: str, message: str) -> None:
    assert failure(text).startswith(message)


def test_nothing_is_imported_half_way() -> None:
    """An error on the last line: no program at all, only the error."""
    good = HEAD + "G98 G82 X1 Y1 R0.1 Z-0.5 P0.8 F5\n" * 3
    with pytest.raises(ImportFailure) as caught:
        read_program((good + "G0 X1 Y1 X2\n").encode(), "t", "gcode")
    assert caught.value.line == 8
    assert isinstance(caught.value, ValueError)


def test_every_note_names_its_line() -> None:
    result = read_program(sample_2_2_6_1().encode(), "s", "gcode")
    per_line = [n for n in result.report if n.kind is not NoteKind.ASSUMED or n.line is not None]
    assert all(n.where for n in per_line)
    assert all(
        n.line is not None
        for n in result.report
        if n.kind in (NoteKind.IGNORED, NoteKind.ROUNDED, NoteKind.BECAME)
    )


def test_hole_operation_of_each_cycle() -> None:
    for code, op in [(81, HoleOp.DRILL), (85, HoleOp.BORE), (86, HoleOp.BORE), (74, HoleOp.TAP)]:
        block = gcode(HEAD + f"G{code} X1 Y1 R0.1 Z-0.5 F5\nM30\n").blocks[0]
        assert isinstance(block, Hole) and block.op is op


# -- the reader's fast lane (issue 19) ----------------------------------------------------

NUMBER_WRITTEN = st.from_regex(r"\A[+-]?(?:0{0,3}[0-9]{1,6}(?:\.[0-9]{0,6})?|\.[0-9]{1,6})\Z")


@settings(max_examples=400, deadline=None)
@given(NUMBER_WRITTEN, st.sampled_from([Units.INCH, Units.MM]))
def test_lengths_are_read_to_the_same_nm_as_decimal_arithmetic(text: str, units: Units) -> None:
    """Lengths are read from the digits as integers: the same nm, rounded half-even, as
    Decimal arithmetic on the number as written gives."""
    assert text_nm(text, units.nm) == int((D(text) * units.nm).to_integral_value())


def _usual_program(moves: list[tuple[str, str, str, str]]) -> str:
    lines = ["G20 G90", "G0 Z0.1000", "X0 Y0", "G1 Z-0.1 F4.5"]
    for code, letter, value, feed in moves:
        lines.append(f"{code} {letter}{value} {feed}".strip())
    return "\n".join([*lines, "G0 Z0.2", "M30"]) + "\n"


MOVES = st.lists(
    st.tuples(
        st.sampled_from(["", "G1", "G01"]),
        st.sampled_from(["X", "Y"]),
        st.from_regex(r"\A-?[0-9]\.[0-9]{1,5}\Z"),
        st.sampled_from(["", "F6", "F7.25"]),
    ),
    min_size=1,
    max_size=12,
)


@settings(max_examples=60, deadline=None)
@given(MOVES)
def test_the_usual_lines_read_as_the_careful_reader_reads_them(
    moves: list[tuple[str, str, str, str]],
) -> None:
    """The upper-case file goes through the reader's fast lane, the same file in lower case
    through the word-by-word reader: the same program and the same report."""
    text = _usual_program(moves)
    fast = read_program(text.encode(), "t", "gcode")
    careful = read_program(text.lower().encode(), "t", "gcode")
    assert fast.program == careful.program
    assert [str(n) for n in fast.report] == [str(n) for n in careful.report]


WORD_LETTERS = st.sampled_from(list("NGXYZIJFMSTngx"))
WORD_NUMBERS = st.one_of(
    st.from_regex(r"\A[+-]?(?:[0-9]{1,14}(?:\.[0-9]{0,4})?|\.[0-9]{1,4})\Z"),
    st.sampled_from(["0", "00", "01", "1", "2", "3", "03", "80", "81", "4", "-1", "1.", ".", ""]),
)
BLANKS = st.sampled_from(["", " ", " ", " ", "  ", "\t"])
LINES = st.lists(st.tuples(BLANKS, WORD_LETTERS, WORD_NUMBERS), max_size=9).map(
    lambda words: "".join(f"{blank}{letter}{number}" for blank, letter, number in words)
)


@settings(max_examples=3000, deadline=None)
@given(LINES)
def test_the_tidy_lines_scanned_give_the_pattern_groups(line: str) -> None:
    """`usual_words` reads a line only where USUAL does, and to the same groups: it is
    the compiled reader's shortcut for USUAL, never a second grammar."""
    words = usual_words(line)
    match = USUAL.fullmatch(line)
    if words is not None:
        assert match is not None, line
        assert tuple(words) == match.groups(), line


def test_the_tidy_lines_of_a_long_file_are_all_scanned() -> None:
    """Every line of the benchmark's file that USUAL reads (our writer's style: one blank
    between words) is read by the shortcut too."""
    from bench.gcode_import import gcode_text

    lines = gcode_text(20_000).splitlines()
    usual = [(line, match.groups()) for line in lines if line and (match := USUAL.fullmatch(line))]
    assert len(usual) > 19_000
    assert all(usual_words(line) == list(groups) for line, groups in usual)


@settings(max_examples=2000, deadline=None)
@given(st.integers(-(10**30), 10**30), st.integers(1, 10**15))
def test_half_even_is_the_fraction_rounded(numerator: int, denominator: int) -> None:
    """Lengths and feeds are rounded in integers: exactly Python's rounding of the exact
    quotient (half to even), for either sign."""
    assert half_even(numerator, denominator) == round(Fraction(numerator, denominator))


# -- what CAM posts write (issue 36) -----------------------------------------------------------

SAFETY_LINE = (
    "%\nO1001\n(MASTERCAM-STYLE START)\nG20\nG0 G17 G40 G80 G90 G94 G98\nT1 M6\n"
    "G0 G90 G54 X1. Y1. S1000 M3\nG43 H1 Z0.1\nG1 Z-0.1 F5.\nG1 X2. F10.\n"
    "G1 G80 X2.5 Y1.5\nG0 Z1.\nM30\n%\n"
)


def test_a_post_s_safety_line_with_g80_beside_g0_reads_as_rs274_reads_it(tmp_path: Path) -> None:
    """`G0 G17 G40 G80 G90 G94 G98`, Mastercam's and Haas's safety line, was refused ("G0
    and G80 in one block are both motion codes"); rs274 reads G80 beside G0-G3 as the cycle
    cancelled and the other code moving. The same file now imports, and its blocks cut what
    rs274 reads from it."""

    assert feeds_as_rs274_reads_them(SAFETY_LINE, tmp_path)


def feeds_as_rs274_reads_them(text: str, tmp_path: Path) -> bool:
    """Whether the imported program feeds to the end points (in) rs274 reads in `text`."""
    from tests.referee import rs274

    path = tmp_path / "post.nc"
    path.write_text(text)
    theirs = [tuple(round(v, 4) for v in m.end) for m in rs274(path) if m.kind == "F"]
    cut = [
        (round(m.x / 25_400_000, 4), round(m.y / 25_400_000, 4), round(m.z / 25_400_000, 4))
        for m in interpret(gcode(text)).moves
        if isinstance(m, Feed)
    ]
    assert cut == theirs, (cut, theirs)
    return True


def test_g98_on_the_last_hole_of_a_g99_series_returns_to_the_initial_level(
    tmp_path: Path,
) -> None:
    """Before: a G98 on the last hole of a G99 series was ignored (the tool stayed at R),
    unreported, and the incremental cycle after it measured R and Z from R: its hole went
    0.9 in deeper than rs274 drills it (Z-1.4 for Z-0.5). Now the G98 hole returns to where
    the series began, the report says Data Block 0 cannot hold that second height, and
    every hole is at rs274's depth."""
    text = (
        "G20 G90\nG0 X0 Y0 Z1.0\nG91 G99 G81 X1 Y1 R-0.9 Z-0.6 F5\nX1\nG98 X1\n"
        "G81 X1 R-0.9 Z-0.6\nG80\nG90 G0 Z1.0\nM30\n"
    )
    assert feeds_as_rs274_reads_them(text, tmp_path)
    assert any("line 5: the tool retracts 0.9 in above Z UP here" in n for n in report(text))


def test_g80_beside_a_cycle_is_still_two_motion_codes() -> None:
    """rs274 refuses G0 beside G81 (two motions): so does the importer, naming both."""
    assert failure("G20\nG0 Z1\nG0 G81 X1 Z-1 R0.1 F5\n").startswith(
        "line 3, column 4: G0 and G81 in one block are both motion codes"
    )


def test_a_1000_line_contour_is_one_short_report_line() -> None:
    """One report line listed every block an operation became: a 1 000-line contour was a
    line of ~40 kB. Runs of one kind are counted, and past six runs the rest is a count."""
    moves = "".join(
        f"G1 X{1 + (k % 2):.1f} Y{k * 0.01:.2f}\n"
        if k % 3
        else f"G2 X{1 + (k % 2):.1f} Y{k * 0.01:.2f} R5.\n"
        for k in range(1, 1000)
    )
    text = "G20\nG0 X1 Y0 Z0.1\nG1 Z-0.1 F5\nF10\n" + moves + "G0 Z1\nM30\n"
    lines = [n for n in report(text) if "→ blocks" in n]
    assert lines and max(len(n) for n in lines) < 400, max(len(n) for n in lines)
    assert any("more blocks" in n for n in lines)


# Fusion 360 for Personal Use (its note in the file): rapids down are written as feeds at the
# cutting rate, then the plunge at the plunge rate (tests/imports/gcode-corpus/fusion-led-floor).
FUSION_PERSONAL = (
    "(1024_block_14bit)\n(T1  D=1.4 CR=0 - ZMIN=-3 - flat end mill)\nG90 G94\nG17\nG21\n"
    "(2D Contour5)\nT1\nS5000 M3\nG54\nG0 X-0.7 Y-0.7\nZ10\nG1 Z5 F1000\nZ2 F333.3\nZ-1\n"
    "Y20 F1000\nX20\nY-0.7\nX-0.7\nZ-2 F333.3\nY20 F1000\nX20\nZ10\nM5\nM30\n"
)


def test_a_plunge_approached_at_another_rate_enters_the_work_at_the_plunge_rate(
    tmp_path: Path,
) -> None:
    """Down to the feed height at one rate (G1 Z5 F1000), into the work at another (Z2
    F333.3, Z-1): the DRILL took the first rate and plunged at 1000 mm/min from Z10, three
    times the file's 333.3 (and so every depth change after it), reported only as "MillBlocks
    has one FEEDR Z". Now Z UP is where the plunge rate starts (Z5), FEEDR Z is the plunge
    rate (333.3 → 334 mm/min, the control's 2 mm/min steps), the feed above it is read as
    the rapid to Z UP and said so, and rs274 reads the same cuts in the file and in ours."""
    result = referee_import(FUSION_PERSONAL.encode(), tmp_path)
    assert describe_all(result.program)[0] == "DRILL X-0.7 Y-0.7 Z5/-1 F334 T1"
    notes = [str(n) for n in result.report]
    assert any(
        "line 12: feed 1000 mm/min down to Z5 mm above the plunge: read as the rapid to Z UP" in n
        for n in notes
    ), notes


def test_a_percent_line_with_text_after_the_start_is_an_error_naming_it() -> None:
    """Fusion's MPCNC post writes its start-up notes as `% vfd enable`; rs274 refuses such a
    line ("Bad character '%' used"). The importer took the second `%` line for the program's
    end and imported nothing after it: a drilling file of 190 lines became a program of no
    blocks, said only as "after the closing %: not imported". Now the line is an error."""
    text = "%\n(MPCNC21)\n% vfd enable\nM3 S5000\nG21\nG0 Z3\nX1 Y1\nG1 Z-1 F100\nG0 Z3\nM30\n%\n"
    message = failure(text)
    assert message.startswith("line 3, column 1: '% vfd enable': a % line starts or ends"), message
    assert "comment" in message
    # The program's closing %, with the ProtoTRAK dialect's `;`, is still the end.
    assert describe_all(gcode("%\nG20\nG0 X1 Y1\n%;\n")) == ["POS X1 Y1 T1"]


def test_polar_coordinates_are_read_and_their_mistakes_named(tmp_path: Path) -> None:
    """LinuxCNC's `@` (distance) and `^` (angle) words were "unexpected character '^'", then
    named as not supported; they are read as rs274 reads them (hole-circle.ngc's line,
    tests/test_import_ngc.py for the files), and what LinuxCNC refuses is refused."""
    text = "G20\nG0 X1.5 Y0 Z0\nG91 G81 R.1 Z-.5 ^60 L6 F10\nG80\nM2\n"
    holes = [b for b in gcode(text).blocks if isinstance(b, Hole)]
    assert len(holes) == 1 and "6 holes equally spaced on a circle" in " ".join(report(text))
    assert failure("G20\nG0 @1 X1\n").startswith(
        "line 2, column 7: X beside polar coordinates (@ ^)"
    )
    assert failure("G20\nG0 @1\n").startswith(
        "line 2, column 4: a polar coordinate from program zero with no angle to go at"
    )
    assert failure("G20\nG18\nG0 @1 ^30\n").startswith(
        "line 3, column 4: polar coordinates (@ ^) in the G18 plane"
    )


def test_g53_retract_reads_as_a_move_to_a_height_the_file_does_not_give(
    tmp_path: Path,
) -> None:
    """`G53 G0 Z0` (Haas and Fusion posts' retract, LinuxCNC's skeleton.ngc) was refused
    ("a move in machine coordinates ... is not supported"). rs274 moves to the machine's Z
    there; the file does not say where that is above the part, so the tool's Z is unknown
    until the file moves it again — as after `G28 G91 Z0`. The cuts are rs274's."""
    text = (
        "G20 G90\nG53 G0 Z0\nT1 M6\nS1000 M3\nG0 X1 Y1\nG43 H1 Z0.1\nG1 Z-0.1 F5\nX2 F10\n"
        "G0 Z0.1\nG53 G0 Z0\nG53 X0 Y0\nG0 X3 Y1\nZ0.1\nG1 Z-0.2 F5\nY2 F10\nG53 G0 Z0\nM30\n"
    )
    result = referee_import(text.encode(), tmp_path)
    assert describe_all(result.program) == [
        "DRILL X1 Y1 Z0.1/-0.1 F5 T1",
        "MILL STD X2 Y1 F10",
        "DRILL X3 Y1 Z0.1/-0.2 F5 T1",
        "MILL STD X3 Y2 F10",
    ]
    assert any("line 2: G53 G0 Z0: the machine's Z0" in str(n) for n in result.report)
    assert failure("G20\nG0 Z1\nG53 G1 Z0 F5\n").startswith("line 3, column 1: G53 G1")


def test_an_arc_in_the_xz_plane_says_what_to_change_in_the_cam() -> None:
    """Fusion's vertical lead-in (G18 G2 X… Z… I… K…) is refused; the error says it is the
    CAM's lead arc and what to turn off, not only that MillBlocks cuts arcs in XY."""
    text = "G21\nG0 X-1.6 Y-1.2 Z25\nG1 Z8.2 F333\nG18 G2 X-1.4 Z8 I0.2 F1000\n"
    message = failure(text)
    assert message.startswith("line 4, column 1: an arc in the G18 (XZ) plane"), message
    assert "lead-in" in message and "CAM" in message


def test_a_first_feed_in_z_says_to_give_the_height_first() -> None:
    """drl2gcode (KiCad drill files) starts with `G1 F1200.0 Z4.0`: from a height the file
    does not give. The error says how to give it."""
    text = (
        "G90\nG21\nM3 S10000.0\nG1 F1200.0 Z4.0\nG1 F1200.0 X0.0 Y0.0\nG1 F1200.0 Z0.2\n"
        "G1 F100.0 Z-3.0\nG1 F1200.0 Z4.0\nM5\nM2\n"
    )
    message = failure(text)
    assert message.startswith("line 4: a feed in Z before the file gives any height"), message
    assert "G0 Z" in message


def test_t0_m6_empties_the_spindle_and_is_no_tool_change() -> None:
    """`T0 M6` (LinuxCNC's skeleton.ngc and Haas programs: take the tool out at the end)
    became a change to tool 0, and the imported program had two errors ("TOOL #: 0 is
    outside the allowed range 1 to 24") and could not be exported. It is no tool change: the
    report says so, and the program has no errors."""
    text = (
        "G20 G90\nT1 M6 G43 H1\nS1000 M3\nG0 X1 Y1\nZ0.1\nG1 Z-0.1 F5\nG0 Z0.5\nX0 Y0\n"
        "M5\nT0 M6\nM2\n"
    )
    result = read_program(text.encode(), "t", "gcode")
    assert describe_all(result.program) == ["DRILL X1 Y1 Z0.1/-0.1 F5 T1", "POS X0 Y0 T1"]
    assert [p for p in validate(result.program) if p.severity is Severity.ERROR] == []
    assert any("line 10: T0 M6 empties the spindle" in str(n) for n in result.report)


def test_coolant_turned_on_among_the_cuts_does_not_end_the_mill_sequence(
    tmp_path: Path,
) -> None:
    """A Fanuc-style program turns the coolant on with the first cut (`G1 Y40 M8`, HelmanCNC's
    beginners' example). The M8 ended the mill sequence and the next cut was refused ("a cut
    in XY at Z-20 mm, but the tool has not fed down to it"). It is the tool's COOLANT; the
    cuts go on, as rs274 reads them."""
    text = (
        "O1000\nT1 M6\nG0 G90 G40 G21 G17 G94 G80\nG54 X-75 Y-75 S500 M3\nG43 Z100 H1\n"
        "G43 Z5\nG1 Z-20 F100\nG1 X-40\nG1 Y40 M8\nG1 X40\nG1 Y-40\nG1 X-75\nG1 Y-75\n"
        "G0 Z100\nM30\n"
    )
    result = referee_import(text.encode(), tmp_path)
    assert describe_all(result.program)[:3] == [
        "DRILL X-75 Y-75 Z5/-20 F100 T1",
        "MILL STD X-40 Y-75 F100",
        "MILL STD X-40 Y40 F100",
    ]
    tool = result.program.block0.tool(1)
    assert tool is not None and tool.coolant.value == "flood"
    # On a line of its own between the plunge and the first cut, the same.
    alone = text.replace("G1 Y40 M8\n", "G1 Y40\n").replace("G1 X-40\n", "M8\nG1 X-40\n")
    assert describe_all(referee_import(alone.encode(), tmp_path, "alone").program)[:2] == [
        "DRILL X-75 Y-75 Z5/-20 F100 T1",
        "MILL STD X-40 Y-75 F100",
    ]


def test_an_arc_centre_on_a_rapid_or_a_line_is_an_error() -> None:
    """`G0 X0.5 Y0. I0. J-0.5` (a circle example from diymachining.com, the G2 written as G0):
    rs274 refuses it ("I word with no G2, G3 … to use it"); the importer reported "I0.: no
    code on the line uses it" and imported a rapid at the cutting depth where the file's
    author meant an arc. Now it is an error naming the word."""
    text = "G17 G20 G90\nG0 Z0.1\nG0 X-0.5 Y0.\nG01 Z0. F5.\nG02 X0. Y0.5 I0.5 J0.\n"
    assert failure(text + "G0 X0.5 Y0. I0. J-0.5\n").startswith(
        "line 6, column 13: I with G0: a rapid has no arc centre"
    )
    assert failure(text + "G1 X0.5 Y0. J-0.5\n").startswith(
        "line 6, column 13: J with G1: a straight feed has no arc centre"
    )


def _lowest_across(motions: list[Motion]) -> dict[tuple[float, float], float]:
    """Each XY point a rapid goes across to after the first cut, and the lowest height a
    rapid across to it runs at (a rapid that moves in X/Y; inches, rounded to 0.0001 in).
    (Before it, rs274 starts both files at its machine zero, Z0.)"""
    lowest: dict[tuple[float, float], float] = {}
    at = (0.0, 0.0, 0.0)
    cut = False
    for motion in motions:
        x, y, z = motion.end
        cut = cut or motion.kind in "FA"
        if cut and motion.kind == "T" and (x, y) != at[:2]:
            point = (round(x, 4), round(y, 4))
            lowest[point] = min(lowest.get(point, math.inf), round(min(at[2], z), 4))
        at = motion.end
    return lowest


def test_a_rise_before_going_home_is_kept_no_rapid_across_is_lower(tmp_path: Path) -> None:
    """Found in viktech/IESI `Drill5holes.nc`: each hole is drilled in two levels, the tool
    rapids back to Z0 ("retract to clean") between them and to Z0.1 after; at the end it rises
    to Z3 and rapids home. Data Block 0's Z RET came from the first retract (0 above Z UP
    0): the move home (a POS) ran at Z0, across the top of the stock, where the file goes
    across at Z3. A rapid across is never lower than the file's now: Z RET is raised to what
    the highest one needs, and the report says so."""
    text = (
        "G20 G90 G17\nT1 M6\nS917 M3 F4\nG0 X0 Y0 Z0.1\nG0 X0.8 Y0.5\nG1 Z-0.125\nG0 Z0\n"
        "G1 Z-0.25\nG0 Z0\nG0 Z0.1\nG0 X1.6 Y0.75\nG1 Z-0.125\nG0 Z0\nG1 Z-0.25\nG0 Z0\n"
        "G0 Z0.1\nM5\nG0 Z3\nG0 X0 Y0\nM30\n"
    )
    result = referee_import(text.encode(), tmp_path)
    ours = tmp_path / "ours.ngc"
    ours.write_bytes(export(result.program, "gcode-linuxcnc", {"spindle-speeds": "by-hand"}).data)
    theirs = _lowest_across(rs274(tmp_path / "file-original.ngc"))
    mine = _lowest_across(rs274(ours))
    assert theirs[(0.0, 0.0)] == 3.0
    low = {xy: (z, mine.get(xy)) for xy, z in theirs.items() if mine.get(xy, -math.inf) < z}
    assert not low, f"rapids across lower than the file's (point: file's, ours): {low}"
    assert result.program.block0.z_retract == D(3)
    assert (
        "became: line 19: the tool goes across at Z3 in, 3 in above the operations' Z UP: "
        "Z RET 3 in (Data Block 0; was 0 in), so that no rapid across is lower than the "
        "file's: every operation retracts 3 in above its Z UP"
    ) in [str(n) for n in result.report]
