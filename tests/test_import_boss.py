"""Our own BOSS tapes read back (issue 29 #8): G70/G71 as the BOSS (seed 004 §8.2.3-8.3.2,
"Modal G70" / "Modal G71") and the ANC post-processor spec (seed 002 §19, G70 inch input,
G71 metric input) mean them, the tool the tape starts with, and the segmented real-time
tape (`%#0 … $ #0 … $ … M02 $ $`, seed 004 §8.1.1) joined into one program.

The 1704 keeps its own G20/G30 (arcs with deceleration, seed 000 §4): nothing here changes
how a 1704 tape is read."""

from __future__ import annotations

import re
from decimal import Decimal as D
from pathlib import Path

import pytest
from click.testing import CliRunner

from app.cli import main
from app.cnc import document
from app.cnc.blocks import Hole, HoleOp, Program
from app.cnc.formats.reading import ImportFailure, ImportResult, detect_format, read_program
from app.cnc.formats.tape1704.reader import parse_tape
from app.cnc.formats.targets import export
from app.cnc.interpret import interpret
from app.cnc.recognition.steps import Arc
from app.cnc.units import Units
from tests.imports.support import speeds, with_rpms
from tests.referee import deviation, trace

GOLDEN = Path(__file__).parent / "golden"


def golden(name: str) -> Program:
    return document.loads((GOLDEN / name / "program.json").read_text())


def messages(result: ImportResult) -> str:
    return "\n".join(str(n) for n in result.report)


# -- G70 / G71 ------------------------------------------------------------------------------


def test_a_metric_boss_tape_reads_back_in_millimetres() -> None:
    """tap-metric's TAP at X25 Y20 mm, Z DN -15 mm (written Z-10. with tool 5's TCAL 5):
    before, G71 was "not a code MillBlocks knows" and the tape came back in inches — every
    dimension 25.4 times too large."""
    data = export(golden("tap-metric"), "tape-boss").data
    assert b"G71G90" in data
    result = read_program(data, "tap-metric")
    assert result.program.units is Units.MM
    [tap] = result.program.blocks
    assert isinstance(tap, Hole) and tap.op is HoleOp.TAP
    assert tap.units is Units.MM
    assert (tap.x, tap.y) == (D(25), D(20))
    text = messages(result)
    assert "not a code MillBlocks knows" not in text
    assert "G71: the program and every block are mm" in text


@pytest.mark.parametrize(("code", "units"), [("G70", Units.INCH), ("G71", Units.MM)])
def test_g70_and_g71_in_a_gcode_file_set_the_units(code: str, units: Units) -> None:
    """A Fanuc-style file of an older control (seed 002: G70 inch, G71 metric input)."""
    text = f"{code} G90\nT1 M6\nS1000 M3\nG0 X1. Y2. Z0.1\nG1 Z-0.5 F10.\nG0 Z0.1\nM2\n"
    result = read_program(text.encode(), "part", "gcode")
    assert result.program.units is units
    [hole] = result.program.blocks
    assert isinstance(hole, Hole) and (hole.x, hole.y) == (D(1), D(2))


def test_g71_then_g20_changes_the_units_as_g21_would() -> None:
    text = "G71 G90\nT1 M6\nS1000 M3\nG0 X10. Y20. Z2.\nG1 Z-5. F100.\nG0 Z2.\nG20\nX1. Y1.\nM2\n"
    result = read_program(text.encode(), "part", "gcode")
    assert result.program.units is Units.MM
    assert "units change to inch" in messages(result)


def test_a_1704_tape_keeps_g20_as_an_arc() -> None:
    """On the 1704, G20 is a clockwise arc with deceleration (seed 000 §4), not inches."""
    tape = b"%\nN1G50X0Y0Z0\nN2G01X10000Y0F100\nN3G20X20000Y10000I20000J0\nN4G00Z10000M30\n"
    parsed = parse_tape(tape, "arc", {})
    arcs = [s for s in parsed.steps if isinstance(s, Arc)]
    assert len(arcs) == 1 and arcs[0].clockwise


def test_g71_is_gcode_evidence_not_a_1704_code() -> None:
    text = b"G71 G90\nG0 X10. Y20. Z2.\nM2\n"
    assert detect_format(text) == "gcode"


# -- the tool --------------------------------------------------------------------------------


