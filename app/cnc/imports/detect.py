"""Which reader a file needs, from its content, and the dispatch to it.

- **dxf**: a binary DXF's sentinel, or text whose first group is `0` then `SECTION`.
- **json**: text whose first character is `{` (a MillBlocks program document).
- **tape** (punch image): bytes that are not text — a NUL, a control character other than
  tab/CR/LF, or bytes that are not UTF-8 (ASCII rows carry a parity bit, EIA rows are codes
  in channels 1-8); the tape reader then tells EIA from ASCII by their parity.
- **events**: a `G100`-`G109` word (seed 003 §2.2.1): no G-code or tape has those.
- **tape** (listing) or **gcode**: the two share word-address syntax, and some codes mean
  different things (G20/G30 arcs or units and home, G50 rapid or scaling off, G94 preset
  or feed per minute, G98/G99 quill or cycle return; G00 is a feed move on the 1704). The
  file is read as one only when it has something the other cannot have, and nothing the
  first cannot; otherwise detection refuses to guess and asks for the format.

  Only in G-code: lower-case letters, word letters the 1704 lacks (O P Q H D L …), two
  different G or M codes in one block, G codes the 1704 lacks (G17, G21, G28, G40-G43,
  G54, G92 …), S or T words longer than the 1704's two digits, G4 with P, a decimal point
  where the 1704's 2.4 / 3.3 formats would not put it (the 1704 ignores points, so X1.5 is
  0.0015 in there), a block-delete slash.
  Only on a 1704 tape: G50 with axis words, G20/G30 with an arc centre, G04 with F, a
  dimension of five or more digits without a point (10 000 in as G-code).
"""

from __future__ import annotations

import re
from collections.abc import Mapping

from app.cnc import document
from app.cnc.blocks import Program
from app.cnc.copy import CopyError, resolve_copies
from app.cnc.imports.common import ImportFailure, ImportNote, NoteKind, is_text
from app.cnc.imports.dxf import is_dxf, parse_options, read_drawing
from app.cnc.imports.dxf_blocks import program_from_drawing
from app.cnc.imports.events import read_events
from app.cnc.imports.gcode import parse_gcode
from app.cnc.imports.motion import program_from_motion
from app.cnc.imports.tape import read_tape
from app.cnc.numbers import NumberError, parse_decimal

FORMATS = ("json", "events", "gcode", "tape", "dxf")

_EVENT = re.compile(r"(?<![A-Z0-9.])G10[0-9](?![0-9.])", re.IGNORECASE)
_COMMENT = re.compile(r"\([^)]*\)?")
_WORD = re.compile(r"([A-Za-z])\s*([+-]?[0-9.]*)")
_TAPE_G = {0, 1, 2, 3, 4, 20, 30, 50, 80, 81, 82, 83, 84, 85, 86, 87, 88, 89, 90, 91, 94, 98, 99}
_TAPE_LETTERS = set("NGXYZIJKRFSTM")
_DIMENSIONS = set("XYZIJKR")


def detect_format(data: bytes) -> str:
    """ "json", "events", "gcode" or "tape". Raises ImportFailure when the content could be
    either a 1704 tape or G-code (or is empty)."""
    if not data.strip():
        raise ImportFailure("", "the file is empty")
    if is_dxf(data):
        return "dxf"
    if not is_text(data):
        return "tape"
    text = data.decode("utf-8").lstrip("\ufeff")
    if text.lstrip().startswith("{"):
        return "json"
    plain = _COMMENT.sub(" ", text)
    if _EVENT.search(plain):
        return "events"
    gcode, tape = _evidence(plain)
    if gcode and not tape:
        return "gcode"
    if tape and not gcode:
        return "tape"
    if gcode and tape:
        raise ImportFailure(
            "",
            f"this could be a 1704 tape ({tape}) or G-code ({gcode}); give the format "
            "(tape or gcode)",
        )
    raise ImportFailure(
        "",
        "this could be a 1704 tape or G-code: nothing in it is only one of them (their G "
        "codes differ: G00 feeds on a 1704 and rapids in G-code; G20/G30, G50, G94, G98/G99); "
        "give the format (tape or gcode)",
    )


def _evidence(text: str) -> tuple[str, str]:
    """(first reason it must be G-code, first reason it must be a tape), '' for none."""
    gcode = tape = ""
    for number, raw in enumerate(text.replace("\r", "\n").split("\n"), start=1):
        for block in raw.split(";"):
            stripped = block.strip()
            if not stripped or stripped.startswith("%"):
                continue
            g_reason, t_reason = _block_evidence(stripped)
            if g_reason and not gcode:
                gcode = f"line {number}: {g_reason}"
            if t_reason and not tape:
                tape = f"line {number}: {t_reason}"
            if gcode and tape:
                return gcode, tape
    return gcode, tape


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


def decode_text(data: bytes) -> str:
    """The file as text. Raises ImportFailure naming line and column of a byte that is not
    UTF-8."""
    try:
        return data.decode("utf-8").lstrip("\ufeff")
    except UnicodeDecodeError as exc:
        before = data[: exc.start]
        line = before.count(b"\n") + 1
        column = exc.start - (before.rfind(b"\n") + 1) + 1
        raise ImportFailure(
            f"line {line}, column {column}",
            f"byte 0x{data[exc.start]:02X} is not text (UTF-8)",
            line,
        ) from None


def read(
    data: bytes,
    name: str,
    format: str | None,
    options: Mapping[str, str],
) -> tuple[Program, list[ImportNote], str]:
    """Read `data` in `format` (detected when None): the program, its report, the format."""
    chosen = detect_format(data) if format is None else format
    if chosen not in FORMATS:
        raise ImportFailure("", f"no import format {chosen!r}; formats: {', '.join(FORMATS)}")
    if chosen == "dxf":
        drawing = read_drawing(data, name, parse_options(options))
        return program_from_drawing(drawing), drawing.notes.report(), chosen
    allowed = {"units", "resolution"} if chosen == "tape" else set()
    unknown = sorted(set(options) - allowed)
    if unknown:
        known = ", ".join(sorted(allowed)) or "none"
        raise ImportFailure(
            "", f"{chosen} import has no option {unknown[0]!r}; its options: {known}"
        )
    if chosen == "tape":
        program, notes = read_tape(data, name, options)
        return program, notes.report(), chosen
    text = decode_text(data)
    if chosen == "json":
        note = ImportNote(NoteKind.BECAME, None, "a MillBlocks program document, as written")
        return _json(text), [note], chosen
    if chosen == "events":
        program, notes = read_events(text, name)
        return program, notes.report(), chosen
    parsed = parse_gcode(text, name)
    return program_from_motion(parsed), parsed.notes.report(), chosen


def _json(text: str) -> Program:
    try:
        program = document.loads(text)
    except document.DocumentError as exc:
        raise ImportFailure(exc.where, exc.message) from None
    try:
        return resolve_copies(program)
    except CopyError as exc:
        raise ImportFailure(f"block {exc.block}", exc.message) from None
