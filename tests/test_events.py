"""The ProtoTRAK Plus events target, against numbers worked out by hand from seed 003 §2.2.

The sample part of §2.2.6 (two bolt circles, a circular pocket, a contour) is entered as a
MillBlocks program and must export to the events the Plus itself writes for it (§2.2.6.3),
with the differences listed in `test_sample_part_differs_from_the_manual_only_as_listed`.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import replace
from decimal import Decimal as D
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from app.cnc import document
from app.cnc.blocks import (
    ArcEnd,
    Block,
    BoltCircle,
    Circle,
    Comp,
    DataBlock0,
    Direction,
    Engrave,
    Face,
    Frame,
    Helix,
    Hole,
    HoleOp,
    MillArc,
    MillingMode,
    MillLine,
    Mode,
    Placement,
    Pos,
    Program,
    Rep,
    ThreadMill,
    Tool,
)
from app.cnc.compiler import compile_program
from app.cnc.copy import resolve_copies
from app.cnc.formats.events import writer
from app.cnc.formats.events.model import (
    Mill,
    Position,
    Routine,
    format_angle,
    format_dimension,
    format_feed,
    millblocks_angle,
    plus_angle,
    plus_holes,
)
from app.cnc.formats.events.writer import build_events, check_events
from app.cnc.formats.targets import Export, ExportError, Report, export
from app.cnc.interpret import interpret
from app.cnc.problems import Severity as ProblemSeverity
from app.cnc.toolpath import ArcFeed, Dwell, Feed, Rapid
from app.cnc.units import NM_PER_INCH, NM_PER_MM, Units
from app.cnc.validate import validate
from bench.programs import sized
from tests.export_support import traced_export

GOLDEN = Path(__file__).parent / "golden"
CASES = sorted(p for p in GOLDEN.iterdir() if (p / "program.json").exists())
INCH = NM_PER_INCH


def lines(result: Export) -> list[str]:
    """The event file's lines (CR LF line ends, as written by default)."""
    text = result.data.decode("ascii")
    assert text.endswith("\r\n") and "\n" not in text.replace("\r\n", "")
    return text.split("\r\n")[:-1]


def entries(result: Export) -> list[str]:
    return [str(e) for e in result.report.entries]


def make(
    *blocks: Block,
    units: Units = Units.INCH,
    tools: tuple[Tool, ...] = (),
    milling: MillingMode = MillingMode.CLIMB,
    part_number: str = "12",
) -> Program:
    if not tools:
        dia = D("0.5") if units is Units.INCH else D(12)
        tools = (Tool(number=1, diameter=dia, rpm=1000), Tool(number=2, diameter=dia, rpm=800))
    program = Program(
        name="test",
        part_number=part_number,
        units=units,
        block0=DataBlock0(current_tool=1, milling=milling, tools=tools),
        blocks=blocks,
    )
    problems = [str(p) for p in validate(program) if p.severity is ProblemSeverity.ERROR]
    assert problems == []
    return program


def drill(
    x: str | int,
    y: str | int,
    tool: int = 1,
    z_dn: str | None = "-0.25",
    comp: Comp = Comp.NONE,
    pecks: int = 1,
    mode: Mode = Mode.ABS,
    loop: bool = False,
) -> Hole:
    depth = z_dn is not None
    return Hole(
        op=HoleOp.DRILL,
        x=D(x),
        y=D(y),
        z_up=D("0.05") if depth else None,
        z_dn=None if z_dn is None else D(z_dn),
        feed_z=D(5) if depth else None,
        pecks=pecks,
        tool=tool,
        comp=comp,
        mode=mode,
        loop=loop,
    )


def line(x: str | int, y: str | int, z_dn: str | None = "-0.25", tool: int = 1) -> MillLine:
    return MillLine(x=D(x), y=D(y), z_dn=None if z_dn is None else D(z_dn), feed_xy=D(8), tool=tool)


# -- the sample part, seed 003 §2.2.6 ----------------------------------------------------------

# §2.2.6.3 as printed (`XEQA` is the manual's misprint of `XE0A`).
SEED_EVENTS = [
    "SAMPLE P/N G20;",
    "N001 G104 XC0A YC0A HL05 R1.125 A45.0 T01;",
    "N002 G104 XC0A YC0A HL05 R1.125 A45.0 T02;",
    "N003 G108 XC0A YC0A R0.75 DR2 TC2 FC0.01 F8.0 D0.5 T03;",
    "N004 G103 XB0A YB-2.45A XEQA YE2.45A XC0A YC0A F8.0 TC1 D0.5 CR0 T03;",
    "N005 G101 XB0I YB0I XE-3.064A YE0.5045A TC1 F8.0 D0.5 CR0.841 T03;",
    "N006 G101 XB0I YB0I XE0A YE-2.45A TC1 F8.0 D0.5 CR- T03;",
]
# §2.2.6.1, the same part from a Fanuc 6 post: the bolt holes in the order drilled (N3, N6-N9).
SEED_HOLES = [
    (0.7955, 0.7955),
    (-0.5107, 1.0024),
    (-1.1111, -0.176),
    (-0.176, -1.1111),
    (1.0024, -0.5107),
]


