"""The Tektronix 1704 tape targets, held to seed 000 and the published tape codes.

Expected values come from the standards (EIA RS-244-B, ASCII with ISO 840 parity), the 1704
manual's own sample (Table 4-1) and hand derivations written next to them, not from the
code. Tape words are parsed back by a small reader in this file, so a test states what a
1704 would do with the tape.
"""

from __future__ import annotations

import itertools
import math
import re
import tracemalloc
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from decimal import Decimal as D
from pathlib import Path
from unittest import mock

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.cnc import document
from app.cnc.blocks import (
    ArcEnd,
    Block,
    DataBlock0,
    Direction,
    Hole,
    HoleOp,
    MillArc,
    MillLine,
    Pos,
    Program,
    Tool,
)
from app.cnc.compiler import compile_program
from app.cnc.copy import resolve_copies
from app.cnc.formats.tape1704 import codes as tapecode
from app.cnc.formats.tape1704 import plan
from app.cnc.formats.tape1704.codes import TapeCode
from app.cnc.formats.tape1704.targets import Tape
from app.cnc.formats.targets import (
    Export,
    ExportError,
    OptionError,
    Report,
    export,
    get_target,
)
from app.cnc.units import Units
from bench.programs import sized
from tests.strategies import programs

GOLDEN = Path(__file__).parent / "golden"
SAMPLES = ["contour-cut-right", "stop-and-tool-changes", "tap-metric", "two-axis", "frame-in-tan"]


def golden(name: str) -> Program:
    text = (GOLDEN / name / "program.json").read_text(encoding="utf-8")
    return resolve_copies(document.loads(text))


def listing(program: Program, target: str = "tape-ascii", **options: str) -> str:
    return export(program, target, options).data.decode("ascii")


# --- a reader for the listings: what the 1704 would hold after each block --------------

WORD = re.compile(r"([A-Z])(-?\d+)")


@dataclass
class Block1704:
    """One block as read, with the modal state after it (values in tape units)."""

    text: str
    words: dict[str, int]
    g: int | None
    pos: dict[str, int | None] = field(default_factory=dict)
    centre: tuple[int | None, int | None] = (None, None)
    feed: int | None = None

    @property
    def moves(self) -> bool:
        return any(axis in self.words for axis in "XYZ")


def read_blocks(text: str) -> list[Block1704]:
    """Parse a listing: comments dropped, words read, modal G/X/Y/Z/I/J/F carried along."""
    g: int | None = None
    pos: dict[str, int | None] = {"X": None, "Y": None, "Z": None}
    ij: list[int | None] = [None, None]
    feed: int | None = None
    blocks = []
    for raw in text.splitlines():
        line = re.sub(r"\(.*?\)", "", raw).strip()
        if not line or line == "%":
            continue
        words = {letter: int(value) for letter, value in WORD.findall(line)}
        if "G" in words and words["G"] in (0, 1, 2, 3, 20, 30, 50, 81, 82, 85, 89):
            g = words["G"]
        for axis in "XYZ":
            if axis in words:
                pos[axis] = words[axis]
        if "I" in words:
            ij[0] = words["I"]
        if "J" in words:
            ij[1] = words["J"]
        if "F" in words and words.get("G") != 4:
            feed = words["F"]
        blocks.append(Block1704(line, words, g, dict(pos), (ij[0], ij[1]), feed))
    return blocks


def line_blocks(*blocks: Block, units: Units = Units.INCH, tcal: str | None = "0") -> Program:
    """A program with tool 1 (0.25 in, 1000 rpm) and the given blocks."""
    tool = Tool(number=1, diameter=D("0.25"), rpm=1000, tcal=None if tcal is None else D(tcal))
    return Program(
        name="T",
        units=units,
        block0=DataBlock0(current_tool=1, tools=(tool,)),
        blocks=tuple(blocks),
    )


def drill(x: str, y: str, depth: bool = True, feed_z: str = "5") -> Hole:
    """A DRILL with tool 1: Z UP 0.1, Z DN −0.25 (none in a two-axis program)."""
    if not depth:
        return Hole(op=HoleOp.DRILL, x=D(x), y=D(y), tool=1)
    return Hole(
        op=HoleOp.DRILL, x=D(x), y=D(y), tool=1, z_up=D("0.1"), z_dn=D("-0.25"), feed_z=D(feed_z)
    )


def mill(x: str, y: str, feed: str = "10") -> MillLine:
    return MillLine(x=D(x), y=D(y), feed_xy=D(feed), tool=1)


# --- the code tables --------------------------------------------------------------------


def test_every_eia_code_has_odd_parity_and_every_ascii_code_even() -> None:
    for ch, row in tapecode.EIA_CODES.items():
        assert tapecode.holes(row) % 2 == 1, f"EIA {ch!r} = {row:#04x}"
    for ch, row in tapecode.ASCII_CODES.items():
        assert tapecode.holes(row) % 2 == 0, f"ASCII {ch!r} = {row:#04x}"
    assert tapecode.holes(tapecode.EIA_DELETE) % 2 == 1
    assert tapecode.holes(tapecode.ASCII_DELETE) % 2 == 0


# Rows as the standards print them (channel n = bit n-1). EIA RS-244-B: '0' is channel 6
# alone; '1' channel 1; '3' = channels 1+2 plus parity 5; 'X' = zone channel 6 with BCD 7
# (1+2+3) plus parity 5; 'G' = zone 6+7 with BCD 7, already odd; EOB channel 8; End of
# Record (rewind stop) channels 1, 2, 4; Delete channels 1-7; '-' channel 7.
EIA_PINNED = {
    "0": 0x20, "1": 0x01, "3": 0x13, "9": 0x19, "X": 0x37, "G": 0x67, "N": 0x45,
    "M": 0x54, "F": 0x76, "-": 0x40, "\n": 0x80, "%": 0x0B, "\t": 0x3E,
}  # fmt: skip
# ASCII 7-bit codes with channel 8 punched when they have an odd number of holes (ISO 840):
# '0' 0x30 (two holes), '1' 0x31 -> 0xB1, 'X' 0x58 -> 0xD8, CR 0x0D -> 0x8D, '%' 0x25 -> 0xA5.
ASCII_PINNED = {
    "0": 0x30, "1": 0xB1, "X": 0xD8, "G": 0x47, "N": 0x4E, "-": 0x2D, "\n": 0x8D,
    "%": 0xA5, "(": 0x28, ")": 0xA9, "\t": 0x09,
}  # fmt: skip


