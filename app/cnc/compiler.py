"""The compiler: a Program becomes its CompiledPath (path.py) in one pass, node by node.

It behaves as seed 001 §3.4.5 describes the data-block control, with the readings of
DESIGN.md §3 where the manual is vague (docs/readings.md has them all):

- Retract height: Z RET above Z UP after each operation and while positioning; above tool
  zero when Z UP is negative. Before any hole block it is Z RET above tool zero.
- Positioning goes up before moving across and across before going down, so the tool never
  drops below the height it travels at.
- DRILL: XY and retract height at rapid, rapid to Z UP, feed to Z DN (peck levels evenly
  spaced from Z UP to Z DN, rapid up to Z UP and back down to the level just reached between
  them), dwell 0.8 s, rapid to the retract height.
- BORE: as DRILL without pecks, then feed out to Z UP. TAP: as DRILL to Z DN without dwell,
  spindle reversed, feed up to Z UP + 0.3 in (7.62 mm), original direction restored.
- BOLT CIR: the block before gives the centre and the hole parameters and is not drilled;
  afterwards the table is over the last hole, which is the reference for an INC block.
- LOOP/REP: pattern (i, j) starts at the reference point before the LOOP block plus
  (i·ΔX, j·ΔY), row by row; nested pairs repeat inside each outer pattern.
- STOP: after its block, the head retracts, the spindle stops, the program stops.
- A block without depths (2-axis, as on the ProtoTRAK Plus) moves in XY only and stops for
  the operator where the quill goes down and up.

What makes it fast and small (issue 18):

- Each top-level node (a block, a bolt circle, a mill sequence, a LOOP) is compiled for the
  state it is entered in (position, tool, spindle, coolant, retract height, reference) and
  the result is cached by (its blocks, that state): after an edit, only the nodes whose
  blocks or entry state changed are compiled again (`Cache`).
- A LOOP's patterns are compiled in coordinates relative to each pattern's reference point
  (its blocks are incremental): patterns entered in the same relative state are the same
  piece, compiled once and placed by translation (`path.Run`).
- Lengths are integer nanometres, converted once where a block's value is read; geometry
  (plane.py and what builds on it) is computed in floats and rounded once per move.

Programs with errors compile as far as they can: a node that cannot be cut (a mill sequence
whose plan has errors) gives no moves and its problems; the rest compiles. The problems a
compile finds are the geometry's (`Compiled.problems`); validate.py adds the rest.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from decimal import Decimal
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from app.cnc import cost, limits, sizes
from app.cnc.blocks import (
    Block,
    BoltCircle,
    DataBlock0,
    Hole,
    HoleOp,
    Mode,
    Pos,
    Program,
    Rep,
)
from app.cnc.cutter import Finding
from app.cnc.geometry import bolt_circle_points, resolve_xy
from app.cnc.kinds import REGISTRY
from app.cnc.memo import ByObject, Memo, Recent
from app.cnc.path import (
    HOLE,
    MOVE,
    TAG,
    CompiledPath,
    HoleSpan,
    MillPlan,
    MillSpan,
    Node,
    Op,
    Piece,
    Run,
    Seq,
    plan_rows,
    size,
)
from app.cnc.plane import Path, length
from app.cnc.problems import Rule, Severity
from app.cnc.ramp import Ramp, Zigzag
from app.cnc.routines import peck_levels as peck_levels  # where it was, for its importers
from app.cnc.sequences import SequencePlan, plan_sequence
from app.cnc.structure import BoltPattern, LoopPattern, MillSequence, Single, build_nodes
from app.cnc.toolpath import ToolInfo
from app.cnc.units import Units, to_nm

if TYPE_CHECKING:
    # The pocket engine (and pyclipper) is loaded when a POCKET is cut, not for every
    # compile: a command on a program without one does not wait for it.
    from app.cnc.pocketing.model import PocketPlan

DWELL_MS = int(limits.HOLE_DWELL_SECONDS * 1000)

Row = tuple[int, int, int, int, int, int, int, int, int, int]
Calculated = tuple[int, str, Decimal]  # (block number, field name, value)


class CompileError(ValueError):
    """The program asks for motion the compiler cannot produce (names the block)."""

    def __init__(self, block: int, message: str) -> None:
        super().__init__(f"block {block}: {message}")
        self.block = block
        self.message = message


def retract_height(z_up: int, z_retract: int) -> int:
    """Z RET above Z UP, or above tool zero when Z UP is negative (seed 001 §3.4.4)."""
    return max(z_up, 0) + z_retract


class State(NamedTuple):
    """Where the control is between nodes: what a node's moves depend on. (A tuple: made,
    compared and hashed once per node per compile, and a tuple does that fastest.)"""

    x: int
    y: int
    z: int
    tool: int
    spindle_on: bool
    coolant: str
    retract: int
    reference: tuple[int, int]

    def shifted(self, dx: int, dy: int) -> State:
        """The same state with X, Y and the reference point moved by (dx, dy)."""
        return State(
            self.x + dx,
            self.y + dy,
            self.z,
            self.tool,
            self.spindle_on,
            self.coolant,
            self.retract,
            (self.reference[0] + dx, self.reference[1] + dy),
        )


@dataclass(slots=True)
class NodeResult:
    """A compiled top-level node: its moves (blocks relative to its first block), the state
    it leaves, and the geometry's findings (blocks relative too)."""

    node: Node
    exit: State
    findings: list[Finding]
    calculated: list[Calculated]


