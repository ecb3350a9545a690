"""Mirror image: the left-hand part from the right-hand program, as a new program.

Reflection about part zero in X (x → −x), in Y (y → −y), or both (a half turn). The 1704
does this with switches (seed 000 Fig. 3-9), which reverses every cut: climb milling
becomes conventional. Here each cut keeps its milling direction instead: under a
one-axis mirror every contour is run backwards (which also keeps the cutter compensation
side), arcs keep their direction, and CIRCLE/FRAME routines and POCKETs keep climb or
conventional because the control derives their direction from Data Block 0 (a POCKET's
contour is a shape: reflected as it stands, its arcs turn the other way). Under a two-axis mirror
(a rotation) nothing needs reversing.

Positions are rewritten in absolute form outside LOOPs and as increments inside them, so
every block lands on the mirror of the original; a BOLT CIR gets the mirrored start angle
(the same set of holes, drilled in the other order).
"""

from __future__ import annotations

import dataclasses
import enum
from collections.abc import Callable
from dataclasses import dataclass
from decimal import Decimal
from typing import Any

from app.cnc.blocks import (
    Block,
    BoltCircle,
    Direction,
    Hole,
    MillQcir,
    Mode,
    Program,
    Rep,
)
from app.cnc.geometry import bolt_circle_points, resolve_xy
from app.cnc.kinds import REGISTRY, Mill, Role
from app.cnc.structure import mill_sequence_end, starts_mill_sequence
from app.cnc.text import derived_name
from app.cnc.units import Units, to_nm

XY = tuple[int, int]


class Axis(enum.Enum):
    """Which coordinates change sign."""

    X = "x"
    Y = "y"
    XY = "xy"


@dataclass(frozen=True)
class Mirrored:
    """The new program and what was done to it, in words."""

    program: Program
    notes: list[str]


def mirror(program: Program, axis: Axis) -> Mirrored:
    """The program of the part reflected in `axis` about part zero (see the module doc)."""
    sx = -1 if axis in (Axis.X, Axis.XY) else 1
    sy = -1 if axis in (Axis.Y, Axis.XY) else 1
    reverse = axis is not Axis.XY

    def m(point: XY) -> XY:
        return (sx * point[0], sy * point[1])

    targets = _targets(program.blocks)
    blocks = list(program.blocks)
    # Each new block with the absolute point it must reach (None: no position of its own).
    plan: list[tuple[Block, XY | None]] = []
    notes: list[str] = []
    index = 0
    while index < len(blocks):
        block = blocks[index]
        if (
            starts_mill_sequence(program.blocks, index)
            and REGISTRY.of(blocks[index + 1]).mill is not Mill.ROUTINE
        ):
            end = mill_sequence_end(program.blocks, index)
            plan += _contour(program, index, end, targets, m, reverse)
            if reverse:
                notes.append(
                    f"blocks {index + 1}-{end}: the contour runs backwards so each cut keeps "
                    "its milling direction (compensation side kept)"
                )
            index = end
            continue
        plan.append(_single(block, index, targets, m, sx, sy, blocks))
        index += 1
    new_blocks = _encode(plan, program.units)
    name = derived_name(program.name, f" (mirror {axis.value.upper()})")
    notes.insert(
        0,
        f"mirrored in {axis.value.upper()} about part zero; climb and conventional cuts stay "
        "as they were (the 1704's mirror switches would turn climb into conventional)",
    )
    if any(isinstance(b, BoltCircle) for b in new_blocks) and reverse:
        notes.append("bolt circles: the same holes, drilled in the other order")
    return Mirrored(
        dataclasses.replace(program, name=name, blocks=tuple(new_blocks)),
        notes,
    )