def sample_part() -> Program:
    """The §2.2.6 sample part as MillBlocks blocks.

    From the Fanuc listing (§2.2.6.1): tools 1 and 2 drill 5 holes on R 1.125 about (0, 0)
    (Z-0.1 and Z-0.6, R plane 0.05, F5), the first at X0.7955 Y0.7955, i.e. 45°
    counter-clockwise from +X: a BOLT CIR angle θ0 = 270° − 45° = 225° (DESIGN.md §3).
    Tool 3 (Ø0.5, S1000 M03: clockwise spindle) cuts a circular pocket R 0.75 at (0, 0) in
    two passes (FC0.01: CIR 2P POCKET; climb, so counter-clockwise inside, DR2), then a
    contour to the right of the travel (TC1: CUT RT) from (0, -2.45): an arc counter-
    clockwise about (0, 0) to (0, 2.45), a line toward the corner X-3.064 Y0.5045, the
    corner rounded (CR0.841), a line back to (0, -2.45).

    MillBlocks has no conrad on a mill line, so the rounded corner is an ARC CC block between
    two tangent points; typed to 0.001 in, the points nearest the manual's fillet that keep
    both joints from turning inward are (-2.162, 1.074) and (-2.294, -0.236) about
    (-1.712, 0.367): radius √(0.45² + 0.707²) = 0.8381 in, and √(0.582² + 0.603²) = 0.8380
    in at the end.
    """
    tools = (
        Tool(number=1, diameter=D("0.201"), rpm=1000),
        Tool(number=2, diameter=D("0.201"), rpm=1000),
        Tool(number=3, diameter=D("0.5"), rpm=1000),
    )
    bolt = BoltCircle(op=HoleOp.DRILL, holes=5, angle=D(225), radius=D("1.125"))
    contour = (
        MillArc(direction=Direction.CCW, x=D(0), y=D(0), z_dn=D("-0.5"), feed_xy=D(8), tool=3),
        ArcEnd(x=D(0), y=D("2.45")),
        MillLine(x=D("-2.162"), y=D("1.074"), z_dn=D("-0.5"), feed_xy=D(8), tool=3),
        MillArc(
            direction=Direction.CCW,
            x=D("-1.712"),
            y=D("0.367"),
            z_dn=D("-0.5"),
            feed_xy=D(8),
            tool=3,
        ),
        ArcEnd(x=D("-2.294"), y=D("-0.236")),
        MillLine(x=D(0), y=D("-2.45"), z_dn=D("-0.5"), feed_xy=D(8), tool=3),
    )
    return make(
        drill(0, 0, tool=1, z_dn="-0.1"),
        bolt,
        drill(0, 0, tool=2, z_dn="-0.6"),
        bolt,
        drill(0, 0, tool=3),
        Circle(placement=Placement.POCKET, two_pass=True, radius=D("0.75"), feed_xy=D(8), tool=3),
        drill(0, "-2.45", tool=3, z_dn="-0.5", comp=Comp.RIGHT),
        *contour,
        tools=tools,
        part_number="",
    )


def test_sample_part_exports_to_the_events_of_the_manual() -> None:
    """§2.2.6.3, event by event, with the numbers of §2.2.4/§2.2.5.

    N001/N002: the bolt circles, A = 270° − 225° = 45.0, tools 1 and 2. N003: CIR 2P
    POCKET → G108, DR2 (counter-clockwise) TC2 (left of it: inside), FC0.01 (2P leaves
    0.010 in), F8.0, D0.5, T03. N004: the arc → G103 from (0, -2.45) to (0, 2.45) about
    (0, 0), TC1 (CUT RT), CR0 (connected). N005-N007: line, fillet arc, line; the last is
    not connected (CR-), the end of the mill sequence. No part number: PN0, the default.
    """
    result = export(sample_part(), "events")
    assert lines(result) == [
        "%",
        "PN0 G20;",
        "N001 G104 XC0A YC0A HL05 R1.125 A45.0 T01;",
        "N002 G104 XC0A YC0A HL05 R1.125 A45.0 T02;",
        "N003 G108 XC0A YC0A R0.75 DR2 TC2 FC0.01 F8.0 D0.5 T03;",
        "N004 G103 XB0A YB-2.45A XE0A YE2.45A XC0A YC0A F8.0 TC1 D0.5 CR0 T03;",
        "N005 G101 XB0A YB2.45A XE-2.162A YE1.074A TC1 F8.0 D0.5 CR0 T03;",
        "N006 G103 XB-2.162A YB1.074A XE-2.294A YE-0.236A XC-1.712A YC0.367A F8.0 TC1 "
        "D0.5 CR0 T03;",
        "N007 G101 XB-2.294A YB-0.236A XE0A YE-2.45A TC1 F8.0 D0.5 CR- T03;",
        "%",
    ]
    assert not any(e.severity.value in ("error", "warning") for e in result.report.entries)


