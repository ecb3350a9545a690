"""The simulator's input: the moves of a compiled piece as arrays of straight segments and
arc pieces.

`piece_segments` is the one place that reads MOVE rows (app/cnc/path.py); everything else
in this package depends only on the arrays it returns. It is vectorised: a piece of any
length costs a few numpy passes, no Python per move.

Conventions (those of the compiled path): X/Y are part coordinates and Z is the tool tip in
part Z (each tool's Z is measured from its calibrated zero), all in nanometres, kept here as
float64 because arcs are split into pieces whose ends are computed. A segment's tool shape
comes from the block that moves it:

- DRILL holes (and DRILL bolt circles) are cut by a drill point: a 118° cone, so the
  bottom of the tool at distance d from its axis is d / tan(59°) above the tip.
- Everything else is a flat-bottomed cylinder of the tool's diameter: end mills for
  milling blocks (and the DRILL that starts a mill sequence: it plunges the end mill), and
  the boring bar and the tap. A tap is modelled by its diameter; its thread is not.
- A tool without a diameter in Data Block 0 is simulated with a stated default (0.125 in,
  3 mm in a metric program) and named in `ToolShapes.notes()`.

Arcs are split into pieces of at most 90°, so each piece's bounding box is tight and the
sweep can test "inside the sector" with two cross products. A helical arc (its Z changes)
becomes straight chords within `HELIX_CHORD` of it, each descending in proportion.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from decimal import Decimal

import numpy as np
import numpy.typing as npt

from app.cnc.blocks import HoleOp
from app.cnc.path import HOLE_OPS, CompiledPath, Op, Rows, placed_holes
from app.cnc.toolpath import ToolInfo
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
# How far a helical arc's chords may be from it (nm): a quarter of Verify's inch tolerance
# (0.001 in), so the chords' error stays well inside what Verify reports.
HELIX_CHORD = 25_400 / 4


@dataclass
class Segments:
    """Motions, one row per straight segment or arc piece (lengths in nm).

    `x0…z1` are the start and end of the tool tip; `cx`, `cy` the centre of an arc piece
    (`arc` True; Z is then constant) and `ccw` its direction seen from above. `radius` is
    the tool's radius and `slope` its bottom's rise per unit of distance from the axis (0 for
    a flat end, `DRILL_SLOPE` for a drill point). `block` is the data block each comes from,
    `tool` the tool number, `rapid` True for moves at the rapid rate. Rows are in program
    order.
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

    def __len__(self) -> int:
        return len(self.x0)

    def select(self, mask: BOOL | I64) -> Segments:
        """The rows `mask` picks (a boolean mask or indices)."""
        return Segments(**{name: getattr(self, name)[mask] for name in _FIELDS})

    def translated(self, dx: float, dy: float) -> Segments:
        """The same motions moved by (dx, dy) nm."""
        if not (dx or dy):
            return self
        moved = dict(vars(self))
        for name in ("x0", "x1", "cx"):
            moved[name] = self.__dict__[name] + dx
        for name in ("y0", "y1", "cy"):
            moved[name] = self.__dict__[name] + dy
        return Segments(**moved)

    def tiled(self, offsets: I64) -> Segments:
        """These motions placed at each of `offsets` (k × 2 nm) in turn, as one array."""
        k = len(offsets)
        parts = {name: np.tile(getattr(self, name), k) for name in _FIELDS}
        dx = np.repeat(offsets[:, 0].astype(np.float64), len(self))
        dy = np.repeat(offsets[:, 1].astype(np.float64), len(self))
        for name in ("x0", "x1", "cx"):
            parts[name] += dx
        for name in ("y0", "y1", "cy"):
            parts[name] += dy
        return Segments(**parts)

    @staticmethod
    def empty() -> Segments:
        f, b, i = np.zeros(0), np.zeros(0, dtype=np.bool_), np.zeros(0, dtype=np.int32)
        return Segments(f, f, f, f, f, f, f, f, b, b, b, f, f, i, i)

    @staticmethod
    def concatenate(parts: list[Segments]) -> Segments:
        """The rows of `parts` one after the other."""
        if not parts:
            return Segments.empty()
        return Segments(
            **{name: np.concatenate([getattr(p, name) for p in parts]) for name in _FIELDS}
        )


