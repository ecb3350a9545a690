"""The shop's tools: what a tool is, as the tool crib keeps it and a program copies it.

A crib tool (`CribTool`) is one physical tool of the shop: its number (the T number of the
machine's tool table), its name ("#7 DRILL", "1/4-20 TAP"), its type, cutting diameter,
flutes, tool material, how far it sticks out of its holder, its measured length offset
(TCAL, the Z of the machine's tool table) and, for a tap or thread mill, its pitch (threads
per inch or millimetres) and hand. Lengths are in the tool's own `units`, to 0.0001 in or
0.001 mm (a 3/16 in end mill is 0.1875: finer than a program's 0.001 in, which a program's
copy is rounded to, app.cnc.crib).

The storage (app/storage/crib.py) keeps crib tools with revisions; a program keeps its own
copy of what it picked in Data Block 0 (app.cnc.blocks.Tool), so a program never changes
because the crib did. Pure core: no web, database or serial code.
"""

from __future__ import annotations

import enum
import re
from dataclasses import dataclass
from decimal import Decimal
from fractions import Fraction

from app.cnc import limits
from app.cnc.kinds import REGISTRY, Value, prompt
from app.cnc.text import NOTES_LENGTH, text_fault
from app.cnc.units import Units, format_decimal


class ToolType(enum.Enum):
    """What a tool is; it decides which speeds and feeds table applies (app.cnc.cutting)."""

    END_MILL = "end_mill"
    DRILL = "drill"
    CENTRE_DRILL = "centre_drill"
    SPOT_DRILL = "spot_drill"
    REAMER = "reamer"
    TAP = "tap"
    BORING_BAR = "boring_bar"
    CHAMFER_MILL = "chamfer_mill"
    THREAD_MILL = "thread_mill"
    ENGRAVER = "engraver"
    FACE_MILL = "face_mill"

    @property
    def label(self) -> str:
        """As the machinist says it: `end mill`, `centre drill`."""
        return self.value.replace("_", " ")


class ToolMaterial(enum.Enum):
    """What the cutting edges are made of (carbide runs at twice HSS's surface speed)."""

    HSS = "hss"
    COBALT = "cobalt"
    CARBIDE = "carbide"

    @property
    def label(self) -> str:
        return {"hss": "HSS", "cobalt": "cobalt HSS", "carbide": "carbide"}[self.value]


class Hand(enum.Enum):
    """A thread's hand: a left-hand tap runs in reverse (a negative RPM)."""

    RIGHT = "right"
    LEFT = "left"


class PitchUnit(enum.Enum):
    """How a pitch is given: threads per inch (1/4-20) or millimetres per thread (M6x1)."""

    TPI = "tpi"
    MM = "mm"


THREADING = frozenset({ToolType.TAP, ToolType.THREAD_MILL})
"""The types that have a pitch and a hand."""

MAX_NUMBER = 99_999
"""A crib number is the T number of the machine's tool table: LinuxCNC takes up to 99 999."""
MAX_FLUTES = 99
MAX_TPI = Decimal(100)
MAX_PITCH_MM = Decimal(10)
CRIB_RESOLUTION = {Units.INCH: Decimal("0.0001"), Units.MM: Decimal("0.001")}
"""A crib tool's lengths go to 0.0001 in / 0.001 mm (a tool's size as its maker gives it)."""

# A tool's name goes into G-code comments, tool tables and onto the set-up sheet: what a
# comment holds (no parentheses or semicolons, which end it), short enough for a tool
# table's column.
TOOL_NAME_LENGTH = 24
TOOL_NAME_CHARACTERS = frozenset(
    "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789 .,-:/#+=*"
)


def tool_name_fault(name: str) -> str:
    """What is wrong with a tool's name ("" when nothing): too long, or a character a
    comment cannot hold."""
    allowed = f"allowed up to {TOOL_NAME_LENGTH} letters, digits, spaces and . , - : / # + = *"
    if len(name) > TOOL_NAME_LENGTH:
        return f"{len(name)} characters is too long; {allowed}"
    bad = sorted({c for c in name if c not in TOOL_NAME_CHARACTERS})
    if bad:
        return (
            "has characters a G-code comment cannot hold: "
            + " ".join(repr(c) for c in bad)
            + f"; {allowed}"
        )
    return ""


LENGTH, COUNT, CHOICE, TEXT = Value.LENGTH, Value.COUNT, Value.CHOICE, Value.TEXT


