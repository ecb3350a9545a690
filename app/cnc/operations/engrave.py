"""ENGRAVE's strokes (blocks.Engrave): text in a single-stroke Hershey font, laid along a line
or an arc, in nm.

The font is the Hershey Roman simplex ("futural") of the `Hershey-Fonts` package: one
stroke a line of the letter, no outlines, as an engraving cutter draws it. Its glyphs are
the printable ASCII characters (space to ~); any other character is refused by validation,
naming it. HEIGHT is the capital height (cap line to base line, 21 font units); letters are
spaced by the font's own widths.

Along a line the baseline starts at X, Y and runs at ANGLE (degrees counter-clockwise from
+X), the letters upright to its left. Along an arc the baseline is the circle of RAD about
X, Y from ANGLE (counter-clockwise from +X, where the text starts), the text reading
clockwise with its letters standing outward (the top of a circle), or counter-clockwise
with them standing inward (its bottom). Each point of a stroke is placed on the curve; the
stroke's segments between points stay straight (small beside the radius).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator
from typing import TYPE_CHECKING

from app.cnc.blocks import Direction, Engrave, EngraveLayout
from app.cnc.compiler import retract_height, rounded_point
from app.cnc.cost import POS_ROWS
from app.cnc.units import to_nm

if TYPE_CHECKING:
    from HersheyFonts import HersheyFonts

    from app.cnc.blocks import Engrave, Program
    from app.cnc.compiler import _Compiler as Compiler

FONT = "futural"
CAP, BASE = -12, 9  # the font's cap line and base line (its units, y down)

Pt = tuple[float, float]


@functools.cache
def _font() -> HersheyFonts:
    # Imported when a program has ENGRAVE text, not with validation (6 ms of every start).
    from HersheyFonts import HersheyFonts

    font = HersheyFonts()
    font.load_default_font(FONT)
    return font


def missing(text: str) -> str | None:
    """The first character of `text` the font has no glyph for, or None."""
    glyphs = _font().all_glyphs
    return next((c for c in text if c not in glyphs), None)


def glyph_strokes(text: str, height: float) -> Iterator[list[Pt]]:
    """The text's strokes on a baseline from (0, 0) along +X, capitals `height` high (the
    same unit as `height`), y up."""
    scale = height / (BASE - CAP)
    x = 0.0
    for glyph in _font().glyphs_for_text(text):
        for stroke in glyph.strokes:
            yield [(x + (gx - glyph.left_offset) * scale, (BASE - gy) * scale) for gx, gy in stroke]
        x += glyph.char_width * scale


def along_line(strokes: Iterator[list[Pt]], start: Pt, angle: float) -> list[list[Pt]]:
    """Strokes laid along a line from `start` at `angle` degrees counter-clockwise of +X."""
    c, s = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    sx, sy = start
    return [[(sx + u * c - v * s, sy + u * s + v * c) for u, v in stroke] for stroke in strokes]


def along_arc(
    strokes: Iterator[list[Pt]], centre: Pt, radius: float, angle: float, clockwise: bool
) -> list[list[Pt]]:
    """Strokes laid along a circle of `radius` about `centre` from `angle` degrees
    (counter-clockwise of +X): clockwise, letters standing outward; else standing inward."""
    cx, cy = centre
    a0 = math.radians(angle)
    placed = []
    for stroke in strokes:
        points = []
        for u, v in stroke:
            if clockwise:
                theta, r = a0 - u / radius, radius + v
            else:
                theta, r = a0 + u / radius, radius - v
            points.append((cx + r * math.cos(theta), cy + r * math.sin(theta)))
        placed.append(points)
    return placed


def estimate_moves(program: Program, block: Engrave) -> int:
    """About how many moves an ENGRAVE makes (its `Kind.cost`, read by cost.py): each
    stroke's points and its plunge and retract."""
    strokes = list(glyph_strokes(block.text, 1.0))
    return sum(len(s) + POS_ROWS for s in strokes) + POS_ROWS


def cut(c: Compiler, number: int, block: Engrave, at: tuple[int, int]) -> None:
    """ENGRAVE (operations/engrave.py lays the strokes out): each stroke as a DRILL and its
    MILL STD blocks would cut it — across at the retract height, down at rapid to Z UP,
    fed to Z DN at FEEDR Z, along the stroke at FEEDR XY, up to the retract height. A
    block whose text the font cannot write makes no moves: validation reports it."""
    units = block.units
    if not block.text or missing(block.text) is not None:
        return
    z_up, z_dn = to_nm(block.z_up, units), to_nm(block.z_dn, units)
    if z_dn >= z_up or (block.layout is EngraveLayout.ARC and block.radius is None):
        return
    height = float(to_nm(block.height, units))
    strokes = glyph_strokes(block.text, height)
    if block.layout is EngraveLayout.LINE:
        placed = along_line(strokes, at, float(block.angle))
    else:
        assert block.radius is not None
        radius = float(to_nm(block.radius, units))
        placed = along_arc(strokes, at, radius, float(block.angle), block.direction is Direction.CW)
    c.use_tool(number, block.tool)
    feed_z, feed = to_nm(block.feed_z, units), to_nm(block.feed_xy, units)
    c.retract = retract_height(z_up, c.z_retract)
    for stroke in placed:
        points = [rounded_point(p) for p in stroke]
        if len(points) < 2:
            continue
        c.position(number, points[0], c.retract)
        c.rapid_z(number, z_up)
        c.feed_to(number, (*points[0], z_dn), feed_z)
        for point in points[1:]:
            c.feed_to(number, (*point, z_dn), feed)
        c.retract_up(number)