def test_pinned_rows_from_the_published_standards() -> None:
    for ch, row in EIA_PINNED.items():
        assert tapecode.EIA_CODES[ch] == row, f"EIA {ch!r}"
    for ch, row in ASCII_PINNED.items():
        assert tapecode.ASCII_CODES[ch] == row, f"ASCII {ch!r}"
    assert tapecode.EIA_DELETE == 0x7F
    assert tapecode.ASCII_DELETE == 0xFF


def test_eia_letters_and_digits_follow_the_rs244_construction() -> None:
    """Zone (A-I: 6+7, J-R: 7, S-Z: 6) + BCD digit, then channel 5 if the count is even."""

    def eia(zone: int, digit: int) -> int:
        base = zone | digit
        return base if tapecode.holes(base) % 2 else base | 0x10

    expected = {str(d): eia(0, d) for d in range(1, 10)}
    expected |= {chr(ord("A") + k): eia(0x60, k + 1) for k in range(9)}
    expected |= {chr(ord("J") + k): eia(0x40, k + 1) for k in range(9)}
    expected |= {chr(ord("S") + k): eia(0x20, k + 2) for k in range(8)}
    for ch, row in expected.items():
        assert tapecode.EIA_CODES[ch] == row, ch


def test_ascii_rows_are_the_ascii_codes_with_parity() -> None:
    for ch, row in tapecode.ASCII_CODES.items():
        seven = 0x0D if ch == "\n" else ord(ch)  # End of Block is carriage return
        assert row & 0x7F == seven, ch


@pytest.mark.parametrize("code", list(TapeCode))
def test_no_two_characters_share_a_row(code: TapeCode) -> None:
    table = tapecode.table(code)
    assert len(set(table.values())) == len(table)
    assert tapecode.BLANK not in table.values()
    assert tapecode.delete(code) not in table.values()


def test_eia_cannot_punch_comments() -> None:
    assert not tapecode.can_encode("(NOTE)", TapeCode.EIA)
    with pytest.raises(tapecode.TapeCodeError, match=r"'\('"):
        tapecode.encode("N1(NOTE)\n", TapeCode.EIA)


# --- punch images -----------------------------------------------------------------------


def punched(program: Program, code: TapeCode, **options: str) -> tuple[bytes, str, Export]:
    """The punch image, the listing, and the punch export (for its report)."""
    result = export(program, f"punch-{code.value}", options)
    text = export(program, f"tape-{code.value}", options).data.decode("ascii")
    return result.data, text, result


@pytest.mark.parametrize("code", list(TapeCode))
@pytest.mark.parametrize("case", SAMPLES)
def test_every_row_of_real_output_has_the_codes_parity(case: str, code: TapeCode) -> None:
    rows, _, _ = punched(golden(case), code)
    first_eob = rows.index(tapecode.end_of_block(code))  # the leader may hold anything else
    leader, data = rows[: first_eob - 1], rows[first_eob - 1 :]
    assert data[0] == tapecode.rewind_stop(code), "rewind stop, then End of Block"
    bad = [i for i, row in enumerate(data) if not tapecode.parity_ok(row, code)]
    assert bad == []
    assert tapecode.end_of_block(code) not in leader


@pytest.mark.parametrize("code", list(TapeCode))
@pytest.mark.parametrize(
    "options",
    [{}, {"tabs": "yes", "tool-change-leader": "6"}, {"sequence": "no", "circular": "no"}],
)
@pytest.mark.parametrize("case", SAMPLES)
def test_listing_punch_decode_round_trip(
    case: str, code: TapeCode, options: dict[str, str]
) -> None:
    rows, text, _ = punched(golden(case), code, **options)
    decoded = tapecode.decode(rows, code)
    assert decoded.ok
    assert decoded.text == text
    assert text.startswith("%\n")


def test_the_eia_rewind_stop_is_end_of_record_not_ascii_percent() -> None:
    rows, _, _ = punched(golden("drill-single"), TapeCode.EIA)
    decoded = tapecode.decode(rows, TapeCode.EIA)
    assert rows[decoded.leader_rows : decoded.leader_rows + 2] == bytes([0x0B, 0x80])
    assert 0x25 not in rows[: decoded.leader_rows + 1]  # ASCII '%' (EIA 'V') nowhere there


def test_decoder_reports_parity_errors_by_row_and_skips_rubouts() -> None:
    rows, text, _ = punched(golden("drill-single"), TapeCode.EIA)
    tape = bytearray(rows)
    start = tapecode.decode(rows, TapeCode.EIA).leader_rows
    bad_row = start + 5
    tape[bad_row] ^= 0x04  # a dropped hole: even parity
    # An operator's correction: a wrong character punched over with Delete, blank tape.
    tape[start + 8 : start + 8] = bytes([tapecode.EIA_DELETE, tapecode.BLANK])
    decoded = tapecode.decode(bytes(tape), TapeCode.EIA)
    assert decoded.parity_errors == [bad_row]
    assert len(decoded.text) == len(text)


def test_the_title_is_punched_in_the_leader_as_letters() -> None:
    program = golden("drill-single")
    for code in TapeCode:
        rows, _, _ = punched(program, code, title="HX 1")
        leader = rows[: tapecode.decode(rows, code).leader_rows]
        title = tapecode.title_rows("HX 1")
        assert title in leader
        # 'H' read off the tape: a full column (channels 1-7), the bar in channel 4 only
        # (the middle of seven dots), a full column. 'X' starts with channels 7, 6, 2, 1.
        assert list(title[:5]) == [0x7F, 0x08, 0x08, 0x08, 0x7F]
        assert title[6] == 0b1100011
        assert all(row & 0x80 == 0 for row in leader), "channel 8 is never punched there"
        assert tapecode.end_of_block(code) not in leader


