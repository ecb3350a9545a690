"""LinuxCNC tool tables (`.tbl`): reading one into the crib, writing the crib or a
program's tools as one.

A line of a LinuxCNC tool table (LinuxCNC documentation, "Tool Table Format") is

    T7 P7 D0.2010 Z-1.5000 ;#7 DRILL

T the tool number, P the pocket, D the diameter, X Y Z A B C U V W the offsets (Z the
length offset `G43 H7` applies), I J Q a lathe tool's angles and orientation, and after
`;` a comment. Values are in the machine's units (its INI file's LINEAR_UNITS), which the
file does not say: the reader and the writer are told (`units`).

Writing: the crib's tools by their crib numbers (T = P = the number, D the diameter, Z the
measured length offset TCAL where the crib has one, the name as the comment); or a
program's Data Block 0 tools by the numbers the program calls them (`T3 M6` / `G43 H3`):
D its DIA, Z its TCAL where known, so the G-code's `G43 H` finds the length the set-up
sheet lists. A length not known is left out (LinuxCNC reads it as 0: touch the tool off).

Reading: each T line becomes a crib tool: number T, diameter D, TCAL Z, the name from the
comment (characters a name cannot hold left out, cut to 24), its type, flutes, tool
material and a tap's pitch and hand from the words of the comment (`1/4-20 TAP`: a
right-hand tap of 20 TPI; `LH`: left hand);
what is not carried (pockets other than T, X/Y and rotary offsets, lathe words) and what was
assumed is reported line by line. A line that cannot be read is a TableError naming its line
and column, and nothing is read. Pure core: no web, database or serial code.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from decimal import ROUND_HALF_EVEN, Decimal

from app.cnc.blocks import Program
from app.cnc.numbers import NumberError, parse_decimal
from app.cnc.tools import (
    CRIB_RESOLUTION,
    MAX_NUMBER,
    TOOL_NAME_CHARACTERS,
    TOOL_NAME_LENGTH,
    CribTool,
    Hand,
    PitchUnit,
    ToolMaterial,
    ToolType,
    kind_in,
    thread_in,
)
from app.cnc.units import Units

MAX_TABLE_LINES = 10_000
"""LinuxCNC's own tool table holds at most 1000 tools (CANON_POCKETS_MAX); ten times that is
a file that is not a tool table."""
PLACES = {Units.INCH: 4, Units.MM: 3}
"""Decimals written: a crib tool's resolution (0.0001 in, 0.001 mm)."""
WORDS = "TPXYZABCUVWDIJQ"
_WORD = re.compile(r"([A-Za-z])\s*([+-]?[0-9.]+)")


class TableError(ValueError):
    """A tool table that cannot be read: the message names the line and column."""


@dataclass(frozen=True)
class TableTool:
    """One line of a tool table, in the table's units: T, P, D, Z and the comment."""

    number: int
    pocket: int
    diameter: Decimal | None = None
    length: Decimal | None = None
    comment: str = ""
    line: int = 0
    others: tuple[str, ...] = ()  # words read but not carried (X, Y, A…, I, J, Q)


@dataclass
class TableRead:
    """What a table read gave: its tools and, per line, what was assumed or not carried."""

    tools: list[CribTool] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def text(self) -> str:
        return "".join(f"{note}\n" for note in self.notes)


# -- reading ---------------------------------------------------------------------------------