@dataclass(frozen=True, kw_only=True)
class CribTool:
    """One tool of the shop's crib (see the module docstring). `length` is how far it
    sticks out of its holder; `tcal` its length offset as the machine's tool table holds it
    (None: not measured). `pitch` is in `pitch_unit` (None: not a threading tool)."""

    number: int = prompt("NUMBER", COUNT)
    name: str = prompt("NAME", TEXT)
    kind: ToolType = prompt("TYPE", CHOICE)
    units: Units = prompt("UNITS", CHOICE, Units.INCH)
    diameter: Decimal = prompt("DIA", LENGTH)
    flutes: int | None = prompt("FLUTES", COUNT, None)
    material: ToolMaterial = prompt("TOOL MATERIAL", CHOICE, ToolMaterial.HSS)
    length: Decimal | None = prompt("LENGTH OUT", LENGTH, None)
    tcal: Decimal | None = prompt("TCAL", LENGTH, None)
    pitch: Decimal | None = prompt("PITCH", LENGTH, None)
    pitch_unit: PitchUnit = prompt("PITCH UNIT", CHOICE, PitchUnit.TPI)
    hand: Hand = prompt("HAND", CHOICE, Hand.RIGHT)
    notes: str = prompt("NOTES", TEXT, "")

    @property
    def title(self) -> str:
        """`T12 1/4-20 TAP`."""
        return f"T{self.number} {self.name}"

    def describe(self) -> str:
        """One line for lists: `T12 1/4-20 TAP: tap, 0.25 in, HSS, 4 flutes, 20 TPI`."""
        parts = [
            self.kind.label,
            f"{format_decimal(self.diameter)} {self.units.symbol}",
            self.material.label,
        ]
        if self.flutes is not None:
            parts.append(f"{self.flutes} flute" + ("s" if self.flutes != 1 else ""))
        if self.pitch is not None:
            parts.append(pitch_text(self.pitch, self.pitch_unit))
            if self.hand is Hand.LEFT:
                parts.append("left hand")
        if self.length is not None:
            parts.append(f"{format_decimal(self.length)} {self.units.symbol} out")
        return f"{self.title}: " + ", ".join(parts)


def pitch_text(pitch: Decimal, unit: PitchUnit) -> str:
    """`20 TPI`, `1 mm pitch`."""
    return (
        f"{format_decimal(pitch)} TPI"
        if unit is PitchUnit.TPI
        else f"{format_decimal(pitch)} mm pitch"
    )


def lead_per_rev(pitch: Decimal, unit: PitchUnit, units: Units) -> Fraction:
    """How far a thread advances in one turn, exactly, in `units` (in or mm): 1/TPI inch
    or the pitch in mm (25.4 mm to the inch, exactly). A tap feeds this far per turn."""
    if unit is PitchUnit.TPI:
        inches = 1 / Fraction(pitch)
        return inches if units is Units.INCH else inches * Fraction(254, 10)
    mm = Fraction(pitch)
    return mm if units is Units.MM else mm / Fraction(254, 10)


def tool_faults(tool: CribTool) -> list[tuple[str, str]]:
    """What is wrong with a crib tool: (field label, message) for each problem, empty when
    it can be kept. Each message says what is wrong and what is allowed."""
    faults: list[tuple[str, str]] = []
    u = tool.units
    if not 1 <= tool.number <= MAX_NUMBER:
        faults.append(
            (
                "NUMBER",
                f"{tool.number} is outside the allowed range 1 to {MAX_NUMBER} "
                "(the T number of the machine's tool table)",
            )
        )
    if not tool.name.strip():
        faults.append(("NAME", "missing; every tool in the crib needs a name (#7 DRILL)"))
    elif fault := tool_name_fault(tool.name):
        faults.append(("NAME", fault))
    faults += _length_faults("DIA", tool.diameter, u, positive=True)
    if tool.flutes is not None and not 1 <= tool.flutes <= MAX_FLUTES:
        faults.append(("FLUTES", f"{tool.flutes} is outside the allowed range 1 to {MAX_FLUTES}"))
    if tool.length is not None:
        faults += _length_faults("LENGTH OUT", tool.length, u, positive=True)
    if tool.tcal is not None:
        faults += _length_faults("TCAL", tool.tcal, u)
    faults += thread_faults(tool.kind, tool.pitch, tool.pitch_unit, tool.hand)
    if fault := text_fault(tool.notes, NOTES_LENGTH):
        faults.append(("NOTES", fault))
    return faults