def _single(
    block: Block,
    index: int,
    targets: list[tuple[XY | None, XY | None]],
    m: Callable[[XY], XY],
    sx: int,
    sy: int,
    blocks: list[Block],
) -> tuple[Block, XY | None]:
    """One block outside a contour, mirrored as its declaration says: its point (X/Y) moved,
    its steps (REP X/Y, COPY XOF/YOF) and directions (BOLT CIR ANGLE) reflected, and a
    shape's turns (a POCKET's arcs, Role.TURN in Mill.GEOMETRY: reflected as it stands, the
    passes keep climb or conventional by themselves) reversed by a one-axis mirror; a block
    whose size (FRAME XL/YW) is measured from the point before keeps its values, and that
    point moves by the size on a flipped axis (the mirrored frame's lower-left corner)."""
    target, _ = targets[index]
    following = blocks[index + 1] if index + 1 < len(blocks) else None
    sizes = {} if following is None else _roles(following, Role.SIZE_X, Role.SIZE_Y)
    changes: dict[str, Any] = {}
    shape = REGISTRY.of(block).mill is Mill.GEOMETRY
    for name, role in _roles(block, Role.STEP_X, Role.STEP_Y, Role.ANGLE, Role.TURN).items():
        value = getattr(block, name)
        if value is None:
            continue
        if role is Role.TURN:
            if shape and sx * sy < 0:
                changes[name] = Direction.CCW if value is Direction.CW else Direction.CW
        elif role is Role.ANGLE:
            changes[name] = _mirrored_angle(value, sx, sy)
        else:
            changes[name] = (sx if role is Role.STEP_X else sy) * value
    if changes:
        block = dataclasses.replace(block, **changes)
    if target is None:
        return block, None
    point = m(target)
    if sizes:
        assert following is not None
        width, height = (
            to_nm(getattr(following, name), following.units) if name else 0
            for name in (_name(sizes, Role.SIZE_X), _name(sizes, Role.SIZE_Y))
        )
        point = (point[0] - (width if sx < 0 else 0), point[1] - (height if sy < 0 else 0))
    return block, point


def _roles(block: Block, *roles: Role) -> dict[str, Role]:
    """The block's fields that have one of `roles` (name → role), in declaration order."""
    return {
        f.name: f.prompt.role
        for f in REGISTRY.fields(type(block))
        if f.prompt.role is not None and f.prompt.role in roles
    }


def _name(found: dict[str, Role], role: Role) -> str:
    return next((name for name, r in found.items() if r is role), "")


def _mirrored_angle(angle: Decimal, sx: int, sy: int) -> Decimal:
    """A direction in degrees clockwise from the lower vertical centre line, reflected."""
    if sx < 0 and sy < 0:
        angle = Decimal(180) + angle
    elif sx < 0:
        angle = -angle
    elif sy < 0:
        angle = Decimal(180) - angle
    angle %= 360
    return angle + 360 if angle < 0 else angle


