"""ProtoTRAK Plus events import (seed 003 §2.2), held to the manual's samples.

§2.2.5 shows one line of every event type; §2.2.6.3 is the sample part as the Plus itself
writes it — the same part §2.2.6.1 gives as G-code, so the two imports are compared. The
expected blocks are worked out by hand next to each test; the fixtures are the listings as
printed (tests/imports/seed003-2.2.5.cnc, seed003-2.2.6.3.cnc).
"""

from __future__ import annotations

import dataclasses
import math
from decimal import Decimal as D

import pytest

from app.cnc.blocks import Comp, Hole, MillingMode, Program
from app.cnc.formats.reading import ImportFailure, read_program
from app.cnc.geometry import bolt_circle_points
from app.cnc.interpret import interpret
from app.cnc.problems import Rule, Severity
from app.cnc.toolpath import ArcFeed, Feed
from app.cnc.units import Units
from app.cnc.validate import validate
from tests.imports.support import describe_all, fixture, with_rpms, xy_path
from tests.test_import_gcode import sample_2_2_6_1


def events(text: str) -> Program:
    return read_program(text.encode(), "e", "events").program


def notes(text: str) -> list[str]:
    return [str(n) for n in read_program(text.encode(), "e", "events").report]


def failure(text: str) -> str:
    with pytest.raises(ImportFailure) as caught:
        read_program(text.encode(), "e", "events")
    return str(caught.value)


# -- §2.2.5: one line of every event ----------------------------------------------------------

