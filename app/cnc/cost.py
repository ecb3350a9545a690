"""What a program will cost before any of its work starts: the moves, holes and pocket
passes its blocks expand to, read from the blocks in time proportional to their number.

A LOOP multiplies everything inside it by its (NX + 1) × (NY + 1) patterns, and LOOPs nest:
five blocks can ask for 10^8 holes. Everything after the compile (the drawing, the cycle
time, every export, Verify) works move by move, so the one limit that bounds them all is
the number of moves (`sizes.MAX_MOVES`). `check` refuses a program past it, naming the
outermost block that takes it there (a LOOP, or the block whose node does) with the
figure and the limit; the library, the importers, validation and the compile all ask it
(docs/security.md, "Bounded work").

The figures are upper estimates, not the path: a hole counts every move a hole can make
(a tool change, pecks, the dwell), a contour block three elements (its line or arc, a
corner arc, a trim), a CIRCLE or FRAME pocket a ring per step-over, an irregular POCKET a
level per step-over across its narrower half, each level round every contour twice. The
compile holds the real path to the same limit after each top-level node, for what an
estimate cannot foresee. Pure: no Flask, database or serial code.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from decimal import Decimal

from app.cnc import sizes
from app.cnc.blocks import (
    RAMP_HIGH,
    RAMP_LOW,
    Block,
    BoltCircle,
    Circle,
    Entry,
    Frame,
    Hole,
    HoleOp,
    Placement,
    Pocket,
    Program,
    Rep,
)
from app.cnc.kinds import REGISTRY, Mill
from app.cnc.memo import Recent
from app.cnc.plane import Path, sweep
from app.cnc.ramp import angle_of, helix_radius, zigzag_length
from app.cnc.routines import pocket_overlap
from app.cnc.structure import BoltPattern, LoopPattern, MillSequence, Node, Single, build_nodes
from app.cnc.units import to_nm

# The most rows (moves) the compiler makes for each (compiler.py):
TOOL_ROWS = 8  # a tool change: retract, clearance, coolant and spindle off, TOOL, both on
SPINDLE_ROWS = 3  # the same tool: the spindle and coolant on again after a STOP
POS_ROWS = 4  # up, across, down, an index
HOLE_ROWS = 10  # up, over the hole, down to Z UP, in, dwell or a tap's reversals, retract
PECK_ROWS = 3  # each further peck: up, back down, feed on
STOP_ROWS = 4  # STOP: retract, coolant and spindle off, the stop
SEQUENCE_ROWS = 5  # a mill sequence: over the plunge point, down to Z UP, the last retract
LEVEL_ROWS = 4  # each peck level: feed down, retract, back over, down
CONTOUR_ELEMENTS = 3  # a contour block: its line or arc, a corner arc, a trim
RING_ELEMENTS = 10  # a CIRCLE/FRAME ring: four sides, four corners, a step-over, a lead


@dataclass(frozen=True, slots=True)
class Cost:
    """A program's expected size: `moves` (canonical moves, the unit every later step
    works in), `holes` and irregular-pocket `passes`. When `moves` passes the limit it was
    checked against, `over` is the 1-based block that takes it there (the first block of
    the top-level node: a LOOP block for a LOOP) and `node_moves` that node's moves, its
    `patterns` the LOOP's patterns in all (1 for any other node). When a POCKET would take
    more planning than `sizes.MAX_POCKET_WORK` first, `over` is that POCKET, `levels` and
    `points` what its planning multiplies. Either way `stop` is the first block of the
    top-level node the compile stops before."""

    moves: int
    holes: int
    passes: int
    over: int | None = None
    node_moves: int = 0
    patterns: int = 1
    rep: int | None = None
    stop: int | None = None
    levels: int = 0
    points: int = 0

    def message(self, limit: int) -> str:
        """What a refusal says: the figure, what makes it, and what is allowed."""
        if self.levels:
            work = self.levels * self.points
            return (
                f"planning this POCKET means shrinking its region, drawn with {self.points:,} "
                f"points, {self.levels} times ({work:,} in all); a POCKET is planned from at "
                f"most {sizes.MAX_POCKET_WORK:,}, so that it plans in seconds: a larger tool "
                "or STEP, or fewer arcs in its contours, make it less"
            )
        if self.rep is not None:
            what = (
                f"this LOOP, with its REP in block {self.rep}, repeats its blocks "
                f"{self.patterns:,} times, about {self.node_moves // self.patterns:,} moves "
                "each"
            )
        else:
            what = f"this block makes about {self.node_moves:,} moves"
        return (
            f"the program would make about {self.moves:,} moves ({what}); a program makes at "
            f"most {limit:,} moves, so that every page, export and command on it answers in "
            "seconds"
        )


@dataclass(frozen=True, slots=True)
class Size:
    """What a node expands to: its moves, holes and irregular-pocket passes, and its
    heaviest POCKET's planning (block, levels, points). A `Mill.ROUTINE` kind's `Kind.cost`
    gives this for its sequence, less the drill's rows."""

    moves: int
    holes: int
    passes: int
    pocket: tuple[int, int, int] | None = None  # the heaviest POCKET: block, levels, points


