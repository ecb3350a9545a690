"""The simulator's input: the tool path as arrays of straight and circular segments.

`toolpath_segments` is the one place that reads the interpreter's `Toolpath`; everything
else in this package depends only on the arrays it returns. When the tool path becomes
compact arrays itself (compile once, per block), only this function changes.

Conventions (those of app/cnc/toolpath.py): X/Y are part coordinates and Z is the tool tip
in part Z (each tool's Z is measured from its calibrated zero), all in nanometres, kept here
as float64 because arcs are split into pieces whose ends are computed. A segment's tool
shape comes from the block that moves it:

- DRILL holes (and DRILL bolt circles) are cut by a drill point: a 118° cone, so the
  bottom of the tool at distance d from its axis is d / tan(59°) above the tip.
- Everything else is a flat-bottomed cylinder of the tool's diameter: end mills for
  milling blocks (and the DRILL that starts a mill sequence: it plunges the end mill), and
  the boring bar and the tap. A tap is modelled by its diameter; its thread is not.
- A tool without a diameter in Data Block 0 is simulated with a stated default (0.125 in,
  3 mm in a metric program) and named in `Segments.notes`.

Arcs are split into pieces of at most 90°, so each piece's bounding box is tight and the
sweep can test "inside the sector" with two cross products.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from decimal import Decimal

import numpy as np
import numpy.typing as npt

from app.cnc.blocks import BoltCircle, Hole, HoleOp, Program
from app.cnc.geometry import arc_sweep
from app.cnc.structure import starts_mill_sequence
from app.cnc.toolpath import ArcFeed, Feed, Rapid, ToolChange, Toolpath
from app.cnc.units import Units, format_length, to_nm

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]
I32 = npt.NDArray[np.int32]
BOOL = npt.NDArray[np.bool_]

DRILL_POINT_DEGREES = 118.0
# Height gained per unit of distance from the axis on a 118° drill point.
DRILL_SLOPE = 1.0 / math.tan(math.radians(DRILL_POINT_DEGREES / 2))
DEFAULT_DIAMETER = {Units.INCH: Decimal("0.125"), Units.MM: Decimal(3)}
MAX_ARC_PIECE = math.pi / 2


@dataclass
class Segments:
    """The tool path's motions, one row per straight segment or arc piece (lengths in nm).

    `x0…z1` are the start and end of the tool tip; `cx`, `cy` the centre of an arc piece
    (`arc` True; Z is then constant) and `ccw` its direction seen from above. `radius` is
    the tool's radius and `slope` its bottom's rise per unit of distance from the axis (0 for
    a flat end, `DRILL_SLOPE` for a drill point). `block` is the data block each comes from,
    `tool` the tool number, `rapid` True for moves at the rapid rate. Rows are in program
    order. `notes` say what was assumed (a default diameter).
    """

    x0: F64
    y0: F64
    z0: F64
    x1: F64
    y1: F64
    z1: F64
    cx: F64
    cy: F64
    arc: BOOL
    ccw: BOOL
    rapid: BOOL
    radius: F64
    slope: F64
    tool: I32
    block: I32
    units: Units = Units.INCH
    notes: list[str] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.x0)

    def select(self, mask: BOOL | I64) -> Segments:
        """The rows `mask` picks (a boolean mask or indices), notes kept."""
        return Segments(
            x0=self.x0[mask],
            y0=self.y0[mask],
            z0=self.z0[mask],
            x1=self.x1[mask],
            y1=self.y1[mask],
            z1=self.z1[mask],
            cx=self.cx[mask],
            cy=self.cy[mask],
            arc=self.arc[mask],
            ccw=self.ccw[mask],
            rapid=self.rapid[mask],
            radius=self.radius[mask],
            slope=self.slope[mask],
            tool=self.tool[mask],
            block=self.block[mask],
            units=self.units,
            notes=self.notes,
        )


def drill_point_blocks(program: Program) -> set[int]:
    """Numbers of the blocks whose holes are cut with a drill point (DRILL holes)."""
    numbers = set()
    for index, block in enumerate(program.blocks):
        if isinstance(block, Hole) and block.op is HoleOp.DRILL:
            if not starts_mill_sequence(program.blocks, index):
                numbers.add(index + 1)
        elif isinstance(block, BoltCircle) and block.op is HoleOp.DRILL:
            numbers.add(index + 1)
    return numbers


def toolpath_segments(program: Program, toolpath: Toolpath) -> Segments:
    """The motions of `toolpath` (interpreted from `program`) as segment arrays."""
    pointed = drill_point_blocks(program)
    default = to_nm(DEFAULT_DIAMETER[program.units], program.units)
    notes: list[str] = []
    radius_of: dict[int, float] = {}
    for number in sorted({toolpath.initial_tool} | _tools_used(toolpath)):
        info = toolpath.tools.get(number)
        diameter = None if info is None else info.diameter
        if diameter is None or diameter <= 0:
            diameter = default
            if number != 0:
                notes.append(
                    f"tool {number} has no diameter in Data Block 0: simulated as "
                    f"{format_length(default, program.units)} {program.units.symbol}"
                )
        radius_of[number] = diameter / 2

    rows: list[tuple[float, ...]] = []
    flags: list[tuple[int, int, int, int, int]] = []
    x, y, z = (float(c) for c in toolpath.start)
    tool = toolpath.initial_tool
    for move in toolpath.moves:
        if isinstance(move, ToolChange):
            tool = move.tool
            z = float(move.z)
            continue
        if not isinstance(move, Rapid | Feed | ArcFeed):
            continue
        r = radius_of.get(tool, default / 2)
        slope = DRILL_SLOPE if move.block in pointed else 0.0
        ex, ey, ez = float(move.x), float(move.y), float(move.z)
        if isinstance(move, ArcFeed):
            for piece in _arc_pieces((x, y), (ex, ey), (move.cx, move.cy), move.clockwise):
                (px, py), (qx, qy) = piece
                rows.append((px, py, ez, qx, qy, ez, move.cx, move.cy, r, slope))
                flags.append((1, int(not move.clockwise), 0, tool, move.block))
        else:
            rows.append((x, y, z, ex, ey, ez, 0.0, 0.0, r, slope))
            flags.append((0, 0, int(isinstance(move, Rapid)), tool, move.block))
        x, y, z = ex, ey, ez
    data = np.array(rows, dtype=np.float64).reshape(-1, 10)
    flag = np.array(flags, dtype=np.int64).reshape(-1, 5)

    def column(k: int) -> F64:
        return np.ascontiguousarray(data[:, k])

    return Segments(
        x0=column(0),
        y0=column(1),
        z0=column(2),
        x1=column(3),
        y1=column(4),
        z1=column(5),
        cx=column(6),
        cy=column(7),
        radius=column(8),
        slope=column(9),
        arc=flag[:, 0].astype(np.bool_),
        ccw=flag[:, 1].astype(np.bool_),
        rapid=flag[:, 2].astype(np.bool_),
        tool=flag[:, 3].astype(np.int32),
        block=flag[:, 4].astype(np.int32),
        units=program.units,
        notes=notes,
    )


def _tools_used(toolpath: Toolpath) -> set[int]:
    return {m.tool for m in toolpath.moves if isinstance(m, ToolChange)}


def _arc_pieces(
    start: tuple[float, float], end: tuple[float, float], centre: tuple[int, int], clockwise: bool
) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """An arc split into equal pieces of at most 90° (the first starts, the last ends
    exactly where the arc does)."""
    cx, cy = float(centre[0]), float(centre[1])
    sweep = arc_sweep(start, end, (cx, cy), clockwise)
    n = max(1, math.ceil(sweep / MAX_ARC_PIECE - 1e-9))
    radius = math.hypot(start[0] - cx, start[1] - cy)
    a0 = math.atan2(start[1] - cy, start[0] - cx)
    step = (-sweep if clockwise else sweep) / n
    points = [start]
    for k in range(1, n):
        a = a0 + k * step
        points.append((cx + radius * math.cos(a), cy + radius * math.sin(a)))
    points.append(end)
    return list(itertools.pairwise(points))
