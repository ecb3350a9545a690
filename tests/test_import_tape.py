"""Tektronix 1704 tape import (seed 000): listings and punch images, EIA and ASCII.

The manual's programs are Table 3-1 (the sample part cut with lines), Table 4-1 (the same
part with arcs) and Table 4-2 (succeeding arcs). The fixtures are the tables as the scan
prints them (tests/imports/seed000-table-*.tape); the damage is walked through here, each
error naming its tape block, and what the tables then import to is worked out by hand.
"""

from __future__ import annotations

from decimal import Decimal as D

import pytest

from app.cnc.formats.reading import ImportFailure, read_program
from app.cnc.formats.tape1704 import codes as tapecode
from app.cnc.formats.tape1704.codes import TapeCode
from app.cnc.formats.targets import export
from app.cnc.units import Units
from tests.imports.support import GOLDEN, describe_all, fixture_text, load


def tape(text: str, **options: str) -> list[str]:
    return describe_all(read_program(text.encode(), "t", "tape", options or None).program)


def failure(data: str | bytes, **options: str) -> str:
    raw = data.encode() if isinstance(data, str) else data
    with pytest.raises(ImportFailure) as caught:
        read_program(raw, "t", "tape", options or None)
    return str(caught.value)


def report(text: str) -> list[str]:
    return [str(n) for n in read_program(text.encode(), "t", "tape").report]


# -- Table 4-1 ------------------------------------------------------------------------------

# The scan read I as 1 twice (`Y30000110000`, `Y31769156250`) and N as No (`No17`).
SCAN_FIX_4_1 = [("30000110000", "30000I10000"), ("31769156250", "31769I56250"), ("No17", "N017")]

# Worked out from the table (2.4 inch format, F3.1; no Z: a 2-axis tape; G00 and G01 are
# feed moves on the 1704, the mode before any G is G00):
# N001 X5000 Y5000 M03 F2000: 200 ipm, above a MILL block's 100 ipm: positioning to
#   X0.5 Y0.5 (reported). N002 G00 F20 M09: F2.0, coolant off; no move.
# N003 Y25000 F80 (8 ipm) starts cutting at X0.5 Y0.5: a DRILL there without depths
#   (the quill by hand), then MILL STD to X0.5 Y2.5; N004 to X1.0 Y2.5.
# N005 G03 X1.5 Y3.0 about I1.0 J3.0 (absolute, §4): a counter-clockwise quarter from the
#   bottom of the circle to its right: a QCIR; N006 on about the same centre to X1.0 Y3.5:
#   another QCIR.
# N007-N012: lines (values to 0.0001 in rounded to 0.001 in, reported: Y5.3604 → 5.360…).
# N013 G03 X5.5 Y3.1769 about I5.625 J3.1769: 68°, an ARC; N014 line; N015 G03 to
#   X5.6005 Y2.5898 about the same I and J2.7124: an ARC (X5.600 Y2.590).
# N016-N018: lines back to X0.5 Y0.5. N019 X0 Y0 M30 F2000: positioning: a POS; M30 ends.
EXPECTED_4_1 = [
    "DRILL X0.5 Y0.5 T1",
    "MILL STD X0.5 Y2.5 F8",
    "MILL STD X1 Y2.5 F8",
    "MILL QCIR CC X1.5 Y3 F8",
    "MILL QCIR CC X1 Y3.5 F8",
    "MILL STD X0.5 Y3.5 F8",
    "MILL STD X0.5 Y5.36 F8",
    "MILL STD X4.038 Y6.54 F8",
    "MILL STD X6.5 Y5.309 F8",
    "MILL STD X6.5 Y3.662 F8",
    "MILL STD X5.579 Y3.293 F8",
    "MILL ARC CC XY-CENT X5.625 Y3.177 F8",
    "MILL ARC XY-END X5.5 Y3.177",
    "MILL STD X5.5 Y2.712 F8",
    "MILL ARC CC XY-CENT X5.625 Y2.712 F8",
    "MILL ARC XY-END X5.6 Y2.59",
    "MILL STD X6.5 Y2.41 F8",
    "MILL STD X6.5 Y0.5 F8",
    "MILL STD X0.5 Y0.5 F8",
    "POS X0 Y0 T1",
]


def table_4_1() -> str:
    text = fixture_text("seed000-table-4-1.tape")
    for printed, meant in SCAN_FIX_4_1:
        text = text.replace(printed, meant)
    return text