class Cache(Memo[NodeResult]):
    """Compiled top-level nodes by (blocks, entry state, Data Block 0 and units): an edit
    recompiles only what changed.

    Bounded by moves held (`rows`, at 62 bytes a move; the plans kept on its mill spans
    counted as the rows their memory would hold): least recently used entries go first,
    and a node larger than a tenth of the budget is not kept. Safe to share between
    threads (a web server's requests).
    """

    def put(self, key: object, value: NodeResult) -> None:
        self.keep(key, value, size(value.node) + plan_rows(value.node) + 1)


# A top-level node's one placement: where it was compiled (read only; shared by every Run).
_HERE = np.zeros((1, 2), dtype=np.int64)
_HERE.flags.writeable = False


class _Key:
    """A top-level node's cache key: (its blocks, shape, entry state, Data Block 0 and
    units), with its hash worked out once (a lookup hashes a key twice) from each block's
    hash, kept per block object (most blocks are the same objects edit after edit)."""

    __slots__ = ("hash", "parts")

    def __init__(
        self,
        blocks: tuple[Block, ...],
        shape: object,
        state: State,
        context: object,
        context_hash: int,
    ) -> None:
        self.parts = (blocks, shape, state, context)
        self.hash = hash((tuple(_block_hash(b) for b in blocks), shape, state, context_hash))

    def __hash__(self) -> int:
        return self.hash

    def __eq__(self, other: object) -> bool:
        return isinstance(other, _Key) and self.hash == other.hash and self.parts == other.parts


_BLOCK_HASHES: ByObject[int] = ByObject()
# One object per distinct (Data Block 0, units): every node's key holds it, and a key
# compared with a kept one then finds it the same object instead of comparing every tool
# (each version read from the library has a Data Block 0 object of its own).
_CONTEXTS: Recent[tuple[DataBlock0, Units]] = Recent(64)


def _interned(context: tuple[DataBlock0, Units]) -> tuple[DataBlock0, Units]:
    found = _CONTEXTS.get(context)
    if found is None:
        _CONTEXTS.keep(context, context)
        found = context
    return found


def _block_hash(block: Block) -> int:
    found = _BLOCK_HASHES.get(block)
    if found is None:
        found = hash(block)
        _BLOCK_HASHES.keep(block, found)
    return found


@dataclass(slots=True, frozen=True)
class Compiled:
    """A compiled program: its path and the problems its geometry has (block numbers
    absolute, each once, in block order; the findings of mill sequences and routines).
    Shared between callers: read it, do not change it."""

    path: CompiledPath
    findings: tuple[Finding, ...] = ()
    # The values calculated from the print (issue 33, app/cnc/solve.py): (block, field,
    # value as the block would hold it), for the editor to show beside the typed ones.
    calculated: tuple[Calculated, ...] = ()


# The nodes every compile in this process shares, and the last few programs compiled:
# validation, the preview, the time and an export of the same program compile it once.
SHARED_CACHE = Cache()
# By what the compile reads of a program, by object for its blocks and Data Block 0 (a
# program's hash would hash every block's values): each entry keeps its program, so no id
# in a key is reused while the entry is in.
_RECENT: Recent[tuple[Program, Compiled]] = Recent(8, lru=True)


def compile_program(program: Program, cache: Cache | None = None) -> Compiled:
    """Compile a program (COPY blocks already carried out; a pending COPY is skipped).

    Never raises: a node that cannot be cut (a mill sequence whose geometry has an error)
    is left out and its findings say why; the rest compiles. A program past the moves it
    may make (`sizes.move_limit()`, estimated from its blocks by `cost`, and counted as
    each top-level node is compiled) compiles up to the node that takes it past, and an
    error names that node's first block: nothing after the compile works on more moves
    than the limit. `cache` keeps compiled nodes between compiles; by default the
    process's shared cache, and a program compiled a moment ago is answered from memory.

    Raises sizes.OverBudget when a time budget is in force and runs out.
    """
    if cache is not None:
        return _Compiler(program, cache).run()
    key = (id(program.blocks), id(program.block0), program.units, sizes.move_limit())
    found = _RECENT.get(key)
    if found is not None and found[0].blocks is program.blocks:
        return found[1]
    result = _Compiler(program, SHARED_CACHE).run()
    _RECENT.keep(key, (program, result))
    return result


class _Buffer:
    """The moves of one piece being compiled."""

    __slots__ = ("holes", "mills", "rows", "strings")

    def __init__(self) -> None:
        self.rows: list[Row] = []
        self.holes: list[tuple[int | bool, ...]] = []
        self.mills: list[MillSpan] = []
        self.strings: list[str] = []

    def text(self, value: str) -> int:
        try:
            return self.strings.index(value)
        except ValueError:
            self.strings.append(value)
            return len(self.strings) - 1


