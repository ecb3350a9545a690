"""ProtoTRAK Plus events (seed 003 §2.2): the events, their words and their numbers, once.

The reader (reader.py) makes these events from a file and then data blocks from them; the
writer (writer.py) makes them from data blocks and then the file. Lengths are nm, feeds
nm/min; `source` is where an event came from: the data block it was made for (writing) or
the file line it was read from (reading).

Numbers (§2.2.4): inch dimensions to 0.0001 in, metric to 0.01 mm (both exact in nm);
feeds 0.1-99.9 ipm and 5-2535 mm/min; dimensions and conrad ±99.9999 in / ±9999.99 mm;
FE/LE event references 1-255; line numbers 0-999. A number written without a decimal
point has implied decimals (4 in inches, 2 in mm; 3 for an angle; 1 for an inch feed), so
the writer always writes the point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from decimal import ROUND_HALF_EVEN, Decimal
from fractions import Fraction

from app.cnc.numbers import parse_decimal
from app.cnc.units import Units

XY = tuple[int, int]
Pt = tuple[float, float]

# §2.2.4: inch dimensions to 0.0001 in, metric to 0.01 mm; both exact in nanometres.
RESOLUTION_NM = {Units.INCH: 2_540, Units.MM: 10_000}
PLACES = {Units.INCH: 4, Units.MM: 2}
MAX_DIMENSION_NM = {Units.INCH: 99_9999 * 2_540, Units.MM: 9999_99 * 10_000}
FEED_RANGE_NM = {
    Units.INCH: (2_540_000, 999 * 2_540_000),
    Units.MM: (5 * 1_000_000, 2535 * 1_000_000),
}
MAX_EVENT_REFERENCE = 255
MAX_LINE_NUMBER = 999

# TC (§2.2.4): the tool centre on the line, right or left of the travel.
TOOL_CENTRE, TOOL_RIGHT, TOOL_LEFT = 0, 1, 2

# The words of each event in the order of the §2.2.5 listing (N and G lead every event);
# an arc may give its centre as I J (from its begin point) instead of XC YC.
WORDS: dict[int, tuple[str, ...]] = {
    100: ("X", "Y", "T"),
    101: ("XB", "YB", "XE", "YE", "TC", "F", "D", "CR", "T"),
    102: ("XB", "YB", "XE", "YE", "XC", "YC", "F", "TC", "D", "CR", "T"),
    104: ("XC", "YC", "HL", "R", "A", "T"),
    105: ("FE", "LE", "XO", "YO", "RE", "D", "T"),
    106: ("XB", "YB", "XD", "YD", "DR", "TC", "FC", "F", "D", "CR", "T"),
    108: ("XC", "YC", "R", "DR", "TC", "FC", "F", "D", "T"),
}
WORDS[103] = WORDS[102]
WORDS[107] = WORDS[106]
WORDS[109] = WORDS[108]
ARC_CENTRE_WORDS = ("I", "J")


def _moved(p: XY, shift: XY) -> XY:
    return (p[0] + shift[0], p[1] + shift[1])


@dataclass(frozen=True, slots=True)
class Position:
    """G100 Position event (§2.2.5 N001): go to X Y with tool T."""

    source: int
    at: XY
    tool: int

    code = 100

    def moved(self, shift: XY) -> Position:
        return replace(self, at=_moved(self.at, shift))


@dataclass(frozen=True, slots=True)
class Mill:
    """G101 Mill (a line), G102 Arc CW or G103 Arc CCW event (§2.2.5 N002-N004).

    `centre` is None for a line. `comp` is TC (0 centre, 1 right, 2 left); `conrad` the
    corner radius into the next event, None for `CR-` (not connected).
    """

    source: int
    begin: XY
    end: XY
    centre: XY | None
    clockwise: bool
    comp: int
    feed: int
    diameter: int | None
    conrad: int | None
    tool: int

    @property
    def code(self) -> int:
        if self.centre is None:
            return 101
        return 102 if self.clockwise else 103

    def moved(self, shift: XY) -> Mill:
        centre = None if self.centre is None else _moved(self.centre, shift)
        return replace(
            self, begin=_moved(self.begin, shift), end=_moved(self.end, shift), centre=centre
        )


@dataclass(frozen=True, slots=True)
class Bolthole:
    """G104 Bolthole event (§2.2.5 N005): HL holes on radius R about XC YC.

    `angle` is the Plus's A: degrees counter-clockwise from +X to the first hole; the
    others follow counter-clockwise.
    """

    source: int
    centre: XY
    holes: int
    radius: int
    angle: Decimal
    tool: int

    code = 104

    def moved(self, shift: XY) -> Bolthole:
        return replace(self, centre=_moved(self.centre, shift))


@dataclass(frozen=True, slots=True)
class Repeat:
    """G105 Repeat event (§2.2.5 N006): events FE…LE again RE times, the k-th shifted
    k·(XO, YO)."""

    source: int
    first: int
    last: int
    offset: XY
    repeats: int
    tool: int
    diameter: int | None

    code = 105

    def moved(self, shift: XY) -> Repeat:
        return self


@dataclass(frozen=True, slots=True)
class Routine:
    """G106/G107 rectangular and G108/G109 circular pocket/frame (§2.2.5 N007-N010).

    A rectangle has its lower-left corner at `point` (XB YB), the diagonal corner at
    `diagonal` (XD YD) and corner radius `radius` (CR); a circle its centre at `point`
    (XC YC) and radius `radius` (R). `clockwise` is DR 1; `finish` is FC, the finishing
    allowance.
    """

    source: int
    rectangular: bool
    pocket: bool
    point: XY
    diagonal: XY | None
    radius: int
    clockwise: bool
    comp: int
    finish: int
    feed: int
    diameter: int | None
    tool: int

    @property
    def code(self) -> int:
        return (106 if self.rectangular else 108) + (0 if self.pocket else 1)

    def moved(self, shift: XY) -> Routine:
        diagonal = None if self.diagonal is None else _moved(self.diagonal, shift)
        return replace(self, point=_moved(self.point, shift), diagonal=diagonal)


Event = Position | Mill | Bolthole | Repeat | Routine


# -- numbers (§2.2.4) ------------------------------------------------------------------------


def steps(nm: int, units: Units) -> int:
    """A length in the Plus's steps (0.0001 in, 0.01 mm), rounded half-even."""
    return round(Fraction(nm, RESOLUTION_NM[units]))


