"""Tektronix 1704 tapes (seed 000): a listing (text) or a punch image (a byte per row).

A punch image is read with `app.cnc.formats.tape1704.codes.decode`, the 1704 reader's rules: the
leader up to the first End of Block is skipped (a punched title is allowed there), then
blank rows and rub-outs are skipped and every row must have its code's parity — odd for
EIA, even for ASCII; the code is the one whose parity the rows have. Any parity error or
unknown row is an error naming the row and the block it falls in.

A listing is the text: lines before a line `%` (the rewind stop) are leader; one block per
line (a `;`, as Table 3-1 prints the End of Block, also ends one). Blank lines and tabs are
skipped; comments in parentheses (ASCII tapes) are kept as comments.

Words (seed 000 §2): `N3 G2 X±2.4 Y±2.4 Z±2.4 I J K R F3.1 S2 T2 M2` — implied decimals,
leading zeros dropped, words modal; the metric option and resolution option 2 make motion
words 3.3 and F whole. A decimal point is ignored by the control, so one that is not where
the format puts it (X1.5 reads 0.0015 in) is refused. One G and one M per block; a letter
given twice with different values (Table 3-1's `N006X11197X25145`) is refused.

Readings (docs/imports.md):
- G00 and G01 are feed moves (G00 stops at the end, G01 does not); G50 is the rapid. The
  mode before the first G is G00 (Table 3-1/4-1 N001 moves at its F before any G).
  A linear move at more than MillBlocks' FEEDR XY limit (100 ipm, 2540 mm/min), or before
  any F, is positioning (Table 4-1 positions at F2000, 200 ipm): a rapid, reported.
- Arcs (G02/G03, G20/G30 with deceleration): the centre I J is absolute (§4, Table 4-1)
  and modal; both end axes must be given (a missing one is read as zero by the control,
  §4) and the arc must stay within one quadrant (§4: "up to 90 degrees within one circle
  quadrant"); an end off the start's radius (Table 4-2's N003 as printed) is refused.
- G04 F: a dwell of F tenths of a second. G94 sets the axes it names (all, with none) to
  zero where the tool is. G98/G99 and M50/M51: the quill actuator (2-axis).
- G81-G89: the fixed cycles of §4's table (to R at rapid, feed to Z, back to R); their
  dwell and peck times are the panel's timers, not in the tape (reported).
- S and T words are the machine builder's codes (§4): T is read as the tool number, S as
  no speed (the user enters the RPM). M06 without a T numbers the tools in order.
- Units: inches in the standard format unless the options say `units=metric` (or
  `resolution=option1/option2`); a MillBlocks ASCII tape's header comment (PART ZERO AT
  TABLE … MM) is used as a hint and its part zero is taken into Data Block 0.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from decimal import Decimal
from typing import overload

from app.cnc import limits
from app.cnc.blocks import Program
from app.cnc.formats.tape1704 import codes as tapecode
from app.cnc.formats.tape1704.codes import TapeCode
from app.cnc.recognition.common import ImportFailure, Notes, arc_end_off, is_text, show
from app.cnc.recognition.motion import program_from_motion
from app.cnc.recognition.steps import (
    Arc,
    Coolant,
    Cycle,
    Dwell,
    End,
    Feed,
    Message,
    Parsed,
    QuillCycle,
    Rapid,
    SpindleOff,
    SpindleOn,
    Step,
    Stop,
    ToolChange,
    ToolData,
)
from app.cnc.units import Units


@dataclass(frozen=True)
class Format:
    """How a 1704 punches numbers (seed 000 §2, §4): digits before and after the implied
    point of motion words, what a unit of F is, and the step positions are rounded to."""

    name: str
    units: Units
    int_digits: int
    frac_digits: int
    feed_nm: int  # one unit of the F word, nm/min
    feed_places: int  # digits after F's implied point

    @property
    def digit_nm(self) -> int:
        return int(self.units.nm // 10**self.frac_digits)


FORMATS = {
    ("inch", "standard"): Format("standard inch (2.4, F3.1)", Units.INCH, 2, 4, 2_540_000, 1),
    ("inch", "option1"): Format("resolution option 1 (2.4, F3.1)", Units.INCH, 2, 4, 2_540_000, 1),
    ("inch", "option2"): Format("resolution option 2 (3.3, F4)", Units.INCH, 3, 3, 25_400_000, 0),
    ("metric", "standard"): Format("metric option (3.3, F4)", Units.MM, 3, 3, 1_000_000, 0),
}
LETTERS = set("NGXYZIJKRFSTM")
DIMENSIONS = set("XYZIJKR")
WORD_DIGITS = {"N": 3, "G": 2, "M": 2, "S": 2, "T": 2, "F": 4}
MOTION_G = {0, 1, 2, 3, 20, 30, 50, 80, 81, 82, 83, 84, 85, 86, 87, 88, 89}
KNOWN_G = MOTION_G | {4, 90, 91, 94, 98, 99}
CYCLE_NOTES = {
    82: "the dwell at the bottom is the panel's timer (1.3-12 s), not in the tape",
    83: "the pecks are made by the panel's peck timer, not in the tape: one feed to Z",
    88: "the dwell is the panel's timer",
    89: "the dwell is the panel's timer",
}
HEADER = re.compile(
    r"PART ZERO AT TABLE X(-?\d{1,6}\.\d{1,6}) Y(-?\d{1,6}\.\d{1,6}) (IN|MM)", re.ASCII
)
TOOL_COMMENT = re.compile(
    r"(FIRST )?TOOL (\d{1,2})(?: DIA (\d{1,6}\.\d{1,6}))?(?: TCAL (-?\d{1,6}\.\d{1,6}))?$", re.ASCII
)
# MillBlocks' ASCII tapes say how their Z words were made (tape1704.header): with each
# tool's TCAL added (the 1704 has no length offsets), or touched off with G94.
TCAL_IN_Z = "Z WORDS INCLUDE EACH TOOL TCAL"
START = re.compile(r"START OVER PART ZERO, Z(-?\d{1,6}\.\d{1,6}) ABOVE TOOL ZERO", re.ASCII)


def read_tape(data: bytes, name: str, options: Mapping[str, str]) -> tuple[Program, Notes]:
    """Read a listing or punch image. Raises ImportFailure naming block and row/line."""
    reader = _TapeReader(data, name, options)
    return program_from_motion(reader.parse()), reader.notes


def parse_tape(data: bytes, name: str, options: Mapping[str, str]) -> Parsed:
    """The motion a listing or punch image describes (before it becomes blocks), Z as each
    tool's own Z where the tape says its Z words include TCAL. Raises ImportFailure."""
    return _TapeReader(data, name, options).parse()


