"""RS274/NGC and Fanuc G-code, read into motion (then recognised as data blocks).

The codes are those of seed 003's RS274/NGC (LinuxCNC) and Fanuc tables, executed in
LinuxCNC's order within a block (feed, speed, tool, spindle, dwell, plane, units,
compensation, tool length, coordinates, distance mode, return mode, G10/G28/G92, motion,
stop). Readings where the dialects differ or the seed is vague (docs/imports.md):

- **No G20/G21** in the file: inches (seed 003's Fanuc samples have none and are inch),
  reported.
- **`;`** ends a block (the ProtoTRAK "modified Fanuc 6", §2.1 rule 3); text after it on the
  same line is a comment (LinuxCNC), reported when there is any.
- **G45 Hn Z…** (Fanuc "tool offset increase"; §2.2.6.1-2 use it to bring each tool down):
  tool n's length offset taken up, then a move to the given axes in the current motion
  mode, as `G43 Hn` and a move would. G46-G48 need offset values the file lacks: refused.
- **Which tool**: M6 changes to the selected T; a G43/G45 H after it names the tool (a
  length offset belongs to its tool) — §2.2.6.1 writes T1 on every line, H1, H2, H3.
- **G92** before any motion says where part zero is (the tool's start); a later one shifts
  the coordinates, and the shift is carried into the imported (part) coordinates.
- **Work offsets** (G54-G59.3): part zero is the zero of the system in effect at the first
  move. Where the file gives another system's zero from it (G10 L2 for both, or G10 L20),
  that system's points are moved by the difference, as rs274 cuts them (a Z zero neither
  gives: the same, reported); where it does not, that system's first move is refused at
  the G code choosing it (the values are only on the machine's offset table). A G10 L2
  value of the system holding part zero is Data Block 0 X/Y (part zero on the table).
- **A feed outside FEEDR XY / FEEDR Z** (app.cnc.limits): cut at the nearest end of the
  range, reported at the F word (`need_feed`).
- **G28/G30** with axis words: the tool goes to the intermediate point (imported as a
  move); the return on to the machine's home, which the file does not give, is not.
- **G04 P**: seconds (LinuxCNC); in a Fanuc-style `G04 P800` (two-digit code, no point)
  milliseconds. G04 X: seconds.
- A **canned cycle left on by a G00/G01** that only moves in X/Y is refused: RS274 ends the
  cycle there (no hole), while a ProtoTRAK post writing its modal code on every line
  (§2.1 rule 1, §2.2.6.2 N6-N9) means a hole — the file cannot say which.
- **Subroutines, control flow, parameters and expressions** (LinuxCNC's O-words, Fanuc's
  M98/M99): at the first line that has any (`FrontEnd`) the file is read again, run by
  `ngc.py`, which gives this reader each line as it runs, values in place, with the file's
  line and column of each character (a failure here is moved back to them). Every other
  file is read straight (the fast path).
- **M99** that reaches this reader is the main program's: its end (rs274 reads it so).
- **@ and ^**: LinuxCNC's polar coordinates about program zero (`polar`), each L repeat of
  an incremental canned cycle turned again.
- Unknown G and M codes are listed with their line and not imported; codes that change the
  motion in ways MillBlocks cannot hold (G5-G5.3, G33, G38.x, G93, G95, rotary axes) are
  refused, naming line and column; G53 G0 is a rapid to a place the file does not give in
  part coordinates (`machine_move`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from decimal import Decimal
from typing import Final

from app.cnc import limits
from app.cnc.formats.gcode import ngc
from app.cnc.numbers import NUMBER_TEXT
from app.cnc.recognition.common import (
    MAX_ABS_NM,
    MAX_DIGITS,
    ImportFailure,
    Notes,
    arc_end_off,
    check_digits,
    failure,
    feed_nm,
    show,
    show_feed,
    split_lines,
    text_lines,
)
from app.cnc.recognition.steps import (
    Arc,
    Coolant,
    Cycle,
    Dwell,
    End,
    Feed,
    Message,
    Parsed,
    Rapid,
    SpindleOff,
    SpindleOn,
    Step,
    StepSource,
    Stop,
    StreamSource,
    ToolChange,
    ToolData,
)
from app.cnc.units import NM_PER_INCH, NM_PER_MM, Units, half_even

NUMBER: Final = re.compile(NUMBER_TEXT)
SIMPLE: Final = re.compile(rf"(?:[ \t]*[A-Za-z]{NUMBER_TEXT})+[ \t]*")
# The commonest line, read in one match: N, G0-G3 or G80, X, Y, Z, I, J, F, each perhaps,
# in this order (`_Reader.fast_words` takes the numbers as written).
# Its numbers have at most 12 digits and point (MAX_DIGITS: no need to count them again).
_SHORT = rf"[+-]?(?=[0-9.]{{1,{MAX_DIGITS}}}(?![0-9.])){NUMBER_TEXT.removeprefix('[+-]?')}"
USUAL: Final = re.compile(
    rf"[ \t]*(?:N([0-9]{{1,{MAX_DIGITS}}})[ \t]*)?(?:G(0?[0-3]|80)[ \t]*)?(?:X({_SHORT})[ \t]*)?"
    rf"(?:Y({_SHORT})[ \t]*)?(?:Z({_SHORT})[ \t]*)?(?:I({_SHORT})[ \t]*)?"
    rf"(?:J({_SHORT})[ \t]*)?(?:F({_SHORT}))?"
)
# A word with the blanks before it (the column is counted from their lengths).
PAIRS: Final = re.compile(rf"([ \t]*)([A-Za-z])({NUMBER_TEXT})")
MAX_STEPS: Final = 2_000_000  # L repeats could make any number of holes from one line
HEADER = re.compile(r"^(.*) PART ([0-9]{1,8}|-) MILLBLOCKS$")
# MillBlocks' set-up comments (emit/gcode.py): part zero and each tool's diameter and length.
SETUP_ZERO = re.compile(
    r"^SET-UP: G0?54 = PART ZERO AT TABLE X(-?\d+\.\d+) Y(-?\d+\.\d+)$", re.ASCII
)
SETUP_TOOL = re.compile(
    r"^SET-UP: T(\d{1,2})(?: DIA (\d+\.\d+))? LENGTH H\d+"
    r"(?: = (-?\d+\.\d+), ITS TCAL|: UNCALIBRATED, MEASURE IT)$",
    re.ASCII,
)
SETUP_NAME = re.compile(r"^SET-UP: T(\d{1,2}) IS (.+)$", re.ASCII)

# LinuxCNC's modal groups (one code of each per block), seed 003 Table 5 plus Fanuc's.
MODAL_GROUPS: dict[str, set[str]] = {
    "motion": {"0", "1", "2", "3", "33", "38.2", "73", "74", "76", "80", "81", "82", "83"}
    | {"84", "85", "86", "87", "88", "89"},
    "plane": {"17", "18", "19"},
    "distance": {"90", "91"},
    "arc distance": {"90.1", "91.1"},
    "feed mode": {"93", "94", "95"},
    # G70/G71: the units of the BOSS (seed 004 §8.2.3, §8.3.1) and older Fanuc-style
    # controls (seed 002 §19: G70 inch input, G71 metric input); not in seed 003's tables.
    "units": {"20", "21", "70", "71"},
    "cutter compensation": {"40", "41", "42", "41.1", "42.1"},
    "tool length": {"43", "43.1", "44", "49"},
    "return mode": {"98", "99"},
    "coordinate system": {"54", "55", "56", "57", "58", "59", "59.1", "59.2", "59.3"},
    "path control": {"61", "61.1", "64"},
    "non-modal": {"4", "10", "28", "30", "45", "46", "47", "48", "53", "92", "92.1", "92.2"}
    | {"92.3"},
}
GROUP_OF: Final = {code: group for group, codes in MODAL_GROUPS.items() for code in codes}
CYCLES: Final = {"73", "74", "76", "81", "82", "83", "84", "85", "86", "87", "88", "89"}
# Codes of seed 003's tables that change the motion in ways a data-block program cannot hold.
REFUSED_G = {
    # LinuxCNC's other motion codes: ignoring one would move its axis words at G0/G1.
    "5": "a cubic spline",
    "5.1": "a quadratic spline",
    "5.2": "a NURBS curve",
    "5.3": "a NURBS curve",
    "33": "thread cutting",
    "33.1": "rigid tapping",
    "38.2": "probing",
    "38.3": "probing",
    "38.4": "probing",
    "38.5": "probing",
    "41.1": "dynamic cutter compensation",
    "42.1": "dynamic cutter compensation",
    "43.1": "dynamic tool length",
    "44": "negative tool length offset",
    "46": "tool offset decrease (the offset value is not in the file)",
    "47": "tool offset double increase (the offset value is not in the file)",
    "48": "tool offset double decrease (the offset value is not in the file)",
    "93": "inverse time feed",
    "95": "feed per revolution",
    "7": "imaginary axis designation",
    "22": "",
    "29": "return from the reference point (its position is not in the file)",
    "31": "skip cutting",
    "50": "",
    "51": "scaling",
    "52": "a local coordinate system",
    "65": "macro call",
    "66": "macro call",
    "68": "coordinate rotation",
    # Fanuc's codes that change what X and Y mean (seed 002 and later Fanuc manuals): read
    # as if absent, the next G1 X1. Y45. would be a straight move to X1 Y45.
    "7.1": "cylindrical interpolation",
    "12": "a circle cutting cycle of the control",
    "12.1": "polar coordinate interpolation",
    "13": "a circle cutting cycle of the control",
    "16": "polar coordinates (X a radius, Y an angle)",
    "51.1": "a programmable mirror image",
    "68.1": "a tilted working plane",
    "68.2": "a tilted working plane",
}
NOTED_G = {
    "17": "",
    "22": "stored stroke limit on: not carried",
    "23": "stored stroke limit off: not carried",
    "27": "reference point return check: not carried",
    "40": "",
    "49": "tool length offset cancelled: Z is then the spindle's, MillBlocks' Z is the tool's",
    "50": "scaling off: nothing to import",
    "54": "",
    "60": "single direction positioning: not carried",
    "61": "exact path mode: not carried (MillBlocks has no path control)",
    "61.1": "exact stop mode: not carried",
    "64": "continuous mode: not carried",
    "67": "macro modal call cancel: nothing to import",
    "69": "coordinate rotation off: nothing to import",
    "13.1": "polar coordinate interpolation off: nothing to import",
    "15": "polar coordinates off: nothing to import",
    "50.1": "programmable mirror image off: nothing to import",
    "69.1": "tilted working plane off: nothing to import",
    "80": "",
    "94": "",
    "96": "constant surface speed: not carried",
    "97": "constant surface speed cancel: not carried",
}
# LinuxCNC's comments that write somewhere (MSG is the next block's MESSAGE).
OUTPUT_COMMENTS: Final = {
    "DEBUG": "a message on LinuxCNC's screen",
    "PRINT": "a message on LinuxCNC's terminal",
    "LOG": "a line of LinuxCNC's log file",
    "LOGOPEN": "opens LinuxCNC's log file",
    "LOGAPPEND": "opens LinuxCNC's log file",
}
NOTED_M = {
    "48": "feed and speed overrides on: not carried",
    "49": "feed and speed overrides off: not carried",
    "60": "pallet shuttle and stop: not carried",
}
# (M98 beginning its line, and M99 in a subprogram, are the front end's: ngc.py.)
REFUSED_M = {"98": "a subprogram call not at the beginning of its line"}
AXES = ("X", "Y", "Z")
# LinuxCNC's polar coordinates in the XY plane: @ the distance from program zero, ^ the
# angle (degrees, counter-clockwise from +X).
POLAR: Final = ("@", "^")
MOVING: Final = (*AXES, *POLAR)
ALLOWED = set("XYZIJKRFSTMGNPQLHDO")
# Blocks `_Reader.plain` executes: these letters and (at most) one of these codes.
AXES_AND_FEED: Final = frozenset("NXYZF")
LINEAR: Final = frozenset({"0", "1"})
# The G words `fast_words` takes, as written, and their code.
MOTION_CODES: Final = {"80": "80"} | {f"{p}{c}": c for c in "0123" for p in ("", "0")}
NO_CODES: dict[str, Word] = {}


def widest_feeds(ranges: dict[Units, limits.FeedLimits]) -> tuple[int, int]:
    """The slowest and fastest feed (nm/min) a block of either unit takes: a file's units
    need not be the block's (an inch program's mm block at 2 mm/min is written F0.0787)."""
    return (
        min(feed_nm(f.low, u) for u, f in ranges.items()),
        max(feed_nm(f.high, u) for u, f in ranges.items()),
    )


# The control's FEEDR XY and FEEDR Z ranges in nm/min (app.cnc.limits), either unit's.
FEEDS_ACROSS: Final = widest_feeds(limits.FEED_XY)
FEEDS_DOWN: Final = widest_feeds(limits.FEED_Z)
# A feed this close to a range's end is within it: half the last place of a feed written to
# 0.0001 ipm, as a G-code writer (ours too) writes an mm block's 2 mm/min: F0.0787.
FEED_SLACK: Final = NM_PER_INCH // 20_000
# The work offsets' codes, systems 1-9 (G10 L2/L20 P1-P9).
SYSTEM_CODES: Final = ("54", "55", "56", "57", "58", "59", "59.1", "59.2", "59.3")
# The letters a word may have, either case, to the upper case (O: the careful reader).
LETTERS: Final = {c: c for c in ALLOWED - {"O"}} | {c.lower(): c for c in ALLOWED - {"O"}}
LETTER_HINT = {
    "A": "a rotary axis",
    "B": "a rotary axis",
    "C": "a rotary axis",
    "U": "a secondary axis",
    "V": "a secondary axis",
    "W": "a secondary axis",
}


# `USUAL`'s slots by word letter (N G X Y Z I J F), for `usual_words`.
_SLOTS: Final = {ord(letter): slot for slot, letter in enumerate("NGXYZIJF")}
_MOTION_TEXTS: Final = frozenset({"0", "1", "2", "3", "00", "01", "02", "03", "80"})
# This module compiled (app.cnc.native): `usual_words` before the pattern.
SCAN_FIRST: Final = not __file__.endswith(".py")
INCH: Final = Units.INCH  # (compiled: a constant, not a look-up on the class per line)


def usual_words(line: str) -> list[str | None] | None:
    """USUAL's groups for the tidiest of its lines, read a character at a time: words in
    USUAL's order, each once, one blank between them, no leading blank, numbers with at
    most a minus sign. None for any other line (USUAL then decides), so that where this
    gives groups they are USUAL's (tests/test_import_gcode.py holds them equal).

    Compiled (app.cnc.native) this is about three times as fast as the pattern; in Python
    it is slower, and the reader then does not use it (`SCAN_FIRST`).
    """
    n = len(line)
    found: list[str | None] = [None, None, None, None, None, None, None, None]
    pos = 0
    after = 0  # the slots before this one are behind us
    while pos < n:
        slot = _SLOTS.get(ord(line[pos]), -1)
        if slot < after:
            return None
        after = slot + 1
        start = pos + 1
        k = start
        if k < n and slot > 1 and ord(line[k]) == 45:  # "-" (N and G have no sign)
            k += 1
        digits = 0
        point = False
        while k < n:
            code = ord(line[k])
            if 48 <= code <= 57:
                digits += 1
            elif code == 46 and not point and slot > 1:  # "." (N and G have none)
                point = True
            else:
                break
            k += 1
        if digits == 0 or digits + point > MAX_DIGITS:
            return None
        text = line[start:k]
        if slot == 1 and text not in _MOTION_TEXTS:
            return None
        found[slot] = text
        if k < n:
            if ord(line[k]) != 32 or k + 1 == n:  # one blank, and a word after it
                return None
            k += 1
        pos = k
    return found


# Line as read → its USUAL groups (empty: not a USUAL line), `seen_words`' memory: a long
# file repeats its commonest lines (the retract heights, the plunges, `G80`) thousands of
# times, and a look-up here is a small part of matching the pattern again. Bounded (about a
# megabyte): emptied when full, the lines the file repeats come back at once (on the
# bench's file a memory of 4 096 lines finds 52.6 % of them, one of 65 536 52.7 %).
_SEEN: Final[dict[str, tuple[str | None, ...]]] = {}
_SEEN_MAX: Final = 1 << 12
_NOT_USUAL: Final[tuple[str | None, ...]] = ()


def seen_words(raw: str) -> tuple[str | None, ...]:
    """USUAL's groups of line `raw` (trailing blanks ignored), `_NOT_USUAL` for a line that
    is not one of its lines, remembered in `_SEEN` for the next time the line comes."""
    line = raw.rstrip()
    words: tuple[str | None, ...] = _NOT_USUAL
    if line:
        found = usual_words(line) if SCAN_FIRST else None
        if found is not None:
            words = tuple(found)
        else:
            usual = USUAL.fullmatch(line)
            if usual is not None:
                words = usual.groups()
    if len(_SEEN) >= _SEEN_MAX:
        _SEEN.clear()
    _SEEN[raw] = words
    return words


class Word:
    """A letter and its number as written, and the column the letter is in.

    Slotted and without a `Decimal` made up front: a file has a few words on each of its
    (up to millions of) lines, and most are lengths, read straight to nm (`text_nm`).
    """

    __slots__ = ("column", "letter", "text")

    def __init__(self, letter: str, text: str, column: int) -> None:
        self.letter = letter
        self.text = text
        self.column = column

    def __repr__(self) -> str:
        return f"Word({self.letter!r}, {self.text!r}, {self.column})"

    @property
    def value(self) -> Decimal:
        """The number, exactly as written."""
        return Decimal(self.text)

    @property
    def code(self) -> str:
        """A G or M code's number as written in the tables (`0`, `92.1`)."""
        code = _CODES.get(self.text)
        if code is None:
            value = self.value
            if value == value.to_integral_value():
                code = str(int(value))
            else:
                code = format(value.normalize(), "f")
            if len(_CODES) < 4096:  # G/M numbers: a file uses a handful
                _CODES[self.text] = code
        return code


