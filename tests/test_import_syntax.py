"""G-code as other people's files write it: blanks inside words, a DOS end-of-file mark,
`;` comments beside O-words, a fractional S, grbl's `K0` in XY arcs. Each case is a few
lines made for the test; the comment names the public file it was found in."""

from __future__ import annotations

from pathlib import Path

import pytest

from app.cnc.blocks import MillArc
from app.cnc.formats.reading import ImportFailure, detect_format, read_program
from tests.imports.support import describe_all
from tests.referee import referee_import

HEAD = "G20 G90 G17\nT1 M6\nS1000 M3\nG0 X0 Y0\nG0 Z0.1\nG1 Z-0.1 F5\n"


def failure(text: str) -> str:
    with pytest.raises(ImportFailure) as caught:
        read_program(text.encode(), "t", "gcode")
    return str(caught.value)


def notes(text: str) -> list[str]:
    return [str(n) for n in read_program(text.encode(), "t", "gcode").report]


# -- blanks inside a word -------------------------------------------------------------------


def test_blanks_between_letter_and_number_are_read_as_linuxcnc_reads_them(
    tmp_path: Path,
) -> None:
    # LinuxCNC/linuxcnc:nc_files/gmoccapy_2_tools_with_cutter_radius_compensation.ngc
    # (`G3 I -20`) and stcline/CNC_Training:NC_Files/smiley.nc (`Y -0.25`): rs274 takes
    # the blanks out of a line before reading it, so `X 1. 5` is X1.5 too.
    text = HEAD + "G1 X 1. 5 Y -0.25 F 1 0\nG3 X1.5 Y0.25 I -0.5 J 0.25\nG0 Z1\nM2\n"
    program = referee_import(text.encode(), tmp_path).program
    assert describe_all(program)[1:] == [
        "MILL STD X1.5 Y-0.25 F10",
        "MILL ARC CC XY-CENT X1 Y0 F10",
        "MILL ARC XY-END X1.5 Y0.25",
    ]


def test_a_letter_with_no_number_is_still_refused() -> None:
    assert failure(HEAD + "G1 X Y1\n").startswith("line 7, column 4: X needs a number; found ' Y1'")
    assert failure(HEAD + "G1 X - Y1\n").startswith("line 7, column 4: X needs a number")


def test_a_function_after_a_letter_is_evaluated(tmp_path: Path) -> None:
    # `Xsqrt[2]`: the front end evaluates it, as rs274 does.
    text = HEAD + "G1 X sqrt[4] Y1\nG0 Z1\nM2\n"
    program = referee_import(text.encode(), tmp_path).program
    assert describe_all(program)[1:] == ["MILL STD X2 Y1 F5"]


# -- DOS Ctrl-Z and NUL padding at the end ---------------------------------------------------


@pytest.mark.parametrize(
    "tail", [b"\x1a", b"%\n\x1a", b"\x00\x00\x00\x00", b"M2\r\n\x1a", b"M2\x1a\x1a"]
)
def test_a_dos_end_of_file_mark_or_nuls_at_the_end_are_padding(tail: bytes) -> None:
    # Found in no repository: the audit's probes (a DOS editor's ^Z, a tape's NUL trailer).
    data = b"%\nG20 G17 G90\nG0 X0 Y0\nG0 Z0.1\nG1 Z-0.1 F5\nG1 X1 F10\nG0 Z1\n" + tail
    assert detect_format(data) == "gcode"
    result = read_program(data, "t")
    assert result.format == "gcode"
    assert describe_all(result.program) == ["DRILL X0 Y0 Z0.1/-0.1 F5 T1", "MILL STD X1 Y0 F10"]


# -- detection: `;` comments and O-word names --------------------------------------------


def test_a_semicolon_comment_and_o_word_names_are_no_tape_evidence() -> None:
    # LinuxCNC/linuxcnc:nc_files/m6demo.ngc: `; This demonstrates…` on line 1 and a bare
    # `G30` inside `O<tc_at_g30> if […]`: detection said "could be a 1704 tape (line 38:
    # G20/G30 with an arc centre …) or G-code (line 1: the lower-case word h)".
    text = (
        "; This demonstrates a tool change\n"
        "#<at_g30> = 1\n"
        "O<tc_at_g30> if [#<at_g30> NE 0]\n"
        "    G30\n"
        "O<tc_at_g30> endif\n"
        "G20 G0 X1 Y1\nM2\n"
    )
    assert detect_format(text.encode()) == "gcode"


def test_a_semicolon_comment_is_named_as_g_code_evidence() -> None:
    # A file with a tape's evidence too: the refusal names the comment for what it is.
    text = "; made by hand\nG0 X10000\n"
    with pytest.raises(ImportFailure) as caught:
        detect_format(text.encode())
    assert "G-code (line 1: a comment after ';', which a 1704 tape cannot have)" in str(
        caught.value
    )


# -- a fractional spindle speed ----------------------------------------------------------


def test_a_fractional_spindle_speed_is_rounded_to_whole_rpm(tmp_path: Path) -> None:
    # LinuxCNC/linuxcnc:tests/interp/cam-nisley/cam.ngc:56 (`S4696.93856585`).
    text = HEAD.replace("S1000", "S1696.93856585") + "G1 X1 F10\nG0 Z1\nM2\n"
    result = referee_import(text.encode(), tmp_path)
    assert [t.rpm for t in result.program.block0.tools] == [1697]
    assert "rounded: line 3: S1696.93856585 → S1697: the control's spindle speed is whole rpm" in [
        str(n) for n in result.report
    ]
    assert failure(HEAD.replace("S1000", "S100000.6")).startswith(
        "line 3, column 1: S100000.6: a whole number from 0 to 100000 is needed"
    )


# -- K in an XY arc ----------------------------------------------------------------------


def test_a_zero_k_in_an_xy_arc_is_reported_and_changes_nothing(tmp_path: Path) -> None:
    # FreeCAD's grbl post (FreeCAD-generated files, e.g. an `Ecc_33MM_cut.nc`) writes
    # `K0.000` in every G17 arc; grbl ignores it, rs274 refuses it (so it reads the file
    # without the K).
    arc = "G2 X2 Y0 I0.5 J0 K0.000 F10\n"
    text = HEAD + "G1 X1 F10\n" + arc + "G0 Z1\nM2\n"
    result = referee_import(
        text.encode(), tmp_path, as_rs274_reads=text.replace(" K0.000", "").encode()
    )
    assert "ignored: line 8: K0.000: no code on the line uses it" in [str(n) for n in result.report]
    assert any(isinstance(b, MillArc) for b in result.program.blocks)


def test_any_other_k_in_an_xy_arc_is_refused() -> None:
    text = HEAD + "G1 X1 F10\nG2 X2 Y0 I0.5 J0 K0.1\n"
    assert failure(text).startswith(
        "line 8, column 18: K0.1 in an XY (G17) arc: only I and J give its centre"
    )
