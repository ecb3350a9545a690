"""Word-address files: a 1704 tape listing and G-code share their syntax, so neither can be
told from the other by its look; this finds what only one of them can have.

The two share word-address syntax, and some codes mean different things (G20/G30 arcs or
units and home, G50 rapid or scaling off, G94 preset or feed per minute, G98/G99 quill or
cycle return; G00 is a feed move on the 1704). A file is read as one only when it has
something the other cannot have, and nothing the first cannot; otherwise detection refuses
to guess and asks for the format.

Only in G-code: lower-case letters, word letters the 1704 lacks (O P Q H D L …), two
different G or M codes in one block, G codes the 1704 lacks (G17, G21, G28, G40-G43, G54,
G92 …), S or T words longer than the 1704's two digits, G4 with P, a decimal point where
the 1704's 2.4 / 3.3 formats would not put it (the 1704 ignores points, so X1.5 is 0.0015 in
there), a block-delete slash, words of text after a `;` (a comment).
Only on a 1704 tape: G50 with axis words, G20/G30 with an arc centre, G04 with F, a
dimension of five or more digits without a point (10 000 in as G-code); each in a block
without words of text.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from app.cnc.formats.importers import Content, Sniff, Strength
from app.cnc.numbers import NumberError, parse_decimal

_WORD = re.compile(r"([A-Za-z])\s*([+-]?[0-9.]*)")
_TAPE_G = {0, 1, 2, 3, 4, 20, 30, 50, 80, 81, 82, 83, 84, 85, 86, 87, 88, 89, 90, 91, 94, 98, 99}
_TAPE_LETTERS = set("NGXYZIJKRFSTM")
_DIMENSIONS = set("XYZIJKR")
# What a block holds for `_block_evidence` to find a tape in it: a G word that may be
# G4, G20, G30 or G50 (G40 or G200 match too: only the full look tells), or a dimension of
# five digits or more. Once a text has G-code's evidence, a block without either is passed
# over: it can add nothing (most of a CAM file's blocks).
_MAY_BE_TAPE = re.compile(r"[Gg]\s*\+?0*(?:4|20|30|50)|[XYZIJKRxyzijkr]\s*[+-]?[0-9]{5}")
# Two letters together: words of text (`This`, `if`, `sqrt`), never a 1704 tape's block,
# whose every letter is followed by its digits (a scan-damaged block has other marks).
_PROSE = re.compile(r"[A-Za-z]{2}")
# Why a file with no evidence either way could be both.
LOOK_ALIKE = (
    "their G codes differ: G00 feeds on a 1704 and rapids in G-code; G20/G30, G50, G94, G98/G99"
)


@dataclass(frozen=True)
class Evidence:
    """The first reason a text must be G-code, and the first that it must be a tape ('' for
    none), each with its line."""

    gcode: str
    tape: str


def sniff(content: Content, gcode: bool) -> Sniff | None:
    """The sniff of the G-code importer (`gcode`) or the tape importer for word-address
    text: evidence of its own, or possible when neither has any; None when the text has
    only the other's evidence (or is not text)."""
    if content.text is None:
        return None
    found: Evidence = content.memo(
        "word-address", lambda: evidence(content.plain_head(SNIFF_LINES))
    )
    mine, other = (found.gcode, found.tape) if gcode else (found.tape, found.gcode)
    if mine:
        return Sniff(Strength.EVIDENCE, mine)
    if other:
        return None
    return Sniff(Strength.POSSIBLE, LOOK_ALIKE)


SNIFF_LINES = 5_000
"""Lines looked at for evidence. A long CAM file shows what it is in its first lines; a
word past them that contradicts it is the reader's to refuse, naming its line. (Reading a
10^5-line file's every word here took as long as importing it.)"""


def evidence(text: str) -> Evidence:
    """What in `text` (comments blanked) only G-code or only a 1704 tape can have, in its
    first SNIFF_LINES lines."""
    gcode = tape = ""
    lines = text.replace("\r", "\n").split("\n", SNIFF_LINES)[:SNIFF_LINES]
    for number, raw in enumerate(lines, start=1):
        for index, block in enumerate(raw.split(";")):
            stripped = block.strip()
            if not stripped or stripped.startswith("%"):
                continue
            if index and _PROSE.search(stripped):
                # G-code reads what follows a ';' as a comment; on a tape a ';' ends a
                # block, and this text is none (`; This demonstrates…`).
                if not gcode:
                    gcode = f"line {number}: a comment after ';', which a 1704 tape cannot have"
                continue
            if gcode and not _MAY_BE_TAPE.search(stripped):
                continue  # only a tape's evidence is still sought, and this has none
            g_reason, t_reason = _block_evidence(stripped)
            if t_reason and _PROSE.search(stripped):
                # Letters inside what no tape block can be are not a tape's words (the
                # `g30` and `if` of `O<tc_at_g30> if [...]`).
                t_reason = ""
            if g_reason and not gcode:
                gcode = f"line {number}: {g_reason}"
            if t_reason and not tape:
                tape = f"line {number}: {t_reason}"
            if gcode and tape:
                return Evidence(gcode, tape)
    return Evidence(gcode, tape)


def _block_evidence(block: str) -> tuple[str, str]:
    gcode = tape = ""
    if block.startswith("/"):
        gcode = "a block-delete slash"
    words = _WORD.findall(block)
    gs: set[str] = set()
    ms: set[str] = set()
    letters = {letter.upper() for letter, _ in words}
    for letter, value in words:
        if letter.islower() and not gcode:
            gcode = f"the lower-case word {letter}{value}"
        up = letter.upper()
        if up not in _TAPE_LETTERS and not gcode:
            gcode = f"the word {up}{value}, which a 1704 tape has no letter for"
        if up == "G" and value:
            gs.add(value)
            try:
                number = parse_decimal(value, exponent=False)
            except NumberError:
                continue
            integral = number == number.to_integral_value()
            if (not integral or int(number) not in _TAPE_G) and not gcode:
                gcode = f"G{value}, which the 1704 does not have"
        elif up == "M" and value:
            ms.add(value.rstrip("."))
        elif up in "ST" and len(value.replace(".", "").lstrip("+-")) > 2 and not gcode:
            gcode = f"{up}{value}, longer than the 1704's two digits"
        elif up in _DIMENSIONS and value:
            digits = value.lstrip("+-")
            if "." in digits:
                places = len(digits.split(".")[1])
                if places not in (3, 4) and not gcode:
                    gcode = f"{up}{value}: a point where the 1704's formats put none"
            elif len(digits) >= 5 and not tape:
                tape = f"{up}{value}: {digits} in as G-code, an implied-decimal 1704 number"
    numbers = {_code(v) for v in gs} - {None}
    if len(numbers) > 1 and not gcode:
        gcode = "two G codes in one block"
    if len({_code(v) for v in ms} - {None}) > 1 and not gcode:
        gcode = "two M codes in one block"
    axes = letters & {"X", "Y", "Z"}
    if 50 in numbers and axes and not tape:
        tape = "G50 with axis words (the 1704's rapid)"
    if numbers & {20, 30} and letters & {"I", "J", "K"} and not tape:
        tape = "G20/G30 with an arc centre (the 1704's decelerating arcs)"
    if 4 in numbers:
        if "F" in letters and not tape:
            tape = "G04 with F (the 1704's dwell)"
        if "P" in letters and not gcode:
            gcode = "G4 with P (G-code's dwell)"
    return gcode, tape


def _code(value: str) -> int | None:
    try:
        number = parse_decimal(value, exponent=False)
    except NumberError:
        return None
    return int(number) if number == number.to_integral_value() else None
