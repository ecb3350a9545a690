"""The Bridgeport rotary table driven through the Y axis (seed 004 §8.2-8.3).

The table is driven from the Y output, so a Y distance is an angle: BOSS 4/5 programs 0.1 in
(2.54 mm) per degree, BOSS 6 0.05 in (1.27 mm). A rotary cut's feed is a feed number: the
desired feed along the cutter path divided by the cutter-path radius times a factor.

Scan damage: §8.2.3 and §8.2.4 print the BOSS 4/5 factor as ".175", but their own worked
examples need 0.0175 (12 ipm on a 4 in radius: 12 / (4 × 0.0175) = 171 → "F171"; 210 mm/min
on 100 mm: 210 / (100 × 0.0175) = 120 → "F120"), and 0.0175 is one degree in radians, as
each BOSS 4/5 feed number is 1 deg/min. BOSS 6 (2 deg/min per number) prints 0.035, and
0.0138 for metric, and its examples agree (F86, F152). Feed numbers round to the nearest.
"""

from __future__ import annotations

import enum
from decimal import ROUND_HALF_UP, Decimal

from app.cnc.units import Units


class Boss(enum.Enum):
    """The control generation, which sets the rotary scaling."""

    BOSS45 = "boss45"
    BOSS6 = "boss6"


_DISTANCE_PER_DEGREE = {
    (Boss.BOSS45, Units.INCH): Decimal("0.1"),
    (Boss.BOSS45, Units.MM): Decimal("2.54"),
    (Boss.BOSS6, Units.INCH): Decimal("0.05"),
    (Boss.BOSS6, Units.MM): Decimal("1.27"),
}
_FEED_FACTOR = {
    (Boss.BOSS45, Units.INCH): Decimal("0.0175"),
    (Boss.BOSS45, Units.MM): Decimal("0.0175"),
    (Boss.BOSS6, Units.INCH): Decimal("0.035"),
    (Boss.BOSS6, Units.MM): Decimal("0.0138"),
}
FEED_RANGE = {
    (Boss.BOSS45, Units.INCH): (2, 320),
    (Boss.BOSS45, Units.MM): (1, 812),
    (Boss.BOSS6, Units.INCH): (2, 510),
    (Boss.BOSS6, Units.MM): (5, 1295),
}
MAX_STEP = {Units.INCH: Decimal(32), Units.MM: Decimal(812)}


def y_distance(degrees: Decimal, boss: Boss, units: Units) -> Decimal:
    """The Y value that turns the table `degrees` (25° → 2.5 in on BOSS 4/5, 1.25 in on 6)."""
    return degrees * _DISTANCE_PER_DEGREE[(boss, units)]


def feed_number(feed: Decimal, radius: Decimal, boss: Boss, units: Units) -> int:
    """The F number for a rotary cut at `feed` (per minute, along the cutter path) on a
    cutter-path `radius` (same unit). Raises ValueError outside the control's range."""
    if radius <= 0:
        raise ValueError("the cutter-path radius must be more than 0")
    number = int((feed / (radius * _FEED_FACTOR[(boss, units)])).to_integral_value(ROUND_HALF_UP))
    low, high = FEED_RANGE[(boss, units)]
    if not low <= number <= high:
        raise ValueError(f"feed number F{number} is outside {low}-{high}")
    return number
