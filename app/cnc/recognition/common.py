"""What every importer shares: the report, the one failure, and exact number handling.

An import either returns a whole program with a report of what became what, or raises
`ImportFailure` naming the line and column (or tape block and row) of the first thing it
could not read. Nothing half-imported is ever returned (DESIGN.md §6).

Lengths inside the importers are integer nanometres, as in the tool path (DESIGN.md §2);
they become block values (`Decimal`, in a block's units) once, at the end, rounded to the
programming resolution (0.001 in / 0.01 mm) — and every value that moves is reported.
"""

from __future__ import annotations

import enum
import re
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field, replace
from decimal import Decimal
from fractions import Fraction
from functools import lru_cache
from typing import Final

from mypy_extensions import mypyc_attr

from app.cnc import limits
from app.cnc.places import Places, more_text
from app.cnc.units import Units, half_even

XY = tuple[int, int]

# A number with more digits than this is not a dimension anyone meant (and would make
# floats overflow): the importers refuse it, naming where it is.
MAX_DIGITS: Final = 12
# Dimensions beyond ±10 000 in (254 m) are refused as unreadable; the control's own limits
# (99.999 in) are left to validation, so a program with a bad value can still be corrected.
MAX_ABS_NM: Final = 10_000 * 25_400_000


class NoteKind(enum.Enum):
    """What an import note tells the user."""

    BECAME = "became"  # what part of the file became which blocks
    IGNORED = "ignored"  # not understood or not carried; nothing was made of it
    ASSUMED = "assumed"  # a reading chosen where the file is silent or the manual vague
    ROUNDED = "rounded"  # a value moved to the program's resolution
    NEEDS = "needs"  # something the user must supply before the program runs


@dataclass(frozen=True)
class ImportNote:
    """One line of an import report. `line` is the file's line (a tape's block for a punch
    image), None for the whole file; `where` says it in words (`line 12`, `block N003`).
    `also` lists the next few further lines the same note applies to (a G81 on every hole
    line), `more` counts those further lines not listed (app.cnc.places).

    A note that recurs with its own details at each place (`same`: the text its places
    share, e.g. "holes on a circle read as BOLT CIR") is one note: `message` is the first
    place's, `count` how many places in all."""

    kind: NoteKind
    line: int | None
    message: str
    where: str = ""
    also: tuple[int, ...] = ()
    unit: str = "line"  # what `line` and `also` count: "line" or "tape block"
    same: str = ""
    count: int = 1
    more: int = 0

    @property
    def also_text(self) -> str:
        """The further lines in words (`also lines 48, 84 and 3 more`), after the count of
        a recurring note (`BOLT CIR: 2775 in all; also lines …`); empty when there are
        none. A bolt-circle grid repeats a note on thousands of lines: the report names
        where it starts and how many, not all of them."""
        count = f"{self.same}: {self.count} in all" if self.same and self.count > 1 else ""
        if not self.also:
            return count
        shown = ", ".join(str(n) for n in self.also)
        also = f"also {self.unit}s {shown}{more_text(self.more)}"
        return f"{count}; {also}" if count else also

    def __str__(self) -> str:
        place = self.where or ("file" if self.line is None else f"line {self.line}")
        told = self.also_text
        return f"{self.kind.value}: {place}: {self.message}{f' ({told})' if told else ''}"


class ImportFailure(ValueError):
    """A file that cannot be imported. The message names where: `line 3, column 16: …`,
    or for a tape `block 4 (N004), row 57: …`. Nothing is returned when this is raised."""

    def __init__(
        self, where: str, message: str, line: int | None = None, column: int | None = None
    ) -> None:
        super().__init__(f"{where}: {message}" if where else message)
        self.where = where
        self.message = message
        self.line = line
        self.column = column


def failure(line: int, column: int | None, message: str) -> ImportFailure:
    """An ImportFailure at a text position (1-based line and column)."""
    where = f"line {line}" if column is None else f"line {line}, column {column}"
    return ImportFailure(where, message, line, column)