_CODES: dict[str, str] = {}
_POWERS: Final = [10**k for k in range(32)]


def text_nm(text: str, nm_per_unit: int) -> int:
    """A number as written (NUMBER_TEXT: sign, digits, point) times `nm_per_unit`, rounded
    half-even to whole nm, computed on the digits as integers: exactly what
    `int((Decimal(text) * nm_per_unit).to_integral_value())` gives, without the Decimal."""
    return text_length(text, nm_per_unit)[0]


# nm per unit → number as written → (nm, decimal places): `text_length`'s memory.
_LENGTHS: Final[dict[int, dict[str, tuple[int, int]]]] = {}


def text_length(text: str, nm_per_unit: int) -> tuple[int, int]:
    """`text_nm` and the decimal places `text` is written with. Remembered: a file writes
    the same few heights, feeds and offsets over and over."""
    known = lengths_known(nm_per_unit)
    found = known.get(text)
    if found is None:
        if len(known) >= 1 << 16:
            known.clear()
        found = known[text] = (_text_nm(text, nm_per_unit), places(text))
    return found


def lengths_known(nm_per_unit: int) -> dict[str, tuple[int, int]]:
    """`text_length`'s memory for these units: a hot loop looks a number up in it first
    (`known.get(text) or text_length(text, per)`) and calls `text_length` only for a new
    one."""
    known = _LENGTHS.get(nm_per_unit)
    if known is None:
        known = _LENGTHS[nm_per_unit] = {}
    return known


def _text_nm(text: str, nm_per_unit: int) -> int:
    negative = text[0] == "-"
    body = text[1:] if text[0] in "+-" else text
    whole, _, fraction = body.partition(".")
    scaled = int(whole + fraction or "0") * nm_per_unit
    written = len(fraction)
    if written == 0:
        return -scaled if negative else scaled
    divisor = _POWERS[written] if written < len(_POWERS) else int(10**written)
    # The magnitude rounded, then the sign: "-0.5" is as far from 0 as "0.5".
    quotient = half_even(scaled, divisor)
    return -quotient if negative else quotient


def places(text: str) -> int:
    """How many decimal places a number is written with."""
    point = text.find(".")
    return 0 if point < 0 else len(text) - point - 1


def digit_text(text: str) -> str:
    """A number's digits, without sign and point (for `check_digits`)."""
    return text.lstrip("+-").replace(".", "")


def is_positive(text: str) -> bool:
    """`Decimal(text) > 0` for a number as written (NUMBER_TEXT)."""
    return text[0] != "-" and any(ch in "123456789" for ch in text)


@dataclass(init=False)
class Block:
    """A line's words: G and M codes in `gs` and `ms`, any other letter in `other`
    (`make_block` fills them). Its `__init__` written out: mypyc compiles it (the one
    dataclasses makes runs as Python, app.cnc.recognition.steps)."""

    line: int
    words: list[Word]
    comment: str = ""
    gs: list[Word] = field(default_factory=list)
    ms: list[Word] = field(default_factory=list)
    other: dict[str, Word] = field(default_factory=dict)

    def __init__(self, line: int, words: list[Word], comment: str = "") -> None:
        self.line = line
        self.words = words
        self.comment = comment
        self.gs = []
        self.ms = []
        self.other = {}

    def has(self, letter: str) -> bool:
        return letter in self.other

    def get(self, letter: str) -> Word | None:
        return self.other.get(letter)


# `lengths_known` of inches and of mm, for the hot loop (each dict lives as long as the
# process: `text_length` empties it in place when full, never replaces it).
_INCH_LENGTHS: Final = lengths_known(NM_PER_INCH)
_MM_LENGTHS: Final = lengths_known(NM_PER_MM)

# Lines a stream reads at a time when the segmenter asks for more.
STREAM_LINES: Final = 256


