"""Punched-tape character codes for the Tektronix 1704: EIA RS-244 and ASCII/ISO with parity.

The 1704 reads 8-channel, 1-inch tape in either code, chosen by a switch (seed 000 §1 "EIA,
ASCII and ISO Character Coding"); its own code chart (Fig. 1-4) is lost in the scan, so the
tables below are the published standards':

- **EIA RS-244-B** (Electronic Industries Association, "Character Code for Numerical Machine
  Control Perforated Tape"): digits are BCD in channels 1-4 (0 is channel 6 alone); letters
  are a zone (A-I channels 6+7, J-R channel 7, S-Z channel 6) plus the BCD digit; channel 5
  is the parity hole that makes every code odd; End of Block is channel 8 alone; the rewind
  stop is the End of Record code (channels 1, 2, 4); Delete is channels 1-7.
- **ASCII** (ANSI X3.4, ISO 646 7-bit code) punched per **ISO 840 / EIA RS-358** with even
  parity in channel 8: channels 1-7 carry the 7-bit code, channel 8 is punched when they hold
  an odd number of holes. The 1704's End of Block in ASCII is carriage return (seed 000 §1
  "Block": "punched by pressing the carriage return"); the rewind stop is `%`.

A *row* is one byte: channel n is bit n-1 (channel 1 = 0x01, channel 8 = 0x80). The sprocket
(feed) hole is on every row and carries no data. Blank tape (0x00) and Delete are ignored by
the reader in both codes (seed 000 §2 "Code Delete").

A listing is the text form of a tape: `%` stands for the rewind stop (in EIA, its End of
Record code, not the ASCII `%`), a newline for End of Block, a tab for the tab code.
"""

from __future__ import annotations

import enum
import re
from dataclasses import dataclass, field


class TapeCode(enum.Enum):
    """The two codes the 1704's reader switch selects."""

    EIA = "eia"
    ASCII = "ascii"


ROWS_PER_INCH = 10
"""Rows are punched 0.1 in apart (EIA RS-227 / ISO 1154 tape)."""

BLANK = 0x00
"""Sprocket hole only: leader, trailer and tape feed; ignored in both codes."""

EOB_CHAR = "\n"
REWIND_STOP_CHAR = "%"

# --- EIA RS-244-B -----------------------------------------------------------------------
# Values are the rows as punched, parity (channel 5, 0x10) included. Only the characters a
# 1704 tape uses are listed; EIA has no lower case and no parentheses in RS-244 (the 1704's
# comments work in ASCII only, seed 000 §2 "Parentheses").
EIA_END_OF_BLOCK = 0x80  # channel 8 alone (RS-244 "EOB", the carriage return key)
EIA_REWIND_STOP = 0x0B  # channels 1, 2, 4: RS-244 "End of Record" (rewind stop)
EIA_DELETE = 0x7F  # channels 1-7 (rub-out)
EIA_TAB = 0x3E  # channels 2, 3, 4, 5, 6

EIA_CODES: dict[str, int] = {
    # digits: BCD in channels 1-4, parity in 5; zero is channel 6
    "0": 0x20,
    "1": 0x01,
    "2": 0x02,
    "3": 0x13,
    "4": 0x04,
    "5": 0x15,
    "6": 0x16,
    "7": 0x07,
    "8": 0x08,
    "9": 0x19,
    # A-I: channels 6 and 7 plus the digit 1-9
    "A": 0x61,
    "B": 0x62,
    "C": 0x73,
    "D": 0x64,
    "E": 0x75,
    "F": 0x76,
    "G": 0x67,
    "H": 0x68,
    "I": 0x79,
    # J-R: channel 7 plus the digit 1-9
    "J": 0x51,
    "K": 0x52,
    "L": 0x43,
    "M": 0x54,
    "N": 0x45,
    "O": 0x46,
    "P": 0x57,
    "Q": 0x58,
    "R": 0x49,
    # S-Z: channel 6 plus the digit 2-9
    "S": 0x32,
    "T": 0x23,
    "U": 0x34,
    "V": 0x25,
    "W": 0x26,
    "X": 0x37,
    "Y": 0x38,
    "Z": 0x29,
    # signs and punctuation
    " ": 0x10,  # space: channel 5
    "+": 0x70,  # channels 5, 6, 7
    "-": 0x40,  # channel 7
    ".": 0x6B,  # channels 1, 2, 4, 6, 7
    "/": 0x31,  # channels 1, 5, 6
    "\t": EIA_TAB,
    REWIND_STOP_CHAR: EIA_REWIND_STOP,
    EOB_CHAR: EIA_END_OF_BLOCK,
}