def _words(event_line: str) -> dict[str, str]:
    words = event_line.rstrip(";").split()
    return {w.rstrip("-.0123456789AIQ"): w for w in words[1:]}


def _number(word: str, code: str) -> float:
    return float(word[len(code) :].rstrip("AI"))


def test_sample_part_differs_from_the_manual_only_as_listed() -> None:
    """The allowed differences from §2.2.6.3, each named:

    1. `%` lines around the file (§2.2.3: "%  Beginning and End of File Character"), and
       `PN0 G20;` for the label line the manual prints as `SAMPLE P/N G20;` (§2.2.5 `PN2 G20;`).
    2. `XEQA` is the manual's misprint of `XE0A` (the arc ends on the Y axis at (0, 2.45)).
    3. A begin point continuing the previous event is written absolute (`XB0A YB2.45A`), not
       as `XB0I YB0I`.
    4. The fillet: the manual's line N005 to the virtual corner X-3.064 Y0.5045 with CR0.841
       becomes a line to the first tangent point, a G103 arc of radius 0.838 (the fillet
       typed to 0.001 in), and the manual's N006 is our N007 — same end, same CR-.
    """
    ours = lines(export(sample_part(), "events"))
    assert ours[0] == "%" and ours[-1] == "%"
    assert ours[1] == "PN0 G20;" and SEED_EVENTS[0].endswith(" G20;")
    seed = [s.replace("XEQA", "XE0A") for s in SEED_EVENTS[1:]]
    assert ours[2:6] == seed[:4]
    n005, n006 = _words(seed[4]), _words(seed[5])
    line1, fillet, line2 = (_words(s) for s in ours[6:9])
    # 3: begins where the arc N004 ended, (0, 2.45).
    assert (line1["XB"], line1["YB"]) == ("XB0A", "YB2.45A")
    # 4: our first line runs along the manual's N005 (from (0, 2.45) toward the corner):
    # its end is within 0.005 in of that line.
    x1, y1 = _number(line1["XE"], "XE"), _number(line1["YE"], "YE")
    cx, cy = _number(n005["XE"], "XE"), _number(n005["YE"], "YE")
    off_line = abs((cx - 0) * (y1 - 2.45) - (cy - 2.45) * (x1 - 0)) / math.hypot(cx, cy - 2.45)
    assert off_line < 0.005
    # The fillet's radius is the manual's CR0.841 within 0.005 in.
    xc, yc = _number(fillet["XC"], "XC"), _number(fillet["YC"], "YC")
    assert abs(math.dist((x1, y1), (xc, yc)) - _number(n005["CR"], "CR")) < 0.005
    assert fillet["G"] == "G103"
    # Our N007 is the manual's N006 apart from the begin point.
    for code in ("XE", "YE", "TC", "F", "D", "CR", "T"):
        assert line2[code] == n006[code]
    for words in (line1, fillet):
        for code in ("TC", "F", "D", "T"):
            assert words[code] == n005[code]


def test_bolthole_angle_both_ways_on_the_sample() -> None:
    """A_plus = 270° − θ0 and back (DESIGN.md §3), with the holes of §2.2.6.1.

    θ0 = 225° (clockwise from straight below) is A45.0 (counter-clockwise from +X), and
    45° → 225°. From A45.0 the Plus drills 45°, 117°, 189°, 261°, 333° (72° apart,
    counter-clockwise): 1.125·(cos, sin) of those is the Fanuc listing's X0.7955 Y0.7955,
    X-0.5107 Y1.0024, … MillBlocks drills the same first hole, then clockwise: the same
    holes with the last four in reverse order.
    """
    assert plus_angle(D(225)) == D(45)
    assert millblocks_angle(D(45)) == D(225)
    for theta0, a_plus in [
        ("0", "270"),
        ("90", "180"),
        ("270", "0"),
        ("300", "330"),
        ("0.01", "269.99"),
    ]:
        assert plus_angle(D(theta0)) == D(a_plus)
        assert millblocks_angle(D(a_plus)) == D(theta0)
    radius = 1.125 * INCH
    plus = [(x / INCH, y / INCH) for x, y in plus_holes((0.0, 0.0), radius, 5, D(45))]
    assert [(round(x, 4), round(y, 4)) for x, y in plus] == SEED_HOLES
    toolpath = interpret(sample_part())
    x = y = 0
    drilled = []
    for move in toolpath.moves:
        if isinstance(move, Rapid | Feed):
            x, y = move.x, move.y
        elif isinstance(move, Dwell) and move.block == 2:
            drilled.append((round(x / INCH, 4), round(y / INCH, 4)))
    first, *others = SEED_HOLES
    assert drilled == [first, *reversed(others)]