def test_no_letter_of_the_title_face_can_be_an_end_of_block() -> None:
    rows = tapecode.title_rows("".join(sorted(tapecode.TITLE_CHARACTERS)))
    assert tapecode.EIA_END_OF_BLOCK not in rows
    assert tapecode.ASCII_END_OF_BLOCK not in rows


def test_no_title_and_a_longer_leader() -> None:
    rows, _, _ = punched(golden("drill-single"), TapeCode.ASCII, ident="no", leader="30")
    assert rows[:300] == bytes(300)
    assert rows[300] == tapecode.ASCII_REWIND_STOP


def test_tape_length_is_reported_in_feet_at_ten_rows_per_inch() -> None:
    rows, _, result = punched(golden("contour-cut-right"), TapeCode.EIA)
    notes = [e.message for e in result.report.entries if "tape length" in e.message]
    feet = len(rows) / 120
    assert notes == [
        f"tape length {feet:.1f} ft ({len(rows)} rows at 10 rows per inch, leader and "
        "trailer included)"
    ]
    # Leader and trailer default to a foot each: 240 of the rows are blank or title.
    longer, _, _ = punched(golden("contour-cut-right"), TapeCode.EIA, trailer="24")
    assert len(longer) == len(rows) + 120


# --- the manual's sample part (Table 4-1) -------------------------------------------------

# Table 4-1 as printed, with the scan's misreadings corrected: "110000J30000" is I10000
# J30000 and "X55000Y31769156250J31769" is I56250 (OCR read I as 1), "No17" is N017.
TABLE_4_1 = """N001X5000Y5000M03F2000
N002G00F20M09
N003Y25000F80
N004G01X10000
N005G03X15000Y30000I10000J30000
N006X10000Y35000
N007G00X5000
N008Y53604
N009X40384Y65398
N010X65000Y53090
N011Y36615
N012G01X55786Y32929
N013G03X55000Y31769I56250J31769
N014G01Y27124
N015G03X56005Y25898J27124
N016G00X65000Y24099
N017Y5000
N018X5000
N019X0Y0M30F2000
"""


def table_4_1_program() -> Program:
    """The sample part (Fig. 4-2) in data blocks: the cutter centre path of a 1-inch cutter,
    uncompensated, two-axis like the table (no Z), then a POS back to X0 Y0.

    MillBlocks dimensions go to 0.001 in, so the table's 0.0001 in points are rounded there
    (5.3604 → 5.360 …); P14 (5.6005, 2.5898) is entered as 5.600, 2.590, the nearer 0.001 in
    point to its circle.
    """

    def arc(cx: str, cy: str, ex: str, ey: str) -> tuple[MillArc, ArcEnd]:
        centre = MillArc(direction=Direction.CCW, x=D(cx), y=D(cy), feed_xy=D(8), tool=1)
        return centre, ArcEnd(x=D(ex), y=D(ey))

    def cut(x: str, y: str) -> MillLine:
        return mill(x, y, "8")

    blocks: list[Block] = [
        drill("0.5", "0.5", depth=False),
        cut("0.5", "2.5"),  # P2
        cut("1.0", "2.5"),  # P3
        *arc("1.0", "3.0", "1.0", "3.5"),  # P4, P5: the 180° cut-out
        cut("0.5", "3.5"),  # P6
        cut("0.5", "5.360"),  # P7
        cut("4.038", "6.540"),  # P8
        cut("6.5", "5.309"),  # P9
        cut("6.5", "3.662"),  # P10
        cut("5.579", "3.293"),  # P11
        *arc("5.625", "3.177", "5.5", "3.177"),  # P12
        cut("5.5", "2.712"),  # P13
        *arc("5.625", "2.712", "5.600", "2.590"),  # P14
        cut("6.5", "2.410"),  # P15
        cut("6.5", "0.5"),  # P16
        cut("0.5", "0.5"),  # P1
        Pos(x=D(0), y=D(0), tool=1),  # P0
    ]
    tool = Tool(number=1, diameter=D(1), rpm=500, tcal=D(0))
    return Program(
        name="TABLE 4-1", block0=DataBlock0(current_tool=1, tools=(tool,)), blocks=tuple(blocks)
    )


def cut_moves(blocks: list[Block1704]) -> list[Block1704]:
    return [b for b in blocks if b.moves and b.g in (0, 1, 2, 3, 20, 30)]


def test_table_4_1_follows_the_30_degree_rule() -> None:
    """The reading of the rule, checked on the manual's own program: G01/G03 exactly where
    the next move turns by 30° or less, G00 elsewhere (turns computed from its numbers)."""
    moves = cut_moves(read_blocks(TABLE_4_1))
    assert [b.words.get("N") for b in moves][:2] == [3, 4]
    points = [(b.pos["X"], b.pos["Y"]) for b in moves]
    start = (5000, 5000)
    for k, block in enumerate(moves[:-1]):
        here = points[k - 1] if k else start
        out = direction_out(block, here)
        into = direction_in(moves[k + 1], points[k])
        smooth = turn(out, into) <= 30
        assert (block.g in (1, 2, 3)) == smooth, block.text


def direction_out(block: Block1704, start: tuple[int | None, int | None]) -> tuple[float, float]:
    x, y = block.pos["X"], block.pos["Y"]
    assert x is not None and y is not None and start[0] is not None and start[1] is not None
    if block.g in (2, 3, 20, 30):
        cx, cy = block.centre
        assert cx is not None and cy is not None
        rx, ry = x - cx, y - cy
        return (ry, -rx) if block.g in (2, 20) else (-ry, rx)
    return (x - start[0], y - start[1])