# Worked out from the listing with §2.2.2-2.2.4 (A: absolute, I: incremental; where from is
# our reading, docs/imports.md):
# N001 G100 X1.2A Y2.2I: from X0 Y0 (the start), Y 0 + 2.2 → POS X1.2 Y2.2, T01.
# N002 G101 XB1.05A YB2.025I XE1.0I YE3.0A TC1 CR-: begin Y = 2.2 + 2.025 = 4.225 (from the
#   position after N001); end X = 1.05 + 1.0 = 2.05 (from the begin point); TC1 = CUT RT;
#   F20.0; D0.555 is tool 2's diameter; CR-: not connected: a DRILL and one MILL STD.
# N003 G102 XB2.0A YB0A XE0A YE0A XC1.0A YC0I: centre Y = 0 + 0 (from the end point); a
#   clockwise half circle about X1 Y0 from X2 Y0 to X0 Y0, TC2 = CUT LT, tool 3 (D0.5).
# N004 G103: counter-clockwise from X-1 Y-1 to X1 Y1 about X0 Y0, TC0, F15.5, tool 4.
# N005 G104 XC1.75A YC0.75A HL05 R1.5 A15.0: BOLT CIR of 5, R1.5, θ0 = 270 − 15 = 255°.
# N006 G105 FE001 LE005 XO1.2 YO2.3 RE02: events 1-5 twice more, shifted (1.2, 2.3) and
#   (2.4, 4.6). They use tools 1-4 (a LOOP has one tool) and the step is along X and Y (a
#   REP steps one axis per count): written out as blocks — the same 11 blocks, shifted.
# N007 G106 XB1.0A YB1.0A XD2.0A YD2.0A DR1 FC0.05 CR0.25: a 1 × 1 rectangular pocket from
#   X1 Y1, corner radius 0.25, cut clockwise (DR1): Data Block 0's conventional milling
#   (climb would cut a pocket counter-clockwise); FC > 0: 2P; D0.23 is tool 1's diameter.
# N008 G107 XB-0.25A YB-0.5A XD0.25A YD1.0I DR1 TC1 FC0.02 CR0.3: YD = -0.5 + 1.0 = 0.5;
#   a 0.5 × 1 frame; TC1 (right of a clockwise travel) is inside: FRM 2P INSIDE.
# N009 G108 XC1.4I YC2.8I R0.75 DR1 TC1 FC0.04: centre from the position after N008 (its
#   corner Y-0.5): X1.15 Y2.3; a clockwise pocket, conventional as before; tool 7.
# N010 G109 XC-2.0A YC-1.0I R1.0 DR2 TC1 FC0: centre Y = 2.3 - 1.0 = 1.3 (after N009, its
#   centre); counter-clockwise with the tool right of the travel: OUTSIDE — conventional
#   milling cuts an outside circle counter-clockwise, as before.
FIRST = [
    "POS X1.2 Y2.2 T1",
    "DRILL CUT RT X1.05 Y4.225 T2",
    "MILL STD X2.05 Y3 F20",
    "DRILL CUT LT X2 Y0 T3",
    "MILL ARC C XY-CENT X1 Y0 F10",
    "MILL ARC XY-END X0 Y0",
    "DRILL X-1 Y-1 T4",
    "MILL ARC CC XY-CENT X0 Y0 F15.5",
    "MILL ARC XY-END X1 Y1",
    "DRILL X1.75 Y0.75 T1",
    "BOLT CIR DRILL 5 x R1.5 from 255",
]
EXPECTED_2_2_5 = [
    *FIRST,
    "POS X2.4 Y4.5 T1",
    "DRILL CUT RT X2.25 Y6.525 T2",
    "MILL STD X3.25 Y5.3 F20",
    "DRILL CUT LT X3.2 Y2.3 T3",
    "MILL ARC C XY-CENT X2.2 Y2.3 F10",
    "MILL ARC XY-END X1.2 Y2.3",
    "DRILL X0.2 Y1.3 T4",
    "MILL ARC CC XY-CENT X1.2 Y2.3 F15.5",
    "MILL ARC XY-END X2.2 Y3.3",
    "DRILL X2.95 Y3.05 T1",
    "BOLT CIR DRILL 5 x R1.5 from 255",
    "POS X3.6 Y6.8 T1",
    "DRILL CUT RT X3.45 Y8.825 T2",
    "MILL STD X4.45 Y7.6 F20",
    "DRILL CUT LT X4.4 Y4.6 T3",
    "MILL ARC C XY-CENT X3.4 Y4.6 F10",
    "MILL ARC XY-END X2.4 Y4.6",
    "DRILL X1.4 Y3.6 T4",
    "MILL ARC CC XY-CENT X2.4 Y4.6 F15.5",
    "MILL ARC XY-END X3.4 Y5.6",
    "DRILL X4.15 Y5.35 T1",
    "BOLT CIR DRILL 5 x R1.5 from 255",
    "DRILL X1 Y1 T1",
    "FRM 2P POCKET 1 x 1 CR0.25 F11 T1",
    "DRILL X-0.25 Y-0.5 T2",
    "FRM 2P INSIDE 0.5 x 1 CR0.3 F14 T2",
    "DRILL X1.15 Y2.3 T7",
    "CIR 2P POCKET R0.75 F10.4 T7",
    "DRILL X-2 Y1.3 T4",
    "CIRCLE OUTSIDE R1 F15 T4",
]


def test_2_2_5_every_event_type() -> None:
    result = read_program(fixture("seed003-2.2.5.cnc"), "listing.cnc")
    assert result.format == "events"
    program = result.program
    assert program.part_number == "2" and program.units is Units.INCH
    assert describe_all(program) == EXPECTED_2_2_5
    db0 = program.block0
    assert db0.milling is MillingMode.CONVENTIONAL
    assert [(t.number, t.diameter, t.rpm) for t in db0.tools] == [
        (1, D("0.23"), None),
        (2, D("0.555"), None),
        (3, D("0.5"), None),
        (4, D("0.75"), None),
        (7, D("0.125"), None),
    ]
    # 2-axis: no hole block has depths.
    assert not any(isinstance(b, Hole) and b.has_depth for b in program.blocks)
    # What validation then asks for: the speeds (the Plus sets them by hand), and the
    # sample's N008 frame, whose corner radius 0.3 does not fit its 0.5 in width and which
    # is narrower than its 0.555 in tool (§2.2.5 is a syntax sample; the import keeps the
    # numbers and validation names them).
    rules = {p.rule for p in validate(program) if p.severity is Severity.ERROR}
    assert rules == {Rule.TOOL_NO_RPM, Rule.FRAME_CORNER, Rule.ROUTINE_TOO_SMALL}