_FIELDS = tuple(Segments.__dataclass_fields__)


def default_diameter(units: Units) -> int:
    """The diameter (nm) the simulation gives a tool Data Block 0 gives none:
    DEFAULT_DIAMETER, stated in Verify's report."""
    return to_nm(DEFAULT_DIAMETER[units], units)


def drill_point_blocks(path: CompiledPath) -> set[int]:
    """Numbers of the blocks whose holes are cut with a drill point: the compiled holes a
    DRILL makes (a bolt circle's on its BOLT CIR block; a DRILL that starts a mill sequence
    makes none, the end mill goes down there). Read from the holes' intent the compile
    keeps, not from the blocks again."""
    drill = HOLE_OPS.index(HoleOp.DRILL)
    found: set[int] = set()
    for blocks, holes in placed_holes(path.root):
        found.update(np.unique(blocks[holes["op"] == drill]).tolist())
    return found


@dataclass
class ToolShapes:
    """What cuts: each tool's radius (nm; the stated default where Data Block 0 gives no
    diameter) and which blocks drill with a point. `used` collects the tools that moved."""

    tools: dict[int, ToolInfo]
    units: Units
    pointed: I64
    used: set[int] = field(default_factory=set)

    @staticmethod
    def of(path: CompiledPath) -> ToolShapes:
        pointed = np.array(sorted(drill_point_blocks(path)), dtype=np.int64)
        return ToolShapes(path.tools, path.units, pointed)

    @property
    def default_diameter(self) -> int:
        return default_diameter(self.units)

    def radius(self, tool: int) -> float:
        """The radius the simulation gives `tool`, nm."""
        info = self.tools.get(tool)
        diameter = None if info is None else info.diameter
        if diameter is None or diameter <= 0:
            diameter = self.default_diameter
        return diameter / 2

    def notes(self) -> list[str]:
        """A note for each tool used that has no diameter (simulated with the default)."""
        out = []
        default = self.default_diameter
        for number in sorted(self.used):
            info = self.tools.get(number)
            if number != 0 and (info is None or info.diameter is None or info.diameter <= 0):
                out.append(
                    f"tool {number} has no diameter in Data Block 0: simulated as "
                    f"{format_length(default, self.units)} {self.units.symbol}"
                )
        return out


@dataclass(frozen=True)
class Entry:
    """Where the tool tip is (nm) and which tool is in the spindle."""

    x: int
    y: int
    z: int
    tool: int