def direction_in(block: Block1704, start: tuple[int | None, int | None]) -> tuple[float, float]:
    assert start[0] is not None and start[1] is not None
    if block.g in (2, 3, 20, 30):
        cx, cy = block.centre
        assert cx is not None and cy is not None
        rx, ry = start[0] - cx, start[1] - cy
        return (ry, -rx) if block.g in (2, 20) else (-ry, rx)
    return direction_out(block, start)


def turn(a: tuple[float, float], b: tuple[float, float]) -> float:
    cosine = (a[0] * b[0] + a[1] * b[1]) / (math.hypot(*a) * math.hypot(*b))
    return math.degrees(math.acos(max(-1.0, min(1.0, cosine))))


def test_table_4_1_sample_part_exports_to_the_tables_moves() -> None:
    """The sample part comes out as Table 4-1's cut, block for block (N003-N018).

    Allowed differences, each for a reason:
    - coordinates and centres within 0.0005 in: MillBlocks dimensions go to 0.001 in, the
      table's to 0.0001 in;
    - N001 positions at G00 F2000 (200 ipm) in the table; MillBlocks positions at rapid
      (G50, seed 000's rapid traverse) with the spindle start M03 in the same block;
    - N002 `G00 F20 M09` sets coolant (the text calls M09 coolant on; Table 2-1 says off —
      the manual disagrees with itself); MillBlocks has no coolant, and its two-axis
      program stops for the quill there (M00) instead;
    - N019 returns to P0 at G00 F2000 with M30; MillBlocks raises the quill (M00), rapids
      to X0 Y0 (G50, the POS block), stops the spindle (M05), then M30;
    - sequence numbers count those extra blocks, so they differ.
    """
    ours = read_blocks(listing(table_4_1_program()))
    theirs = read_blocks(TABLE_4_1)
    stops = [k for k, b in enumerate(ours) if b.words.get("M") == 0]
    assert len(stops) == 2
    assert ours[0].words | {"N": 1} == {"N": 1, "G": 50, "X": 5000, "Y": 5000, "M": 3}
    our_cut = cut_moves(ours[stops[0] : stops[1]])
    table_cut = cut_moves(theirs)[: len(our_cut)]
    assert [b.words["N"] for b in table_cut] == list(range(3, 19))
    assert len(our_cut) == 16
    for mine, table in zip(our_cut, table_cut, strict=True):
        assert mine.g == table.g, (mine.text, table.text)
        for axis in "XY":
            a, b = mine.pos[axis], table.pos[axis]
            assert a is not None and b is not None and abs(a - b) <= 5, (mine.text, table.text)
        if table.g in (2, 3):
            for a, b in zip(mine.centre, table.centre, strict=True):
                assert a is not None and b is not None and abs(a - b) <= 5, mine.text
            assert "X" in mine.words and "Y" in mine.words, "both end axes in an arc block"
        # The centre is written only when it changes, as the table does (N015 has no I).
        assert ("I" in mine.words) == ("I" in table.words), (mine.text, table.text)
    assert ours[-3].words | {"N": 0} == {"N": 0, "G": 50, "X": 0, "Y": 0}
    assert [b.words.get("M") for b in ours[-2:]] == [5, 30]


# --- motion rules ---------------------------------------------------------------------


def test_30_degree_rule_on_lines() -> None:
    """Three cuts: along +X, then 25° up (turn 25°: G01 before it), then 35° further (turn
    35°: G00 before it); the last cut is followed by the retract (terminal: G00)."""
    p1 = (1.0, 0.0)
    p2 = (p1[0] + math.cos(math.radians(25)), math.sin(math.radians(25)))
    p3 = (p2[0] + math.cos(math.radians(60)), p2[1] + math.sin(math.radians(60)))
    program = line_blocks(
        drill("0", "0"),
        mill(f"{p1[0]:.3f}", f"{p1[1]:.3f}"),
        mill(f"{p2[0]:.3f}", f"{p2[1]:.3f}"),
        mill(f"{p3[0]:.3f}", f"{p3[1]:.3f}"),
    )
    cuts = [b for b in read_blocks(listing(program)) if b.moves and b.g in (0, 1)]
    assert [b.g for b in cuts] == [0, 1, 0, 0]  # plunge (turns 90°), 25°, 35°, last
    assert "G01" in cuts[1].text and "G00" in cuts[2].text


def test_m_codes_only_after_decelerated_blocks() -> None:
    """Seed 000 §2: no M code (but a program stop) in or right after a G01/G02/G03 block,
    and no G01/G02/G03 before one; we hold every M code, dwell and stop to it."""
    for case in ["contour-cut-right", "stop-and-tool-changes", "two-axis", "tap-metric"]:
        for code in ("ascii", "eia"):
            blocks = read_blocks(listing(golden(case), f"tape-{code}"))
            for before, block in itertools.pairwise(blocks):
                if "M" in block.words or block.words.get("G") in (4, 94):
                    assert before.g not in (1, 2, 3) or not before.moves, (before.text, block.text)
                if "M" in block.words and block.moves:
                    assert block.g in (0, 50, 20, 30), block.text
                assert sum(1 for letter in block.text if letter == "M") <= 1
                assert sum(1 for letter in block.text if letter == "G") <= 1
            last_motion = [b for b in blocks if b.moves][-1]
            assert last_motion.g in (0, 50), "full deceleration on the last move"