@pytest.mark.parametrize(
    ("value", "units", "text"),
    [
        # §2.2.4 inch: 12.3456 = +12.3456, -1. = -1.0000, .1 = 0.1000 (we always write the
        # point and one decimal; zero as in the listings' `YB0A`).
        ("12.3456", Units.INCH, "12.3456"),
        ("-12.3456", Units.INCH, "-12.3456"),
        ("0.1234", Units.INCH, "0.1234"),
        ("-1", Units.INCH, "-1.0"),
        ("0.1", Units.INCH, "0.1"),
        ("1.2", Units.INCH, "1.2"),
        ("0", Units.INCH, "0"),
        ("0.00005", Units.INCH, "0"),  # half a step rounds to even: 0
        ("0.00015", Units.INCH, "0.0002"),  # 1.5 steps round to even: 2
        ("-0.00004", Units.INCH, "0"),  # no negative zero
        # §2.2.4 metric: 1234.56 = +1234.56 mm, +1234 = 12.34 mm with implied decimals.
        ("1234.56", Units.MM, "1234.56"),
        ("-1234.56", Units.MM, "-1234.56"),
        ("12.34", Units.MM, "12.34"),
        ("-1", Units.MM, "-1.0"),
        ("0.1", Units.MM, "0.1"),
        ("0.005", Units.MM, "0"),
    ],
)
def test_dimension_format(value: str, units: Units, text: str) -> None:
    nm = int(D(value) * units.nm)
    assert format_dimension(nm, units) == text


def test_feed_angle_and_code_formats() -> None:
    """§2.2.4: inch feeds with their point (`F1` would be 0.1 ipm), metric feeds whole
    mm/min (`F2535`), angles to 0.001° (`A-300.000`); §2.2.5: `A15.0`, `T01`, `HL05`."""
    assert format_feed(8 * 2_540_000 * 10, Units.INCH) == "8.0"
    assert format_feed(155 * 2_540_000, Units.INCH) == "15.5"
    assert format_feed(1 * 2_540_000, Units.INCH) == "0.1"
    assert format_feed(2535 * NM_PER_MM, Units.MM) == "2535"
    assert format_feed(220 * NM_PER_MM, Units.MM) == "220"
    assert format_angle(D(45)) == "45.0"
    assert format_angle(D("269.99")) == "269.99"
    assert format_angle(D("-300")) == "-300.0"
    assert format_angle(D(0)) == "0"
    result = export(make(drill(1, 1), BoltCircle(op=HoleOp.DRILL, holes=5, radius=D(1))), "events")
    assert lines(result)[2] == "N001 G104 XC1.0A YC1.0A HL05 R1.0 A270.0 T01;"


def test_metric_file() -> None:
    """G21; dimensions to 0.01 mm (12.5 mm → `12.5`), feeds in whole mm/min."""
    blocks = (
        drill("10.5", 20, z_dn="-5"),
        MillLine(x=D("22.75"), y=D(20), z_dn=D(-5), feed_xy=D(250), tool=1),
    )
    blocks = (replace(blocks[0], feed_z=D(100)), blocks[1])
    program = make(*(replace(b, units=Units.MM) for b in blocks), units=Units.MM)
    assert lines(export(program, "events"))[1:4] == [
        "PN12 G21;",
        "N001 G101 XB10.5A YB20.0A XE22.75A YE20.0A TC0 F250 D12.0 CR- T01;",
        "%",
    ]


# -- conrad ------------------------------------------------------------------------------------


def test_conrad_connected_until_the_depth_changes_and_at_the_end() -> None:
    """CR0 between events of one mill sequence at one depth; CR- (not connected, §2.2.4)
    on the event before a Z DN change (the operator moves the quill) and on the last."""
    program = make(
        drill(0, 0, z_dn="-0.25"),
        line(1, 0),
        line(1, 1),
        line(0, 1, z_dn="-0.4"),
        line(0, 0, z_dn="-0.4"),
    )
    result = export(program, "events")
    conrads = [ln.split()[-2] for ln in lines(result)[2:-1]]
    assert conrads == ["CR0", "CR-", "CR0", "CR-"]
    assert (
        "lost: block 4: Z DN -0.4: the depth changes here; the event before ends not "
        "connected (CR-) and the operator moves the quill by hand"
    ) in entries(result)


def test_two_axis_contour_is_connected() -> None:
    program = make(drill(0, 0, z_dn=None), line(1, 0, None), line(1, 1, None))
    conrads = [ln.split()[-2] for ln in lines(export(program, "events"))[2:-1]]
    assert conrads == ["CR0", "CR-"]