def piece_segments(
    rows: Rows, block_shift: int, entry: Entry, shapes: ToolShapes
) -> tuple[Segments, Entry]:
    """The motions of MOVE `rows` (coordinates as stored; blocks + `block_shift`) entered at
    `entry`, and where they leave the tool. TOOL rows change the tool and set Z."""
    ops = rows["op"]
    setter = np.flatnonzero((ops <= Op.ARC_CCW) | (ops == Op.TOOL))
    shapes.used.add(entry.tool)
    if not len(setter):
        return Segments.empty(), entry
    picked = rows[setter]
    kind = picked["op"]
    motion = kind <= Op.ARC_CCW
    order = np.arange(len(picked))
    # A TOOL row keeps X and Y: those of the last motion before it (or the entry).
    last_motion = np.maximum.accumulate(np.where(motion, order, -1))
    x_after = np.where(last_motion >= 0, picked["x"][last_motion], entry.x)
    y_after = np.where(last_motion >= 0, picked["y"][last_motion], entry.y)
    z_after = picked["z"]
    is_tool = ~motion
    last_tool = np.maximum.accumulate(np.where(is_tool, order, -1))
    tool_after = np.where(last_tool >= 0, picked["value"][last_tool], entry.tool)
    exit_entry = Entry(int(x_after[-1]), int(y_after[-1]), int(z_after[-1]), int(tool_after[-1]))
    shapes.used.update(np.unique(tool_after).tolist())

    def before(values: I64, first: int) -> I64:
        out = np.empty_like(values)
        out[0] = first
        out[1:] = values[:-1]
        return out

    sx = before(x_after, entry.x)[motion].astype(np.float64)
    sy = before(y_after, entry.y)[motion].astype(np.float64)
    sz = before(z_after, entry.z)[motion].astype(np.float64)
    moves = picked[motion]
    tool = tool_after[motion]
    ex, ey, ez = (moves[c].astype(np.float64) for c in ("x", "y", "z"))
    cx, cy = moves["cx"].astype(np.float64), moves["cy"].astype(np.float64)
    op = moves["op"]
    arc = op >= Op.ARC_CW
    ccw = op == Op.ARC_CCW
    block = moves["block"].astype(np.int64) + block_shift
    # Arcs in pieces of at most 90°: a move repeated once per piece. A helical arc (its Z
    # changes) is cut into chords within HELIX_CHORD of it instead, each a straight move
    # whose Z changes in proportion: the sweep's arc pieces keep one Z.
    helical = arc & (sz != ez)
    pieces = np.ones(len(moves), dtype=np.int64)
    if arc.any():
        a0 = np.arctan2(sy - cy, sx - cx)
        a1 = np.arctan2(ey - cy, ex - cx)
        turn = np.where(ccw, a1 - a0, a0 - a1) % (2 * math.pi)
        turn = np.where(turn > 1e-12, turn, 2 * math.pi)
        largest = np.full(len(moves), MAX_ARC_PIECE)
        if helical.any():
            r = np.hypot(sx - cx, sy - cy)
            tolerance = np.minimum(HELIX_CHORD, r)
            largest = np.where(
                helical,
                np.minimum(MAX_ARC_PIECE, 2 * np.arccos(1 - tolerance / np.maximum(r, 1.0))),
                largest,
            )
        pieces = np.where(arc, np.maximum(1, np.ceil(turn / largest - 1e-9)), 1).astype(np.int64)
    take = np.repeat(np.arange(len(moves)), pieces)
    x0, y0, x1, y1 = sx[take], sy[take], ex[take], ey[take]
    if arc.any():
        first = np.cumsum(pieces) - pieces
        k = np.arange(len(take)) - first[take]
        n = pieces[take]
        is_arc = arc[take]
        step = np.where(ccw, turn, -turn)[take] / n
        radius = np.hypot(sx - cx, sy - cy)[take]
        ccx, ccy = cx[take], cy[take]
        start_angle = a0[take]
        inner_start = is_arc & (k > 0)
        ang = start_angle[inner_start] + k[inner_start] * step[inner_start]
        x0[inner_start] = ccx[inner_start] + radius[inner_start] * np.cos(ang)
        y0[inner_start] = ccy[inner_start] + radius[inner_start] * np.sin(ang)
        inner_end = is_arc & (k < n - 1)
        ang = start_angle[inner_end] + (k[inner_end] + 1) * step[inner_end]
        x1[inner_end] = ccx[inner_end] + radius[inner_end] * np.cos(ang)
        y1[inner_end] = ccy[inner_end] + radius[inner_end] * np.sin(ang)
    z0 = np.where(arc & ~helical, ez, sz)[take]
    z1 = ez[take]
    if helical.any():
        first = np.cumsum(pieces) - pieces
        k = np.arange(len(take)) - first[take]
        n = pieces[take]
        on_helix = helical[take]
        rise = (ez - sz)[take]
        z0 = np.where(on_helix, sz[take] + rise * k / n, z0)
        z1 = np.where(on_helix & (k < n - 1), sz[take] + rise * (k + 1) / n, z1)
    flat_arc = (arc & ~helical)[take]
    tools = tool[take]
    kinds, which = np.unique(tools, return_inverse=True)
    radius_of = np.array([shapes.radius(t) for t in kinds.tolist()], dtype=np.float64)[which]
    blocks = block[take]
    slope = np.where(np.isin(blocks, shapes.pointed), DRILL_SLOPE, 0.0)
    segments = Segments(
        x0=x0,
        y0=y0,
        z0=z0,
        x1=x1,
        y1=y1,
        z1=z1,
        cx=np.where(flat_arc, cx[take], 0.0),
        cy=np.where(flat_arc, cy[take], 0.0),
        arc=flat_arc,
        ccw=ccw[take],
        rapid=(op == Op.RAPID)[take],
        radius=radius_of,
        slope=slope,
        tool=tools.astype(np.int32),
        block=blocks.astype(np.int32),
    )
    return segments, exit_entry
