"""Feeds and speeds: the RPM and feeds offered for a tool in a stated workpiece material.

    RPM        = surface speed × 12 / (π × D)        (sfm, D in inches; metric alike:
                                                      m/min × 1000 / (π × D mm), the same RPM)
    FEEDR XY   = RPM × flutes × chip load             (milling tools)
    FEEDR Z    = RPM × feed per revolution            (drills, reamers, boring bars)
    TAP        = RPM × pitch, exactly                 (a tap feeds one pitch per turn)

The RPM is rounded down to a whole rpm (never faster than the table), then clamped to the
machine's spindle (app.cnc.spindle: the control's 60-500 low and 500-4000 high gear, or
the machine profile's range): above the top it runs at the top; below the bottom at the
bottom (faster than the table, said in a note); in a gap between two gears at the top of
the lower gear. A tap's RPM is then lowered to the nearest speed whose feed FEEDR Z can hold
exactly (0.1 ipm, or 2 mm/min steps). Feeds are rounded down to the field's step and kept
within its range and the machine's largest feed. Offered values are offers: the editor never
writes one over a value typed (app.web), and feeds are worked out from the RPM the tool is
set to run at when it has one.

The figures and where they come from (docs/tools.md has the table):

- Milling surface speeds, HSS: Grizzly G0619 mill manual, Figure 20 "Cutting Speeds for
  High Speed Steel (HSS) Cutting Tools" (aluminium & alloys 300 sfm, brass & bronze 150,
  cast iron soft 80, stainless 60, plastics 300-800: the low end), whose note reads "For
  carbide cutting tools, double the cutting speed ... refer to the Machinery's Handbook";
  1018: Machinery's Handbook, "Recommended Cutting Speeds in Feet per Minute for Turning,
  Milling, Drilling, and Reaming Plain Carbon and Alloy Steels", AISI 1006-1026 at
  125-175 HB: milling 110, drilling 90 sfm.
- Drilling surface speeds, HSS: U.S. Navy training manual (Machinery Repairman, "Holding
  the work"), high-speed steel twist drills: aluminium 200-300, brass 200-300, cast iron
  70-150 sfm (the low ends); carbide "two to three times these speeds" (we take two);
  304: Machinery's Handbook, "Recommended Cutting Speeds ... Drilling and Reaming Stainless
  Steels", austenitic 201-348 annealed 135-185 HB: drilling HSS 55 sfm; acetal: Norseman
  Drill, "Recommended Speeds ... with H.S.S. Drills", plastics 100-300 sfm (the low end).
- Reamers: half the drilling speed (U.S. Army TM 1-420 §37a: "machine reamer speeds are
  approximately one-half that used for drilling").
- Tapping surface speeds, HSS taps: Clarkson-Osborn, "Recommended Cutting Speeds For HSS
  Taps" (plain carbon steel 50-60, austenitic stainless 16-22, cast iron 150-300 HB 30-40,
  brass 50-65, aluminium silicon-alloyed under 5 % 82-150, thermoplastics 60-105 sfm: "start
  at the lower end of the range", which we take).
- Chip loads (in per tooth, by cutter diameter 1/8, 1/4, 1/2, 3/4, 1 in): Protocutter,
  "Speeds and Feeds For Carbide End Mills" (low carbon steels .0005 .001 .003 .0045 .0065;
  stainless up to 40 Rc .0005 .001 .003 .004 .006; cast iron .0005 .001 .003 .005 .007;
  brass .001 .002 .003 .004 .005; plastics .0015 .003 .006 .010 .012; aluminium .002 .004
  .006 .008 from 1/4 in up); the aluminium 1/8 in figure from Torbide Tooling's carbide end
  mill chart, .001 (Protocutter prints .005, more than its own 1/4 in figure). Between two
  diameters the chip load is read on the straight line between them; under 1/8 in it
  shrinks in proportion to the diameter; over 1 in it stays at the 1 in figure.
- Drill feeds per revolution (the Navy manual): No. 80-1/8 in .001-.002, 1/8-1/4 in
  .002-.004, 1/4-1/2 in .004-.007, 1/2-1 in .007-.015, over 1 in .015-.025 in/rev; read on
  the straight line across each range by diameter (1/4 in: .004, 3/8 in: .0055), and the
  lower figure of each range for a hard material (304: "use the lower feed rate ... for the
  harder materials"); over 1 in, .015.

Our readings (no table gives them): a centre or spot drill runs at the drilling speed and
feed of its diameter; a reamer feeds per turn as a drill of its diameter; a boring bar runs
at the milling speed and feeds per turn its flutes (1 when not given) × the chip load; a
cobalt HSS tool takes the HSS figures; end mills, face, chamfer and thread mills and
engravers take the milling speed and chip load of their diameter (no FEEDR Z offered: how
fast to plunge an end mill is the programmer's choice); a custom material's surface speed
is used as given for every tool (no tapping speed: a tap's RPM is the programmer's), its
chip load for every milling tool.

Pure core: no web, database or serial code.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
from decimal import ROUND_FLOOR, Decimal
from fractions import Fraction

from app.cnc import limits
from app.cnc.kinds import Value, prompt
from app.cnc.spindle import CONTROL, Spindle
from app.cnc.tools import Hand, PitchUnit, ToolMaterial, ToolType, lead_per_rev, pitch_text
from app.cnc.units import Units, format_decimal

MM_PER_INCH = Fraction(254, 10)
FEET_PER_METRE = Fraction(10_000, 3_048)


class MaterialName(enum.Enum):
    """The workpiece materials a program may state (or `custom`, with its own figures)."""

    AL_6061 = "6061"
    STEEL_1018 = "1018"
    SS_304 = "304"
    BRASS = "brass"
    CAST_IRON = "cast_iron"
    ACETAL = "acetal"
    CUSTOM = "custom"

    @property
    def label(self) -> str:
        return MATERIAL_LABELS[self]


MATERIAL_LABELS = {
    MaterialName.AL_6061: "6061 aluminium",
    MaterialName.STEEL_1018: "1018 steel",
    MaterialName.SS_304: "304 stainless",
    MaterialName.BRASS: "brass",
    MaterialName.CAST_IRON: "gray cast iron",
    MaterialName.ACETAL: "acetal",
    MaterialName.CUSTOM: "custom",
}


@dataclass(frozen=True, kw_only=True)
class Workpiece:
    """The material a program's part is cut from (the program document's `material`).

    For `custom`, `surface_speed` (sfm in an inch program, m/min in a metric one) and
    `chip_load` (in or mm per tooth) are the programmer's; the named materials take theirs
    from the tables of this module and leave both None."""

    name: MaterialName = prompt("MATERIAL", Value.CHOICE)
    surface_speed: Decimal | None = prompt("SURFACE SPEED", Value.LENGTH, None)
    chip_load: Decimal | None = prompt("CHIP LOAD", Value.LENGTH, None)

    def label(self, units: Units) -> str:
        """`6061 aluminium`, `custom: 350 sfm, 0.002 in per tooth`."""
        if self.name is not MaterialName.CUSTOM:
            return self.name.label
        speed = "-" if self.surface_speed is None else format_decimal(self.surface_speed)
        load = "-" if self.chip_load is None else format_decimal(self.chip_load)
        return f"custom: {speed} {speed_symbol(units)}, {load} {units.symbol} per tooth"


def speed_symbol(units: Units) -> str:
    """The surface speed's unit in a program of `units`: sfm or m/min."""
    return "sfm" if units is Units.INCH else "m/min"