def test_table_4_1_as_printed() -> None:
    """Detection refuses (the scan's `No17` has a lower-case o, which only G-code has,
    while `X10000` is a 1704 number); read as a tape, N005's `Y30000110000` has more than
    the Y word's six digits."""
    with pytest.raises(ImportFailure) as caught:
        read_program(fixture_text("seed000-table-4-1.tape").encode(), "t")
    assert "could be a 1704 tape" in str(caught.value)
    message = failure(fixture_text("seed000-table-4-1.tape"))
    assert message.startswith("tape block 5 (N005), line 5, column 14: Y30000110000: more than")


def test_table_4_1_imports_to_the_sample_part() -> None:
    result = read_program(table_4_1().encode(), "table-4-1.tape")
    assert result.format == "tape"
    assert describe_all(result.program) == EXPECTED_4_1
    notes = [str(n) for n in result.report]
    assert any(
        n.startswith("assumed: tape block 1 (N001, line 1): G00 with F at 200 in per minute")
        for n in notes
    )
    assert any(n.startswith("needs: tape block 1") and "no spindle speed" in n for n in notes)


# -- Table 4-2 ------------------------------------------------------------------------------


def test_table_4_2_walk_through() -> None:
    """Table 4-2 is an excerpt (no F, no end); its arcs, as printed and as repaired:

    1. As printed, `1125000` is I125000 with the I read as 1: not a tape word (N003).
    2. With the I: N003 goes from X11 Y10 about I12.5 J10 (radius 1.5) to X12 Y11, 1.118
       from that centre: the end is not on the radius (N003). The centre X12 Y10 fits the
       whole table: N003 and N004 turn about it, N005 and N006 about X12.5 Y10.
    3. With I120000: the excerpt gives no feed rate before its first arc (N003).
    4. With F100 (10 ipm) on N001: N007 G30 from X12 Y10 to X12.5 Y9.5 about I12 J9.5
       turns 270° counter-clockwise: more than the quadrant the 1704 cuts (N007).
    5. As G20 (clockwise, the 90° way round): the tape reads. From X0 Y0 the feed to
       X10 Y10 starts a 2-axis mill sequence; the arcs are clockwise quarters on
       axis-parallel centre lines: QCIRs.
    """
    text = fixture_text("seed000-table-4-2.tape")
    steps = [
        (
            "tape block 3 (N003), line 3, column 26: '1': not a tape word",
            [("\t1125000", "\tI125000"), ("\t1120000", "\tI120000")],
        ),
        (
            "tape block 3 (N003), line 3: the arc's end is 0.382 in off its radius: the start "
            "is 1.5 in",
            [("Y110000\tI125000", "Y110000\tI120000")],
        ),
        (
            "tape block 3 (N003), line 3: an arc with no feed rate (F) given yet",
            [("Y100000\n", "Y100000\tF100\n")],
        ),
        ("tape block 7 (N007), line 7: the arc turns 270.0°", [("G30\tX125000", "G20\tX125000")]),
    ]
    for expected, fixes in steps:
        assert failure(text).startswith(expected)
        for printed, meant in fixes:
            assert printed in text
            text = text.replace(printed, meant)
    assert tape(text) == [
        "DRILL X0 Y0 T1",
        "MILL STD X10 Y10 F10",
        "MILL STD X11 Y10 F10",
        "MILL QCIR C X12 Y11 F10",
        "MILL QCIR C X13 Y10 F10",
        "MILL QCIR C X12.5 Y9.5 F10",
        "MILL QCIR C X12 Y10 F10",
        "MILL QCIR C X12.5 Y9.5 F10",
    ]


# -- Table 3-1 ------------------------------------------------------------------------------


