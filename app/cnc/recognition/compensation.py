"""Cutter compensation (G41/G42) in imported G-code: the path the control cuts, and whether
MillBlocks' compensated contour cuts the same.

A G-code contour under G41/G42 is the part's outline; the control offsets the tool from
it by the tool radius. Its rules are RS274/NGC's as LinuxCNC's interpreter applies them
(`rs274`, src/emc/rs274ngc/interp_convert.cc: convert_straight_comp1/2,
convert_arc_comp1/2), which this module follows so that an import can be held to them:

- **Entry**: the first cut after G41/G42 starts from where the tool is, uncompensated. A
  line ends one tool radius to the side of its programmed end, square to the line from
  the tool to that end; an arc ends one radius from its programmed end along the radius,
  about a centre moved so that it still starts where the tool is. The cut must be longer
  than the tool radius.
- **Corners**: at a convex corner (a turn of more than 0.05 rad away from the
  compensation side) an arc of the tool radius about the programmed corner joins the two
  offset cuts; at a concave one the cut before ends where the next one's offset meets it;
  a turn of 0.05 rad or less is no corner: the next cut starts from where the last ended.
- **Exit**: after G40 the next cut goes from the compensated point to its programmed end.

MillBlocks compensates a contour itself (app/cnc/cutter.py `compensate`): it goes down one
tool radius to the side of the first cut and joins every corner, however small. Where
the two agree after the control's entry, the contour is read as compensated blocks
(DRILL … CUT LT/RT); where they do not, as the tool-centre path the control cuts.

Lengths are nm; points of the tool-centre path are floats (rounded once, in the builder).
Pure core: no web, database or serial code.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from app.cnc.blocks import Comp, DataBlock0, HoleOp, Tool
from app.cnc.plane import Path, close
from app.cnc.recognition.build import Builder
from app.cnc.recognition.common import XY, ImportFailure, Notes, decimal_of, quantize_nm, show
from app.cnc.recognition.ops import Element, HoleSpec, MillOp
from app.cnc.sequences import plan_sequence
from app.cnc.units import Units

Pt = tuple[float, float]

# LinuxCNC's TOLERANCE_CONCAVE_CORNER (radians): a turn up to this is no corner.
SMALL_TURN = 0.05
# How far apart (nm) the control's path and MillBlocks' (of the blocks, rounded) may be for
# the contour to be read as compensated blocks: the programming resolution.
AGREE = {Units.INCH: 25_400, Units.MM: 10_000}
TAU = 2 * math.pi
HALF = math.pi / 2


class CompError(ValueError):
    """A compensated contour the control refuses; `line` is the cut at fault."""

    def __init__(self, line: int, message: str) -> None:
        super().__init__(message)
        self.line = line
        self.message = message


@dataclass(frozen=True)
class Cut:
    """A programmed cut (the file's): a line to `end`, or an arc about `centre`."""

    line: int
    end: XY
    centre: XY | None
    clockwise: bool


@dataclass(frozen=True)
class Piece:
    """A move of the tool centre: a line to `end`, or an arc about `centre`. `cut` is the
    index of the programmed cut it comes from; `corner` marks an arc the control adds round
    a convex corner (it belongs to the cut after the corner)."""

    cut: int
    end: Pt
    centre: Pt | None = None
    clockwise: bool = False
    corner: bool = False


def _f(p: XY) -> Pt:
    return (float(p[0]), float(p[1]))


def _angle(a: Pt, b: Pt) -> float:
    """The direction from `a` to `b` (radians)."""
    return math.atan2(b[1] - a[1], b[0] - a[0])


def _at(p: Pt, radius: float, angle: float) -> Pt:
    return (p[0] + radius * math.cos(angle), p[1] + radius * math.sin(angle))


def _sweep(start: Pt, end: Pt, centre: Pt, clockwise: bool) -> float:
    """How far an arc turns (radians, 0 < … ≤ 2π; a full circle when its ends meet)."""
    a0, a1 = _angle(centre, start), _angle(centre, end)
    turn = (a0 - a1) if clockwise else (a1 - a0)
    turn %= TAU
    return turn if turn > 1e-12 else TAU


def control_path(
    start: XY, cuts: list[Cut], left: bool, radius: float, units: Units
) -> list[Piece]:
    """The tool-centre path the control cuts for `cuts` (the first is the entry move) with
    compensation to the left (G41) or right (G42) and a tool of `radius` nm, starting from
    the uncompensated point `start`. Raises CompError where the control refuses it."""
    # How much further (radians) a trimmed arc may turn: LinuxCNC's figure per unit.
    slack = 0.001 if units is Units.INCH else 0.0254
    return _Control(_f(start), left, radius, slack).run(cuts)


@dataclass
class _Prev:
    """The last cut as the control queued it: a line (its direction) or an arc (its actual
    centre, radius and turn: +1 counter-clockwise, -1 clockwise)."""

    arc: bool
    centre: Pt = (0.0, 0.0)
    turn: int = 0


class _Control:
    def __init__(self, start: Pt, left: bool, radius: float, slack: float) -> None:
        self.slack = slack
        self.first_start = start
        self.current = start  # where the tool is (the untrimmed end of the last cut)
        self.programmed = start
        self.left = left
        self.r = radius
        self.pieces: list[Piece] = []
        self.queued = -1  # the piece a concave corner moves the end of (-1: none)
        # What the control checks a moved end against: a straight cut's direction as queued
        # (the entry's is square to it, as LinuxCNC queues it), an arc's programmed turn.
        self.direction: Pt = (0.0, 0.0)
        self.programmed_turn = 0.0
        self.prev = _Prev(arc=False)

    def inside(self, turn: int) -> bool:
        """LinuxCNC's TOOL_INSIDE_ARC: the tool is on the centre's side of the arc."""
        return (self.left and turn > 0) or (not self.left and turn < 0)

    def run(self, cuts: list[Cut]) -> list[Piece]:
        for k, cut in enumerate(cuts):
            if k == 0:
                self.entry(k, cut)
            elif cut.centre is None:
                self.line(k, cut)
            else:
                self.arc(k, cut)
        if cuts:
            # G40 (or whatever ends the contour) flushes the last cut, checked as a corner
            # would check it: a concave corner before may have moved its start past its end.
            self.move_end(self.current, cuts[-1].line)
        return self.pieces

    def start_of(self, index: int) -> Pt:
        return self.pieces[index - 1].end if index > 0 else self.first_start

    # -- the entry move ----------------------------------------------------------------------

    def entry(self, k: int, cut: Cut) -> None:
        c, p = self.current, _f(cut.end)
        if math.dist(c, p) <= self.r:
            what = "arc" if cut.centre is not None else "move"
            raise CompError(
                cut.line,
                f"the cutter compensation entry {what} is not longer than the tool radius",
            )
        if cut.centre is None:
            alpha = _angle(c, p) + (HALF if self.left else -HALF)
            end = _at(p, self.r, alpha)
            self.pieces.append(Piece(k, end))
            self.prev = _Prev(arc=False)
            self.direction = (math.cos(alpha), math.sin(alpha))
        else:
            centre = _f(cut.centre)
            turn = -1 if cut.clockwise else 1
            gamma = _angle(p, centre) if self.inside(turn) else _angle(centre, p)
            end = _at(p, self.r, gamma)
            # The centre moves along the radius so that the arc still starts at the tool.
            b_len = math.dist(c, end) / 2
            ab = _angle(end, centre)
            a = _angle(end, c) - ab
            if abs(math.cos(a)) < 1e-6:
                raise CompError(cut.line, "the tool radius is not less than the arc's radius")
            moved = _at(end, b_len / math.cos(a), ab)
            self.pieces.append(Piece(k, end, moved, cut.clockwise))
            self.prev = _Prev(arc=True, centre=moved, turn=turn)
            self.programmed_turn = _sweep(c, end, moved, cut.clockwise)
        self.queued = len(self.pieces) - 1
        self.current, self.programmed = end, p

    # -- corners ------------------------------------------------------------------------------

    def move_end(self, point: Pt, line: int) -> None:
        """A concave corner: the queued cut ends at `point` instead (the control's
        move_endpoint_and_flush), unless that turns a straight cut round, or makes an arc
        turn further than it was programmed to (gouges the control refuses)."""
        index = self.queued
        piece = self.pieces[index]
        start = self.start_of(index)
        if piece.centre is None:
            dx, dy = self.direction
            if dx * (point[0] - start[0]) + dy * (point[1] - start[1]) < 0:
                raise CompError(
                    line,
                    "a straight cut in a concave corner cannot be reached by the tool "
                    "without gouging",
                )
        elif self.programmed_turn:
            after = _sweep(start, point, piece.centre, piece.clockwise)
            if after > self.programmed_turn + self.slack:
                raise CompError(
                    line,
                    "an arc in a concave corner cannot be reached by the tool without gouging",
                )
        self.pieces[index] = Piece(piece.cut, point, piece.centre, piece.clockwise, piece.corner)

    def corner_arc(self, k: int, corner: Pt, to: Pt) -> None:
        self.pieces.append(Piece(k, to, corner, self.left, corner=True))

    # -- lines ----------------------------------------------------------------------------------

    def line(self, k: int, cut: Cut) -> None:
        c, op, p = self.current, self.programmed, _f(cut.end)
        theta = _angle(op, c)
        alpha = _angle(op, p)
        if self.left:
            if theta < alpha:
                theta += TAU
            beta = theta - alpha - HALF
            gamma = HALF
        else:
            if alpha < theta:
                alpha += TAU
            beta = alpha - theta - HALF
            gamma = -HALF
        end = _at(p, self.r, alpha + gamma)
        mid = _at(op, self.r, alpha + gamma)
        prev = self.prev
        concave = (
            beta < -SMALL_TURN
            or beta > math.pi + SMALL_TURN
            or (
                beta > math.pi - SMALL_TURN
                and prev.arc
                and ((not self.left and prev.turn > 0) or (self.left and prev.turn < 0))
            )
        )
        if not concave and beta > SMALL_TURN:
            # (The control checks the cut before against where it ends here too: a concave
            # corner before may have moved its start past its end.)
            self.move_end(c, cut.line)
            self.corner_arc(k, op, mid)
        elif concave:
            if not prev.arc:
                half = (beta + math.pi) / 2
                if half == 0:
                    raise CompError(cut.line, "a zero-degree inside corner")
                self.move_end(_at(c, self.r / math.tan(half), theta + gamma), cut.line)
            else:
                self.move_end(self.arc_then_line(op, p, cut.line), cut.line)
        self.pieces.append(Piece(k, end))
        self.queued = len(self.pieces) - 1
        self.current, self.programmed = end, p
        self.prev = _Prev(arc=False)
        self.direction = (p[0] - op[0], p[1] - op[1])

    def arc_then_line(self, op: Pt, p: Pt, line: int) -> Pt:
        """Where the compensated arc before a concave corner meets the next line's offset."""
        prev = self.pieces[self.queued]
        assert prev.centre is not None
        centre, turn = prev.centre, self.prev.turn
        old = math.dist(centre, prev.end)
        base = _angle(op, p)
        theta = base + HALF if turn > 0 else base - HALF
        phi = _angle(op, centre)
        inside = self.inside(turn)
        uncompensated = old + self.r if inside else old - self.r
        d = uncompensated * math.cos(theta - phi)
        ratio = (d - self.r if inside else d + self.r) / old
        if not -1 <= ratio <= 1:
            raise CompError(
                line,
                "an arc then a straight cut make a corner the compensated tool cannot fit "
                "in without gouging",
            )
        if inside:
            angle = (-math.acos(ratio) if turn > 0 else math.acos(ratio)) + theta + math.pi
        else:
            angle = (math.acos(ratio) if turn > 0 else -math.acos(ratio)) + theta + math.pi
        return _at(centre, old, angle)

    # -- arcs -----------------------------------------------------------------------------------

    def arc(self, k: int, cut: Cut) -> None:
        assert cut.centre is not None
        c, op, p, centre = self.current, self.programmed, _f(cut.end), _f(cut.centre)
        turn = -1 if cut.clockwise else 1
        arc_radius = math.dist(centre, p)
        theta = _angle(op, c) + (-HALF if self.left else HALF)
        delta = _angle(op, centre)
        alpha = delta - HALF if turn > 0 else delta + HALF
        beta = theta - alpha if self.left else alpha - theta
        if beta > 1.5 * math.pi:
            beta -= TAU
        elif beta < -HALF:
            beta += TAU
        inside = self.inside(turn)
        if inside:
            gamma = _angle(p, centre)
            if arc_radius <= self.r:
                raise CompError(cut.line, "the tool radius is not less than the arc's radius")
        else:
            gamma = _angle(centre, p)
            delta += math.pi
        end = _at(p, self.r, gamma)
        concave = (
            beta < -SMALL_TURN
            or beta > math.pi + SMALL_TURN
            or (abs(beta - math.pi) < SMALL_TURN and not inside)
        )
        if concave:
            if not self.prev.arc:
                across = arc_radius * math.sin(beta - HALF)
                if inside:
                    distance = arc_radius - self.r
                    ratio = (across + self.r) / distance
                else:
                    distance = arc_radius + self.r
                    ratio = (across - self.r) / distance
                if not -1 <= ratio <= 1:
                    raise CompError(
                        cut.line,
                        "an arc in a concave corner cannot be reached by the tool without gouging",
                    )
                if inside:
                    angle = theta + (math.asin(ratio) if turn > 0 else -math.asin(ratio))
                else:
                    angle = theta + math.pi + (-math.asin(ratio) if turn > 0 else math.asin(ratio))
                self.move_end(_at(centre, distance, angle), cut.line)
            else:
                self.move_end(self.arc_then_arc(centre, arc_radius, turn, cut.line), cut.line)
        elif beta > SMALL_TURN:
            self.corner_arc(k, op, _at(op, self.r, delta))
        self.pieces.append(Piece(k, end, centre, cut.clockwise))
        self.queued = len(self.pieces) - 1
        self.current, self.programmed = end, p
        self.prev = _Prev(arc=True, centre=centre, turn=turn)
        self.programmed_turn = _sweep(op, p, centre, cut.clockwise)

    def arc_then_arc(self, centre: Pt, arc_radius: float, turn: int, line: int) -> Pt:
        """Where the compensated arc before a concave corner meets the next arc's offset."""
        prev = self.pieces[self.queued]
        assert prev.centre is not None
        old = math.dist(prev.centre, prev.end)
        new = arc_radius - self.r if self.inside(turn) else arc_radius + self.r
        between = math.dist(prev.centre, centre)
        if old == 0 or between == 0:
            raise CompError(line, "an arc then an arc about the same centre in a corner")
        a = (old * old + between * between - new * new) / (2 * old * between)
        if not -1 <= a <= 1:
            raise CompError(
                line,
                "two arcs make a corner the compensated tool cannot fit in without gouging",
            )
        back = math.acos(a)
        towards = _angle(prev.centre, centre)
        if self.inside(self.prev.turn):
            direction = towards + back if turn > 0 else towards - back
        else:
            direction = towards - back if turn > 0 else towards + back
        return _at(prev.centre, old, direction)


# -- MillBlocks' reading -------------------------------------------------------------------


def after_entry(pieces: list[Piece]) -> tuple[list[Piece], list[Piece]]:
    """The control's path split where the contour proper starts: the entry move (and the
    arc round the corner after it), and the rest."""
    split = next(
        (n for n, p in enumerate(pieces) if p.cut > 0 and not p.corner),
        len(pieces),
    )
    return pieces[:split], pieces[split:]


def millblocks_path(
    start: XY, elements: list[Element], comp: Comp, tool: int, diameter: int, units: Units
) -> Path | None:
    """The tool-centre path MillBlocks cuts for a DRILL at `start` with `comp` and these
    cuts: the blocks the importer writes for them (rounded, build.py), planned as the
    interpreter plans them (app/cnc/sequences.py); None where its rules find an error in them."""
    level = 0 if elements[0].z_dn is None else elements[0].z_dn
    spec = HoleSpec(HoleOp.DRILL, level + 1, level, 1, 1, tool, units)
    builder = Builder(Notes())
    builder.mill(MillOp([0], start, spec, comp, elements), inc=False, loop=False)
    size = decimal_of(quantize_nm(diameter, units), units)
    block0 = DataBlock0(tools=(Tool(number=tool, diameter=size, rpm=1000),))
    blocks = tuple(builder.blocks)
    at = (quantize_nm(start[0], units), quantize_nm(start[1], units))
    plan = plan_sequence(blocks, block0, units, 0, tuple(range(1, len(blocks))), at)
    if not plan.passes or any(f.severity.value == "error" for f in plan.findings):
        return None
    return plan.passes[0]


def same_path(control: list[Piece], start: Pt, ours: Path, tolerance: float) -> str:
    """ "" when MillBlocks' path `ours` cuts the control's `control` (starting at `start`)
    within `tolerance` nm; else how they differ, in words."""
    if not close(start, ours.start, tolerance):
        return "it goes down on the offset of the first cut, which the control's entry cuts short"
    differs = "the control joins a corner otherwise (to it, a turn of 0.05 rad or less is none)"
    if len(control) != len(ours.elements):
        return differs
    for p, e in zip(control, ours.elements, strict=True):
        if (p.centre is None) != (e.centre is None) or not close(p.end, e.end, tolerance):
            return differs
        if (
            p.centre is not None
            and e.centre is not None
            and (p.clockwise != e.clockwise or not close(p.centre, e.centre, tolerance))
        ):
            return differs
    return ""


# -- a mill sequence's compensated contours -------------------------------------------------


@dataclass
class Part:
    """One mill sequence of the blocks: a DRILL at `at` (down to `depth`) with `comp`, and
    its cuts. The first part is the file's plunge; each later one starts where the tool is
    (MillBlocks sets compensation on the DRILL, so a change of it is a new DRILL)."""

    at: XY
    comp: Comp
    depth: int
    elements: list[Element] = field(default_factory=list)


def _round(p: Pt) -> XY:
    return (round(p[0]), round(p[1]))


def _level(element: Element, level: int) -> int:
    return level if element.z_dn is None else element.z_dn


def _code(comp: Comp) -> str:
    return "G41" if comp is Comp.LEFT else "G42"


def _cut(comp: Comp) -> str:
    return "CUT LT" if comp is Comp.LEFT else "CUT RT"


class Reading:
    """How the cuts of one plunge are read where the file compensates them (G41/G42): the
    parts (mill sequences) they become, each said in the report."""

    def __init__(self, tool: int, diameters: Mapping[int, int], units: Units, notes: Notes):
        self.tool = tool
        self.diameters = diameters
        self.units = units
        self.notes = notes

    def parts(
        self, at: XY, depth: int, elements: list[Element], sides: list[tuple[str, int]]
    ) -> list[Part]:
        """`elements` (the cuts after the plunge at `at` to `depth`), each with its
        compensation side ("", "left", "right") and D tool (0: the tool in use), as parts.
        Raises ImportFailure where the control refuses the compensated contour."""
        parts: list[Part] = []
        current = Part(at, Comp.NONE, depth)
        here, level = at, depth
        i, n = 0, len(elements)
        while i < n:
            side, d_tool = sides[i]
            if not side:
                element = elements[i]
                current.elements.append(element)
                here, level = element.end, _level(element, level)
                i += 1
                continue
            j = i
            while j < n and sides[j] == sides[i]:
                j += 1
            run = elements[i:j]
            after = elements[j] if j < n and not sides[j][0] else None
            comp = Comp.LEFT if side == "left" else Comp.RIGHT
            tool = d_tool or self.tool
            diameter = self.diameters.get(tool)
            before, entry_level = level, _level(run[0], level)
            for element in run:
                level = _level(element, level)
            if diameter is not None:
                here, goes_on = self.compensated(
                    current, parts, comp, tool, diameter, here, run, entry_level, after
                )
                if not goes_on:
                    current = Part(here, Comp.NONE, level)
                i = j
                continue
            if tool != self.tool:
                raise ImportFailure(
                    self.notes.where(run[0].line),
                    f"{_code(comp)} D{d_tool} with tool {self.tool}: the file does not give "
                    f"tool {d_tool}'s diameter, and MillBlocks compensates with the DRILL's "
                    "own tool",
                    run[0].line,
                )
            # The diameter is the operator's (the control's tool table): the contour is read
            # as compensated, its entry and exit moves offset like the rest.
            taken = [*run, after] if after is not None else run
            if current.elements:
                parts.append(current)
                current = Part(here, comp, before)
            current.comp = comp
            current.elements += taken
            parts.append(current)
            self.unchecked(comp, tool, run, after)
            if after is not None:
                level = _level(after, level)
            here = taken[-1].end
            current = Part(here, Comp.NONE, level)
            i = j + (1 if after is not None else 0)
        if current.elements or not parts:
            parts.append(current)
        return parts

    def compensated(
        self,
        current: Part,
        parts: list[Part],
        comp: Comp,
        tool: int,
        diameter: int,
        start: XY,
        run: list[Element],
        level: int,
        after: Element | None,
    ) -> tuple[XY, bool]:
        """A compensated run whose tool diameter is known: the control's path, read as a
        compensated contour where MillBlocks cuts the same (the entry move then cut as the
        tool centre goes, in `current`; the contour a part of its own; both appended to
        `parts`), else as that path itself (appended to `current`). Returns where the tool
        is then, and whether `current` goes on (False: a new part starts there)."""
        lines = [e.line for e in run]
        span = self.notes.span(lines)
        size = f"tool {tool} of diameter {show(diameter, self.units)}"
        if diameter == 0:
            current.elements += run
            self.notes.assumed(run[0].line, f"{span}: {_code(comp)} with {size}: nothing is offset")
            return run[-1].end, True
        radius = diameter / 2
        cuts = [Cut(e.line, e.end, e.centre, e.clockwise) for e in run]
        try:
            pieces = control_path(start, cuts, comp is Comp.LEFT, radius, self.units)
        except CompError as exc:
            raise ImportFailure(
                self.notes.where(exc.line),
                f"cutter compensation ({_code(comp)}, {size}): {exc.message} (rs274 refuses "
                "it too)",
                exc.line,
            ) from None
        entry, rest = after_entry(pieces)
        why = ""
        if tool != self.tool:
            why = f"D{tool} is not the tool in use, and MillBlocks offsets by the DRILL's tool"
        elif not rest:
            why = "it is only the entry move"
        else:
            ours = millblocks_path(run[0].end, run[1:], comp, tool, diameter, self.units)
            if ours is None:
                why = "MillBlocks' compensation finds an error in it"
            else:
                why = same_path(rest, entry[-1].end, ours, AGREE[self.units])
        if why:
            current.elements += _tool_centre(pieces, run)
            self.notes.became(
                run[0].line,
                f"{span}: cutter compensation {comp.value} ({_code(comp)}, {size}) read as the "
                "tool-centre path the control cuts: MILL blocks without compensation "
                f"(MillBlocks' {_cut(comp)} would not cut the same: {why})",
            )
            return _round(pieces[-1].end), True
        current.elements += _tool_centre(entry, run)
        parts.append(current)
        parts.append(Part(run[0].end, comp, level, list(run[1:])))
        exit_text = "" if after is None else f", the exit move (line {after.line}) after it"
        self.notes.became(
            run[1].line,
            f"{self.notes.span(lines[1:])}: cutter compensation {comp.value} ({_code(comp)}, "
            f"{size}): a compensated contour, DRILL {_cut(comp)}, which cuts the control's "
            f"path; the entry move (line {run[0].line}) is cut as the tool centre goes before "
            f"it{exit_text}, and MillBlocks retracts and comes down again at each change",
        )
        return _round(pieces[-1].end), False

    def unchecked(self, comp: Comp, tool: int, run: list[Element], after: Element | None) -> None:
        lines = [e.line for e in run] + ([] if after is None else [after.line])
        exit_text = (
            ""
            if after is None
            else f", and the exit move (line {after.line}) its last, offset like the rest "
            "where the control ends it on its programmed point"
        )
        self.notes.needs(
            run[0].line,
            f"tool {tool}'s diameter (DIA in Data Block 0): the file compensates with the "
            "control's tool table",
        )
        self.notes.assumed(
            run[0].line,
            f"{self.notes.span(lines)}: cutter compensation {comp.value} ({_code(comp)}): a "
            f"compensated contour, DRILL {_cut(comp)}. The file does not give tool {tool}'s "
            "diameter, so the control's path cannot be checked: the entry move (line "
            f"{run[0].line}) is the contour's first cut, offset like the rest where the "
            f"control starts it from the uncompensated point{exit_text}",
        )


def _tool_centre(pieces: list[Piece], run: list[Element]) -> list[Element]:
    """The control's moves as cuts without compensation: each with its cut's line and feed,
    a depth change on the first move of its cut."""
    out: list[Element] = []
    seen: set[int] = set()
    for p in pieces:
        source = run[p.cut]
        z_dn = source.z_dn if p.cut not in seen else None
        seen.add(p.cut)
        centre = None if p.centre is None else _round(p.centre)
        out.append(Element(source.line, _round(p.end), centre, p.clockwise, z_dn, source.feed))
    return out