def parse_table(text: str) -> list[TableTool]:
    """The T lines of a tool table. Raises TableError (line and column) for a line that
    is not one, a number that cannot be read, or a tool listed twice."""
    lines = text.splitlines()
    if len(lines) > MAX_TABLE_LINES:
        raise TableError(f"{len(lines)} lines; a tool table has at most {MAX_TABLE_LINES}")
    found: list[TableTool] = []
    seen: dict[int, int] = {}
    for n, raw in enumerate(lines, start=1):
        body, _, comment = raw.partition(";")
        if not body.strip():
            continue
        words: dict[str, Decimal] = {}
        at = 0
        stripped = body.rstrip()
        while at < len(stripped):
            if stripped[at].isspace():
                at += 1
                continue
            match = _WORD.match(stripped, at)
            column = at + 1
            if match is None:
                raise TableError(
                    f"line {n}, column {column}: {stripped[at : at + 12]!r} is not a word of a "
                    f"tool table; a line is T<n> P<n> D<dia> Z<length> … ;comment"
                )
            letter = match.group(1).upper()
            if letter not in WORDS:
                raise TableError(
                    f"line {n}, column {column}: {letter} is not a tool table word; "
                    f"allowed: {' '.join(WORDS)}"
                )
            if letter in words:
                raise TableError(f"line {n}, column {column}: {letter} is given twice")
            try:
                words[letter] = parse_decimal(match.group(2), exponent=False)
            except NumberError as exc:
                raise TableError(f"line {n}, column {column + 1}: {letter}: {exc}") from None
            at = match.end()
        if "T" not in words:
            raise TableError(f"line {n}, column 1: no T word; each line names its tool (T7)")
        number = _whole(words["T"], n, "T")
        if not 1 <= number <= MAX_NUMBER:
            raise TableError(f"line {n}: T{number} is outside the tool numbers 1 to {MAX_NUMBER}")
        if number in seen:
            raise TableError(f"line {n}: T{number} is listed twice (also on line {seen[number]})")
        seen[number] = n
        pocket = _whole(words["P"], n, "P") if "P" in words else number
        others = tuple(f"{k}{v}" for k, v in words.items() if k not in "TPDZ" and v != 0)
        found.append(
            TableTool(
                number,
                pocket,
                words.get("D"),
                words.get("Z"),
                comment.strip(),
                n,
                others,
            )
        )
    return found


def _whole(value: Decimal, line: int, letter: str) -> int:
    if value != value.to_integral_value():
        raise TableError(f"line {line}: {letter}{value} is not a whole number")
    return int(value)


def read_table(text: str, units: Units) -> TableRead:
    """The crib tools a tool table in `units` describes, with what was assumed and not
    carried. Raises TableError naming the line for what cannot be read."""
    result = TableRead()
    for entry in parse_table(text):
        where = f"line {entry.line}, T{entry.number}"
        if entry.diameter is None or entry.diameter <= 0:
            result.notes.append(
                f"{where}: no diameter (D{entry.diameter or 0}): not read; a crib tool needs its "
                "cutting diameter"
            )
            continue
        name, changed = name_of(entry.comment, entry.number)
        if changed:
            result.notes.append(
                f"{where}: named {name!r} (the comment {entry.comment!r} {changed})"
            )
        kind = kind_in(entry.comment)
        if kind is None:
            kind = ToolType.END_MILL
            result.notes.append(f"{where}: the comment names no type: taken as an end mill")
        thread = thread_in(entry.comment) if kind in (ToolType.TAP, ToolType.THREAD_MILL) else None
        if kind is ToolType.TAP and thread is None:
            result.notes.append(
                f"{where}: a tap whose comment gives no thread (1/4-20, M6x1): give its pitch "
                "in the crib"
            )
        diameter = _rounded(entry.diameter, units, where, "D", result)
        tcal = None if entry.length is None else _rounded(entry.length, units, where, "Z", result)
        if entry.pocket != entry.number:
            result.notes.append(f"{where}: pocket P{entry.pocket} is not kept (written as P = T)")
        if entry.others:
            result.notes.append(f"{where}: not carried: {' '.join(entry.others)}")
        result.tools.append(
            CribTool(
                number=entry.number,
                name=name,
                kind=kind,
                units=units,
                diameter=diameter,
                flutes=_flutes(entry.comment),
                material=_material(entry.comment),
                tcal=tcal,
                pitch=thread[0] if thread else None,
                pitch_unit=thread[1] if thread else PitchUnit.TPI,
                hand=Hand.LEFT if thread and _left_hand(entry.comment) else Hand.RIGHT,
            )
        )
    return result