def test_2_2_5_report() -> None:
    text = fixture("seed003-2.2.5.cnc").decode()
    lines = notes(text)
    assert any(
        n.startswith(
            "assumed: line 7: G105 FE1 LE5 RE2: the events use tools 1 and 2 and 3 "
            "and 4 and a LOOP has one tool, so the repeats are written out"
        )
        for n in lines
    )
    assert "ignored: line 7: T02 on the G105: the repeated events keep their own tools" in lines
    assert any(n.startswith("ignored: line 8: TC2 on a pocket cut clockwise") for n in lines)
    assert any(n.startswith("assumed: line 8: FC0.05 in: 2P") for n in lines)
    assert any(n.startswith("became: line 8: DR1: Data Block 0 conventional") for n in lines)
    assert any(
        "A15.0 (counter-clockwise from +X) is a BOLT CIR angle of 255.00°" in n for n in lines
    )
    assert any(n.startswith("needs: line 2: tool 1 has no spindle speed") for n in lines)


# -- §2.2.6.3: the sample part, as the Plus writes it ---------------------------------------

# Worked out from the listing (after `XEQA`, the scan's misreading of `XE0A`):
# N001/N002 G104 XC0 YC0 HL05 R1.125 A45.0, tools 1 and 2: θ0 = 270° − 45° = 225°.
# N003 G108 R0.75 DR2 TC2 FC0.01 F8.0 D0.5 T03: a circular pocket, counter-clockwise: climb
#   milling (a climb pocket turns counter-clockwise on a clockwise spindle); FC0.01: 2P.
# N004 G103 XB0 YB-2.45 XE0 YE2.45 about X0 Y0, TC1: CUT RT, the arc counter-clockwise.
# N005 G101 XB0I YB0I (the begin is where N004 ended) to Y0.5045 with CR0.841 into
#   N006 G101 to X0 Y-2.45: the Plus rounds the corner. Both lines are straight, so the
#   fillet is the arc of radius 0.841 between the tangent points X-2.1613 Y1.0777 and
#   X-2.2943 Y-0.2377 about X-1.7105 Y0.3677 (worked out with the corner's half angle:
#   tangent length 0.841 / tan(½·angle)). It is the first line's CONRAD (issue 33): the
#   block keeps the corner Y0.504 (0.5045 rounded half-even to 0.001 in) and the
#   compile rounds it, within 0.001 in of those points (the corner moved 0.0005 in).
EXPECTED_2_2_6_3 = [
    "DRILL X0 Y0 T1",
    "BOLT CIR DRILL 5 x R1.125 from 225",
    "DRILL X0 Y0 T2",
    "BOLT CIR DRILL 5 x R1.125 from 225",
    "DRILL X0 Y0 T3",
    "CIR 2P POCKET R0.75 F8 T3",
    "DRILL CUT RT X0 Y-2.45 T3",
    "MILL ARC CC XY-CENT X0 Y0 F8",
    "MILL ARC XY-END X0 Y2.45",
    "MILL STD X-3.064 Y0.504 F8 CONRAD0.841",
    "MILL STD X0 Y-2.45 F8",
]


def sample_2_2_6_3() -> bytes:
    return fixture("seed003-2.2.6.3.cnc").replace(b"XEQA", b"XE0A")


def test_2_2_6_3_as_printed_refuses_the_misprint() -> None:
    """`XEQA`: XE followed by Q, not a number — an error naming the line and column."""
    message = failure(fixture("seed003-2.2.6.3.cnc").decode())
    assert message == "line 5, column 27: XE needs a number; found 'QA ' (a misprinted 0? XEQ…)"


