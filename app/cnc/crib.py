"""A program and the shop's tool crib: picking a crib tool into Data Block 0, telling where
the program's copy differs from the crib, and the feeds and speeds offered for the tools.

A program keeps its own copy of each tool it picked (app.cnc.blocks.Tool: the crib's
number, DIA, NAME, type, flutes, tool material, length out of the holder, a tap's pitch and
hand, and TCAL when the crib has measured it), so it never changes because the crib did;
`differences` says where the two part. The copy is in the program's units, rounded to the
program's resolution as every import's tools are (0.001 in, 0.01 mm: a 3/16 in end mill is
DIA 0.188), and compared after that rounding. Pure core: no web, database or serial code.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from decimal import Decimal
from fractions import Fraction
from typing import TYPE_CHECKING

from app.cnc.blocks import Program, Tool
from app.cnc.cutting import Cutter, Offer, offer
from app.cnc.kinds import REGISTRY
from app.cnc.recognition.common import decimal_of, quantize_nm
from app.cnc.spindle import Spindle
from app.cnc.tools import CribTool, Hand, PitchUnit, ToolMaterial, ToolType
from app.cnc.units import Units, format_decimal, to_nm

if TYPE_CHECKING:
    from app.cnc.machine import MachineModel

# What a pick copies from the crib into Data Block 0 (TCAL too, where the crib has one).
COPIED: tuple[str, ...] = ("diameter", "name", "crib", "kind", "flutes", "tool_material")
COPIED += ("length", "pitch", "pitch_unit", "hand", "tcal")


def in_units(value: Decimal, source: Units, units: Units) -> Decimal:
    """A crib length in a program's units, rounded (half-even) to the program's resolution."""
    return decimal_of(quantize_nm(to_nm(value, source), units), units)


def copy_of(crib: CribTool, number: int, units: Units) -> Tool:
    """Crib tool `crib` as tool `number` of a program in `units` (no RPM: the program's)."""
    return Tool(
        number=number,
        diameter=in_units(crib.diameter, crib.units, units),
        tcal=None if crib.tcal is None else in_units(crib.tcal, crib.units, units),
        name=crib.name,
        crib=crib.number,
        kind=crib.kind,
        flutes=crib.flutes,
        tool_material=crib.material,
        length=None if crib.length is None else in_units(crib.length, crib.units, units),
        pitch=crib.pitch,
        pitch_unit=crib.pitch_unit,
        hand=crib.hand,
    )


def pick(
    current: Tool | None,
    crib: CribTool,
    number: int,
    units: Units,
    offered_rpm: int | None = None,
) -> Tool:
    """Tool `number` after picking `crib` into it: the crib's DIA, name, type, flutes,
    tool material, length out, pitch and hand (the tool picked is that tool), its TCAL
    where the crib has one; the RPM and coolant as they were, the offered RPM only where
    none was typed (an offer never overwrites a typed value)."""
    copied = copy_of(crib, number, units)
    if current is None:
        return replace(copied, rpm=offered_rpm)
    return replace(
        copied,
        rpm=current.rpm if current.rpm is not None else offered_rpm,
        coolant=current.coolant,
        tcal=copied.tcal if copied.tcal is not None else current.tcal,
    )


def differences(tool: Tool, crib: CribTool | None, units: Units) -> list[str]:
    """Where a program's tool differs from the crib tool it was picked from: `DIA 0.498
    here, 0.500 in the crib`, one line per field (TCAL only where the crib has one); one
    line when the crib no longer has it."""
    if tool.crib is None:
        return []
    if crib is None:
        return [f"T{tool.crib} is no longer in the crib"]
    copied = copy_of(crib, tool.number, units)
    found = []
    for name in COPIED:
        if name in ("crib", "pitch_unit") or (name == "tcal" and copied.tcal is None):
            continue
        here, there = getattr(tool, name), getattr(copied, name)
        if name == "pitch" and here is not None and there is not None:
            same = (here, tool.pitch_unit) == (there, copied.pitch_unit)
        else:
            same = here == there
        if not same:
            label = REGISTRY.label(Tool, name)
            found.append(f"{label} {_shown(tool, name)} here, {_shown(copied, name)} in the crib")
    return found


def _shown(tool: Tool, name: str) -> str:
    value = getattr(tool, name)
    if value is None or value == "":
        return "none"
    if name == "pitch":
        unit = "TPI" if tool.pitch_unit is PitchUnit.TPI else "mm"
        return f"{format_decimal(value)} {unit}"
    if isinstance(value, Decimal):
        return format_decimal(value)
    if isinstance(value, ToolType | ToolMaterial):
        return value.label
    if isinstance(value, Hand):
        return f"{value.value} hand"
    return str(value)


# -- feeds and speeds for a program's tools --------------------------------------------------


def cutter_of(tool: Tool, units: Units) -> Cutter | None:
    """What the speeds and feeds need of a program's tool (None: no type or no DIA)."""
    if tool.kind is None or tool.diameter is None or tool.diameter <= 0:
        return None
    diameter = Fraction(tool.diameter)
    if units is Units.MM:
        diameter /= Fraction(254, 10)
    return Cutter(
        tool.kind,
        diameter,
        tool.flutes,
        tool.tool_material or ToolMaterial.HSS,
        tool.pitch,
        tool.pitch_unit,
        tool.hand,
    )


def tool_offer(
    program: Program,
    tool: Tool,
    spindle: Spindle | None = None,
    max_feed: Decimal | None = None,
    *,
    own_rpm: bool = True,
) -> Offer | None:
    """The figures offered for a program's tool in its stated material (None: no material
    stated, or the tool's type or DIA not known). With `own_rpm`, feeds follow the RPM the
    tool is set to run at, where it has one."""
    cutter = cutter_of(tool, program.units)
    if program.material is None or cutter is None:
        return None
    rpm = tool.rpm if own_rpm else None
    return offer(program.material, cutter, program.units, spindle, rpm, max_feed)


@dataclass(frozen=True)
class FeedOffers:
    """FEEDR XY and FEEDR Z offered for a new block with each tool of Data Block 0 (as
    form text), for the block entry form."""

    by_tool: dict[int, dict[str, str]]

    def for_tool(self, number: int) -> dict[str, str]:
        return self.by_tool.get(number, {})


def feed_offers(program: Program, spindle: Spindle | None = None) -> FeedOffers:
    """The feeds each tool of Data Block 0 is offered with (its own RPM, else the offered
    one): FEEDR XY for milling tools, FEEDR Z for drills, reamers, boring bars and taps."""
    found: dict[int, dict[str, str]] = {}
    for tool in program.block0.tools:
        figures = tool_offer(program, tool, spindle)
        if figures is None:
            continue
        values = {}
        if figures.feed_xy is not None:
            values["feed_xy"] = f"{figures.feed_xy:f}"
        if figures.feed_z is not None:
            values["feed_z"] = f"{figures.feed_z:f}"
        if values:
            found[tool.number] = values
    return FeedOffers(found)


def machine_limits(
    machine: MachineModel | None, units: Units
) -> tuple[Spindle | None, Decimal | None]:
    """A machine's spindle and its largest feed in `units` per minute (None each where the
    machine, or its profile, gives none: the control's spindle, FEEDR's own limit)."""
    if machine is None:
        return None, None
    feed = machine.max_feed
    if feed is not None and machine.units is not units:
        feed = feed * Decimal("25.4") if units is Units.MM else feed / Decimal("25.4")
    return machine.spindle, feed
