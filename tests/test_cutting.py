"""Feeds and speeds (issue 34 point 3), checked against the cited tables by hand.

Every figure below is worked on paper from app/cnc/cutting.py's tables (docs/tools.md
cites each): RPM = sfm × 12 / (π × D) rounded down, then kept to the spindle; FEEDR XY =
RPM × flutes × chip load and FEEDR Z = RPM × feed per turn, rounded down to 0.1 ipm (2
mm/min); a tap's feed RPM × pitch exactly. Each material and each tool type has a case.
`tests/speeds/expected.txt` is the golden of every material with every type (regenerated
with `make regen-golden` after a reviewed change).
"""

from __future__ import annotations

from decimal import Decimal as D
from fractions import Fraction as F
from pathlib import Path

import pytest

from app.cnc.cutting import (
    MATERIAL_LABELS,
    TABLES,
    Cutter,
    MaterialName,
    Workpiece,
    chip_load,
    clamp,
    drill_feed,
    exact_tap_rpm,
    offer,
)
from app.cnc.machine import PRESETS
from app.cnc.spindle import CONTROL, read_spindle
from app.cnc.tools import Hand, PitchUnit, ToolMaterial, ToolType
from app.cnc.units import Units
from tests.golden_support import check_golden

HSS, CARBIDE = ToolMaterial.HSS, ToolMaterial.CARBIDE
INCH, MM = Units.INCH, Units.MM


def material(name: MaterialName, speed: str | None = None, load: str | None = None) -> Workpiece:
    return Workpiece(
        name=name,
        surface_speed=None if speed is None else D(speed),
        chip_load=None if load is None else D(load),
    )