class _Compiler:
    def __init__(self, program: Program, cache: Cache | None) -> None:
        self.program = program
        self.blocks = program.blocks
        units = program.units
        db0 = program.block0
        self.cache = cache
        self.context = _interned((db0, units))
        self.context_hash = hash(self.context)
        self.z_retract = to_nm(db0.z_retract, units)
        self.tools = {
            t.number: ToolInfo(
                number=t.number,
                diameter=None if t.diameter is None else to_nm(t.diameter, units),
                rpm=t.rpm,
                tcal=None if t.tcal is None else to_nm(t.tcal, units),
                coolant=t.coolant.value,
                name=t.name,
            )
            for t in db0.tools
        }
        self.x, self.y, self.z = 0, 0, self.z_retract
        self.reference = (0, 0)
        self.retract = self.z_retract
        self.tool = db0.current_tool
        self.spindle_on = False
        self.coolant = "off"
        self.base = 0  # block numbers in rows are relative to this one
        self.buffer = _Buffer()
        self.nodes: list[Node] = []  # the nodes of the sequence being compiled
        self.findings: list[Finding] = []
        self.calculated: list[Calculated] = []

    # -- state ----------------------------------------------------------------------------

    def state(self) -> State:
        return State(
            self.x,
            self.y,
            self.z,
            self.tool,
            self.spindle_on,
            self.coolant,
            self.retract,
            self.reference,
        )

    def restore(self, state: State) -> None:
        self.x, self.y, self.z = state.x, state.y, state.z
        self.tool = state.tool
        self.spindle_on = state.spindle_on
        self.coolant = state.coolant
        self.retract = state.retract
        self.reference = state.reference

    # -- the program ----------------------------------------------------------------------

    def run(self) -> Compiled:
        top: list[Node] = []
        limit = sizes.move_limit()
        over = cost.estimate(self.program, limit)
        moves = 0
        for node in build_nodes(self.blocks, tolerant=True):
            indexes = _indexes(node)
            first = indexes[0]
            if over.stop is not None and first + 1 >= over.stop:
                self.findings.append(_too_large(over, limit))
                break
            sizes.spend()
            key = _Key(
                tuple(self.blocks[i] for i in indexes),
                _shape(node, first),
                self.state(),
                self.context,
                self.context_hash,
            )
            found = self.cache.get(key) if self.cache is not None else None
            if found is None:
                found = self.compile_top(node, first + 1)
                if self.cache is not None:
                    self.cache.put(key, found)
            moves += size(found.node)
            if moves > limit:
                # More than the estimate foresaw (a pocket's rings drawn as polylines):
                # the same limit, on the moves made.
                made = cost.Cost(moves, 0, 0, first + 1, size(found.node), stop=first + 1)
                self.findings.append(_too_large(made, limit))
                break
            self.restore(found.exit)
            top.append(Run(found.node, _HERE, first + 1))
            self.findings += [_shifted(f, first + 1) for f in found.findings]
            self.calculated += [(n + first + 1, name, v) for n, name, v in found.calculated]
        self.base = 0
        last = len(self.blocks)
        self.retract_up(last)
        self.set_coolant(last, "off")
        if self.spindle_on:
            self.emit(Op.SPINDLE_OFF, last)
        self.emit(Op.END, last)
        top.append(self.take())
        path = CompiledPath(
            units=self.program.units,
            origin=(
                to_nm(self.program.block0.x_offset, self.program.units),
                to_nm(self.program.block0.y_offset, self.program.units),
            ),
            start=(0, 0, self.z_retract),
            initial_tool=self.program.block0.current_tool,
            tools=self.tools,
            root=Seq(top),
        )
        return Compiled(path, _distinct(self.findings), tuple(sorted(set(self.calculated))))

    def compile_top(self, node: object, base: int) -> NodeResult:
        """One top-level node from the current state, blocks relative to `base`."""
        self.base = base
        saved_findings, saved_calculated = self.findings, self.calculated
        self.findings, self.calculated = [], []
        self.run_node(node)
        findings = [_shifted(f, -base) for f in self.findings]
        calculated = [(n - base, name, v) for n, name, v in self.calculated]
        result = NodeResult(self.collect(), self.state(), findings, calculated)
        self.findings, self.calculated = saved_findings, saved_calculated
        return result

    def take(self) -> Piece:
        """The buffer as a piece (and a fresh buffer)."""
        buffer, self.buffer = self.buffer, _Buffer()
        rows = np.array(buffer.rows, dtype=MOVE) if buffer.rows else np.zeros(0, dtype=MOVE)
        holes = np.array(buffer.holes, dtype=HOLE) if buffer.holes else np.zeros(0, dtype=HOLE)
        return Piece(rows, holes, tuple(buffer.mills), 0, tuple(buffer.strings))

    def collect(self) -> Node:
        """Everything compiled since the sequence began: one node."""
        if self.buffer.rows or not self.nodes:
            self.nodes.append(self.take())
        nodes, self.nodes = self.nodes, []
        return nodes[0] if len(nodes) == 1 else Seq(nodes)

    # -- nodes ----------------------------------------------------------------------------

    def run_node(self, node: object) -> None:
        if isinstance(node, LoopPattern):
            self.run_loop(node)
            return
        if isinstance(node, Single):
            indexes = [node.index]
        elif isinstance(node, BoltPattern):
            indexes = [node.centre, node.bolt]
        else:
            assert isinstance(node, MillSequence)
            indexes = [node.drill, *node.mills]
        for i in indexes:
            if self.blocks[i].message:
                self.emit(Op.MESSAGE, i + 1, value=self.buffer.text(self.blocks[i].message))
        if isinstance(node, Single):
            self.run_single(node.index)
        elif isinstance(node, BoltPattern):
            self.run_bolt_circle(node)
        else:
            self.run_mill_sequence(node)
        if any(self.blocks[i].stop for i in indexes):
            self.program_stop(indexes[-1] + 1)

    def run_loop(self, node: LoopPattern) -> None:
        """LOOP … REP: each pattern compiled relative to its reference point; patterns
        entered in the same relative state share one piece, placed by translation."""
        rep = self.blocks[node.rep]
        assert isinstance(rep, Rep)
        step_x, step_y = to_nm(rep.x, rep.units), to_nm(rep.y, rep.units)
        start = self.reference
        translatable = _incremental(self.blocks, node)
        if self.buffer.rows:
            self.nodes.append(self.take())
        outer = self.nodes
        self.nodes = []
        bodies: dict[State, tuple[Node, State]] = {}
        runs: list[tuple[Node, list[tuple[int, int]]]] = []
        for j in range(rep.ny + 1):
            for i in range(rep.nx + 1):
                sizes.spend()
                ref = (start[0] + i * step_x, start[1] + j * step_y)
                self.reference = ref
                if translatable:
                    # The body as seen from its pattern's reference point, which is (0, 0).
                    entry = self.state().shifted(-ref[0], -ref[1])
                    found = bodies.get(entry)
                    if found is None:
                        self.restore(entry)
                        for child in node.body:
                            self.run_node(child)
                        found = (self.collect(), self.state())
                        bodies[entry] = found
                    body, exit_state = found
                    self.restore(exit_state.shifted(ref[0], ref[1]))
                    offset = ref
                else:
                    for child in node.body:
                        self.run_node(child)
                    body, offset = self.collect(), (0, 0)
                if runs and runs[-1][0] is body:
                    runs[-1][1].append(offset)
                else:
                    runs.append((body, [offset]))
        self.nodes = outer
        first = 0
        for body, offsets in runs:
            placed = Run(
                body,
                np.array(offsets, dtype=np.int64),
                rep=node.rep + 1 - self.base,
                first=first,
                origin=start if translatable else (0, 0),
            )
            self.nodes.append(placed)
            first += len(offsets)

    def run_single(self, index: int) -> None:
        block = self.blocks[index]
        number = index + 1
        if isinstance(block, Pos):
            self.use_tool(number, block.tool)
            target = self.resolve(block)
            self.position(number, target, self.retract)
            self.reference = target
            if block.index:
                self.emit(Op.INDEX, number)
        elif isinstance(block, Hole):
            target = self.resolve(block)
            self.hole(number, block, target)
            self.reference = target
        else:
            # An operation (HELIX, THREAD MILL, FACE, ENGRAVE): its kind declares what cuts
            # it (`Kind.cut`), at its X/Y.
            cut = REGISTRY.cutter(type(block))
            if cut is None:
                raise CompileError(number, f"a {block.title} block cannot stand on its own here")
            target = self.resolve(block)
            cut(self, number, block, target)
            self.reference = target

    def run_bolt_circle(self, node: BoltPattern) -> None:
        centre_block = self.blocks[node.centre]
        bolt = self.blocks[node.bolt]
        assert isinstance(centre_block, Hole) and isinstance(bolt, BoltCircle)
        centre = self.resolve(centre_block)
        radius = to_nm(bolt.radius, bolt.units)
        points = bolt_circle_points(centre, radius, bolt.holes, bolt.angle)
        number = node.bolt + 1
        self.hole(number, centre_block, points[0])
        rest = points[1:]
        if len(rest) >= 2 and len(set(points)) == len(points):
            # From the second hole on, each hole is entered alike (over the hole before,
            # at the same height, tool and spindle), and a hole's moves do not depend on
            # where across the tool comes from: one hole's moves, placed at each point.
            self.hole_pattern(number, centre_block, rest)
        else:
            for point in rest:
                self.hole(number, centre_block, point)
        self.reference = points[-1]

    def hole_pattern(self, number: int, block: Hole, points: list[tuple[int, int]]) -> None:
        """Holes at `points` (distinct, none where the tool is): the first compiled at
        (0, 0), and placed at every point when it leaves the state it was entered in
        (apart from where the tool is); otherwise each hole is compiled in turn."""
        entry = self.state()
        first = points[0]
        if self.buffer.rows:
            self.nodes.append(self.take())
        self.restore(entry.shifted(-first[0], -first[1]))
        self.hole(number, block, (0, 0))
        piece = self.take()
        exit_state = self.state()
        if _alike(entry, exit_state):
            self.nodes.append(Run(piece, np.array(points, dtype=np.int64)))
            last = points[-1]
            self.restore(exit_state.shifted(last[0], last[1]))
            return
        self.restore(entry)
        for point in points:
            self.hole(number, block, point)

    def run_mill_sequence(self, node: MillSequence) -> None:
        """A DRILL and its mill blocks: plunge, cut every pass at each peck level, retract.

        With pecks the whole sequence runs at each level; between levels the head rapids to
        the retract height, back to the plunge point, down to the level just finished, and
        feeds to the next (seed 001 §3.4.5.2 PECK). A 2P routine takes its levels down to
        the roughing depth, then feeds to Z DN for the finishing pass. A sequence whose plan
        has errors is not cut (its findings say why; its MillSpan has no rows); the
        reference still moves on.
        """
        drill = self.blocks[node.drill]
        assert isinstance(drill, Hole)
        number = node.drill + 1
        last = node.mills[-1] + 1
        start = self.resolve(drill)
        plan = plan_sequence(
            self.blocks, self.program.block0, self.program.units, node.drill, node.mills, start
        )
        self.findings += plan.findings
        self.calculated += [(n, name, v) for (n, name), v in plan.calculated.items()]
        if any(f.severity is Severity.ERROR for f in plan.findings) or not plan.passes:
            # Not cut: a span without rows says where it would be (with the programmed
            # contour), so a drawing can show what is left out.
            self.record_mill(node, drill, start, len(self.buffer.rows), plan)
            self.reference = plan.end
            return
        self.use_tool(number, drill.tool)
        first_row = len(self.buffer.rows)
        if plan.pocket is not None:
            if drill.has_depth:
                self.cut_pocket(number, last, drill, plan.pocket)
            else:
                self.cut_pocket_by_hand(number, last, plan.pocket)
            self.record_mill(node, drill, start, first_row, plan)
            self.reference = plan.end
            return
        plunge = rounded_point(plan.passes[0].start)
        if not drill.has_depth:
            self.position(number, plunge, self.z)
            self.stop_for(number, "quill: lower the quill to depth by hand")
            for path in plan.passes:
                self.cut(path, depth_cap=None, feed_z=0, follow_depth=False)
            self.stop_for(last, "quill: raise the quill by hand")
            self.record_mill(node, drill, start, first_row, plan)
            self.reference = plan.end
            return
        z_up, z_dn, feed_z = _depths(drill)
        self.retract = retract_height(z_up, self.z_retract)
        levels = peck_levels(z_up, z_dn + plan.rough_allowance, drill.pecks)
        # Where each level's way down starts: the plunge point, or its ramp's start.
        ramps = [
            None if plan.ramp is None else plan.ramp.rows(above, level)
            for above, level in zip([z_up, *levels], levels, strict=False)
        ]
        self.position(number, plunge if ramps[0] is None else ramps[0][0], self.retract)
        self.rapid_z(number, z_up)
        first = plan.passes[0]
        routine = node.mills[0] + 1
        for k, level in enumerate(levels):
            final = k == len(levels) - 1
            ramp = ramps[k]
            if ramp is None:
                self.feed_to(number, (self.x, self.y, level), feed_z)
            else:
                self.ramp_down(routine, ramp[1], plan.ramp)
            self.cut(first, depth_cap=None if final else level, feed_z=feed_z)
            if not final:
                self.retract_up(number)
                following = ramps[k + 1]
                self.rapid_xy(number, plunge if following is None else following[0])
                self.rapid_z(number, level, tag="peck-reentry")
        for path in plan.passes[1:]:
            # The finishing pass of a 2P routine: over to its plunge point, down to Z DN.
            finish_start = rounded_point(path.start)
            self.feed_to(
                last, (finish_start[0], finish_start[1], self.z), self.feed_of(last), "step-over"
            )
            self.feed_to(number, (self.x, self.y, z_dn), feed_z)
            self.cut(path, depth_cap=None, feed_z=feed_z)
        self.retract_up(last)
        self.record_mill(node, drill, start, first_row, plan)
        self.reference = plan.end

    def ramp_down(
        self, number: int, ends: list[tuple[int, int, int]], ramp: Ramp | Zigzag | None
    ) -> None:
        """Down a ramp (app.cnc.ramp) from where the tool is to its rows' `ends`, at block
        `number`'s XY feed: each row a helical arc about a helix's centre, or a straight
        leg of a zigzag."""
        assert ramp is not None
        feed = self.feed_of(number)
        if isinstance(ramp, Zigzag):
            for end in ends:
                self.feed_to(number, end, feed, "lead-in")
            return
        centre = rounded_point(ramp.centre)
        for end in ends:
            self.helix_to(number, end, centre, ramp.clockwise, feed, "lead-in")

    def cut_pocket(self, number: int, last: int, drill: Hole, pocket: PocketPlan) -> None:
        """A POCKET: every pass at each peck level (app.cnc.pocketing).

        The tool goes down only where the plan says it fits: at the first pass's plunge
        point, and after a retract at a RETRACT link's start. At the first level it feeds
        down from Z UP; at the levels after, it rapids to the level just cut (that point was
        cleared there) and feeds on down, as the DRILL's pecks do. Between levels it
        retracts and returns to the first plunge point.
        """
        from app.cnc.pocketing.model import LinkKind

        z_up, z_dn, feed_z = _depths(drill)
        self.retract = retract_height(z_up, self.z_retract)
        first = rounded_point(pocket.passes[0].entry.path.start)
        self.position(number, first, self.retract)
        self.rapid_z(number, z_up)
        above = z_up
        levels = peck_levels(z_up, z_dn, drill.pecks)
        for k, level in enumerate(levels):
            for cut in pocket.passes:
                link = cut.entry
                if link.kind is LinkKind.RETRACT:
                    self.retract_up(number)
                    self.rapid_xy(number, rounded_point(link.path.start))
                    self.rapid_z(number, above, tag="" if k == 0 else "peck-reentry")
                if link.kind in (LinkKind.PLUNGE, LinkKind.RETRACT):
                    self.feed_to(number, (self.x, self.y, level), feed_z)
                self.cut_pocket_path(link.path, "step-over")
                self.cut_pocket_path(cut.path, "")
            if k < len(levels) - 1:
                self.retract_up(number)
                self.rapid_xy(number, first)
                self.rapid_z(number, level, tag="peck-reentry")
            above = level
        self.retract_up(last)

    def cut_pocket_by_hand(self, number: int, last: int, pocket: PocketPlan) -> None:
        """A 2-axis POCKET: the passes at the one depth the operator sets, stopping for the
        quill to go down at each place the plan plunges and to come up before the table
        moves on (as a 2-axis mill sequence does)."""
        from app.cnc.pocketing.model import LinkKind

        down = False
        for cut in pocket.passes:
            link = cut.entry
            if link.kind in (LinkKind.PLUNGE, LinkKind.RETRACT):
                if down:
                    self.stop_for(number, "quill: raise the quill by hand")
                self.position(number, rounded_point(link.path.start), self.z)
                self.stop_for(number, "quill: lower the quill to depth by hand")
                down = True
            self.cut_pocket_path(link.path, "step-over")
            self.cut_pocket_path(cut.path, "")
        self.stop_for(last, "quill: raise the quill by hand")

    def cut_pocket_path(self, path: Path, tag: str) -> None:
        """A pocket path's elements at the current depth; links and cleanup moves
        (`Element.tag` "link") are step-overs. An element shorter than a nanometre once
        rounded is left out: an arc whose end rounds onto its start would be a full circle."""
        feed = -1
        at = path.start  # the true start: an arc's sweep is judged from it, not the rounding
        for element in path.elements:
            end = rounded_point(element.end)
            if end == (self.x, self.y) and length(at, element) < 10:
                at = element.end
                continue
            at = element.end
            if feed < 0:
                feed = self.feed_of(element.block)
            move_tag = "step-over" if element.tag == "link" else tag
            if element.centre is None:
                self.feed_to(element.block, (end[0], end[1], self.z), feed, move_tag)
            else:
                self.arc_to(
                    element.block,
                    end,
                    rounded_point(element.centre),
                    element.clockwise,
                    feed,
                    move_tag,
                )
                self.x, self.y = end

    def record_mill(
        self,
        node: MillSequence,
        drill: Hole,
        start: tuple[int, int],
        first_row: int,
        plan: SequencePlan,
    ) -> None:
        """The span of a mill sequence just compiled, with its plan: what it is programmed
        to make, so no consumer plans it again."""
        finished = plan.finished
        routine = 0 if finished is not None else node.mills[0] + 1 - self.base
        depth = None if drill.z_dn is None else to_nm(drill.z_dn, drill.units)
        kept = MillPlan(plan.end, plan.routine, plan.outlines, plan.pocket, tuple(plan.findings))
        self.buffer.mills.append(
            MillSpan(
                first_row,
                len(self.buffer.rows),
                node.drill + 1 - self.base,
                start[0],
                start[1],
                finished,
                routine,
                depth,
                drill.tool,
                drill.comp.value,
                shift=-self.base,
                plan=kept,
            )
        )

    def cut(
        self, path: Path, depth_cap: int | None, feed_z: int, follow_depth: bool = True
    ) -> None:
        """Cut a path's elements from where the tool is (its start) at the current depth.

        `depth_cap` is the peck level being cut: no element goes deeper than it. An element
        whose block has a different Z DN feeds there first at the drill's FEEDR Z. In a
        2-axis sequence (`follow_depth` False) the quill is the operator's: Z never moves.
        """
        for element in path.elements:
            if follow_depth and element.z_dn is not None:
                z = element.z_dn if depth_cap is None else max(element.z_dn, depth_cap)
                if z != self.z:
                    self.feed_to(element.block, (self.x, self.y, z), feed_z)
            feed = self.feed_of(element.block)
            end = rounded_point(element.end)
            if element.centre is None:
                self.feed_to(element.block, (end[0], end[1], self.z), feed, element.tag)
            else:
                self.arc_to(
                    element.block,
                    end,
                    rounded_point(element.centre),
                    element.clockwise,
                    feed,
                    element.tag,
                )

    def feed_of(self, number: int) -> int:
        """The XY feed (nm/min) of mill block `number`."""
        block = self.blocks[number - 1]
        feed: Decimal = getattr(block, "feed_xy")  # noqa: B009 - every mill block has one
        return to_nm(feed, block.units)

    # -- operations ---------------------------------------------------------------------

    def hole(self, number: int, block: Hole, target: tuple[int, int]) -> None:
        """Drill, bore or tap one hole at `target` with `block`'s parameters."""
        self.use_tool(number, block.tool)
        if not block.has_depth:
            self.position(number, target, self.z)
            self.stop_for(number, f"quill: {block.op.value} the hole by hand, then raise it")
            return
        z_up, z_dn, feed = _depths(block)
        self.retract = retract_height(z_up, self.z_retract)
        # Up first (outside the hole's span: a canned cycle starts at the height it returns
        # to), then across, down and in.
        if self.retract > self.z:
            self.rapid_z(number, self.retract)
        elif self.z > self.retract:
            # Above it (a tool change raised the head): across and down to it first, also
            # outside the span, so the hole is a canned cycle from where it returns to.
            self.rapid_xy(number, target)
            self.rapid_z(number, self.retract)
        z0 = self.z
        first_row = len(self.buffer.rows)
        self.rapid_xy(number, target)
        self.rapid_z(number, self.retract)
        self.rapid_z(number, z_up)
        step = 0
        if block.op is HoleOp.DRILL:
            levels = peck_levels(z_up, z_dn, block.pecks)
            step = z_up - levels[0] if block.pecks > 1 else 0
            for k, level in enumerate(levels):
                self.feed_to(number, (self.x, self.y, level), feed)
                if k < len(levels) - 1:
                    self.rapid_z(number, z_up, tag="peck-retract")
                    self.rapid_z(number, level, tag="peck-reentry")
            self.emit(Op.DWELL, number, value=DWELL_MS)
        elif block.op is HoleOp.BORE:
            self.feed_to(number, (self.x, self.y, z_dn), feed)
            self.emit(Op.DWELL, number, value=DWELL_MS)
            self.feed_to(number, (self.x, self.y, z_up), feed)
        else:
            self.feed_to(number, (self.x, self.y, z_dn), feed)
            self.tap_out(number, block, z_up, feed)
        self.retract_up(number)
        canned = block.op is HoleOp.DRILL and self.z == z0 and z_up < z0
        self.buffer.holes.append(
            HoleSpan(
                first_row,
                len(self.buffer.rows),
                block.op,
                target[0],
                target[1],
                z0,
                z_up,
                z_dn,
                feed,
                block.pecks,
                step,
                DWELL_MS if block.op is not HoleOp.TAP else 0,
                canned,
                block.tool,
            ).row()
        )

    def tool_diameter(self, tool: int) -> int | None:
        """A tool's DIA in nm (None: not given, or not positive)."""
        info = self.tools.get(tool)
        if info is None or info.diameter is None or info.diameter <= 0:
            return None
        return info.diameter

    def spindle_rpm(self, tool: int) -> int | None:
        """A tool's signed RPM (None: none given)."""
        info = self.tools.get(tool)
        return None if info is None else info.rpm

    def tap_out(self, number: int, block: Hole, z_up: int, feed: int) -> None:
        """Reverse the spindle, feed up to 0.3 in above Z UP, restore the direction."""
        clockwise, rpm = self.spindle(block.tool)
        self.emit_spindle(number, not clockwise, rpm)
        lift = limits.TAP_FEED_OUT_INCH if block.units is Units.INCH else limits.TAP_FEED_OUT_MM
        self.feed_to(number, (self.x, self.y, z_up + to_nm(lift, block.units)), feed)
        self.emit_spindle(number, clockwise, rpm)

    def program_stop(self, number: int) -> None:
        """STOP: the head retracts and the spindle shuts off (seed 001 §3.4.5.3)."""
        self.retract_up(number)
        self.set_coolant(number, "off")
        if self.spindle_on:
            self.emit(Op.SPINDLE_OFF, number)
            self.spindle_on = False
        self.stop_for(number, "STOP")

    def stop_for(self, number: int, reason: str) -> None:
        self.emit(Op.STOP, number, value=self.buffer.text(reason))

    def use_tool(self, number: int, tool: int) -> None:
        """Change to `tool` if another is in the spindle, and make sure the spindle turns."""
        if tool != self.tool:
            self.retract_up(number)
            self.set_coolant(number, "off")
            # The head stays where it is for the change, so a longer new tool's tip ends up
            # lower: go high enough first that the new tip is still at the retract height.
            clear = self.retract + self.tcal(tool) - self.tcal(self.tool)
            if clear > self.z:
                self.rapid_z(number, clear, tag="retract")
            if self.spindle_on:
                self.emit(Op.SPINDLE_OFF, number)
                self.spindle_on = False
            self.z += self.tcal(self.tool) - self.tcal(tool)
            self.emit(Op.TOOL, number, z=self.z, value=tool)
            self.tool = tool
        if not self.spindle_on:
            clockwise, rpm = self.spindle(tool)
            self.emit_spindle(number, clockwise, rpm)
            self.spindle_on = True
        info = self.tools.get(tool)
        self.set_coolant(number, "off" if info is None else info.coolant)

    def set_coolant(self, number: int, mode: str) -> None:
        """Switch the coolant to `mode` (off, flood, mist) if it is not that already."""
        if mode == self.coolant:
            return
        if self.coolant != "off":
            self.emit(Op.COOLANT_OFF, number)
        if mode != "off":
            self.emit(Op.COOLANT, number, value=1 if mode == "flood" else 2)
        self.coolant = mode

    def tcal(self, tool: int) -> int:
        """A tool's calibrated Z zero in nm (0 for no tool or an uncalibrated one)."""
        info = self.tools.get(tool)
        return 0 if info is None or info.tcal is None else info.tcal

    def spindle(self, tool: int) -> tuple[bool, int | None]:
        """(clockwise, speed) of a tool's spindle: the RPM's sign and size, or clockwise at
        no known speed for a tool without RPM (a target that writes speeds refuses it)."""
        info = self.tools.get(tool)
        if info is None or info.rpm is None:
            return True, None
        return info.rpm > 0, abs(info.rpm)

    def resolve(self, block: Block) -> tuple[int, int]:
        x: Decimal = getattr(block, "x")  # noqa: B009 - every positioned block has x and y
        y: Decimal = getattr(block, "y")  # noqa: B009
        mode: Mode = block.mode
        return resolve_xy(x, y, mode, block.units, self.reference)

    # -- rows (each motion skips a move that goes nowhere) -------------------------------

    def emit(self, op: Op, number: int, z: int = 0, value: int = 0) -> None:
        self.buffer.rows.append((op, 0, number - self.base, 0, 0, z, 0, 0, 0, value))

    def emit_spindle(self, number: int, clockwise: bool, rpm: int | None) -> None:
        value = -1 if rpm is None else rpm
        self.buffer.rows.append(
            (Op.SPINDLE, 0, number - self.base, 0, 0, 0, 0, 0, int(clockwise), value)
        )

    def position(self, number: int, target: tuple[int, int], z: int) -> None:
        """Rapid to `target` at height `z`: up first, across, then down."""
        if z > self.z:
            self.rapid_z(number, z)
        self.rapid_xy(number, target)
        self.rapid_z(number, z)

    def retract_up(self, number: int) -> None:
        """Rapid up to the retract height; a head already above it stays where it is."""
        if self.z < self.retract:
            self.rapid_z(number, self.retract, tag="retract")

    def rapid_xy(self, number: int, target: tuple[int, int]) -> None:
        if (self.x, self.y) != target:
            self.x, self.y = target
            self.buffer.rows.append(
                (Op.RAPID, 0, number - self.base, self.x, self.y, self.z, 0, 0, 0, 0)
            )

    def rapid_z(self, number: int, z: int, tag: str = "") -> None:
        if z != self.z:
            self.z = z
            self.buffer.rows.append(
                (Op.RAPID, TAG[tag], number - self.base, self.x, self.y, z, 0, 0, 0, 0)
            )

    def feed_to(self, number: int, end: tuple[int, int, int], feed: int, tag: str = "") -> None:
        if end != (self.x, self.y, self.z):
            self.x, self.y, self.z = end
            self.buffer.rows.append((Op.FEED, TAG[tag], number - self.base, *end, 0, 0, feed, 0))

    def arc_to(
        self,
        number: int,
        end: tuple[int, int],
        centre: tuple[int, int],
        clockwise: bool,
        feed: int,
        tag: str = "",
    ) -> None:
        op = Op.ARC_CW if clockwise else Op.ARC_CCW
        self.buffer.rows.append(
            (op, TAG[tag], number - self.base, end[0], end[1], self.z, *centre, feed, 0)
        )
        self.x, self.y = end

    def helix_to(
        self,
        number: int,
        end: tuple[int, int, int],
        centre: tuple[int, int],
        clockwise: bool,
        feed: int,
        tag: str = "",
    ) -> None:
        """An arc from where the tool is to `end` (x, y, z, nm) about `centre`: helical when
        Z changes on the way. One row turns at most once around; a row that ends at its
        start's X/Y (and another Z) is one whole turn (path.py)."""
        op = Op.ARC_CW if clockwise else Op.ARC_CCW
        self.buffer.rows.append((op, TAG[tag], number - self.base, *end, *centre, feed, 0))
        self.x, self.y, self.z = end