# The last programs' costs, by the objects the cost is read from: one edit asks for the same
# version's cost up to four times (validation, its compile, the library's check before the
# save, the preview's compile of a copy with the same blocks), each a walk of every block.
_COSTS: Recent[tuple[tuple[Block, ...], object, Cost]] = Recent(8)


def estimate(program: Program, limit: int | None = None) -> Cost:
    """The cost of `program` (COPY blocks are not motion). `limit` (default
    `sizes.move_limit()`) only decides which block `Cost.over` names."""
    cap = sizes.move_limit() if limit is None else limit
    blocks = program.blocks
    # The entry keeps its blocks and Data Block 0 alive, so their ids are not reused.
    key = (id(blocks), id(program.block0), program.units, cap)
    kept = _COSTS.get(key)
    if kept is not None and kept[0] is blocks and kept[1] is program.block0:
        return kept[2]
    found = _estimate(program, cap)
    _COSTS.keep(key, (blocks, program.block0, found))
    return found


def _estimate(program: Program, cap: int) -> Cost:
    """The cost of `program`, its moves held to `cap` (estimate, worked out)."""
    blocks = program.blocks
    moves = holes = passes = 0
    tool = program.block0.current_tool
    over: Cost | None = None
    for node in build_nodes(blocks, tolerant=True):
        size, tool = _node(blocks, program, node, tool)
        moves += size.moves
        holes += size.holes
        passes += size.passes
        first = _first(node)
        if over is None and size.pocket is not None:
            block, levels, points = size.pocket
            if levels * points > sizes.MAX_POCKET_WORK:
                over = Cost(0, 0, 0, block, stop=first + 1, levels=levels, points=points)
        if over is None and moves > cap:
            if isinstance(node, LoopPattern):
                patterns = _patterns(blocks[node.rep])
                over = Cost(0, 0, 0, first + 1, size.moves, patterns, node.rep + 1, first + 1)
            else:
                over = Cost(0, 0, 0, first + 1, size.moves, stop=first + 1)
    if over is None:
        return Cost(moves, holes, passes)
    return replace(over, moves=moves, holes=holes, passes=passes)


def check(program: Program, limit: int | None = None) -> Cost:
    """The cost of `program`; raises `sizes.TooLarge` naming the block, the figure and the
    limit when its moves are past `limit` (default `sizes.move_limit()`)."""
    cap = sizes.move_limit() if limit is None else limit
    cost = estimate(program, cap)
    if cost.over is not None:
        raise sizes.TooLarge(f"block {cost.over}: {cost.message(cap)}")
    return cost


def _first(node: Node) -> int:
    if isinstance(node, Single):
        return node.index
    if isinstance(node, BoltPattern):
        return node.centre
    if isinstance(node, MillSequence):
        return node.drill
    return _first(node.body[0])


def _patterns(rep: Block) -> int:
    assert isinstance(rep, Rep)
    return (max(rep.nx, 0) + 1) * (max(rep.ny, 0) + 1)