def test_arcs_split_at_the_axes_one_quadrant_per_block() -> None:
    """A 270° counter-clockwise arc from 30° to 300° about (1, 1), radius 0.5: it crosses
    the +Y, −X and −Y axes, so four blocks end at (1, 1.5), (0.5, 1), (1, 0.5) (exactly
    centre ± R) and at the typed end; each block's two ends lie in one quadrant."""
    start = (1 + 0.5 * math.cos(math.radians(30)), 1 + 0.5 * math.sin(math.radians(30)))
    end = (1 + 0.5 * math.cos(math.radians(300)), 1 + 0.5 * math.sin(math.radians(300)))
    program = line_blocks(
        drill(f"{start[0]:.3f}", f"{start[1]:.3f}"),
        MillArc(direction=Direction.CCW, x=D(1), y=D(1), feed_xy=D(10), tool=1),
        ArcEnd(x=D(f"{end[0]:.3f}"), y=D(f"{end[1]:.3f}")),
    )
    blocks = read_blocks(listing(program))
    arcs = [b for b in blocks if b.g in (3, 30) and b.moves]
    ends = [(b.words["X"], b.words["Y"]) for b in arcs]
    radius = round(10000 * math.hypot(start[0] - 1, start[1] - 1))  # of the typed start
    assert ends[:3] == [(10000, 10000 + radius), (10000 - radius, 10000), (10000, 10000 - radius)]
    assert ends[3] == (round(end[0] * 10000), round(end[1] * 10000))
    previous = (round(start[0] * 10000), round(start[1] * 10000))
    for block, point in zip(arcs, ends, strict=True):
        assert block.centre == (10000, 10000)
        assert "X" in block.words and "Y" in block.words
        rel = [(p[0] - 10000, p[1] - 10000) for p in (previous, point)]
        assert any(
            all(sx * dx >= 0 and sy * dy >= 0 for dx, dy in rel)
            for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1))
        ), block.text
        previous = point
    assert [b.g for b in arcs] == [3, 3, 3, 30], "G30 where the arc ends the cut"


def test_words_are_modal_and_never_repeated() -> None:
    for case in ["contour-cut-right", "bolt-circle-drill", "frame-in-tan", "tap-metric"]:
        text = listing(golden(case))
        previous: Block1704 | None = None
        for block in read_blocks(text):
            restart = previous is not None and previous.words.get("M") == 6
            if previous is not None and not restart:
                arc = block.g in (2, 3, 20, 30)
                for axis in "XYZ" if not arc else "Z":
                    if axis in block.words:
                        assert previous.pos[axis] != block.words[axis], block.text
                for k, axis in enumerate("IJ"):
                    if axis in block.words:
                        assert previous.centre[k] != block.words[axis], block.text
                if "F" in block.words and "G" not in block.words:
                    assert previous.feed != block.words["F"], block.text
                if block.words.get("G") in (0, 1, 2, 3, 50) and previous.moves:
                    assert previous.g != block.words["G"], block.text
            previous = block


def test_number_format_trailing_zeros_kept_no_decimal_point() -> None:
    text = listing(golden("contour-cut-right"))
    assert "." not in re.sub(r"\(.*?\)", "", text)
    assert "X30000" in text  # 3.0000 in
    assert "F40" in text  # 4.0 ipm
    metric = listing(golden("tap-metric"))
    assert "X25000Y20000" in metric  # 25.000 mm, 20.000 mm (X3.3)
    assert "F250" in metric  # 250 mm/min (F4)


def test_z_words_carry_each_tools_tcal() -> None:
    """contour-cut-right: tool 2 has TCAL −1.25 in; Z DN −0.3 is punched −1.55 (Z−15500)."""
    text = listing(golden("contour-cut-right"))
    assert "Z-15500" in text
    assert "Z-3000" not in text


def test_an_uncalibrated_tool_cannot_cut() -> None:
    program = line_blocks(drill("1", "1"), tcal=None)
    with pytest.raises(ExportError) as raised:
        export(program, "tape-eia")
    # A need of the target, once for the tool (not once per move), with the other way out.
    assert str(raised.value) == (
        "tape-eia needs calibrated tools (TCAL in Data Block 0); or export with z-zero=g94 "
        "to touch off each tool at its change"
    )
    assert [str(p) for p in raised.value.problems] == [
        "Data Block 0, TOOL 1 TCAL: tool 1 is not calibrated (TCAL ****) and moves down in Z "
        "in block 1; Z words that include each tool's TCAL cannot place its tip: calibrate "
        "it in Data Block 0"
    ]
    # Presetting Z at each tool change needs no TCAL.
    assert "G00Z-2500" in listing(program, **{"z-zero": "g94"})


def test_g94_presets_z_at_each_tool_change() -> None:
    blocks = read_blocks(listing(golden("stop-and-tool-changes"), **{"z-zero": "g94"}))
    for k, block in enumerate(blocks):
        if block.words.get("M") == 6:
            assert blocks[k + 1].words == {"N": blocks[k + 1].words["N"], "G": 94, "Z": 0}
            assert set(blocks[k + 2].words) == {"N", "G", "Z"}, "straight up, then across"


# --- capacity and reader limitation ----------------------------------------------------


def report_errors(program: Program, target: str = "tape-eia", **options: str) -> list[str]:
    with pytest.raises(ExportError) as raised:
        export(program, target, options)
    assert raised.value.report is not None
    return [str(e) for e in raised.value.report.entries if e.severity.value == "error"]


def test_capacity_limits_are_errors_naming_the_block() -> None:
    metric = line_blocks(
        Pos(x=D(10), y=D(10), tool=1, units=Units.MM),
        Pos(x=D(1200), y=D(10), tool=1, units=Units.MM),
        units=Units.MM,
    )
    assert report_errors(metric) == [
        "error: block 2: X 1200.000 mm is beyond the 1704's capacity of ±999.999 mm"
    ]
    fast = line_blocks(drill("1", "1", feed_z="250"))
    assert report_errors(fast) == [
        "error: block 1: feed 250.0 ipm is above the 1704's maximum 200.0 ipm (inch, 0.0001 in)"
    ]
    # A 127.279 in radius (start (−40, −40) about (50, 50)): the 1704's limit is 99.9999 in.
    big = line_blocks(
        drill("-40", "-40"),
        MillArc(direction=Direction.CW, x=D(50), y=D(50), feed_xy=D(10), tool=1),
        ArcEnd(x=D("-77.279"), y=D(50)),
    )
    errors = report_errors(big)
    assert errors[0].startswith("error: block 2: arc radius 127.2792 in is above")


