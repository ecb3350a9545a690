"""A machine's spindle: the speeds it runs, in one range or in gear ranges.

The data-block control's spindle (seed 001 §3.4.4) runs 60-500 rpm in low gear and 500-4000
rpm in high gear, a negative RPM the same speeds counter-clockwise. That is the spindle a
program is checked against as it is typed (a warning: it may be cut on another machine) and
the one an export is checked against when no machine is chosen; a machine profile may give
its own (`spindle=100-24000`, or gears `spindle=60-500, 500-4000`), and an export to that
machine is checked against it (app.cnc.formats.targets.export).

Whatever the machine, an RPM field takes 1 to 99 999 (five digits, either direction): beyond
that it is a typing mistake on every machine.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from app.cnc import limits

FIELD_MAX_RPM = 99_999


class SpindleError(ValueError):
    """A spindle range that cannot be read (the message says what is expected)."""


@dataclass(frozen=True)
class Spindle:
    """The speeds a spindle runs, as gear ranges (low, high) in rpm in ascending order (one
    range: no gears). `owner` names the machine in messages ("the control")."""

    gears: tuple[tuple[int, int], ...]
    owner: str = "the machine"

    @property
    def low(self) -> int:
        return self.gears[0][0]

    @property
    def high(self) -> int:
        return self.gears[-1][1]

    def runs(self, rpm: int) -> bool:
        """True when some gear runs `rpm` (negative: the same speed in reverse)."""
        return any(lo <= abs(rpm) <= hi for lo, hi in self.gears)

    def gear(self, rpm: int) -> str:
        """The gear an RPM needs ("low gear", "gear 2 of 3"; "" without gears)."""
        speed = abs(rpm)
        for k, (lo, hi) in enumerate(self.gears):
            if lo <= speed <= hi:
                return _gear_name(k, len(self.gears))
        return ""

    def range_text(self) -> str:
        """`60 to 4000 rpm (60-500 low gear, 500-4000 high gear), or -60 to -4000 in
        reverse`."""
        text = f"{self.low} to {self.high} rpm"
        if len(self.gears) > 1:
            text += (
                " ("
                + ", ".join(
                    f"{lo}-{hi} {_gear_name(k, len(self.gears))}"
                    for k, (lo, hi) in enumerate(self.gears)
                )
                + ")"
            )
        return text + f", or -{self.low} to -{self.high} in reverse"

    def text(self) -> str:
        """The form the machine profile stores: `60-500, 500-4000`."""
        return ", ".join(f"{lo}-{hi}" for lo, hi in self.gears)


def _gear_name(k: int, count: int) -> str:
    if count == 1:
        return ""
    if count == 2:
        return ("low", "high")[k] + " gear"
    return f"gear {k + 1} of {count}"


CONTROL = Spindle(
    (
        (limits.MIN_RPM, limits.GEAR_CHANGE_RPM),
        (limits.GEAR_CHANGE_RPM, limits.MAX_RPM),
    ),
    "the ProtoTRAK-style control",
)


def read_spindle(raw: object, owner: str = "the machine") -> Spindle:
    """A spindle from a machine profile's `spindle`: `100-24000`, or gear ranges separated by
    commas (`60-500, 500-4000`), or a list of [low, high] pairs. Raises SpindleError."""
    pairs: list[tuple[object, object]] = []
    if isinstance(raw, str):
        for part in raw.split(","):
            found = re.fullmatch(r"\s*(\d+)\s*(?:-|/|to)\s*(\d+)\s*(?:rpm)?\s*", part)
            if found is None:
                raise SpindleError(
                    f"{part.strip()!r} is not a range of speeds; write LOW-HIGH in rpm, "
                    "gears separated by commas (60-500, 500-4000)"
                )
            pairs.append((found.group(1), found.group(2)))
    elif isinstance(raw, list | tuple) and all(
        isinstance(p, list | tuple) and len(p) == 2 for p in raw
    ):
        pairs = [(p[0], p[1]) for p in raw]
    else:
        raise SpindleError(f"expected LOW-HIGH in rpm, got {raw!r}")
    if not pairs:
        raise SpindleError("no range of speeds given")
    gears: list[tuple[int, int]] = []
    for a, b in pairs:
        try:
            lo, hi = int(str(a)), int(str(b))
        except ValueError:
            raise SpindleError(f"{a}-{b} is not a range of whole rpm") from None
        if not 1 <= lo < hi <= FIELD_MAX_RPM:
            raise SpindleError(
                f"{lo}-{hi}: a gear runs from a lower to a higher speed, within 1 to "
                f"{FIELD_MAX_RPM} rpm"
            )
        if gears and lo < gears[-1][0]:
            raise SpindleError(f"{lo}-{hi}: list the gears from the slowest up")
        gears.append((lo, hi))
    return Spindle(tuple(gears), owner)


def refusal(number: int, rpm: int, spindle: Spindle | None) -> str:
    """Why a tool's RPM is refused for the machine exported to (`spindle` None: no machine
    chosen, or its profile gives no spindle range, so the control's is assumed)."""
    which = spindle or CONTROL
    text = f"tool {number} runs at {rpm} rpm; {which.owner}'s spindle runs {which.range_text()}"
    if spindle is None:
        return text + (
            " (no machine with a spindle range was chosen): choose a machine whose profile "
            "gives its spindle range (spindle=LOW-HIGH), or change the tool's RPM"
        )
    return text + ": change the tool's RPM, or choose a machine that runs it"