# --- ASCII with even parity in channel 8 (ISO 840 / RS-358) ------------------------------
# The 7-bit ASCII value in channels 1-7, 0x80 added where that value has an odd number of
# holes. Listed literally (not computed) so a test can hold them against the standard.
ASCII_END_OF_BLOCK = 0x8D  # CR 0x0D (three holes) + parity
ASCII_REWIND_STOP = 0xA5  # "%" 0x25 (three holes) + parity
ASCII_DELETE = 0xFF  # DEL 0x7F (seven holes) + parity
ASCII_TAB = 0x09  # HT 0x09 (two holes)

ASCII_CODES: dict[str, int] = {
    " ": 0xA0,
    "#": 0xA3,
    "(": 0x28,
    ")": 0xA9,
    "*": 0xAA,
    "+": 0x2B,
    ",": 0xAC,
    "-": 0x2D,
    ".": 0x2E,
    "/": 0xAF,
    "0": 0x30,
    "1": 0xB1,
    "2": 0xB2,
    "3": 0x33,
    "4": 0xB4,
    "5": 0x35,
    "6": 0x36,
    "7": 0xB7,
    "8": 0xB8,
    "9": 0x39,
    ":": 0x3A,
    "=": 0xBD,
    "A": 0x41,
    "B": 0x42,
    "C": 0xC3,
    "D": 0x44,
    "E": 0xC5,
    "F": 0xC6,
    "G": 0x47,
    "H": 0x48,
    "I": 0xC9,
    "J": 0xCA,
    "K": 0x4B,
    "L": 0xCC,
    "M": 0x4D,
    "N": 0x4E,
    "O": 0xCF,
    "P": 0x50,
    "Q": 0xD1,
    "R": 0xD2,
    "S": 0x53,
    "T": 0xD4,
    "U": 0x55,
    "V": 0x56,
    "W": 0xD7,
    "X": 0xD8,
    "Y": 0x59,
    "Z": 0x5A,
    "\t": ASCII_TAB,
    REWIND_STOP_CHAR: ASCII_REWIND_STOP,
    EOB_CHAR: ASCII_END_OF_BLOCK,
}

_TABLES = {TapeCode.EIA: EIA_CODES, TapeCode.ASCII: ASCII_CODES}
# A character outside each code's table (one search over a whole run of blocks' text).
_OUTSIDE = {
    code: re.compile("[^" + "".join(re.escape(ch) for ch in sorted(table)) + "]")
    for code, table in _TABLES.items()
}
_DELETE = {TapeCode.EIA: EIA_DELETE, TapeCode.ASCII: ASCII_DELETE}


class TapeCodeError(ValueError):
    """A character the chosen code cannot punch."""


def table(code: TapeCode) -> dict[str, int]:
    """Character → row for `code` (a copy)."""
    return dict(_TABLES[code])


def end_of_block(code: TapeCode) -> int:
    """The End of Block row: EIA channel 8, ASCII carriage return with parity."""
    return _TABLES[code][EOB_CHAR]


def rewind_stop(code: TapeCode) -> int:
    """The rewind stop row: EIA End of Record, ASCII `%` with parity."""
    return _TABLES[code][REWIND_STOP_CHAR]


def delete(code: TapeCode) -> int:
    """The rub-out row (every data channel punched, parity kept)."""
    return _DELETE[code]


def holes(row: int) -> int:
    """How many channels of `row` are punched (the sprocket hole is not counted)."""
    return bin(row & 0xFF).count("1")


def parity_ok(row: int, code: TapeCode) -> bool:
    """True when `row` has the code's parity: odd for EIA, even for ASCII (seed 000 §1
    "Tape Errors"). Blank tape is exempt: it is tape feed, not a character."""
    if row == BLANK:
        return True
    odd = holes(row) % 2 == 1
    return odd if code is TapeCode.EIA else not odd