def test_2_2_6_3_imports_to_the_sample_part() -> None:
    result = read_program(sample_2_2_6_3(), "sample.cnc")
    program = result.program
    assert result.format == "events"
    assert program.name == "SAMPLE P/N"
    assert describe_all(program) == EXPECTED_2_2_6_3
    assert program.block0.milling is MillingMode.CLIMB
    drill = program.blocks[6]
    assert isinstance(drill, Hole) and drill.comp is Comp.RIGHT
    finished = dataclasses.replace(
        program,
        blocks=tuple(
            dataclasses.replace(b, comp=Comp.NONE) if b is drill else b for b in program.blocks
        ),
    )
    fillets = [
        m for m in interpret(with_rpms(finished, {})).moves if getattr(m, "tag", "") == "conrad"
    ]
    assert len(fillets) == 1 and isinstance(fillets[0], ArcFeed)
    fillet = fillets[0]
    for got, wanted in (
        (fillet.x, -2.2943),
        (fillet.y, -0.2377),
        (fillet.cx, -1.7105),
        (fillet.cy, 0.3677),
    ):
        assert abs(got / 25.4e6 - wanted) <= 0.001
    assert [(t.number, t.diameter) for t in program.block0.tools] == [
        (1, None),
        (2, None),
        (3, D("0.5")),
    ]


def test_2_2_6_3_is_the_same_part_as_2_2_6_1() -> None:
    """The events (§2.2.6.3) and the Fanuc listing (§2.2.6.1) import to the same holes and
    the same contour in XY. Allowed differences, each for its reason:

    - depths: the events are 2-axis (no Z), the G-code drills to Z-0.1 and Z-0.6;
    - the pocket: a G108 routine (MillBlocks plans its own passes) against the listing's
      explicit circles of 0.115, 0.49 and 0.5; both cut the wall pass, a full circle of 0.5
      (0.75 less the 0.25 tool radius) about X0 Y0, and nothing farther out;
    - the contour: the events give the finished contour with CUT RT and D0.5, the listing
      the tool centre's path; MillBlocks' compensation makes the listing's path within
      0.0012 in (the fillet's points are rounded to 0.001 in), except that the listing
      closes the contour with the corner arc about X0 Y-2.45 (N47), where MillBlocks stops
      at the end of the last offset line (docs/readings.md), and where the rounded fillet
      meets a line the listing has a link of under 0.0006 in in X and Y (MillBlocks one of
      0.0003 in: a joint whose turn is below the programming resolution is a tangent).
    """
    plus = with_rpms(read_program(sample_2_2_6_3(), "s").program, {})
    fanuc = read_program(sample_2_2_6_1().encode(), "s").program
    # The same holes: the same BOLT CIR blocks.
    plus_bolts = [b for b in plus.blocks if b.kind == "BOLT_CIR"]
    fanuc_bolts = [b for b in fanuc.blocks if b.kind == "BOLT_CIR"]
    assert plus_bolts == fanuc_bolts and len(plus_bolts) == 2
    holes = bolt_circle_points((0, 0), 28_575_000, 5, D(225))
    assert [(round(x / 25.4e6, 4), round(y / 25.4e6, 4)) for x, y in holes] == [
        (0.7955, 0.7955),
        (1.0024, -0.5107),
        (-0.176, -1.1111),
        (-1.1111, -0.176),
        (-0.5107, 1.0024),
    ]
    # The pocket's wall pass.
    for program, blocks in ((plus, slice(4, 6)), (fanuc, slice(4, 20))):
        part = dataclasses.replace(program, blocks=program.blocks[blocks])
        moves = interpret(with_rpms(part, {})).moves
        arcs = [m for m in moves if isinstance(m, ArcFeed)]
        assert any((m.cx, m.cy) == (0, 0) and math.hypot(m.x, m.y) == 12_700_000 for m in arcs)
        assert max(math.hypot(m.x, m.y) for m in arcs) <= 12_700_000
    # The contour.
    plus_part = dataclasses.replace(plus, blocks=plus.blocks[6:])
    fanuc_part = dataclasses.replace(fanuc, blocks=fanuc.blocks[20:31])
    ours = xy_path(interpret(plus_part), shortest=15_240)
    theirs = xy_path(interpret(with_rpms(fanuc_part, {})), shortest=15_240)
    closing = theirs.pop()
    assert closing.centre == (0, -62_230_000) and closing.end == (0, -68_580_000)
    assert len(ours) == len(theirs)
    for a, b in zip(ours, theirs, strict=True):
        assert (a.centre is None) == (b.centre is None)
        assert abs(a.end[0] - b.end[0]) <= 30_480 and abs(a.end[1] - b.end[1]) <= 30_480
        if a.centre is not None and b.centre is not None:
            assert a.clockwise == b.clockwise
            assert max(abs(a.centre[0] - b.centre[0]), abs(a.centre[1] - b.centre[1])) <= 30_480