@dataclass
class _Block:
    """One block of the tape: its text and where it came from."""

    index: int  # 1-based, counted after the rewind stop
    text: str
    line: int  # listing line (0 for a punch image)
    column: int  # column of the block's first character on that line
    rows: tuple[int, int] | None = None  # punch image: first and last row
    words: list[tuple[str, str, int]] = field(default_factory=list)  # letter, digits, column
    comment: str = ""

    @property
    def n(self) -> str:
        for letter, value, _ in self.words:
            if letter == "N":
                return f"N{value}"
        match = re.match(r"\s*N([0-9]+)", self.text)
        return f"N{match.group(1)}" if match else ""


class _TapeReader:
    def __init__(self, data: bytes, name: str, options: Mapping[str, str]) -> None:
        self.data = data
        self.name = name
        self.options = options
        self.notes = Notes(unit="tape block")
        self.blocks: list[_Block] = []
        self.code: TapeCode | None = None

    # -- reading the tape ---------------------------------------------------------------

    def parse(self) -> Parsed:
        if is_text(self.data):
            self.listing(self.data.decode("utf-8").lstrip("\ufeff"))
        else:
            self.punch(self.data)
        return _Interpreter(self, self.format()).run()

    def where(self, block: _Block, column: int | None = None) -> str:
        n = f" ({block.n})" if block.n else ""
        if block.rows is not None:
            return f"tape block {block.index}{n}, rows {block.rows[0]}-{block.rows[1]}"
        col = "" if column is None else f", column {column}"
        return f"tape block {block.index}{n}, line {block.line}{col}"

    def fail(self, block: _Block, message: str, column: int | None = None) -> ImportFailure:
        return ImportFailure(self.where(block, column), message, block.index)

    def listing(self, text: str) -> None:
        lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
        start = next((k for k, raw in enumerate(lines) if raw.strip() == "%"), None)
        if start is None:
            start = -1
            self.notes.assumed(None, "no rewind stop (%): the listing starts with its first line")
        elif start > 0 and any(raw.strip() for raw in lines[:start]):
            self.notes.ignored(1, f"leader (lines 1-{start}): skipped, as the reader skips it")
        for number in range(start + 1, len(lines)):
            raw = lines[number]
            column = 1
            for piece in raw.split(";"):
                if piece.strip():
                    self.add_block(piece, number + 1, column)
                column += len(piece) + 1

    def add_block(self, text: str, line: int, column: int) -> None:
        block = _Block(len(self.blocks) + 1, text, line, column)
        self.blocks.append(block)
        n = f"{block.n}, " if block.n else ""
        self.notes.labels[block.index] = f"tape block {block.index} ({n}line {line})"

    def punch(self, rows: bytes) -> None:
        decoded = {code: tapecode.decode(rows, code) for code in TapeCode}
        scores = {code: len(d.parity_errors) + len(d.unknown_rows) for code, d in decoded.items()}
        usable = [c for c in TapeCode if decoded[c].text]
        if not usable:
            raise ImportFailure(
                "",
                "a punch image with no End of Block (EIA channel 8, ASCII CR): no blocks on it",
            )
        code = min(usable, key=lambda c: (scores[c], c.value))
        others = [c for c in usable if c is not code]
        if others and scores[others[0]] == scores[code]:
            raise ImportFailure(
                "",
                "the rows fit EIA and ASCII equally badly: give a listing, or check the image",
            )
        self.code = code
        result = decoded[code]
        self.notes.assumed(
            None,
            f"{code.value.upper()} punch image (its rows have "
            f"{'odd' if code is TapeCode.EIA else 'even'} parity); leader of "
            f"{result.leader_rows} rows skipped",
        )
        eob = tapecode.end_of_block(code)
        skip = {tapecode.BLANK, tapecode.delete(code)}
        reverse = {row: ch for ch, row in tapecode.table(code).items()}
        chars: list[str] = []
        first_row = result.leader_rows
        block_rows: list[tuple[int, int]] = []
        texts: list[str] = []
        bad_rows = set(result.parity_errors) | {r for r, _ in result.unknown_rows}
        bad: tuple[int, int] | None = None  # (row, block index)
        for index in range(result.leader_rows, len(rows)):
            row = rows[index]
            if row in skip:
                continue
            if index in bad_rows and bad is None:
                bad = (index, len(texts) + 1)
            if row == eob:
                texts.append("".join(chars))
                block_rows.append((first_row, index))
                chars = []
                first_row = index + 1
                continue
            chars.append(reverse.get(row, "?"))
        if chars and "".join(chars).strip():
            texts.append("".join(chars))
            block_rows.append((first_row, len(rows) - 1))
            self.notes.ignored(None, "the tape ends without an End of Block after its last block")
        # The first "block" is the rewind stop before the first End of Block.
        if texts and texts[0].strip() == tapecode.REWIND_STOP_CHAR:
            texts, block_rows = texts[1:], block_rows[1:]
        else:
            self.notes.assumed(None, "no rewind stop before the first End of Block")
        for k, (text, span_rows) in enumerate(zip(texts, block_rows, strict=True), start=1):
            block = _Block(k, text, 0, 1, span_rows)
            self.blocks.append(block)
            self.notes.labels[k] = f"tape block {k}" + (f" ({block.n})" if block.n else "")
        if bad is not None:
            row, index = bad
            value = rows[row]
            what = (
                f"a parity error: {tapecode.holes(value)} holes (row 0x{value:02X}), "
                f"{'EIA needs an odd' if code is TapeCode.EIA else 'ASCII needs an even'} number"
                if row in result.parity_errors
                else f"row 0x{value:02X} is no {code.value.upper()} character"
            )
            block_index = max(1, index - 1)
            if block_index <= len(self.blocks):
                block = self.blocks[block_index - 1]
                raise ImportFailure(f"row {row}, {self.where(block)}", what, block_index)
            raise ImportFailure(f"row {row}", what)

    def format(self) -> Format:
        units = self.options.get("units", "").strip().lower()
        resolution = self.options.get("resolution", "standard").strip().lower() or "standard"
        if units not in ("", "inch", "metric"):
            raise ImportFailure("", f"option units: {units!r} is not inch or metric")
        if resolution not in ("standard", "option1", "option2"):
            raise ImportFailure(
                "", f"option resolution: {resolution!r} is not standard/option1/option2"
            )
        if not units:
            hint = next((m for b in self.blocks if (m := HEADER.search(b.text))), None)
            units = "metric" if hint is not None and hint.group(3) == "MM" else "inch"
            if hint is not None:
                self.notes.assumed(
                    None, f"the header comment says {hint.group(3)}: the {units} format"
                )
            else:
                self.notes.assumed(
                    None,
                    "inch tape, standard format (2.4, F3.1): the tape does not say (give "
                    "units=metric for the metric option)",
                )
        if units == "metric" and resolution != "standard":
            raise ImportFailure("", "the resolution options are inch formats")
        return FORMATS[(units, resolution)]