def _node(blocks: tuple[Block, ...], program: Program, node: Node, tool: int) -> tuple[Size, int]:
    """The size of `node` entered with `tool` in the spindle, and the tool after it."""
    if isinstance(node, LoopPattern):
        first, after = _body(blocks, program, node, tool)
        k = _patterns(blocks[node.rep])
        if k == 1:
            return first, after
        again, after = _body(blocks, program, node, after)
        return (
            Size(
                first.moves + (k - 1) * again.moves,
                first.holes + (k - 1) * again.holes,
                first.passes + (k - 1) * again.passes,
                _heavier(first.pocket, again.pocket),
            ),
            after,
        )
    if isinstance(node, Single):
        indexes = [node.index]
    elif isinstance(node, BoltPattern):
        indexes = [node.centre, node.bolt]
    else:
        indexes = [node.drill, *node.mills]
    extra = sum(1 for i in indexes if blocks[i].message)
    extra += STOP_ROWS if any(blocks[i].stop for i in indexes) else 0
    block = blocks[indexes[0]]
    used: int = getattr(block, "tool", tool)
    extra += TOOL_ROWS if used != tool else SPINDLE_ROWS
    if isinstance(node, Single):
        if isinstance(block, Hole):
            return Size(extra + _hole_rows(block), 1, 0), used
        # A kind that counts its own moves declares how (`Kind.cost`: HELIX, THREAD MILL,
        # FACE, ENGRAVE); any other block standing alone is a move to X/Y.
        estimator = REGISTRY.estimator(type(block))
        if estimator is not None and REGISTRY.of(block).mill is not Mill.ROUTINE:
            rows: int = estimator(program, block)
            return Size(extra + rows, 0, 0), used
        return Size(extra + POS_ROWS, 0, 0), used
    if isinstance(node, BoltPattern):
        bolt = blocks[node.bolt]
        assert isinstance(block, Hole) and isinstance(bolt, BoltCircle)
        count = max(bolt.holes, 1)
        return Size(extra + count * _hole_rows(block), count, 0), used
    assert isinstance(node, MillSequence) and isinstance(block, Hole)
    levels = max(block.pecks, 1)
    # A routine (CIRCLE, FRAME, POCKET) declares how it counts its sequence (`Kind.cost`);
    # contour blocks are counted here, a few elements each.
    estimator = REGISTRY.estimator(type(blocks[node.mills[0]]))
    if estimator is not None:
        routine: Size = estimator(program, blocks, node)
        return replace(routine, moves=extra + SEQUENCE_ROWS + routine.moves), used
    per_level = CONTOUR_ELEMENTS * len(node.mills) + LEVEL_ROWS
    return Size(extra + SEQUENCE_ROWS + levels * per_level, 0, 0), used


def _body(
    blocks: tuple[Block, ...], program: Program, node: LoopPattern, tool: int
) -> tuple[Size, int]:
    """One pattern of a LOOP entered with `tool`, and the tool after it."""
    moves = holes = passes = 0
    pocket: tuple[int, int, int] | None = None
    for child in node.body:
        size, tool = _node(blocks, program, child, tool)
        moves += size.moves
        holes += size.holes
        passes += size.passes
        pocket = _heavier(pocket, size.pocket)
    return Size(moves, holes, passes, pocket), tool


def _heavier(
    a: tuple[int, int, int] | None, b: tuple[int, int, int] | None
) -> tuple[int, int, int] | None:
    """Of two POCKETs (block, levels, points), the one whose planning is more work."""
    if a is None or (b is not None and b[1] * b[2] > a[1] * a[2]):
        return b
    return a


def routine_size(program: Program, blocks: tuple[Block, ...], sequence: MillSequence) -> Size:
    """CIRCLE's and FRAME's `Kind.cost`: each peck level (and the second pass of a 2P) a
    ring, or a ring per step-over across a pocket's half, and a helical ramp's turns."""
    drill = blocks[sequence.drill]
    routine = blocks[sequence.mills[0]]
    assert isinstance(drill, Hole)
    levels = max(drill.pecks, 1)
    rings = _routine_rings(program, routine)
    two_pass = 1 if getattr(routine, "two_pass", False) else 0
    per_level = rings * RING_ELEMENTS + LEVEL_ROWS
    ramp = _ramp_rows(program, drill, routine, levels)
    return Size((levels + two_pass) * per_level + ramp, 0, 0)


def pocket_size(program: Program, blocks: tuple[Block, ...], sequence: MillSequence) -> Size:
    """An irregular POCKET's `Kind.cost`: its rings each peck level (`_pocket`), and what
    its planning multiplies, for `sizes.MAX_POCKET_WORK`."""
    drill = blocks[sequence.drill]
    assert isinstance(drill, Hole)
    levels = max(drill.pecks, 1)
    rings, per_ring, work = _pocket(blocks, program, sequence)
    per_level = rings * per_ring + LEVEL_ROWS
    return Size(levels * per_level, 0, levels * rings, (sequence.mills[0] + 1, *work))


def _ramp_rows(program: Program, drill: Hole, routine: Block, levels: int) -> int:
    """About how many rows a pocket's ramp entry makes (app/cnc/ramp.py): a row a helix's
    turn or a zigzag's leg down the whole depth, and one more a level for what is left. From the
    numbers alone: a tiny tool at a shallow angle is refused before it is compiled."""
    if not isinstance(routine, Circle | Frame) or routine.entry is None or not drill.has_depth:
        return 0
    tool_radius = _tool_radius(program, routine.tool)
    # The length of one row: a helix's turn, or a zigzag's leg.
    row = (
        zigzag_length(tool_radius)
        if routine.entry is Entry.ZIGZAG
        else 2 * math.pi * helix_radius(tool_radius)
    )
    # An angle out of range is refused by validation; here it is only kept from nothing.
    stated = float(angle_of(routine.ramp_angle))
    angle = math.radians(min(max(stated, float(RAMP_LOW)), RAMP_HIGH))
    pitch = max(row * math.tan(angle), 1.0)
    assert drill.z_up is not None and drill.z_dn is not None
    depth = max(to_nm(drill.z_up, drill.units) - to_nm(drill.z_dn, drill.units), 0)
    return int(depth / pitch) + 2 * levels