# -- numbers and tags (§2.2.4) ----------------------------------------------------------------


def test_implied_decimals_tags_and_defaults() -> None:
    """§2.2.4: `+1234` = 0.1234 in, `-123456` = -12.3456 in, `00.1000` and `.1` = 0.1,
    `-1.` = -1; the I tag adds to the position before (Y1.5I after Y0.1: 1.6); after G91
    an untagged value is incremental, an A tag still absolute; no T: tool 1 (the default)."""
    program = events(
        "PN7 G20;\nN1 G100 X+1234 Y-123456 T1;\nN2 G100 X00.1000 Y.1;\nN3 G100 X-1. Y1.5I;\n"
        "N4 G91;\nN5 G100 X1.0 Y1.0A T2;\n"
    )
    assert describe_all(program) == [
        "POS X0.123 Y-12.346 T1",
        "POS X0.1 Y0.1 T1",
        "POS X-1 Y1.6 T1",
        "POS X0 Y1 T2",
    ]


def test_metric_numbers_feeds_and_diameters() -> None:
    """G21: `1234.56` mm as written, `+1234` = 12.34 mm, `XE10A` = 0.10 mm; a metric feed is
    whole mm/min (F5 → FEEDR XY 4: MillBlocks' metric feeds go in steps of 2, reported);
    `D+1.35` = 1.35 mm."""
    text = "PN1 G21;\nN1 G100 X1234.56 Y+1234 T1;\nN2 G101 XB0A YB0A XE10A YE0A F5 D+1.35 CR- T1;\n"
    program = events(text)
    assert program.units is Units.MM
    assert describe_all(program) == [
        "POS X1234.56 Y12.34 T1",
        "DRILL X0 Y0 T1",
        "MILL STD X0.1 Y0 F4",
    ]
    tool = program.block0.tool(1)
    assert tool is not None and tool.diameter == D("1.35")
    assert any("FEEDR XY 5 mm/min → 4" in n for n in notes(text))


def test_angles_and_inch_feeds() -> None:
    """`A-300000` = -300°: θ0 = 270 − (−300) = 570 = 210°; `A.12` = 0.12°: 269.88°;
    `F1` = 0.1 ipm, `F1.` = 1.0 ipm, `F99.9`."""
    program = events(
        "PN1 G20;\nN1 G104 XC0A YC0A HL04 R1.0 A-300000 T1;\nN2 G104 XC0A YC0A HL04 R1.0 A.12 "
        "T1;\nN3 G101 XB0A YB0A XE1.0A YE0A F1 CR0 T1;\nN4 G101 XB1.0A YB0A XE2.0A YE0A F1. CR0 "
        "T1;\nN5 G101 XB2.0A YB0A XE3.0A YE0A F99.9 CR- T1;\n"
    )
    assert describe_all(program) == [
        "DRILL X0 Y0 T1",
        "BOLT CIR DRILL 4 x R1 from 210",
        "DRILL X0 Y0 T1",
        "BOLT CIR DRILL 4 x R1 from 269.88",
        "DRILL X0 Y0 T1",
        "MILL STD X1 Y0 F0.1",
        "MILL STD X2 Y0 F1",
        "MILL STD X3 Y0 F99.9",
    ]


# -- repeats, conrads, routines -----------------------------------------------------------------