# (case, material, cutter, units, rpm offered, gear, FEEDR XY, FEEDR Z) — the arithmetic in
# the comment above each, from the tables' figures.
HAND = [
    # 6061, carbide: 300 sfm (Grizzly) × 2 = 600; 600 × 12 / (π × 0.5) = 4583.7 → 4583, kept
    # to the control's 4000; chip load at 1/2 in .004 (Protocutter): 4000 × 3 × .004 = 48.0.
    (
        "6061 carbide end mill",
        MaterialName.AL_6061,
        Cutter(ToolType.END_MILL, F(1, 2), 3, CARBIDE),
        INCH,
        4000,
        "high gear",
        "48.0",
        None,
    ),
    # 1018, HSS: 110 sfm (Machinery's Handbook, milling); 1320 / (π × 0.375) = 1120.5 → 1120;
    # chip load at 3/8 in on the line from .001 (1/4) to .003 (1/2): .002; 1120 × 4 × .002 =
    # 8.96 → 8.9.
    (
        "1018 HSS end mill",
        MaterialName.STEEL_1018,
        Cutter(ToolType.END_MILL, F(3, 8), 4, HSS),
        INCH,
        1120,
        "high gear",
        "8.9",
        None,
    ),
    # 304, carbide: 60 × 2 = 120 sfm; 1440 / (π × 0.25) = 1833.5 → 1833; .001 at 1/4 in;
    # 1833 × 2 × .001 = 3.666 → 3.6.
    (
        "304 carbide end mill",
        MaterialName.SS_304,
        Cutter(ToolType.END_MILL, F(1, 4), 2, CARBIDE),
        INCH,
        1833,
        "high gear",
        "3.6",
        None,
    ),
    # brass, HSS: 150 sfm; 1800 / (π × 0.75) = 763.9 → 763; .004 at 3/4 in; 763 × 2 × .004 =
    # 6.104 → 6.1.
    (
        "brass HSS end mill",
        MaterialName.BRASS,
        Cutter(ToolType.END_MILL, F(3, 4), 2, HSS),
        INCH,
        763,
        "high gear",
        "6.1",
        None,
    ),
    # gray cast iron, HSS: 80 sfm; 960 / π = 305.6 → 305 (low gear); .007 at 1 in; 305 × 4 ×
    # .007 = 8.54 → 8.5.
    (
        "cast iron HSS end mill",
        MaterialName.CAST_IRON,
        Cutter(ToolType.END_MILL, F(1), 4, HSS),
        INCH,
        305,
        "low gear",
        "8.5",
        None,
    ),
    # acetal, HSS: 300 sfm; 3600 / (π × 0.125) = 9167.3 → kept to 4000; .0015 at 1/8 in;
    # 4000 × 2 × .0015 = 12.0.
    (
        "acetal HSS end mill",
        MaterialName.ACETAL,
        Cutter(ToolType.END_MILL, F(1, 8), 2, HSS),
        INCH,
        4000,
        "high gear",
        "12.0",
        None,
    ),
    # 6061 in a metric program, carbide 10 mm, 3 flutes: 600 sfm = 182.88 m/min; 182.88 ×
    # 1000 / (π × 10) = 5821.0 → 4000; chip load at 10 mm = 0.3937 in on the line from .002
    # (1/4) to .004 (1/2): .002 + .008 × (10/25.4 − 1/4) = 0.08/25.4 in = 0.08 mm; 4000 × 3
    # × 0.08 = 960 mm/min.
    (
        "6061 carbide 10 mm end mill",
        MaterialName.AL_6061,
        Cutter(ToolType.END_MILL, F(10) / F(254, 10), 3, CARBIDE),
        MM,
        4000,
        "high gear",
        "960",
        None,
    ),
    # #7 drill (0.201) in 1018, HSS: 90 sfm (Machinery's Handbook, drilling); 1080 / (π ×
    # 0.201) = 1710.3 → 1710; feed on the line from .002 (1/8) to .004 (1/4): .002 + .002 ×
    # 0.076 / 0.125 = .003216; 1710 × .003216 = 5.499 → 5.4.
    (
        "1018 HSS drill",
        MaterialName.STEEL_1018,
        Cutter(ToolType.DRILL, F("0.201"), 2, HSS),
        INCH,
        1710,
        "high gear",
        None,
        "5.4",
    ),
    # The same drill in 304: 55 sfm; 660 / (π × 0.201) = 1045.2 → 1045; the lower figure of
    # its range for a hard material, .002; 1045 × .002 = 2.09 → 2.0.
    (
        "304 HSS drill",
        MaterialName.SS_304,
        Cutter(ToolType.DRILL, F("0.201"), 2, HSS),
        INCH,
        1045,
        "high gear",
        None,
        "2.0",
    ),
    # #3 centre drill (pilot 0.125) in 6061: 200 sfm (Navy, drilling aluminium);
    # 2400 / (π × 0.125) = 6111.5 → 4000; .002 at 1/8; 4000 × .002 = 8.0.
    (
        "6061 HSS centre drill",
        MaterialName.AL_6061,
        Cutter(ToolType.CENTRE_DRILL, F(1, 8), 2, HSS),
        INCH,
        4000,
        "high gear",
        None,
        "8.0",
    ),
    # 1/2 in carbide spot drill in brass: 200 × 2 = 400 sfm; 4800 / (π × 0.5) = 3055.8 → 3055;
    # .007 at 1/2 in; 3055 × .007 = 21.385 → 21.3.
    (
        "brass carbide spot drill",
        MaterialName.BRASS,
        Cutter(ToolType.SPOT_DRILL, F(1, 2), 2, CARBIDE),
        INCH,
        3055,
        "high gear",
        None,
        "21.3",
    ),
    # 1/4 in HSS reamer in 1018: 90 × 1/2 = 45 sfm (TM 1-420); 540 / (π × 0.25) = 687.5 → 687;
    # .004 at 1/4 in; 687 × .004 = 2.748 → 2.7.
    (
        "1018 HSS reamer",
        MaterialName.STEEL_1018,
        Cutter(ToolType.REAMER, F(1, 4), 6, HSS),
        INCH,
        687,
        "high gear",
        None,
        "2.7",
    ),
    # 1/4-20 HSS tap in 1018: 50 sfm (Clarkson-Osborn); 600 / (π × 0.25) = 763.9 → 763; the
    # feed 763 / 20 = 38.15 is not a 0.1 ipm step: 762 rpm, 762 / 20 = 38.1 exactly.
    (
        "1018 HSS tap",
        MaterialName.STEEL_1018,
        Cutter(ToolType.TAP, F(1, 4), 4, HSS, D(20), PitchUnit.TPI),
        INCH,
        762,
        "high gear",
        None,
        "38.1",
    ),
    # 3/4 in carbide boring bar, one edge, in cast iron: 80 × 2 = 160 sfm; 1920 / (π × 0.75) =
    # 814.9 → 814; .005 at 3/4 in × 1 edge per turn; 814 × .005 = 4.07 → 4.0.
    (
        "cast iron carbide boring bar",
        MaterialName.CAST_IRON,
        Cutter(ToolType.BORING_BAR, F(3, 4), 1, CARBIDE),
        INCH,
        814,
        "high gear",
        None,
        "4.0",
    ),
    # 1/2 in HSS chamfer mill, 4 flutes, in 304: 60 sfm; 720 / (π × 0.5) = 458.4 → 458 (low
    # gear); .003 at 1/2 in; 458 × 4 × .003 = 5.496 → 5.4.
    (
        "304 HSS chamfer mill",
        MaterialName.SS_304,
        Cutter(ToolType.CHAMFER_MILL, F(1, 2), 4, HSS),
        INCH,
        458,
        "low gear",
        "5.4",
        None,
    ),
    # 3/8 in carbide thread mill, 3 flutes, in 6061: 600 sfm; 7200 / (π × 0.375) = 6111.5 →
    # 4000; .003 at 3/8 in; 4000 × 3 × .003 = 36.0.
    (
        "6061 carbide thread mill",
        MaterialName.AL_6061,
        Cutter(ToolType.THREAD_MILL, F(3, 8), 3, CARBIDE, D(20)),
        INCH,
        4000,
        "high gear",
        "36.0",
        None,
    ),
    # 1/16 in carbide engraver, one flute, in acetal: 300 × 2 = 600 sfm; 7200 / (π × 0.0625) =
    # 36669 → 4000; under 1/8 in the chip load shrinks with the diameter: .0015 × 0.0625 /
    # 0.125 = .00075; 4000 × 1 × .00075 = 3.0.
    (
        "acetal carbide engraver",
        MaterialName.ACETAL,
        Cutter(ToolType.ENGRAVER, F(1, 16), 1, CARBIDE),
        INCH,
        4000,
        "high gear",
        "3.0",
        None,
    ),
    # 2 in carbide face mill, 5 inserts, in cast iron: 160 sfm; 1920 / (π × 2) = 305.6 → 305;
    # over 1 in the 1 in chip load, .007; 305 × 5 × .007 = 10.675 → 10.6.
    (
        "cast iron carbide face mill",
        MaterialName.CAST_IRON,
        Cutter(ToolType.FACE_MILL, F(2), 5, CARBIDE),
        INCH,
        305,
        "low gear",
        "10.6",
        None,
    ),
]