class GcodeStream(StreamSource):
    """The steps of G-code text as it is read, for a segmenter walking a StepWindow: read
    on (`more`) as far as it looks, the steps it has passed dropped, so that a file of any
    length holds only the lines and steps between them. A tool change waits (`settled`)
    until a cut or a G43 H says which tool it is. Raises FrontEnd where the file needs
    the front end (subroutines, parameters: the whole program, `parse_gcode`)."""

    def __init__(self, lines: Iterator[str], name: str) -> None:
        self.reader = _Reader("", name, False)  # (never the front end's: no text needed)
        super().__init__(self.reader.steps)
        self.reader.out = self
        self.lines = lines
        self.number = 0
        self.parsed: Parsed | None = None  # once read to the end
        self.outside = False  # a dropped step names a tool past the control's

    def so_far(self, notes: Notes) -> Parsed:
        return self.reader.so_far(notes)

    def renumbers(self) -> bool:
        reader = self.reader
        numbers = {reader.initial_tool, *reader.tools}
        for step in self.steps:
            if isinstance(step, ToolChange):
                numbers.add(step.tool)
            elif isinstance(step, Feed | Arc):
                numbers.add(step.comp_tool)
        return self.outside or any(not 0 <= n <= limits.MAX_TOOL for n in numbers)

    def settled(self) -> int:
        pending = self.reader.change_pending
        if pending is not None and self.parsed is None:
            return pending[2]
        return self.dropped + len(self.steps)

    def more(self) -> bool:
        if self.parsed is not None:
            return False
        number = self.reader.read_lines(self.lines, self.number, STREAM_LINES)
        if number > self.number + STREAM_LINES - 1:
            self.number = number
            return True
        self.number = number
        self.parsed = self.reader.finish()
        return True

    def drop(self, count: int) -> None:
        reader = self.reader
        top = limits.MAX_TOOL
        for step in self.steps[:count]:
            if isinstance(step, Rapid):
                reader.passed_motion = step
            elif isinstance(step, (Feed, Arc)):  # (a tuple: `Feed | Arc` is made each time)
                reader.passed_motion = step
                reader.passed_cut = True
                if not 0 <= step.comp_tool <= top:
                    self.outside = True
            elif isinstance(step, Cycle):
                reader.passed_cut = True
            elif isinstance(step, ToolChange) and not 0 <= step.tool <= top:
                self.outside = True
        super().drop(count)

    def read_all(self) -> Parsed:
        """The rest of the file, read (its steps kept)."""
        while self.more():
            pass
        assert self.parsed is not None
        return self.parsed


def parse_gcode(text: str, name: str = "") -> Parsed:
    """Read G-code text. Raises ImportFailure naming line and column of the first problem.

    A file is read straight until a line needs the front end (`FrontEnd`): then it is read
    again from the start as `ngc.expand` runs it. So a plain file pays nothing for the
    front end (not even a search for what it reads), and one that needs it is read once
    more up to that line."""
    try:
        return _Reader(text, name, False).run()
    except FrontEnd:
        return _Reader(text, name, True).run()


class FrontEnd(Exception):
    """A parameter, expression, O-word or M98 where the file was read straight."""


def _cancel_beside(first: Word, second: Word) -> bool:
    """Whether two motion codes in one block are G80 and one of G0-G3 (either order)."""
    pair = {first.code, second.code}
    return "80" in pair and len(pair) == 2 and (pair - {"80"}) <= {"0", "1", "2", "3"}