def test_reader_limitation_warns_on_short_fast_blocks() -> None:
    """Block 2 cuts 0.010 in in G01 (the next cut turns 0.6°), its F100.0 following the
    plunge's F5.0: F1 = 5 ipm in force as it starts, F2 = 100 ipm (seed 000 §3: "initial"
    and "final" feedrate), so T1 = 60 · 0.01 / ((5 + 100) / 2) = 0.011 s. The next block,
    `N5X10000Y100` and its End of Block, is 13 characters: T2 = 0.010 + 12/300 = 0.050 s,
    more than T1: the reader cannot keep up."""
    program = line_blocks(
        drill("0", "0"), mill("0.01", "0", "100"), mill("1", "0.01", "100"), mill("2", "0.01")
    )
    result = export(program, "tape-eia")
    lines = result.data.decode().splitlines()
    assert "N4G01X100F1000" in lines and "N5X10000Y100" in lines
    warnings = [str(e) for e in result.report.entries if "reader limitation" in e.message]
    assert warnings == [
        "warning: block 2: reader limitation: N4G01X100F1000 moves 0.0100 in in 0.011 s but "
        "the next block (13 characters) takes 0.050 s to read: the slides may stop and dwell "
        "(seed 000 §3)"
    ]
    slow = line_blocks(drill("0", "0"), mill("0.01", "0", "1"), mill("1", "0.01", "1"))
    assert not [e for e in export(slow, "tape-eia").report.entries if "reader" in e.message]


# --- chords (no circular interpolation) ---------------------------------------------------


Point2 = tuple[float, float]


def polyline_after(blocks: list[Block1704], first: int) -> list[Point2]:
    points: list[Point2] = []
    for block in blocks[first:]:
        if not block.moves or block.g not in (0, 1) or "Z" in block.words:
            if points and block.g == 50:
                break
            continue
        x, y = block.pos["X"], block.pos["Y"]
        assert x is not None and y is not None
        points.append((x / 10000, y / 10000))
    return points


def distance_to_segment(p: Point2, a: Point2, b: Point2) -> float:
    ax, ay = b[0] - a[0], b[1] - a[1]
    length = ax * ax + ay * ay
    along = ((p[0] - a[0]) * ax + (p[1] - a[1]) * ay) / length if length else 0.0
    t = max(0.0, min(1.0, along))
    return math.hypot(p[0] - a[0] - t * ax, p[1] - a[1] - t * ay)


@pytest.mark.parametrize("tolerance", ["0.001", "0.0003"])
def test_chords_hold_the_tolerance_on_the_part(tolerance: str) -> None:
    """circle-inside: cutter path radius 1.0 about (2, 2), tool 0.5 in, so the hole's wall
    is at R + r = 1.25 (were it a boss, at R − r = 0.75). The wall the cutter leaves is
    where the tool's edge reaches: at each point P of the wall the error is the distance
    from P to the chord path less the tool radius. It must stay within the tolerance all
    round, for either side; every chord end point is on the cutter-path circle."""
    blocks = read_blocks(listing(golden("circle-inside"), circular="no", tolerance=tolerance))
    assert not any(b.g in (2, 3, 20, 30) for b in blocks)
    lead_in = next(k for k, b in enumerate(blocks) if b.pos["Y"] == 10000 and b.moves)
    path = polyline_after(blocks, lead_in)
    ring = path[: len(path) - 1]  # the last move is the lead-out
    assert ring[0] == (2.0, 1.0) and ring[-1] == (2.0, 1.0)
    for x, y in ring:
        assert abs(math.hypot(x - 2, y - 2) - 1.0) <= 0.0001
    tol = float(tolerance)
    segments = list(itertools.pairwise(ring))
    for wall in (1.25, 0.75):
        worst = 0.0
        for k in range(3600):
            angle = math.radians(k / 10)
            p = (2 + wall * math.cos(angle), 2 + wall * math.sin(angle))
            reach = min(distance_to_segment(p, a, b) for a, b in segments)
            worst = max(worst, abs(reach - 0.25))
        assert worst <= tol, (wall, worst)
    # Equal steps, no more than the tolerance needs: the step angle with one chord fewer
    # would leave more than e = tol·R/(R + r) (less half a resolution step on each axis).
    e = tol * 1.0 / 1.25 - 0.0001 * math.sqrt(2) / 2
    fewer = 2 * math.pi / (len(segments) - 1)
    assert 1.0 * (1 - math.cos(fewer / 2)) > e


# --- options ------------------------------------------------------------------------------


def test_sequence_numbers_start_increment_and_off() -> None:
    numbering = {"sequence-start": "10", "sequence-increment": "5"}
    blocks = read_blocks(listing(golden("drill-single"), **numbering))
    assert [b.words["N"] for b in blocks[:3]] == [10, 15, 20]
    plain = listing(golden("drill-single"), sequence="no")
    assert "N" not in re.sub(r"\(.*?\)", "", plain)


def test_end_code_and_tabs() -> None:
    text = listing(golden("drill-single"), **{"end-code": "M02", "tabs": "yes"})
    assert text.rstrip().endswith("\tM02")
    assert "N1\tG50\tX0\tY0" in text


def test_eia_has_no_comments_and_says_what_is_lost() -> None:
    result = export(golden("stop-and-tool-changes"), "tape-eia")
    assert "(" not in result.data.decode()
    lost = [str(e) for e in result.report.entries if e.severity.value == "lost"]
    assert lost == [
        "lost: program: Data Block 0 part zero at table X4.5000 Y3.2500 in: EIA tapes carry "
        "no comments; set the floating zero there by hand"
    ]
    ascii_text = listing(golden("stop-and-tool-changes"))
    assert "(PART ZERO AT TABLE X4.5000 Y3.2500 IN)" in ascii_text
    assert "M06 (TOOL 2 DIA 0.5000 TCAL -1.2500)" in ascii_text


