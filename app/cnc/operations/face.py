"""FACE's passes (blocks.Face): where the tool goes in one level, in nm.

Passes run along X, the tool's centre from `clear` plus its radius beyond the rectangle's
left edge to as far beyond its right edge (the tool fully off the part at both ends). The
rows are evenly spaced in Y, at most `step` apart, from the row whose tool edge runs
`overhang` below the rectangle's lower edge to the one whose edge runs as far above its
upper edge (`overhang` is the smaller of the clearance and the tool's radius, so the tool
always overlaps the part); a rectangle narrower than that is one row through its centre.
Zig-zag rows alternate +X and −X starting +X; one-way rows all go +X.
"""

from __future__ import annotations

import math
from decimal import Decimal
from typing import TYPE_CHECKING

from app.cnc import limits
from app.cnc.blocks import Face, FacePattern
from app.cnc.compiler import retract_height
from app.cnc.cost import LEVEL_ROWS, POS_ROWS
from app.cnc.routines import peck_levels
from app.cnc.units import Units, to_nm

if TYPE_CHECKING:
    from app.cnc.blocks import Face, Program
    from app.cnc.compiler import _Compiler as Compiler


def face_clear(clear: Decimal | None, units: Units) -> int:
    """FACE's CLEAR in nm: the block's (in `units`), or 0.050 in when it is empty."""
    if clear is None:
        return to_nm(limits.FACE_CLEAR_INCH, Units.INCH)
    return to_nm(clear, units)


def face_rows(
    centre: tuple[int, int], xl: int, yw: int, tool_radius: int, step: int, clear: int
) -> list[tuple[int, int, int]]:
    """(y, x from, x to) of each pass, bottom row first, every one in +X (the caller turns
    every other one round for zig-zag). Raises ValueError for a step or tool not above 0."""
    if step <= 0 or tool_radius <= 0:
        raise ValueError("a FACE needs a tool with a diameter and a step above 0")
    cx, cy = centre
    overhang = min(clear, tool_radius)
    x_from = cx - xl // 2 - tool_radius - clear
    x_to = cx + (xl - xl // 2) + tool_radius + clear
    low = cy - yw // 2 + tool_radius - overhang
    high = cy + (yw - yw // 2) - tool_radius + overhang
    if high <= low:
        return [(cy, x_from, x_to)]
    count = math.ceil((high - low) / step) + 1
    return [(low + round((high - low) * k / (count - 1)), x_from, x_to) for k in range(count)]


def estimate_moves(program: Program, block: Face) -> int:
    """About how many moves a FACE makes (its `Kind.cost`, read by cost.py): each pass a
    row per step across its width, there and back, from its numbers and its tool's DIA."""
    units = block.units
    tool = program.block0.tool(block.tool)
    diameter = 0 if tool is None or tool.diameter is None else to_nm(tool.diameter, program.units)
    step = max(diameter * block.step // 100, 1)
    rows = to_nm(block.yw, units) // step + 2
    return block.passes * (2 * rows + LEVEL_ROWS) + POS_ROWS


def cut(c: Compiler, number: int, block: Face, centre: tuple[int, int]) -> None:
    """FACE about `centre` (operations/face.py says the rows): at each of # PASS levels from
    Z UP to Z DN, down at rapid beside the part, the rows at FEEDR XY, zig-zag (step-over
    feeds off the part's end) or one-way (up to the retract height and back between).
    A block whose tool has no DIA makes no moves: validation reports it."""
    units = block.units
    tool_diameter = c.tool_diameter(block.tool)
    z_up, z_dn = to_nm(block.z_up, units), to_nm(block.z_dn, units)
    if tool_diameter is None or z_dn >= z_up:
        return
    clear = face_clear(block.clear, units)
    rows = face_rows(
        centre,
        to_nm(block.xl, units),
        to_nm(block.yw, units),
        tool_diameter // 2,
        tool_diameter * block.step // 100,
        clear,
    )
    zigzag = block.pattern is FacePattern.ZIGZAG
    feed = to_nm(block.feed_xy, units)
    c.use_tool(number, block.tool)
    c.retract = retract_height(z_up, c.z_retract)
    first = (rows[0][1], rows[0][0])
    for level in peck_levels(z_up, z_dn, block.passes):
        c.position(number, first, c.retract)
        c.rapid_z(number, level)
        for k, (y, x_from, x_to) in enumerate(rows):
            forward = not zigzag or k % 2 == 0
            start, end = (x_from, x_to) if forward else (x_to, x_from)
            if (c.x, c.y) != (start, y):
                if zigzag:
                    c.feed_to(number, (start, y, level), feed, "step-over")
                else:
                    c.retract_up(number)
                    c.rapid_xy(number, (start, y))
                    c.rapid_z(number, level)
            c.feed_to(number, (end, y, level), feed)
        c.retract_up(number)