@pytest.mark.parametrize(
    ("name", "stock", "cutter", "units", "rpm", "gear", "feed_xy", "feed_z"),
    HAND,
    ids=[case[0] for case in HAND],
)
def test_the_offered_figures_are_the_tables_worked_by_hand(
    name: str,
    stock: MaterialName,
    cutter: Cutter,
    units: Units,
    rpm: int,
    gear: str,
    feed_xy: str | None,
    feed_z: str | None,
) -> None:
    figures = offer(material(stock), cutter, units)
    assert figures.rpm == rpm, figures.lines
    assert figures.gear == gear
    assert figures.feed_xy == (None if feed_xy is None else D(feed_xy)), figures.lines
    assert figures.feed_z == (None if feed_z is None else D(feed_z)), figures.lines


def test_every_material_and_every_tool_type_has_a_hand_worked_case() -> None:
    materials = {case[1] for case in HAND}
    kinds = {case[2].kind for case in HAND}
    assert materials == set(TABLES), set(TABLES) - materials
    assert kinds == set(ToolType), set(ToolType) - kinds


def test_a_custom_material_takes_its_own_surface_speed_and_chip_load() -> None:
    # 350 sfm: 4200 / (π × 0.5) = 2673.8 → 2673; 2673 × 2 × .002 = 10.692 → 10.6.
    figures = offer(
        material(MaterialName.CUSTOM, "350", "0.002"),
        Cutter(ToolType.END_MILL, F(1, 2), 2, CARBIDE),
        INCH,
    )
    assert (figures.rpm, figures.feed_xy) == (2673, D("10.6"))
    # Metric: 100 m/min and 0.05 mm per tooth, a 10 mm end mill: 100 × 1000 / (π × 10) =
    # 3183.1 → 3183; 3183 × 4 × 0.05 = 636.6 → 636 mm/min.
    metric = offer(
        material(MaterialName.CUSTOM, "100", "0.05"),
        Cutter(ToolType.END_MILL, F(10) / F(254, 10), 4, HSS),
        MM,
    )
    assert (metric.rpm, metric.feed_xy) == (3183, D(636))
    # No tapping speed from a custom material; a tap's feed still follows its RPM.
    tap = offer(
        material(MaterialName.CUSTOM, "350", "0.002"),
        Cutter(ToolType.TAP, F(1, 4), 4, HSS, D(20)),
        INCH,
        rpm=500,
    )
    assert tap.rpm is None and tap.feed_z == D("25.0")
    assert any("no tapping speed" in line for line in tap.lines)