CUSTOM_SPEED_HIGH = {Units.INCH: Decimal(10_000), Units.MM: Decimal(3_000)}
CUSTOM_LOAD_HIGH = {Units.INCH: Decimal("0.1"), Units.MM: Decimal("2.5")}


def workpiece_faults(workpiece: Workpiece, units: Units) -> list[str]:
    """What is wrong with a stated material (empty when nothing): a custom one needs its
    surface speed and chip load, within bounds; a named one takes neither."""
    speed, load = workpiece.surface_speed, workpiece.chip_load
    if workpiece.name is not MaterialName.CUSTOM:
        if speed is not None or load is not None:
            return [
                f"{workpiece.name.label} takes its surface speed and chip load from the tables; "
                "give them only for a custom material"
            ]
        return []
    faults = []
    high_speed, high_load = CUSTOM_SPEED_HIGH[units], CUSTOM_LOAD_HIGH[units]
    if speed is None:
        faults.append(f"a custom material needs its surface speed ({speed_symbol(units)})")
    elif not 0 < speed <= high_speed:
        faults.append(
            f"surface speed {format_decimal(speed)} {speed_symbol(units)} is outside the "
            f"allowed range: over 0, up to {high_speed}"
        )
    if load is None:
        faults.append(f"a custom material needs its chip load ({units.symbol} per tooth)")
    elif not 0 < load <= high_load:
        faults.append(
            f"chip load {format_decimal(load)} {units.symbol} is outside the allowed range: "
            f"over 0, up to {high_load}"
        )
    return faults


