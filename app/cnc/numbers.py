"""The one number reader: what a machinist may type (or a file may hold) as a number.

Every surface that reads a number from text — the web forms, the JSON program document,
machine limits, export options, the CLI and the importers' number words — reads it here,
so they accept and refuse the same things:

- ASCII digits only: `²`, full-width `１` and Arabic-Indic `٣` are digits to Python's
  `int()` and `Decimal()`, not to a control;
- one optional sign (`--5` is refused), no `_` separators (`1_000`), no spaces inside;
- a decimal number may have a point and, where `exponent` allows it, an exponent
  (`1e3`), but never `NaN` or `Infinity`;
- bounded: at most 1E+`MAX_MAGNITUDE` in size and `MAX_FRACTION_DIGITS` places after the
  point once the exponent is applied, so `1E+999999999` is refused here instead of
  overflowing a later `quantize` (decimal.Overflow) or costing unbounded work.

Errors are `NumberError` (a ValueError) whose message says what is wrong and what is
allowed; callers put the field's name in front. Pure: no Flask, database or serial code.
"""

from __future__ import annotations

import re
from decimal import Decimal, InvalidOperation

MAX_MAGNITUDE = 30
"""The largest power of ten a number may reach (1E+30): far beyond any machine, so
validation still names the field's own range for 1e30, yet small enough that converting to
nanometres and rounding never overflows Decimal's context."""

MAX_WHOLE_DIGITS = 12
"""Digits of a whole number (tool numbers, counts, RPM)."""

MAX_FRACTION_DIGITS = 12
"""Digits after the point: a nanometre is 0.00000004 in, so 12 places lose nothing."""

MAX_LENGTH = 40
"""Characters in one number as typed, exponent included."""

DIGITS = "[0-9]"
"""A digit, for the importers' word patterns (Python's `\\d` also matches `٣` and `１`)."""

NUMBER_TEXT = r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)"
r"""A signed decimal number without exponent, ASCII digits only (the importers' words).

Written so that a run of digits can be matched one way only: `[0-9]+\.?[0-9]*` (the
importers' earlier pattern) can split `999…` anywhere, and inside a repeated group such as
G-code's whole-line pattern that made a failed match of a 400-byte line take seconds to
years (found by the long fuzz run)."""

_DECIMAL = re.compile(NUMBER_TEXT + r"(?:[eE][+-]?[0-9]+)?", re.ASCII)
_PLAIN = re.compile(NUMBER_TEXT, re.ASCII)
_WHOLE = re.compile(r"[+-]?[0-9]+", re.ASCII)

ALLOWED = "digits 0-9 with an optional sign and decimal point, such as -1.25"
ALLOWED_WHOLE = "digits 0-9 with an optional sign, such as 12"


class NumberError(ValueError):
    """Text that is not a number MillBlocks reads; the message says what is allowed."""


def quoted(text: str) -> str:
    """The text as quoted in a message (cut short: a message never echoes megabytes)."""
    return repr(text if len(text) <= MAX_LENGTH else text[:MAX_LENGTH] + "…")


def parse_decimal(text: str, *, exponent: bool = True) -> Decimal:
    """The Decimal `text` spells (surrounding spaces ignored).

    Raises NumberError for anything but ASCII digits with an optional sign, point and (with
    `exponent`) an e-exponent, and for values beyond 1E+30 or finer than 10^-12.
    """
    stripped = text.strip()
    if stripped == "":
        raise NumberError(f"no number given; allowed: {ALLOWED}")
    pattern = _DECIMAL if exponent else _PLAIN
    if len(stripped) > MAX_LENGTH or pattern.fullmatch(stripped) is None:
        raise NumberError(f"{quoted(stripped)} is not a number; allowed: {ALLOWED}")
    return check_decimal(decimal_of(stripped), stripped)


def decimal_of(text: str) -> Decimal:
    """`Decimal(text)` for text already known to spell a number (a JSON reader's token),
    refusing an exponent past what Decimal can hold at all (1e99999999999999999999)."""
    try:
        return Decimal(text)
    except InvalidOperation:
        raise NumberError(
            f"{quoted(text)} is out of range; allowed: up to 1E+{MAX_MAGNITUDE} in size and "
            f"{MAX_FRACTION_DIGITS} decimal places"
        ) from None


def check_decimal(value: Decimal, text: str | None = None) -> Decimal:
    """`value` if it is finite and inside the bounds above; NumberError otherwise.

    For numbers that arrive already parsed (a JSON document read with Decimal floats).
    """
    shown = quoted(text if text is not None else str(value))
    if not value.is_finite():
        raise NumberError(f"{shown} is not a number; allowed: {ALLOWED}")
    if value.is_zero():
        return value
    if value.adjusted() > MAX_MAGNITUDE:
        raise NumberError(f"{shown} is too large; allowed: up to 1E+{MAX_MAGNITUDE} in size")
    # Trailing zeros (1.0000000000000) are harmless; only real places count.
    # (Counted from the digits: normalize() would round to the context's precision.)
    _, digits, exponent = value.as_tuple()
    trailing = len(digits) - len("".join(map(str, digits)).rstrip("0"))
    places = -(int(exponent) + trailing)
    if places > MAX_FRACTION_DIGITS:
        raise NumberError(
            f"{shown} has too many decimal places; allowed: at most {MAX_FRACTION_DIGITS}"
        )
    return value


def parse_int(text: str) -> int:
    """The whole number `text` spells (surrounding spaces ignored).

    Raises NumberError for anything but ASCII digits with one optional sign, and for more
    than `MAX_WHOLE_DIGITS` digits.
    """
    stripped = text.strip()
    if stripped == "":
        raise NumberError(f"no number given; allowed: {ALLOWED_WHOLE}")
    if len(stripped) > MAX_LENGTH or _WHOLE.fullmatch(stripped) is None:
        raise NumberError(f"{quoted(stripped)} is not a whole number; allowed: {ALLOWED_WHOLE}")
    if len(stripped.lstrip("+-")) > MAX_WHOLE_DIGITS:
        raise NumberError(
            f"{quoted(stripped)} is too large; allowed: at most {MAX_WHOLE_DIGITS} digits"
        )
    return int(stripped)


def check_int(value: int) -> int:
    """`value` if it has at most `MAX_WHOLE_DIGITS` digits; NumberError otherwise."""
    if abs(value) >= 10**MAX_WHOLE_DIGITS:
        raise NumberError(f"{value} is too large; allowed: at most {MAX_WHOLE_DIGITS} digits")
    return value
