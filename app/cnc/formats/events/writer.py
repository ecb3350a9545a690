"""ProtoTRAK Plus events: the program as G100-G109 events for the Plus's RS-232 port.

Seed 003 §1 and §2.2 (the ProtoTRAK Plus CAD/CAM Interface Manual) are the source. The
events format is DESIGN.md §1's one structural exception: it mirrors the data blocks (a
bolt circle is one G104, a frame one G106/G107) instead of the tool path, and is then
checked against the tool path (`check_events`): every XY point an event puts the tool at
must be where the tool path goes at that block, and back.

The file (§2.2.3-§2.2.5): `%`, a label line `PN<part number> G20;` (G21 in mm), one event per
line `N001 G10x <words>;`, `%`. Words follow the order of the §2.2.5 listing. Readings we
chose where the manual is vague (docs/readings.md):

- Numbers (§2.2.4): a number without a decimal point has implied decimals there
  (`+1234` = 0.1234 in, `F1` = 0.1 ipm), so every non-zero dimension, radius, conrad,
  finish cut and angle carries a point; trailing zeros are dropped but one decimal is kept,
  and zero is `0`, as in the listings (`X1.2A`, `XC1.0A`, `YB0A`, `CR0`). Inch lengths to
  0.0001 in, mm to 0.01 mm, rounded half-even; angles to 0.001°; inch feeds with one
  decimal (`F8.0`), mm feeds whole mm/min (`F250`). T two digits, HL two, FE/LE three, RE
  two, N three (`T01 HL05 FE001 RE02 N001`), as in §2.2.5.
- Coordinates are written absolute with the A tag (§2.2.4), never incremental, so no event
  depends on where the control thinks the previous one ended; XO/YO of a repeat are
  offsets and carry no tag (§2.2.5 N006).
- The Plus has no Z (§2.1 "a 2-axis control") and no hole event (§2.2.1 lists Position,
  Mill, Arc, Bolthole, Repeat, Pocket and Frame): a DRILL/BORE/TAP hole is a G100 position
  where the operator works the quill by hand. Depths, pecks, dwell, the tap's reversal,
  retract height, spindle speeds, STOP and INDEX are reported as not carried.
- CR (conrad) on a mill or arc event is the corner radius into the next event (§2.2.6.3:
  CR0.841 is the fillet between N005 and N006). MillBlocks contours have sharp corners, so
  CR0 within a mill sequence; `CR-` (not connected, as the Plus itself writes it in
  §2.2.6.3) on its last event and before a block whose Z DN changes (§2.2.4: the Plus uses
  the Z information to decide if movements are connected). A full-circle arc is written as
  two half-circle events.
- TC 0/1/2 = tool centre/right/left of the travel (§2.2.4). DR 1 = clockwise, 2 =
  counter-clockwise: §2.2.6.3's circular pocket is `DR2 TC2` and the same part's G-code
  (§2.2.6.1) cuts it with G03. Circle and frame routines get DR from climb/conventional and
  the spindle direction as app/cnc/routines.py decides, and TC from inside/outside for that
  direction; FC is the 2P finishing allowance (0.010 in, 0.25 mm) or 0. On G106/G107 CR is
  the frame's corner radius (circles have none, §2.2.5 N009-N010).
- G104's angle A is measured counter-clockwise from +X and the holes go counter-clockwise
  (§2.2.6.1: `A45.0` drills X0.7955 Y0.7955 first, then X-0.5107 Y1.0024): A = 270° − θ0 for
  a BOLT CIR whose first hole is at θ0 (DESIGN.md §3), the same first hole, the others in
  reverse order.
- G105 repeats events FE…LE RE more times, the k-th time shifted by k·(XO, YO) (a linear
  series), with the T and D of the repeated events (§2.2.5 N006). A one-row LOOP/REP is one
  G105. A grid writes each row as its events and a G105; a repeat is never repeated (nested
  LOOP/REP expands the outer ones), nor one whose events use several tools or reach past
  event 255 (the FE/LE range, §2.2.4): those patterns are written out, and reported.
- Line ends are CR LF (the manual sends a DOS file with `COPY 1.CNC COM1`, §3.2); option
  `line_end=lf` writes LF.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from decimal import Decimal
from typing import Any

import numpy as np
import numpy.typing as npt

from app.cnc.blocks import (
    Block,
    BoltCircle,
    Circle,
    Comp,
    DataBlock0,
    Engrave,
    Face,
    Frame,
    Helix,
    Hole,
    MillArc,
    MillLine,
    MillQcir,
    Placement,
    Pocket,
    Pos,
    Program,
    Rep,
    ThreadMill,
)
from app.cnc.formats.events.model import (
    FEED_RANGE_NM,
    MAX_DIMENSION_NM,
    MAX_EVENT_REFERENCE,
    MAX_LINE_NUMBER,
    RESOLUTION_NM,
    TOOL_CENTRE,
    TOOL_LEFT,
    TOOL_RIGHT,
    WORDS,
    XY,
    Bolthole,
    Event,
    Mill,
    Position,
    Pt,
    Repeat,
    Routine,
    format_angle,
    format_dimension,
    format_feed,
    plus_angle,
    plus_holes,
    written,
)
from app.cnc.formats.targets import Option, OptionKind, Out, Report, Target, register
from app.cnc.geometry import bolt_circle_points, resolve_xy
from app.cnc.motions import motions
from app.cnc.path import CompiledPath, MillSpan, Op, placed_mills
from app.cnc.plane import Element, Path, sweep
from app.cnc.pocketing.model import LinkKind
from app.cnc.problems import Rule
from app.cnc.routines import INSIDE_PLACEMENTS, clearance, pocket_overlap, rough_depth, rough_wall
from app.cnc.solve import CONRAD
from app.cnc.structure import BoltPattern, LoopPattern, MillSequence, Node, Single, build_nodes
from app.cnc.units import Units, to_nm

TC = {Comp.NONE: TOOL_CENTRE, Comp.RIGHT: TOOL_RIGHT, Comp.LEFT: TOOL_LEFT}
Check = tuple[int, Pt]  # a block number and an XY point (nm) the tool is at for it


@dataclass
class Events:
    """A program's events, with what the self-check needs.

    `checks[i]` lists the XY points (nm, as written) event i + 1 puts the tool at, each with
    the block whose tool path must go there. `unchecked` holds blocks whose motion the Plus
    computes itself (compensated contours, circle and frame routines) and blocks refused
    (their error says why; the self-check adds none).
    """

    units: Units
    part_number: str
    events: list[Event] = field(default_factory=list)
    checks: list[tuple[Check, ...]] = field(default_factory=list)
    unchecked: set[int] = field(default_factory=set)


# -- circle and frame routines ---------------------------------------------------------------


def routine_comp(placement: Placement, clockwise: bool) -> int:
    """TC for a routine: inside a clockwise path is to the right of the travel."""
    inside = placement in INSIDE_PLACEMENTS
    return TOOL_RIGHT if inside == clockwise else TOOL_LEFT


# -- from blocks to events -------------------------------------------------------------------


def build_events(program: Program, path: CompiledPath, report: Report) -> Events:
    """The events of a validated program (COPY blocks carried out), reporting what is lost.

    The events mirror the blocks, but every mill sequence is read from the compiled path
    (its programmed contour, routine, pocket passes and the problems its plan found), as
    the compile planned it where it is cut: nothing is planned again here."""
    builder = _Builder(program, path, report)
    builder.run_nodes(build_nodes(program.blocks))
    builder.report_program()
    return builder.result


class _Builder:
    def __init__(self, program: Program, path: CompiledPath, report: Report) -> None:
        self.program = program
        self.blocks = program.blocks
        self.block0: DataBlock0 = program.block0
        self.units = program.units
        self.path = path
        self.report = report
        self.result = Events(program.units, program.part_number)
        self.reference: XY = (0, 0)
        # Every mill sequence as compiled, by its DRILL block and where it is cut.
        self.mills = {(m.drill, m.x, m.y): m for m in placed_mills(path.root)}

    @property
    def events(self) -> list[Event]:
        return self.result.events

    def add(self, event: Event, checks: Sequence[Check] = ()) -> None:
        self.result.events.append(event)
        self.result.checks.append(tuple(checks))

    def point(self, p: XY) -> Pt:
        """A point as the file carries it (rounded to the Plus's resolution), for checks."""
        return (float(written(p[0], self.units)), float(written(p[1], self.units)))

    def diameter(self, tool: int) -> int | None:
        info = self.path.tools.get(tool)
        return None if info is None else info.diameter

    def mill(self, node: MillSequence, start: XY) -> MillSpan:
        """The compiled mill sequence of `node` cut from `start`."""
        return self.mills[node.drill + 1, start[0], start[1]]

    def resolve(self, block: Block) -> XY:
        x: Decimal = getattr(block, "x")  # noqa: B009 - every positioned block has x and y
        y: Decimal = getattr(block, "y")  # noqa: B009
        return resolve_xy(x, y, block.mode, block.units, self.reference)

    # -- nodes ----------------------------------------------------------------------------

    def run_nodes(self, nodes: Sequence[Node]) -> None:
        for node in nodes:
            if isinstance(node, LoopPattern):
                self.run_loop(node)
            elif isinstance(node, Single):
                self.run_single(node.index)
            elif isinstance(node, BoltPattern):
                self.run_bolt_circle(node)
            else:
                self.run_mill_sequence(node)

    def run_single(self, index: int) -> None:
        block = self.blocks[index]
        number = index + 1
        if isinstance(block, Helix | ThreadMill | Face | Engrave):
            # The Plus has no Z (seed 003 §2.1) and no event for X, Y and Z moving together.
            why = (
                "its passes go down level by level"
                if isinstance(block, Face)
                else "its strokes go down one by one"
                if isinstance(block, Engrave)
                else "a helix moves Z with X and Y"
            )
            self.report.error(
                number,
                f"{block.title} is not written: {why}, and the Plus is a 2-axis control whose "
                "events have no Z (seed 003 §2.1); use a G-code target",
            )
            # Refused, said once: the self-check has no event to compare it with.
            self.result.unchecked.add(number)
            self.reference = self.resolve(block)
            return
        assert isinstance(block, Pos | Hole)
        target = self.resolve(block)
        self.add(Position(number, target, block.tool), [(number, self.point(target))])
        if isinstance(block, Hole):
            self.report_hole(
                number,
                block,
                f"written as a G100 position event; the operator {_verb(block)} the hole by "
                "hand (the Plus has no hole event, seed 003 §2.2.1)",
            )
        self.reference = target

    def run_bolt_circle(self, node: BoltPattern) -> None:
        centre_block = self.blocks[node.centre]
        bolt = self.blocks[node.bolt]
        assert isinstance(centre_block, Hole) and isinstance(bolt, BoltCircle)
        number = node.bolt + 1
        centre = self.resolve(centre_block)
        radius = to_nm(bolt.radius, bolt.units)
        angle = plus_angle(bolt.angle)
        event = Bolthole(number, centre, bolt.holes, radius, angle, centre_block.tool)
        holes = plus_holes(
            self.point(centre), float(written(radius, self.units)), bolt.holes, angle
        )
        self.add(event, [(number, hole) for hole in holes])
        self.report_hole(
            node.centre + 1,
            centre_block,
            f"the operator {_verb(centre_block)} each hole of the G104 bolt circle by hand",
        )
        if bolt.holes > 2:
            self.report.rewritten(
                number,
                f"angle {bolt.angle}° (clockwise from below) is A{format_angle(angle)} "
                "(counter-clockwise from +X): the Plus takes the same first hole, then the "
                f"other {bolt.holes - 1} counter-clockwise, the reverse of MillBlocks' order",
            )
        self.reference = bolt_circle_points(centre, radius, bolt.holes, bolt.angle)[-1]

    def run_mill_sequence(self, node: MillSequence) -> None:
        drill = self.blocks[node.drill]
        assert isinstance(drill, Hole)
        start = self.resolve(drill)
        self.report_hole(node.drill + 1, drill, "the operator lowers the quill to depth by hand")
        first = self.blocks[node.mills[0]]
        if isinstance(first, Circle | Frame | Pocket) and first.entry is not None:
            # A ramp goes down along X and Y; the operator lowers a Plus's quill by hand.
            self.report.error(
                node.mills[0] + 1,
                f"{first.type_name} with ENTRY {first.entry.name} is not written: a ramp moves "
                "Z with X and Y, and the Plus is a 2-axis control whose events have no Z "
                "(seed 003 §2.1); use a G-code target, or ENTRY empty (PLUNGE)",
            )
            self.result.unchecked.update([node.drill + 1, *(i + 1 for i in node.mills)])
            self.reference = start
        elif isinstance(first, Circle | Frame):
            self.routine(node, drill, first, start)
            self.reference = start
        elif isinstance(first, Pocket):
            self.pocket(node, drill, first, start)
            self.reference = start
        else:
            self.contour(node, drill, start)

    def run_loop(self, node: LoopPattern) -> None:
        """LOOP…REP: G105 repeats where a linear series is exact, written out elsewhere."""
        rep = self.blocks[node.rep]
        assert isinstance(rep, Rep)
        number = node.rep + 1
        step = (to_nm(rep.x, rep.units), to_nm(rep.y, rep.units))
        start = self.reference
        # Rows of patterns: (offset of the row's first pattern, step along it, repeats).
        if rep.nx == 0 and rep.ny > 0:
            rows = [((0, 0), (0, step[1]), rep.ny)]
        else:
            rows = [((0, j * step[1]), (step[0], 0), rep.nx) for j in range(rep.ny + 1)]
        if rep.nx == rep.ny == 0:
            self.report.note(number, "NX 0, NY 0: the pattern runs once; no G105")
        end: XY | None = None
        for (ox, oy), (sx, sy), repeats in rows:
            self.reference = (start[0] + ox, start[1] + oy)
            first = len(self.events)
            self.run_nodes(node.body)
            if end is None:
                end = self.reference
            if repeats == 0:
                continue
            body = self.events[first:]
            reason = self.not_repeatable(body, first + 1, (sx, sy), repeats)
            if reason is None:
                tool = _tools(body).pop()
                last = len(self.events)
                diameter = self.diameter(tool)
                self.add(Repeat(number, first + 1, last, (sx, sy), repeats, tool, diameter))
                if rep.nx and rep.ny:
                    self.report.rewritten(
                        number,
                        f"NX {rep.nx} × NY {rep.ny} grid: the Plus's G105 repeats along one "
                        f"line, so each of the {rep.ny + 1} rows is written out with a G105 "
                        "along X",
                    )
                continue
            repeated = "its repeat is" if repeats == 1 else f"its {repeats} repeats are"
            self.report.rewritten(number, f"{reason}, so {repeated} written out as events")
            for k in range(1, repeats + 1):
                self.reference = (start[0] + ox + k * sx, start[1] + oy + k * sy)
                self.run_nodes(node.body)
        assert end is not None
        self.reference = (
            end[0] + rep.nx * step[0],
            end[1] + rep.ny * step[1],
        )

    def not_repeatable(
        self, body: Sequence[Event], first: int, step: XY, repeats: int
    ) -> str | None:
        """Why events `first`… cannot be one G105 repeating `repeats` times by `step` (nm)
        (None when they can)."""
        resolution = RESOLUTION_NM[self.units]
        if repeats > 1 and (step[0] % resolution or step[1] % resolution):
            return (
                f"the step is not a whole number of the file's {_resolution_text(self.units)} "
                "(a millimetre REP in an inch program), and a G105 would add up its rounding"
            )
        if any(isinstance(event, Repeat) for event in body):
            return "the pattern holds a G105 (nested LOOP/REP) and a repeat is not repeated"
        tools = _tools(body)
        if len(tools) > 1:
            listed = " and ".join(str(t) for t in sorted(tools))
            return f"the pattern uses tools {listed} and a G105 has one T"
        if first + len(body) - 1 > MAX_EVENT_REFERENCE:
            return f"FE/LE cannot refer to events above {MAX_EVENT_REFERENCE} (seed 003 §2.2.4)"
        return None

    # -- mill sequences ---------------------------------------------------------------------

    def contour(self, node: MillSequence, drill: Hole, start: XY) -> None:
        """Line, quarter-circle and arc blocks: one G101/G102/G103 per element."""
        drill_number = node.drill + 1
        mill = self.mill(node, start)
        path = mill.contour()
        assert path is not None  # a contour's span has one
        tool = drill.tool
        diameter = self.diameter(tool)
        checked = drill.comp is Comp.NONE
        if not checked:
            self.report_compensation(node, drill, mill, diameter)
        depth = mill.depth
        events: list[Mill] = []
        checks: list[list[Check]] = []
        current = start
        for k, element in enumerate(path.elements):
            block = self.blocks[element.block - 1]
            assert isinstance(block, MillLine | MillQcir | MillArc)
            if element.tag == CONRAD and self.conrad_written(path, k, events, checks, depth):
                assert element.corner is not None
                current = _round(element.corner)
                continue
            target = _round(element.end)
            if drill.has_depth and element.z_dn is not None and element.z_dn != depth:
                depth = element.z_dn
                if events:
                    events[-1] = replace(events[-1], conrad=None)
                pieces = (
                    "; the Plus compensates each piece on its own, so the corner here is cut "
                    "differently"
                    if drill.comp is not Comp.NONE
                    else ""
                )
                self.report.unsupported(
                    element.block,
                    f"Z DN {block.z_dn}: the depth changes here; the event before "
                    f"ends not connected (CR-) and the operator moves the quill by hand{pieces}",
                )
            if element.centre is None and target == current:
                self.report.note(element.block, "no XY move: no event")
                continue
            feed = self.feed(element.block, block)
            centre = None if element.centre is None else _round(element.centre)
            ends = _arc_ends(current, target, centre)
            halves = [(end, k == len(ends) - 1) for k, end in enumerate(ends)]
            if len(ends) == 2:
                self.report.rewritten(
                    element.block, "a full-circle arc is written as two half-circle events"
                )
            for half_end, is_end in halves:
                event = Mill(
                    source=element.block,
                    begin=current,
                    end=half_end,
                    centre=centre,
                    clockwise=element.clockwise,
                    comp=TC[drill.comp],
                    feed=feed,
                    diameter=diameter,
                    conrad=0,
                    tool=tool,
                )
                event_checks: list[Check] = []
                if checked and not events:
                    event_checks.append((drill_number, self.point(current)))
                if checked and is_end:
                    event_checks.append((element.block, self.point(half_end)))
                events.append(event)
                checks.append(event_checks)
                current = half_end
        if not events:
            self.add(Position(drill_number, start, tool), [(drill_number, self.point(start))])
            self.report.note(drill_number, "the mill blocks move nowhere: a G100 position only")
        else:
            events[-1] = replace(events[-1], conrad=None)
        for event, event_checks in zip(events, checks, strict=True):
            self.add(event, event_checks)
        if not checked:
            self.result.unchecked.update([drill_number, *(i + 1 for i in node.mills)])
        self.reference = mill.exit()

    def conrad_written(
        self,
        path: Path,
        k: int,
        events: list[Mill],
        checks: list[list[Check]],
        depth: int | None,
    ) -> bool:
        """Write the conrad element `k` of a contour as the CR of the event before it (seed
        003 §2.2.4: the corner radius into the next event), that event ending at the sharp
        corner: True when done. The Plus cannot where there is no event before it or the
        depth changes after it (the event ends not connected): the arc is written as an
        event then."""
        element = path.elements[k]
        nxt = path.elements[k + 1] if k + 1 < len(path.elements) else None
        if not events or element.corner is None or nxt is None:
            return False
        if nxt.z_dn is not None and nxt.z_dn != depth:
            return False
        block = self.blocks[element.block - 1]
        holder = self.blocks[element.block] if isinstance(block, MillArc) else block
        radius: Decimal | None = getattr(holder, "conrad", None)
        if radius is None:
            return False
        corner = _round(element.corner)
        conrad = to_nm(radius, holder.units)
        events[-1] = replace(events[-1], end=corner, conrad=conrad)
        # The tool path goes round the corner, not through it: no check at the corner.
        checks[-1] = [c for c in checks[-1] if c[0] != element.block]
        self.report.rewritten(
            element.block,
            f"CONRAD {radius}: written as CR{format_dimension(conrad, self.units)} on the "
            "event into the corner (the Plus rounds it)",
        )
        return True

    def pocket(self, node: MillSequence, drill: Hole, block: Pocket, start: XY) -> None:
        """POCKET → its passes as explicit G101/G102/G103 events on the tool centre (TC0):
        the Plus has no irregular pocket. A G100 position comes first and wherever the tool
        retracts between passes (the operator raises and lowers the quill there)."""
        number = node.mills[0] + 1
        pocket = self.mill(node, start).pocket()
        blocks = [node.drill + 1, *(i + 1 for i in node.mills)]
        self.result.unchecked.update(blocks)
        if pocket is None:
            return  # not cut: validation says why
        tool = drill.tool
        diameter = self.diameter(tool)
        feed = self.feed(number, block)
        events: list[Event] = []
        current: XY | None = None
        plunges = 0
        for cut in pocket.passes:
            link = cut.entry
            if current is None or link.kind in (LinkKind.PLUNGE, LinkKind.RETRACT):
                if events and isinstance(events[-1], Mill):
                    events[-1] = replace(events[-1], conrad=None)
                current = _on_grid(link.path.start, self.units.resolution_nm)
                events.append(Position(number, current, tool))
                plunges += 1
            at = link.path.start
            for element in (*link.path.elements, *cut.path.elements):
                current = self.pocket_element(
                    events, number, current, at, element, feed, diameter, tool
                )
                at = element.end
        if events and isinstance(events[-1], Mill):
            events[-1] = replace(events[-1], conrad=None)
        for event in events:
            self.add(event)
        self.report.rewritten(
            number,
            f"POCKET: the Plus has no irregular pocket; its {len(pocket.passes)} passes are "
            f"written as {sum(isinstance(e, Mill) for e in events)} mill events on the tool "
            f"centre (TC0) at one depth, with a G100 where the quill goes down "
            f"({plunges} {'place' if plunges == 1 else 'places'})",
        )

    def pocket_element(
        self,
        events: list[Event],
        number: int,
        current: XY,
        at: Pt,
        element: Element,
        feed: int,
        diameter: int | None,
        tool: int,
    ) -> XY:
        """One element of a pocket pass as mill events (a full circle as two halves, an
        element that goes nowhere as none); the point it ends at.

        Points are written at the programming resolution (0.001 in, 0.01 mm), which is what
        the Plus's blocks hold and what reads back: an arc's end is the point of that grid
        next to the true end whose radius matches the start's within half a step, so the
        arc is cut as written, without a divot (`mill.true_arc`).
        """
        step = self.units.resolution_nm
        target = _on_grid(element.end, step)
        centre = None if element.centre is None else _on_grid(element.centre, step)
        if target == current and (centre is None or abs(sweep(at, element)) < math.pi):
            return current  # shorter than the grid's step: nothing to write
        if centre is not None and target != current:
            target = _on_radius(current, target, centre, step)
        for end in _arc_ends(current, target, centre):
            events.append(
                Mill(
                    number,
                    current,
                    end,
                    centre,
                    element.clockwise,
                    TOOL_CENTRE,
                    feed,
                    diameter,
                    0,
                    tool,
                )
            )
            current = end
        return current

    def report_compensation(
        self, node: MillSequence, drill: Hole, mill: MillSpan, diameter: int | None
    ) -> None:
        number = node.drill + 1
        side = "right" if drill.comp is Comp.RIGHT else "left"
        dia = "" if diameter is None else f" and D{format_dimension(diameter, self.units)}"
        self.report.note(
            number,
            f"cutter compensation {side}: the finished contour is written with "
            f"TC{TC[drill.comp]}{dia}; the Plus computes the tool's offset path itself",
        )
        for finding in mill.findings():
            if finding.rule is Rule.COMP_DIVOT:
                self.report.warning(
                    finding.block,
                    "inside corner with an arc: the Plus compensates one event ahead and "
                    "leaves a divot here, where MillBlocks' tool path is trimmed",
                )

    def routine(self, node: MillSequence, drill: Hole, block: Circle | Frame, start: XY) -> None:
        """CIRCLE → G108 pocket / G109 frame; FRAME → G106 pocket / G107 frame."""
        number = node.mills[0] + 1
        shape = self.mill(node, start).shape()
        assert shape is not None  # a routine's span has one
        clockwise = shape.clockwise
        pocket = block.placement is Placement.POCKET
        finish = rough_wall(block.units) if block.two_pass else 0
        common: dict[str, Any] = {
            "source": number,
            "pocket": pocket,
            "point": start,
            "clockwise": clockwise,
            "comp": routine_comp(block.placement, clockwise),
            "finish": finish,
            "feed": self.feed(number, block),
            "diameter": self.diameter(drill.tool),
            "tool": drill.tool,
        }
        if not shape.is_frame:
            event = Routine(rectangular=False, diagonal=None, radius=shape.radius, **common)
            name = "G108 circular pocket" if pocket else "G109 circular frame"
        else:
            diagonal = (start[0] + shape.width, start[1] + shape.height)
            radius = shape.corner_radius
            event = Routine(rectangular=True, diagonal=diagonal, radius=radius, **common)
            name = "G106 rectangular pocket" if pocket else "G107 rectangular frame"
        self.add(event)
        self.result.unchecked.update([node.drill + 1, number])
        u = block.units

        def size(nm: int) -> str:
            return f"{format_dimension(nm, u)} {u.symbol}"

        if block.placement in (Placement.INSIDE, Placement.OUTSIDE):
            entry = f"the plunge {size(clearance(u))} off the wall and the feed straight in"
        elif block.placement is Placement.POCKET:
            entry = f"the tangent entry and passes overlapping {size(pocket_overlap(u))}"
        else:
            entry = "the tangent quarter-arc entry and exit"
        self.report.rewritten(
            number,
            f"{block.type_name} is a {name}: the Plus cuts it with its own entry and "
            f"passes, not MillBlocks' ({entry})",
        )
        if block.two_pass and drill.has_depth:
            self.report.unsupported(
                number,
                f"2P: the roughing depth {size(rough_depth(u))} above Z DN is not carried "
                "(no Z); the Plus finishes with FC at the depth the operator sets",
            )

    def feed(self, number: int, block: Block) -> int:
        """A block's FEEDR XY in nm/min, limited to the Plus's range (reported)."""
        typed: Decimal = getattr(block, "feed_xy")  # noqa: B009 - mill blocks have one
        feed = to_nm(typed, block.units)
        low, high = FEED_RANGE_NM[self.units]
        if not low <= feed <= high:
            limited = min(max(feed, low), high)
            self.report.warning(
                number,
                f"FEEDR XY {typed} {block.units.feed_symbol} is outside the Plus's range "
                f"(seed 003 §2.2.4); written as F{format_feed(limited, self.units)}",
            )
            return limited
        return feed

    # -- what the Plus does not carry ---------------------------------------------------

    def report_hole(self, number: int, block: Hole, how: str) -> None:
        """A hole block's Z cycle: lost when it has depths, by hand either way."""
        if not block.has_depth:
            self.report.note(number, f"{block.type_name}: {how}")
            return
        cycle = f"Z UP {block.z_up}, Z DN {block.z_dn}, FEEDR Z {block.feed_z}"
        self.report.unsupported(
            number, f"{block.type_name} {cycle} not carried: the Plus has no Z; {how}"
        )
        if block.pecks > 1:
            self.report.unsupported(
                number, f"{block.pecks} pecks not carried: the operator pecks by hand"
            )

    def report_program(self) -> None:
        """Set-up data and block qualifiers the events have no place for."""
        db0 = self.block0
        if db0.x_offset or db0.y_offset:
            self.report.unsupported(
                0,
                f"part zero offset X {db0.x_offset} Y {db0.y_offset} not carried: the "
                "events are in part coordinates; set part zero on the Plus",
            )
        if any(isinstance(b, Hole) and b.has_depth for b in self.blocks):
            self.report.unsupported(0, f"Z RET {db0.z_retract} not carried: the Plus has no Z")
        used = _tools(self.events)
        tools = [t for n in sorted(used) if (t := db0.tool(n)) is not None]
        if any(t.rpm is not None for t in tools):
            self.report.unsupported(
                0, "spindle speeds (RPM) not carried: the Plus's spindle is set by hand"
            )
        if any(t.tcal is not None for t in tools):
            self.report.unsupported(0, "tool calibrations (TCAL) not carried: the Plus has no Z")
        for tool in tools:
            if tool.coolant.value != "off":
                self.report.unsupported(
                    0, f"tool {tool.number} coolant ({tool.coolant.value}) not carried: set by hand"
                )
        for number, block in enumerate(self.blocks, start=1):
            if block.message:
                self.report.unsupported(
                    number, f"message {block.message!r} not carried: events have no messages"
                )
            if block.stop:
                self.report.unsupported(number, "STOP not carried: the Plus has no stop event")
            if isinstance(block, Pos) and block.index:
                self.report.unsupported(
                    number, "INDEX not carried: the Plus has no rotary fixture signal"
                )
            if block.units is not self.units:
                self.report.rewritten(
                    number,
                    f"typed in {block.units.symbol}: written in {_unit_name(self.units)} to "
                    f"{format_dimension(RESOLUTION_NM[self.units], self.units)} "
                    f"{self.units.symbol} ({_g_units(self.units)} holds for the whole file)",
                )
        count = len(self.events)
        if count > MAX_LINE_NUMBER:
            self.report.error(
                None,
                f"{count} events: line numbers run to {MAX_LINE_NUMBER} (seed 003 §2.2.4)",
            )
        elif count > MAX_EVENT_REFERENCE:
            self.report.warning(
                None,
                f"{count} events: the Plus numbers events to {MAX_EVENT_REFERENCE} "
                "(seed 003 §2.2.4 FE/LE); it may not hold this program",
            )


def _verb(block: Hole) -> str:
    return {"DRILL": "drills", "BORE": "bores", "TAP": "taps"}[block.op.value]


def _tools(events: Sequence[Event]) -> set[int]:
    return {event.tool for event in events}


def _round(p: Pt) -> XY:
    return round(p[0]), round(p[1])


def _resolution_text(units: Units) -> str:
    return "0.0001 in" if units is Units.INCH else "0.01 mm"


def _unit_name(units: Units) -> str:
    return "inches" if units is Units.INCH else "millimetres"


def _g_units(units: Units) -> str:
    return "G20" if units is Units.INCH else "G21"


# -- the self-check ----------------------------------------------------------------------------


def check_events(events: Events, path: CompiledPath, report: Report) -> None:
    """Compare the events with the tool path; a difference is a report error.

    Every XY point the tool path moves to at a block must be one of the points the events
    put the tool at for that block (G105 repeats and G104 holes included, as the Plus
    computes them from the written numbers), and every such point must be a position of the
    tool path, both within the Plus's resolution (a written point is off by up to half of
    it; a G104 hole, which the Plus computes from a rounded centre and a rounded radius, by
    up to a whole step). The second test is not per block: a
    block that finds the tool already at its point has no move of its own. Blocks whose
    path the Plus computes itself (`events.unchecked`: compensated contours, routines) are
    skipped; circular pockets and frames must turn the way the tool path does.

    The tool path is read a chunk at a time and checked as it comes against the events'
    points (arrays): nothing of the path is kept, so memory does not grow with the moves.
    """
    units = events.units
    cell = RESOLUTION_NM[units]
    tolerance = cell + 1
    expected = _expected_points(events)
    anywhere = _Near(expected.points, cell)  # the events' points, whatever their block
    mine = _Near(expected.points, cell, expected.blocks)  # each block's own points
    moved_blocks: set[int] = set()
    extra: dict[int, Pt] = {}
    # Circular routines: the turns of arcs about their centre, by block.
    centres = {
        (event.source, event.point)
        for event in events.events
        if isinstance(event, Routine) and not event.rectangular
    }
    turns: dict[tuple[int, XY], set[bool]] = defaultdict(set)
    start = np.array([[path.start[0], path.start[1]]], dtype=np.float64)
    anywhere.mark(start, tolerance)
    for m in motions(path):
        rows = m.rows
        xy = np.column_stack((rows["x"], rows["y"])).astype(np.float64)
        anywhere.mark(np.unique(xy, axis=0), tolerance)
        moved = (rows["x"] != m.x0) | (rows["y"] != m.y0)
        blocks = rows["block"][moved]
        if not len(blocks):
            continue
        moved_blocks.update(np.unique(blocks).tolist())
        points = xy[moved]
        checked = ~np.isin(blocks, list(events.unchecked) + list(extra)) & np.isin(
            blocks, expected.known
        )
        if checked.any():
            near = mine.near(points[checked], tolerance, blocks[checked])
            for block, px, py in zip(
                blocks[checked][~near].tolist(),
                points[checked][~near, 0].tolist(),
                points[checked][~near, 1].tolist(),
                strict=True,
            ):
                extra.setdefault(block, (px, py))
        if centres:
            arcs = rows[rows["op"] >= Op.ARC_CW]
            for block, cx, cy, op in zip(
                arcs["block"].tolist(),
                arcs["cx"].tolist(),
                arcs["cy"].tolist(),
                arcs["op"].tolist(),
                strict=True,
            ):
                if (block, (cx, cy)) in centres:
                    turns[block, (cx, cy)].add(op == Op.ARC_CW)

    def where(p: Pt) -> str:
        px, py = format_dimension(round(p[0]), units), format_dimension(round(p[1]), units)
        return f"X{px} Y{py}"

    missing = ~anywhere.marked()
    for block in np.unique(expected.blocks).tolist():
        first = np.flatnonzero(missing & (expected.blocks == block))
        if len(first):
            x, y = expected.points[first[0]].tolist()
            report.error(
                block,
                f"self-check: the events put the tool at {where((x, y))}, where the tool "
                "path never goes",
            )
    known = set(expected.known.tolist())
    for block in sorted(moved_blocks):
        if block in events.unchecked:
            continue
        if block not in known:
            report.error(block, "self-check: the tool path moves here but no event does")
            continue
        if block in extra:
            report.error(
                block,
                f"self-check: the tool path goes to {where(extra[block])}, which no event reaches",
            )
    for event in events.events:
        if isinstance(event, Routine) and not event.rectangular:
            turn = turns.get((event.source, event.point), set())
            if turn and turn != {event.clockwise}:
                report.error(event.source, "self-check: DR turns the other way from the tool path")


@dataclass
class _Expected:
    """Every point the events put the tool at (`points`, k × 2, nm as floats, in the order
    the events make them) with its block (`blocks`); `known` the blocks that have any."""

    points: npt.NDArray[np.float64]
    blocks: npt.NDArray[np.int64]

    @property
    def known(self) -> npt.NDArray[np.int64]:
        return np.unique(self.blocks)


def _expected_points(events: Events) -> _Expected:
    """Every block's XY points by the events, G105 repeats carried out (as arrays: a repeat
    of a bolt circle is thousands of points)."""
    units = events.units
    xs: list[npt.NDArray[np.float64]] = []
    ys: list[npt.NDArray[np.float64]] = []
    blocks: list[npt.NDArray[np.int64]] = []

    def add(checks: Sequence[Check], dx: npt.NDArray[np.int64], dy: npt.NDArray[np.int64]) -> None:
        # Each shift (dx[k], dy[k]) in turn, every check of `checks` in order within it.
        if not checks or not len(dx):
            return
        cx = np.array([p[0] for _, p in checks], dtype=np.float64)
        cy = np.array([p[1] for _, p in checks], dtype=np.float64)
        xs.append((cx[None, :] + dx[:, None]).ravel())
        ys.append((cy[None, :] + dy[:, None]).ravel())
        blocks.append(np.tile(np.array([b for b, _ in checks], dtype=np.int64), len(dx)))

    none = np.zeros(1, dtype=np.int64)
    for event, checks in zip(events.events, events.checks, strict=True):
        add(checks, none, none)
        if isinstance(event, Repeat):
            ox, oy = written(event.offset[0], units), written(event.offset[1], units)
            k = np.arange(1, event.repeats + 1, dtype=np.int64)
            repeated = [c for n in range(event.first, event.last + 1) for c in events.checks[n - 1]]
            add(repeated, k * ox, k * oy)
    if not xs:
        return _Expected(np.zeros((0, 2)), np.zeros(0, dtype=np.int64))
    points = np.column_stack((np.concatenate(xs), np.concatenate(ys)))
    return _Expected(points, np.concatenate(blocks))


class _Near:
    """Points bucketed by cell (sorted cell keys, optionally with a block), to find for many
    query points at once whether one lies within a tolerance below the cell size: the
    neighbouring cells of each query are looked up with `searchsorted`.

    Each distinct point (of its block) is kept once: a query takes the points of a cell one
    pass at a time, as many passes as the fullest cell holds, and a program can put the
    tool at one place hundreds of times (DRILLs repeated there, a REP X0 Y0), which made
    every chunk of the path cost that many passes (600 DRILLs at one place took 7 s)."""

    SPAN = 1 << 20  # cells either side of zero a key can hold (±2.6 m at 2.54 µm)

    def __init__(
        self,
        points: npt.NDArray[np.float64],
        cell: int,
        blocks: npt.NDArray[np.int64] | None = None,
    ) -> None:
        self.cell = cell
        rows = points if blocks is None else np.column_stack((points, blocks))
        distinct, inverse = np.unique(rows.reshape(-1, rows.shape[1]), axis=0, return_inverse=True)
        self.inverse = inverse.reshape(-1)  # the distinct point of each point given
        self.points = np.ascontiguousarray(distinct[:, :2], dtype=np.float64)
        self.reached = np.zeros(len(distinct), dtype=bool)  # by `mark`, per distinct point
        keys = self.keys(self.points, None if blocks is None else distinct[:, 2].astype(np.int64))
        self.order = np.argsort(keys, kind="stable")
        self.sorted_keys = keys[self.order]
        # The most points in one key: how many candidates a query takes from each cell.
        edges = np.flatnonzero(np.diff(self.sorted_keys)) if len(keys) else keys
        bounds = np.concatenate(([0], edges + 1, [len(keys)]))
        self.most = int(np.diff(bounds).max()) if len(keys) else 0

    def cells(self, points: npt.NDArray[np.float64]) -> npt.NDArray[np.int64]:
        return np.floor(points / self.cell).astype(np.int64) + self.SPAN

    def keys(
        self, points: npt.NDArray[np.float64], blocks: npt.NDArray[np.int64] | None
    ) -> npt.NDArray[np.int64]:
        c = self.cells(points)
        keys = c[:, 0] * (2 * self.SPAN) + c[:, 1]
        if blocks is not None:
            keys = keys + blocks.astype(np.int64) * (2 * self.SPAN) ** 2
        return keys

    def _pairs(
        self,
        query: npt.NDArray[np.float64],
        tolerance: float,
        blocks: npt.NDArray[np.int64] | None,
    ) -> Iterator[tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]]:
        """(query index, point index) of every pair within `tolerance`, in batches."""
        if not len(query) or not len(self.points):
            return
        base = self.keys(query, blocks)
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                key = base + dx * (2 * self.SPAN) + dy
                lo = np.searchsorted(self.sorted_keys, key, side="left")
                hi = np.searchsorted(self.sorted_keys, key, side="right")
                for j in range(self.most):
                    which = np.flatnonzero(lo + j < hi)
                    if not len(which):
                        break
                    found = self.order[lo[which] + j]
                    close = np.all(np.abs(self.points[found] - query[which]) <= tolerance, axis=1)
                    yield which[close], found[close]

    def near(
        self,
        query: npt.NDArray[np.float64],
        tolerance: float,
        blocks: npt.NDArray[np.int64] | None = None,
    ) -> npt.NDArray[np.bool_]:
        """For each query point (of its block), whether a point lies within `tolerance`."""
        hit = np.zeros(len(query), dtype=bool)
        for which, _ in self._pairs(query, tolerance, blocks):
            hit[which] = True
        return hit

    def mark(self, query: npt.NDArray[np.float64], tolerance: float) -> None:
        """Mark every point within `tolerance` of a query point as reached (`marked`)."""
        for _, found in self._pairs(query, tolerance, None):
            self.reached[found] = True

    def marked(self) -> npt.NDArray[np.bool_]:
        """For each point given (in order), whether `mark` reached it."""
        return self.reached[self.inverse]