# -- a tap's feed: RPM × pitch, exactly -------------------------------------------------------


def test_a_quarter_twenty_tap_at_500_rpm_feeds_25_ipm() -> None:
    figures = offer(
        material(MaterialName.STEEL_1018),
        Cutter(ToolType.TAP, F(1, 4), 4, HSS, D(20), PitchUnit.TPI),
        INCH,
        rpm=500,
    )
    assert figures.feed_z == D("25.0") and str(figures.feed_z) == "25.0"
    assert "FEEDR Z 25.0 ipm = 500 × 20 TPI, exactly" in figures.lines


def test_an_m6x1_tap_at_500_rpm_feeds_500_mm_per_min() -> None:
    figures = offer(
        material(MaterialName.STEEL_1018),
        Cutter(ToolType.TAP, F(6) / F(254, 10), 3, HSS, D(1), PitchUnit.MM),
        MM,
        rpm=500,
    )
    assert figures.feed_z == D(500) and str(figures.feed_z) == "500"


def test_a_tap_whose_feed_falls_between_steps_is_offered_no_feed_and_told_the_speeds() -> None:
    # 333 rpm × 1/20 in = 16.65 ipm: FEEDR Z holds 16.6 or 16.7, neither exact.
    figures = offer(
        material(MaterialName.STEEL_1018),
        Cutter(ToolType.TAP, F(1, 4), 4, HSS, D(20)),
        INCH,
        rpm=333,
    )
    assert figures.feed_z is None
    assert any("332 rpm (16.6 ipm) or 334 rpm (16.7 ipm)" in line for line in figures.lines)


def test_the_offered_tap_speed_feeds_exactly_and_a_left_hand_tap_runs_in_reverse() -> None:
    # A 1/2-13 tap in 1018: 600 / (π × 0.5) = 381.97 → 381; RPM / 13 ipm is a whole number
    # of 0.1 ipm steps when RPM × 10 / 13 is whole, at multiples of 13: 377 rpm → 29.0 ipm.
    figures = offer(
        material(MaterialName.STEEL_1018),
        Cutter(ToolType.TAP, F(1, 2), 4, HSS, D(13), PitchUnit.TPI, Hand.LEFT),
        INCH,
    )
    assert figures.rpm == -377 and figures.feed_z == D("29.0")
    assert exact_tap_rpm(381, F(1, 13), INCH, CONTROL) == 377
    # A metric tap in an inch program: 1 mm = 1/25.4 in per turn lands on 0.1 ipm only at
    # multiples of 254 rpm (254 / 25.4 = 10.0 ipm).
    assert exact_tap_rpm(600, F(10, 254), INCH, CONTROL) == 508


# -- kept to each machine's spindle -----------------------------------------------------------

END_MILL_6061 = Cutter(ToolType.END_MILL, F(1, 2), 3, CARBIDE)  # the table's 4583 rpm
FACE_MILL_IRON = Cutter(ToolType.FACE_MILL, F(6), 8, HSS)  # 960 / (π × 6) = 50.9 → 50 rpm