# -- the tables ----------------------------------------------------------------------------


class Family(enum.Enum):
    """Which surface speed a tool type runs at."""

    MILL = "milling"
    DRILL = "drilling"
    REAM = "reaming"
    TAP = "tapping"


FAMILY = {
    ToolType.END_MILL: Family.MILL,
    ToolType.FACE_MILL: Family.MILL,
    ToolType.CHAMFER_MILL: Family.MILL,
    ToolType.THREAD_MILL: Family.MILL,
    ToolType.ENGRAVER: Family.MILL,
    ToolType.BORING_BAR: Family.MILL,
    ToolType.DRILL: Family.DRILL,
    ToolType.CENTRE_DRILL: Family.DRILL,
    ToolType.SPOT_DRILL: Family.DRILL,
    ToolType.REAMER: Family.REAM,
    ToolType.TAP: Family.TAP,
}
CHIP_LOAD_TOOLS = frozenset(t for t, f in FAMILY.items() if f is Family.MILL)
DRILL_FEED_TOOLS = frozenset(
    {ToolType.DRILL, ToolType.CENTRE_DRILL, ToolType.SPOT_DRILL, ToolType.REAMER}
)

GRIZZLY = "Grizzly G0619 manual, Fig. 20, HSS"
MH_STEEL = "Machinery's Handbook, plain carbon steels 1006-1026 at 125-175 HB, HSS"
MH_STAINLESS = "Machinery's Handbook, austenitic stainless 201-348 annealed, HSS"
NAVY = "U.S. Navy Machinery Repairman manual, HSS twist drills"
NORSEMAN = "Norseman Drill, HSS drills, plastics"
CLARKSON = "Clarkson-Osborn, HSS taps"
PROTOCUTTER = "Protocutter carbide end mill chart"
TORBIDE = "Torbide Tooling carbide end mill chart"
TM_1_420 = "U.S. Army TM 1-420 §37a"


@dataclass(frozen=True)
class Figure:
    """A surface speed in sfm for HSS, and where it comes from."""

    sfm: int
    source: str


@dataclass(frozen=True)
class MaterialTable:
    """One material's figures: HSS surface speeds per family (carbide runs at twice),
    chip loads in in/tooth at CHIP_DIAMETERS, and whether drills take the lower feed."""

    mill: Figure
    drill: Figure
    tap: Figure
    chip_loads: tuple[Fraction, ...]
    chip_source: str
    hard: bool = False


def _loads(*values: str) -> tuple[Fraction, ...]:
    return tuple(Fraction(v) for v in values)


