"""`read_program`: format detection, the JSON document, the one failure, the report."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from app.cnc import document
from app.cnc.formats.reading import (
    ImportFailure,
    ImportResult,
    detect_format,
    importers,
    read_program,
)
from app.cnc.formats.targets import export
from tests.imports.support import GOLDEN, fixture, load


@pytest.mark.parametrize(
    ("target", "expected"),
    [
        ("gcode-linuxcnc", "gcode"),
        ("gcode-fanuc", "gcode"),
        ("gcode-prototrak", "gcode"),
        ("events", "events"),
        ("tape-ascii", "tape"),
        ("tape-eia", "tape"),
        ("punch-eia", "tape"),
        ("punch-ascii", "tape"),
        ("json", "json"),
    ],
)
@pytest.mark.parametrize("case", ["bolt-circle-drill", "two-axis", "circle-pocket-mm"])
def test_our_own_exports_are_detected(case: str, target: str, expected: str) -> None:
    data = export(load(GOLDEN / case), target).data
    assert detect_format(data) == expected


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("seed003-2.2.6.1.ngc", "gcode"),
        ("seed003-2.2.6.2.ngc", "gcode"),
        ("seed003-2.2.6.3.cnc", "events"),
        ("seed003-2.2.5.cnc", "events"),
        ("seed000-table-3-1.tape", "tape"),
        ("seed000-table-4-2.tape", "tape"),
    ],
)
def test_the_seed_samples_are_detected(name: str, expected: str) -> None:
    assert detect_format(fixture(name)) == expected


@pytest.mark.parametrize(
    ("text", "readable_as"),
    [
        # G00 feeds on a 1704 and rapids in G-code; four decimals read alike on both.
        ("N1 G00 X1.0000 Y2.0000\nN2 G01 X2.0000 F100\n", "gcode"),
        # G94: preset to zero on a 1704, feed per minute in G-code.
        ("G94\nG00 X1.0000\n", "gcode"),
        # G98/G99: the quill on a 1704, the canned-cycle return in G-code.
        ("G99\nG00 X1.0000 Y1.0000\nG98\n", "tape"),
    ],
)
def test_tape_or_gcode_detection_refuses_to_guess(text: str, readable_as: str) -> None:
    with pytest.raises(ImportFailure) as caught:
        read_program(text.encode())
    assert "could be a 1704 tape or G-code" in str(caught.value)
    assert "give the format" in str(caught.value)
    # Given the format, it reads.
    assert read_program(text.encode(), format=readable_as).format == readable_as


def test_evidence_for_both_is_named() -> None:
    with pytest.raises(ImportFailure) as caught:
        detect_format(b"G17 G20\nN2G50X10000Y10000\n")
    message = str(caught.value)
    assert "line 2: X10000: 10000 in as G-code" in message
    assert "line 1: G17, which the 1704 does not have" in message


@pytest.mark.parametrize(
    ("block", "reason"),
    [
        ("N2G50X1000Y1000", "line 3: G50 with axis words"),
        ("N2 g+050. x1000", "line 3: G50 with axis words"),
        ("N2G20X1000Y0I500J0", "line 3: G20/G30 with an arc centre"),
        ("N2 G030 X1000 K500", "line 3: G20/G30 with an arc centre"),
        ("N2G04F0015", "line 3: G04 with F"),
        ("N2 G4.0 F15", "line 3: G04 with F"),
        ("N2G01Z-12500", "line 3: Z-12500: 12500 in as G-code"),
        ("N2 x 10000", "line 3: X10000: 10000 in as G-code"),
    ],
)
def test_a_tapes_evidence_after_gcodes_is_found(block: str, reason: str) -> None:
    # Once the text is known to have G-code's evidence, only blocks that may be a tape's
    # are looked at again: each kind of a tape's evidence must still be one of them.
    with pytest.raises(ImportFailure) as caught:
        detect_format(f"G17 G20\nG0 X1.0000 Y1.0000\n{block}\n".encode())
    message = str(caught.value)
    assert "line 1: G17, which the 1704 does not have" in message
    assert reason in message


def test_json_document() -> None:
    program = load(GOLDEN / "copy-offsets-abs")
    result = read_program(document.dumps(program).encode(), "p.json")
    assert result.format == "json" and result.program == program
    assert [str(n) for n in result.report] == [
        "became: file: a MillBlocks program document, as written"
    ]


def test_json_copy_blocks_are_carried_out_as_the_file_is_read() -> None:
    raw = (GOLDEN / "copy-offsets-abs" / "program.json").read_bytes()
    assert read_program(raw).program == load(GOLDEN / "copy-offsets-abs")


def test_json_errors_name_where() -> None:
    with pytest.raises(ImportFailure) as caught:
        read_program(b'{\n  "format": "millblocks-program",\n  "version": 1,\n  oops\n}')
    assert str(caught.value).startswith("line 4, column 3: not valid JSON")
    good = document.to_dict(load(GOLDEN / "drill-single"))
    good["blocks"][0]["type"] = "DRIL"
    with pytest.raises(ImportFailure) as caught:
        read_program(json.dumps(good).encode())
    assert str(caught.value).startswith("block 1, type: unknown block type 'DRIL'")


def test_one_failure_type_for_everything() -> None:
    assert issubclass(ImportFailure, ValueError)
    for data, fmt in [
        (b"", None),
        (b"G0 X1", "pdf"),
        (b"G20\nG0 X1 (\xd8 cutter)\n", "gcode"),
    ]:
        with pytest.raises(ImportFailure):
            read_program(data, "x", fmt)
    with pytest.raises(ImportFailure) as caught:
        read_program(b"G20\nG0 X1 (\xd8 cutter)\n", "x", "gcode")
    assert str(caught.value) == "line 2, column 8: byte 0xD8 is not text (UTF-8)"
    assert list(importers()) == ["json", "events", "gcode", "boss", "tape", "dxf"]


def test_result_report_as_text_is_in_file_order() -> None:
    result = read_program(fixture("seed003-2.2.6.3.cnc").replace(b"XEQA", b"XE0A"), "s")
    assert isinstance(result, ImportResult)
    text = result.text()
    assert text.startswith("Import report (events):\n")
    lines = text.splitlines()[1:]
    numbers = [int(s.split("line ")[1].split(":")[0]) for s in lines if ": line " in s]
    assert numbers == sorted(numbers)


def test_the_name_argument_names_a_program_whose_file_does_not() -> None:
    text = b"PN12 G20;\nN1 G100 X1.0A Y1.0A T1;\n"
    assert read_program(text, "bracket.cnc").program.name == "bracket.cnc"
    assert read_program(text).program.name == "imported"


def test_deterministic() -> None:
    data = export(load(GOLDEN / "frame-pocket"), "gcode-linuxcnc").data
    first = read_program(data, "a")
    assert all(read_program(data, "a") == first for _ in range(3))


def test_reading_a_file_from_disk_keeps_its_bytes(tmp_path: Path) -> None:
    path = tmp_path / "part.ngc"
    path.write_bytes(export(load(GOLDEN / "drill-single"), "gcode-fanuc").data)
    assert read_program(path.read_bytes(), path.name).format == "gcode"