@pytest.mark.parametrize(
    ("spindle", "fast", "slow"),
    [
        # The seed's control: 60-500 low, 500-4000 high.
        (None, (4000, "high gear"), (60, "low gear")),
        # Kearney & Trecker 180 (seed 002 §2.2): 4-4000 rpm, one range.
        (PRESETS["kt-180"].spindle, (4000, ""), (50, "")),
        # A machining centre's 100-24 000.
        (read_spindle("100-24000"), (4583, ""), (100, "")),
    ],
    ids=["control", "kt-180", "24000"],
)
def test_the_rpm_is_kept_to_each_machine_s_spindle(
    spindle: object, fast: tuple[int, str], slow: tuple[int, str]
) -> None:
    high = offer(material(MaterialName.AL_6061), END_MILL_6061, INCH, spindle)  # type: ignore[arg-type]
    low = offer(material(MaterialName.CAST_IRON), FACE_MILL_IRON, INCH, spindle)  # type: ignore[arg-type]
    assert (high.rpm_table, low.rpm_table) == (4583, 50)
    assert (high.rpm, high.gear) == fast
    assert (low.rpm, low.gear) == slow
    # The feeds follow the RPM the spindle runs: 4000 × 3 × .004 = 48.0; 4583 × 3 × .004 =
    # 54.996 → 54.9.
    assert high.feed_xy == (D("48.0") if fast[0] == 4000 else D("54.9"))


def test_between_two_gears_the_top_of_the_lower_one() -> None:
    gears = read_spindle("60-400, 800-4000", "the old Bridgeport")
    rpm, note = clamp(600, gears)
    assert rpm == 400 and "between gears" in note
    assert clamp(700, CONTROL) == (700, "")
    assert clamp(30, CONTROL)[0] == 60 and "faster than the table" in clamp(30, CONTROL)[1]


def test_feeds_are_kept_to_the_field_and_the_machine() -> None:
    # 6061 carbide 1 in, 4 flutes, on a 24 000 rpm spindle: 7200 / π = 2291 rpm; .008 ×
    # 4 × 2291 = 73.3 ipm; with a machine whose largest feed is 60 ipm: 60.
    cutter = Cutter(ToolType.END_MILL, F(1), 4, CARBIDE)
    free = offer(material(MaterialName.AL_6061), cutter, INCH, read_spindle("100-24000"))
    assert free.feed_xy == D("73.3")
    kept = offer(
        material(MaterialName.AL_6061), cutter, INCH, read_spindle("100-24000"), max_feed=D(60)
    )
    assert kept.feed_xy == D(60)


# -- the tables as read -----------------------------------------------------------------------


def test_chip_loads_and_drill_feeds_read_on_the_line_between_the_table_s_columns() -> None:
    steel = TABLES[MaterialName.STEEL_1018].chip_loads
    assert chip_load(steel, F(1, 4)) == F("0.001")
    assert chip_load(steel, F(3, 8)) == F("0.002")
    assert chip_load(steel, F(1, 16)) == F("0.00025")
    assert chip_load(steel, F(3)) == F("0.0065")
    assert drill_feed(F(1, 4)) == F("0.004")
    assert drill_feed(F(3, 8)) == F("0.0055")
    assert drill_feed(F(3, 8), hard=True) == F("0.004")
    assert drill_feed(F(2)) == F("0.015")


def test_the_golden_of_every_material_with_every_tool_type() -> None:
    lines = []
    for name in MaterialName:
        stock = material(name, "350", "0.002") if name is MaterialName.CUSTOM else material(name)
        for kind in ToolType:
            for diameter in (F(1, 4), F(1, 2)):
                for tool_material in (HSS, CARBIDE):
                    pitch = D(20) if kind in (ToolType.TAP, ToolType.THREAD_MILL) else None
                    flutes = {ToolType.BORING_BAR: 1, ToolType.ENGRAVER: 1}.get(kind, 3)
                    cutter = Cutter(kind, diameter, flutes, tool_material, pitch)
                    figures = offer(stock, cutter, INCH)
                    lines.append(
                        f"{MATERIAL_LABELS[name]:<15} {kind.label:<13} {float(diameter):<5} "
                        f"{tool_material.label:<8} {figures.summary()}"
                    )
    check_golden(Path(__file__).parent / "speeds" / "expected.txt", "\n".join(lines) + "\n")