def _too_large(over: cost.Cost, limit: int) -> Finding:
    """The error of a program past the moves it may make, on the block `over` names."""
    assert over.over is not None
    field = "LOOP" if over.rep is not None else "STEP" if over.levels else None
    return Finding(over.over, Rule.TOO_LARGE, Severity.ERROR, over.message(limit), field)


def _depths(block: Hole) -> tuple[int, int, int]:
    """Z UP, Z DN and FEEDR Z of a block with depths, in nm (and nm/min)."""
    assert block.z_up is not None and block.z_dn is not None and block.feed_z is not None
    units = block.units
    return to_nm(block.z_up, units), to_nm(block.z_dn, units), to_nm(block.feed_z, units)


def _alike(a: State, b: State) -> bool:
    """True when two states differ at most in where the tool is in XY."""
    return (a.z, a.tool, a.spindle_on, a.coolant, a.retract) == (
        b.z,
        b.tool,
        b.spindle_on,
        b.coolant,
        b.retract,
    )


def rounded_point(point: tuple[float, float]) -> tuple[int, int]:
    """A computed point rounded once to the nanometre."""
    return round(point[0]), round(point[1])


def _indexes(node: object) -> list[int]:
    """The block indexes a node is made of, in order."""
    if isinstance(node, Single):
        return [node.index]
    if isinstance(node, BoltPattern):
        return [node.centre, node.bolt]
    if isinstance(node, MillSequence):
        return [node.drill, *node.mills]
    assert isinstance(node, LoopPattern)
    inner = [i for child in node.body for i in _indexes(child)]
    return sorted({*inner, node.rep})