class _Reader:
    def __init__(self, text: str, name: str, expanding: bool) -> None:
        self.expanding = expanding  # the lines come from the front end (ngc.py)
        self.running: ngc.Line | None = None  # the front end's line being read
        self.text = text
        self.notes = Notes()
        self.steps: list[Step] = []
        # Where the steps go: the list, of which a stream drops those the segmenter has
        # passed (`passed_cut` and `passed_motion` keep what this reader asks of them).
        self.out = StepSource(self.steps)
        self.passed_cut = False  # a Feed, Arc or Cycle among the dropped steps
        self.passed_motion: Step | None = None  # the last Rapid, Feed or Arc among them
        self.name = ""
        self.part_number = ""
        self.fallback_name = name
        # modal state
        self.units: Units | None = None
        self.program_units: Units | None = None
        self.units_assumed = False
        self.motion: str | None = None
        self.cycle_drilled = False  # the last motion block drilled with a canned cycle
        self.series_z = 0  # the Z before the series of canned cycles began (G98 returns there)
        self.incremental = False
        self.arc_absolute = False
        self.plane = "17"
        self.comp = ""
        self.comp_tool = 0  # G41/G42's D (0: the tool in the spindle)
        self.arc_barred = False  # G40 has just ended compensation: the next move is a line
        # A `G0 X Y` right after a canned cycle, until the next move says what it meant:
        # the error if nothing does, and where it went (None: not yet moved).
        self.undecided: tuple[ImportFailure, tuple[int, int] | None] | None = None
        self.return_initial = True
        self.feed: int | None = None
        self.feed_at = (0, 0, "")  # line, column and number of the F word giving `feed`
        self.speed: int | None = None
        self.spindle: bool | None = None  # True clockwise, False counter-clockwise
        self.selected_tool: int | None = None
        self.tool = 0
        self.initial_tool = 0
        # (line, T, index of its ToolChange step) of an M6 that no cut has confirmed yet
        self.change_pending: tuple[int, int, int] | None = None
        self.moved = False
        self.moves_made = False  # a Rapid, Feed or Arc is among the steps
        self.x: int | None = None
        self.y: int | None = None
        self.z: int | None = None
        self.shift = [0, 0, 0]  # nm: part coordinates less the file's (G92 and `work`)
        # Work offsets, G54-G59.3 (systems 1-9; 0 unused): where each system's zero is on
        # the machine, per axis, as (anchor, nm): nm from where system `anchor`'s zero was on
        # the machine's offset table when the program began (which the file does not give),
        # or, anchor 0, from machine zero (a G10 L2 value). Two systems' zeros are a known
        # distance apart only where their anchors agree.
        self.systems: list[list[tuple[int, int]]] = [[(n, 0)] * 3 for n in range(10)]
        self.system = 1
        self.system_word = (0, 0)  # line and column of the G54-G59.3 or G10 in effect
        # Part zero: the zero of the system in effect at the first move, then (`frame`).
        self.frame: list[tuple[int, int]] | None = None
        self.frame_system = 1
        self.frame_line = 0
        self.work = [0, 0, 0]  # nm: the active system's zero from part zero (in `shift`)
        # A system whose zero is not a known distance from part zero: refused at its move.
        self.unplaced: ImportFailure | None = None
        self.placing = True  # `frame` not yet fixed, or `unplaced`: moves go by `target`
        self.cycle_r: int | None = None
        self.cycle_z: int | None = None
        self.cycle_q: int | None = None
        self.cycle_p: Decimal | None = None
        self.decimals = 0
        self.tools: dict[int, ToolData] = {}
        self.tool_names: dict[int, str] = {}
        self.active_length = 0  # nm: the tool length offset in effect (G43 H: the TCAL)
        self.start_z: int | None = None
        self.percent = 0
        self.ended_at: int | None = None

    # -- the file -------------------------------------------------------------------------

    def run(self) -> Parsed:
        if self.expanding:
            # Subroutines, control flow, parameters or expressions: the lines as they run,
            # the front end told after each whether the program has ended.
            runs = ngc.expand(split_lines(self.text), self.notes)
            run = next(runs, None)
            while run is not None:
                self.running = run
                try:
                    self.read(run.number, run.text, run.titles)
                except ImportFailure as exc:
                    if self.undecided is not None and exc is self.undecided[0]:
                        raise  # (located when it was made, on its own line)
                    raise run.moved(exc) from None
                try:
                    run = runs.send(self.percent >= 2 or self.ended_at is not None)
                except StopIteration:
                    break
        else:
            self.read_lines(text_lines(self.text), 0, -1)
        return self.finish()

    def made(self) -> int:
        """How many steps this reader has made (some perhaps dropped since)."""
        return self.out.dropped + len(self.steps)

    def finish(self) -> Parsed:
        """The file read to its end: what it says about the set-up, and the steps held."""
        if self.undecided is not None:
            raise self.undecided[0]
        if self.units_assumed:
            self.notes.assumed(None, "no G20/G21 before the first dimension: read in inches")
        if self.tool == 0 and self.made():
            self.notes.assumed(None, "the file names no tool: tool 1")
            self.initial_tool = 1
        return self.so_far(self.notes)

    def so_far(self, notes: Notes) -> Parsed:
        """What the file has said so far about the set-up (at its end: all it says), its
        report going to `notes`. Its units are those of the first G20/G21 (inches when
        none), its tolerance half a step of the finest number read."""
        units = self.program_units or Units.INCH
        places = max(self.decimals, 4 if units is Units.INCH else 3)
        tolerance = max(1, round(Decimal(units.nm) / (2 * 10**places)))
        initial_tool = self.initial_tool
        if self.tool == 0 and self.made():
            initial_tool = 1  # (as `finish` will say, unless a tool is named yet)
        return Parsed(
            format="gcode",
            units=units,
            steps=self.steps,
            notes=notes,
            tolerance=tolerance,
            name=self.name or self.fallback_name,
            part_number=self.part_number,
            offsets=self.table_zero(),
            tools=self.tools,
            initial_tool=initial_tool,
            start_z=self.start_z,
        )

    def located(self, exc: ImportFailure) -> ImportFailure:
        """`exc` at the file's line and column now, to be raised later (when another line
        is read): the front end's line maps them (`ngc.Line.moved`)."""
        return exc if self.running is None else self.running.moved(exc)

    def read_lines(self, lines: Iterator[str], number: int, count: int) -> int:
        """Read the next `count` lines of `lines` (all of them when `count` is negative),
        the first being line `number` + 1; returns the number of the last line read (fewer
        than `count` read: `lines` has ended).

        `read` of each line, with its commonest case — a line `fast_words` takes — written
        into the loop: a long file is nearly all such lines, and this loop runs for each
        of them."""
        seen = _SEEN
        stop = number + count if count >= 0 else -1
        for raw in lines:
            number += 1
            if self.percent < 2 and self.ended_at is None:
                words = seen.get(raw)
                if words is None:
                    words = seen_words(raw)
                if not (words and self.fast_words(number, words)):
                    self.read_other(number, raw, True)
            else:
                self.read(number, raw, True)
            if number == stop:
                break
        return number

    def read(self, number: int, raw: str, titles: bool) -> None:
        """Read and execute line `number` (`titles`: a comment alone on it may name the
        program)."""
        if self.percent >= 2 or self.ended_at is not None:
            if raw.strip() and raw.strip() != "%":
                where = "the closing %" if self.percent >= 2 else "the program end"
                self.notes.ignored(number, f"after {where}: not imported")
            return
        words = _SEEN.get(raw)
        if words is None:
            words = seen_words(raw)
        if not (words and self.fast_words(number, words)):
            self.read_other(number, raw, titles)

    def read_other(self, number: int, raw: str, titles: bool) -> None:
        """`read` of a line that `fast_words` does not take (before the program's end)."""
        line = raw.rstrip()
        if SIMPLE.fullmatch(line):
            # Only words (the usual line): one pass of PAIRS reads them all.
            pairs = PAIRS.findall(line)
            if self.fast_motion(number, pairs):
                return
            block = self.simple_line(number, pairs) or self.read_line(number, line, titles)
        else:
            block = self.read_line(number, line, titles)
        if block is not None:
            self.execute(block)

    def read_line(self, number: int, line: str, titles: bool = True) -> Block | None:
        """Split one line (without trailing blanks) into words and comments, one character
        at a time, saying what is wrong where. Returns None for a line with no words."""
        stripped = line.lstrip()
        if not stripped:
            return None
        pos = len(line) - len(stripped)
        if stripped.startswith("%"):
            self.percent += 1
            if self.percent > 1 and stripped[1:].strip() not in ("", ";"):
                # Only the opening % may carry a label (the ProtoTRAK dialect's `%:NAME;`);
                # a later one is the program's end, and text after it is not a program's
                # end anyone wrote (an MPCNC post's `% vfd enable`; rs274 refuses it).
                raise failure(
                    number,
                    pos + 1,
                    f"{stripped!r}: a % line starts or ends the program and holds nothing "
                    "else (LinuxCNC refuses this line too): put the text in a comment "
                    "( … ) or delete the line",
                )
            label = stripped[1:].strip().lstrip(":").rstrip(";").strip()
            if label and self.percent == 1:
                self.name = label
                self.notes.became(number, f"program label {label!r}: the program name")
            return None
        if stripped.startswith("/"):
            self.notes.assumed(number, ngc.BLOCK_DELETE)
            pos += 1
        words: list[Word] = []
        comments: list[str] = []
        n = len(line)
        while pos < n:
            ch = line[pos]
            if ch in " \t":
                pos += 1
            elif ch == "(":
                close = line.find(")", pos)
                if close < 0:
                    raise failure(number, pos + 1, "comment not closed: '(' without ')'")
                comments.append(line[pos + 1 : close].strip())
                pos = close + 1
            elif ch == ";":
                rest = line[pos + 1 :].strip()
                if rest:
                    comments.append(rest)
                    self.notes.assumed(number, f"text after ';' read as a comment: {rest!r}")
                break
            elif (ch.isascii() and ch.isalpha()) or ch in "@^":
                pos = self.word(number, line, pos, words)
            elif ch in "#[" and not self.expanding:
                raise FrontEnd
            else:
                raise failure(number, pos + 1, f"unexpected character {ch!r}")
        for comment in comments:
            head = comment.split(",", 1)[0].upper() if "," in comment else ""
            if comment.upper().startswith("MSG,"):
                self.steps.append(Message(number, comment[4:].strip()))
            elif comment.startswith("SET-UP: "):
                self.setup_comment(number, comment)
            elif head in OUTPUT_COMMENTS:
                self.notes.ignored(number, f"({head}, …): {OUTPUT_COMMENTS[head]}; not carried")
        if not words:
            if titles and comments and not self.name and not self.moved and not self.made():
                self.title(number, comments[0])
            return None
        return self.make_block(number, words, " ".join(comments))

    def fast_motion(self, number: int, pairs: list[tuple[str, str, str]]) -> bool:
        """A line of X/Y/Z/F/N words and perhaps G0 or G1 (PAIRS of a SIMPLE line), in
        absolute coordinates from a known point: the state changes and the step that
        `execute` makes of it, without Word and Block objects. Nothing is changed and False
        returned for any other line, or where `execute` would report or refuse something
        (it then reads the line and says so)."""
        x = y = z = f = g = n = None
        for _space, letter, text in pairs:
            if letter == "X" and x is None:
                x = text
            elif letter == "Y" and y is None:
                y = text
            elif letter == "Z" and z is None:
                z = text
            elif letter == "F" and f is None:
                f = text
            elif letter == "G" and g is None:
                g = text
            elif letter == "N" and n is None:
                n = text
            else:
                return False
        for word in (n, x, y, z, f):
            if word is not None and len(word) > MAX_DIGITS:
                return False  # (USUAL's numbers are no longer than this)
        return self.fast_words(number, (n, g, x, y, z, None, None, f))

    def fast_words(self, number: int, words: tuple[str | None, ...]) -> bool:
        """`fast_motion` of USUAL's groups (the numbers as written of N, G, X, Y, Z, I, J
        and F; None: not on the line)."""
        _n, g, x, y, z, i, j, f = words  # (N is the block's number: nothing to do)
        units = self.units
        if (
            units is None
            or self.incremental
            or self.arc_barred
            or self.undecided is not None
            or self.placing
        ):
            return False
        motion = self.motion if g is None else MOTION_CODES.get(g)
        if motion is None or (motion == "0" and self.comp):
            return False
        if motion == "80":
            # G80 alone: the cycle ends (set_motion); with any other word, `execute`.
            if g is None or not (x is y is z is i is j is f is None):
                return False
            self.motion = "80"
            self.cycle_drilled = False
            return True
        if units is INCH:
            per, known = NM_PER_INCH, _INCH_LENGTHS
        else:
            per, known = NM_PER_MM, _MM_LENGTHS
        feed = self.feed
        if f is not None:
            feed = (known.get(f) or text_length(f, per))[0]
            if feed <= 0 and not is_positive(f):  # (more than 0 nm: more than 0)
                return False
        if feed is not None:
            low, high = FEEDS_ACROSS
            if not low - FEED_SLACK <= feed <= high + FEED_SLACK:
                return False  # (`need_feed` reports it, at the F word's column)
        # Where the axis words go, for a line, an arc or a hole alike, as `target` has it
        # (an axis without a word stays where it is), and the decimal places the file is
        # then written to; a word out of `length`'s range is `execute`'s to refuse. Written
        # out axis by axis, here once (not a loop over the three, nor a function returning
        # a tuple): this runs for nearly every line of a long file. Without a G92 shift the
        # remembered nm object itself is kept (one int for every repeat of a number).
        decimals = self.decimals
        shift = self.shift
        nx, ny, nz = self.x, self.y, self.z
        if x is not None:
            nm, written = known.get(x) or text_length(x, per)
            if not -MAX_ABS_NM <= nm <= MAX_ABS_NM:
                return False
            nx = nm + shift[0] if shift[0] else nm
            if written > decimals:
                decimals = written
        if y is not None:
            nm, written = known.get(y) or text_length(y, per)
            if not -MAX_ABS_NM <= nm <= MAX_ABS_NM:
                return False
            ny = nm + shift[1] if shift[1] else nm
            if written > decimals:
                decimals = written
        if z is not None:
            nm, written = known.get(z) or text_length(z, per)
            if not -MAX_ABS_NM <= nm <= MAX_ABS_NM:
                return False
            nz = nm + shift[2] if shift[2] else nm
            if written > decimals:
                decimals = written
        if i is not None or j is not None:
            # (I/J with no axis word moves nothing: `execute` then only sets the modes.)
            if (motion != "2" and motion != "3") or x is y is z is None:
                return False
            return self.fast_arc(number, nx, ny, nz, decimals, i, j, motion, feed, per, known)
        if motion in CYCLES and g is None and z is None and (x is not None or y is not None):
            return self.fast_hole(number, nx, ny, decimals, feed)
        if (motion != "0" and motion != "1") or (g is not None and self.cycle_drilled):
            return False
        if x is None and y is None and z is None:
            self.feed, self.motion = feed, motion
            return True
        if motion == "1" and feed is None:
            return False
        if nx is None or ny is None:
            return False
        self.decimals = decimals
        self.feed, self.motion = feed, motion
        if motion == "0":
            if not self.moves_made and x is None and y is None:
                self.start_z = nz
            self.steps.append(Rapid(number, nx, ny, nz, units))
        else:
            assert feed is not None
            self.change_pending = None
            self.steps.append(Feed(number, nx, ny, nz, feed, units, self.comp, self.comp_tool))
        self.moves_made = self.moved = True
        self.x, self.y, self.z = nx, ny, nz
        self.cycle_drilled = False
        return True

    def fast_arc(
        self,
        number: int,
        nx: int | None,
        ny: int | None,
        nz: int | None,
        decimals: int,
        i: str | None,
        j: str | None,
        motion: str,
        feed: int | None,
        per: int,
        known: dict[str, tuple[int, int]],
    ) -> bool:
        """`fast_words` for an arc by its centre (I, J; G90.1 or G91.1) in the XY plane at
        one depth from a known point (to `nx`, `ny`, `nz`, the file then written to
        `decimals` places; `known`: `lengths_known(per)`): what `execute` and `arc` make of
        it when they have nothing to report or refuse (`check_arc`'s tests included)."""
        sx, sy = self.x, self.y
        if feed is None or self.plane != "17" or sx is None or sy is None:
            return False
        if nx is None or ny is None or (nz is not None and self.z is not None and nz != self.z):
            return False
        ci = cj = 0
        if i is not None:
            ci, written = known.get(i) or text_length(i, per)
            if not -MAX_ABS_NM <= ci <= MAX_ABS_NM:
                return False
            if written > decimals:
                decimals = written
        if j is not None:
            cj, written = known.get(j) or text_length(j, per)
            if not -MAX_ABS_NM <= cj <= MAX_ABS_NM:
                return False
            if written > decimals:
                decimals = written
        if self.arc_absolute:
            cx, cy = ci + self.shift[0], cj + self.shift[1]
        else:
            cx, cy = sx + ci, sy + cj
        units = self.units
        assert units is not None
        r1 = math.dist((sx, sy), (cx, cy))
        if r1 == 0 or arc_end_off(r1, math.dist((nx, ny), (cx, cy)), units):
            return False
        self.decimals = decimals
        self.feed, self.motion = feed, motion
        self.change_pending = None
        clockwise = motion == "2"
        self.steps.append(
            Arc(number, nx, ny, nz, cx, cy, clockwise, feed, units, self.comp, self.comp_tool)
        )
        self.moves_made = self.moved = True
        self.x, self.y, self.z = nx, ny, nz
        self.cycle_drilled = False
        return True

    def cycle_clear(self, start_z: int, r: int) -> int:
        """Where a canned cycle's hole retracts to: R (G99), or (G98) the height the tool
        was at before this series of cycles began — not the R a G99 hole before it in the
        series left it at — or R where that is higher (RS274/NGC, as rs274 reads it)."""
        if not self.cycle_drilled:
            self.series_z = start_z  # the first hole of a series
        return max(self.series_z, r) if self.return_initial else r

    def fast_hole(
        self, number: int, nx: int | None, ny: int | None, decimals: int, feed: int | None
    ) -> bool:
        """`fast_motion` for the next hole of the canned cycle in effect (X/Y, perhaps F,
        absolute; at `nx`, `ny`, the file then written to `decimals` places): what `cycle`
        makes of it when it has nothing to report or refuse."""
        code = self.motion
        r, bottom, start_z = self.cycle_r, self.cycle_z, self.z
        if r is None or bottom is None or start_z is None or feed is None or bottom >= r:
            return False
        if self.comp:
            return False
        pecking = code == "73" or code == "83"
        if (pecking and not self.cycle_q) or self.out.dropped + len(self.steps) >= MAX_STEPS:
            return False  # (the second: `made() + 1 > MAX_STEPS`, written out for speed)
        if nx is None or ny is None:
            return False
        self.decimals = decimals
        assert code is not None and self.units is not None
        self.feed = feed
        self.change_pending = None
        clear = self.cycle_clear(start_z, r)
        peck = (self.cycle_q or 0) if pecking else 0
        self.steps.append(
            Cycle(number, int(code), nx, ny, r, bottom, clear, feed, peck, self.cycle_p, self.units)
        )
        self.x, self.y, self.z = nx, ny, clear
        self.moved = self.cycle_drilled = True
        return True

    def simple_line(self, number: int, pairs: list[tuple[str, str, str]]) -> Block | None:
        """The block of a SIMPLE line's PAIRS; None when a word needs the careful reader
        (a letter it refuses, too many digits) to say what is wrong."""
        words: list[Word] = []
        column = 1
        for space, letter, text in pairs:
            column += len(space)
            letter = LETTERS.get(letter, "")
            if not letter or (len(text) > MAX_DIGITS and not check_digits(digit_text(text))):
                return None
            words.append(Word(letter, text, column))
            column += 1 + len(text)
        return self.make_block(number, words, "")

    def make_block(self, number: int, words: list[Word], comment: str) -> Block:
        """The block of `words`: G and M codes apart, other letters once each."""
        block = Block(number, words, comment)
        for word in words:
            if word.letter == "G":
                block.gs.append(word)
            elif word.letter == "M":
                block.ms.append(word)
            elif word.letter in block.other:
                first = block.other[word.letter]
                raise failure(
                    number,
                    word.column,
                    f"{word.letter} given twice in one block ({first.letter}{first.text} and "
                    f"{word.letter}{word.text})",
                )
            else:
                block.other[word.letter] = word
        return block

    def word(self, number: int, line: str, pos: int, words: list[Word]) -> int:
        """Read the word at `pos` into `words`; returns where the next one may start."""
        ch = line[pos]
        letter = ch.upper()
        if letter in LETTER_HINT:
            raise failure(
                number, pos + 1, f"{letter}: {LETTER_HINT[letter]}; MillBlocks has X, Y, Z"
            )
        match = NUMBER.match(line, pos + 1)
        if letter == "O":
            if not self.expanding:
                raise FrontEnd
            # (An O-word beginning its line is the front end's.)
            raise failure(number, pos + 1, "an O-word (O number or subroutine) must begin its line")
        if letter not in ALLOWED and letter not in POLAR:
            raise failure(number, pos + 1, f"'{ch}' is not a G-code word letter")
        end = match.end() if match is not None else pos + 1
        text = match.group() if match is not None else ""
        if end < len(line) and line[end] in " \t":
            # Blanks inside a word mean nothing, as to LinuxCNC (`G3 I -20`, `X 1. 5`):
            # the word goes on past them while digits (or a first sign) follow.
            text, end = spaced_number(line, pos + 1)
            match = NUMBER.fullmatch(text)
        if match is None:
            after = line[pos + 1 : pos + 4]
            rest = line[pos + 1 :].lstrip(" \t").lower()
            if not self.expanding and (
                rest[:1] in ("#", "[") or any(rest.startswith(f + "[") for f in ngc.FUNCTIONS)
            ):
                raise FrontEnd
            hint = " (the letter O where a zero belongs?)" if after[:1].upper() == "O" else ""
            raise failure(number, pos + 1, f"{letter} needs a number; found {after!r}{hint}")
        if not check_digits(digit_text(text)):
            raise failure(number, pos + 2, f"{letter}{text}: too many digits")
        words.append(Word(letter, text, pos + 1))
        return end

    def title(self, number: int, comment: str) -> None:
        match = HEADER.match(comment)
        if match:
            self.name = match.group(1).strip()
            if match.group(2) != "-":
                self.part_number = match.group(2)
            self.notes.became(number, "the MillBlocks header comment: program name and part number")
        else:
            self.name = comment
            self.notes.became(number, f"comment {comment!r}: the program name")

    # -- numbers --------------------------------------------------------------------------

    def length(self, word: Word, block: Block) -> int:
        """A dimension word in nm (in the current units)."""
        units = self.units or self.current_units()
        nm, written = text_length(word.text, NM_PER_INCH if units is Units.INCH else NM_PER_MM)
        self.decimals = max(self.decimals, written)
        if not -MAX_ABS_NM <= nm <= MAX_ABS_NM:
            raise failure(block.line, word.column, f"{word.letter}{word.text} is out of range")
        return nm

    def current_units(self) -> Units:
        if self.units is None:
            self.units = Units.INCH
            self.program_units = self.program_units or Units.INCH
            self.units_assumed = True
        return self.units

    def integer(self, word: Word, block: Block, low: int, high: int) -> int:
        text = word.text
        if text.isdigit() and text.isascii() and low <= int(text) <= high:
            return int(text)  # the usual word (T2, H1, S1200): no Decimal needed
        value = word.value
        if value != value.to_integral_value() or not low <= value <= high:
            raise failure(
                block.line,
                word.column,
                f"{word.letter}{word.text}: a whole number from {low} to {high} is needed",
            )
        return int(value)

    def rpm(self, word: Word, block: Block) -> int:
        """An S word in whole rpm, the control's resolution: a fraction (a CAM's S4696.94)
        is rounded, as LinuxCNC's spindle takes it, with a note at its line. Raises
        ImportFailure for a speed outside 0-100000 rpm."""
        text = word.text
        if not (text.isdigit() and text.isascii()) and word.value.to_integral_value() != word.value:
            rounded = word.value.to_integral_value()  # (half even, as Decimal rounds)
            if 0 <= rounded <= 100_000:
                self.notes.rounded(
                    block.line, f"S{text} → S{rounded}: the control's spindle speed is whole rpm"
                )
                return int(rounded)
        return self.integer(word, block, 0, 100_000)

    # -- a block ----------------------------------------------------------------------------

    def execute(self, block: Block) -> None:
        # Every step below is guarded by the words it needs, so the usual line (a few axis
        # words, perhaps a motion code and F) goes through only the checks that concern it.
        codes = self.g_codes(block) if block.gs else NO_CODES
        m_codes = [(m, m.code) for m in block.ms]
        line = block.line
        other = block.other
        for word, code in m_codes:
            if code == "98" and not self.expanding:
                raise FrontEnd
            if code in REFUSED_M:
                raise failure(line, word.column, f"M{code}: {REFUSED_M[code]} is not supported")
        if other.keys() <= AXES_AND_FEED and not m_codes and codes.keys() <= LINEAR:
            self.plain(block, codes)
            return
        f = block.get("F")
        if f is not None and "4" not in codes:
            if not is_positive(f.text):
                raise failure(line, f.column, f"F{f.text}: a feed must be more than 0")
            self.feed = self.rate(f)
            self.feed_at = (line, f.column, f.text)
        s = block.get("S")
        if s is not None:
            self.speed = self.rpm(s, block)
            if self.spindle is not None and not any(c in ("3", "4", "5") for _, c in m_codes):
                self.steps.append(SpindleOn(line, self.speed, self.spindle))
        t = block.get("T")
        if t is not None:
            self.selected_tool = self.integer(t, block, 0, 999)
        if any(c == "6" for _, c in m_codes):
            if self.selected_tool is None:
                self.notes.assumed(line, "M6 with no T selected: the same tool stays")
            elif self.selected_tool == 0:
                # LinuxCNC's and Haas's way to take the tool out (at the end, or before a
                # manual change): no tool of the control's 1-24.
                self.notes.ignored(
                    line,
                    "T0 M6 empties the spindle: no tool change in MillBlocks (its tools are "
                    "1 to 24); the tool before stays in the program",
                )
            else:
                if self.tool == 0 and not self.moves_made:
                    # The first tool called before any move (a post's start): the tool in
                    # the spindle when the program starts, no change.
                    self.initial_tool = self.tool = self.selected_tool
                    self.notes.became(
                        line, f"T{self.tool} M6 before any move: tool {self.tool} starts"
                    )
                else:
                    if self.tool == 0:
                        # Moves before the first change, with no tool named (a BOSS tape has
                        # no length offsets to name it): the tape reader's reading, tool 1.
                        self.initial_tool = 1
                        self.notes.assumed(
                            None, "the file does not say which tool it starts with: tool 1"
                        )
                    self.steps.append(ToolChange(line, self.selected_tool))
                    self.change_pending = (line, self.selected_tool, self.made() - 1)
                    self.tool = self.selected_tool
        for _, code in m_codes:
            if code in ("3", "4"):
                self.spindle = code == "3"
                self.steps.append(SpindleOn(line, self.speed, self.spindle))
            elif code == "5":
                self.spindle = None
                self.steps.append(SpindleOff(line))
            elif code in ("7", "8", "9"):
                mode = {"7": "mist", "8": "flood", "9": "off"}[code]
                self.steps.append(Coolant(line, mode))
            elif code in NOTED_M:
                self.notes.ignored(line, f"M{code}: {NOTED_M[code]}")
            elif code not in ("0", "1", "2", "30", "6", "99"):
                self.notes.ignored(line, f"M{code}: not a code MillBlocks knows; not imported")
        uses_axes = False  # a code on the line takes the axis words: no move
        if "4" in codes:
            self.dwell(block, codes["4"])
            uses_axes = block.has("X") and not block.has("P")  # Fanuc G04 X is the time
        self.modes(block, codes)
        if "10" in codes:
            self.g10(block)
            uses_axes = True
        for code in ("28", "30"):
            if code in codes:
                self.home(block, code)
                uses_axes = True
        if "92" in codes:
            self.g92(block)
            uses_axes = True
        for code in ("92.1", "92.2"):
            if code in codes:
                self.shift = list(self.work)
                self.notes.assumed(line, f"G{code}: the G92 shift is cancelled")
        if "92.3" in codes:
            self.notes.ignored(line, "G92.3: restoring a stored G92 shift is not supported")
        motion_word = next((codes[c] for c in codes if GROUP_OF.get(c) == "motion"), None)
        if motion_word is not None:
            self.set_motion(block, motion_word, uses_axes)
        if "53" in codes:
            self.machine_move(block, codes["53"])
            uses_axes = True
        polar = block.get("@") or block.get("^")
        if polar is not None and uses_axes:
            raise failure(
                line, polar.column, "polar coordinates (@ ^) with G4, G10, G28, G30, G53 or G92"
            )
        if any(block.has(a) for a in MOVING) and not uses_axes:
            self.move(block)
        self.unused(block, codes)
        for _, code in m_codes:
            if code in ("0", "1"):
                self.steps.append(Stop(line, code == "1", block.comment))
            elif code in ("2", "30"):
                self.steps.append(End(line))
                self.ended_at = line
                self.notes.became(line, f"M{code}: the end of the program")
            elif code == "99":
                self.steps.append(End(line))
                self.ended_at = line
                self.notes.assumed(
                    line,
                    "M99 in the main program: its end, as LinuxCNC's preview reads it (a "
                    "control starts the program again)",
                )

    def plain(self, block: Block, codes: dict[str, Word]) -> None:
        """`execute` for a block of axis words, F and N, with G0 or G1 or no G code: what
        `execute` would do for it (no spindle, tool, mode or M step applies), in order."""
        f = block.other.get("F")
        if f is not None:
            if not is_positive(f.text):
                raise failure(block.line, f.column, f"F{f.text}: a feed must be more than 0")
            self.feed = self.rate(f)
            self.feed_at = (block.line, f.column, f.text)
        if codes:
            motion_word = codes.get("0") or codes["1"]
            self.set_motion(block, motion_word, False)
        other = block.other
        if "X" in other or "Y" in other or "Z" in other:
            self.move(block)

    def modes(self, block: Block, codes: dict[str, Word]) -> None:
        """Plane, units, compensation, tool length, coordinate system, distance, return."""
        line = block.line
        for code in ("17", "18", "19"):
            if code in codes:
                self.plane = code
                if code != "17":
                    self.notes.ignored(
                        line,
                        f"G{code} selects the {'XZ' if code == '18' else 'YZ'} plane; "
                        "MillBlocks cuts arcs in XY only (an arc while it is on is refused)",
                    )
        for code in ("20", "21", "70", "71"):
            if code in codes:
                self.units = Units.INCH if code in ("20", "70") else Units.MM
                if self.program_units is None:
                    self.program_units = self.units
                    u = self.units
                    older = ""
                    if code in ("70", "71"):
                        older = f" (G{code} as the BOSS and older controls mean it: G2{code[1]})"
                    self.notes.became(
                        line,
                        f"G{code}: the program and every block are {u.value} (numbers finer "
                        f"than {u.resolution} {u.symbol} are rounded, each reported){older}",
                    )
                elif self.units is not self.program_units:
                    self.notes.assumed(
                        line,
                        f"units change to {self.units.value}: the blocks from here are "
                        f"{self.units.value} blocks",
                    )
        if "40" in codes:
            # As rs274: the move that ends compensation goes straight from the compensated
            # point (an arc there is refused).
            last = next(
                (s for s in reversed(self.steps) if isinstance(s, Rapid | Feed | Arc)),
                self.passed_motion,
            )
            self.arc_barred = isinstance(last, Feed | Arc) and last.comp != ""
            self.comp, self.comp_tool = "", 0
        for code, side in (("41", "left"), ("42", "right")):
            if code in codes:
                self.compensation(block, codes[code], side)
        for code in ("43", "45"):
            if code in codes:
                self.length_offset(block, code)
                self.apply_length(block.get("H"), block)
        if "49" in codes:
            self.apply_length(None, block)
        for n, code in enumerate(SYSTEM_CODES, 1):
            word = codes.get(code)
            if word is not None:
                self.select_system(line, word, n)
        if "90" in codes:
            self.incremental = False
        if "91" in codes:
            self.incremental = True
        if "90.1" in codes:
            self.arc_absolute = True
        if "91.1" in codes:
            self.arc_absolute = False
        if "98" in codes:
            self.return_initial = True
        if "99" in codes:
            self.return_initial = False
        for code in codes:
            if NOTED_G.get(code):
                self.notes.ignored(line, f"G{code}: {NOTED_G[code]}")

    def compensation(self, block: Block, word: Word, side: str) -> None:
        """G41/G42 [D]: cutter compensation to that side with D's diameter (the tool in the
        spindle without D; D0 has no radius, so nothing is offset, as rs274 reads it)."""
        if self.comp:
            raise failure(
                block.line,
                word.column,
                f"G{word.code} while cutter compensation is on: G40 must end it first (as "
                "rs274 reads it)",
            )
        d = block.get("D")
        number = 0 if d is None else self.integer(d, block, 0, 999)
        if d is not None and number == 0:
            self.notes.assumed(
                block.line, f"G{word.code} D0: a radius of 0, so the path is the tool centre"
            )
            return
        self.comp, self.comp_tool = side, number

    def set_motion(self, block: Block, word: Word, uses_axes: bool) -> None:
        new = word.code
        if (
            self.cycle_drilled
            and new in ("0", "1")
            and not uses_axes
            and not block.has("Z")
            and (block.has("X") or block.has("Y"))
        ):
            # Decided by what comes next: a canned cycle at that very point means the line
            # only moved there (FreeCAD's post writes `G0 X Y` before each cycle line; a
            # hole there would be drilled twice); anything else leaves it undecided.
            self.undecided = (
                self.located(
                    failure(
                        block.line,
                        word.column,
                        f"G{new} right after a canned cycle moves to X/Y with no Z: in RS274 it "
                        "ends the cycle, so no hole is drilled here; a ProtoTRAK post that writes "
                        "its G code on every line (seed 003 §2.1, §2.2.6.2) means a hole. Which is "
                        "meant cannot be told: remove the G code to drill here, or put G80 before "
                        "the line to only move",
                    )
                ),
                None,
            )
        self.motion = new
        if new not in CYCLES:
            self.cycle_drilled = False

    def g_codes(self, block: Block) -> dict[str, Word]:
        codes: dict[str, Word] = {}
        groups: dict[str, Word] = {}
        for word in block.gs:
            code = word.code
            if REFUSED_G.get(code):
                raise failure(
                    block.line, word.column, f"G{code}: {REFUSED_G[code]} is not supported"
                )
            group = GROUP_OF.get(code)
            if group is None and code not in NOTED_G:
                self.notes.ignored(
                    block.line, f"G{code}: not a code MillBlocks knows; not imported"
                )
                continue
            if group is not None and group != "non-modal":
                if group in groups and group == "motion" and _cancel_beside(groups[group], word):
                    # G80 beside G0-G3, as a post's safety line writes it (G0 G17 G40 G80 G90
                    # G94 G98): rs274 cancels the cycle and keeps the other motion code.
                    if code != "80":
                        codes.pop(groups[group].code, None)
                        groups[group] = word
                        codes[code] = word
                    continue
                if group in groups:
                    other = groups[group]
                    raise failure(
                        block.line,
                        word.column,
                        f"G{other.code} and G{code} in one block are both {group} codes",
                    )
                groups[group] = word
            codes[code] = word
        return codes

    def unused(self, block: Block, codes: dict[str, Word]) -> None:
        used = {"N", "F", "S", "T", "X", "Y", "Z", "@", "^"}
        if self.motion in ("2", "3") or self.motion in CYCLES:
            used |= {"I", "J", "R", "Q", "P", "L"}
        if "4" in codes:
            used |= {"P", "X"}
        if "10" in codes:
            used |= {"L", "P", "R"}
        if "43" in codes or "45" in codes:
            used.add("H")
        if "41" in codes or "42" in codes:
            used.add("D")
        for letter, word in block.other.items():
            if letter in "IJK" and letter not in used and self.motion in ("0", "1"):
                # An arc's centre on a straight move: an arc written as G0/G1, cut straight
                # (rs274 refuses it too).
                what = "a rapid" if self.motion == "0" else "a straight feed"
                raise failure(
                    block.line,
                    word.column,
                    f"{letter} with G{self.motion}: {what} has no arc centre (LinuxCNC refuses "
                    "it too); is G2 or G3 meant?",
                )
            if letter not in used:
                self.notes.ignored(block.line, f"{letter}{word.text}: no code on the line uses it")

    # -- tools and set-up -------------------------------------------------------------------

    def length_offset(self, block: Block, code: str) -> None:
        h = block.get("H")
        line = block.line
        if h is None:
            self.notes.assumed(line, f"G{code} without H: the tool in the spindle")
            return
        number = self.integer(h, block, 0, 999)
        if code == "45":
            self.notes.assumed(
                line,
                f"G45 H{number} (Fanuc: tool offset increase) read as in seed 003 §2.2.6.1: "
                f"tool {number}'s length offset, then the move to the axes given",
            )
        if self.change_pending is not None:
            change_line, selected, index = self.change_pending
            self.change_pending = None
            if selected != number:
                self.notes.assumed(
                    line,
                    f"M6 (line {change_line}) with T{selected} selected, then H{number}: "
                    f"read as tool {number} (a length offset belongs to its tool)",
                )
                self.steps[index - self.out.dropped] = ToolChange(change_line, number)
                self.tool = number
        elif self.tool == 0:
            self.initial_tool = number
            self.tool = number
            self.notes.became(
                line, f"H{number} before any tool change: tool {number} is in the spindle"
            )
        elif number != self.tool:
            self.notes.assumed(
                line,
                f"H{number} with tool {self.tool} in the spindle and no tool change: read "
                f"as tool {number}",
            )
            self.tool = number
            self.steps.append(ToolChange(line, number))

    def apply_length(self, h: Word | None, block: Block) -> None:
        """G43 H / G49: the head stays where it is, so Z reads differently by the change in
        length offset (a known TCAL from G10 L1 or the set-up comments; 0 otherwise)."""
        number = 0 if h is None else self.integer(h, block, 0, 999)
        data = self.tools.get(number)
        length = 0 if data is None or data.tcal is None else data.tcal
        if self.z is not None:
            self.z += self.active_length - length
        self.active_length = length

    def g10(self, block: Block) -> None:
        line = block.line
        lword, pword = block.get("L"), block.get("P")
        kind = None if lword is None else self.integer(lword, block, 0, 99)
        p = None if pword is None else self.integer(pword, block, 0, 999)
        if kind in (2, 20) and p is not None and p <= 9:
            assert lword is not None
            self.set_system(block, lword, kind, p)
        elif kind == 1 and p is not None:
            z, r = block.get("Z"), block.get("R")
            tcal = None if z is None else self.length(z, block)
            diameter = None if r is None else 2 * abs(self.length(r, block))
            self.tools[p] = ToolData(diameter=diameter or None, tcal=tcal)
            self.notes.became(
                line, f"G10 L1 P{p}: tool {p}'s diameter and length (Data Block 0 DIA, TCAL)"
            )
        else:
            self.notes.ignored(line, "G10 with this L/P: not imported")

    # -- work offsets ---------------------------------------------------------------------------

    def select_system(self, line: int, word: Word, n: int) -> None:
        """G54-G59.3: the points from here are in system `n`, moved into part coordinates
        by where its zero is from part zero (`place_work`)."""
        self.system = n
        self.system_word = (line, word.column)
        self.place_work(line, word.column)
        offsets = self.systems[n]
        if (
            offsets[0][0] != 0
            and offsets[1][0] != 0
            and n != 1
            and self.unplaced is None
            and (self.frame is None or self.frame_system == n)
        ):
            self.notes.assumed(
                line,
                f"G{SYSTEM_CODES[n - 1]}: coordinates read as part coordinates (its "
                "offsets are not in the file)",
            )

    def set_system(self, block: Block, lword: Word, kind: int, p: int) -> None:
        """G10 L2 (where system P's zero is on the machine) and G10 L20 (where it is such
        that the tool is now at the given point in it); P0: the system in effect."""
        line = block.line
        n = self.system if p == 0 else p
        r = block.get("R")
        if r is not None and Decimal(r.text) != 0:
            raise failure(
                line, r.column, f"G10 L{kind} R: a rotated coordinate system is not supported"
            )
        offsets = self.systems[n]
        if kind == 20 and self.frame is None:
            # The tool's position is known before any move only as a G92 gave it, in the
            # system in effect: that system holds part zero.
            self.fix_frame(line)
        for k, axis in enumerate(AXES):
            word = block.get(axis)
            if word is None:
                continue  # (that axis's zero stays where it was)
            value = self.length(word, block)
            if kind == 2:
                offsets[k] = (0, value)
                continue
            current = getattr(self, axis.lower())
            frame = self.frame
            if current is None or frame is None:
                raise failure(
                    line, word.column, f"G10 L20 {axis}: the tool's position is not known"
                )
            # The tool is at part zero + `current` on the machine; a G92 shift stays on top
            # of the new zero, as rs274 keeps it.
            g92 = self.shift[k] - self.work[k]
            offsets[k] = (frame[k][0], frame[k][1] + current - g92 - value)
        code = SYSTEM_CODES[n - 1]
        if kind == 2 and n == 1 and (self.frame is None or self.frame_system == 1):
            self.notes.became(line, "G10 L2 P1: part zero on the table (Data Block 0 X, Y)")
        else:
            self.notes.became(line, f"G10 L{kind} P{p}: where G{code}'s zero is")
        if n == self.system:
            self.system_word = (line, lword.column)
        self.place_work(line, lword.column)

    def fix_frame(self, line: int) -> None:
        """Part zero: the zero of the system in effect (at the first move)."""
        self.frame = list(self.systems[self.system])
        self.frame_system = self.system
        self.frame_line = line
        if self.system != 1 and (self.frame[0][0] == 0 or self.frame[1][0] == 0):
            self.notes.became(
                line,
                f"G{SYSTEM_CODES[self.system - 1]} holds part zero: its zero on the table, "
                "as the file's G10 gives it, is Data Block 0 X, Y",
            )
        self.placing = self.unplaced is not None

    def place(self, line: int) -> None:
        """Before a move read by `execute` while `placing`: part zero fixed at the first
        move, or the refusal of a system not placed on it."""
        if self.unplaced is not None:
            raise self.unplaced
        if self.frame is None:
            self.fix_frame(line)

    def place_work(self, line: int, column: int) -> None:
        """The active system's zero from part zero into `shift` (the G92 shift kept), or,
        where the file does not give it, a refusal for the next move (`unplaced`): one part
        zero cannot hold two fixtures whose zeros are only on the machine's offset table."""
        frame = self.frame
        if frame is None:
            return  # (the first move's system holds part zero)
        offsets = self.systems[self.system]
        work = [0, 0, 0]
        for k in range(3):
            anchor, nm = offsets[k]
            if anchor == frame[k][0]:
                work[k] = nm - frame[k][1]
            elif k == 2:
                # Z is measured from each tool's zero (G43), which the fixtures share as
                # far as the file says.
                self.notes.assumed(
                    line,
                    f"G{SYSTEM_CODES[self.system - 1]}: its Z zero read as "
                    f"G{SYSTEM_CODES[self.frame_system - 1]}'s (neither is in the file)",
                )
            else:
                here, there = SYSTEM_CODES[self.system - 1], SYSTEM_CODES[self.frame_system - 1]
                self.unplaced = self.located(
                    failure(
                        line,
                        column,
                        f"G{here}: a second work offset; part zero is G{there}'s (the moves "
                        f"from line {self.frame_line}) and where G{here}'s zero is from it "
                        "is on the machine's offset table, not in the file (give both with "
                        "G10 L2, or import each fixture's moves on their own)",
                    )
                )
                self.placing = True
                return
        self.unplaced = None
        self.placing = False
        shift = self.shift
        for k in range(3):
            shift[k] += work[k] - self.work[k]
        self.work = work

    def table_zero(self) -> tuple[int, int] | None:
        """Data Block 0 X, Y: where part zero is on the table, when the file gives it (G10
        L2 of the system holding part zero, or MillBlocks' set-up comment)."""
        frame = self.frame if self.frame is not None else self.systems[self.system]
        (xa, x), (ya, y) = frame[0], frame[1]
        if xa != 0 and ya != 0:
            return None
        return (x if xa == 0 else 0, y if ya == 0 else 0)

    def setup_comment(self, line: int, comment: str) -> None:
        """A MillBlocks set-up comment: part zero, or a tool's diameter and length (TCAL)."""
        named = SETUP_NAME.match(comment)
        if named is not None:
            # The name comes before its tool's diameter and length comment.
            self.tool_names[int(named.group(1))] = named.group(2).strip()
            self.notes.became(line, f"the set-up comment of tool {named.group(1)}: its name")
            return
        zero = SETUP_ZERO.match(comment)
        tool = SETUP_TOOL.match(comment)
        units = self.current_units()
        if zero is not None:
            g54 = self.systems[1]
            g54[0] = (0, decimal_nm(zero.group(1), units))
            g54[1] = (0, decimal_nm(zero.group(2), units))
            self.place_work(line, 0)
            self.notes.became(line, "the set-up comment: part zero (Data Block 0 X, Y)")
        elif tool is not None:
            number = int(tool.group(1))
            dia, tcal = tool.group(2), tool.group(3)
            self.tools[number] = ToolData(
                diameter=None if dia is None else decimal_nm(dia, units),
                tcal=None if tcal is None else decimal_nm(tcal, units),
                name=self.tool_names.get(number, ""),
            )
            self.notes.became(
                line, f"the set-up comment of tool {number}: its DIA and TCAL (Data Block 0)"
            )

    def g92(self, block: Block) -> None:
        line = block.line
        if not self.moved and all(v is None for v in (self.x, self.y, self.z)):
            for axis in AXES:
                word = block.get(axis)
                if word is not None:
                    setattr(self, axis.lower(), self.length(word, block))
            self.notes.assumed(
                line,
                "G92 before any move: the tool starts at the point it names (part zero is "
                "where the file says the tool is)",
            )
            return
        for k, axis in enumerate(AXES):
            word = block.get(axis)
            if word is None:
                continue
            current = getattr(self, axis.lower())
            if current is None:
                raise failure(line, word.column, f"G92 {axis}: the tool's position is not known")
            # The point now called `value` is `current` in part coordinates.
            self.shift[k] = current - self.length(word, block)
        self.notes.assumed(line, "G92 shifts the coordinates: later points are converted back")

    def home(self, block: Block, code: str) -> None:
        line = block.line
        if not any(block.has(a) for a in AXES):
            self.notes.ignored(
                line, f"G{code}: a return to the machine's home, which the file does not give"
            )
            self.x = self.y = self.z = None
            return
        named = [a for a in AXES if block.has(a)]
        if self.incremental and all(Decimal(block.other[a].text) == 0 for a in named):
            # `G91 G28 Z0`, a post's retract: the intermediate point is where the tool is,
            # so the tool goes straight to the reference point (not in the file).
            for a in named:
                setattr(self, a.lower(), None)
            self.notes.assumed(
                line,
                f"G{code} G91 {' '.join(a + '0' for a in named)}: straight to the machine's "
                "reference point, which the file does not give",
            )
            return
        x, y, z = self.target(block)
        self.steps.append(Rapid(line, x, y, z, self.current_units()))
        self.moves_made = True
        self.x, self.y, self.z = x, y, z
        self.moved = True
        self.cycle_drilled = False
        self.notes.assumed(
            line,
            f"G{code}: the move to the intermediate point is imported; the return on to the "
            "machine's home (not in the file) is not",
        )

    def machine_move(self, block: Block, word: Word) -> None:
        """G53: a rapid to a place in machine coordinates (a post's `G53 G0 Z0` retract, a
        tool change position). The file does not say where that is in part coordinates:
        the axes it names are not known until the file moves them again (as after `G28`).
        """
        line = block.line
        named = [a for a in AXES if block.has(a)]
        if not named:
            self.notes.ignored(line, "G53 with no axis words: nothing moves")
            return
        if self.motion != "0":
            raise failure(
                line,
                word.column,
                f"G53 G{self.motion}: a {'feed' if self.motion != '80' else 'move'} in "
                "machine coordinates; where it goes in part coordinates is not in the file "
                "(G53 is read with G0, a rapid to a machine position)",
            )
        for a in named:
            setattr(self, a.lower(), None)
        self.moved = True
        self.cycle_drilled = False
        words = " ".join(f"{a}{block.other[a].text}" for a in named)
        one = len(named) == 1
        self.notes.assumed(
            line,
            f"G53 G0 {words}: the machine's {words}, which the file does not give in part "
            f"coordinates: the tool's {' and '.join(named)} {'is' if one else 'are'} not "
            f"known until the file gives {'it' if one else 'them'} again",
        )

    # -- motion -------------------------------------------------------------------------------

    def rate(self, word: Word) -> int:
        units = self.units or self.current_units()
        return text_nm(word.text, NM_PER_INCH if units is Units.INCH else NM_PER_MM)

    def target(self, block: Block) -> tuple[int, int, int | None]:
        """Where the axis words go, in part coordinates (G90/G91, G92 shift, work offset)."""
        if self.placing:
            self.place(block.line)
        other = block.other
        x_word, y_word, z_word = other.get("X"), other.get("Y"), other.get("Z")
        x, y = self.x, self.y
        if "@" in other or "^" in other:
            x, y = self.polar(block, x, y)
        elif x_word is None:
            if x is None:
                x = 0
                if y_word is not None or self.motion != "0":
                    self.note_zero(block.line, "X")
        else:
            x = self.axis_target(block, x_word, x, 0)
        if y_word is None:
            if y is None:
                y = 0
                if x_word is not None or self.motion != "0":
                    self.note_zero(block.line, "Y")
        else:
            y = self.axis_target(block, y_word, y, 1)
        z = self.z if z_word is None else self.axis_target(block, z_word, self.z, 2)
        assert x is not None and y is not None
        return x, y, z

    def polar(self, block: Block, x: int | None, y: int | None) -> tuple[int, int]:
        """Where @ (distance) and ^ (angle, degrees) go from (`x`, `y`), in part
        coordinates, as LinuxCNC's find_ends has them: about program zero (G92 included),
        G17 only, no X or Y beside them. G90: the point's distance and angle, a missing one
        the tool's; G91: added to the tool's. A missing word needs the tool's direction,
        which it does not have at program zero: refused there, as LinuxCNC refuses it."""
        line = block.line
        at, angle = block.get("@"), block.get("^")
        first = at or angle
        assert first is not None
        for letter in ("X", "Y"):
            word = block.get(letter)
            if word is not None:
                raise failure(line, word.column, f"{letter} beside polar coordinates (@ ^)")
        if self.plane != "17":
            raise failure(line, first.column, f"polar coordinates (@ ^) in the G{self.plane} plane")
        for axis, now in (("X", x), ("Y", y)):
            if now is None:
                self.note_zero(line, axis)
        px, py = (x or 0) - self.shift[0], (y or 0) - self.shift[1]
        distance, direction = math.hypot(px, py), math.atan2(py, px)
        if (self.incremental or angle is None) and px == 0 and py == 0:
            raise failure(
                line,
                first.column,
                "a polar coordinate from program zero with no angle to go at: give ^ (and "
                "@) in G90",
            )
        if at is not None:
            value = self.length(at, block)
            distance = distance + value if self.incremental else value
        if angle is not None:
            turn = math.radians(float(angle.value))
            direction = direction + turn if self.incremental else turn
        return (
            round(distance * math.cos(direction)) + self.shift[0],
            round(distance * math.sin(direction)) + self.shift[1],
        )

    def axis_target(self, block: Block, word: Word, current: int | None, k: int) -> int:
        """Where one axis word goes (`k`: 0 X, 1 Y, 2 Z; `current`: where it is)."""
        value = self.length(word, block)
        if not self.incremental:
            return value + self.shift[k]
        if current is None:
            if k == 2:
                raise failure(block.line, word.column, "Z incremental from an unknown height")
            current = 0
            self.note_zero(block.line, AXES[k])
        return current + value

    def uncut(self) -> bool:
        """Whether no feed, arc or cycle has been read yet."""
        return not self.passed_cut and not any(
            isinstance(s, Feed | Arc | Cycle) for s in self.steps
        )

    def note_zero(self, line: int, axis: str) -> None:
        self.notes.assumed(line, f"{axis} not known yet: the tool starts over part zero ({axis}0)")

    def move(self, block: Block) -> None:
        line = block.line
        units = self.current_units()
        motion = self.motion
        if motion is None:
            raise failure(line, block.words[0].column, "axis words with no motion mode (G0/G1/…)")
        if motion == "80":
            raise failure(line, block.words[0].column, "axis words after G80 with no motion code")
        if motion in CYCLES:
            if self.undecided is not None:
                self.decide(self.target(block)[:2], True)
            self.cycle(block)
            return
        x, y, z = self.target(block)
        if self.undecided is not None:
            self.decide((x, y), False)
        if self.comp and motion == "0" and (x, y) != (self.x, self.y):
            raise failure(
                line,
                block.words[0].column,
                "a rapid move in X/Y with cutter compensation on: the control offsets it too, "
                "and MillBlocks offsets cuts only — turn compensation on (G41/G42) with the "
                "first cut, or off (G40) before the rapid",
            )
        if self.arc_barred and motion in ("2", "3"):
            raise failure(
                line,
                next((w.column for w in block.gs if w.code == motion), block.words[0].column),
                "an arc right after G40: the control refuses it (the move that ends cutter "
                "compensation goes straight from the compensated point)",
            )
        self.arc_barred = False
        if motion != "0":
            self.change_pending = None
        if motion == "0":
            if not (block.has("X") or block.has("Y")) and (
                not self.moves_made
                or (self.start_z is None and self.z is None and z is not None and self.uncut())
            ):
                # The first Z move, up or down to where the program starts (after a move
                # across at an unknown height, as a post's `G0 X Y` / `G43 Z H` starts).
                self.start_z = z
            self.steps.append(Rapid(line, x, y, z, units))
            self.moves_made = True
        elif motion == "1":
            feed = self.need_feed(block, (x, y) != (self.x, self.y))
            self.steps.append(Feed(line, x, y, z, feed, units, self.comp, self.comp_tool))
            self.moves_made = True
        else:
            self.arc(block, x, y, z, motion == "2")
            self.moves_made = True
        self.x, self.y, self.z = x, y, z
        self.moved = True
        self.cycle_drilled = False

    def decide(self, to: tuple[int, int], hole: bool) -> None:
        """The move after a `G0 X Y` right after a canned cycle (`undecided`): a hole at
        that point says the line only moved; a move elsewhere leaves it ambiguous."""
        assert self.undecided is not None
        error, at = self.undecided
        if at is None:
            self.undecided = (error, to)  # the line itself: where it goes
        elif to == at and hole:
            self.undecided = None
        elif to != at:
            raise error

    def need_feed(self, block: Block, across: bool = True) -> int:
        """The feed of a move (nm/min) across X/Y (`across`) or in Z alone, within the
        control's FEEDR XY or FEEDR Z: one outside is cut at the nearest end of that range
        (as pecks past 40 are drilled as 40), reported at its F word."""
        feed = self.feed
        if feed is None:
            raise failure(block.line, block.words[0].column, "a feed move with no F given yet")
        low, high = FEEDS_ACROSS if across else FEEDS_DOWN
        if low - FEED_SLACK <= feed <= high + FEED_SLACK:
            return feed
        cut = high if feed > high else low
        units = self.current_units()
        other = Units.MM if units is Units.INCH else Units.INCH
        ranges = limits.FEED_XY if across else limits.FEED_Z
        limit, also = ranges[units], ranges[other]
        self.notes.assumed(
            self.feed_at[0],
            f"F{self.feed_at[2]} (column {self.feed_at[1]}): {show_feed(feed, units)} "
            f"{'across' if across else 'in Z'} is outside FEEDR {'XY' if across else 'Z'}'s "
            f"{limit.low} to {limit.high} {units.feed_symbol} ({also.low} to {also.high} "
            f"{other.feed_symbol} in {'an mm' if other is Units.MM else 'an inch'} block), "
            f"the control's: cut at {show_feed(cut, units)}",
        )
        return cut

    def arc(self, block: Block, x: int, y: int, z: int | None, clockwise: bool) -> None:
        line = block.line
        units = self.current_units()
        first = block.words[0].column
        if self.plane != "17":
            raise failure(
                line,
                first,
                f"an arc in the G{self.plane} ({'XZ' if self.plane == '18' else 'YZ'}) plane: "
                "MillBlocks cuts arcs in XY only; if it is a CAM's vertical lead-in or "
                "lead-out, turn those off (a lead in XY, or none)",
            )
        # An arc with a Z move (a helix) is a step like any arc: what it becomes (a HELIX
        # block, or a refusal naming the line) is the segmenter's (app.cnc.recognition.segment).
        k = block.get("K")
        # FreeCAD's grbl post writes K0.000 in every G17 arc; grbl ignores it, and a zero
        # changes nothing (rs274 refuses any K here): `unused` reports it.
        if k is not None and k.value != 0:
            raise failure(
                line, k.column, f"K{k.text} in an XY (G17) arc: only I and J give its centre"
            )
        sx = self.x if self.x is not None else 0
        sy = self.y if self.y is not None else 0
        i_word, j_word, r_word = block.get("I"), block.get("J"), block.get("R")
        feed = self.need_feed(block)
        if r_word is not None:
            if i_word is not None or j_word is not None:
                raise failure(line, r_word.column, "an arc with both R and I/J")
            radius = self.length(r_word, block)
            cx, cy = self.centre_from_radius(line, r_word, (sx, sy), (x, y), radius, clockwise)
        else:
            if i_word is None and j_word is None:
                raise failure(line, first, "an arc with no centre (I, J or R)")
            i = 0 if i_word is None else self.length(i_word, block)
            j = 0 if j_word is None else self.length(j_word, block)
            if self.arc_absolute:
                cx, cy = i + self.shift[0], j + self.shift[1]
            else:
                cx, cy = sx + i, sy + j
            where = i_word or j_word
            assert where is not None
            check_arc(line, where.column, (sx, sy), (x, y), (cx, cy), units)
        self.steps.append(
            Arc(line, x, y, z, cx, cy, clockwise, feed, units, self.comp, self.comp_tool)
        )

    def centre_from_radius(
        self,
        line: int,
        word: Word,
        start: tuple[int, int],
        end: tuple[int, int],
        radius: int,
        clockwise: bool,
    ) -> tuple[int, int]:
        """The centre of an R-form arc: R > 0 the arc of 180° or less, R < 0 the longer."""
        d = math.dist(start, end)
        if d == 0:
            raise failure(line, word.column, "an R-form arc cannot be a full circle")
        half = d / 2
        r = float(abs(radius))
        if r < half:
            if half - r > 12_700:
                raise failure(line, word.column, "R is smaller than half the distance to the end")
            r = half
        h = math.sqrt(max(r * r - half * half, 0.0))
        mx, my = (start[0] + end[0]) / 2, (start[1] + end[1]) / 2
        ux, uy = (end[0] - start[0]) / d, (end[1] - start[1]) / d
        # The short way round: a clockwise arc's centre is right of the chord, else left.
        side = -1 if clockwise else 1
        if radius < 0:
            side = -side
        return round(mx - side * h * uy), round(my + side * h * ux)

    def dwell(self, block: Block, word: Word) -> None:
        p, x = block.get("P"), block.get("X")
        line = block.line
        chosen = p if p is not None else x
        if chosen is None:
            raise failure(line, word.column, "G4 with no dwell time (P or X)")
        seconds = chosen.value
        if p is not None and "." not in p.text and word.text.startswith("0"):
            seconds = p.value / 1000
            self.notes.assumed(line, f"G04 P{p.text}: Fanuc milliseconds ({seconds} s)")
        if not 0 <= seconds <= 100_000:
            raise failure(line, chosen.column, "a dwell time out of range")
        self.steps.append(Dwell(line, seconds))

    def cycle(self, block: Block) -> None:
        line = block.line
        code = self.motion
        assert code is not None
        units = self.current_units()
        first = block.words[0].column
        if self.comp:
            raise failure(
                line,
                first,
                f"G{code} with cutter compensation on: rs274 refuses a canned cycle then",
            )
        self.change_pending = None
        x0, y0 = self.x or 0, self.y or 0
        x, y, _ = self.target(block)
        r_word, z_word, q_word = block.get("R"), block.get("Z"), block.get("Q")
        start_z = self.z
        if start_z is None:
            raise failure(line, first, "a canned cycle from an unknown height (no Z yet)")
        if r_word is not None:
            value = self.length(r_word, block)
            self.cycle_r = start_z + value if self.incremental else value + self.shift[2]
        if self.cycle_r is None:
            raise failure(line, first, f"G{code} with no R plane")
        if z_word is not None:
            value = self.length(z_word, block)
            self.cycle_z = self.cycle_r + value if self.incremental else value + self.shift[2]
        if self.cycle_z is None:
            raise failure(line, first, f"G{code} with no Z depth")
        if q_word is not None:
            self.cycle_q = abs(self.length(q_word, block))
        p_word = block.get("P")
        if p_word is not None:
            self.cycle_p = p_word.value
        r, bottom = self.cycle_r, self.cycle_z
        if bottom >= r:
            where = z_word or r_word or block.words[0]
            raise failure(line, where.column, f"G{code}: Z is not below R")
        feed = self.need_feed(block, False)
        peck = 0
        if code in ("73", "83"):
            if not self.cycle_q:
                raise failure(line, first, f"G{code} with no peck depth Q")
            peck = self.cycle_q
        l_word = block.get("L")
        repeats = 1 if l_word is None else self.integer(l_word, block, 1, 1000)
        clear = self.cycle_clear(start_z, r)
        dx, dy = (x - x0, y - y0) if self.incremental else (0, 0)
        if self.made() + repeats > MAX_STEPS:
            raise failure(line, first, f"more than {MAX_STEPS} moves: not a program to import")
        hx, hy = x, y
        for k in range(repeats):
            if k and self.incremental:
                # Each repeat moves on from the last hole (polar: turned and stepped out).
                if block.has("@") or block.has("^"):
                    hx, hy = self.polar(block, hx, hy)
                else:
                    hx, hy = hx + dx, hy + dy
            self.steps.append(
                Cycle(line, int(code), hx, hy, r, bottom, clear, feed, peck, self.cycle_p, units)
            )
        self.x, self.y, self.z = hx, hy, clear
        self.moved = True
        self.cycle_drilled = True


