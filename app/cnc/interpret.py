"""The interpreter: a validated Program becomes a Toolpath of canonical moves.

It behaves as seed 001 §3.4.5 describes the data-block control, with the readings of
DESIGN.md §3 where the manual is vague:

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

Lengths are integer nanometres (see toolpath.py for the conventions). The interpreter
assumes `validate(program)` reported no errors; a pending COPY block is skipped.
"""

from __future__ import annotations

from decimal import Decimal
from fractions import Fraction

from app.cnc import limits
from app.cnc.blocks import (
    Block,
    BoltCircle,
    Hole,
    HoleOp,
    Mode,
    Pos,
    Program,
    Rep,
)
from app.cnc.geometry import bolt_circle_points, resolve_xy
from app.cnc.mill import Path, plan_sequence
from app.cnc.problems import Severity
from app.cnc.structure import BoltPattern, LoopPattern, MillSequence, Node, Single, build_nodes
from app.cnc.toolpath import (
    ArcFeed,
    CoolantOff,
    CoolantOn,
    Dwell,
    Feed,
    IndexTable,
    Message,
    Move,
    ProgramEnd,
    ProgramStop,
    Rapid,
    Repetition,
    SpindleOff,
    SpindleOn,
    ToolChange,
    ToolInfo,
    Toolpath,
)
from app.cnc.units import Units, to_nm


class InterpretError(ValueError):
    """The program asks for motion this interpreter cannot produce (names the block)."""

    def __init__(self, block: int, message: str) -> None:
        super().__init__(f"block {block}: {message}")
        self.block = block
        self.message = message


def interpret(program: Program) -> Toolpath:
    """Turn a validated program into its tool path. Raises InterpretError (see above)."""
    return _Interpreter(program).run()


def peck_levels(z_up: int, z_dn: int, pecks: int) -> list[int]:
    """The depths (nm) a drill feeds to: `pecks` levels evenly spaced, the last at Z DN.

    Level k (1…N) is Z UP − k·(Z UP − Z DN)/N, rounded once to the nanometre.
    """
    span = z_up - z_dn
    return [z_up - round(Fraction(k * span, pecks)) for k in range(1, pecks + 1)]


def retract_height(z_up: int, z_retract: int) -> int:
    """Z RET above Z UP, or above tool zero when Z UP is negative (seed 001 §3.4.4)."""
    return max(z_up, 0) + z_retract