CHIP_DIAMETERS = (Fraction(1, 8), Fraction(1, 4), Fraction(1, 2), Fraction(3, 4), Fraction(1))
TABLES: dict[MaterialName, MaterialTable] = {
    MaterialName.AL_6061: MaterialTable(
        Figure(300, f"{GRIZZLY}: aluminum & alloys"),
        Figure(200, f"{NAVY}: aluminum 200-300"),
        Figure(82, f"{CLARKSON}: aluminium, silicon under 5 %, 82-150"),
        _loads("0.001", "0.002", "0.004", "0.006", "0.008"),
        f"{PROTOCUTTER}: aluminum (1/8 in: {TORBIDE})",
    ),
    MaterialName.STEEL_1018: MaterialTable(
        Figure(110, f"{MH_STEEL}: milling"),
        Figure(90, f"{MH_STEEL}: drilling"),
        Figure(50, f"{CLARKSON}: plain carbon steel 50-60"),
        _loads("0.0005", "0.001", "0.003", "0.0045", "0.0065"),
        f"{PROTOCUTTER}: low carbon steels",
    ),
    MaterialName.SS_304: MaterialTable(
        Figure(60, f"{GRIZZLY}: stainless steel"),
        Figure(55, f"{MH_STAINLESS}: drilling"),
        Figure(16, f"{CLARKSON}: austenitic stainless 16-22"),
        _loads("0.0005", "0.001", "0.003", "0.004", "0.006"),
        f"{PROTOCUTTER}: stainless steels up to 40 Rc",
        hard=True,
    ),
    MaterialName.BRASS: MaterialTable(
        Figure(150, f"{GRIZZLY}: brass & bronze"),
        Figure(200, f"{NAVY}: brass 200-300"),
        Figure(50, f"{CLARKSON}: brass 50-65"),
        _loads("0.001", "0.002", "0.003", "0.004", "0.005"),
        f"{PROTOCUTTER}: brass/bronze",
    ),
    MaterialName.CAST_IRON: MaterialTable(
        Figure(80, f"{GRIZZLY}: cast iron, soft"),
        Figure(70, f"{NAVY}: cast iron 70-150"),
        Figure(30, f"{CLARKSON}: cast iron, lamellar graphite 150-300 HB, 30-40"),
        _loads("0.0005", "0.001", "0.003", "0.005", "0.007"),
        f"{PROTOCUTTER}: cast/malleable iron",
    ),
    MaterialName.ACETAL: MaterialTable(
        Figure(300, f"{GRIZZLY}: plastics 300-800"),
        Figure(100, f"{NORSEMAN} 100-300"),
        Figure(60, f"{CLARKSON}: thermoplastic 60-105"),
        _loads("0.0015", "0.003", "0.006", "0.010", "0.012"),
        f"{PROTOCUTTER}: plastics",
    ),
}
CARBIDE_FACTOR = 2
REAMER_FACTOR = Fraction(1, 2)

# The Navy manual's drill feeds: (diameter from, to, feed per rev from, to), inches. No. 80
# is 0.0135 in.
DRILL_FEEDS: tuple[tuple[Fraction, Fraction, Fraction, Fraction], ...] = (
    (Fraction("0.0135"), Fraction(1, 8), Fraction("0.001"), Fraction("0.002")),
    (Fraction(1, 8), Fraction(1, 4), Fraction("0.002"), Fraction("0.004")),
    (Fraction(1, 4), Fraction(1, 2), Fraction("0.004"), Fraction("0.007")),
    (Fraction(1, 2), Fraction(1), Fraction("0.007"), Fraction("0.015")),
)
DRILL_FEED_OVER_1 = Fraction("0.015")


def chip_load(table: tuple[Fraction, ...], diameter: Fraction) -> Fraction:
    """The chip load (in/tooth) of a cutter `diameter` inches across, read from a table at
    CHIP_DIAMETERS: on the straight line between two columns, in proportion below the
    first, the last column's above the last."""
    first, last = CHIP_DIAMETERS[0], CHIP_DIAMETERS[-1]
    if diameter <= first:
        return table[0] * diameter / first
    if diameter >= last:
        return table[-1]
    for k in range(len(CHIP_DIAMETERS) - 1):
        d0, d1 = CHIP_DIAMETERS[k], CHIP_DIAMETERS[k + 1]
        if d0 <= diameter <= d1:
            return table[k] + (table[k + 1] - table[k]) * (diameter - d0) / (d1 - d0)
    raise AssertionError("unreachable: the diameters cover every size")


