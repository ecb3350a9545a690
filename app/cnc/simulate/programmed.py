"""What the program asks for, for verify to measure the simulated part against.

`programmed_geometry` gathers it for verify: the finished contours of compensated MILL
sequences and of POCKETs (walls and islands), the CIRCLE/FRAME routines, and every hole with
its programmed depth (a HELIX is the bore of its finished DIA). All of it is the compiled
path's: its hole and mill spans carry where each was cut and the plan it was cut from (the
contour, the routine's circle or frame, the POCKET's outlines: LOOP patterns, bolt circles,
incremental positions and the plans are the compiler's, not re-derived or planned again
here). HELIX, THREAD MILL, FACE and ENGRAVE blocks are read where the compiled moves cut
them, their sizes from the blocks. Lengths in nm, part coordinates.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from app.cnc.blocks import (
    Comp,
    Engrave,
    Face,
    Helix,
    HoleOp,
    Placement,
    Program,
    ThreadMill,
    ThreadPlace,
)
from app.cnc.compiler import compile_program
from app.cnc.operations.thread import full_form_bottom, thread_depth, thread_lead
from app.cnc.path import MillSpan, Op, Rows
from app.cnc.plane import Element, signed_area
from app.cnc.pocketing.regions import element_points
from app.cnc.process import placed_hole_list
from app.cnc.routines import INSIDE_PLACEMENTS
from app.cnc.toolpath import ToolInfo
from app.cnc.units import to_nm


@dataclass(frozen=True)
class Contour:
    """A compensated contour's finished surface: `elements` from `start`, the part on the
    `part_left` side of travel, cut by a tool of `tool_radius` down to `depth` (the DRILL's
    Z DN; an element's own Z DN where it has one). `drill` is the block that starts it."""

    drill: int
    start: tuple[float, float]
    elements: tuple[Element, ...]
    part_left: bool
    tool_radius: int
    depth: int | None
    # Where the tool's centre went cutting it (polylines, float nm), for an open contour or
    # a slot, whose waste is the tool's swath: empty for a closed contour.
    swept: tuple[tuple[tuple[float, float], ...], ...] = ()


@dataclass(frozen=True)
class Routine:
    """A CIRCLE (`centre`, `radius`) or FRAME (`corner`, `width`, `height`, `corner_radius`)
    routine: its finished contour, `inside` for INSIDE, IN/TAN and POCKET, `pocket` for
    POCKET, cut by a tool of `tool_radius` to `depth` (None in a 2-axis program).

    `depth` is the required depth: material left above it where the routine cuts is rest
    material. `allowed` is how low it may cut, where that is lower (None: `depth`, as for
    every CIRCLE and FRAME): an external thread must have its full form down to a lead and
    a quarter above its Z DN, and may cut down to Z DN (its run-out, partly cut)."""

    block: int
    is_frame: bool
    inside: bool
    pocket: bool
    tool_radius: int
    depth: int | None
    centre: tuple[float, float] = (0.0, 0.0)
    radius: int = 0
    corner: tuple[float, float] = (0.0, 0.0)
    width: int = 0
    height: int = 0
    corner_radius: int = 0
    drill: int = 0  # the DRILL block that starts it
    allowed: int | None = None
    crest: int = 0  # an external thread's major radius: its form reaches out to it

    @property
    def deepest(self) -> int | None:
        """The lowest Z (nm) it may cut to: cutting below it is a gouge."""
        return self.depth if self.allowed is None else self.allowed


@dataclass(frozen=True)
class HoleSpec:
    """A DRILL, BORE or TAP hole at (x, y), programmed to `depth` (Z DN) by `block`, with a
    tool of `radius` (0: Data Block 0 gives no diameter); a HELIX's bore of its finished
    radius, flat like a BORE's."""

    block: int
    op: HoleOp
    x: int
    y: int
    depth: int
    radius: int = 0
    kind: str = ""  # what made it, where not its operation ("HELIX": a helical bore)

    @property
    def name(self) -> str:
        """What the hole is called in a finding (DRILL, BORE, TAP, HELIX)."""
        return self.kind or self.op.value


@dataclass(frozen=True)
class PocketArea:
    """A POCKET (`block`) as cut: its wall (`contours[0]`) and islands as finished contours
    (where this placement of it is), the tool that clears it and its depth."""

    block: int
    contours: tuple[Contour, ...]
    tool_radius: int
    depth: int | None


@dataclass
class Programmed:
    """Everything verify compares against."""

    contours: list[Contour] = field(default_factory=list)
    routines: list[Routine] = field(default_factory=list)
    holes: list[HoleSpec] = field(default_factory=list)
    pockets: list[PocketArea] = field(default_factory=list)
    # Contours cut with the tool's centre on them (CUT none): a slot, not a finished
    # surface; `part_left` means nothing here.
    slots: list[Contour] = field(default_factory=list)


def _routine(mill: MillSpan, radius: int) -> Routine:
    """The CIRCLE/FRAME routine of `mill`, as the compile planned it where it is cut."""
    shape = mill.shape()
    assert shape is not None  # a routine's span has one
    return Routine(
        block=mill.routine,
        is_frame=shape.is_frame,
        inside=shape.placement in INSIDE_PLACEMENTS,
        pocket=shape.placement is Placement.POCKET,
        tool_radius=radius,
        depth=mill.depth,
        centre=shape.centre,
        radius=shape.radius,
        corner=shape.corner,
        width=shape.width,
        height=shape.height,
        corner_radius=shape.corner_radius,
        drill=mill.drill,
    )


def programmed_geometry(program: Program) -> Programmed:
    """The contours, routines and holes of a validated program (see the module's note)."""
    compiled = compile_program(program).path
    found = Programmed()
    seen: set[tuple[int, int, int]] = set()
    for placed in placed_hole_list(compiled):
        if (placed.block, placed.x, placed.y) not in seen:
            seen.add((placed.block, placed.x, placed.y))
            radius = 0 if placed.diameter is None else placed.diameter // 2
            found.holes.append(
                HoleSpec(placed.block, placed.op, placed.x, placed.y, placed.bottom, radius)
            )
    helical = {
        number: block
        for number, block in enumerate(program.blocks, 1)
        if isinstance(block, Helix | ThreadMill)
    }
    faces = {n: b for n, b in enumerate(program.blocks, 1) if isinstance(b, Face | Engrave)}
    for chunk in compiled.chunks():
        if helical:
            _helical_cuts(chunk.rows, helical, seen, compiled.tools, found)
        if faces:
            _swaths(chunk.rows, faces, compiled.tools, found)
        for mill in chunk.mills:
            info = compiled.tools.get(mill.tool)
            radius = 0 if info is None or info.diameter is None else info.diameter // 2
            outlines = mill.outlines()
            if outlines:
                if mill.start == mill.end:
                    continue  # not cut: its plan has errors, which validation names
                # A POCKET's walls and islands are finished surfaces, as a compensated
                # contour's: the part outside the boundary and inside each island.
                walls = []
                for name, outline in outlines:
                    inside_left = signed_area(outline) > 0  # counter-clockwise
                    island = name != "boundary"
                    walls.append(
                        Contour(
                            drill=mill.drill,
                            start=outline.start,
                            elements=outline.elements,
                            part_left=inside_left if island else not inside_left,
                            tool_radius=radius,
                            depth=mill.depth,
                        )
                    )
                found.contours += walls
                found.pockets.append(PocketArea(mill.routine, tuple(walls), radius, mill.depth))
                continue
            if mill.routine:
                found.routines.append(_routine(mill, radius))
                continue
            contour = mill.contour()
            if contour is None or not contour.elements or mill.start == mill.end:
                continue
            compensated = mill.comp != Comp.NONE.value and radius > 0
            closed = math.dist(contour.start, contour.elements[-1].end) < 1.0
            (found.contours if compensated else found.slots).append(
                Contour(
                    drill=mill.drill,
                    start=contour.start,
                    elements=contour.elements,
                    # CUT RT puts the tool right of the contour: the part is on the left.
                    part_left=mill.comp == Comp.RIGHT.value,
                    tool_radius=radius,
                    depth=mill.depth,
                    swept=() if closed and compensated else _swept(chunk.rows, mill),
                )
            )
    return found


def _helical_cuts(
    rows: Rows,
    blocks: dict[int, Helix | ThreadMill],
    seen: set[tuple[int, int, int]],
    tools: dict[int, ToolInfo],
    found: Programmed,
) -> None:
    """Each HELIX and THREAD MILL where the compiled path cuts it (the centre of its turns,
    wherever a LOOP or an INC block put it; the lead arcs are tagged and have their own
    centres) as what it removes: a HELIX the bore of its finished DIA to Z DN, flat; an
    internal thread the bore of its major diameter to Z DN (the thread's form is not
    simulated: the tool is a cylinder of its DIA); an external thread all round outside
    its minor diameter, as a CIRCLE OUTSIDE, its full form required down to a lead and a
    quarter above Z DN and allowed down to Z DN (`full_form_bottom`: the helix reaches Z DN
    only where its last turn ends). A HELIX ends with a whole turn at Z DN and an internal
    thread's tool comes down at the bore's centre to Z DN: both are flat to Z DN, as a
    hole is, where verify measures them."""
    turns = rows[((rows["op"] == Op.ARC_CW) | (rows["op"] == Op.ARC_CCW)) & (rows["tag"] == 0)]
    for number, cx, cy in zip(
        turns["block"].tolist(), turns["cx"].tolist(), turns["cy"].tolist(), strict=True
    ):
        block = blocks.get(number)
        if block is None or (number, cx, cy) in seen:
            continue
        seen.add((number, cx, cy))
        units = block.units
        depth = to_nm(block.z_dn, units)
        size = to_nm(block.diameter, units)
        if isinstance(block, Helix):
            found.holes.append(HoleSpec(number, HoleOp.BORE, cx, cy, depth, size // 2, "HELIX"))
        elif block.place is ThreadPlace.INTERNAL:
            found.holes.append(
                HoleSpec(number, HoleOp.BORE, cx, cy, depth, size // 2, block.type_name)
            )
        else:
            info = tools.get(block.tool)
            radius = 0 if info is None or info.diameter is None else info.diameter // 2
            lead = thread_lead(block)
            minor = size - round(2 * thread_depth(lead, False))
            found.routines.append(
                Routine(
                    block=number,
                    is_frame=False,
                    inside=False,
                    pocket=False,
                    tool_radius=radius,
                    depth=full_form_bottom(to_nm(block.z_up, units), depth, lead),
                    centre=(float(cx), float(cy)),
                    radius=minor // 2,
                    drill=number,
                    allowed=depth,
                    crest=size // 2,
                )
            )


def _swaths(
    rows: Rows,
    faces: dict[int, Face | Engrave],
    tools: dict[int, ToolInfo],
    found: Programmed,
) -> None:
    """Each pass of a FACE, and each stroke of an ENGRAVE, where the compiled path cuts it,
    as what it removes: the swath its tool sweeps along each cut, to Z DN (as a slot's). A
    FACE's swaths overlap by the step-over; together they are the rectangle and the run-off
    round it."""
    x, y, z = 0, 0, 0
    strokes: set[tuple[int, int, int, int, int]] = set()
    for op, tag, number, ex, ey, ez in zip(
        rows["op"].tolist(),
        rows["tag"].tolist(),
        rows["block"].tolist(),
        rows["x"].tolist(),
        rows["y"].tolist(),
        rows["z"].tolist(),
        strict=True,
    ):
        block = faces.get(number)
        key = (number, x, y, ex, ey)
        cut = op == Op.FEED and tag == 0 and z == ez and (ex, ey) != (x, y)
        if block is not None and cut and key not in strokes:
            strokes.add(key)
            info = tools.get(block.tool)
            r = 0 if info is None or info.diameter is None else info.diameter // 2
            line = ((float(x), float(y)), (float(ex), float(ey)))
            found.slots.append(
                Contour(
                    drill=number,
                    start=line[0],
                    elements=(Element(number, line[1], None, False),),
                    part_left=False,
                    tool_radius=r,
                    depth=to_nm(block.z_dn, block.units),
                    swept=(line,),
                )
            )
        if op <= Op.ARC_CCW:
            x, y, z = ex, ey, ez


def _swept(rows: Rows, mill: MillSpan) -> tuple[tuple[tuple[float, float], ...], ...]:
    """The tool centre's cutting moves of a mill span as polylines (arcs in chords of
    1 µm): a rapid ends one."""
    lines: list[tuple[tuple[float, float], ...]] = []
    current: list[tuple[float, float]] = []
    for op, x, y, cx, cy in rows[["op", "x", "y", "cx", "cy"]][mill.start : mill.end].tolist():
        end = (float(x), float(y))
        if op == Op.RAPID:
            if len(current) > 1:
                lines.append(tuple(current))
            current = [end]
        elif op == Op.FEED:
            current.append(end)
        elif op in (Op.ARC_CW, Op.ARC_CCW) and current:
            arc = Element(0, end, (float(cx), float(cy)), op == Op.ARC_CW)
            current += element_points(current[-1], arc, 1_000.0)
    if len(current) > 1:
        lines.append(tuple(current))
    return tuple(lines)