def test_full_circle_arc_is_two_half_circles() -> None:
    """ARC CC about (1, 0) from (0, 0) back to (0, 0): G103 to (2, 0), then G103 back."""
    program = make(
        drill(0, 0),
        MillArc(direction=Direction.CCW, x=D(1), y=D(0), z_dn=D("-0.25"), feed_xy=D(8), tool=1),
        ArcEnd(x=D(0), y=D(0)),
    )
    result = export(program, "events")
    assert lines(result)[2:4] == [
        "N001 G103 XB0A YB0A XE2.0A YE0A XC1.0A YC0A F8.0 TC0 D0.5 CR0 T01;",
        "N002 G103 XB2.0A YB0A XE0A YE0A XC1.0A YC0A F8.0 TC0 D0.5 CR- T01;",
    ]
    assert "rewritten: block 2: a full-circle arc is written as two half-circle events" in (
        entries(result)
    )


# -- LOOP/REP ----------------------------------------------------------------------------------


def loop(rep: Rep, tool: int = 1) -> Program:
    return make(
        Pos(x=D(1), y=D(1), tool=tool),
        drill(0, 0, tool=tool, mode=Mode.INC, loop=True),
        rep,
    )


def test_one_row_loop_is_one_g105() -> None:
    """REP X0.75 NX3: the hole at (1, 1) and 3 more, each 0.75 further: G105 FE002 LE002
    XO0.75 YO0 RE03 (XO/YO are offsets: no A/I tag, §2.2.5 N006). REP Y0.5 NY2 (NX0) is a
    series along Y; the Y of a REP with NY0 moves nothing, so YO0."""
    row = export(loop(Rep(x=D("0.75"), y=D("0.5"), nx=3)), "events")
    assert lines(row)[2:5] == [
        "N001 G100 X1.0A Y1.0A T01;",
        "N002 G100 X1.0A Y1.0A T01;",
        "N003 G105 FE002 LE002 XO0.75 YO0 RE03 D0.5 T01;",
    ]
    column = export(loop(Rep(x=D("0.75"), y=D("0.5"), ny=2)), "events")
    assert lines(column)[4] == "N003 G105 FE002 LE002 XO0 YO0.5 RE02 D0.5 T01;"
    assert not any("G105" in e for e in entries(row) + entries(column))


def test_grid_writes_each_row_with_its_g105_and_reports_it() -> None:
    """loop-rep-grid: NX3 × NY2 from (1, 1), X0.75 Y0.5: rows at y = 1, 1.5, 2, each the
    hole and a G105 along X (the Plus's repeat is one linear series)."""
    result = export(golden("loop-rep-grid"), "events")
    assert lines(result)[3:9] == [
        "N002 G100 X1.0A Y1.0A T01;",
        "N003 G105 FE002 LE002 XO0.75 YO0 RE03 D0.25 T01;",
        "N004 G100 X1.0A Y1.5A T01;",
        "N005 G105 FE004 LE004 XO0.75 YO0 RE03 D0.25 T01;",
        "N006 G100 X1.0A Y2.0A T01;",
        "N007 G105 FE006 LE006 XO0.75 YO0 RE03 D0.25 T01;",
    ]
    assert (
        "rewritten: block 3: NX 3 × NY 2 grid: the Plus's G105 repeats along one line, so "
        "each of the 3 rows is written out with a G105 along X"
    ) in entries(result)


def test_nested_loops_expand_the_outer_repeats() -> None:
    """loop-nested-3-deep: the inner REP (NX1, X0.1) is a G105; the middle (NY1, Y0.5) and
    outer (NX1 NY1, X3 Y3) would repeat a G105, so their patterns are written out: 4 outer
    × 2 middle patterns, each a POS, a hole and a G105 (plus the outer POS each time)."""
    result = export(golden("loop-nested-3-deep"), "events")
    events = lines(result)[2:-1]
    assert sum(" G105 " in e for e in events) == 8
    assert events[2:5] == [
        "N003 G100 X0.5A Y0A T01;",
        "N004 G100 X0.5A Y0.25A T01;",
        "N005 G105 FE004 LE004 XO0.1 YO0 RE01 D0.25 T01;",
    ]
    assert events[-2] == "N028 G100 X3.5A Y3.75A T01;"
    why = "the pattern holds a G105 (nested LOOP/REP) and a repeat is not repeated"
    assert f"rewritten: block 6: {why}, so its repeat is written out as events" in entries(result)
    assert f"rewritten: block 7: {why}, so its repeat is written out as events" in entries(result)