def drill_feed(diameter: Fraction, hard: bool = False) -> Fraction:
    """A drill's feed per revolution (in/rev) for `diameter` inches (DRILL_FEEDS): on the
    straight line across its range, or its range's lower figure for a hard material."""
    if diameter >= DRILL_FEEDS[-1][1]:
        return DRILL_FEED_OVER_1
    for d0, d1, f0, f1 in DRILL_FEEDS:
        if diameter < d1:
            if hard or diameter <= d0:
                return f0
            return f0 + (f1 - f0) * (diameter - d0) / (d1 - d0)
    raise AssertionError("unreachable: the ranges cover every size")


# -- the offer -----------------------------------------------------------------------------


@dataclass(frozen=True)
class Cutter:
    """What the offer needs to know of a tool: its type, cutting diameter (inches, exact),
    flutes, tool material and, for a tap, its pitch and hand."""

    kind: ToolType
    diameter: Fraction
    flutes: int | None = None
    material: ToolMaterial = ToolMaterial.HSS
    pitch: Decimal | None = None
    pitch_unit: PitchUnit = PitchUnit.TPI
    hand: Hand = Hand.RIGHT


@dataclass(frozen=True)
class Offer:
    """The figures offered for one tool. Speeds in sfm and loads in inches inside; `units`
    is the program's, in which `feed_xy` and `feed_z` are given (on the field's steps).
    `rpm` is signed (a left-hand tap runs in reverse); `rpm_table` the table's RPM before
    the spindle's limits. `lines` say how each figure was reached."""

    units: Units
    surface_speed: Fraction | None = None
    rpm_table: int | None = None
    rpm: int | None = None
    gear: str = ""
    chip_load: Fraction | None = None
    feed_per_rev: Fraction | None = None
    feed_xy: Decimal | None = None
    feed_z: Decimal | None = None
    lines: tuple[str, ...] = field(default_factory=tuple)
    feeds_at: int | None = None  # the RPM the feeds are for (the tool's own, or `rpm`)

    def summary(self) -> str:
        """One line: `4000 rpm, high gear · FEEDR XY 48.0 ipm` (`· at 500 rpm: FEEDR Z …`
        when the feeds are for the tool's own RPM)."""
        parts = []
        if self.rpm is not None:
            parts.append(f"{self.rpm} rpm" + (f", {self.gear}" if self.gear else ""))
        if (
            self.feeds_at is not None
            and self.feeds_at != self.rpm
            and (self.feed_xy is not None or self.feed_z is not None)
        ):
            parts.append(f"at {self.feeds_at} rpm:")
        if self.feed_xy is not None:
            parts.append(f"FEEDR XY {feed_text(self.feed_xy, self.units)}")
        if self.feed_z is not None:
            parts.append(f"FEEDR Z {feed_text(self.feed_z, self.units)}")
        return " · ".join(parts).replace(": · ", ": ") or "nothing to offer"


def feed_text(value: Decimal, units: Units) -> str:
    """`48.0 ipm`, `500 mm/min`."""
    shown = f"{value:.1f}" if units is Units.INCH else f"{value:.0f}"
    return f"{shown} {units.feed_symbol}"