# -- text (§2.2.5) -----------------------------------------------------------------------------


def render(events: Events, line_end: str = "\r\n") -> str:
    """The event file: `%`, the label line, one line per event, `%`."""
    units = events.units
    part = events.part_number or "0"
    lines = ["%", f"PN{part} {_g_units(units)};"]
    for number, event in enumerate(events.events, start=1):
        lines.append(f"N{number:03d} " + " ".join(_words(event, units)) + ";")
    lines.append("%")
    return line_end.join(lines) + line_end


def _words(event: Event, units: Units) -> list[str]:
    """An event's words, in the order the model lists them (§2.2.5)."""

    def length(nm: int) -> str:
        return format_dimension(nm, units)

    def axis(nm: int) -> str:
        return f"{length(nm)}A"

    values: dict[str, str] = {"T": f"{event.tool:02d}"}
    if isinstance(event, Position):
        values |= {"X": axis(event.at[0]), "Y": axis(event.at[1])}
    elif isinstance(event, Mill):
        values |= {
            "XB": axis(event.begin[0]),
            "YB": axis(event.begin[1]),
            "XE": axis(event.end[0]),
            "YE": axis(event.end[1]),
            "TC": str(event.comp),
            "F": format_feed(event.feed, units),
            "CR": "-" if event.conrad is None else length(event.conrad),
        }
        if event.centre is not None:
            values |= {"XC": axis(event.centre[0]), "YC": axis(event.centre[1])}
    elif isinstance(event, Bolthole):
        values |= {
            "XC": axis(event.centre[0]),
            "YC": axis(event.centre[1]),
            "HL": f"{event.holes:02d}",
            "R": length(event.radius),
            "A": format_angle(event.angle),
        }
    elif isinstance(event, Repeat):
        values |= {
            "FE": f"{event.first:03d}",
            "LE": f"{event.last:03d}",
            "XO": length(event.offset[0]),
            "YO": length(event.offset[1]),
            "RE": f"{event.repeats:02d}",
        }
    else:
        values |= {
            "DR": "1" if event.clockwise else "2",
            "TC": str(event.comp),
            "FC": length(event.finish),
            "F": format_feed(event.feed, units),
        }
        if event.rectangular:
            assert event.diagonal is not None
            values |= {
                "XB": axis(event.point[0]),
                "YB": axis(event.point[1]),
                "XD": axis(event.diagonal[0]),
                "YD": axis(event.diagonal[1]),
                "CR": length(event.radius),
            }
        else:
            values |= {
                "XC": axis(event.point[0]),
                "YC": axis(event.point[1]),
                "R": length(event.radius),
            }
    if not isinstance(event, Position | Bolthole) and event.diameter is not None:
        values["D"] = length(event.diameter)
    return [f"G{event.code}"] + [
        f"{code}{values[code]}" for code in WORDS[event.code] if code in values
    ]