def step_z(step: Step) -> int | None:
    """The Z a step moves at, if it has one."""
    return step.z if isinstance(step, Rapid | Feed | Arc) else None


class _Interpreter:
    """The 1704's modal state, block by block, into motion steps."""

    def __init__(self, reader: _TapeReader, fmt: Format) -> None:
        self.reader = reader
        self.fmt = fmt
        self.units = fmt.units
        self.notes = reader.notes
        self.steps: list[Step] = []
        self.g = 0  # the 1704 starts in G00 (Table 4-1 N001)
        self.incremental = False
        self.x, self.y = 0, 0
        self.z: int | None = None
        self.i: int | None = None
        self.j: int | None = None
        self.feed: int | None = None
        self.shift = [0, 0, 0]
        self.tool = 0
        self.changed = False  # an M06 has been read
        self.start_tool_used = False  # motion before any M06: the tape's first tool
        self.comment_tool: int | None = None
        self.offsets: tuple[int, int] | None = None
        self.ended = False
        self.cycle_r: int | None = None
        self.cycle_z: int | None = None
        self.selected: int | None = None
        self.tool_data: dict[int, ToolData] = {}
        self.first_tool = 0  # named by a FIRST TOOL header comment
        self.tcal_in_z = False  # Z words are the tool's Z plus its TCAL (header comment)
        self.start_z: int | None = None  # where the tool starts (header comment)

    def run(self) -> Parsed:
        for block in self.reader.blocks:
            if self.ended:
                if block.text.strip():
                    self.notes.ignored(block.index, "after the end of the program: not imported")
                continue
            self.words(block)
            self.execute(block)
        tolerance = max(1, self.fmt.digit_nm // 2)
        if self.fmt.name.startswith("resolution option 1"):
            tolerance = 2 * self.fmt.digit_nm // 2
        initial = self.first_tool
        if self.start_tool_used and not initial:
            initial = 1
            self.notes.assumed(None, "the tape does not say which tool it starts with: tool 1")
        if not self.tcal_in_z and any(step_z(s) is not None for s in self.steps):
            self.notes.assumed(
                None,
                "the tape does not say whether its Z words include tool calibrations (TCAL): "
                "each Z word is read as the tool's own Z",
            )
        return Parsed(
            format="tape",
            units=self.units,
            steps=self.steps,
            notes=self.notes,
            tolerance=tolerance,
            name=self.reader.name,
            offsets=self.offsets,
            start_z=self.start_z,
            tools=self.tool_data,
            initial_tool=initial,
        )

    # -- words -----------------------------------------------------------------------------

    def words(self, block: _Block) -> None:
        text = block.text
        pos = 0
        comments: list[str] = []
        seen: dict[str, str] = {}
        n = len(text)
        while pos < n:
            ch = text[pos]
            column = block.column + pos
            if ch in " \t":
                pos += 1
                continue
            if ch == "%":
                pos += 1
                continue
            if ch == "(":
                close = text.find(")", pos)
                if close < 0:
                    raise self.reader.fail(block, "comment not closed: '(' without ')'", column)
                comments.append(text[pos + 1 : close].strip())
                pos = close + 1
                continue
            if ch == "?":
                raise self.reader.fail(block, "a row no character has", column)
            if ch not in LETTERS:
                what = "a letter the 1704 has no word for" if ch.isalpha() else "not a tape word"
                raise self.reader.fail(block, f"{ch!r}: {what} (N G X Y Z I J K R F S T M)", column)
            match = re.match(r"[+-]?[0-9.]*", text[pos + 1 :])
            assert match is not None
            value = match.group()
            digits = value.lstrip("+-").replace(".", "")
            if not digits:
                raise self.reader.fail(block, f"{ch} needs digits", column)
            self.check_point(block, ch, value, column)
            limit = WORD_DIGITS.get(ch, self.fmt.int_digits + self.fmt.frac_digits)
            if len(digits.lstrip("0")) > limit:
                raise self.reader.fail(
                    block,
                    f"{ch}{value}: more than the {limit} digits of the 1704's {ch} word",
                    column,
                )
            if ch in "GM":
                block.words.append((ch, value, column))  # one of each: checked per block
            elif ch in seen:
                if seen[ch] != digits.lstrip("0"):
                    hint = " (the second is probably Y: scan damage?)" if ch == "X" else ""
                    raise self.reader.fail(
                        block,
                        f"{ch} given twice with different values ({ch}{seen[ch] or 0} and "
                        f"{ch}{digits}){hint}",
                        column,
                    )
                self.notes.ignored(block.index, f"{ch}{value} written twice: read once")
            else:
                seen[ch] = digits.lstrip("0")
                block.words.append((ch, value, column))
            pos += 1 + len(value)
        block.comment = " ".join(comments)
        letters = {letter for letter, _, _ in block.words}
        if block.comment and letters <= {"N"} and "N" in letters:
            # A block that is only a comment: an operator message (MillBlocks' own tapes).
            self.steps.append(Message(block.index, block.comment))
        tool = TOOL_COMMENT.match(block.comment)
        self.comment_tool = None
        if tool is not None:
            number = int(tool.group(2))
            self.comment_tool = number
            self.tool_data[number] = ToolData(
                diameter=None if tool.group(3) is None else self.comment_length(tool.group(3)),
                tcal=None if tool.group(4) is None else self.comment_length(tool.group(4)),
            )
            self.notes.became(
                block.index, f"the comment on tool {number}: its DIA and TCAL (Data Block 0)"
            )
            if tool.group(1) and not self.changed and not self.start_tool_used:
                self.tool = number
                self.first_tool = number
                self.notes.became(block.index, f"the comment: the tape starts with tool {number}")
        start = START.search(block.comment)
        if start is not None:
            self.start_z = self.comment_length(start.group(1))
            self.notes.became(block.index, "the header comment: where the tool starts")
        if TCAL_IN_Z in block.comment:
            self.tcal_in_z = True
            self.notes.became(
                block.index,
                "the header comment: Z words include each tool's TCAL; each tool's TCAL is "
                "taken off its Z words",
            )
        if block.comment:
            header = HEADER.search(block.comment)
            if header is not None:
                units = Units.INCH if header.group(3) == "IN" else Units.MM
                ox = int(Decimal(header.group(1)) * units.nm)
                oy = int(Decimal(header.group(2)) * units.nm)
                self.offsets = (ox, oy)
                self.notes.became(block.index, "the header comment: part zero (Data Block 0 X, Y)")

    @overload
    def part_z(self, z: int) -> int: ...
    @overload
    def part_z(self, z: None) -> None: ...
    @overload
    def part_z(self, z: int | None) -> int | None: ...

    def part_z(self, z: int | None) -> int | None:
        """The tool's own Z (from its calibrated zero) for a Z word of the tape: the word less
        the TCAL of the tool in the spindle when the tape says its Z words include it."""
        if z is None or not self.tcal_in_z:
            return z
        data = self.tool_data.get(self.tool)
        return z - (0 if data is None or data.tcal is None else data.tcal)

    def comment_length(self, text: str) -> int:
        """A length written in a MillBlocks tape's comment (in the tape's units), in nm."""
        return int(Decimal(text) * self.units.nm)

    def check_point(self, block: _Block, letter: str, value: str, column: int) -> None:
        """The 1704 ignores decimal points; one that says a different number is refused."""
        if "." not in value:
            return
        after = len(value.split(".", 1)[1].replace(".", ""))
        if letter in DIMENSIONS:
            expected = self.fmt.frac_digits
        elif letter == "F":
            expected = self.fmt.feed_places
        else:
            expected = 0
        if value.count(".") > 1 or after != expected:
            digits = value.replace(".", "")
            raise self.reader.fail(
                block,
                f"{letter}{value}: the 1704 ignores the point and reads {letter}{digits}, "
                f"which is not the number the point shows",
                column,
            )

    def number(self, value: str) -> int:
        digits = value.replace(".", "")
        return int(digits) if digits.strip("+-") else 0

    def length(self, value: str) -> int:
        return self.number(value) * self.fmt.digit_nm

    # -- a block ---------------------------------------------------------------------------

    def execute(self, block: _Block) -> None:
        line = block.index
        words: dict[str, tuple[str, int]] = {}
        gs: list[int] = []
        for letter, value, column in block.words:
            if letter == "G":
                gs.append(self.number(value))
            words[letter] = (value, column)
        if len(set(gs)) > 1:
            raise self.reader.fail(
                block, "two different G words in one block (seed 000 §2: they must not be)"
            )
        ms = [self.number(v) for letter, v, _ in block.words if letter == "M"]
        if len(set(ms)) > 1:
            raise self.reader.fail(
                block, "two different M words in one block (seed 000 §2: they must not be)"
            )
        for letter, found in (("G", gs), ("M", ms)):
            if len(found) > len(set(found)):
                self.notes.ignored(line, f"{letter}{found[0]:02d} written twice: read once")
        g = gs[0] if gs else None
        if g is not None and g not in KNOWN_G:
            raise self.reader.fail(block, f"G{g:02d} is not a 1704 code", words["G"][1])
        m = self.number(words["M"][0]) if "M" in words else None
        if "F" in words and g != 4:
            self.feed = self.number(words["F"][0]) * self.fmt.feed_nm
        if "S" in words:
            self.notes.ignored(
                line,
                f"S{words['S'][0]}: a spindle code of the machine builder, not a speed (the RPM "
                "is entered in Data Block 0)",
            )
        if "T" in words:
            tool = self.number(words["T"][0])
            if tool != self.tool and m != 6:
                self.notes.assumed(
                    line, f"T{words['T'][0]} without M06: selected for the next change"
                )
            self.selected = tool
        if m is not None:
            self.m_before(block, m, words)
        if g == 4:
            if "F" not in words:
                raise self.reader.fail(block, "G04 needs F (the dwell in tenths of a second)")
            seconds = Decimal(self.number(words["F"][0])) / 10
            self.steps.append(Dwell(line, seconds))
        elif g in (90, 91):
            self.incremental = g == 91
        elif g == 94:
            self.preset(block, words)
        elif g in (98, 99):
            self.steps.append(QuillCycle(line, g == 99))
            self.notes.became(line, f"G{g}: the quill drill cycle {'on' if g == 99 else 'off'}")
        elif g is not None:
            self.g = g
        if g not in (4, 94) and any(axis in words for axis in "XYZ"):
            self.motion(block, words)
        elif g not in (4, 94) and ("I" in words or "J" in words):
            self.centre(block, words)
        if m is not None:
            self.m_after(block, m)

    def m_before(self, block: _Block, m: int, words: dict[str, tuple[str, int]]) -> None:
        line = block.index
        if m in (3, 4):
            self.steps.append(SpindleOn(line, None, m == 3))
        elif m == 6:
            tool = self.selected if self.selected is not None else self.comment_tool
            if tool is None:
                used = {1 if self.start_tool_used else 0, *self.tool_data, self.tool}
                tool = max(used) + 1
                self.notes.assumed(
                    line, f"M06: the tape does not say which tool; called tool {tool}"
                )
            elif self.selected is None:
                self.notes.became(line, f"M06 with the comment TOOL {tool}: tool {tool}")
            self.tool = tool
            self.changed = True
            self.steps.append(ToolChange(line, tool))
        elif m == 51:
            self.steps.append(Stop(line, False, "M51 quill down"))
        elif m in (7, 8):
            self.steps.append(Coolant(line, "mist" if m == 7 else "flood"))
        elif m == 52:
            self.notes.ignored(line, "M52: the quill turret, not carried")

    def m_after(self, block: _Block, m: int) -> None:
        line = block.index
        if m in (0, 1):
            self.steps.append(Stop(line, m == 1, block.comment))
        elif m in (2, 30):
            self.steps.append(End(line))
            self.ended = True
            self.notes.became(line, f"M{m:02d}: the end of the program")
        elif m == 5:
            self.steps.append(SpindleOff(line))
        elif m == 9:
            self.steps.append(Coolant(line, "off"))
        elif m == 50:
            last = self.steps[-1] if self.steps else None
            if isinstance(last, Stop) and last.comment == "M51 quill down":
                return
            self.steps.append(Stop(line, False, "M50 quill up"))
        elif m not in (3, 4, 6, 7, 8, 51, 52):
            self.notes.ignored(line, f"M{m:02d}: a function of the machine builder, not imported")

    def preset(self, block: _Block, words: dict[str, tuple[str, int]]) -> None:
        named = [k for k, a in enumerate("XYZ") if a in words]
        for k in named or [0, 1, 2]:
            current = (self.x, self.y, self.z)[k]
            if current is None:
                continue
            # The point the tool is at (`current`, part coordinates) now reads `value`.
            value = self.length(words["XYZ"[k]][0]) if "XYZ"[k] in words else 0
            self.shift[k] = current - value
        self.notes.assumed(
            block.index,
            "G94: the axes it names (all, with none) read zero here; later points are "
            "converted back to part coordinates",
        )

    def centre(self, block: _Block, words: dict[str, tuple[str, int]]) -> None:
        if "K" in words:
            raise self.reader.fail(
                block, "K: arcs in the XZ/YZ planes are not supported", words["K"][1]
            )
        if "I" in words:
            self.i = self.length(words["I"][0]) + (self.x if self.incremental else self.shift[0])
        if "J" in words:
            self.j = self.length(words["J"][0]) + (self.y if self.incremental else self.shift[1])

    def motion(self, block: _Block, words: dict[str, tuple[str, int]]) -> None:
        line = block.index
        if not self.changed:
            self.start_tool_used = True
        target = [self.x, self.y, self.z]
        for k, axis in enumerate("XYZ"):
            if axis in words:
                value = self.length(words[axis][0])
                base = target[k] if self.incremental else self.shift[k]
                target[k] = (base or 0) + value
        x, y, z = target
        assert x is not None and y is not None
        g = self.g
        self.centre(block, words)
        if g in (2, 3, 20, 30):
            self.arc(block, words, x, y, z, g in (2, 20))
        elif g == 50:
            self.steps.append(Rapid(line, x, y, self.part_z(z), self.units))
        elif g == 80:
            r = words.get("R")
            rz = z if r is None else self.length(r[0]) + self.shift[2]
            self.steps.append(Rapid(line, x, y, self.part_z(rz), self.units))
            z = rz
        elif g >= 81:
            self.cycle(block, words, x, y)
            return
        else:
            # A move in Z alone is a FEEDR Z (up to 250 ipm), one across a FEEDR XY (100).
            in_z = (x, y) == (self.x, self.y)
            feeds = limits.FEED_Z if in_z else limits.FEED_XY
            limit = feeds[self.units].high * self.units.nm
            if self.feed is None or self.feed > limit:
                self.steps.append(Rapid(line, x, y, self.part_z(z), self.units))
                why = "no F given yet"
                if self.feed is not None:
                    rate = show(self.feed, self.units)
                    which = "FEEDR Z" if in_z else "FEEDR XY"
                    why = f"F at {rate} per minute, above MillBlocks' {which} limit"
                self.notes.assumed(line, f"G{g:02d} with {why}: read as positioning (rapid)")
            else:
                self.steps.append(Feed(line, x, y, self.part_z(z), self.feed, self.units))
        self.x, self.y, self.z = x, y, z

    def arc(
        self,
        block: _Block,
        words: dict[str, tuple[str, int]],
        x: int,
        y: int,
        z: int | None,
        clockwise: bool,
    ) -> None:
        line = block.index
        if "X" not in words or "Y" not in words:
            raise self.reader.fail(
                block,
                "an arc needs both X and Y: the 1704 reads a missing end axis as zero (seed 000 "
                "§4)",
            )
        if "Z" in words and z != self.z:
            raise self.reader.fail(
                block, "an arc with a Z move: arcs are in one plane", words["Z"][1]
            )
        if self.i is None or self.j is None:
            raise self.reader.fail(block, "an arc with no centre (I and J) given yet")
        centre = (self.i, self.j)
        start = (self.x, self.y)
        r1, r2 = math.dist(start, centre), math.dist((x, y), centre)
        if r1 == 0:
            raise self.reader.fail(block, "the arc's centre is its start point")
        if arc_end_off(r1, r2, self.units):
            raise self.reader.fail(
                block,
                f"the arc's end is {show(abs(r1 - r2), self.units)} off its radius: the start "
                f"is {show(r1, self.units)} from the centre I J, the end "
                f"{show(r2, self.units)}",
            )
        a0 = math.atan2(start[1] - centre[1], start[0] - centre[0])
        a1 = math.atan2(y - centre[1], x - centre[0])
        sweep = (a0 - a1) if clockwise else (a1 - a0)
        sweep %= 2 * math.pi
        eps = max(1e-9, 2 * self.fmt.digit_nm / r1)
        if (x, y) == start or sweep > math.pi / 2 + eps:
            raise self.reader.fail(
                block,
                f"the arc turns {math.degrees(sweep if (x, y) != start else 2 * math.pi):.1f}°: "
                "the 1704 cuts up to 90° within one quadrant (seed 000 §4)",
            )
        for q in range(4):
            axis = q * math.pi / 2
            into = ((a0 - axis) if clockwise else (axis - a0)) % (2 * math.pi)
            if eps < into < sweep - eps:
                raise self.reader.fail(
                    block,
                    f"the arc crosses the {q * 90}° line through its centre: the 1704 cuts "
                    "within one quadrant (seed 000 §4)",
                )
        if self.feed is None:
            raise self.reader.fail(block, "an arc with no feed rate (F) given yet")
        self.steps.append(
            Arc(line, x, y, self.part_z(z), centre[0], centre[1], clockwise, self.feed, self.units)
        )
        self.x, self.y = x, y

    def cycle(self, block: _Block, words: dict[str, tuple[str, int]], x: int, y: int) -> None:
        line = block.index
        code = self.g
        if "R" in words:
            self.cycle_r = self.length(words["R"][0]) + self.shift[2]
        if "Z" in words:
            self.cycle_z = self.length(words["Z"][0]) + self.shift[2]
        if self.cycle_r is None or self.cycle_z is None:
            raise self.reader.fail(block, f"G{code} needs R (the clearance) and Z (the depth)")
        if self.cycle_z >= self.cycle_r:
            raise self.reader.fail(block, f"G{code}: Z is not below R")
        if self.feed is None:
            raise self.reader.fail(block, f"G{code} with no feed rate (F) given yet")
        self.steps.append(
            Cycle(
                line,
                code,
                x,
                y,
                self.part_z(self.cycle_r),
                self.part_z(self.cycle_z),
                self.part_z(self.cycle_r),
                self.feed,
                0,
                None,
                self.units,
            )
        )
        self.notes.assumed(
            line,
            f"G{code}: read as seed 000 §4's fixed cycle (to R at rapid, feed to Z, back to R); "
            "the machine builder may have set it otherwise"
            + (f"; {CYCLE_NOTES[code]}" if code in CYCLE_NOTES else ""),
        )
        self.x, self.y, self.z = x, y, self.cycle_r