def surface_speed(
    workpiece: Workpiece, cutter: Cutter, units: Units
) -> tuple[Fraction | None, str]:
    """The surface speed (sfm) for `cutter` in `workpiece`, and how it was found (None:
    none to offer, the text says why)."""
    family = FAMILY[cutter.kind]
    if workpiece.name is MaterialName.CUSTOM:
        if workpiece.surface_speed is None:
            return None, "the custom material gives no surface speed"
        if family is Family.TAP:
            return None, "a custom material gives no tapping speed: type the tap's RPM"
        given = Fraction(workpiece.surface_speed)
        sfm = given if units is Units.INCH else given * FEET_PER_METRE
        shown = f"{format_decimal(workpiece.surface_speed)} {speed_symbol(units)}"
        if family is Family.REAM:
            return sfm * REAMER_FACTOR, f"the custom {shown} × 1/2 for a reamer ({TM_1_420})"
        return sfm, f"the custom {shown}"
    table = TABLES[workpiece.name]
    figure = {
        Family.MILL: table.mill,
        Family.DRILL: table.drill,
        Family.REAM: table.drill,
        Family.TAP: table.tap,
    }[family]
    sfm = Fraction(figure.sfm)
    how = f"{figure.sfm} sfm ({figure.source})"
    if family is Family.REAM:
        sfm *= REAMER_FACTOR
        how += f" × 1/2 for a reamer ({TM_1_420})"
    if cutter.material is ToolMaterial.CARBIDE:
        sfm *= CARBIDE_FACTOR
        how += " × 2 for carbide"
    return sfm, how


def table_rpm(sfm: Fraction, diameter: Fraction) -> int:
    """RPM = sfm × 12 / (π × D), D in inches, rounded down to a whole rpm."""
    return math.floor(float(sfm * 12 / diameter) / math.pi)


def clamp(rpm: int, spindle: Spindle) -> tuple[int, str]:
    """`rpm` as the spindle can run it, and what was done ("" when nothing): the top of
    its range above it, the bottom below it, the top of the lower gear in a gap."""
    if spindle.runs(rpm):
        return rpm, ""
    if rpm > spindle.high:
        return spindle.high, f"the table's {rpm} rpm is above {spindle.owner}'s top speed"
    if rpm < spindle.low:
        return spindle.low, (
            f"the table's {rpm} rpm is below {spindle.owner}'s slowest speed: "
            "it runs faster than the table"
        )
    below = max(hi for lo, hi in spindle.gears if hi < rpm)
    return below, f"the table's {rpm} rpm falls between gears: the top of the lower gear"