def can_encode(text: str, code: TapeCode) -> bool:
    """True when every character of `text` has a row in `code`."""
    return _OUTSIDE[code].search(text) is None


def encode(text: str, code: TapeCode) -> bytes:
    """The rows for a listing (`%` rewind stop, newline End of Block, tab).

    Raises TapeCodeError naming the first character the code has no row for.
    """
    codes = _TABLES[code]
    rows = bytearray()
    for index, ch in enumerate(text):
        row = codes.get(ch)
        if row is None:
            raise TapeCodeError(f"{code.value.upper()} has no code for {ch!r} (character {index})")
        rows.append(row)
    return bytes(rows)


@dataclass
class Decoded:
    """A punch image read back: the listing, and what was wrong with the rows.

    Row numbers count from 0, the first row of the image.
    """

    text: str
    leader_rows: int
    parity_errors: list[int] = field(default_factory=list)
    unknown_rows: list[tuple[int, int]] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.parity_errors and not self.unknown_rows


def decode(rows: bytes, code: TapeCode) -> Decoded:
    """Read a punch image back to its listing, as the 1704's reader does.

    Everything before the first End of Block is leader (a punched title is allowed there)
    except the rewind stop that precedes that End of Block, which is kept as `%`. After it,
    blank rows and rub-outs are skipped; every other row is checked for parity (errors are
    listed by row) and looked up; a row no character has is listed and read as `?`.
    """
    eob = end_of_block(code)
    skip = {BLANK, delete(code)}
    try:
        first_eob = rows.index(eob)
    except ValueError:
        return Decoded(text="", leader_rows=len(rows))
    reverse = {row: ch for ch, row in _TABLES[code].items()}
    leader = first_eob
    before = [i for i in range(first_eob) if rows[i] not in skip]
    if before and rows[before[-1]] == rewind_stop(code):
        leader = before[-1]
    out: list[str] = []
    result = Decoded(text="", leader_rows=leader)
    for index in range(leader, len(rows)):
        row = rows[index]
        if row in skip:
            continue
        if not parity_ok(row, code):
            result.parity_errors.append(index)
        ch = reverse.get(row)
        if ch is None:
            result.unknown_rows.append((index, row))
            ch = "?"
        out.append(ch)
    result.text = "".join(out)
    return result