def test_repeats_past_event_255_are_written_out() -> None:
    """NX1 × NY199 grid: 200 rows of a hole and a G105 (events 2…401). FE/LE run to 255
    (§2.2.4), so from the row whose hole would be event 256 on, rows are written out; the
    file is longer than the Plus's 255 events: a warning."""
    result = export(loop(Rep(x=D("0.1"), y=D("0.1"), nx=1, ny=199)), "events")
    events = lines(result)[2:-1]
    assert len(events) == 401
    assert events[254] == "N255 G105 FE254 LE254 XO0.1 YO0 RE01 D0.5 T01;"
    assert events[255] == "N256 G100 X1.0A Y13.7A T01;"
    assert events[256] == "N257 G100 X1.1A Y13.7A T01;"
    assert "warning: program: 401 events: the Plus numbers events to 255" in "\n".join(
        entries(result)
    )


def test_more_than_999_events_is_an_error() -> None:
    with pytest.raises(ExportError) as caught:
        export(loop(Rep(x=D("0.1"), y=D("0.1"), nx=1, ny=600)), "events")
    assert caught.value.report is not None
    assert "error: program: 1203 events: line numbers run to 999 (seed 003 §2.2.4)" in [
        str(e) for e in caught.value.report.entries
    ]


def test_dimension_beyond_the_plus_is_an_error() -> None:
    """A grid row at Y 1 + 2·60 = 121 in is beyond ±99.9999 in (§2.2.4)."""
    with pytest.raises(ExportError) as caught:
        export(loop(Rep(x=D(1), y=D(60), nx=1, ny=2)), "events")
    assert caught.value.report is not None
    assert any(
        "121.0 in is beyond the Plus's ±99.9999 in" in str(e) for e in caught.value.report.entries
    )


# -- routines ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("placement", "milling", "rpm", "dr", "tc"),
    [
        # Clockwise spindle, climb: outside clockwise (DR1), tool left of it (TC2); inside
        # counter-clockwise (DR2), tool left of that (TC2) — §2.2.6.3's pocket is DR2 TC2.
        (Placement.OUTSIDE, MillingMode.CLIMB, 1000, 1, 2),
        (Placement.POCKET, MillingMode.CLIMB, 1000, 2, 2),
        (Placement.INSIDE, MillingMode.CLIMB, 1000, 2, 2),
        # Conventional reverses: outside counter-clockwise, tool right; inside clockwise.
        (Placement.OUT_TAN, MillingMode.CONVENTIONAL, 1000, 2, 1),
        (Placement.IN_TAN, MillingMode.CONVENTIONAL, 1000, 1, 1),
        # A counter-clockwise spindle reverses again.
        (Placement.OUTSIDE, MillingMode.CLIMB, -1000, 2, 1),
        (Placement.POCKET, MillingMode.CONVENTIONAL, -1000, 2, 2),
    ],
)
def test_routine_direction_and_tool_side(
    placement: Placement, milling: MillingMode, rpm: int, dr: int, tc: int
) -> None:
    tools = (Tool(number=1, diameter=D("0.5"), rpm=rpm),)
    circle = Circle(placement=placement, radius=D(1), feed_xy=D(9), tool=1)
    program = make(drill(2, 2), circle, tools=tools, milling=milling)
    code = "G108" if placement is Placement.POCKET else "G109"
    assert lines(export(program, "events"))[2] == (
        f"N001 {code} XC2.0A YC2.0A R1.0 DR{dr} TC{tc} FC0 F9.0 D0.5 T01;"
    )
    # The tool path goes round the centre the same way.
    turns = {
        m.clockwise
        for m in interpret(program).moves
        if isinstance(m, ArcFeed) and (m.cx, m.cy) == (2 * INCH, 2 * INCH)
    }
    assert turns == {dr == 1}


def test_frame_events() -> None:
    """FRAME at the corner (1, 1), XL 3, YW 2, corner R 0.375: XB1.0 YB1.0, diagonal
    XD4.0 YD3.0, CR0.375; FRM 2P POCKET → G106 with FC0.01; OUTSIDE → G107 FC0."""
    pocket = Frame(
        placement=Placement.POCKET,
        two_pass=True,
        xl=D(3),
        yw=D(2),
        corner_radius=D("0.375"),
        feed_xy=D(9),
        tool=1,
    )
    outside = replace(pocket, placement=Placement.OUTSIDE, two_pass=False)
    result = export(make(drill(1, 1), pocket, drill(1, 1), outside), "events")
    assert lines(result)[2:4] == [
        "N001 G106 XB1.0A YB1.0A XD4.0A YD3.0A DR2 TC2 FC0.01 F9.0 D0.5 CR0.375 T01;",
        "N002 G107 XB1.0A YB1.0A XD4.0A YD3.0A DR1 TC2 FC0 F9.0 D0.5 CR0.375 T01;",
    ]
    assert (
        "lost: block 2: 2P: the roughing depth 0.005 in above Z DN is not carried (no Z); "
        "the Plus finishes with FC at the depth the operator sets"
    ) in entries(result)


# -- the compatibility report ------------------------------------------------------------------