def test_the_tool_a_boss_tape_starts_with_is_not_tool_0() -> None:
    """The tape moves (Z up) before its first `T5M06`; that tool is the program's current
    tool, which the tape does not name: tool 1 is assumed and said, as for a 1704 tape —
    before, Data Block 0 came back with tool 0 ("no tool") in the spindle."""
    original = golden("tap-metric")
    assert original.block0.current_tool == 1
    result = read_program(export(original, "tape-boss").data, "tap-metric")
    assert result.program.block0.current_tool == 1
    [tap] = result.program.blocks
    assert isinstance(tap, Hole) and tap.tool == 5
    assert "the file does not say which tool it starts with: tool 1" in messages(result)


# -- segments --------------------------------------------------------------------------------


def _segmented(name: str, size: str) -> bytes:
    data = export(golden(name), "tape-boss", {"segment": size}).data
    assert data.count(b"\r#0\r") >= 2
    return data


def test_a_segmented_tape_is_one_program() -> None:
    """Six segments of metric-drill-bolt (a 120-character memory) read back as the
    program the one-segment tape is, and the report says how many segments were joined."""
    whole = read_program(export(golden("metric-drill-bolt"), "tape-boss").data, "bolt")
    data = _segmented("metric-drill-bolt", "120")
    count = data.count(b"#0")
    result = read_program(data, "bolt")
    assert result.format == "boss"
    assert result.program.blocks == whole.program.blocks
    assert result.program.block0 == whole.program.block0
    assert f"{count} segments (#0 … $) joined into one program" in messages(result)
    assert "1 segment (#0 … $)" in messages(whole)


def test_a_segmented_tape_cuts_the_programs_moves() -> None:
    original = golden("metric-drill-bolt")
    back = read_program(_segmented("metric-drill-bolt", "120"), "bolt").program
    back = with_rpms(back, speeds(original))
    expected = trace(interpret(original), with_z=False)
    actual = trace(interpret(back), with_z=False)
    assert deviation(expected, actual, 1_000) <= 1_000


def _bad(text: str) -> str:
    with pytest.raises(ImportFailure) as failed:
        read_program(text.replace("\n", "\r").encode(), "bad", "boss")
    return str(failed.value)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (
            "%#0\nG71G90\nG00X1.Y2.$\n$\n",
            "line 3, column 10: '$' ends a segment on a line of its own",
        ),
        (
            "%#0\nG71G90\nG00X1.Y2.\n",
            "line 1, column 2: the tape ends inside segment 1 (no '$'): the rest of the "
            "tape is missing",
        ),
        (
            "%#0\nG71G90\n$\nG00X1.\n#0\nM02\n$\n$\n",
            "line 4, column 1: text between segments: after '$' the tape goes on with #0",
        ),
        (
            "%#0\nG71G90\n#0\nM02\n$\n$\n",
            "line 3, column 1: #0 inside segment 1 (opened on line 1): a segment ends with "
            "'$' before the next #0",
        ),
        (
            "T1/Z-1.5\n%#0\nG71G90\nM02\n$\n$\n",
            "line 1, column 1: a TLO subroutine (T1/) is not supported",
        ),
        (
            "#1\nG01X1.\n$\n%#0\nM02\n$\n$\n",
            "line 1, column 1: #1: subroutine and macro definitions are not supported",
        ),
        (
            "%#0\nG71G90\nG00X1.Y2.Q\n$\n$\n",
            "line 3, column 10:",
        ),
    ],
)
def test_a_bad_boss_tape_names_line_and_column(text: str, expected: str) -> None:
    assert _bad(text).startswith(expected)


def test_a_boss_tape_is_detected_by_its_segments() -> None:
    assert detect_format(_segmented("metric-drill-bolt", "120")) == "boss"
    assert detect_format(export(golden("loop-rep-grid"), "tape-boss").data) == "boss"


def test_millblocks_import_takes_a_segmented_tape(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'lib.db'}")
    tape = tmp_path / "bolt.bos"
    tape.write_bytes(_segmented("metric-drill-bolt", "120"))
    result = CliRunner().invoke(main, ["import", str(tape)])
    assert result.exit_code == 0, result.stderr
    assert result.stderr.startswith("Import report (boss):\n")
    assert re.search(r"\d+ segments \(#0 … \$\) joined into one program", result.stderr)
