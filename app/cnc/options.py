"""Typed options of an export target or an import format: name, kind, default, meaning.

Both registries (app.cnc.formats.targets for targets, app.cnc.formats.importers for import
formats) declare their options with `Option`, so the command line, the web forms and the
machine presets list them from one declaration.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from decimal import Decimal
from typing import Any

from app.cnc.numbers import NumberError, parse_decimal


class OptionKind(enum.Enum):
    """How an option's text value is read."""

    BOOL = "bool"
    INT = "int"
    DECIMAL = "decimal"
    CHOICE = "choice"
    TEXT = "text"


class OptionError(ValueError):
    """An option that does not exist for the target or whose value cannot be read."""


_TRUE = {"1", "true", "yes", "on"}
_FALSE = {"0", "false", "no", "off"}


@dataclass(frozen=True)
class Option:
    """One export option: its name (as on the command line), kind, default and meaning."""

    name: str
    kind: OptionKind
    default: Any
    help: str
    choices: tuple[str, ...] = ()
    minimum: Decimal | None = None
    maximum: Decimal | None = None

    def parse(self, raw: str) -> Any:
        """The value of `raw` for this option. Raises OptionError saying what is allowed."""
        text = raw.strip()
        if self.kind is OptionKind.BOOL:
            if text.lower() in _TRUE:
                return True
            if text.lower() in _FALSE:
                return False
            raise OptionError(f"option {self.name}: {raw!r} is not yes/no (true/false, 1/0)")
        if self.kind is OptionKind.CHOICE:
            if text not in self.choices:
                allowed = ", ".join(self.choices)
                raise OptionError(f"option {self.name}: {raw!r} is not one of {allowed}")
            return text
        if self.kind is OptionKind.TEXT:
            return raw
        try:
            number = parse_decimal(text)
        except NumberError as exc:
            raise OptionError(f"option {self.name}: {exc}") from None
        if self.kind is OptionKind.INT and number != number.to_integral_value():
            raise OptionError(f"option {self.name}: {raw!r} is not a whole number")
        low, high = self.minimum, self.maximum
        if (low is not None and number < low) or (high is not None and number > high):
            raise OptionError(
                f"option {self.name}: {raw} is outside the allowed range {low} to {high}"
            )
        return int(number) if self.kind is OptionKind.INT else number
