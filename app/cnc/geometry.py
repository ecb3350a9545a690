"""Small exact-geometry helpers shared by validation and the interpreter (lengths in nm)."""

from __future__ import annotations

import functools
import math
from decimal import Decimal

from app.cnc.blocks import Mode
from app.cnc.units import Units, round_nm, to_nm


def resolve_xy(
    x: Decimal, y: Decimal, mode: Mode, units: Units, reference: tuple[int, int]
) -> tuple[int, int]:
    """A block's X/Y as an absolute point in nm: typed values, or `reference` plus them (INC)."""
    px, py = to_nm(x, units), to_nm(y, units)
    if mode is Mode.INC:
        return reference[0] + px, reference[1] + py
    return px, py


def distance(a: tuple[int, int], b: tuple[int, int]) -> float:
    """Euclidean distance between two XY points, in nm."""
    return math.hypot(b[0] - a[0], b[1] - a[1])


def bolt_circle_points(
    centre: tuple[int, int], radius: int, holes: int, angle_deg: Decimal
) -> list[tuple[int, int]]:
    """Hole centres of a bolt circle, in the order the control drills them.

    The angle is measured clockwise (seen from above) from the lower vertical centre line
    (seed 001 Fig. 3-3; DESIGN.md §3): angle 0 is straight below the centre, 90° to its left.
    Hole k is at centre + R·(−sin θk, −cos θk) with θk = A + k·360°/N, taken clockwise.
    Each coordinate is rounded once to the nanometre.
    """
    cx, cy = centre
    return [(cx + dx, cy + dy) for dx, dy in _bolt_offsets(radius, holes, angle_deg)]


@functools.lru_cache(maxsize=256)
def _bolt_offsets(radius: int, holes: int, angle_deg: Decimal) -> tuple[tuple[int, int], ...]:
    """The holes of a bolt circle from its centre (nm), each rounded to the nanometre: the
    same for every circle of one radius, count and angle (an imported file's pattern of
    circles computes them once)."""
    first = float(angle_deg)
    offsets = []
    for k in range(holes):
        theta = math.radians(first + k * 360.0 / holes)
        offsets.append((round_nm(-radius * math.sin(theta)), round_nm(-radius * math.cos(theta))))
    return tuple(offsets)


def arc_sweep(
    start: tuple[float, float],
    end: tuple[float, float],
    centre: tuple[float, float],
    clockwise: bool,
) -> float:
    """The angle (radians, > 0) an arc turns through; a full circle when it ends at its start."""
    a0 = math.atan2(start[1] - centre[1], start[0] - centre[0])
    a1 = math.atan2(end[1] - centre[1], end[0] - centre[0])
    turn = (a0 - a1) if clockwise else (a1 - a0)
    turn %= 2 * math.pi
    return turn if turn > 1e-12 else 2 * math.pi


def chord_step(radius: float, tolerance: float) -> float:
    """The largest angle (radians, at most 90°) one chord of an arc of `radius` may turn
    through and stay within `tolerance` of the arc (both in nm)."""
    if tolerance >= radius:
        return math.pi / 2
    return min(math.pi / 2, 2 * math.acos(1 - tolerance / radius))


def arc_points(
    start: tuple[int, int, int],
    end: tuple[int, int, int],
    centre: tuple[int, int],
    clockwise: bool,
    step: float,
) -> list[tuple[int, int, int]]:
    """The ends of equal chords along an arc from `start` to `end` (x, y, z in nm), each
    turning through at most `step` radians; the last is `end` exactly.

    The arc is helical when the two Zs differ: Z changes in proportion to the angle turned,
    so each chord's end is on the helix. Each coordinate is rounded once to the nanometre.
    An arc that ends where it starts in XY is a whole turn (`arc_sweep`).
    """
    cx, cy = centre
    radius = math.hypot(start[0] - cx, start[1] - cy)
    sweep = arc_sweep((start[0], start[1]), (end[0], end[1]), (cx, cy), clockwise)
    count = max(1, math.ceil(sweep / step - 1e-9))
    a0 = math.atan2(start[1] - cy, start[0] - cx)
    sign = -1.0 if clockwise else 1.0
    rise = end[2] - start[2]
    points = []
    for k in range(1, count):
        angle = a0 + sign * sweep * k / count
        points.append(
            (
                round(cx + radius * math.cos(angle)),
                round(cy + radius * math.sin(angle)),
                start[2] + round(rise * k / count),
            )
        )
    points.append(end)
    return points