@mypyc_attr(allow_interpreted_subclasses=True)  # the DXF reader's DxfNotes (not compiled)
@dataclass
class Notes:
    """The report under construction; `where` turns a line number into words. The same
    message of the same kind on several lines is one note listing them."""

    entries: list[ImportNote] = field(default_factory=list)
    labels: dict[int, str] = field(default_factory=dict)
    unit: str = "line"  # what a number in the report counts: "line", or "tape block"
    _index: dict[tuple[NoteKind, str], int] = field(default_factory=dict)
    _places: dict[int, Places[int | None]] = field(default_factory=dict)

    def where(self, line: int | None) -> str:
        if line is None:
            return "file"
        return self.labels.get(line, f"{self.unit} {line}")

    def span(self, lines: list[int] | tuple[int, ...]) -> str:
        """`line 4` or `lines 4-9` (`tape blocks 4-9`) for a group of source lines."""
        if not lines:
            return "file"
        low, high = min(lines), max(lines)
        return f"{self.unit} {low}" if low == high else f"{self.unit}s {low}-{high}"

    def add(self, kind: NoteKind, line: int | None, message: str, same: str = "") -> None:
        """Report `message` at `line`: the same message of the same kind again adds its
        line to the note's places. With `same` (the text every place shares; `message` is
        this place's own), every note of that kind and `same` is one: the first place's
        message, how many places, the next few lines."""
        key = (kind, same or message)
        index = self._index.get(key)
        if index is None:
            self._index[key] = len(self.entries)
            self.entries.append(ImportNote(kind, line, message, self.where(line), same=same))
            return
        places = self._places.get(index)
        if places is None:
            places = self._places[index] = Places(self.entries[index].line, count=1)
        places.add(line)

    def merge(self, more: Notes) -> None:
        """`more`'s notes after these, as if each had been added here in turn."""
        for k, note in enumerate(more.entries):
            key = (note.kind, note.same or note.message)
            index = self._index.get(key)
            places = more._places.get(k)
            if index is None:
                self._index[key] = len(self.entries)
                self.entries.append(note)
                if places is not None:
                    self._places[len(self.entries) - 1] = places.copy()
                continue
            mine = self._places.get(index)
            if mine is None:
                mine = self._places[index] = Places(self.entries[index].line, count=1)
            mine.join(places if places is not None else Places(note.line))

    def report(self) -> list[ImportNote]:
        """The notes, each with the other lines it applies to."""
        out: list[ImportNote] = []
        for k, note in enumerate(self.entries):
            places = self._places.get(k)
            if places is None:
                out.append(replace(note, unit=self.unit))
                continue
            named = tuple(n for n in places.named if n is not None)
            out.append(
                replace(note, also=named, more=places.more, count=places.count, unit=self.unit)
            )
        return out

    def became(self, line: int | None, message: str, same: str = "") -> None:
        self.add(NoteKind.BECAME, line, message, same)

    def ignored(self, line: int | None, message: str, same: str = "") -> None:
        self.add(NoteKind.IGNORED, line, message, same)

    def assumed(self, line: int | None, message: str, same: str = "") -> None:
        self.add(NoteKind.ASSUMED, line, message, same)

    def rounded(self, line: int | None, message: str, same: str = "") -> None:
        self.add(NoteKind.ROUNDED, line, message, same)

    def needs(self, line: int | None, message: str, same: str = "") -> None:
        self.add(NoteKind.NEEDS, line, message, same)


# -- numbers --------------------------------------------------------------------------------


# LinuxCNC's test of an arc whose end is off its start's radius (rs274ngc's
# CENTER_ARC_RADIUS_TOLERANCE: 0.002 in, 0.02 mm, and 0.1 % of the radius), checked against
# `rs274` itself: the readers refuse what it refuses, and accept what it accepts.
ARC_RADIUS_TOLERANCE = {Units.INCH: 50_800, Units.MM: 20_000}


def arc_end_off(r_start: float, r_end: float, units: Units) -> bool:
    """True when an arc's end is too far off its start's radius to be one arc."""
    off = abs(r_start - r_end)
    return off > ARC_RADIUS_TOLERANCE[units] and off > 0.001 * r_start


def resolution_nm(units: Units) -> int:
    """The programming resolution in nm: 0.001 in = 25 400 nm, 0.01 mm = 10 000 nm."""
    return 25_400 if units is Units.INCH else 10_000


