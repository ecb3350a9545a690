"""Helical motion shared by the operations that cut along a helix (HELIX, THREAD MILL).

Lengths are integer nanometres; a helix is written one row per turn (app/cnc/path.py): the
end points here are those rows' ends. Depths and pitches are whole nanometres, so how many
turns a depth takes is exact.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from app.cnc.blocks import Helix, Placement
from app.cnc.compiler import retract_height
from app.cnc.cost import HOLE_ROWS
from app.cnc.routines import routine_clockwise
from app.cnc.units import to_nm

if TYPE_CHECKING:
    from app.cnc.blocks import Helix, Program
    from app.cnc.compiler import _Compiler as Compiler

Point = tuple[int, int, int]
# The shortest part of a turn a helix ends with (nm): 0.001 in along the arc, ten steps of
# the finest file (0.0001 in), so its end is never written onto its start.
SHORTEST_ARC = 25_400


def helix_ends(
    start: Point, centre: tuple[int, int], z_end: int, pitch: int, clockwise: bool
) -> list[Point]:
    """The ends of the rows of a helix from `start` about `centre` to `z_end`, rising or
    falling `pitch` (nm, > 0) per turn: one row per whole turn (ending over `start`), then
    one for what is left of a turn (ending where that part of a turn takes it). What is left
    shorter than `SHORTEST_ARC` along the arc is taken by the last whole turn instead.

    Raises ValueError for a pitch that is not positive."""
    if pitch <= 0:
        raise ValueError("a helix's pitch must be more than 0")
    x, y, z = start
    cx, cy = centre
    depth = abs(z_end - z)
    way = 1 if z_end > z else -1
    whole, rest = divmod(depth, pitch)
    radius = math.hypot(x - cx, y - cy)
    turn = 2 * math.pi * rest / pitch
    if rest and radius * turn < SHORTEST_ARC:
        # What is left of a turn is too short to write: an arc whose end a file rounds onto
        # its start is a whole circle there. The last whole turn (or one turn, when there is
        # none) goes down to the end instead.
        whole, rest = max(whole, 1), 0
        ends = [(x, y, z + way * pitch * k) for k in range(1, whole)]
        return [*ends, (x, y, z_end)]
    ends = [(x, y, z + way * pitch * k) for k in range(1, whole + 1)]
    if rest:
        angle = math.atan2(y - cy, x - cx) + (-turn if clockwise else turn)
        ends.append(
            (round(cx + radius * math.cos(angle)), round(cy + radius * math.sin(angle)), z_end)
        )
    return ends


def estimate_moves(program: Program, block: Helix) -> int:
    """About how many moves a HELIX makes (its `Kind.cost`, read by cost.py): a row a turn
    down its depth, from its numbers alone (a pitch of nearly nothing is refused before its
    compile works it out)."""
    units = block.units
    depth = max(to_nm(block.z_up, units) - to_nm(block.z_dn, units), 0)
    return depth // max(to_nm(block.pitch, units), 1) + HOLE_ROWS


def cut(c: Compiler, number: int, block: Helix, centre: tuple[int, int]) -> None:
    """HELIX about `centre` (blocks.Helix says the motion). A block whose tool cannot
    cut the diameter (no DIA, or not smaller than the bore's) makes no moves:
    validation reports it."""
    units = block.units
    tool_diameter = c.tool_diameter(block.tool)
    if tool_diameter is None:
        return
    radius = (to_nm(block.diameter, units) - tool_diameter) // 2
    z_up, z_dn = to_nm(block.z_up, units), to_nm(block.z_dn, units)
    if radius <= 0 or z_dn >= z_up:
        return
    c.use_tool(number, block.tool)
    milling = block.milling or c.program.block0.milling
    clockwise = routine_clockwise(Placement.INSIDE, milling, c.spindle_rpm(block.tool))
    feed = to_nm(block.feed_xy, units)
    start = (centre[0] + radius, centre[1])
    c.retract = retract_height(z_up, c.z_retract)
    c.position(number, start, c.retract)
    c.rapid_z(number, z_up)
    pitch = to_nm(block.pitch, units)
    for end in helix_ends((*start, z_up), centre, z_dn, pitch, clockwise):
        c.helix_to(number, end, centre, clockwise, feed)
    # The whole turn at Z DN: the bottom flat and the wall to size all round.
    c.helix_to(number, (c.x, c.y, z_dn), centre, clockwise, feed)
    if 2 * radius <= tool_diameter:
        # The tool covers the centre (no core is left): off the wall to it.
        c.feed_to(number, (*centre, z_dn), feed, "lead-out")
    c.retract_up(number)
