"""Lengths, feeds and their exact internal representation.

Programs are typed in inches (to 0.001 in) or millimetres (to 0.01 mm). Loops and copies add
offsets thousands of times, so the tool path keeps every length as an integer number of
nanometres: 0.0001 in is exactly 2 540 nm and 0.01 mm exactly 10 000 nm, so both units and
every resolution a target uses are represented without error (DESIGN.md §2). Geometry that
needs trigonometry is computed in floats and rounded once, with `round_nm`.

Feeds are integer nanometres per minute for the same reason (0.1 ipm = 2 540 000 nm/min).
"""

from __future__ import annotations

import enum
from decimal import Decimal
from fractions import Fraction
from typing import Final

# Final: the compiled importer (app.cnc.native) then has them as constants.
NM_PER_INCH: Final = 25_400_000
NM_PER_MM: Final = 1_000_000


class Units(enum.Enum):
    """The unit a block's dimensions and feeds are typed in."""

    INCH = "inch"
    MM = "mm"

    @property
    def nm(self) -> int:
        """Nanometres in one unit."""
        return NM_PER_INCH if self is Units.INCH else NM_PER_MM

    @property
    def resolution(self) -> Decimal:
        """The smallest step a dimension is programmed in (seed 001 §3.4.5.1)."""
        return Decimal("0.001") if self is Units.INCH else Decimal("0.01")

    @property
    def resolution_nm(self) -> int:
        """`resolution` in nanometres: 25 400 (0.001 in) or 10 000 (0.01 mm)."""
        return 25_400 if self is Units.INCH else 10_000

    @property
    def symbol(self) -> str:
        """Short name used in messages: `in` or `mm`."""
        return "in" if self is Units.INCH else "mm"

    @property
    def feed_symbol(self) -> str:
        """Feed unit used in messages: `ipm` or `mm/min`."""
        return "ipm" if self is Units.INCH else "mm/min"

    @property
    def dump_places(self) -> int:
        """Decimal places used when printing lengths of this unit (0.0001 in, 0.001 mm)."""
        return 4 if self is Units.INCH else 3


def to_nm(value: Decimal | int, units: Units) -> int:
    """Convert a typed length to nanometres, rounding half-even to the nearest nanometre.

    Values at the programming resolution (0.001 in, 0.01 mm) convert exactly.
    """
    exact = Decimal(value) * units.nm
    return int(exact.to_integral_value())


def half_even(numerator: int, denominator: int) -> int:
    """numerator / denominator (denominator > 0) rounded half to even, as
    `round(Fraction(numerator, denominator))` in integers alone (a tape rounds every length
    and feed it punches, an importer every length it reads: a Fraction each was a fifth of
    the tape's time)."""
    quotient, remainder = divmod(numerator, denominator)  # floor: 0 <= remainder < denominator
    twice = 2 * remainder
    if twice > denominator or (twice == denominator and quotient % 2):
        quotient += 1
    return quotient


def round_nm(value: float | Fraction) -> int:
    """Round a computed length (floats from trigonometry, or exact fractions) to nanometres."""
    return round(value)


def format_length(nm: int, units: Units, places: int | None = None) -> str:
    """Format nanometres in `units` with fixed decimals, rounding half-even.

    `places` defaults to the unit's dump resolution (4 for inches, 3 for mm).
    """
    digits = units.dump_places if places is None else places
    value = Decimal(nm) / Decimal(units.nm)
    quantum = Decimal(1).scaleb(-digits)
    text = f"{value.quantize(quantum):f}"
    return "0." + "0" * digits if text.lstrip("-") == "0." + "0" * digits else text


def message_length(nm: int, units: Units) -> str:
    """A length for a message: at the unit's programming resolution, with its symbol
    ("0.010 in", "0.25 mm")."""
    places = 3 if units is Units.INCH else 2
    return f"{format_length(nm, units, places)} {units.symbol}"


def format_decimal(value: Decimal) -> str:
    """A typed value as the machinist typed it, without exponent notation (except for
    values too large to spell out, such as 1E+30)."""
    if value.is_finite() and abs(value) > Decimal(10) ** 12:
        return str(value.normalize())
    return f"{value:f}"
