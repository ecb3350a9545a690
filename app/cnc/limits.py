"""The numeric limits of the data-block control, in each unit.

From seed 001 §3.4.5.1 unless marked as our reading:
- dimensions to 0.001 in / 0.01 mm;
- FEEDR Z 0.1-250.0 ipm or 2-6350 mm/min, FEEDR XY 0.1-100.0 ipm or 2-2540 mm/min, metric
  feeds in steps of 2 mm/min; inch feeds to 0.1 ipm (the ranges are written to one decimal);
- up to 24 tools, 40 pecks, 250 bolt-circle holes, bolt-circle angle to 0.01°;
- RPM 60-500 low gear, 500-4000 high gear, negative for counter-clockwise (§3.4.4): the
  control's spindle; a machine profile may give its own (app.cnc.spindle).

Our readings where the manual gives no number: a dimension's magnitude is at most 99.999 in
(2539.99 mm), the size of the 1704's ±99.9999 in capacity and far beyond any knee mill's
travel; NX and NY at most 999; the bolt-circle angle from 0 to 359.99°.
"""

from __future__ import annotations

from dataclasses import dataclass
from decimal import Decimal

from app.cnc.units import Units

RAPID_IPM = Decimal(250)
HOLE_DWELL_SECONDS = Decimal("0.8")
TAP_FEED_OUT_INCH = Decimal("0.3")
TAP_FEED_OUT_MM = Decimal("7.62")
MAX_PECKS = 40
MAX_TOOL = 24  # tools 1-24
MAX_BOLT_HOLES = 250
MAX_ISLANDS = 8  # islands in one POCKET (Hurco's conversational pockets take several)
MAX_LOOP_DEPTH = 4
MAX_THREAD_PASSES = 20  # our reading: radial passes of a THREAD MILL
# Our reading: how far beyond the major diameter an external THREAD MILL's tool comes down
# and leaves to (its edge), as the CIRCLE routines' 0.050 in.
THREAD_CLEAR_INCH = Decimal("0.05")
# Our reading: how far a FACE's tool runs off the part's edges when the block gives no CLEAR.
FACE_CLEAR_INCH = Decimal("0.05")
MAX_REPEAT = 999
MIN_RPM = 60
GEAR_CHANGE_RPM = 500
MAX_RPM = 4000
# Our reading: where a target cannot write a helical arc (an arc whose Z changes: HELIX,
# THREAD MILL), it writes straight moves whose chords stay this close to the helix on the
# tool's path: the 0.001 in of seed 002's TOL, which the 1704 tape's chords default to.
HELIX_CHORD_INCH = Decimal("0.001")
# Our reading: the allowance for one manual tool change in the cycle time (the operator
# stops, changes the tool, touches off), when the machine profile gives none.
DEFAULT_TOOL_CHANGE_SECONDS = 30.0


@dataclass(frozen=True)
class FeedLimits:
    """Allowed feed range and granularity for one unit."""

    low: Decimal
    high: Decimal
    step: Decimal


FEED_Z = {
    Units.INCH: FeedLimits(Decimal("0.1"), Decimal("250"), Decimal("0.1")),
    Units.MM: FeedLimits(Decimal(2), Decimal(6350), Decimal(2)),
}
FEED_XY = {
    Units.INCH: FeedLimits(Decimal("0.1"), Decimal("100"), Decimal("0.1")),
    Units.MM: FeedLimits(Decimal(2), Decimal(2540), Decimal(2)),
}
MAX_DIMENSION = {Units.INCH: Decimal("99.999"), Units.MM: Decimal("2539.99")}
ANGLE_RESOLUTION = Decimal("0.01")
MAX_ANGLE = Decimal("359.99")
