"""Calculated geometry of a mill contour: the points the print does not give (issue 33).

A machinist programs from the print: it gives a radius and says two edges are tangent, not
where the tangent point is. So a MILL STD, QCIR or ARC block's X or Y may be left empty
(None, `null` in the document) and a block may say it is `tangent` to the segment before
it; a MILL ARC's XY-CENT block may give its radius (`radius`) instead of, or beside, its
centre. `solve_contour` calculates what is missing, once, from what is given, and rounds
each point once to the nanometre (app.cnc.units.round_nm): the contour it hands the
compiler is ordinary geometry, the same for every consumer (preview, cycle time, Verify,
every writer), and each calculated value is kept so the editor can show it.

What is solved (in block order, each segment from the end of the one before):

- a line's end: both coordinates; or one, with its direction (tangent); or none, with its
  direction, where the next block fixes the point (an arc whose centre is given, tangent
  or not, or whose radius follows from its end);
- a line's end given one coordinate where the next arc's circle is known: their
  intersection;
- an arc's centre: given; or on the normal to the tangent at its start, at the radius, or
  where it is as far from the start as from the given end, or where one coordinate puts
  it; or, without tangency, the radius and both ends (the arc of less than 180°);
- an arc's end: given; one coordinate on its circle; or none, where the next block fixes
  it (a tangent line to a given end: the tangent point; an arc whose centre is given: the
  intersection of the circles, or the tangent point on the line of centres when the next
  arc is tangent);
- a quarter circle's end from one coordinate when it is tangent (its centre lines are
  the axes, so the other coordinate follows).

Where two points fit, the one the direction of travel reaches first is taken (a line goes
forward along its direction; an arc turns the stated way from its start and ends at the
first point that fits); docs/readings.md, "Calculated geometry", has the readings.
A segment that cannot be solved is an error naming the block and the field and what else
the print must give; a tangency that cannot be (a given centre off the normal, a point
inside the circle a tangent line must touch) is an error that says so. Both leave the
sequence uncut, as any geometry error does.

`corners` then rounds the corners that carry a conrad (`conrad`: the radius of an arc
tangent to both segments) or a chamfer (`chamfer`: the bevel's leg along each segment) in
the block's units; the inserted elements carry the block of the corner and its tag, so the
events writer can write a conrad as the Plus's CR.

Pure: no Flask, database or serial code. Lengths in nm (floats while solving).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from decimal import Decimal

from app.cnc.blocks import ArcEnd, Block, Direction, MillArc, MillLine, MillQcir, Mode
from app.cnc.cutter import Finding, offset_element
from app.cnc.memo import Recent
from app.cnc.plane import (
    EPS,
    Element,
    Path,
    Pt,
    add,
    cross,
    dot,
    half_step,
    intersections,
    left_normal,
    qcir_centre,
    scale,
    sub,
    tangent,
    unit,
)
from app.cnc.problems import Rule, Severity
from app.cnc.units import Units, message_length, round_nm, to_nm

CONRAD = "conrad"
CHAMFER = "chamfer"
PLACES = 12  # a calculated value's decimals: every nm of the solved point, exactly


@dataclass
class Solution:
    """A contour's solved points (nm, absolute): `ends[i]` the end of the segment whose
    first block is index `i`, `centres[i]` an arc's centre; `calculated[(number, name)]`
    each value that was empty, as its block would hold it (INC: from the segment's start),
    in the block's units; `findings` what could not be solved."""

    ends: dict[int, tuple[int, int]] = field(default_factory=dict)
    centres: dict[int, tuple[int, int]] = field(default_factory=dict)
    calculated: dict[tuple[int, str], Decimal] = field(default_factory=dict)
    findings: list[Finding] = field(default_factory=list)

    @property
    def failed(self) -> bool:
        return any(f.severity is Severity.ERROR for f in self.findings)


class _Unsolved(Exception):
    """A segment that cannot be solved: the finding that says why."""

    def __init__(self, finding: Finding) -> None:
        super().__init__(finding.message)
        self.finding = finding


@dataclass
class _Seg:
    """One contour segment as typed: its first block (`index`) and the block holding its
    end point (`end_index`: an arc's XY-END, else the same block)."""

    index: int
    end_index: int
    block: MillLine | MillQcir | MillArc
    end_block: MillLine | MillQcir | ArcEnd

    @property
    def number(self) -> int:
        return self.index + 1

    @property
    def end_number(self) -> int:
        return self.end_index + 1

    @property
    def units(self) -> Units:
        return self.block.units


def needs_solving(blocks: tuple[Block, ...], mills: tuple[int, ...]) -> bool:
    """True when a contour has an empty coordinate, a tangency or a radius to honour."""
    for index in mills:
        block = blocks[index]
        if isinstance(block, MillLine | MillQcir | MillArc | ArcEnd) and (
            block.x is None
            or block.y is None
            or getattr(block, "tangent", False)
            or getattr(block, "radius", None) is not None
            or getattr(block, "angle", None) is not None
        ):
            return True
    return False


def solve_contour(
    blocks: tuple[Block, ...], mills: tuple[int, ...], start: tuple[int, int]
) -> Solution:
    """Solve the contour blocks `mills` (indexes into `blocks`) from `start` (nm).

    Never raises: a segment that cannot be solved is a finding (error) naming its block and
    field, and the segments after it are left unsolved (their points are not in `ends`).
    Solved once: the compile's solution is what the events writer (which reads contours
    itself) gets again. Shared: read it, do not change it.
    """
    key = (tuple(blocks[i] for i in mills), mills, start)
    found = _SOLVED.get(key)
    if found is not None:
        return found
    segs = _segments(blocks, mills)
    solution = Solution()
    solver = _Solver(segs, solution, (float(start[0]), float(start[1])))
    try:
        solver.run()
    except _Unsolved as problem:
        solution.findings.append(problem.finding)
    _SOLVED.keep(key, solution)
    return solution


# Recent solutions by (the contour's blocks, their places, the start).
_SOLVED: Recent[Solution] = Recent(256)


def _segments(blocks: tuple[Block, ...], mills: tuple[int, ...]) -> list[_Seg]:
    segs: list[_Seg] = []
    for index in mills:
        block = blocks[index]
        if isinstance(block, MillArc):
            end = blocks[index + 1] if index + 1 < len(blocks) else None
            if isinstance(end, ArcEnd):
                segs.append(_Seg(index, index + 1, block, end))
        elif isinstance(block, MillLine | MillQcir):
            segs.append(_Seg(index, index, block, block))
    return segs


# -- the loci a point may be on -------------------------------------------------------------


@dataclass(frozen=True)
class _Line:
    """Points p + t·d; `ray`: only t > 0 (a direction of travel from p)."""

    p: Pt
    d: Pt
    ray: bool


@dataclass(frozen=True)
class _Circle:
    """An arc's circle: from `start`, turning `clockwise`, about `centre`."""

    centre: Pt
    radius: float
    start: Pt
    clockwise: bool


def _turn(start: Pt, point: Pt, circle: _Circle) -> float:
    """How far (radians, 0 to 2π) the arc turns from `start` to `point` in its direction."""
    c = circle.centre
    a0 = math.atan2(start[1] - c[1], start[0] - c[0])
    a1 = math.atan2(point[1] - c[1], point[0] - c[0])
    turn = (a0 - a1) if circle.clockwise else (a1 - a0)
    turn %= 2 * math.pi
    return turn if turn > 1e-9 else 2 * math.pi


def _travel(centre: Pt, point: Pt, clockwise: bool) -> Pt:
    """The direction an arc about `centre` travels at `point`."""
    r = unit(sub(point, centre))
    return (r[1], -r[0]) if clockwise else (-r[1], r[0])


def _normal_side(t: Pt, clockwise: bool) -> Pt:
    """The unit normal from a point of travel `t` toward the centre of a tangent arc: left
    of the travel for a counter-clockwise arc, right for a clockwise one."""
    n = left_normal(t)
    return scale(n, -1.0) if clockwise else n


def _on_axis(locus: _Line | _Circle, axis: int, value: float) -> list[Pt]:
    """Points of `locus` whose coordinate `axis` (0: X, 1: Y) is `value`."""
    if isinstance(locus, _Line):
        if abs(locus.d[axis]) < 1e-12:
            return []
        t = (value - locus.p[axis]) / locus.d[axis]
        if locus.ray and t <= EPS:
            return []
        return [add(locus.p, scale(locus.d, t))]
    c, r = locus.centre, locus.radius
    offset = value - c[axis]
    if abs(offset) > r + EPS:
        return []
    other = math.sqrt(max(r * r - offset * offset, 0.0))
    found = []
    for sign in (-1.0, 1.0):
        p = [0.0, 0.0]
        p[axis] = value
        p[1 - axis] = c[1 - axis] + sign * other
        found.append((p[0], p[1]))
    return found


def _meet(a: _Line | _Circle, b: _Line | _Circle) -> list[Pt]:
    """Where two loci cross (mill.intersections: the one line/circle rule)."""

    def element(locus: _Line | _Circle) -> tuple[Pt, Element]:
        if isinstance(locus, _Line):
            return locus.p, Element(0, add(locus.p, locus.d))
        # A circle by its radius: intersections() reads the radius from the start point.
        on = add(locus.centre, (locus.radius, 0.0))
        return on, Element(0, on, centre=locus.centre)

    a_start, a_el = element(a)
    b_start, b_el = element(b)
    found = intersections(a_start, a_el, b_start, b_el)
    for locus in (a, b):
        if isinstance(locus, _Line) and locus.ray:
            found = [p for p in found if dot(sub(p, locus.p), locus.d) > EPS]
    return found


def _first(locus: _Line | _Circle, points: list[Pt]) -> Pt | None:
    """Of `points` on `locus`, the one its direction of travel reaches first."""
    if not points:
        return None
    if isinstance(locus, _Line):
        return min(points, key=lambda p: dot(sub(p, locus.p), locus.d))
    return min(points, key=lambda p: _turn(locus.start, p, locus))


# -- the solver -----------------------------------------------------------------------------


class _Solver:
    def __init__(self, segs: list[_Seg], solution: Solution, start: Pt) -> None:
        self.segs = segs
        self.solution = solution
        self.start = start
        self.along: Pt | None = None  # the travel direction at `start` (None: first segment)

    def run(self) -> None:
        for k, seg in enumerate(self.segs):
            nxt = self.segs[k + 1] if k + 1 < len(self.segs) else None
            self.segment(seg, nxt)

    # -- values as typed --------------------------------------------------------------------

    def given(self, block: Block, name: str) -> float | None:
        """A typed coordinate as an absolute nm value (INC: from the segment's start)."""
        value: Decimal | None = getattr(block, name)
        if value is None:
            return None
        nm = float(to_nm(value, block.units))
        if block.mode is Mode.INC:
            nm += self.start[0 if name == "x" else 1]
        return nm

    def point(self, block: Block) -> tuple[float | None, float | None]:
        return self.given(block, "x"), self.given(block, "y")

    def keep(self, block_index: int, block: Block, p: Pt) -> Pt:
        """Round a solved point once to the nanometre and record the empty values it fills."""
        rounded = (round_nm(p[0]), round_nm(p[1]))
        for axis, name in enumerate(("x", "y")):
            if getattr(block, name) is None:
                value = rounded[axis]
                if block.mode is Mode.INC:
                    value -= round_nm(self.start[axis])
                self.solution.calculated[(block_index + 1, name)] = _decimal(value, block.units)
        return (float(rounded[0]), float(rounded[1]))

    # -- one segment --------------------------------------------------------------------------

    def segment(self, seg: _Seg, nxt: _Seg | None) -> None:
        block = seg.block
        if getattr(block, "tangent", False) and self.along is None:
            raise _Unsolved(
                Finding(
                    seg.number,
                    Rule.TANGENCY,
                    Severity.ERROR,
                    "TANGENT on the first block of the sequence: there is no segment before "
                    "it to be tangent to; tangency is allowed from the second block on",
                    "TANGENT",
                )
            )
        if isinstance(block, MillArc):
            end, along = self.arc(seg, block, nxt)
        elif isinstance(block, MillQcir):
            end, along = self.qcir(seg, block)
        else:
            end, along = self.line(seg, block, nxt)
        self.solution.ends[seg.index] = (round_nm(end[0]), round_nm(end[1]))
        if along is not None:
            self.along = along
        self.start = end

    def line(self, seg: _Seg, block: MillLine, nxt: _Seg | None) -> tuple[Pt, Pt | None]:
        s = self.start
        x, y = self.point(block)
        direction = self.along if block.tangent else None
        if block.angle is not None:
            stated = _heading(block.angle)
            if direction is not None and abs(cross(direction, stated)) > 1e-6:
                raise self.impossible(
                    seg,
                    "ANGLE",
                    f"ANGLE {block.angle}° is {_angle(direction, stated)} off the tangent of "
                    "the segment before it; give one or the other",
                )
            direction = stated
        if x is not None and y is not None:
            end = (x, y)
            if direction is not None:
                self.check_line_direction(seg, block, s, end, direction)
        elif direction is not None and (x is not None or y is not None):
            axis, value = (0, x) if x is not None else (1, y)
            assert value is not None
            found = _on_axis(_Line(s, direction, ray=True), axis, value)
            if not found:
                raise self.impossible(
                    seg,
                    "X" if axis == 0 else "Y",
                    f"a line tangent to the segment before it cannot reach "
                    f"{'X' if axis == 0 else 'Y'} {_shown(value, seg.units)} going forward; "
                    "the print must give a point ahead along the tangent",
                )
            end = self.keep(seg.index, block, found[0])
        else:
            locus: _Line | None = None
            if direction is not None:
                locus = _Line(s, direction, ray=True)
            elif x is not None:
                locus = _Line((x, s[1]), (0.0, 1.0), ray=False)
            elif y is not None:
                locus = _Line((s[0], y), (1.0, 0.0), ray=False)
            end = self.keep(seg.index, block, self.from_next(seg, locus, nxt))
        if math.dist(s, end) < EPS:
            return end, None
        return end, unit(sub(end, s))

    def check_line_direction(
        self, seg: _Seg, block: MillLine, s: Pt, end: Pt, direction: Pt
    ) -> None:
        """A line given both coordinates and a direction (TANGENT or ANGLE): they agree."""
        off = cross(direction, sub(end, s))
        if abs(off) > half_step(seg.units) or dot(direction, sub(end, s)) <= 0:
            said = (
                f"not at ANGLE {block.angle}°"
                if block.angle is not None
                else "not tangent to the segment before it"
            )
            raise self.impossible(
                seg,
                "ANGLE" if block.angle is not None else "TANGENT",
                f"the line to X {_shown(end[0], seg.units)} Y {_shown(end[1], seg.units)} is "
                f"{said} (it turns {_angle(direction, sub(end, s))} from it); leave X or Y "
                "empty to have the end calculated along that direction",
            )

    def arc(self, seg: _Seg, block: MillArc, nxt: _Seg | None) -> tuple[Pt, Pt | None]:
        s = self.start
        clockwise = block.direction is Direction.CW
        cx, cy = self.point(block)
        ex, ey = self.point(seg.end_block)
        radius = None if block.radius is None else float(to_nm(block.radius, block.units))
        along = self.along if block.tangent else None
        centre = self.arc_centre(seg, block, s, (cx, cy), (ex, ey), radius, along, clockwise)
        r = math.dist(s, centre)
        if r < EPS:
            raise self.impossible(
                seg, "X", "the arc's centre is its start point; the radius would be zero"
            )
        if radius is not None and abs(r - radius) > half_step(seg.units):
            raise self.impossible(
                seg,
                "RAD",
                f"RAD {_shown(radius, seg.units)} but the centre is "
                f"{_shown(r, seg.units)} from the arc's start; give the centre or the "
                "radius, or both that agree",
            )
        circle = _Circle(centre, r, s, clockwise)
        if ex is not None and ey is not None:
            end: Pt = (ex, ey)
        elif ex is not None or ey is not None:
            axis, value = (0, ex) if ex is not None else (1, ey)
            assert value is not None
            found = _first(circle, _on_axis(circle, axis, value))
            if found is None:
                raise self.impossible(
                    seg,
                    "X" if axis == 0 else "Y",
                    f"{'X' if axis == 0 else 'Y'} {_shown(value, seg.units)} is not on the "
                    f"arc's circle (centre X {_shown(centre[0], seg.units)} Y "
                    f"{_shown(centre[1], seg.units)}, radius {_shown(r, seg.units)})",
                    end_block=True,
                )
            end = self.keep(seg.end_index, seg.end_block, found)
        else:
            end = self.keep(seg.end_index, seg.end_block, self.from_next(seg, circle, nxt))
        self.solution.centres[seg.index] = (round_nm(centre[0]), round_nm(centre[1]))
        return end, _travel(centre, end, clockwise)

    def arc_centre(
        self,
        seg: _Seg,
        block: MillArc,
        s: Pt,
        given: tuple[float | None, float | None],
        end: tuple[float | None, float | None],
        radius: float | None,
        along: Pt | None,
        clockwise: bool,
    ) -> Pt:
        cx, cy = given
        units = seg.units
        turn = "clockwise" if clockwise else "counter-clockwise"
        if along is not None:
            normal = _normal_side(along, clockwise)
            if cx is not None and cy is not None:
                c = (cx, cy)
                off = cross(normal, sub(c, s))
                if abs(off) > half_step(units) or dot(normal, sub(c, s)) <= 0:
                    raise self.impossible(
                        seg,
                        "TANGENT",
                        f"a {turn} arc tangent to the segment before it has its centre on the "
                        f"{'right' if clockwise else 'left'} of the travel, square to it; the "
                        f"centre X {_shown(cx, units)} Y {_shown(cy, units)} is not (leave the "
                        "centre empty and give RAD, or give the centre on that normal)",
                    )
                return c
            normal_line = _Line(s, normal, ray=True)
            if cx is not None or cy is not None:
                axis, value = (0, cx) if cx is not None else (1, cy)
                assert value is not None
                found = _on_axis(normal_line, axis, value)
                if not found:
                    raise self.impossible(
                        seg,
                        "X" if axis == 0 else "Y",
                        f"a {turn} arc tangent to the segment before it has its centre on the "
                        f"{'right' if clockwise else 'left'} of the travel; "
                        f"{'X' if axis == 0 else 'Y'} {_shown(value, units)} puts it behind",
                    )
                return self.keep(seg.index, block, found[0])
            if radius is not None:
                return self.keep(seg.index, block, add(s, scale(normal, radius)))
            ex, ey = end
            if ex is not None and ey is not None:
                chord = sub((ex, ey), s)
                reach = dot(normal, chord)
                if reach <= EPS:
                    raise self.impossible(
                        seg,
                        "TANGENT",
                        f"a {turn} arc tangent to the segment before it cannot end at X "
                        f"{_shown(ex, units)} Y {_shown(ey, units)}: that point is on the "
                        "other side of the tangent; use the other direction",
                        end_block=False,
                    )
                t = dot(chord, chord) / (2 * reach)
                return self.keep(seg.index, block, add(s, scale(normal, t)))
            raise self.under(
                seg,
                "X",
                "the tangent arc's centre is not given and cannot be calculated; the print "
                "must also give RAD, or one coordinate of the centre, or the arc's end X and Y",
            )
        if cx is not None and cy is not None:
            return (cx, cy)
        ex, ey = end
        if radius is not None and ex is not None and ey is not None:
            chord = sub((ex, ey), s)
            half = math.hypot(*chord) / 2
            if half > radius + half_step(units):
                raise self.impossible(
                    seg,
                    "RAD",
                    f"RAD {_shown(radius, units)} is less than half the distance from the "
                    f"arc's start to its end ({_shown(half, units)}); no such arc exists",
                )
            height = math.sqrt(max(radius * radius - half * half, 0.0))
            mid = add(s, scale(chord, 0.5))
            # The arc of less than 180°: its centre on the side the arc turns toward.
            normal = _normal_side(unit(chord), clockwise)
            return self.keep(seg.index, block, add(mid, scale(normal, height)))
        missing = "X" if cx is None else "Y"
        raise self.under(
            seg,
            missing,
            "the arc's centre is not given and cannot be calculated; the print must also give "
            "the centre's X and Y, or RAD with the arc's end X and Y, or say the arc is "
            "TANGENT to the segment before it (with RAD or its end)",
        )

    def qcir(self, seg: _Seg, block: MillQcir) -> tuple[Pt, Pt | None]:
        s = self.start
        x, y = self.point(block)
        clockwise = block.direction is Direction.CW
        if x is not None and y is not None:
            end: Pt = (x, y)
        else:
            along = self.along if block.tangent else None
            if along is None or (x is None and y is None):
                raise self.under(
                    seg,
                    "X" if x is None else "Y",
                    "a QCIR's end is not given and cannot be calculated; the print must give "
                    "both X and Y, or one of them with the QCIR TANGENT to the segment before",
                )
            if abs(along[0]) > 1e-9 and abs(along[1]) > 1e-9:
                raise self.impossible(
                    seg,
                    "TANGENT",
                    "a QCIR starts along the X or Y axis (its centre lines are the axes) and "
                    "the segment before it does not end along one; no tangent QCIR fits",
                )
            normal = _normal_side(along, clockwise)
            axis, value = (0, x) if x is not None else (1, y)
            assert value is not None
            # A quarter turn: end = start + R·(along + normal).
            step = along[axis] + normal[axis]
            r = (value - s[axis]) / step
            if r <= EPS:
                raise self.impossible(
                    seg,
                    "X" if axis == 0 else "Y",
                    f"a {'clockwise' if clockwise else 'counter-clockwise'} QCIR tangent to "
                    f"the segment before it cannot end at {'X' if axis == 0 else 'Y'} "
                    f"{_shown(value, seg.units)}: that is behind its start",
                )
            end = self.keep(seg.index, block, add(s, scale(add(along, normal), r)))
        if math.dist(s, end) < EPS:
            return end, None
        try:
            corner = qcir_centre(_nm(s), _nm(end), block.direction)
        except ValueError:
            return end, None  # not a quarter circle: programmed_contour names it
        centre = (float(corner[0]), float(corner[1]))
        if block.tangent and self.along is not None:
            leaves = _travel(centre, s, clockwise)
            if abs(cross(leaves, self.along)) > 1e-6 or dot(leaves, self.along) <= 0:
                raise self.impossible(
                    seg,
                    "TANGENT",
                    f"the QCIR to X {_shown(end[0], seg.units)} Y {_shown(end[1], seg.units)} "
                    f"starts {_angle(self.along, leaves)} off the segment before it, so it is "
                    "not tangent; leave X or Y empty to have its end calculated",
                )
        return end, _travel(centre, end, clockwise)

    # -- a point the next block fixes -------------------------------------------------------

    def from_next(self, seg: _Seg, locus: _Line | _Circle | None, nxt: _Seg | None) -> Pt:
        """The end of `seg`, on `locus`, where the next segment's start must be."""
        field = "X"
        what = "the end"
        if locus is None or nxt is None:
            given = "X and Y are empty" if locus is None else "the end is only partly given"
            raise self.under(
                seg,
                field,
                f"{given} and nothing calculates the end"
                + (
                    "; this is the last block of the sequence, so the print must give its end"
                    if nxt is None
                    else "; the print must give X and Y, or one of them with the block "
                    "TANGENT to the segment before it, or end it where an arc with a given "
                    "centre starts"
                ),
                end_block=True,
            )
        block = nxt.block
        if block.mode is Mode.INC:
            raise self.under(
                seg,
                field,
                f"{what} of the segment is to be calculated from block {nxt.number}, whose "
                "X and Y are incremental from this very point; make that block ABS",
                end_block=True,
            )
        if isinstance(block, MillArc):
            return self.from_next_arc(seg, locus, nxt, block)
        if isinstance(block, MillLine) and block.tangent and isinstance(locus, _Circle):
            return self.tangent_point(seg, locus, nxt, block)
        if isinstance(block, MillLine) and block.angle is not None:
            return self.from_next_line(seg, locus, nxt, block)
        raise self.under(
            seg,
            field,
            f"{what} of the segment is not given and block {nxt.number} does not fix it; the "
            "print must give X or Y here, or the next block must be an arc whose centre is "
            "given, or a line TANGENT to this arc with its end given",
            end_block=True,
        )

    def from_next_arc(self, seg: _Seg, locus: _Line | _Circle, nxt: _Seg, block: MillArc) -> Pt:
        cx, cy = block.x, block.y
        end = nxt.end_block
        units = seg.units
        if cx is None or cy is None:
            raise self.under(
                seg,
                "X",
                f"the end of the segment is to be where the arc of block {nxt.number} starts, "
                "but that arc's centre is not given; the print must give this end, or the "
                "arc's centre X and Y",
                end_block=True,
            )
        c = (float(to_nm(cx, block.units)), float(to_nm(cy, block.units)))
        clockwise = block.direction is Direction.CW
        if block.tangent:
            if isinstance(locus, _Line):
                # Tangent to a line: the foot of the centre on it.
                t = dot(sub(c, locus.p), locus.d)
                foot = add(locus.p, scale(locus.d, t))
                if (locus.ray and t <= EPS) or math.dist(foot, c) < EPS:
                    raise self.impossible(
                        seg,
                        "X",
                        f"the arc of block {nxt.number} cannot be tangent to this line: its "
                        "centre is behind the line's start or on the line",
                        end_block=True,
                    )
                travel = locus.d if locus.ray else unit(sub(foot, self.start))
                if dot(_normal_side(travel, clockwise), sub(c, foot)) <= 0:
                    raise self.impossible(
                        seg,
                        "X",
                        f"the {'clockwise' if clockwise else 'counter-clockwise'} arc of block "
                        f"{nxt.number} cannot be tangent to this line: its centre is on the "
                        "other side of it; use the other direction",
                        end_block=True,
                    )
                return self.keep(seg.end_index, seg.end_block, foot)
            if isinstance(locus, _Circle):
                along_c = unit(sub(c, locus.centre))
                if math.dist(c, locus.centre) < EPS:
                    raise self.impossible(
                        seg,
                        "X",
                        f"the arc of block {nxt.number} has the same centre; concentric arcs "
                        "cannot be tangent",
                        end_block=True,
                    )
                for sign in (1.0, -1.0):
                    p = add(locus.centre, scale(along_c, sign * locus.radius))
                    if math.dist(p, c) < EPS:
                        continue
                    mine = _travel(locus.centre, p, locus.clockwise)
                    theirs = _travel(c, p, clockwise)
                    if dot(mine, theirs) > 0:
                        return self.keep(seg.end_index, seg.end_block, p)
                raise self.impossible(
                    seg,
                    "X",
                    f"the arc of block {nxt.number} cannot be tangent to this one turning that way",
                    end_block=True,
                )
        if block.radius is not None:
            radius = float(to_nm(block.radius, block.units))
        elif end.x is not None and end.y is not None and end.mode is Mode.ABS:
            radius = math.dist(c, (float(to_nm(end.x, end.units)), float(to_nm(end.y, end.units))))
        else:
            raise self.under(
                seg,
                "X",
                f"the end of the segment is where the arc of block {nxt.number} starts, but "
                "that arc's radius is not known; the print must give this end, or the arc's "
                "RAD, or its end X and Y",
                end_block=True,
            )
        found = _meet(locus, _Circle(c, radius, c, clockwise))
        chosen = self.first_met(locus, found)
        if chosen is None:
            raise self.impossible(
                seg,
                "X",
                f"this segment never meets the circle of block {nxt.number}'s arc (centre X "
                f"{_shown(c[0], units)} Y {_shown(c[1], units)}, radius "
                f"{_shown(radius, units)}); the print's dimensions do not close",
                end_block=True,
            )
        return self.keep(seg.end_index, seg.end_block, chosen)

    def first_met(self, locus: _Line | _Circle, found: list[Pt]) -> Pt | None:
        """Of the points where the segment's `locus` meets the next one, the one it reaches
        first: along its direction of travel, or for a line given only X or Y (no
        direction), the one nearer its start."""
        if isinstance(locus, _Line) and not locus.ray:
            return min(found, key=lambda p: math.dist(p, self.start), default=None)
        return _first(locus, found)

    def from_next_line(self, seg: _Seg, locus: _Line | _Circle, nxt: _Seg, block: MillLine) -> Pt:
        """The next line is given its ANGLE and end: this end is where the line through
        that end at that angle meets this segment (line–line or line–arc)."""
        if block.x is None or block.y is None:
            raise self.under(
                seg,
                "X",
                f"the line of block {nxt.number} is given its ANGLE but not its end; the print "
                "must give that end's X and Y, or this end",
                end_block=True,
            )
        q = (float(to_nm(block.x, block.units)), float(to_nm(block.y, block.units)))
        assert block.angle is not None
        found = _meet(locus, _Line(q, _heading(block.angle), ray=False))
        chosen = self.first_met(locus, found)
        if chosen is None:
            raise self.impossible(
                seg,
                "X",
                f"this segment never meets the line of block {nxt.number} (through X "
                f"{_shown(q[0], seg.units)} Y {_shown(q[1], seg.units)} at "
                f"{block.angle}°): they are parallel, or it is behind; the print's dimensions "
                "do not close",
                end_block=True,
            )
        return self.keep(seg.end_index, seg.end_block, chosen)

    def tangent_point(self, seg: _Seg, circle: _Circle, nxt: _Seg, block: MillLine) -> Pt:
        if block.x is None or block.y is None:
            raise self.under(
                seg,
                "X",
                f"the line of block {nxt.number} is tangent to this arc, but its own end is not "
                "given; the print must give that end's X and Y, or this arc's end",
                end_block=True,
            )
        q = (float(to_nm(block.x, block.units)), float(to_nm(block.y, block.units)))
        c, r = circle.centre, circle.radius
        d = math.dist(q, c)
        if d <= r + EPS:
            raise self.impossible(
                seg,
                "X",
                f"the line of block {nxt.number} is to be tangent to this arc, but its end X "
                f"{_shown(q[0], seg.units)} Y {_shown(q[1], seg.units)} is inside the arc's "
                "circle (or on it); no tangent line reaches it",
                end_block=True,
            )
        base = math.atan2(q[1] - c[1], q[0] - c[0])
        spread = math.acos(r / d)
        for angle in (base + spread, base - spread):
            p = (c[0] + r * math.cos(angle), c[1] + r * math.sin(angle))
            if dot(_travel(c, p, circle.clockwise), sub(q, p)) > 0:
                return self.keep(seg.end_index, seg.end_block, p)
        raise AssertionError("one of the two tangent points leaves toward q")

    # -- findings -------------------------------------------------------------------------------

    def under(self, seg: _Seg, label: str, message: str, *, end_block: bool = False) -> _Unsolved:
        number = seg.end_number if end_block else seg.number
        return _Unsolved(Finding(number, Rule.UNDER_DETERMINED, Severity.ERROR, message, label))

    def impossible(
        self, seg: _Seg, label: str, message: str, *, end_block: bool = False
    ) -> _Unsolved:
        number = seg.end_number if end_block else seg.number
        return _Unsolved(Finding(number, Rule.TANGENCY, Severity.ERROR, message, label))


def _nm(p: Pt) -> tuple[int, int]:
    return (round_nm(p[0]), round_nm(p[1]))


def _decimal(nm: int, units: Units) -> Decimal:
    """A solved length (nm) as a block value: 12 places hold every nanometre exactly."""
    return (Decimal(nm) / Decimal(units.nm)).quantize(Decimal(1).scaleb(-PLACES))


def _shown(nm: float, units: Units) -> str:
    return message_length(round(nm), units)


def _heading(degrees: Decimal) -> Pt:
    """The direction of a line's ANGLE: degrees counter-clockwise from +X."""
    theta = math.radians(float(degrees))
    return (math.cos(theta), math.sin(theta))


def _angle(a: Pt, b: Pt) -> str:
    turn = math.degrees(abs(math.atan2(cross(a, b), dot(a, b))))
    return f"{turn:.2f}°"


# -- conrads and chamfers -------------------------------------------------------------------


def corners(
    path: Path, numbers: list[int], blocks: tuple[Block, ...], findings: list[Finding]
) -> tuple[Path, list[int]]:
    """`path` with each corner that carries a conrad or chamfer rounded or bevelled.

    The corner after element k is the end of its block (a line or QCIR; an arc's XY-END).
    A conrad inserts the arc of that radius tangent to both elements (left turn:
    counter-clockwise), a chamfer the line between the points that far from the corner
    along each element (on an arc: that far in a straight line). The elements it trims
    keep their centres. Both are errors (in `findings`) on the last element (no corner),
    at a tangent corner (nothing to round), or when they do not fit the elements.
    """
    elements = list(path.elements)
    if not any(_corner_value(blocks, e.block) for e in elements):
        return path, numbers
    out: list[Element] = []
    out_numbers: list[int] = []
    starts = [path.start] + [e.end for e in elements[:-1]]
    k = 0
    trimmed_start: Pt | None = None
    while k < len(elements):
        element = elements[k]
        start = starts[k] if trimmed_start is None else trimmed_start
        trimmed_start = None
        value = _corner_value(blocks, element.block)
        last_of_block = k + 1 >= len(elements) or elements[k + 1].block != element.block
        if value is None or not last_of_block or element.tag:
            out.append(element)
            out_numbers.append(numbers[k])
            k += 1
            continue
        kind, size, holder = value
        units = blocks[holder - 1].units
        label = "CONRAD" if kind == CONRAD else "CHAMFER"
        if k + 1 >= len(elements):
            findings.append(
                Finding(
                    holder,
                    Rule.CORNER,
                    Severity.ERROR,
                    f"{label} on the last block of the sequence: there is no next segment to "
                    "make a corner with; put it on a block that has one after it",
                    label,
                )
            )
            out.append(element)
            out_numbers.append(numbers[k])
            k += 1
            continue
        nxt = elements[k + 1]
        made = make_corner(start, element, nxt, kind, float(to_nm(size, units)))
        if isinstance(made, str):
            findings.append(
                Finding(
                    holder,
                    Rule.CORNER,
                    Severity.ERROR,
                    f"{label} {_shown(to_nm(size, units), units)}: {made}",
                    label,
                )
            )
            out.append(element)
            out_numbers.append(numbers[k])
            k += 1
            continue
        t1, inserted, t2 = made
        out.append(replace(element, end=t1))
        out_numbers.append(numbers[k])
        out.append(replace(inserted, block=element.block, tag=kind, corner=element.end))
        out_numbers.append(numbers[k])
        trimmed_start = t2
        k += 1
    return Path(path.start, tuple(out)), out_numbers


def _corner_value(blocks: tuple[Block, ...], number: int) -> tuple[str, Decimal, int] | None:
    """(conrad or chamfer, its size, the block holding it) at the end of block `number`."""
    block = blocks[number - 1]
    holder = number
    if isinstance(block, MillArc):
        holder = number + 1
        block = blocks[number] if number < len(blocks) else block
    conrad = getattr(block, "conrad", None)
    chamfer = getattr(block, "chamfer", None)
    if conrad is not None:
        return CONRAD, conrad, holder
    if chamfer is not None:
        return CHAMFER, chamfer, holder
    return None


def make_corner(
    start: Pt, a: Element, b: Element, kind: str, size: float
) -> tuple[Pt, Element, Pt] | str:
    """The corner at `a.end` between `a` (from `start`) and `b`: (where `a` now ends, the
    inserted element, where `b` now starts), or why it cannot be made."""
    corner = a.end
    t1 = tangent(start, a, at_end=True)
    t2 = tangent(corner, b, at_end=False)
    turn = math.atan2(cross(t1, t2), dot(t1, t2))
    if abs(turn) < 1e-6:
        return "the corner is tangent (the segments blend), so there is nothing to round"
    if kind == CHAMFER:
        p1 = _along(start, a, corner, size, backward=True)
        p2 = _along(corner, b, corner, size, backward=False)
        if p1 is None or p2 is None:
            return "longer than the segments it cuts back; it must fit both"
        return p1, Element(0, p2), p2
    side = 1.0 if turn > 0 else -1.0
    a_start, a_off = offset_element(start, a, side, size)
    b_start, b_off = offset_element(corner, b, side, size)
    centres = intersections(a_start, a_off, b_start, b_off)
    fitting = []
    for c in centres:
        p1 = _foot(start, a, c)
        p2 = _foot(corner, b, c)
        if _within(start, a, p1) and _within(corner, b, p2):
            fitting.append((math.dist(c, corner), c, p1, p2))
    if not fitting:
        return (
            "the arc of that radius tangent to both segments does not fit on them; "
            "give a smaller conrad"
        )
    _, c, p1, p2 = min(fitting)
    return p1, Element(0, p2, centre=c, clockwise=turn < 0), p2


def _foot(start: Pt, element: Element, p: Pt) -> Pt:
    """The point of the line or circle carrying `element` nearest to `p`."""
    if element.centre is None:
        d = unit(sub(element.end, start))
        return add(start, scale(d, dot(sub(p, start), d)))
    c = element.centre
    r = math.dist(start, c)
    return add(c, scale(unit(sub(p, c)), r))


def _within(start: Pt, element: Element, p: Pt) -> bool:
    """`p` (on the element's line or circle) lies on the element itself."""
    if element.centre is None:
        d = sub(element.end, start)
        t = dot(sub(p, start), d) / max(dot(d, d), EPS)
        return -1e-9 <= t <= 1 + 1e-9
    circle = _Circle(element.centre, math.dist(start, element.centre), start, element.clockwise)
    whole = _turn(start, element.end, circle)
    return _turn(start, p, circle) <= whole + 1e-9 or math.dist(p, start) < 1.0


def _along(start: Pt, element: Element, corner: Pt, size: float, backward: bool) -> Pt | None:
    """The point of `element` at straight distance `size` from `corner` (its end when
    `backward`, else its start), or None when the element is too short."""
    if element.centre is None:
        d = unit(sub(element.end, start))
        length = math.dist(start, element.end)
        if size >= length - EPS:
            return None
        return add(corner, scale(d, -size if backward else size))
    c = element.centre
    r = math.dist(start, c)
    if size >= 2 * r:
        return None
    candidates = intersections(
        add(corner, (size, 0.0)),
        Element(0, add(corner, (size, 0.0)), centre=corner),
        start,
        Element(0, element.end, centre=c),
    )
    circle = _Circle(c, r, start, element.clockwise)
    whole = _turn(start, element.end, circle)
    on = [p for p in candidates if _turn(start, p, circle) < whole]
    if not on:
        return None
    # Backward: the one nearest the end (most turned); forward: nearest the start.
    return (
        max(on, key=lambda p: _turn(start, p, circle))
        if backward
        else min(on, key=lambda p: _turn(start, p, circle))
    )