def test_table_3_1_walk_through() -> None:
    """Table 3-1 as printed (each block ended by `;`, as the table prints End of Block).

    Errors, in order, each naming its block: N003 `&25000` (the Y read as &); N006
    `X11197X25145` (X twice with two values: the second is Y); N007 `X11773/22573` (the Y
    read as /). Repaired, the tape reads; the damage no check can see is read as printed:
    N001's M03 twice (read once, reported), N008 missing and N036 twice (sequence numbers
    do not change what the control does), N024 `Y33643` and N050 `Y24970` off the
    circles they belong to, N035 `Y336615` (33.6615 in: six digits are allowed), N043
    `X44000`, and `M30.` (the point ignored, as the control ignores it).
    """
    text = fixture_text("seed000-table-3-1.tape")
    for expected, printed, meant in [
        ("tape block 3 (N003), line 2, column 17: '&'", "N003&25000", "N003Y25000"),
        (
            "tape block 6 (N006), line 2, column 71: X given twice with different values",
            "N006X11197X25145",
            "N006X11197Y25145",
        ),
        ("tape block 7 (N007), line 2, column 89: '/'", "N007X11773/22573", "N007X11773Y22573"),
    ]:
        assert failure(text).startswith(expected)
        text = text.replace(printed, meant)
    result = read_program(text.encode(), "t", "tape")
    blocks = describe_all(result.program)
    # N001 positions (200 ipm); N002 G00 M00 stops for the quill; N003-N054 cut: a DRILL
    # without depths at X0.5 Y0.5 and 51 MILL STD blocks (the 26 chords of the half
    # circle and the rest); N055 G50 X0 Y0: a POS.
    assert len(blocks) == 53
    assert blocks[:4] == [
        "DRILL X0.5 Y0.5 T1",
        "MILL STD X0.5 Y2.5 F8",
        "MILL STD X1 Y2.5 F8",
        "MILL STD X1.06 Y2.504 F8",
    ]
    assert "MILL STD X6.5 Y33.662 F8" in blocks  # N035 as printed
    assert blocks[-1] == "POS X0 Y0 T1"
    notes = [str(n) for n in result.report]
    assert "ignored: tape block 1 (N001, line 1): M03 written twice: read once" in notes


# -- punch images ---------------------------------------------------------------------------


def punched(name: str, target: str) -> tuple[bytes, str]:
    """A punch image and the listing of the same tape (same code: an EIA tape has no
    comments, so its Z words cannot be told from each tool's own Z as an ASCII one's can)."""
    program = load(GOLDEN / name)
    listing = target.replace("punch-", "tape-")
    return export(program, target).data, export(program, listing).data.decode()


@pytest.mark.parametrize("target", ["punch-eia", "punch-ascii"])
def test_punch_image_reads_like_its_listing(target: str) -> None:
    rows, listing = punched("contour-cut-right", target)
    from_rows = read_program(rows, "t")
    assert from_rows.format == "tape"
    from_listing = read_program(listing.encode(), "t")
    assert from_rows.program.blocks == from_listing.program.blocks
    code = "EIA" if target == "punch-eia" else "ASCII"
    assert any(f"{code} punch image" in str(n) for n in from_rows.report)


def test_blank_rows_rubouts_and_the_titled_leader_are_skipped() -> None:
    rows, _ = punched("drill-single", "punch-eia")
    decoded = tapecode.decode(rows, TapeCode.EIA)
    start = decoded.leader_rows + 4
    patched = (
        rows[:start]
        + bytes([tapecode.EIA_DELETE, tapecode.BLANK, tapecode.EIA_DELETE])
        + rows[start:]
    )
    assert read_program(patched, "t").program.blocks == read_program(rows, "t").program.blocks
    assert tapecode.title_rows("DRILL") in rows[: decoded.leader_rows] or decoded.leader_rows > 0


def test_parity_error_names_the_row_and_the_block() -> None:
    rows, _ = punched("drill-single", "punch-eia")
    decoded = tapecode.decode(rows, TapeCode.EIA)
    eob = [i for i in range(decoded.leader_rows, len(rows)) if rows[i] == tapecode.EIA_END_OF_BLOCK]
    # A hole dropped from the third character of the second block (N2…).
    bad = eob[1] + 3
    broken = bytearray(rows)
    broken[bad] ^= 0x01 if broken[bad] & 0x01 else 0x02
    message = failure(bytes(broken))
    assert message.startswith(f"row {bad}, tape block 2 (N2), rows ")
    assert "a parity error" in message and "EIA needs an odd number" in message


def test_a_punch_image_without_an_end_of_block_has_no_blocks() -> None:
    assert failure(bytes([0x01, 0x02, 0x13] * 10)).startswith("a punch image with no End of Block")


# -- listing words --------------------------------------------------------------------------