def test_depths_and_pecks_are_reported_per_block() -> None:
    program = make(
        drill(1, 1, z_dn="-0.5", pecks=3),
        drill(2, 1, z_dn=None),
        drill(0, 0, z_dn="-0.25"),
        line(1, 0),
    )
    result = export(program, "events")
    assert lines(result)[2:5] == [
        "N001 G100 X1.0A Y1.0A T01;",
        "N002 G100 X2.0A Y1.0A T01;",
        "N003 G101 XB0A YB0A XE1.0A YE0A TC0 F8.0 D0.5 CR- T01;",
    ]
    found = entries(result)
    hole = "written as a G100 position event; the operator drills the hole by hand"
    assert (
        f"lost: block 1: DRILL Z UP 0.05, Z DN -0.5, FEEDR Z 5 not carried: the Plus has no Z; "
        f"{hole} (the Plus has no hole event, seed 003 §2.2.1)"
    ) in found
    assert "lost: block 1: 3 pecks not carried: the operator pecks by hand" in found
    assert f"note: block 2: DRILL: {hole} (the Plus has no hole event, seed 003 §2.2.1)" in found
    assert (
        "lost: block 3: DRILL Z UP 0.05, Z DN -0.25, FEEDR Z 5 not carried: the Plus has no "
        "Z; the operator lowers the quill to depth by hand"
    ) in found
    assert "lost: block 0: Z RET 0.1 not carried: the Plus has no Z" in found
    assert "lost: block 0: spindle speeds (RPM) not carried: the Plus's spindle is set by hand" in (
        found
    )


def test_stop_index_and_offsets_are_reported() -> None:
    result = export(golden("pos-index"), "events")
    found = entries(result)
    assert "lost: block 1: INDEX not carried: the Plus has no rotary fixture signal" in found
    assert "lost: block 2: STOP not carried: the Plus has no stop event" in found
    assert any(e.startswith("lost: block 0: part zero offset X 4.5 Y 3.25") for e in found)


def test_feed_above_the_plus_is_limited_with_a_warning() -> None:
    program = make(drill(0, 0), replace(line(1, 0), feed_xy=D(100)))
    result = export(program, "events")
    assert " F99.9 " in lines(result)[2]
    assert (
        "warning: block 2: FEEDR XY 100 ipm is outside the Plus's range (seed 003 §2.2.4); "
        "written as F99.9"
    ) in entries(result)


def test_label_line_and_line_ends() -> None:
    program = make(Pos(x=D(1), y=D(2), tool=1), part_number="12345678")
    assert lines(export(program, "events"))[:2] == ["%", "PN12345678 G20;"]
    lf = export(program, "events", {"line_end": "lf"}).data
    assert lf == b"%\nPN12345678 G20;\nN001 G100 X1.0A Y2.0A T01;\n%\n"


# -- the self-check and determinism ------------------------------------------------------------


def golden(name: str) -> Program:
    return resolve_copies(
        document.loads((GOLDEN / name / "program.json").read_text(encoding="utf-8"))
    )


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_every_golden_program_passes_the_self_check(case: Path) -> None:
    program = golden(case.name)
    ramped = any(getattr(b, "entry", None) is not None for b in program.blocks)
    if ramped or any(isinstance(b, Helix | ThreadMill | Face | Engrave) for b in program.blocks):
        # A helix (or a pocket's ramp entry) moves Z with X and Y, a FACE goes down level
        # by level: the Plus (no Z) refuses them, saying so.
        with pytest.raises(ExportError) as refused:
            export(program, "events")
        assert refused.value.report is not None
        errors = [str(e) for e in refused.value.report.entries if e.severity.value == "error"]
        assert errors and all("the Plus is a 2-axis control" in e for e in errors), (
            "each refused block says why once; the self-check does not add a second, "
            "puzzling error for a block the writer chose not to write"
        )
        return
    first = export(program, "events")
    assert not first.report.has_errors
    assert export(golden(case.name), "events").data == first.data, "deterministic"