def spaced_number(line: str, start: int) -> tuple[str, int]:
    """The number written from `start` in `line` with the blanks inside it taken out
    (a sign first, then digits and a point), and where it ends: `(' -2', 1)` of `'I -20'`
    is `('-20', 5)`. The text may not be a number (`'-'`, `'1.2.'`): the caller checks."""
    chars: list[str] = []
    end = start
    pos = start
    n = len(line)
    while pos < n:
        ch = line[pos]
        if ch in " \t":
            pos += 1
            continue
        if not (ch in "0123456789." or (ch in "+-" and not chars)):
            break
        chars.append(ch)
        pos += 1
        end = pos
    return "".join(chars), end


def decimal_nm(text: str, units: Units) -> int:
    """A number written in a comment, in `units`, as nm."""
    return int((Decimal(text) * units.nm).to_integral_value())


def check_arc(
    line: int,
    column: int,
    start: tuple[int, int],
    end: tuple[int, int],
    centre: tuple[int, int],
    units: Units,
) -> None:
    """LinuxCNC's test (`arc_end_off`): beyond it, an error naming the line."""
    r1 = math.dist(start, centre)
    r2 = math.dist(end, centre)
    if r1 == 0:
        raise failure(line, column, "the arc's centre is its start point")
    if arc_end_off(r1, r2, units):
        raise failure(
            line,
            column,
            f"the arc's end is {show(abs(r1 - r2), units)} off its radius: the start is "
            f"{show(r1, units)} from the centre, the end {show(r2, units)}",
        )
