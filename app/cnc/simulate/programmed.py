"""What the program asks for, for verify to measure the simulated part against.

`programmed_geometry` is the one place that reads the blocks for verify: the finished
contours of compensated MILL sequences (through app/cnc/mill.py's `programmed_contour`, as
the interpreter plans them), the CIRCLE/FRAME routines, and every hole with its programmed
depth. Where a block runs is found by running the interpreter and noting where it starts
each hole and mill sequence (LOOP patterns, bolt circles and incremental positions are then
the interpreter's, not re-derived here). Lengths in nm, part coordinates.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from app.cnc.blocks import Circle, Comp, Frame, Hole, HoleOp, Placement, Program
from app.cnc.interpret import _Interpreter
from app.cnc.mill import INSIDE_PLACEMENTS, Element, programmed_contour
from app.cnc.structure import MillSequence
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


@dataclass(frozen=True)
class Routine:
    """A CIRCLE (`centre`, `radius`) or FRAME (`corner`, `width`, `height`, `corner_radius`)
    routine: its finished contour, `inside` for INSIDE, IN/TAN and POCKET, `pocket` for
    POCKET, cut by a tool of `tool_radius` to `depth` (None in a 2-axis program)."""

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


@dataclass(frozen=True)
class HoleSpec:
    """A DRILL, BORE or TAP hole at (x, y), programmed to `depth` (Z DN) by `block`."""

    block: int
    op: HoleOp
    x: int
    y: int
    depth: int


@dataclass
class Programmed:
    """Everything verify compares against."""

    contours: list[Contour] = field(default_factory=list)
    routines: list[Routine] = field(default_factory=list)
    holes: list[HoleSpec] = field(default_factory=list)


class _Recorder(_Interpreter):
    """The interpreter, noting where each hole and mill sequence starts."""

    def __init__(self, program: Program) -> None:
        super().__init__(program)
        self.found = Programmed()
        self.seen: set[tuple[int, int, int]] = set()

    def hole(self, number: int, block: Hole, target: tuple[int, int]) -> None:
        if block.has_depth and (number, *target) not in self.seen:
            self.seen.add((number, *target))
            assert block.z_dn is not None
            depth = to_nm(block.z_dn, block.units)
            self.found.holes.append(HoleSpec(number, block.op, target[0], target[1], depth))
        super().hole(number, block, target)

    def run_mill_sequence(self, node: MillSequence) -> None:
        drill = self.blocks[node.drill]
        assert isinstance(drill, Hole)
        start = self.resolve(drill)
        info = self.tools.get(drill.tool)
        radius = 0 if info is None or info.diameter is None else info.diameter // 2
        depth = None if drill.z_dn is None else to_nm(drill.z_dn, drill.units)
        first = self.blocks[node.mills[0]]
        if isinstance(first, Circle | Frame):
            self.found.routines.append(_routine(first, node.mills[0] + 1, start, radius, depth))
        elif drill.comp is not Comp.NONE and radius > 0:
            path, _, _ = programmed_contour(self.blocks, node.mills, start)
            self.found.contours.append(
                Contour(
                    drill=node.drill + 1,
                    start=path.start,
                    elements=path.elements,
                    # CUT RT puts the tool right of the contour: the part is on the left.
                    part_left=drill.comp is Comp.RIGHT,
                    tool_radius=radius,
                    depth=depth,
                )
            )
        super().run_mill_sequence(node)


def _routine(
    block: Circle | Frame, number: int, start: tuple[int, int], radius: int, depth: int | None
) -> Routine:
    units = block.units
    common = {
        "block": number,
        "inside": block.placement in INSIDE_PLACEMENTS,
        "pocket": block.placement is Placement.POCKET,
        "tool_radius": radius,
        "depth": depth,
    }
    origin = (float(start[0]), float(start[1]))
    if isinstance(block, Circle):
        return Routine(is_frame=False, centre=origin, radius=to_nm(block.radius, units), **common)  # type: ignore[arg-type]
    return Routine(
        is_frame=True,
        corner=origin,
        width=to_nm(block.xl, units),
        height=to_nm(block.yw, units),
        corner_radius=to_nm(block.corner_radius, units),
        **common,  # type: ignore[arg-type]
    )


def programmed_geometry(program: Program) -> Programmed:
    """The contours, routines and holes of a validated program (see the module's note)."""
    recorder = _Recorder(program)
    recorder.run()
    return recorder.found