def _hole_rows(block: Hole) -> int:
    if not block.has_depth:
        return POS_ROWS  # over the hole, and a stop for the quill
    pecks = max(block.pecks, 1) if block.op is HoleOp.DRILL else 1
    return HOLE_ROWS + PECK_ROWS * (pecks - 1)


def _tool_radius(program: Program, number: int) -> int:
    tool = program.block0.tool(number)
    if tool is None or tool.diameter is None:
        return 0
    return to_nm(tool.diameter, program.units) // 2


def _step(program: Program, block: Block, explicit: Decimal | None = None) -> int | None:
    """The step-over of a pocket in nm (as typed, else the tool's DIA less the overlap), or
    None when there is none to plan with (no DIA, or a step the planner refuses)."""
    tool: int = getattr(block, "tool")  # noqa: B009 - every routine block has one
    radius = _tool_radius(program, tool)
    if radius <= 0:
        return None
    step = (
        2 * radius - pocket_overlap(block.units)
        if explicit is None
        else to_nm(explicit, block.units)
    )
    return step if 0 < step < 2 * radius else None


def _routine_rings(program: Program, block: Block) -> int:
    """Rings of a CIRCLE or FRAME: one, or one per step-over across a pocket's half."""
    assert isinstance(block, Circle | Frame)
    if block.placement is not Placement.POCKET:
        return 1
    if isinstance(block, Circle):
        room = to_nm(abs(block.radius), block.units)
    else:
        room = min(to_nm(abs(block.xl), block.units), to_nm(abs(block.yw), block.units)) // 2
    step = _step(program, block)
    return 1 if step is None else room // step + 2


def _pocket(
    blocks: tuple[Block, ...], program: Program, node: MillSequence
) -> tuple[int, int, tuple[int, int]]:
    """(rings, moves per ring, (levels, points)) of an irregular POCKET: a level per
    step-over across the narrower half of its boundary's box (at most the planner's
    MAX_LEVELS + 1), each level a ring round every contour, each ring twice the contours'
    elements (corner arcs and trims) and its link. Its planning shrinks the region (the
    contours drawn with `points` points, each arc in chords within the planner's
    tolerance) once per level: levels x points is what it multiplies."""
    # The pocket engine (and pyclipper) is loaded for a POCKET, not for every cost.
    from app.cnc.pocketing.plan import MAX_LEVELS
    from app.cnc.pocketing.routine import contours_at

    pocket = blocks[node.mills[0]]
    drill = blocks[node.drill]
    assert isinstance(pocket, Pocket) and isinstance(drill, Hole)
    start = (to_nm(drill.x, drill.units), to_nm(drill.y, drill.units))
    contours = contours_at(blocks, node.mills[0] + 1, start)
    elements = sum(len(c.path.elements) for c in contours)
    boundary = contours[0].path if contours else None
    if boundary is None or not boundary.elements:
        return 1, 2 * elements + 2, (0, 0)
    points = [boundary.start, *(e.end for e in boundary.elements)]
    arcs = zip(points[:-1], boundary.elements, strict=True)
    reach = max((math.dist(a, e.centre) for a, e in arcs if e.centre), default=0.0)
    xs = [p[0] for p in points]
    ys = [p[1] for p in points]
    half = (min(max(xs) - min(xs), max(ys) - min(ys)) + 2 * reach) / 2
    step = _step(program, pocket, pocket.step_over)
    levels = 1 if step is None else min(MAX_LEVELS + 1, int(half // step) + 2)
    drawn = sum(_points(c.path) for c in contours)
    per_ring = 2 * (elements // max(len(contours), 1)) + 2
    return levels * len(contours), per_ring, (levels if step is not None else 0, drawn)


def _points(path: Path) -> int:
    """The points a contour is drawn with for planning (regions.polygon)."""
    from app.cnc.pocketing.plan import DEFAULT_CHORDAL_TOLERANCE
    from app.cnc.pocketing.regions import arc_steps

    count = 0
    at = path.start
    for element in path.elements:
        if element.centre is None:
            count += 1
        else:
            radius = math.dist(at, element.centre)
            turn = sweep(at, element) if radius > 0 else 0.0
            count += arc_steps(radius, turn, DEFAULT_CHORDAL_TOLERANCE)
        at = element.end
    return count