def test_tabs_leader_comments_and_modal_words() -> None:
    """Lines before `%` are leader; tabs between words; the ASCII header comment gives
    part zero; words are modal (G01 and F stay)."""
    text = (
        "TITLE LEADER\n%\n(PART ZERO AT TABLE X1.0000 Y2.0000 IN)\n"
        "N1\tG50\tX10000\tY10000\tZ1000\tM03\nN2\tZ-1000\nN3\tG01\tZ-3000\tF50\n"
        "N4\tX20000\tF100\nN5\tY20000\nN6\tG50\tZ1000\nN7\tM30\n"
    )
    result = read_program(text.encode(), "t", "tape")
    assert describe_all(result.program) == [
        "DRILL X1 Y1 Z-0.1/-0.3 F5 T1",
        "MILL STD X2 Y1 F10",
        "MILL STD X2 Y2 F10",
    ]
    db0 = result.program.block0
    assert (db0.x_offset, db0.y_offset) == (D(1), D(2))
    assert any("leader (lines 1-1): skipped" in str(n) for n in result.report)


def test_metric_option_and_incremental_mode() -> None:
    """units=metric: motion words 3.3 (X12345 = 12.345 mm), F whole mm/min; G91: adds."""
    text = (
        "%\nN1G50X10000Y10000Z2000\nN2Z1000\nN3G00Z-2000F100\nN4G91\nN5G01X5000\n"
        "N6G50Z3000\nN7M30\n"
    )
    assert tape(text, units="metric") == ["DRILL X10 Y10 Z1/-2 F100 T1", "MILL STD X15 Y10 F100"]


def test_g94_preset_and_dwell() -> None:
    """G94 Z0 makes the present Z read zero (later Z words add the old reading); G04 F8 is
    a 0.8 s dwell: the DRILL's own."""
    text = (
        "%\nN1G50X10000Y10000Z5000\nN2G94Z0\nN3G50Z-4000\nN4G00Z-8000F50\nN5G04F8\nN6G50Z0\nN7M30\n"
    )
    assert tape(text) == ["DRILL X1 Y1 Z0.1/-0.3 F5 T1"]


def test_fixed_cycles_and_the_quill() -> None:
    """G81 X Y Z R: the manual's drill cycle (reported: the builder may set it otherwise);
    G99 and a position: a down-up quill cycle, a hole by hand."""
    text = "%\nN1G50X10000Y10000Z2000\nN2G81X20000Y10000Z-5000R1000F50\nN3G80\nN4M30\n"
    result = read_program(text.encode(), "t", "tape")
    assert describe_all(result.program) == ["POS X1 Y1 T1", "DRILL X2 Y1 Z0.1/-0.5 F5 T1"]
    assert any("G81: read as seed 000 §4's fixed cycle" in str(n) for n in result.report)
    quill = "%\nN1G99\nN2G50X10000Y10000\nN3X20000\nN4G98\nN5M30\n"
    assert tape(quill) == ["DRILL X1 Y1 T1", "DRILL X2 Y1 T1"]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            "%\nN1G50X1.5\n",
            "tape block 1 (N1), line 2, column 6: X1.5: the 1704 ignores the point and reads X15",
        ),
        ("%\nN1G50G01X10000\n", "tape block 1 (N1), line 2: two different G words in one block"),
        (
            "%\nN1G50P10\n",
            "tape block 1 (N1), line 2, column 6: 'P': a letter the 1704 has no word for",
        ),
        ("%\nN1G05X10000\n", "tape block 1 (N1), line 2, column 3: G05 is not a 1704 code"),
        (
            "%\nN1G50X10000Y10000\nN2G02X20000I15000J10000F10\n",
            "tape block 2 (N2), line 3: an arc needs both X and Y",
        ),
        (
            "%\nN1G50X10000Y10000\nN2G03X10000Y10000I15000J10000F10\n",
            "tape block 2 (N2), line 3: the arc turns 360.0°",
        ),
        (
            "%\nN1G50X1234567\n",
            "tape block 1 (N1), line 2, column 6: X1234567: more than the 6 digits",
        ),
    ],
)
def test_errors_name_the_block(text: str, message: str) -> None:
    assert failure(text).startswith(message)


def test_options_are_checked() -> None:
    assert failure("%\nN1G50X10000\n", units="furlongs").startswith("option units")
    with pytest.raises(ImportFailure):
        read_program(b"G0 X1", "t", "gcode", {"units": "metric"})


def test_units_of_a_metric_program_from_the_header_comment() -> None:
    listing = export(load(GOLDEN / "tap-metric"), "tape-ascii").data
    result = read_program(listing, "t")
    assert result.program.units is Units.MM
    assert any("the header comment says MM" in str(n) for n in result.report)