def test_g105_of_the_events_just_before_along_x_is_a_loop() -> None:
    program = events(
        "PN1 G20;\nN1 G100 X1.0A Y1.0A T1;\nN2 G100 X1.5A Y1.0A T1;\n"
        "N3 G105 FE001 LE002 XO1.0 YO0 RE03 T01;\n"
    )
    assert describe_all(program) == [
        "INC LOOP POS X1 Y1 T1",
        "INC POS X0.5 Y0 T1",
        "INC REP X1 Y0 NX3 NY0",
    ]
    assert [b for b in interpret(with_rpms(program, {})).moves if b.block == 0] == []


def test_g105_that_no_rep_can_make_is_written_out() -> None:
    text = "PN1 G20;\nN1 G100 X1.0A Y1.0A T1;\nN2 G105 FE1 LE1 XO1.0 YO0.5 RE02 T01;\n"
    assert describe_all(events(text)) == ["POS X1 Y1 T1", "POS X2 Y1.5 T1", "POS X3 Y2 T1"]
    assert any("a REP steps along one axis per count" in n for n in notes(text))


def test_conrad_between_two_lines_is_the_blocks_conrad() -> None:
    """CR0.5 at the corner X2 Y0 of a line along X and one along Y: the first line's CONRAD;
    the compile cuts the fillet between the tangent points 0.5 from the corner (a right
    angle), a counter-clockwise quarter about X1.5 Y0.5."""
    text = (
        "PN1 G20;\nN1 G101 XB0A YB0A XE2.0A YE0A TC0 F10.0 CR0.5 T1;\n"
        "N2 G101 XB2.0A YB0A XE2.0A YE2.0A TC0 F10.0 CR- T1;\n"
    )
    program = events(text)
    assert describe_all(program) == [
        "DRILL X0 Y0 T1",
        "MILL STD X2 Y0 F10 CONRAD0.5",
        "MILL STD X2 Y2 F10",
    ]
    cuts = [m for m in interpret(with_rpms(program, {})).moves if isinstance(m, Feed | ArcFeed)]
    inch = 25_400_000
    assert [(m.x, m.y) for m in cuts] == [
        (int(1.5 * inch), 0),
        (2 * inch, inch // 2),
        (2 * inch, 2 * inch),
    ]
    assert isinstance(cuts[1], ArcFeed) and (cuts[1].cx, cuts[1].cy) == (int(1.5 * inch), inch // 2)
    assert not cuts[1].clockwise


def test_conrad_next_to_an_arc_is_the_arcs_conrad() -> None:
    """CR0.2 after a quarter arc that ends across the next line (not tangent): the QCIR's
    CONRAD. At a tangent joint there is no corner: reported, the corner left as it is."""
    text = (
        "PN1 G20;\nN1 G103 XB1.0A YB0A XE0A YE1.0A XC0A YC0A F10.0 CR0.2 T1;\n"
        "N2 G101 XB0A YB1.0A XE0A YE2.0A F10.0 CR- T1;\n"
    )
    assert describe_all(events(text)) == [
        "DRILL X1 Y0 T1",
        "MILL QCIR CC X0 Y1 F10 CONRAD0.2",
        "MILL STD X0 Y2 F10",
    ]
    tangent = (
        "PN1 G20;\nN1 G103 XB1.0A YB0A XE0A YE1.0A XC0A YC0A F10.0 CR0.2 T1;\n"
        "N2 G101 XB0A YB1.0A XE-1.0A YE1.0A F10.0 CR- T1;\n"
    )
    assert describe_all(events(tangent))[1] == "MILL QCIR CC X0 Y1 F10"
    assert any(
        "line 2: CR0.2 in: the corner is tangent (the segments blend), so there is nothing to "
        "round; the corner stays sharp" in n
        for n in notes(tangent)
    )


def test_frames_and_circles_from_tc_and_dr() -> None:
    """G107 DR1 TC2: clockwise with the tool left of the travel: OUTSIDE (climb cuts an
    outside frame clockwise). G109 DR1 TC1: INSIDE clockwise needs conventional: reported.
    G107 with TC0: the tool centre on the rectangle, a contour from the middle of its
    lower side, clockwise: to X0 Y0 first."""
    text = (
        "PN1 G20;\nN1 G107 XB0A YB0A XD2.0A YD1.0A DR1 TC2 FC0 F10.0 D0.25 CR0.1 T1;\n"
        "N2 G109 XC5.0A YC5.0A R1.0 DR1 TC1 FC0 F10.0 D0.25 T1;\n"
        "N3 G107 XB0A YB0A XD2.0A YD1.0A DR1 TC0 FC0 F10.0 D0.25 CR0 T1;\n"
    )
    program = events(text)
    assert describe_all(program) == [
        "DRILL X0 Y0 T1",
        "FRAME OUTSIDE 2 x 1 CR0.1 F10 T1",
        "DRILL X5 Y5 T1",
        "CIRCLE INSIDE R1 F10 T1",
        "DRILL X1 Y0 T1",
        "MILL STD X0 Y0 F10",
        "MILL STD X0 Y1 F10",
        "MILL STD X2 Y1 F10",
        "MILL STD X2 Y0 F10",
        "MILL STD X1 Y0 F10",
    ]
    assert program.block0.milling is MillingMode.CLIMB
    assert any(
        n.startswith("ignored: line 3: DR1: the Plus cuts this clockwise") for n in notes(text)
    )


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("N1 G100 X1.0A Y1.0A T1;\n", "line 1, column 1: an event before the label line's G20/G21"),
        (
            "SAMPLE;\nN1 G100 X1.0A T1;\n",
            "line 1, column 1: the label line 'SAMPLE' ends without G20",
        ),
        ("PN1 G20;\nN1 G100 X1.0A Y1.0A Q1;\n", "line 2, column 21: 'Q' is not an event code"),
        ("PN1 G20;\nN1 G100 XB1.0A;\n", "line 2, column 9: XB is not a word of a G100 event"),
        ("PN1 G20;\nN1 G01 X1.0;\n", "line 2, column 4: G1 is not an event (G100-G109)"),
        ("PN1 G20;\nN1 G100 X1.0A X2.0A;\n", "line 2, column 15: X given twice in one event"),
        ("PN1 G20;\nN1 G104 XC0A YC0A R1.0 T1;\n", "line 2, column 1: HL missing"),
        (
            "PN1 G20;\nN1 G104 XC0A YC0A HL3 R-1.0 T1;\n",
            "line 2, column 23: R-1.0: no negative signs",
        ),
        (
            "PN1 G20;\nN1 G102 XB1.0A YB0A XE0A YE1.2A XC0A YC0A F1. T1;\n",
            "line 2, column 1: the arc's end is 0.2 in off its radius",
        ),
        ("PN1 G20;\nN1 G105 FE1 LE1 RE1;\n", "line 2, column 1: FE1 LE1: a repeat takes events"),
        (
            "PN1 G20;\nN1 G100 X1.0A Y0A T1;\nN2 G105 FE1 LE1 XO1.0 RE1;\n"
            "N3 G105 FE1 LE2 XO1.0 RE1;\n",
            "line 4, column 1: FE1 LE2 takes in the repeat of event 2",
        ),
        ("PN1 G20;\nN1 G100 X1.0A (open;\n", "line 2, column 15: comment not closed"),
        ("PN1 G20;\n", "no events (G100-G109) in the file"),
    ],
)
def test_errors_name_line_and_column(text: str, message: str) -> None:
    assert failure(text).startswith(message)


def test_two_axis_program_asks_only_for_speeds() -> None:
    program = read_program(sample_2_2_6_3(), "s").program
    rules = {p.rule for p in validate(program) if p.severity is Severity.ERROR}
    assert rules == {Rule.TOOL_NO_RPM}
    assert validate(with_rpms(program, {})) == [] or all(
        p.severity is Severity.WARNING for p in validate(with_rpms(program, {}))
    )