def exact_tap_rpm(rpm: int, lead: Fraction, units: Units, spindle: Spindle) -> int | None:
    """The fastest speed at or below `rpm` the spindle runs at which a tap of `lead`
    (units per turn) feeds exactly on FEEDR Z's steps; else the slowest above it; None when
    the spindle runs none."""
    step = Fraction(limits.FEED_Z[units].step)
    every = (lead / step).denominator  # RPM × lead / step is whole for multiples of this
    below = (rpm // every) * every
    while below >= spindle.low:
        if spindle.runs(below):
            return below
        below -= every
    above = max(every, -(-spindle.low // every) * every)
    while above <= spindle.high:
        if spindle.runs(above):
            return above
        above += every
    return None


def tap_feed(rpm: int, lead: Fraction, units: Units) -> Fraction:
    """A tap's feed: |RPM| × lead, exactly, in `units` per minute."""
    return abs(rpm) * lead


def on_grid(value: Fraction, units: Units, *, xy: bool) -> tuple[Decimal, str]:
    """A feed rounded down to FEEDR's step and kept in its range, and a note when kept."""
    limit = (limits.FEED_XY if xy else limits.FEED_Z)[units]
    steps = math.floor(value / Fraction(limit.step))
    shown = (Decimal(steps) * limit.step).quantize(limit.step, rounding=ROUND_FLOOR)
    if shown > limit.high:
        return limit.high, f"kept to FEEDR's largest, {limit.high} {units.feed_symbol}"
    if shown < limit.low:
        return limit.low, f"raised to FEEDR's smallest, {limit.low} {units.feed_symbol}"
    return shown, ""


def offer(
    workpiece: Workpiece,
    cutter: Cutter,
    units: Units,
    spindle: Spindle | None = None,
    rpm: int | None = None,
    max_feed: Decimal | None = None,
) -> Offer:
    """The figures for `cutter` cutting `workpiece` in a program of `units` on a machine
    with `spindle` (None: the control's) whose largest feed is `max_feed` (program units
    per minute; None: FEEDR's own limit). With `rpm` (the RPM the program runs the tool
    at), the feeds are worked out from it instead of the offered RPM."""
    spindle = spindle or CONTROL
    lines: list[str] = []
    sfm, how = surface_speed(workpiece, cutter, units)
    table: int | None = None
    offered: int | None = None
    gear = ""
    if cutter.diameter <= 0:
        return Offer(units, lines=("no diameter: nothing to offer",))
    lead = (
        lead_per_rev(cutter.pitch, cutter.pitch_unit, units)
        if cutter.kind is ToolType.TAP and cutter.pitch is not None and cutter.pitch > 0
        else None  # no pitch (or one validation refuses): no tap feed offered
    )
    if sfm is None:
        lines.append(f"surface speed: none ({how})")
    else:
        table = table_rpm(sfm, cutter.diameter)
        lines.append(f"surface speed {_speed(sfm, units)}: {how}")
        if units is Units.INCH:
            formula = f"{_speed(sfm, units)} × 12 / (π × {_inches(cutter.diameter)} in)"
        else:
            formula = f"{_speed(sfm, units)} × 1000 / (π × {_mm(cutter.diameter)} mm)"
        lines.append(f"RPM {table} = {formula}, rounded down")
        offered, note = clamp(table, spindle)
        if note:
            lines.append(f"RPM {offered}: {note}")
        if lead is not None:
            exact = exact_tap_rpm(offered, lead, units, spindle)
            if exact is None:
                lines.append("no speed of the spindle feeds this tap exactly on FEEDR Z's steps")
                offered = None
            elif exact != offered:
                lines.append(
                    f"RPM {exact}: the nearest speed at which RPM × pitch lands exactly on "
                    f"FEEDR Z's {limits.FEED_Z[units].step} {units.feed_symbol} steps"
                )
                offered = exact
        if offered is not None:
            if cutter.kind is ToolType.TAP and cutter.hand is Hand.LEFT:
                offered = -offered
                lines.append(f"RPM {offered}: a left-hand tap runs in reverse")
            gear = spindle.gear(offered)
    runs = rpm if rpm is not None else offered
    if rpm is not None:
        lines.append(f"feeds from the tool's own {rpm} rpm")
    load: Fraction | None = None
    per_rev: Fraction | None = None
    feed_xy = feed_z = None
    if cutter.kind in CHIP_LOAD_TOOLS:
        if workpiece.name is MaterialName.CUSTOM:
            if workpiece.chip_load is not None:
                given = Fraction(workpiece.chip_load)
                load = given if units is Units.INCH else given / MM_PER_INCH
                lines.append(f"chip load {_load(load, units)}: the custom material's")
        else:
            table_of = TABLES[workpiece.name]
            load = chip_load(table_of.chip_loads, cutter.diameter)
            lines.append(
                f"chip load {_load(load, units)}: {table_of.chip_source}, at "
                f"{_inches(cutter.diameter)} in"
            )
        if load is not None and cutter.kind is ToolType.BORING_BAR:
            teeth = cutter.flutes or 1
            per_rev = load * teeth
            lines.append(f"feed per turn {_load(per_rev, units)} = {teeth} × chip load")
    elif cutter.kind in DRILL_FEED_TOOLS:
        hard = workpiece.name in TABLES and TABLES[workpiece.name].hard
        per_rev = drill_feed(cutter.diameter, hard)
        lines.append(
            f"feed per turn {_load(per_rev, units)}: {NAVY}, at {_inches(cutter.diameter)} in"
            + (" (the lower figure: a hard material)" if hard else "")
        )
    if runs is not None:
        speed = abs(runs)
        if load is not None and cutter.kind is not ToolType.BORING_BAR:
            if cutter.flutes is None:
                lines.append("no FLUTES: no FEEDR XY offered")
            else:
                raw = _in_units(speed * cutter.flutes * load, units)
                feed_xy, note = on_grid(raw, units, xy=True)
                feed_xy, note = _machine_limit(feed_xy, note, max_feed, units)
                lines.append(
                    f"FEEDR XY {feed_text(feed_xy, units)} = {speed} × {cutter.flutes} × "
                    f"{_load(load, units)}" + (f"; {note}" if note else ", rounded down")
                )
        if per_rev is not None:
            raw = _in_units(speed * per_rev, units)
            feed_z, note = on_grid(raw, units, xy=False)
            feed_z, note = _machine_limit(feed_z, note, max_feed, units)
            lines.append(
                f"FEEDR Z {feed_text(feed_z, units)} = {speed} × {_load(per_rev, units)}"
                + (f"; {note}" if note else ", rounded down")
            )
        if cutter.kind is ToolType.TAP:
            if lead is None:
                lines.append("no PITCH: a tap's feed is RPM × pitch")
            else:
                needed = tap_feed(speed, lead, units)
                step = Fraction(limits.FEED_Z[units].step)
                pitch = pitch_text(cutter.pitch or Decimal(0), cutter.pitch_unit)
                if (needed / step).denominator == 1:
                    feed_z = _decimal(needed).quantize(limits.FEED_Z[units].step)
                    lines.append(f"FEEDR Z {feed_text(feed_z, units)} = {speed} × {pitch}, exactly")
                else:
                    lines.append(
                        f"FEEDR Z: {speed} × {pitch} = {float(needed):.4f} {units.feed_symbol}, "
                        "which FEEDR Z cannot hold exactly: " + tap_speeds_text(speed, lead, units)
                    )
    return Offer(
        units,
        sfm,
        table,
        offered,
        gear,
        load,
        per_rev if per_rev is not None else lead_in_inches(lead, units),
        feed_xy,
        feed_z,
        tuple(lines),
        runs,
    )


def lead_in_inches(lead: Fraction | None, units: Units) -> Fraction | None:
    if lead is None:
        return None
    return lead if units is Units.INCH else lead / MM_PER_INCH


def tap_speeds_text(rpm: int, lead: Fraction, units: Units) -> str:
    """The speeds nearest `rpm` at which a tap of `lead` feeds exactly on FEEDR Z's steps:
    `run it at 332 rpm (16.6 ipm) or 334 rpm (16.7 ipm)`."""
    step = Fraction(limits.FEED_Z[units].step)
    every = (lead / step).denominator
    below = (abs(rpm) // every) * every
    above = below + every
    options = [r for r in (below, above) if r > 0]
    return "run it at " + " or ".join(
        f"{r} rpm ({feed_text(_decimal(tap_feed(r, lead, units)), units)})" for r in options
    )


def _decimal(value: Fraction) -> Decimal:
    return Decimal(value.numerator) / Decimal(value.denominator)


def _machine_limit(
    value: Decimal, note: str, max_feed: Decimal | None, units: Units
) -> tuple[Decimal, str]:
    if max_feed is not None and value > max_feed:
        return max_feed, f"kept to the machine's largest feed, {max_feed} {units.feed_symbol}"
    return value, note


def _in_units(inches_per_min: Fraction, units: Units) -> Fraction:
    return inches_per_min if units is Units.INCH else inches_per_min * MM_PER_INCH


def _speed(sfm: Fraction, units: Units) -> str:
    if units is Units.INCH:
        return f"{_plain(sfm)} sfm"
    return f"{_plain(sfm / FEET_PER_METRE, 2)} m/min"


def _load(inches: Fraction, units: Units) -> str:
    if units is Units.INCH:
        return f"{_plain(inches, 5)} in"
    return f"{_plain(inches * MM_PER_INCH, 4)} mm"


def _inches(value: Fraction) -> str:
    return _plain(value, 4)


def _mm(inches: Fraction) -> str:
    return _plain(inches * MM_PER_INCH, 3)


def _plain(value: Fraction, places: int = 1) -> str:
    """A figure without needless zeros: 600, 0.0045, 182.88."""
    if value.denominator == 1:
        return str(value.numerator)
    text = f"{float(value):.{places}f}".rstrip("0").rstrip(".")
    return text or "0"