def name_of(comment: str, number: int) -> tuple[str, str]:
    """A crib name from a tool table comment, and what had to change ("" when nothing):
    the characters a name cannot hold left out, cut to its length; `T7` for no comment."""
    kept = " ".join("".join(c for c in comment if c in TOOL_NAME_CHARACTERS).split())
    changed = []
    if kept != " ".join(comment.split()):
        changed.append("holds characters a name cannot")
    if len(kept) > TOOL_NAME_LENGTH:
        kept = kept[:TOOL_NAME_LENGTH].rstrip()
        changed.append(f"is longer than {TOOL_NAME_LENGTH} characters")
    if not kept:
        return f"T{number}", "is empty" if not comment.strip() else " and ".join(changed)
    return kept, " and ".join(changed)


def _rounded(value: Decimal, units: Units, where: str, letter: str, result: TableRead) -> Decimal:
    step = CRIB_RESOLUTION[units]
    rounded = value.quantize(step, rounding=ROUND_HALF_EVEN)
    if rounded != value:
        result.notes.append(f"{where}: {letter}{value} rounded to {rounded}")
    # As a machinist writes it: D+0.125000 is 0.125.
    return rounded.normalize() if rounded else Decimal(0)


def _left_hand(comment: str) -> bool:
    return re.search(r"\bLH\b|LEFT", comment.upper()) is not None


def _flutes(comment: str) -> int | None:
    found = re.search(r"\b(\d{1,2})\s*-?\s*(?:FL|FLT|FLUTES?)\b", comment.upper())
    return int(found.group(1)) if found and int(found.group(1)) >= 1 else None


def _material(comment: str) -> ToolMaterial:
    upper = comment.upper()
    if re.search(r"CARB|\bSOLID\b", upper):
        return ToolMaterial.CARBIDE
    if re.search(r"COBALT|\bHSCO\b|\bM42\b", upper):
        return ToolMaterial.COBALT
    return ToolMaterial.HSS


# -- writing ---------------------------------------------------------------------------------


def write_table(tools: Iterable[TableTool], units: Units) -> str:
    """A LinuxCNC tool table of `tools` (values in `units`), one line per tool in number
    order: `T7 P7 D0.2010 Z-1.5000 ;#7 DRILL` (D and Z left out where not known)."""
    lines = []
    for tool in sorted(tools, key=lambda t: t.number):
        words = [f"T{tool.number}", f"P{tool.pocket}"]
        if tool.diameter is not None:
            words.append(f"D{_fixed(tool.diameter, units)}")
        if tool.length is not None:
            words.append(f"Z{_fixed(tool.length, units)}")
        line = " ".join(words)
        if tool.comment:
            line += f" ;{tool.comment}"
        lines.append(line)
    return "".join(f"{line}\n" for line in lines)


def _fixed(value: Decimal, units: Units) -> str:
    places = PLACES[units]
    return f"{value.quantize(Decimal(1).scaleb(-places), rounding=ROUND_HALF_EVEN):f}"


def converted(value: Decimal, source: Units, units: Units) -> Decimal:
    """A crib length in `units` (25.4 mm to the inch), rounded half-even to a crib tool's
    resolution there (0.0001 in, 0.001 mm)."""
    if source is units:
        return value
    exact = value * Decimal("25.4") if units is Units.MM else value / Decimal("25.4")
    return exact.quantize(CRIB_RESOLUTION[units], rounding=ROUND_HALF_EVEN).normalize()


def crib_table(tools: Iterable[CribTool], units: Units) -> list[TableTool]:
    """The crib's tools as tool table lines in `units`, by their crib numbers."""
    return [
        TableTool(
            tool.number,
            tool.number,
            converted(tool.diameter, tool.units, units),
            None if tool.tcal is None else converted(tool.tcal, tool.units, units),
            tool.name,
        )
        for tool in tools
    ]


def program_table(program: Program) -> list[TableTool]:
    """Data Block 0's tools as tool table lines in the program's units, by the numbers the
    program calls them: DIA, and TCAL as the length offset where known."""
    return [
        TableTool(tool.number, tool.number, tool.diameter, tool.tcal, tool.name)
        for tool in program.block0.tools
    ]