def _contour(
    program: Program,
    drill: int,
    end: int,
    targets: list[tuple[XY | None, XY | None]],
    m: Callable[[XY], XY],
    reverse: bool,
) -> list[tuple[Block, XY | None]]:
    """The DRILL and mill blocks of a contour, mirrored (and run backwards if `reverse`)."""
    blocks = program.blocks
    start, _ = targets[drill]
    assert start is not None
    # Segments: (kind block, its end point, its centre, the XY-END block if an arc).
    segments: list[tuple[Block, XY, XY | None, Block | None]] = []
    k = drill + 1
    while k < end:
        block = blocks[k]
        point, centre = targets[k]
        if REGISTRY.sub_kind_of(block).then is not None:  # an XY-CENT and its XY-END
            end_block = blocks[k + 1]
            arc_point, _ = targets[k + 1]
            assert arc_point is not None
            segments.append((block, arc_point, point, end_block))
            k += 2
            continue
        assert point is not None
        segments.append((block, point, centre, None))
        k += 1
    # Every point is written typed (to the block's resolution): tangency and radius have
    # nothing left to solve. Run backwards, a corner's conrad or chamfer moves to the
    # segment that now ends there (the one after it).
    corners = [_corner_of(b, e) for b, _, _, e in segments]
    if reverse:
        corners = [(None, None), *corners[:-1]]
    segments = [
        (
            _as_typed(piece, corners[i] if arc_end is None else (None, None)),
            point,
            centre,
            None if arc_end is None else _as_typed(arc_end, corners[i]),
        )
        for i, (piece, point, centre, arc_end) in enumerate(segments)
    ]
    if not reverse:
        plan: list[tuple[Block, XY | None]] = [(blocks[drill], m(start))]
        for piece, point, centre, arc_end in segments:
            if arc_end is not None:
                assert centre is not None
                plan += [(piece, m(centre)), (arc_end, m(point))]
            else:
                plan.append((piece, m(point)))
        return plan
    points = [start] + [point for _, point, _, _ in segments]
    # A STOP belongs to the sequence's last block, whichever block that now is.
    stop = blocks[end - 1].stop
    segments = [
        (
            dataclasses.replace(b, stop=False),
            p,
            c,
            None if e is None else dataclasses.replace(e, stop=False),
        )
        for b, p, c, e in segments
    ]
    plan = [(blocks[drill], m(points[-1]))]
    for i in range(len(segments) - 1, -1, -1):
        piece, _, centre, arc_end = segments[i]
        back_to = m(points[i])
        if arc_end is not None:
            assert centre is not None
            plan += [(piece, m(centre)), (arc_end, back_to)]
        else:
            plan.append((piece, back_to))
    last_block, last_point = plan[-1]
    plan[-1] = (dataclasses.replace(last_block, stop=stop), last_point)
    return plan


def _targets(blocks: tuple[Block, ...]) -> list[tuple[XY | None, XY | None]]:
    """For each block, the absolute point it reaches in the first pattern (an ARC XY-CENT:
    its centre), and a QCIR's centre; (None, None) for blocks without a position."""
    return _walk(blocks)[0]


def table_position(blocks: tuple[Block, ...]) -> XY:
    """Where the table is after `blocks` (nm, part coordinates; the first pattern of a
    LOOP, moved on by its REP as the next block sees it): the reference of an INC block."""
    return _walk(blocks)[1]


def _walk(blocks: tuple[Block, ...]) -> tuple[list[tuple[XY | None, XY | None]], XY]:
    from app.cnc.plane import qcir_centre
    from app.cnc.solve import needs_solving, solve_contour

    reference: XY = (0, 0)
    found: list[tuple[XY | None, XY | None]] = []
    # The points of a contour calculated from the print (app.cnc.solve), by block index.
    solved: dict[int, XY] = {}
    for index, block in enumerate(blocks):
        kind = REGISTRY.of(block)
        if kind.positioned:
            roles = _roles(block, Role.X, Role.Y)
            x, y = (getattr(block, _name(roles, role)) for role in (Role.X, Role.Y))
            if index in solved:
                point = solved[index]
            elif x is None or y is None:
                point = reference  # not solved: its sequence has an error (validation's)
            else:
                point = resolve_xy(x, y, block.mode, block.units, reference)
            if starts_mill_sequence(blocks, index):
                mills = tuple(range(index + 1, mill_sequence_end(blocks, index)))
                if needs_solving(blocks, mills):
                    solution = solve_contour(blocks, mills, point)
                    solved.update(_solved_points(blocks, solution.ends, solution.centres))
            centre = None
            if isinstance(block, MillQcir):
                centre = qcir_centre(reference, point, block.direction)
            found.append((point, centre))
            if not kind.xy_is_centre:
                reference = point
        elif isinstance(block, BoltCircle) and index > 0:
            radius = to_nm(block.radius, block.units)
            holes = bolt_circle_points(reference, radius, block.holes, block.angle)
            found.append((None, None))
            reference = holes[-1]
        elif isinstance(block, Rep):
            step = resolve_xy(block.x, block.y, Mode.INC, block.units, (0, 0))
            reference = (reference[0] + block.nx * step[0], reference[1] + block.ny * step[1])
            found.append((None, None))
        else:
            found.append((None, None))
    return found, reference