# --- readable titles --------------------------------------------------------------------
# A 5 x 7 dot-matrix face (the usual teleprinter/terminal 5 x 7 shapes), rows top to bottom.
# Punched in channels 1-7, top of the letter in channel 7: channel 8 is never punched, so no
# title row can equal either code's End of Block (EIA 0x80, ASCII 0x8D), which is the one
# row a leader must not contain (seed 000 §2 "Tape Leader").
_FONT: dict[str, tuple[str, ...]] = {
    "A": (".###.", "#...#", "#...#", "#####", "#...#", "#...#", "#...#"),
    "B": ("####.", "#...#", "#...#", "####.", "#...#", "#...#", "####."),
    "C": (".###.", "#...#", "#....", "#....", "#....", "#...#", ".###."),
    "D": ("####.", "#...#", "#...#", "#...#", "#...#", "#...#", "####."),
    "E": ("#####", "#....", "#....", "####.", "#....", "#....", "#####"),
    "F": ("#####", "#....", "#....", "####.", "#....", "#....", "#...."),
    "G": (".###.", "#...#", "#....", "#.###", "#...#", "#...#", ".####"),
    "H": ("#...#", "#...#", "#...#", "#####", "#...#", "#...#", "#...#"),
    "I": (".###.", "..#..", "..#..", "..#..", "..#..", "..#..", ".###."),
    "J": ("..###", "...#.", "...#.", "...#.", "...#.", "#..#.", ".##.."),
    "K": ("#...#", "#..#.", "#.#..", "##...", "#.#..", "#..#.", "#...#"),
    "L": ("#....", "#....", "#....", "#....", "#....", "#....", "#####"),
    "M": ("#...#", "##.##", "#.#.#", "#.#.#", "#...#", "#...#", "#...#"),
    "N": ("#...#", "#...#", "##..#", "#.#.#", "#..##", "#...#", "#...#"),
    "O": (".###.", "#...#", "#...#", "#...#", "#...#", "#...#", ".###."),
    "P": ("####.", "#...#", "#...#", "####.", "#....", "#....", "#...."),
    "Q": (".###.", "#...#", "#...#", "#...#", "#.#.#", "#..#.", ".##.#"),
    "R": ("####.", "#...#", "#...#", "####.", "#.#..", "#..#.", "#...#"),
    "S": (".####", "#....", "#....", ".###.", "....#", "....#", "####."),
    "T": ("#####", "..#..", "..#..", "..#..", "..#..", "..#..", "..#.."),
    "U": ("#...#", "#...#", "#...#", "#...#", "#...#", "#...#", ".###."),
    "V": ("#...#", "#...#", "#...#", "#...#", "#...#", ".#.#.", "..#.."),
    "W": ("#...#", "#...#", "#...#", "#.#.#", "#.#.#", "#.#.#", ".#.#."),
    "X": ("#...#", "#...#", ".#.#.", "..#..", ".#.#.", "#...#", "#...#"),
    "Y": ("#...#", "#...#", ".#.#.", "..#..", "..#..", "..#..", "..#.."),
    "Z": ("#####", "....#", "...#.", "..#..", ".#...", "#....", "#####"),
    "0": (".###.", "#...#", "#..##", "#.#.#", "##..#", "#...#", ".###."),
    "1": ("..#..", ".##..", "..#..", "..#..", "..#..", "..#..", ".###."),
    "2": (".###.", "#...#", "....#", "...#.", "..#..", ".#...", "#####"),
    "3": ("#####", "...#.", "..#..", "...#.", "....#", "#...#", ".###."),
    "4": ("...#.", "..##.", ".#.#.", "#..#.", "#####", "...#.", "...#."),
    "5": ("#####", "#....", "####.", "....#", "....#", "#...#", ".###."),
    "6": ("..##.", ".#...", "#....", "####.", "#...#", "#...#", ".###."),
    "7": ("#####", "....#", "...#.", "..#..", ".#...", ".#...", ".#..."),
    "8": (".###.", "#...#", "#...#", ".###.", "#...#", "#...#", ".###."),
    "9": (".###.", "#...#", "#...#", ".####", "....#", "...#.", ".##.."),
    " ": (".....",) * 7,
    "-": (".....", ".....", ".....", "#####", ".....", ".....", "....."),
    "+": (".....", "..#..", "..#..", "#####", "..#..", "..#..", "....."),
    ".": (".....", ".....", ".....", ".....", ".....", ".##..", ".##.."),
    ",": (".....", ".....", ".....", ".....", ".##..", "..#..", ".#..."),
    ":": (".....", ".##..", ".##..", ".....", ".##..", ".##..", "....."),
    "/": (".....", "....#", "...#.", "..#..", ".#...", "#....", "....."),
    "=": (".....", ".....", "#####", ".....", "#####", ".....", "....."),
    "(": ("...#.", "..#..", ".#...", ".#...", ".#...", "..#..", "...#."),
    ")": (".#...", "..#..", "...#.", "...#.", "...#.", "..#..", ".#..."),
    "?": (".###.", "#...#", "....#", "...#.", "..#..", ".....", "..#.."),
}
TITLE_CHARACTERS = frozenset(_FONT)
TITLE_ROWS_PER_CHARACTER = 6  # five columns and one blank between letters


def title_text(text: str) -> str:
    """`text` as the title face can punch it: upper case, unknown characters as `?`."""
    return "".join(ch if ch in _FONT else "?" for ch in text.upper())


def title_rows(text: str) -> bytes:
    """`text` punched as dot-matrix letters, one row per column of each letter.

    Column rows use channels 1-7 only (the letter's top in channel 7), so no row is ever an
    End of Block in either code. Letters are separated by one blank row; there is no blank
    row after the last letter.
    """
    rows = bytearray()
    for ch in title_text(text):
        glyph = _FONT[ch]
        for column in range(5):
            row = 0
            for line, dots in enumerate(glyph):
                if dots[column] == "#":
                    row |= 1 << (6 - line)  # line 0 (top) → channel 7 (bit 6)
            rows.append(row)
        rows.append(BLANK)
    return bytes(rows[:-1]) if rows else b""