def test_two_axis_stops_and_the_quill_actuator() -> None:
    program = golden("two-axis")
    plain = listing(program)
    assert "M00 (LOWER THE QUILL TO DEPTH BY HAND)" in plain
    assert "Z" not in re.sub(r"\(.*?\)", "", plain)
    quill = read_blocks(listing(program, quill="yes"))
    texts = [b.text for b in quill]
    g99 = next(k for k, t in enumerate(texts) if t.endswith("G99"))
    assert texts[g99 + 1].endswith("X20000Y10000"), "the first hole, both axes given"
    assert any(t.endswith("G98") for t in texts) and any(t.endswith("M51") for t in texts)
    assert report_errors(golden("drill-single"), quill="yes")[0].endswith("this program has depths")


def test_index_needs_an_m_code_or_becomes_an_operator_stop() -> None:
    result = export(golden("pos-index"), "tape-ascii")
    assert "M00 (INDEX THE FIXTURE)" in result.data.decode()
    rewritten = [e for e in result.report.entries if e.severity.value == "rewritten"]
    assert any("INDEX" in e.message for e in rewritten)
    assert "M21" in listing(golden("pos-index"), **{"index-m": "21"})
    with pytest.raises(OptionError, match="M06 has its own meaning"):
        export(golden("pos-index"), "tape-ascii", {"index-m": "6"})


def test_spindle_and_tool_code_tables() -> None:
    program = golden("stop-and-tool-changes")
    codes = {"spindle-codes": "1200=20, 800=15, 2500=40, 400=10", "tool-codes": "number"}
    text = listing(program, **codes)
    assert "S20M03" in text and "T02M06" in text
    missing = report_errors(program, **{"spindle-codes": "1200=20"})
    assert missing[0] == "error: block 2: spindle-codes has no S code for 800 rpm"
    with pytest.raises(OptionError, match="NUMBER=CODE"):
        export(program, "tape-eia", {"tool-codes": "2:05"})


def test_fixed_cycle_when_the_profile_declares_one() -> None:
    """drill-single: DRILL at (1, 1), Z UP 0.1, Z DN −0.5 → one G82 block with R at Z UP."""
    result = export(golden("drill-single"), "tape-ascii", {"drill-cycle": "82"})
    text = result.data.decode()
    assert re.search(r"G82Z-5000R1000F\d+", text), text
    assert "G04" not in text
    assert any("panel timer" in e.message for e in result.report.entries)
    pecks = listing(golden("drill-12-pecks"), **{"drill-cycle": "82"})
    assert "G82" not in pecks, "pecks at our levels are not the 1704's timed pecks"


def test_resolution_options_and_units() -> None:
    """Option 1: 0.0002 in steps (even last digits), F in 0.2 ipm steps; option 2: 0.001 in
    and whole ipm in 3.3 / F4 words; a metric program punched in inches on request."""
    one = read_blocks(listing(golden("contour-cut-right"), resolution="option1"))
    for block in one:
        for letter, value in block.words.items():
            if letter in "XYZIJF":
                assert value % 2 == 0, block.text
    two = listing(golden("contour-cut-right"), resolution="option2")
    assert "X3000" in two and "F10" in two  # 3.000 in, 10 ipm
    inch = listing(golden("tap-metric"), units="inch")
    assert "X9843Y7874" in inch  # 25 mm = 0.984252 in → 0.9843, 20 mm = 0.787402 in → 0.7874
    with pytest.raises(OptionError, match="metric"):
        export(golden("tap-metric"), "tape-eia", {"resolution": "option2"})


def test_decel_writes_no_continuous_motion() -> None:
    text = listing(golden("contour-cut-right"), decel="yes")
    assert not re.search(r"G0[123]", text)
    assert "G30" in text


def test_xyz_together_and_dwell_option() -> None:
    """drill-single: up to Z RET, across to (1, 1), down to Z UP become one XYZ rapid with
    xyz=together; the retract out of the hole stays a Z move of its own."""
    separate = read_blocks(listing(golden("drill-single")))
    together = export(golden("drill-single"), "tape-ascii", {"xyz": "together"})
    merged = read_blocks(together.data.decode())
    assert [b.words for b in separate if b.g == 50][:3] == [
        {"N": 1, "G": 50, "X": 0, "Y": 0, "Z": 2000, "M": 3},
        {"N": 2, "X": 10000, "Y": 10000},
        {"N": 3, "Z": 1000},
    ]
    assert merged[0].words == {"N": 1, "G": 50, "X": 10000, "Y": 10000, "Z": 1000, "M": 3}
    retracts = [b for b in merged if b.g == 50 and set(b.words) <= {"N", "G", "Z"}]
    assert retracts and retracts[0].words["Z"] == 2000, "straight up out of the hole"
    assert any(e.severity.value == "rewritten" for e in together.report.entries)
    no_dwell = export(golden("drill-single"), "tape-ascii", {"dwell": "no"})
    assert "G04" not in no_dwell.data.decode()
    lost = [e for e in no_dwell.report.entries if e.severity.value == "lost"]
    assert any("dwell" in e.message for e in lost)


# --- the drawing ----------------------------------------------------------------------------


def test_svg_draws_every_hole_and_the_feed_track() -> None:
    program = golden("drill-single")
    rows, _, _ = punched(program, TapeCode.EIA)
    svg = export(program, "tape-svg").data
    root = ET.fromstring(svg)
    ns = "{http://www.w3.org/2000/svg}"
    circles = root.findall(f".//{ns}circle")
    feed = [c for c in circles if c.get("r") == "2.3"]
    code = [c for c in circles if c.get("r") == "3.6"]
    assert len(feed) == len(rows)
    assert len(code) == sum(tapecode.holes(row) for row in rows)
    texts = [t.text for t in root.findall(f".//{ns}text")]
    assert "DRILL-SINGLE 4711" in texts and "EOB" in texts and "ER" in texts
    assert export(program, "tape-svg").data == svg, "deterministic"