def quantize_nm(nm: int, units: Units) -> int:
    """`nm` rounded (half-even) to the programming resolution of `units`, still in nm."""
    step = resolution_nm(units)
    return half_even(nm, step) * step


def decimal_of(nm: int, units: Units) -> Decimal:
    """A length at the programming resolution as the block value (`Decimal`, e.g. 1.125).

    `nm` must already be a multiple of the resolution (see `quantize_nm`).
    """
    step = resolution_nm(units)
    places = 3 if units is Units.INCH else 2
    return (Decimal(nm // step) if nm % step == 0 else Decimal(nm) / step).scaleb(-places)


@lru_cache(maxsize=4096)  # a report shows the same few heights and offsets many times
def show(nm: int | float, units: Units, places: int | None = None) -> str:
    """A length for messages, in `units` with the unit's dump places (`0.7955 in`)."""
    digits = units.dump_places if places is None else places
    value = Decimal(round(nm)) / Decimal(units.nm)
    text = f"{value.quantize(Decimal(1).scaleb(-digits)):f}"
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return f"{'0' if text in ('-0', '') else text} {units.symbol}"


def feed_decimal(nm_per_min: int, units: Units) -> Decimal:
    """A feed in nm/min as a FEEDR value: ipm to 0.1, mm/min in steps of 2 (seed 001)."""
    step = limits.FEED_XY[units].step
    value = Fraction(nm_per_min, units.nm) / Fraction(step)
    return Decimal(round(value)) * step


def feed_nm(value: Decimal, units: Units) -> int:
    """A FEEDR value back in nm/min."""
    return int((value * units.nm).to_integral_value())


def show_feed(nm_per_min: int, units: Units) -> str:
    value = Fraction(nm_per_min, units.nm)
    text = f"{Decimal(value.numerator) / Decimal(value.denominator):.4f}".rstrip("0")
    return f"{text.rstrip('.') or '0'} {units.feed_symbol}"


# The control characters a text file does not have (all below 32 but tab, LF, FF and CR).
_CONTROL: Final = re.compile("[\x00-\x08\x0b\x0e-\x1f]")


# What may pad a text file's end and is not part of it: an old DOS editor's end-of-file
# mark (Ctrl-Z, 0x1A) and NULs (a tape's trailer, a transfer's block filled out). Every
# text import reads the file without them (`text_of`, `byte_lines`, `decode_text`).
PADDING: Final = b"\x1a\x00"


def text_of(data: bytes) -> str | None:
    """`data` decoded, when it is UTF-8 text without NULs or control characters (but
    tab/CR/LF/FF, and the PADDING at its end): a file to read as text, not a punch image;
    else None."""
    try:
        text = data.rstrip(PADDING).decode("utf-8")
    except UnicodeDecodeError:
        return None
    # One search in C: testing each character in Python took 0.4 s for 10^5 lines.
    return text if _CONTROL.search(text) is None else None


def is_text(data: bytes) -> bool:
    """True when `data` is text (`text_of`)."""
    return text_of(data) is not None


def split_lines(text: str) -> list[str]:
    """The lines of `text` (CR LF, CR or LF ending each; after a last line break, an
    empty line)."""
    return text.replace("\r\n", "\n").replace("\r", "\n").split("\n")


def byte_lines(data: bytes) -> Iterator[str]:
    """`split_lines` of `decode_text(data)`, one line at a time, each decoded as it is
    reached: a long file is never held as text too, nor as a list of lines. (CR and LF
    are never part of a longer UTF-8 character, so splitting the bytes splits the text.)
    Raises ImportFailure, as `decode_text` does, when the line reached is not UTF-8."""
    try:
        yield from _byte_lines(data, _after_boms(data), len(data), True)
    except UnicodeDecodeError:
        decode_text(data)  # (names the line and column)
        raise


def chunk_lines(chunks: Iterable[bytes]) -> Iterator[str]:
    """`byte_lines` of the bytes `chunks` make together (a file read a part at a time:
    `byte_lines` of it without its bytes held whole). The first chunk holds the file's
    start (its byte order marks). Raises ImportFailure when a line is not UTF-8 (the line
    reached is not known here: `decode_text` of the whole file names it)."""
    rest = b""
    first = True
    try:
        for chunk in chunks:
            data = rest + chunk if rest else chunk
            start = 0
            if first:
                start = _after_boms(data)
                if len(data) - start < len(_BOM) and _BOM.startswith(data[start:]):
                    rest = data  # (perhaps a byte order mark yet: its bytes read so far)
                    continue
                first = False
            # Up to the last line break, but a CR at the very end may be a CR LF's half.
            end = len(data) - 1 if data.endswith(b"\r") else len(data)
            cut = max(data.rfind(b"\n", start, end), data.rfind(b"\r", start, end)) + 1
            if cut <= start:
                rest = data[start:]
                continue
            yield from _byte_lines(data, start, cut, False)
            rest = data[cut:]
        yield from _byte_lines(rest, _after_boms(rest) if first else 0, len(rest), True)
    except UnicodeDecodeError as exc:
        raise ImportFailure("", f"byte 0x{exc.object[exc.start]:02X} is not text (UTF-8)") from None


def _after_boms(data: bytes) -> int:
    start = 0
    while data.startswith(_BOM, start):
        start += len(_BOM)
    return start


def _byte_lines(data: bytes, start: int, n: int, final: bool) -> Iterator[str]:
    """The lines of `data[start:n]`; when not `final`, what follows its last line break
    is not a line (the next part of the file goes on with it)."""
    if not final and data.find(b"\r", start, n) < 0:
        # LF only (nearly every file): _SPLIT bytes at a time decoded and split at once,
        # not a find, slice and decode for each line. (`data[n - 1]` is then an LF.)
        while start < n:
            end = data.rfind(b"\n", start, min(n, start + _SPLIT)) + 1
            if end <= start:  # (a line longer than _SPLIT)
                end = data.find(b"\n", start, n) + 1
            try:
                lines = data[start:end].decode("utf-8").split("\n")
            except UnicodeDecodeError:
                break  # line by line below: the lines before the bad byte are read first
            lines.pop()  # (after the last LF: nothing)
            yield from lines
            start = end
    while True:
        lf = data.find(b"\n", start, n)
        cr = data.find(b"\r", start, n if lf < 0 else lf)
        if cr >= 0:
            yield data[start:cr].decode("utf-8")
            start = cr + 2 if cr + 1 == lf else cr + 1  # (CR LF is one line break)
        elif lf >= 0:
            yield data[start:lf].decode("utf-8")
            start = lf + 1
        else:
            if final:
                yield data[start:n].rstrip(PADDING).decode("utf-8")
            return


_BOM: Final = "\ufeff".encode()
_SPLIT: Final = 1 << 16  # bytes `_byte_lines` decodes at a time


def text_lines(text: str) -> Iterator[str]:
    """`split_lines(text)` one at a time, without a list of them all (a list of a million
    lines is 70 MB) or a copy of the text."""
    start = 0
    n = len(text)
    while True:
        lf = text.find("\n", start)
        cr = text.find("\r", start, n if lf < 0 else lf)
        if cr >= 0:
            yield text[start:cr]
            start = cr + 2 if cr + 1 == lf else cr + 1  # (CR LF is one line break)
        elif lf >= 0:
            yield text[start:lf]
            start = lf + 1
        else:
            yield text[start:]
            return


def check_digits(digits: str) -> bool:
    """True when a number's digits are few enough to be a real value (MAX_DIGITS)."""
    return len(digits.lstrip("0")) <= MAX_DIGITS


def decode_text(data: bytes) -> str:
    """The file as text. Raises ImportFailure naming line and column of a byte that is not
    UTF-8."""
    try:
        return data.rstrip(PADDING).decode("utf-8").lstrip("\ufeff")
    except UnicodeDecodeError as exc:
        before = data[: exc.start]
        line = before.count(b"\n") + 1
        column = exc.start - (before.rfind(b"\n") + 1) + 1
        raise ImportFailure(
            f"line {line}, column {column}",
            f"byte 0x{data[exc.start]:02X} is not text (UTF-8)",
            line,
        ) from None