class _Interpreter:
    def __init__(self, program: Program) -> None:
        self.program = program
        self.blocks = program.blocks
        units = program.units
        db0 = program.block0
        self.z_retract = to_nm(db0.z_retract, units)
        self.tools = {
            t.number: ToolInfo(
                number=t.number,
                diameter=None if t.diameter is None else to_nm(t.diameter, units),
                rpm=t.rpm,
                tcal=None if t.tcal is None else to_nm(t.tcal, units),
                coolant=t.coolant.value,
            )
            for t in db0.tools
        }
        self.x, self.y, self.z = 0, 0, self.z_retract
        self.reference = (0, 0)
        self.retract = self.z_retract
        self.tool = db0.current_tool
        self.spindle_on = False
        self.coolant = "off"
        self.loop_depth = 0
        self.moves: list[Move] = []
        self.toolpath = Toolpath(
            units=units,
            origin=(to_nm(db0.x_offset, units), to_nm(db0.y_offset, units)),
            start=(0, 0, self.z_retract),
            initial_tool=db0.current_tool,
            tools=self.tools,
            moves=self.moves,
        )

    def run(self) -> Toolpath:
        self.run_nodes(build_nodes(self.blocks))
        last = len(self.blocks)
        self.retract_up(last)
        self.set_coolant(last, "off")
        if self.spindle_on:
            self.moves.append(SpindleOff(last))
        self.moves.append(ProgramEnd(last))
        return self.toolpath

    # -- nodes ----------------------------------------------------------------------------

    def run_nodes(self, nodes: tuple[Node, ...]) -> None:
        for node in nodes:
            if isinstance(node, LoopPattern):
                self.run_loop(node)
                continue
            if isinstance(node, Single):
                indexes = [node.index]
            elif isinstance(node, BoltPattern):
                indexes = [node.centre, node.bolt]
            else:
                indexes = [node.drill, *node.mills]
            for i in indexes:
                if self.blocks[i].message:
                    self.moves.append(Message(i + 1, self.blocks[i].message))
            if isinstance(node, Single):
                self.run_single(node.index)
            elif isinstance(node, BoltPattern):
                self.run_bolt_circle(node)
            else:
                self.run_mill_sequence(node)
            if any(self.blocks[i].stop for i in indexes):
                self.program_stop(indexes[-1] + 1)

    def run_loop(self, node: LoopPattern) -> None:
        rep = self.blocks[node.rep]
        assert isinstance(rep, Rep)
        step_x, step_y = to_nm(rep.x, rep.units), to_nm(rep.y, rep.units)
        start = self.reference
        self.loop_depth += 1
        number = 0
        for j in range(rep.ny + 1):
            for i in range(rep.nx + 1):
                self.reference = (start[0] + i * step_x, start[1] + j * step_y)
                first = len(self.moves)
                self.run_nodes(node.body)
                self.toolpath.repetitions.append(
                    Repetition(
                        rep_block=node.rep + 1,
                        depth=self.loop_depth,
                        number=number,
                        start=first,
                        end=len(self.moves),
                        offset=(i * step_x, j * step_y),
                    )
                )
                number += 1
        self.loop_depth -= 1

    def run_single(self, index: int) -> None:
        block = self.blocks[index]
        number = index + 1
        if isinstance(block, Pos):
            self.use_tool(number, block.tool)
            target = self.resolve(block)
            self.position(number, target, self.retract)
            self.reference = target
            if block.index:
                self.moves.append(IndexTable(number))
        elif isinstance(block, Hole):
            target = self.resolve(block)
            self.hole(number, block, target)
            self.reference = target
        else:
            raise InterpretError(number, f"a {block.title} block cannot stand on its own here")

    def run_bolt_circle(self, node: BoltPattern) -> None:
        centre_block = self.blocks[node.centre]
        bolt = self.blocks[node.bolt]
        assert isinstance(centre_block, Hole) and isinstance(bolt, BoltCircle)
        centre = self.resolve(centre_block)
        radius = to_nm(bolt.radius, bolt.units)
        points = bolt_circle_points(centre, radius, bolt.holes, bolt.angle)
        for point in points:
            self.hole(node.bolt + 1, centre_block, point)
        self.reference = points[-1]

    def run_mill_sequence(self, node: MillSequence) -> None:
        """A DRILL and its mill blocks: plunge, cut every pass at each peck level, retract.

        With pecks the whole sequence runs at each level; between levels the head rapids to
        the retract height, back to the plunge point, down to the level just finished, and
        feeds to the next (seed 001 §3.4.5.2 PECK). A 2P routine takes its levels down to
        the roughing depth, then feeds to Z DN for the finishing pass.
        """
        drill = self.blocks[node.drill]
        assert isinstance(drill, Hole)
        number = node.drill + 1
        last = node.mills[-1] + 1
        start = self.resolve(drill)
        self.use_tool(number, drill.tool)
        plan = plan_sequence(
            self.blocks, self.program.block0, self.program.units, node.drill, node.mills, start
        )
        if any(f.severity is Severity.ERROR for f in plan.findings) or not plan.passes:
            raise InterpretError(last, "the mill sequence cannot be cut (validate first)")
        plunge = _round(plan.passes[0].start)
        if not drill.has_depth:
            self.position(number, plunge, self.z)
            self.moves.append(ProgramStop(number, "quill: lower the quill to depth by hand"))
            for path in plan.passes:
                self.cut(path, depth_cap=None, feed_z=0, follow_depth=False)
            self.moves.append(ProgramStop(last, "quill: raise the quill by hand"))
            self.reference = plan.end
            return
        assert drill.z_up is not None and drill.z_dn is not None and drill.feed_z is not None
        units = drill.units
        z_up, z_dn = to_nm(drill.z_up, units), to_nm(drill.z_dn, units)
        feed_z = to_nm(drill.feed_z, units)
        self.retract = retract_height(z_up, self.z_retract)
        self.position(number, plunge, self.retract)
        self.rapid_z(number, z_up)
        levels = peck_levels(z_up, z_dn + plan.rough_allowance, drill.pecks)
        first = plan.passes[0]
        for k, level in enumerate(levels):
            final = k == len(levels) - 1
            self.feed_to(number, (self.x, self.y, level), feed_z)
            self.cut(first, depth_cap=None if final else level, feed_z=feed_z)
            if not final:
                self.retract_up(number)
                self.rapid_xy(number, plunge)
                self.rapid_z(number, level, tag="peck-reentry")
        for path in plan.passes[1:]:
            # The finishing pass of a 2P routine: over to its plunge point, down to Z DN.
            finish_start = _round(path.start)
            self.feed_to(
                last, (finish_start[0], finish_start[1], self.z), self.feed_of(last), "step-over"
            )
            self.feed_to(number, (self.x, self.y, z_dn), feed_z)
            self.cut(path, depth_cap=None, feed_z=feed_z)
        self.retract_up(last)
        self.reference = plan.end

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
            end = _round(element.end)
            if element.centre is None:
                self.feed_to(element.block, (end[0], end[1], self.z), feed, element.tag)
            else:
                self.arc_to(
                    element.block, end, _round(element.centre), element.clockwise, feed, element.tag
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
            self.moves.append(
                ProgramStop(number, f"quill: {block.op.value} the hole by hand, then raise it")
            )
            return
        assert block.z_up is not None and block.z_dn is not None and block.feed_z is not None
        units = block.units
        z_up, z_dn = to_nm(block.z_up, units), to_nm(block.z_dn, units)
        feed = to_nm(block.feed_z, units)
        self.retract = retract_height(z_up, self.z_retract)
        self.position(number, target, self.retract)
        self.rapid_z(number, z_up)
        if block.op is HoleOp.DRILL:
            levels = peck_levels(z_up, z_dn, block.pecks)
            for k, level in enumerate(levels):
                self.feed_to(number, (self.x, self.y, level), feed)
                if k < len(levels) - 1:
                    self.rapid_z(number, z_up, tag="peck-retract")
                    self.rapid_z(number, level, tag="peck-reentry")
            self.moves.append(Dwell(number, limits.HOLE_DWELL_SECONDS))
        elif block.op is HoleOp.BORE:
            self.feed_to(number, (self.x, self.y, z_dn), feed)
            self.moves.append(Dwell(number, limits.HOLE_DWELL_SECONDS))
            self.feed_to(number, (self.x, self.y, z_up), feed)
        else:
            self.feed_to(number, (self.x, self.y, z_dn), feed)
            self.tap_out(number, block, z_up, feed)
        self.retract_up(number)

    def tap_out(self, number: int, block: Hole, z_up: int, feed: int) -> None:
        """Reverse the spindle, feed up to 0.3 in above Z UP, restore the direction."""
        clockwise, rpm = self.spindle(block.tool)
        self.moves.append(SpindleOn(number, clockwise=not clockwise, rpm=rpm))
        lift = limits.TAP_FEED_OUT_INCH if block.units is Units.INCH else limits.TAP_FEED_OUT_MM
        self.feed_to(number, (self.x, self.y, z_up + to_nm(lift, block.units)), feed)
        self.moves.append(SpindleOn(number, clockwise=clockwise, rpm=rpm))

    def program_stop(self, number: int) -> None:
        """STOP: the head retracts and the spindle shuts off (seed 001 §3.4.5.3)."""
        self.retract_up(number)
        self.set_coolant(number, "off")
        if self.spindle_on:
            self.moves.append(SpindleOff(number))
            self.spindle_on = False
        self.moves.append(ProgramStop(number, "STOP"))

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
                self.moves.append(SpindleOff(number))
                self.spindle_on = False
            self.z += self.tcal(self.tool) - self.tcal(tool)
            self.moves.append(ToolChange(number, tool, self.z))
            self.tool = tool
        if not self.spindle_on:
            clockwise, rpm = self.spindle(tool)
            self.moves.append(SpindleOn(number, clockwise=clockwise, rpm=rpm))
            self.spindle_on = True
        info = self.tools.get(tool)
        self.set_coolant(number, "off" if info is None else info.coolant)

    def set_coolant(self, number: int, mode: str) -> None:
        """Switch the coolant to `mode` (off, flood, mist) if it is not that already."""
        if mode == self.coolant:
            return
        if self.coolant != "off":
            self.moves.append(CoolantOff(number))
        if mode != "off":
            self.moves.append(CoolantOn(number, mode))
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

    # -- motion primitives (each skips a move that goes nowhere) -------------------------

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
            self.moves.append(Rapid(number, self.x, self.y, self.z))

    def rapid_z(self, number: int, z: int, tag: str = "") -> None:
        if z != self.z:
            self.z = z
            self.moves.append(Rapid(number, self.x, self.y, z, tag))

    def feed_to(self, number: int, end: tuple[int, int, int], feed: int, tag: str = "") -> None:
        if end != (self.x, self.y, self.z):
            self.x, self.y, self.z = end
            self.moves.append(Feed(number, *end, feed, tag))

    def arc_to(
        self,
        number: int,
        end: tuple[int, int],
        centre: tuple[int, int],
        clockwise: bool,
        feed: int,
        tag: str = "",
    ) -> None:
        self.moves.append(
            ArcFeed(number, end[0], end[1], self.z, centre[0], centre[1], clockwise, feed, tag)
        )
        self.x, self.y = end


def _round(point: tuple[float, float]) -> tuple[int, int]:
    """A computed point rounded once to the nanometre."""
    return round(point[0]), round(point[1])