def written(nm: int, units: Units) -> int:
    """A length (nm) as the file carries it: rounded to the Plus's resolution, back in nm."""
    return steps(nm, units) * RESOLUTION_NM[units]


def _text(value: Decimal) -> str:
    """Trailing zeros dropped, one decimal kept (`1.0`, `-2.45`); zero is `0` (§2.2.5)."""
    if value == 0:
        return "0"
    text = f"{value.normalize():f}"
    return text if "." in text else text + ".0"


def format_dimension(nm: int, units: Units) -> str:
    """A length as the Plus reads it: `12.3456` in, `1234.56` mm, always with a point."""
    return _text(Decimal(steps(nm, units)).scaleb(-PLACES[units]))


def format_feed(nm_per_minute: int, units: Units) -> str:
    """A feed: inch per minute with one decimal (`F8.0`), mm per minute whole (`F250`).

    §2.2.4: an inch feed without a point is read in tenths (`F1` = 0.1 ipm), so it always
    has one; a metric feed is a whole number of mm/min.
    """
    if units is Units.INCH:
        tenths = round(Fraction(nm_per_minute, 2_540_000))
        return f"{Decimal(tenths).scaleb(-1):.1f}"
    return str(round(Fraction(nm_per_minute, 1_000_000)))


def format_angle(degrees: Decimal) -> str:
    """An angle in degrees to 0.001° (§2.2.4 `A-300.000`), e.g. `45.0`."""
    return _text(degrees.quantize(Decimal("0.001"), rounding=ROUND_HALF_EVEN))


def implied(text: str, places: int) -> Decimal:
    """A number as written: with its point as it stands, without one `places` implied
    decimals (§2.2.4: `+1234` is 0.1234 in)."""
    value = parse_decimal(text, exponent=False)
    return value if "." in text else value.scaleb(-places)


# -- bolt circles (DESIGN.md §3) -------------------------------------------------------------


def plus_angle(theta0: Decimal) -> Decimal:
    """The G104 angle A for a BOLT CIR whose first hole is at `theta0`.

    MillBlocks measures θ clockwise from straight below the centre; the Plus measures A
    counter-clockwise from +X. The same first hole: A = 270° − θ0, in [0°, 360°).
    """
    angle = (Decimal(270) - theta0) % 360
    return angle + 360 if angle < 0 else angle


def millblocks_angle(a_plus: Decimal) -> Decimal:
    """The BOLT CIR angle θ0 for a G104 angle A (the inverse, θ0 = 270° − A)."""
    return plus_angle(a_plus)


def plus_holes(centre: Pt, radius: float, holes: int, angle: Decimal) -> list[Pt]:
    """Hole centres of a G104 in the Plus's order: from `angle` counter-clockwise from +X."""
    points = []
    for k in range(holes):
        a = math.radians(float(angle) + k * 360.0 / holes)
        points.append((centre[0] + radius * math.cos(a), centre[1] + radius * math.sin(a)))
    return points