def test_self_check_reports_a_moved_event() -> None:
    """Move the LOOP's hole 0.001 in (beyond half a 0.0001 in step): the check names the
    block, and the G105 moves every repeat with it (the first pattern's hole is where the
    POS left the tool, so the first move of block 2 in the tool path is to X1.75)."""
    program = golden("loop-rep-grid")
    toolpath = compile_program(program).path
    events = build_events(program, toolpath, Report("events"))
    report = Report("events")
    check_events(events, toolpath, report)
    assert report.entries == []
    moved = events.events[1]
    assert isinstance(moved, Position)
    shifted = (moved.at[0] + INCH // 1000, moved.at[1])
    events.events[1] = replace(moved, at=shifted)
    events.checks[1] = ((2, (float(shifted[0]), float(shifted[1]))),)
    check_events(events, toolpath, report)
    assert [str(e) for e in report.entries] == [
        "error: block 2: self-check: the events put the tool at X1.001 Y1.0, where the tool "
        "path never goes",
        "error: block 2: self-check: the tool path goes to X1.75 Y1.0, which no event reaches",
    ]


def test_self_check_reports_a_missing_event_and_a_wrong_direction() -> None:
    program = golden("circle-pocket")
    toolpath = compile_program(program).path
    events = build_events(program, toolpath, Report("events"))
    routine = events.events[0]
    assert isinstance(routine, Routine)
    events.events[0] = replace(routine, clockwise=not routine.clockwise)
    report = Report("events")
    check_events(events, toolpath, report)
    assert [str(e) for e in report.entries] == [
        "error: block 2: self-check: DR turns the other way from the tool path"
    ]
    program = make(drill(0, 0), line(1, 0), line(1, 1))
    toolpath = compile_program(program).path
    events = build_events(program, toolpath, Report("events"))
    assert isinstance(events.events[-1], Mill)
    del events.events[-1], events.checks[-1]
    report = Report("events")
    check_events(events, toolpath, report)
    assert [str(e) for e in report.entries] == [
        "error: block 3: self-check: the tool path moves here but no event does"
    ]


def test_self_check_of_holes_at_one_place_grows_with_the_holes(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Issue 30: 600 DRILLs at one place took 7 s to export (a 20 s request budget holds
    fewer than 1 000). The self-check's point index took the points of a cell one pass
    over the query at a time, as many passes as its fullest cell held, for every chunk of
    the tool path: N holes at one place, N² work. Counted here (the query points of every
    pass, no timing): 200 holes at one place cost about twice what 100 do, as holes apart
    do, and the file and its self-check are those of each hole written out."""
    work = [0]
    index_pairs = writer._Near._pairs

    def counted(
        near: writer._Near,
        query: npt.NDArray[np.float64],
        tolerance: float,
        blocks: npt.NDArray[np.int64] | None,
    ) -> Iterator[tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]]:
        # Each batch is one pass over the query points.
        for found in index_pairs(near, query, tolerance, blocks):
            work[0] += len(query)
            yield found

    monkeypatch.setattr(writer._Near, "_pairs", counted)
    done: dict[int, int] = {}
    for holes in (100, 200):
        work[0] = 0
        result = export(make(*[drill(1, 1) for _ in range(holes)]), "events")
        assert not result.report.has_errors
        events = lines(result)[2:-1]
        assert events == [f"N{n:03d} G100 X1.0A Y1.0A T01;" for n in range(1, holes + 1)]
        done[holes] = work[0]
    assert done[200] <= 2.5 * done[100], done


def test_mixed_units_are_converted_and_reported() -> None:
    """mixed-units: the DRILL typed at X10 Y5 mm in an inch file is X0.3937 Y0.1969
    (10/25.4 = 0.393701, 5/25.4 = 0.196850)."""
    result = export(golden("mixed-units"), "events")
    assert lines(result)[3] == "N002 G100 X0.3937A Y0.1969A T01;"
    assert (
        "rewritten: block 2: typed in mm: written in inches to 0.0001 in (G20 holds for the "
        "whole file)"
    ) in entries(result)


def test_compensated_contour_is_written_as_the_finished_contour() -> None:
    """contour-cut-right: the events carry the programmed contour with TC1 and D0.5, and the
    divot the Plus leaves at the inside corner after the arc (block 7) is a warning."""
    result = export(golden("contour-cut-right"), "events")
    assert lines(result)[2] == "N001 G101 XB0A YB0A XE3.0A YE0A TC1 F10.0 D0.5 CR0 T02;"
    found = entries(result)
    assert any(e.startswith("warning: block 7: inside corner with an arc") for e in found)
    assert (
        "note: block 1: cutter compensation right: the finished contour is written with TC1 "
        "and D0.5; the Plus computes the tool's offset path itself"
    ) in found


def test_mm_dimensions_use_hundredths() -> None:
    assert format_dimension(12_345 * NM_PER_MM // 1000, Units.MM) == "12.34"  # half-even
    assert format_dimension(12_355 * NM_PER_MM // 1000, Units.MM) == "12.36"


def test_the_self_check_of_a_large_program_keeps_no_set_of_its_moves() -> None:
    # Issue 18: an export's memory stays flat in program size. The events of a LOOP of bolt
    # circles are a few dozen lines, but the self-check kept every distinct point of the
    # tool path as Python objects (270 MB at 10^6 moves; 24 MB traced at 10^5). It now
    # reads the path a chunk at a time against the events' own points, held as arrays.
    made, peak = traced_export(sized("bolts", 100_000), "events")
    assert not made.report.has_errors
    assert made.data.count(b"G104") > 1
    assert peak < 10_000_000, f"the events export allocated {peak / 1e6:.1f} MB at its peak"
