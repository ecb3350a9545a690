"""Parts a machinist would program, each with the part it means to make, written apart.

A `Layout` is a rectangular part (an outside profile) holding features in a grid of
slots: frame and circle pockets (0.3 in from the profile's wall at the edge slots),
drilled holes, tapped and bored holes with their pilots, through holes, bolt circles, a
pocket with a hole in its floor. `build(layout)` writes the program's blocks the way the
control asks for them, and, beside them and from the layout alone (not from the
program), the removal the part means: shapely shapes with their depths. The tests compare
the simulated part's volume inside the profile with the shapes' volume, and Verify's
findings with none (or with the one mistake a case plants).

Inches throughout; the stock sits on 0.125 in parallels, so a through hole is declared.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from decimal import Decimal

from shapely.geometry import Point, Polygon, box
from shapely.geometry.base import BaseGeometry
from shapely.ops import unary_union

from app.cnc.blocks import (
    Block,
    BoltCircle,
    Circle,
    Comp,
    DataBlock0,
    Frame,
    Hole,
    HoleOp,
    MillLine,
    Placement,
    Program,
    Stock,
    Tool,
)

D = Decimal
SLOT = 1.25  # in: a feature's square
WALL = 0.3  # in: from the profile's wall to the nearest slot
THICK = 0.75  # in: the stock's height
CLEAR = 0.125  # in: the parallels under it
# Tools: number -> (diameter, what)
TOOLS = {
    1: (0.5, "1/2 end mill"),
    2: (0.25, "1/4 end mill"),
    3: (0.201, "#7 drill"),
    4: (0.25, "1/4-20 tap"),
    5: (0.25, "1/4 drill"),
    6: (0.375, "3/8 boring bar"),
    7: (0.1875, "3/16 end mill"),
}
DRILL_POINT = math.tan(math.radians(59))  # 118° point: height = radius / tan 59°

FEATURES = (
    "frame",
    "circle",
    "drill",
    "tap",
    "bore",
    "through",
    "bolts",
    "pocket-hole",
    "frame-2p",
    "empty",
)


@dataclass(frozen=True)
class Layout:
    """`features` row by row over `columns` slots; `profile_depth` in (negative), or
    "through"; `mistake` one of MISTAKES or ""."""

    columns: int
    features: tuple[str, ...]
    profile_depth: float | str = -0.5  # or "through"
    pocket_depth: float = -0.2
    hole_depth: float = -0.45
    profile_last: bool = True
    mistake: str = ""


MISTAKES = (
    "undrilled-tap",
    "drill-below-stock",
    "profile-wrong-side",
    "tool-too-big-for-corner",
    "pocket-deeper-than-stock",
)


@dataclass
class Built:
    """A program with the removal it means (shape, depth) and where its mistake is."""

    program: Program
    cuts: list[tuple[BaseGeometry, float]]
    outline: Polygon
    # The block numbers a planted mistake may be named by, and the finding's kind.
    mistake_blocks: set[int] = field(default_factory=set)
    mistake_kind: str = ""
    perimeter_depth: float = 0.0  # Σ perimeter × depth of the cuts, for the cell error


def _d(v: float) -> Decimal:
    return D(f"{v:.3f}")


def _hole(op: HoleOp, x: float, y: float, depth: float, tool: int, z_up: float = 0.1) -> Hole:
    return Hole(
        op=op,
        x=_d(x),
        y=_d(y),
        z_up=_d(z_up),
        z_dn=_d(depth),
        feed_z=D(4),
        tool=tool,
    )


def _drilled(x: float, y: float, depth: float, tool: int) -> tuple[BaseGeometry, float]:
    """A drilled hole as a flat disc of the same volume (the point's cone is a third of
    its cylinder: 2/3 of its height comes off)."""
    r = TOOLS[tool][0] / 2
    return Point(x, y).buffer(r, 256), depth + (2 / 3) * r / DRILL_POINT


def build(layout: Layout) -> Built:
    rows = math.ceil(len(layout.features) / layout.columns)
    width = 2 * WALL + layout.columns * SLOT
    height = 2 * WALL + rows * SLOT
    bottom = -THICK
    through_depth = bottom - 0.1  # a 1/4 drill's point (0.075 in) clears the bottom
    features: list[Block] = []
    cuts: list[tuple[BaseGeometry, float]] = []
    perimeter_depth = 0.0
    mistake_blocks: set[int] = set()
    kind = ""
    mistake = layout.mistake

    def add_cut(shape: BaseGeometry, depth: float) -> None:
        nonlocal perimeter_depth
        cuts.append((shape, depth))
        perimeter_depth += shape.length * -depth

    def mark(*blocks: Block) -> None:
        for block in blocks:
            mistake_blocks.add(id(block))

    planted = False
    for k, feature in enumerate(layout.features):
        col, row = k % layout.columns, k // layout.columns
        x0 = WALL + col * SLOT + 0.125
        y0 = WALL + row * SLOT + 0.125
        size = SLOT - 0.25  # 1.0 in
        cx, cy = x0 + size / 2, y0 + size / 2
        plant = not planted and mistake != "" and feature in _PLANTABLE.get(mistake, ())
        if plant:
            planted = True
        depth = layout.pocket_depth
        if feature in ("frame", "frame-2p"):
            corner = 0.2
            tool = 2
            if plant and mistake == "tool-too-big-for-corner":
                tool, corner = 1, 0.125  # a 1/2 end mill in 0.125 in corners
            if plant and mistake == "pocket-deeper-than-stock":
                depth = bottom - CLEAR - 0.05  # past the parallels' room too
            drill = _hole(HoleOp.DRILL, x0, y0, depth, tool)
            frame = Frame(
                placement=Placement.POCKET,
                two_pass=feature == "frame-2p",
                xl=_d(size),
                yw=_d(size * 0.8),
                corner_radius=_d(corner),
                feed_xy=D(10),
                tool=tool,
            )
            features += [drill, frame]
            shape = box(x0 + corner, y0 + corner, x0 + size - corner, y0 + size * 0.8 - corner)
            add_cut(
                shape.buffer(corner, 256) if corner else box(x0, y0, x0 + size, y0 + size * 0.8),
                max(depth, bottom),
            )
            if plant:
                mark(drill, frame)
                kind = "process" if mistake == "pocket-deeper-than-stock" else "rest material"
        elif feature == "circle":
            drill = _hole(HoleOp.DRILL, cx, cy, depth, 2)
            features += [
                drill,
                Circle(placement=Placement.POCKET, radius=_d(0.45), feed_xy=D(10), tool=2),
            ]
            add_cut(Point(cx, cy).buffer(0.45, 256), depth)
        elif feature == "drill":
            hole_depth = layout.hole_depth
            if plant and mistake == "drill-below-stock":
                hole_depth = bottom - 0.3  # past the parallels' room
            drill = _hole(HoleOp.DRILL, cx, cy, hole_depth, 5)
            features.append(drill)
            if plant:
                mark(drill)
                kind = "process"
                add_cut(Point(cx, cy).buffer(TOOLS[5][0] / 2, 256), bottom)
            else:
                add_cut(*_drilled(cx, cy, hole_depth, 5))
        elif feature == "tap":
            pilot = _hole(HoleOp.DRILL, cx, cy, layout.hole_depth, 3)
            tap_depth = layout.hole_depth + 0.1
            tap = _hole(HoleOp.TAP, cx, cy, tap_depth, 4)
            if plant and mistake == "undrilled-tap":
                features.append(tap)
                mark(tap)
                kind = "process"
            else:
                features += [pilot, tap]
                add_cut(*_drilled(cx, cy, layout.hole_depth, 3))
            add_cut(Point(cx, cy).buffer(TOOLS[4][0] / 2, 256), tap_depth)
        elif feature == "bore":
            pilot = _hole(HoleOp.DRILL, cx, cy, layout.hole_depth, 5)
            bore_depth = layout.hole_depth + 0.1
            features += [pilot, _hole(HoleOp.BORE, cx, cy, bore_depth, 6)]
            add_cut(*_drilled(cx, cy, layout.hole_depth, 5))
            add_cut(Point(cx, cy).buffer(TOOLS[6][0] / 2, 256), bore_depth)
        elif feature == "through":
            features.append(_hole(HoleOp.DRILL, cx, cy, through_depth, 5))
            add_cut(Point(cx, cy).buffer(TOOLS[5][0] / 2, 256), bottom)
        elif feature == "bolts":
            features += [
                _hole(HoleOp.DRILL, cx, cy, layout.hole_depth, 3),
                BoltCircle(op=HoleOp.DRILL, holes=5, angle=D(10), radius=D("0.35")),
            ]
            for n in range(5):
                a = math.radians(10 + n * 72)
                hx, hy = cx - 0.35 * math.sin(a), cy - 0.35 * math.cos(a)
                add_cut(*_drilled(hx, hy, layout.hole_depth, 3))
        elif feature == "pocket-hole":
            features += [
                _hole(HoleOp.DRILL, cx, cy, depth, 7),
                Circle(placement=Placement.POCKET, radius=_d(0.4), feed_xy=D(10), tool=7),
                _hole(HoleOp.DRILL, cx, cy, layout.hole_depth, 5, z_up=depth + 0.1),
            ]
            add_cut(Point(cx, cy).buffer(0.4, 256), depth)
            add_cut(*_drilled(cx, cy, layout.hole_depth, 5))
    profile_depth = through_depth if isinstance(layout.profile_depth, str) else layout.profile_depth
    side = Comp.RIGHT
    if mistake == "profile-wrong-side":
        side = Comp.LEFT
    start = _hole(HoleOp.DRILL, width / 2, 0.0, profile_depth, 1)
    start = replace(start, comp=side)

    def line(x: float, y: float) -> MillLine:
        return MillLine(x=_d(x), y=_d(y), z_dn=_d(profile_depth), feed_xy=D(12), tool=1)

    profile: list[Block] = [
        start,
        line(width, 0),
        line(width, height),
        line(0, height),
        line(0, 0),
        line(width / 2, 0),
    ]
    if mistake == "profile-wrong-side":
        mark(start)
        # Blind, the part stands inside its groove (rest material); through, it drops out
        # as a slug with its features, undersize (a gouge).
        kind = "gouge" if layout.profile_depth == "through" else "rest material"
    blocks = features + profile if layout.profile_last else profile + features
    numbers = {id(b): n for n, b in enumerate(blocks, start=1)}
    tools = tuple(
        Tool(number=n, diameter=_d(d), rpm=1200, tcal=D(0)) for n, (d, _) in TOOLS.items()
    )
    program = Program(
        name="intended part",
        block0=DataBlock0(current_tool=1, tools=tools),
        blocks=tuple(blocks),
        stock=Stock(
            x=D("-0.5"),
            y=D("-0.5"),
            xl=_d(width + 1),
            yw=_d(height + 1),
            zh=_d(THICK),
            clear=_d(CLEAR),
        ),
    )
    outline = box(0, 0, width, height)
    return Built(
        program,
        cuts,
        outline,
        {numbers[i] for i in mistake_blocks},
        kind,
        perimeter_depth,
    )


# The features a mistake can be planted in.
_PLANTABLE = {
    "undrilled-tap": ("tap",),
    "drill-below-stock": ("drill",),
    "tool-too-big-for-corner": ("frame", "frame-2p"),
    "pocket-deeper-than-stock": ("frame", "frame-2p"),
}


def plantable(layout: Layout, mistake: str) -> bool:
    """Whether `layout` has a feature `mistake` can be planted in."""
    if mistake == "profile-wrong-side":
        # Through, a contour cut from inside is a window cut out of a plate unless features
        # inside it say the slug is the part: holes do; pockets that clear most of it are
        # the window roughed out (Verify gives them the benefit of the doubt).
        if layout.profile_depth != "through":
            return True
        holes = ("drill", "tap", "bore", "through", "bolts")
        return any(f in holes for f in layout.features) and all(
            f in (*holes, "empty") for f in layout.features
        )
    return any(f in _PLANTABLE[mistake] for f in layout.features)


def removed_volume(
    cuts: list[tuple[BaseGeometry, float]], outline: Polygon, top: float = 0.0
) -> float:
    """in³ the cuts remove inside `outline`: the union of every cut at least as deep as
    each level, level by level (shapely areas)."""
    levels = sorted({depth for _, depth in cuts}, reverse=True)  # shallow to deep
    volume = 0.0
    above = top
    for level in levels:
        region = unary_union([shape for shape, depth in cuts if depth <= level])
        volume += region.intersection(outline).area * (above - level)
        above = level
    return volume