def thread_faults(
    kind: ToolType | None, pitch: Decimal | None, unit: PitchUnit, hand: Hand
) -> list[tuple[str, str]]:
    """A pitch and hand belong to a tap or thread mill, and a tap needs its pitch: (field
    label, message) for each problem. Shared by the crib and Data Block 0's copy."""
    faults: list[tuple[str, str]] = []
    threading = kind in THREADING
    if pitch is None:
        if kind is ToolType.TAP:
            faults.append(
                (
                    "PITCH",
                    "missing; a tap feeds one pitch per turn, so the crib needs it "
                    "(threads per inch, 20 for a 1/4-20, or mm, 1 for an M6x1)",
                )
            )
    elif not threading:
        what = kind.label if kind is not None else "tool without a type"
        faults.append(("PITCH", f"a pitch is for a tap or a thread mill, not a {what}"))
    else:
        high = MAX_TPI if unit is PitchUnit.TPI else MAX_PITCH_MM
        shown = pitch_text(pitch, unit)
        if not 0 < pitch <= high:
            faults.append(
                ("PITCH", f"{shown} is outside the allowed range: more than 0, up to {high}")
            )
        elif pitch != pitch.quantize(Decimal("0.001")):
            faults.append(("PITCH", f"{shown} has too many decimals; pitches go to 0.001"))
    if hand is Hand.LEFT and kind is not None and not threading:
        faults.append(
            ("HAND", f"a {kind.label} has no hand; left hand is for a tap or a thread mill")
        )
    return faults


def _length_faults(
    label: str, value: Decimal, units: Units, *, positive: bool = False
) -> list[tuple[str, str]]:
    high = limits.MAX_DIMENSION[units]
    step = CRIB_RESOLUTION[units]
    shown = f"{format_decimal(value)} {units.symbol}"
    if positive and value <= 0:
        return [(label, f"{shown} must be more than 0; allowed up to {high} {units.symbol}")]
    if not -high <= value <= high:
        return [(label, f"{shown} is outside the allowed range {-high} to {high} {units.symbol}")]
    if value != value.quantize(step):
        return [
            (
                label,
                f"{shown} has too many decimals; a crib tool's sizes go to {step} {units.symbol}",
            )
        ]
    return []


# -- what a name says ----------------------------------------------------------------------

# Words in a name (or a tool table's comment) that say the type, most specific first.
_KIND_WORDS: tuple[tuple[str, ToolType], ...] = (
    (r"CENT(?:RE|ER)\s*DRILL|\bC/?D\b", ToolType.CENTRE_DRILL),
    (r"SPOT", ToolType.SPOT_DRILL),
    (r"THREAD\s*MILL", ToolType.THREAD_MILL),
    (r"CHAMF", ToolType.CHAMFER_MILL),
    (r"FACE\s*MILL|SHELL\s*MILL|FLY\s*CUT", ToolType.FACE_MILL),
    (r"BOR(?:E|ING)", ToolType.BORING_BAR),
    (r"ENGRAV", ToolType.ENGRAVER),
    (r"REAM", ToolType.REAMER),
    (r"\bTAP\b", ToolType.TAP),
    (r"DRILL", ToolType.DRILL),
    (r"END\s*MILL|ENDMILL|\bE/?M\b|\bFLAT\b|\bBALL\b", ToolType.END_MILL),
)

_TPI = re.compile(r"(?:\d+/\d+|#\d+|\d*\.\d+|\d+)\s*-\s*(\d+(?:\.\d+)?)\b", re.ASCII)
_METRIC = re.compile(r"\bM\d+(?:\.\d+)?\s*[xX×]\s*(\d+(?:\.\d+)?)\b")


def kind_in(text: str) -> ToolType | None:
    """The type a name or comment names (`1/4-20 TAP` → tap), or None."""
    upper = text.upper()
    for pattern, kind in _KIND_WORDS:
        if re.search(pattern, upper):
            return kind
    return None


def thread_in(text: str) -> tuple[Decimal, PitchUnit] | None:
    """The pitch a thread size in a name gives: `1/4-20` → 20 TPI, `M6x1` → 1 mm."""
    found = _METRIC.search(text.upper())
    if found:
        return Decimal(found.group(1)), PitchUnit.MM
    found = _TPI.search(text)
    if found:
        return Decimal(found.group(1)), PitchUnit.TPI
    return None


def tool_changes(old: CribTool, new: CribTool) -> list[str]:
    """`DIA 0.5 → 0.498` for each field that differs, for a revision's summary."""
    changes = []
    for f in REGISTRY.fields(CribTool):
        a, b = getattr(old, f.name), getattr(new, f.name)
        if a != b:
            changes.append(f"{f.label} {_shown(a)} → {_shown(b)}")
    return changes


def _shown(value: object) -> str:
    if value is None or value == "":
        return "-"
    if isinstance(value, Decimal):
        return format_decimal(value)
    if isinstance(value, ToolType | ToolMaterial):
        return value.label
    if isinstance(value, enum.Enum):
        return str(value.value)
    return str(value)