def _solved_points(
    blocks: tuple[Block, ...], ends: dict[int, XY], centres: dict[int, XY]
) -> dict[int, XY]:
    """The point each contour block stands for, from a solution: a line's or QCIR's end, an
    arc's centre (its XY-CENT block) and end (its XY-END block)."""
    points: dict[int, XY] = {}
    for index, end in ends.items():
        if REGISTRY.of(blocks[index]).xy_is_centre:
            points[index] = centres[index]
            points[index + 1] = end
        else:
            points[index] = end
    return points


def _as_typed(block: Block, corner: tuple[Decimal | None, Decimal | None]) -> Block:
    """A contour block with every point typed (the mirror writes them all): no tangency or
    radius left to solve, and the conrad or chamfer of the corner at its end."""
    names = {f.name for f in REGISTRY.fields(type(block))}
    changes: dict[str, Any] = {
        name: value
        for name, value in (("tangent", False), ("angle", None), ("radius", None))
        if name in names
    }
    if "conrad" in names:
        changes["conrad"], changes["chamfer"] = corner
    return dataclasses.replace(block, **changes) if changes else block


def _corner_of(block: Block, arc_end: Block | None) -> tuple[Decimal | None, Decimal | None]:
    """The conrad and chamfer at the end of a segment (an arc's: on its XY-END)."""
    holder = arc_end if arc_end is not None else block
    return getattr(holder, "conrad", None), getattr(holder, "chamfer", None)


def _encode(plan: list[tuple[Block, XY | None]], units: Units) -> list[Block]:
    """Write each planned point into its block: absolute outside LOOPs, increments inside,
    to the block's resolution; QCIR directions follow from the new geometry."""
    out: list[Block] = []
    reference: XY = (0, 0)
    open_loops = 0
    for block, point in plan:
        if block.loop and REGISTRY.of(block).loopable:
            open_loops += 1
        if point is not None:
            inside = open_loops > 0
            block_units = block.units
            value = (point[0] - reference[0], point[1] - reference[1]) if inside else point
            roles = _roles(block, Role.X, Role.Y)
            changes: dict[str, Any] = {
                "mode": Mode.INC if inside else Mode.ABS,
                _name(roles, Role.X): _decimal(value[0], block_units),
                _name(roles, Role.Y): _decimal(value[1], block_units),
            }
            block = dataclasses.replace(block, **changes)
            if not REGISTRY.of(block).xy_is_centre:
                reference = point
        # A QCIR or ARC keeps its direction: a one-axis mirror turns it the other way and
        # running it backwards turns it back; a half turn changes neither.
        out.append(block)
        if isinstance(block, BoltCircle) and len(out) > 1:
            centre_block = out[-2]
            assert isinstance(centre_block, Hole)
            reference = _bolt_last(out, reference)
        if isinstance(block, Rep):
            step = resolve_xy(block.x, block.y, Mode.INC, block.units, (0, 0))
            reference = (reference[0] + block.nx * step[0], reference[1] + block.ny * step[1])
            open_loops = max(0, open_loops - 1)
    del units
    return out


def _bolt_last(out: list[Block], centre: XY) -> XY:
    bolt = out[-1]
    assert isinstance(bolt, BoltCircle)
    holes = bolt_circle_points(centre, to_nm(bolt.radius, bolt.units), bolt.holes, bolt.angle)
    return holes[-1]


def length_of(nm: int, units: Units) -> Decimal:
    """nm as a value of `units`, at the programming resolution (0.001 in / 0.01 mm)."""
    return _decimal(nm, units)


def _decimal(nm: int, units: Units) -> Decimal:
    """nm as a value of `units`, at the programming resolution (0.001 in / 0.01 mm)."""
    exact = Decimal(nm) / Decimal(units.nm)
    return exact.quantize(units.resolution)
