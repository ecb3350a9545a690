"""Helical motion shared by the operations that cut along a helix (HELIX, THREAD MILL).

Lengths are integer nanometres; a helix is written one row per turn (app/cnc/path.py): the
end points here are those rows' ends. Depths and pitches are whole nanometres, so how many
turns a depth takes is exact.
"""

from __future__ import annotations

import math

Point = tuple[int, int, int]


def helix_ends(
    start: Point, centre: tuple[int, int], z_end: int, pitch: int, clockwise: bool
) -> list[Point]:
    """The ends of the rows of a helix from `start` about `centre` to `z_end`, rising or
    falling `pitch` (nm, > 0) per turn: one row per whole turn (ending over `start`), then
    one for what is left of a turn (ending where that part of a turn takes it).

    Raises ValueError for a pitch that is not positive."""
    if pitch <= 0:
        raise ValueError("a helix's pitch must be more than 0")
    x, y, z = start
    cx, cy = centre
    depth = abs(z_end - z)
    way = 1 if z_end > z else -1
    whole, rest = divmod(depth, pitch)
    ends = [(x, y, z + way * pitch * k) for k in range(1, whole + 1)]
    if rest:
        radius = math.hypot(x - cx, y - cy)
        turn = 2 * math.pi * rest / pitch
        angle = math.atan2(y - cy, x - cx) + (-turn if clockwise else turn)
        ends.append(
            (round(cx + radius * math.cos(angle)), round(cy + radius * math.sin(angle)), z_end)
        )
    return ends