def check_ranges(events: Events, report: Report) -> None:
    """Dimensions beyond the Plus's ±99.9999 in / ±9999.99 mm (§2.2.4) are errors."""
    units = events.units
    limit = MAX_DIMENSION_NM[units]
    for event in events.events:
        values: list[int] = []
        if isinstance(event, Position):
            values = list(event.at)
        elif isinstance(event, Mill):
            values = [*event.begin, *event.end, *(event.centre or ())]
        elif isinstance(event, Bolthole):
            values = [*event.centre, event.radius]
        elif isinstance(event, Repeat):
            values = list(event.offset)
        else:
            values = [*event.point, *(event.diagonal or ()), event.radius]
        worst = max((abs(v) for v in values), default=0)
        if written(worst, units) > limit:
            report.error(
                event.source,
                f"{format_dimension(worst, units)} {units.symbol} is beyond the Plus's "
                f"±{format_dimension(limit, units)} {units.symbol} (seed 003 §2.2.4)",
            )


@register
class EventsTarget(Target):
    """ProtoTRAK Plus events G100-G109 over RS-232 (seed 003 §2.2)."""

    name = "events"
    label = "ProtoTRAK Plus (events over RS-232)"
    reads_back = "events"
    description = "ProtoTRAK Plus events G100-G109 (RS-232, seed 003 §2.2)"
    extension = "cnc"
    options = (
        Option(
            "line_end",
            OptionKind.CHOICE,
            "crlf",
            "end of line after each `;` block: crlf (a DOS file, as the manual sends) or lf",
            choices=("crlf", "lf"),
        ),
    )

    def write(
        self,
        program: Program,
        path: CompiledPath,
        options: Mapping[str, Any],
        report: Report,
        out: Out,
    ) -> None:
        events = build_events(program, path, report)
        check_ranges(events, report)
        check_events(events, path, report)
        line_end = "\r\n" if options.get("line_end", "crlf") == "crlf" else "\n"
        out.write(render(events, line_end).encode("ascii"))


def _arc_ends(current: XY, target: XY, centre: XY | None) -> list[XY]:
    """Where the events of a move from `current` end: `target`, or for a full circle (an
    arc that ends where it starts) two half circles, through the opposite point."""
    if centre is None or target != current:
        return [target]
    return [(2 * centre[0] - current[0], 2 * centre[1] - current[1]), target]


def _on_grid(p: Pt, step: int) -> XY:
    """A point (nm) on the grid of `step` nm."""
    return (round(p[0] / step) * step, round(p[1] / step) * step)


def _on_radius(start: XY, end: XY, centre: XY, step: int) -> XY:
    """`end`, or the nearest grid point around it whose distance from `centre` is within
    half a step of the start's (an arc the reader takes as typed); `end` when none is."""
    radius = math.dist(start, centre)
    if abs(math.dist(end, centre) - radius) <= step / 2:
        return end
    around = [
        (end[0] + i * step, end[1] + j * step) for i in (-1, 0, 1) for j in (-1, 0, 1) if i or j
    ]
    fits = [p for p in around if abs(math.dist(p, centre) - radius) <= step / 2]
    return min(fits, key=lambda p: (math.dist(p, end), p)) if fits else end
