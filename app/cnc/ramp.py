"""Ramp entry for pocketing routines (issue 33): going down to each depth level on a
helical or zigzag ramp at a stated angle instead of plunging.

The ramp replaces the feed straight down at the entry point of the first pass (the point
a plunge would go down at). A HELIX ramp goes round a circle whose path is half the tool's
DIA across (docs/readings.md, "Ramp entry"), on the pocket's side of the entry point (its
centre straight in from it, away from the wall), round the way the routine goes; it goes
down `tan(angle)` per unit of its length and ends at depth at the entry point. It starts
where that length, measured back along the circle from the entry point, puts it. A ZIGZAG
ramp goes back and forth along a straight (a chord of the first pass's region) from the
entry point straight in, the tool's DIA long, at the same slope, ending at depth at the
entry point.

Lengths are nanometres (floats for the geometry, integers for the rows the compile
writes); angles of the block in degrees.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from decimal import Decimal

# The ramp angle when the block states none (degrees): a machinist's default for an end
# mill ramping into aluminium or steel.
DEFAULT_ANGLE = Decimal(3)

Pt = tuple[float, float]


@dataclass(frozen=True)
class Ramp:
    """A helical ramp: about `centre` at `radius` (nm), round `clockwise` (seen from above),
    ending over `entry`, going down `tan(angle)` per unit of length (`angle` in radians)."""

    entry: Pt
    centre: Pt
    radius: float
    clockwise: bool
    angle: float

    def rows(self, z_from: int, z_to: int) -> tuple[tuple[int, int], list[tuple[int, int, int]]]:
        """Where the ramp from `z_from` down to `z_to` (nm) starts (x, y), and the ends of
        its rows (x, y, z): one row a whole turn (ending over the start), the last ending
        over the entry point at `z_to`. A ramp that is less than a nanometre's turn from
        whole turns starts over the entry point."""
        drop = z_from - z_to
        pitch = 2 * math.pi * self.radius * math.tan(self.angle)  # the depth of one turn
        turns = drop / pitch
        whole = math.floor(turns)
        rest = turns - whole
        ex, ey = self.entry
        cx, cy = self.centre
        if rest * 2 * math.pi * self.radius < 1:
            rest = 0.0
        # Back from the entry point by what is left over a whole number of turns.
        back = 2 * math.pi * rest * (1 if self.clockwise else -1)
        a = math.atan2(ey - cy, ex - cx) + back
        start = (
            (round(cx + self.radius * math.cos(a)), round(cy + self.radius * math.sin(a)))
            if rest
            else (round(ex), round(ey))
        )
        ends = [(*start, z_from - round(k * pitch)) for k in range(1, whole + 1)]
        if rest or not ends:
            ends.append((round(ex), round(ey), z_to))
        else:
            ends[-1] = (round(ex), round(ey), z_to)
        return start, ends


@dataclass(frozen=True)
class Zigzag:
    """A zigzag ramp: back and forth between `entry` and `far` (nm), ending over `entry`,
    going down `tan(angle)` per unit of length (`angle` in radians)."""

    entry: Pt
    far: Pt
    angle: float

    def rows(self, z_from: int, z_to: int) -> tuple[tuple[int, int], list[tuple[int, int, int]]]:
        """Where the ramp from `z_from` down to `z_to` (nm) starts (x, y), and the ends of
        its rows (x, y, z): one row a leg of the straight, the last ending over the entry
        point at `z_to`. The first row is what is left over whole legs (none when that is
        under a nanometre)."""
        ex, ey = self.entry
        fx, fy = self.far
        leg = math.dist(self.entry, self.far)
        slope = math.tan(self.angle)
        total = (z_from - z_to) / slope  # the length the ramp goes along
        whole = math.floor(total / leg)
        rest = total - whole * leg
        if rest < 1:
            rest = 0.0
        ux, uy = (fx - ex) / leg, (fy - ey) / leg
        # Walking back from the entry point: after an odd number of legs the far end.
        if whole % 2 == 0:
            start = (ex + ux * rest, ey + uy * rest)
        else:
            start = (fx - ux * rest, fy - uy * rest)
        ends: list[tuple[int, int, int]] = []
        if rest:
            x, y = (ex, ey) if whole % 2 == 0 else (fx, fy)
            ends.append((round(x), round(y), z_to + round(whole * leg * slope)))
        for k in range(whole, 0, -1):
            x, y = (ex, ey) if (k - 1) % 2 == 0 else (fx, fy)
            ends.append((round(x), round(y), z_to + round((k - 1) * leg * slope)))
        if not ends:
            ends.append((round(ex), round(ey), z_to))
        return (round(start[0]), round(start[1])), ends


def angle_of(stated: Decimal | None) -> Decimal:
    """The ramp angle in degrees: as stated, or `DEFAULT_ANGLE`."""
    return DEFAULT_ANGLE if stated is None else stated


def helix_radius(tool_radius: float) -> float:
    """The radius (nm) of a helical ramp's path: half the tool's radius, so the path is
    half the tool's DIA across. The tool then covers the centre of the circle (no post is
    left), and a non-centre-cutting end mill's core (up to half its DIA across) never
    stands still over uncut material (docs/readings.md)."""
    return tool_radius / 2


def zigzag_length(tool_radius: float) -> float:
    """The length (nm) of a zigzag ramp's straight: the tool's DIA, so each leg moves the
    tool a whole DIA on from where it went down the leg before (docs/readings.md)."""
    return 2 * tool_radius


def zigzag_ramp(entry: Pt, inward: Pt, length: float, angle: Decimal) -> Zigzag:
    """The zigzag ramp ending at `entry` whose straight goes `length` (nm;
    `zigzag_length`) along the unit vector `inward` (into the pocket), `angle` degrees."""
    far = (entry[0] + inward[0] * length, entry[1] + inward[1] * length)
    return Zigzag(entry, far, math.radians(float(angle)))


def helix_ramp(entry: Pt, inward: Pt, clockwise: bool, radius: float, angle: Decimal) -> Ramp:
    """The helical ramp of `radius` (nm; `helix_radius`) ending at `entry`, its centre
    `radius` from it along the unit vector `inward` (into the pocket, away from the wall),
    round `clockwise` as the routine goes, `angle` degrees."""
    centre = (entry[0] + inward[0] * radius, entry[1] + inward[1] * radius)
    return Ramp(entry, centre, radius, clockwise, math.radians(float(angle)))