def test_tape_search_restates_position_spindle_and_coolant_at_every_block() -> None:
    """Seed 000 §4 tape search: with tape-search, every data block that starts out of the
    work begins with a block carrying X, Y, Z, the spindle and the feed, with the coolant
    in force in the block before it (one M code per block); N is on every block. The full
    rules are in tests/test_shop_floor.py."""
    from app.cnc import document
    from app.cnc.formats.targets import export

    program = document.loads(
        (Path(__file__).parent / "golden" / "coolant-and-messages" / "program.json").read_text()
    )
    plain = export(program, "tape-ascii").data.decode().splitlines()
    searched = export(program, "tape-ascii", {"tape-search": "yes"}).data.decode().splitlines()
    blocks = [line for line in searched if line.startswith("N")]
    assert len(blocks) > len([line for line in plain if line.startswith("N")])
    # Block 4 (the tap, tool 3 in reverse) is searched to at the tool's position with its
    # spindle and feed; it then moves over the hole.
    index = blocks.index(next(b for b in blocks if "X30000Y10000" in b))
    assert re.search(r"G50X0Y0Z5750F50M04$", blocks[index - 1]), blocks[index - 1]
    assert all(re.match(r"N\d+", line) for line in blocks)


def _writer_peak(moves: int) -> tuple[int, int]:
    """The bytes of the tape-eia listing of a LOOP/REP drilling grid of about `moves` moves
    and the peak bytes Python allocated while the writer made it (tracemalloc; the program
    is compiled before, so the peak is the writer's alone)."""

    class Counted:
        size = 0

        def write(self, data: bytes) -> int:
            self.size += len(data)
            return len(data)

    program = resolve_copies(sized("grid", moves))
    path = compile_program(program).path
    target = get_target("tape-eia")
    options = target.parse_options({})
    out, report = Counted(), Report("tape-eia")
    tracemalloc.start()
    try:
        target.write(program, path, options, report, out)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert not report.has_errors
    return out.size, peak


def test_the_tape_writer_memory_does_not_grow_with_the_program() -> None:
    # Issue 31: a 10^6-line file converts to a tape in flat memory. The planner turned each
    # chunk of the compiled path into Python lists whole, and a LOOP's chunk grows with its
    # repeats: 4.1x the peak for 10x the moves (5.3 MB at 2x10^5). It now takes a slice of
    # a chunk at a time.
    small_size, small = _writer_peak(20_000)
    large_size, large = _writer_peak(200_000)
    assert large_size > 9 * small_size  # the tape did grow tenfold
    assert large < 2 * small, f"writer peak {small / 1e6:.1f} MB → {large / 1e6:.1f} MB"


# --- runs: the writer's columns against the items one by one -------------------------------

# Options that change what a run's columns write (the others, tape-search, xyz=together and
# the quill, take the items one by one: `Planner.runs`).
_RUN_OPTIONS = st.fixed_dictionaries(
    {
        "circular": st.sampled_from(("yes", "no")),
        "decel": st.sampled_from(("no", "yes")),
        "tabs": st.sampled_from(("no", "yes")),
        "zeros": st.sampled_from(("2", "0")),
        "sequence": st.sampled_from(("yes", "no")),
        "sequence-start": st.sampled_from(("1", "990", "999")),
        "sequence-increment": st.sampled_from(("1", "5")),
        "dwell": st.sampled_from(("yes", "no")),
        "z-zero": st.sampled_from(("tcal", "g94")),
        "resolution": st.sampled_from(("standard", "option1", "option2")),
        "units": st.sampled_from(("program", "inch", "metric")),
        "drill-cycle": st.sampled_from(("0", "81")),
    }
).map(
    # Options 1 and 2 are inch formats (a metric tape is refused with them).
    lambda options: options | {"units": "inch"} if options["resolution"] != "standard" else options
)


def _tape(
    program: Program, options: dict[str, str], code: TapeCode, runs: bool, fewest: int = 1
) -> tuple[list[str], list[tuple[object, int | None, str]]]:
    """The listing's lines and the report of `program`'s tape, its straight moves, arcs,
    chords and dwells in runs (`plan.Run`) of at least `fewest` rows (by default however
    few: the generated programs are small), or not."""
    path = compile_program(program).path
    report = Report("tape")
    tape = Tape(program, path, get_target("tape-eia").parse_options(options), code, report)
    tape.planner.runs = runs
    with mock.patch.object(plan, "_MIN_RUN_ROWS", fewest):
        texts = [text for part in tape.image.listing(tape.lines()) for text in part]
    tape.finish()
    return texts, [(entry.severity, entry.block, entry.message) for entry in report.entries]


@settings(max_examples=60, deadline=None)
@given(programs(), _RUN_OPTIONS, st.sampled_from(TapeCode))
def test_runs_write_the_tape_the_items_one_by_one_write(
    program: Program, options: dict[str, str], code: TapeCode
) -> None:
    # Issue 31: the writer makes most blocks in columns. Every block, its words, its
    # sequence number, and every report entry (left-out moves, reader limitation, N999)
    # must be what the items one by one make (the path tape-search takes).
    assert _tape(program, options, code, runs=True) == _tape(program, options, code, runs=False)


@pytest.mark.parametrize(
    "case", sorted(p.name for p in GOLDEN.iterdir() if (p / "program.json").exists())
)
def test_runs_write_each_golden_tape_as_the_items_one_by_one(case: str) -> None:
    # Every golden program (tool changes, restarts, coolant, messages, holes, pockets, ...)
    # in both codes, with arcs and as chords: every block and report entry the same.
    program = golden(case)
    for options in ({}, {"circular": "no", "tabs": "yes", "sequence-start": "995"}):
        for code in TapeCode:
            assert _tape(program, options, code, runs=True) == _tape(
                program, options, code, runs=False
            ), (case, options, code)


@pytest.mark.parametrize("family", ["grid", "bolts"])
def test_runs_write_a_large_tape_as_the_items_one_by_one(family: str) -> None:
    # The bench's programs: long runs of drilled holes (dwells) and arcs across chunks.
    program = resolve_copies(sized(family, 6_000))
    items = _tape(program, {}, TapeCode.EIA, runs=False)
    assert _tape(program, {}, TapeCode.EIA, runs=True) == items
    assert _tape(program, {}, TapeCode.EIA, runs=True, fewest=plan._MIN_RUN_ROWS) == items