def _shape(node: object, first: int) -> object:
    """The node's structure with block indexes relative to its first block (two nodes of
    the same blocks and shape compile alike, wherever they are)."""
    if isinstance(node, Single):
        return ("single", node.index - first)
    if isinstance(node, BoltPattern):
        return ("bolt", node.centre - first, node.bolt - first)
    if isinstance(node, MillSequence):
        return ("mill", node.drill - first, tuple(i - first for i in node.mills))
    assert isinstance(node, LoopPattern)
    return ("loop", tuple(_shape(child, first) for child in node.body), node.rep - first)


def _incremental(blocks: tuple[Block, ...], node: LoopPattern) -> bool:
    """True when every positioned block of the loop is INC: its patterns are the same moves
    translated (a program with an ABS block inside a LOOP, an error, compiles each)."""
    for i in _indexes(node):
        block = blocks[i]
        if hasattr(block, "x") and not isinstance(block, Rep) and block.mode is Mode.ABS:
            return False
    return True


def _distinct(findings: list[Finding]) -> tuple[Finding, ...]:
    """Each finding once (a LOOP body compiled for several entry states finds its
    problems each time), in block order."""
    return tuple(sorted(dict.fromkeys(findings), key=lambda f: f.block))


def _shifted(finding: Finding, blocks: int) -> Finding:
    """A finding with its block number moved by `blocks`."""
    return replace(finding, block=finding.block + blocks)
