"""The words of a 1704 tape: the plan's items rounded to the tape's resolution, their G
codes by the motion rules, and the blocks as text (seed 000 §2, §4).

- Positions are rounded once (half-even) to the machine's resolution; a move shorter than
  it is left out (reported); a feed the tape cannot carry is an error, one it rounds is
  reported.
- Arcs are split at the axes so each block stays in one quadrant (§4: "up to 90 degrees
  within one circle quadrant"), both end axes always written; the centre is the absolute
  I J (Table 4-1 N005 `I10000J30000`) and is not repeated while it stays the same (N015).
- G01/G02/G03 only into a feed move whose direction changes by 30° or less; G00, G20, G30
  otherwise (terminal motion, the last move, before any auxiliary block). Rapids are G50.
- Words `N3 G2 X±2.4 Y±2.4 Z±2.4 I J K R F3.1 S2 T2 M2` in that order, modal, leading
  zeros dropped (with zeros=0 every digit is punched), no decimal point.
- The reader limitation (§3, scan-damaged: DESIGN.md's reading) is checked block by block.

Each stage is a generator over the one before: `Rounder.items`, then `Words.lines`, then
`check_reader`; each reports through its own `Report`. Each takes the planner's runs
(`plan.Run`) in columns (`Rounder.run`, `Words.run_lines`, `LineRun`) and every other item
one by one; a run whose columns would have something to report but a left-out move goes
one by one too.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from app.cnc.formats.tape1704.plan import (
    ARC,
    DWELL,
    LINE,
    RAPID,
    Aux,
    Item,
    Kind,
    Motion,
    Piece,
    Run,
    sanitize_comment,
)
from app.cnc.formats.tape1704.profile import Profile, TapeFormat
from app.cnc.formats.targets import Report
from app.cnc.geometry import arc_sweep
from app.cnc.units import half_even

Point = tuple[int, int, int | None]
Vector = tuple[float, float, float]


@dataclass
class Line:
    """One punched block: its text (no End of Block) and what the checks need."""

    text: str
    block: int
    continuous: bool = False  # executed in G01/G02/G03: no deceleration at its end
    length: float = 0.0  # in the tape's unit
    feed_start: int = 0  # F word values
    feed_end: int = 0
    leader_after: int = 0


_N_WORDS = np.array([f"N{n}" for n in range(1000)], dtype=object)
"""The N word of each sequence number (`Words.line`: the number modulo 1000)."""
_G_WORDS = np.array(["" for _ in range(51)], dtype=object)
"""The G word of each motion code a run's blocks have (G04: its dwells)."""
for _code in (0, 1, 2, 3, 4, 20, 30, 50):
    _G_WORDS[_code] = f"G{_code:02d}"


@dataclass
class LineRun:
    """Blocks one after another (a `Run`'s) as columns: what each one's `Line` holds."""

    texts: list[str]
    block: npt.NDArray[np.int64]
    continuous: npt.NDArray[np.bool_]
    length: npt.NDArray[np.float64]
    feed_start: npt.NDArray[np.int64]
    feed_end: npt.NDArray[np.int64]

    def line(self, k: int) -> Line:
        return Line(
            self.texts[k],
            int(self.block[k]),
            bool(self.continuous[k]),
            float(self.length[k]),
            int(self.feed_start[k]),
            int(self.feed_end[k]),
        )


# -- geometry of the motion rules -------------------------------------------------------------


def tangent_out(motion: Motion, start: Point) -> Vector:
    """The direction a motion ends in (an arc's tangent at its end point)."""
    ex, ey, ez = motion.end
    if motion.kind is Kind.ARC and motion.centre is not None:
        rx, ry = ex - motion.centre[0], ey - motion.centre[1]
        return (ry, -rx, 0.0) if motion.clockwise else (-ry, rx, 0.0)
    dz = 0 if ez is None or start[2] is None else ez - start[2]
    return (ex - start[0], ey - start[1], dz)


def tangent_in(motion: Motion, start: Point) -> Vector:
    """The direction a motion starts in (an arc's tangent at its start point)."""
    if motion.kind is Kind.ARC and motion.centre is not None:
        rx, ry = start[0] - motion.centre[0], start[1] - motion.centre[1]
        return (ry, -rx, 0.0) if motion.clockwise else (-ry, rx, 0.0)
    return tangent_out(motion, start)


def turn_degrees(a: Vector, b: Vector) -> float:
    """The angle between two directions, degrees (180 when either is zero)."""
    norm = math.hypot(*a) * math.hypot(*b)
    if norm == 0:
        return 180.0
    cosine = sum(p * q for p, q in zip(a, b, strict=True)) / norm
    return math.degrees(math.acos(max(-1.0, min(1.0, cosine))))


def motion_length(motion: Motion, start: Point) -> float:
    """A motion's path length in tape units (an arc along its circle)."""
    ex, ey, ez = motion.end
    if motion.kind is Kind.ARC and motion.centre is not None:
        return arc_length((start[0], start[1]), (ex, ey), motion.centre, motion.clockwise)
    dz = 0 if ez is None or start[2] is None else ez - start[2]
    return math.sqrt((ex - start[0]) ** 2 + (ey - start[1]) ** 2 + dz**2)


def arc_length(
    start: tuple[int, int], end: tuple[int, int], centre: tuple[int, int], clockwise: bool
) -> float:
    """An arc's length along its circle, in the units of its points (a whole turn when it
    ends where it starts)."""
    radius = math.hypot(start[0] - centre[0], start[1] - centre[1])
    return radius * arc_sweep(start, end, centre, clockwise)


# -- pass 2: round to the tape's resolution, split arcs at the quadrants -----------------------


def units_array(nm: npt.NDArray[np.int64], fmt: TapeFormat) -> npt.NDArray[np.int64]:
    """`fmt.units` of each of `nm`: half_even(nm, step) in units of the last digit."""
    step = fmt.step_nm
    quotient, remainder = np.divmod(nm, step)  # floor: 0 <= remainder < step
    twice = 2 * remainder
    quotient += (twice > step) | ((twice == step) & (quotient % 2 == 1))
    result: npt.NDArray[np.int64] = quotient * (step // fmt.digit_nm)
    return result


class Rounder:
    """Items in nm → items in tape units. `start` is where the tape starts (nm, the
    control's Z)."""

    def __init__(self, fmt: TapeFormat, profile: Profile, start: Point) -> None:
        self.fmt = fmt
        self.profile = profile
        self.start = start
        self.report = Report("rounding")
        self.limit = fmt.max_units
        self.pos: Point = self.first()  # where the last kept move ends (tape units)
        self.carry_restart = False  # a left-out move's restart, for the next one kept

    def first(self) -> Point:
        """The start in tape units."""
        fmt = self.fmt
        x, y, z = self.start
        return (fmt.units(x), fmt.units(y), None if z is None else fmt.units(z))

    def items(self, items: Iterator[Piece]) -> Iterator[Piece]:
        for item in items:
            if isinstance(item, Aux):
                if item.preset_z:
                    self.pos = (self.pos[0], self.pos[1], 0)
                yield item
            elif isinstance(item, Run):
                rounded = self.run(item)
                if rounded is None:
                    for each in item.items():
                        if isinstance(each, Aux):
                            yield each
                        else:
                            yield from self.motion(each)
                elif len(rounded):
                    yield rounded
            else:
                yield from self.motion(item)

    def run(self, run: Run) -> Run | None:
        """A run rounded as `motion` rounds each of its moves, in columns, its arcs split at
        the quadrants; None when a move has something to report but its being too short
        (a coordinate past the capacity, a feed the tape cannot carry exactly, an arc too
        short or too large): then the items go one by one."""
        fmt, pos, limit = self.fmt, self.pos, self.limit
        moving = run.motions()
        if not len(moving):
            return run
        kind = run.kind[moving]
        x, y = units_array(run.x[moving], fmt), units_array(run.y[moving], fmt)
        z = None if run.z is None else units_array(run.z[moving], fmt)
        arcs = np.flatnonzero(kind == ARC)
        cx, cy = units_array(run.cx[moving][arcs], fmt), units_array(run.cy[moving][arcs], fmt)
        if (
            np.abs(x).max() > limit
            or np.abs(y).max() > limit
            or (z is not None and (pos[2] is None or np.abs(z).max() > limit))
            or (len(arcs) and max(np.abs(cx).max(), np.abs(cy).max()) > limit)
        ):
            return None
        feed = run.feed[moving]
        feeding = kind != RAPID
        if feeding.any():
            values, where = np.unique(feed[feeding], return_inverse=True)
            words = []
            for value in values.tolist():
                word = fmt.feed_value(value)
                if not (fmt.feed_min <= word <= fmt.feed_max and word * fmt.feed_unit_nm == value):
                    return None
                words.append(word)
            feed = feed.copy()
            feed[feeding] = np.array(words, dtype=np.int64)[where.reshape(-1)]
        # Where each motion starts: the one before's end (a move left out ends there too).
        sx = np.concatenate(([pos[0]], x[:-1]))
        sy = np.concatenate(([pos[1]], y[:-1]))
        # A straight move that ends where it starts is left out (a feed's reported), its
        # restart the next kept move's. In a two-axis program only X and Y count.
        moved = (x != sx) | (y != sy)
        if z is not None:
            moved |= z != np.concatenate(([pos[2] or 0], z[:-1]))  # pos[2] is known (above)
        moved[arcs] = True
        pieces: list[list[tuple[int, int]]] = []
        arc_rows = moving[arcs]
        # An arc's quadrant ends depend only on where its start and end are from its
        # centre (exact integers): the arcs of a pattern (one shape in many places) are
        # split once, each then moved to its centre.
        shapes: dict[tuple[int, int, int, int, bool, bool], list[tuple[int, int]]] = {}
        # Scalars from lists (not numpy's, one at a time): a CAM file's run has 10^4 arcs.
        for bx, by, ex, ey, ox, oy, clockwise, full_circle in zip(
            (sx[arcs] - cx).tolist(),
            (sy[arcs] - cy).tolist(),
            (x[arcs] - cx).tolist(),
            (y[arcs] - cy).tolist(),
            cx.tolist(),
            cy.tolist(),
            run.clockwise[arc_rows].tolist(),
            run.full[arc_rows].tolist(),
            strict=True,
        ):
            key = (bx, by, ex, ey, clockwise, full_circle)
            shape = shapes.get(key)
            if shape is None:
                # split_arc's refusals (a radius past the capacity, none, no sweep) go
                # one by one.
                radius = round(math.hypot(bx, by))
                if radius > limit or radius == 0 or (ex == bx and ey == by and not full_circle):
                    return None
                shape = quadrant_ends((bx, by), (ex, ey), (0, 0), radius, clockwise, full_circle)
                shapes[key] = shape
            pieces.append([(ox + px, oy + py) for px, py in shape])
        restart = run.restart or self.carry_restart
        if restart and run.kind[0] == DWELL:
            return None  # Words.lines restarts the motion mode on a run's first row only
        kept = np.flatnonzero(moved)
        for k in np.flatnonzero(~moved & feeding).tolist():
            self.report.note(
                int(run.block[moving[k]]), "a move shorter than the tape's resolution is left out"
            )
        if not len(kept):
            self.carry_restart = restart
        else:
            self.carry_restart = False
        self.pos = (int(x[-1]), int(y[-1]), pos[2] if z is None else int(z[-1]))
        # The run's rows again, each kept motion once and each arc once a quadrant.
        count = np.ones(len(run), dtype=np.int64)
        count[moving[~moved]] = 0
        count[arc_rows] = [len(points) for points in pieces]
        rows = np.repeat(np.arange(len(run)), count)
        out = run.take(rows, restart)
        xs = np.zeros(len(run), dtype=np.int64)
        ys = np.zeros(len(run), dtype=np.int64)
        xs[moving], ys[moving] = x, y
        out.x, out.y = xs[rows], ys[rows]
        if z is not None:
            zs = np.zeros(len(run), dtype=np.int64)
            zs[moving] = z
            out.z = zs[rows]
        feeds = np.zeros(len(run), dtype=np.int64)
        feeds[moving] = feed
        out.feed = feeds[rows]
        if len(arcs):
            cxs = np.zeros(len(run), dtype=np.int64)
            cys = np.zeros(len(run), dtype=np.int64)
            cxs[arc_rows], cys[arc_rows] = cx, cy
            out.cx, out.cy = cxs[rows], cys[rows]
            out.full = np.zeros(len(rows), dtype=np.bool_)
            # Each arc's quadrant ends in place of its end: an arc's rows follow each other
            # in `rows`, and the arcs come in order, as `pieces` has them.
            is_arc = np.zeros(len(run), dtype=np.bool_)
            is_arc[arc_rows] = True
            slots = np.flatnonzero(is_arc[rows])
            ends = np.array([point for points in pieces for point in points], dtype=np.int64)
            at_x, at_y = out.x.copy(), out.y.copy()
            at_x[slots], at_y[slots] = ends[:, 0], ends[:, 1]
            out.x, out.y = at_x, at_y
        return out

    def motion(self, item: Motion) -> list[Item]:
        """One motion rounded: none when it is too short, an arc's quadrants."""
        fmt, report, pos = self.fmt, self.report, self.pos
        # fmt.units inlined for the end points (three a move): the same half-even rounding.
        step, ratio, limit = fmt.step_nm, fmt.step_nm // fmt.digit_nm, self.limit
        ex, ey, ez = item.end
        end = (
            half_even(ex, step) * ratio,
            half_even(ey, step) * ratio,
            None if ez is None else half_even(ez, step) * ratio,
        )
        if not (
            -limit <= end[0] <= limit
            and -limit <= end[1] <= limit
            and (end[2] is None or -limit <= end[2] <= limit)
        ):
            self.check_capacity(item.block, end)
        item.restart = item.restart or self.carry_restart
        self.carry_restart = False
        if item.kind in (Kind.LINE, Kind.ARC, Kind.CYCLE):
            item.feed = self.check_feed(item.block, item.feed)
        if item.search_feed:
            item.search_feed = self.check_feed(item.block, item.search_feed)
        if item.kind is Kind.CYCLE:
            item.cycle_depth = fmt.units(item.cycle_depth)
            self.check_capacity(item.block, (0, 0, item.cycle_depth))
            item.end = end
            self.pos = end
            return [item]
        if item.kind is Kind.ARC:
            assert item.centre is not None
            centre = (fmt.units(item.centre[0]), fmt.units(item.centre[1]))
            self.check_capacity(item.block, centre, "IJ")
            pieces = self.split_arc(item, pos, end, centre)
            if not pieces:
                self.carry_restart = item.restart
                report.note(item.block, "an arc shorter than the tape's resolution is left out")
            if pieces:
                self.pos = (end[0], end[1], end[2] if end[2] is not None else pos[2])
            return pieces
        same_z = end[2] is None or pos[2] is None or end[2] == pos[2]
        searched = item.search_feed or (item.kind is Kind.RAPID and item.restart)
        if (
            (end[0], end[1]) == (pos[0], pos[1])
            and same_z
            and not item.quill_cycle
            and not (searched and self.profile.tape_search)
        ):
            self.carry_restart = item.restart
            if item.kind is not Kind.RAPID:
                report.note(item.block, "a move shorter than the tape's resolution is left out")
            return []
        item.end = end
        self.pos = (end[0], end[1], end[2] if end[2] is not None else pos[2])
        return [item]

    def check_capacity(self, block: int, point: Sequence[int | None], axes: str = "XYZ") -> None:
        limit = self.limit
        if all(value is None or -limit <= value <= limit for value in point):
            return
        for axis, value in zip(axes, point, strict=True):
            if value is not None and abs(value) > limit:
                self.report.error(
                    block,
                    f"{axis} {self.fmt.show(value)} is beyond the 1704's capacity of "
                    f"±{self.fmt.show(limit)}",
                )

    def check_feed(self, block: int, feed_nm: int) -> int:
        """The F word value of a feed; a feed the tape cannot carry is an error quoting the
        programmed feed, one it rounds is reported (never silently)."""
        fmt = self.fmt
        value = fmt.feed_value(feed_nm)
        if fmt.feed_min <= value <= fmt.feed_max and value * fmt.feed_unit_nm == feed_nm:
            return value  # carried exactly: nothing to say (and no words made to say it)
        programmed = fmt.show_programmed_feed(feed_nm)
        if value < fmt.feed_min:
            self.report.error(
                block,
                f"feed {programmed} is below the 1704's minimum {fmt.show_feed(fmt.feed_min)} "
                f"({fmt.name})",
            )
        elif value > fmt.feed_max:
            self.report.error(
                block,
                f"feed {programmed} is above the 1704's maximum {fmt.show_feed(fmt.feed_max)} "
                f"({fmt.name})",
            )
        elif value * fmt.feed_unit_nm != feed_nm:
            self.report.rewritten(
                block,
                f"feed {programmed} is written F{value} ({fmt.show_feed(value)}): {fmt.name} "
                f"feeds go in steps of {fmt.feed_step_text}",
            )
        return value

    def split_arc(
        self,
        arc: Motion,
        start: Point,
        end: Point,
        centre: tuple[int, int],
    ) -> list[Item]:
        """The arc as blocks of at most one quadrant each (seed 000 §4: "arcs up to 90
        degrees within one circle quadrant"), split where it crosses an axis through its
        centre. Points on an axis are exact (centre ± radius) in tape units."""
        cx, cy = centre
        sx, sy = start[0], start[1]
        radius = round(math.hypot(sx - cx, sy - cy))
        if radius > self.fmt.max_units:
            self.report.error(
                arc.block,
                f"arc radius {self.fmt.show(radius)} is above the 1704's maximum "
                f"{self.fmt.show(self.fmt.max_units)}",
            )
        if radius == 0 or ((end[0], end[1]) == (sx, sy) and not arc.full_circle):
            return []
        points = quadrant_ends(
            (sx, sy), (end[0], end[1]), centre, radius, arc.clockwise, arc.full_circle
        )
        pieces: list[Item] = []
        for px, py in points:
            pieces.append(
                Motion(
                    arc.block,
                    Kind.ARC,
                    (px, py, end[2]),
                    centre=centre,
                    clockwise=arc.clockwise,
                    feed=arc.feed,
                    restart=arc.restart and not pieces,
                )
            )
        return pieces


def _within_30(
    a: tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int64]],
    b: tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int64]],
) -> npt.NDArray[np.bool_]:
    """For each pair of directions of `a` and `b` (columns x, y, z), whether they differ by
    30° or less: `turn_degrees` in columns. Where floating point could make a different
    last digit matter (within 1e-6° of the limit), `turn_degrees` answers."""
    ax, ay, az = a
    bx, by, bz = b
    dot = (ax * bx + ay * by + az * bz).astype(np.float64)
    norm = np.sqrt((ax * ax + ay * ay + az * az).astype(np.float64)) * np.sqrt(
        (bx * bx + by * by + bz * bz).astype(np.float64)
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        degrees = np.degrees(np.arccos(np.clip(dot / norm, -1.0, 1.0)))
    degrees[norm == 0] = 180.0
    limit = 30.0 + 1e-9
    within: npt.NDArray[np.bool_] = degrees <= limit
    for k in np.flatnonzero(np.abs(degrees - limit) < 1e-6).tolist():
        one = (int(ax[k]), int(ay[k]), int(az[k]))
        other = (int(bx[k]), int(by[k]), int(bz[k]))
        within[k] = turn_degrees(one, other) <= limit
    return within


def quadrant_ends(
    start: tuple[int, int],
    end: tuple[int, int],
    centre: tuple[int, int],
    radius: int,
    clockwise: bool,
    full_circle: bool,
) -> list[tuple[int, int]]:
    """Where each quadrant block of an arc (`Rounder.split_arc`) ends: the axes through its
    centre it crosses (centre ± radius), then its end."""
    sx, sy = start
    cx, cy = centre
    a0 = math.atan2(sy - cy, sx - cx)
    sweep = 2 * math.pi if full_circle else arc_sweep(start, end, centre, clockwise)
    quarter = math.pi / 2
    axis_points = ((1, 0), (0, 1), (-1, 0), (0, -1))
    points: list[tuple[int, int]] = []
    if clockwise:
        k = math.ceil(a0 / quarter) - 1
        step = -1
    else:
        k = math.floor(a0 / quarter) + 1
        step = 1
    while True:
        travelled = abs(k * quarter - a0)
        if travelled >= sweep - 1e-12:
            break
        dx, dy = axis_points[k % 4]
        point = (cx + dx * radius, cy + dy * radius)
        if point not in (start, end) and (not points or point != points[-1]):
            points.append(point)
        k += step
    points.append(end)
    return points


def with_starts(items: Iterator[Piece], start: Point) -> Iterator[tuple[Piece, Point]]:
    """Each item with where it starts (tape units), for the direction rules."""
    pos = start
    for item in items:
        yield item, pos
        if isinstance(item, Aux):
            if item.preset_z:
                pos = (pos[0], pos[1], 0)
        elif isinstance(item, Run):
            end = item.end()
            if end is not None:
                pos = (end[0], end[1], end[2] if end[2] is not None else pos[2])
        else:
            z = item.end[2] if item.end[2] is not None else pos[2]
            pos = (item.end[0], item.end[1], z)


# -- passes 3 and 4: G codes by the motion rules, then the words ------------------------------


class Words:
    """Rounded items → the tape's blocks (`Line`s)."""

    def __init__(self, fmt: TapeFormat, profile: Profile) -> None:
        self.fmt = fmt
        self.profile = profile
        self.report = Report("words")
        self.number = profile.sequence_start
        self.wrapped = False

    def choose_g(self, item: Motion, start: Point, following: Item | None, after: Point) -> None:
        """G01/G02/G03 only into a feed move whose direction changes by 30° or less; G00,
        G20, G30 otherwise (terminal motion, the last move, before any auxiliary block)."""
        if item.kind is Kind.RAPID:
            item.gcode = "50"
            return
        if item.kind is Kind.CYCLE:
            item.gcode = f"{item.cycle_code:02d}"
            return
        smooth = False
        if (
            not self.profile.decel
            and isinstance(following, Motion)
            and following.kind in (Kind.LINE, Kind.ARC)
            and not following.quill_cycle
        ):
            smooth = turn_degrees(tangent_out(item, start), tangent_in(following, after)) <= (
                30.0 + 1e-9
            )
        if item.kind is Kind.LINE:
            item.gcode = "01" if smooth else "00"
        elif item.clockwise:
            item.gcode = "02" if smooth else "20"
        else:
            item.gcode = "03" if smooth else "30"

    def line(
        self,
        words: list[tuple[str, str]],
        block: int,
        comment: str = "",
        motion: Motion | None = None,
        start: Point | None = None,
        feed_before: int | None = None,
        leader_after: int = 0,
    ) -> Line:
        profile, fmt = self.profile, self.fmt
        if profile.sequence:
            if self.number > 999 and not self.wrapped:
                self.wrapped = True
                self.report.warning(
                    block,
                    "sequence numbers pass N999 here and start again at N000 (the N word "
                    "has three digits; a tape search stops at the first match)",
                )
            words = [("N", str(self.number % 1000)), *words]
            self.number += profile.sequence_increment
        joiner = "\t" if profile.tabs else ""
        text = joiner.join([letter + value for letter, value in words])
        if comment:  # every comment of the tape's blocks, through the one comment rule
            text += f" ({sanitize_comment(comment)})"
        line = Line(text, block, leader_after=leader_after)
        if motion is not None and start is not None and motion.gcode in ("01", "02", "03"):
            line.continuous = True
            line.length = motion_length(motion, start) * fmt.digit_nm / fmt.unit_nm
            line.feed_end = motion.feed
            line.feed_start = motion.feed if feed_before is None else feed_before
        return line

    def lines(self, items: Iterator[tuple[Piece, Point]]) -> Iterator[Line | LineRun]:
        """The blocks of the rounded items (each with where it starts), a run's in columns."""
        self.g: str | None = None
        self.pos: list[int | None] = [None, None, None]
        self.ij: list[int | None] = [None, None]
        self.feed: int | None = None
        self.s_code: str | None = None
        self.g99 = False
        self.carried: list[tuple[str, str]] = []
        last_block = 0
        ahead = iter(items)
        current = next(ahead, None)
        following = next(ahead, None)
        while current is not None:
            item, start = current
            if isinstance(item, Run):
                # All but its last item in columns (each one's next is in the run), then the
                # last one by one: what comes after the run decides its G code.
                count = len(item)
                if count > 1:
                    yield self.run_lines(item, start)
                    start = item.start_of(count - 1, start)
                restart = item.restart and count == 1  # a dwell first went one by one
                current = (item.take(slice(count - 1, None), restart).items()[0], start)
                continue
            last_block = item.block
            yield from self.item_lines(item, start, following)
            current, following = following, next(ahead, None)
        if self.g99:
            yield self.line([("G", "98")], last_block)

    def item_lines(
        self, item: Item, start: Point, following: tuple[Piece, Point] | None
    ) -> list[Line]:
        """The blocks of one item; `following` is the next (an auxiliary block may ride on
        it, and a feed move's G code depends on it)."""
        out: list[Line] = []
        after: Item | None = None
        after_start = start
        if following is not None:
            next_piece, after_start = following
            if isinstance(next_piece, Run):
                after = next_piece.take(slice(0, 1), next_piece.restart).items()[0]
            else:
                after = next_piece
        if isinstance(item, Aux):
            if (
                item.forward
                and isinstance(after, Motion)
                and after.kind is Kind.RAPID
                and not any(letter == "G" for letter, _ in item.words)
            ):
                self.carried.extend(
                    item.words if item.restate else spindle_words(item.words, self.s_code)
                )
                self.s_code = next((v for k, v in item.words if k == "S"), self.s_code)
                return out
            if self.g99 and item.words[-1] in (("M", "30"), ("M", "02")):
                out.append(self.line([("G", "98")], item.block))  # no drill cycle left on
                self.g99 = False
            words = spindle_words(item.words, self.s_code)
            self.s_code = next((v for k, v in item.words if k == "S"), self.s_code)
            if words or item.comment:
                out.append(
                    self.line(words, item.block, item.comment, leader_after=item.leader_after)
                )
                if any(letter == "G" for letter, _ in words):
                    self.g = None  # G04 and G94 act in their block only; state the mode again
                if item.preset_z:
                    self.pos[2] = 0
            return out
        self.choose_g(item, start, after, after_start)
        pos, ij = self.pos, self.ij
        if item.restart:
            pos = [None, None, None]
            ij = self.ij = [None, None]
            self.g, self.feed = None, None
        if item.quill_cycle != self.g99:
            out.append(self.line([("G", "99" if item.quill_cycle else "98")], item.block))
            self.g99 = item.quill_cycle
            self.g = None  # state the motion mode again after the quill's G
        words = []
        if item.gcode != self.g:
            words.append(("G", item.gcode))
        ex, ey, ez = item.end
        arc = item.kind is Kind.ARC
        for axis, value in enumerate((ex, ey)):
            if not item.z_only and (arc or item.quill_cycle or value != pos[axis]):
                words.append(("XY"[axis], self.digits(value)))
        if item.kind is Kind.CYCLE:
            words.append(("Z", self.digits(item.cycle_depth)))
            assert ez is not None
            words.append(("R", self.digits(ez)))
        elif ez is not None and not arc and ez != pos[2]:
            words.append(("Z", self.digits(ez)))
        if arc:
            assert item.centre is not None
            for axis, value in enumerate(item.centre):
                if value != ij[axis]:
                    words.append(("IJ"[axis], self.digits(value)))
                    ij[axis] = value
        feed_before = self.feed
        if item.kind is not Kind.RAPID and item.feed != self.feed:
            words.append(("F", self.feed_word(item.feed)))
            self.feed = item.feed
        elif item.kind is Kind.RAPID and item.search_feed:
            words.append(("F", self.feed_word(item.search_feed)))
            self.feed = item.search_feed
        words.extend(self.carried)
        self.carried = []
        out.append(self.line(words, item.block, motion=item, start=start, feed_before=feed_before))
        self.g = item.gcode
        self.pos = [ex, ey, ez if ez is not None else pos[2]]
        return out

    def run_lines(self, run: Run, start: Point) -> LineRun:
        """The blocks of a run's items but its last, as `item_lines` writes each (G codes,
        modal words, sequence numbers) in columns. `start` is where the run starts."""
        profile, fmt = self.profile, self.fmt
        count = len(run) - 1
        kind, x, y, z, feed = run.kind, run.x, run.y, run.z, run.feed
        moving = kind != DWELL
        arc = kind == ARC
        indices = np.arange(len(run))
        # The motion before each row (-1: none in the run) and where each row starts.
        last_motion = np.maximum.accumulate(np.where(moving, indices, -1))
        before = np.concatenate(([-1], last_motion[:-1]))
        had = before >= 0
        prior = np.maximum(before, 0)
        sx = np.where(had, x[prior], start[0])
        sy = np.where(had, y[prior], start[1])
        dx, dy = x - sx, y - sy
        if z is None:
            dz = np.zeros_like(dx)
        elif start[2] is None:
            dz = np.where(had, z - z[prior], 0)
        else:
            dz = z - np.where(had, z[prior], start[2])
        # Directions: a straight move's own, an arc's tangent at its end (out) and start (in).
        turn = np.where(run.clockwise, 1, -1)
        ex, ey = x - run.cx, y - run.cy
        bx, by = sx - run.cx, sy - run.cy
        out_x, out_y = np.where(arc, turn * ey, dx), np.where(arc, -turn * ex, dy)
        in_x, in_y = np.where(arc, turn * by, dx), np.where(arc, -turn * bx, dy)
        out_z = np.where(arc, 0, dz)
        feeding = (kind == LINE) | arc
        gcode = np.where(kind == RAPID, 50, np.where(arc, np.where(run.clockwise, 20, 30), 0))
        gcode[kind == DWELL] = 4
        gcode = gcode[:count]
        if not profile.decel:
            smooth = feeding[:count] & feeding[1:]
            ahead = np.flatnonzero(smooth)
            smooth[ahead] = _within_30(
                (out_x[ahead], out_y[ahead], out_z[ahead]),
                (in_x[ahead + 1], in_y[ahead + 1], out_z[ahead + 1]),
            )
            # G01, G02, G03 into a smooth turn; G00, G20, G30 otherwise.
            gcode[smooth] = np.where(arc[:count][smooth], gcode[smooth] // 10, 1)
        first = int(np.argmax(moving)) if moving.any() else -1
        if run.restart and first == 0:
            self.pos = [None, None, None]
            self.ij = [None, None]
            self.g, self.feed = None, None
        pos = self.pos
        columns: list[npt.NDArray[np.object_]] = []
        if profile.sequence:
            numbers = self.number + profile.sequence_increment * np.arange(count, dtype=np.int64)
            over = np.flatnonzero(numbers > 999)
            if not self.wrapped and len(over):
                self.wrapped = True
                self.report.warning(
                    int(run.block[over[0]]),
                    "sequence numbers pass N999 here and start again at N000 (the N word "
                    "has three digits; a tape search stops at the first match)",
                )
            self.number += profile.sequence_increment * count
            columns.append(_N_WORDS[numbers % 1000])
        # Each word where it differs from the one before (the state before the run first);
        # a dwell's G04 leaves no motion mode in force.
        g_before = np.empty(count, dtype=np.int64)
        g_before[0] = -1 if self.g is None else int(self.g)
        g_before[1:] = np.where(moving[: count - 1], gcode[:-1], -1)
        written = (gcode != g_before) | ~moving[:count]
        column = _G_WORDS[gcode]
        column[~written] = ""
        columns.append(column)
        straight = moving[:count] & ~arc[:count]
        axes = [("X", x, pos[0], arc), ("Y", y, pos[1], arc)]
        if z is not None:
            axes.append(("Z", z, pos[2], np.zeros_like(arc)))
        for letter, values, state, always in axes:
            written = np.where(had[:count], values[prior[:count]] != values[:count], True)
            if state is not None:
                written[~had[:count]] = values[:count][~had[:count]] != state
            written = (written & straight) | always[:count]
            columns.append(self.word_column(letter, values[:count], written))
        last_arc = np.maximum.accumulate(np.where(arc, indices, -1))
        arc_before = np.concatenate(([-1], last_arc[:-1]))[:count]
        has_arc = arc_before >= 0
        prior_arc = np.maximum(arc_before, 0)
        for letter, centre, axis in (("I", run.cx, 0), ("J", run.cy, 1)):
            state = self.ij[axis]
            shown = centre[:count]
            if state is None:
                written = arc[:count] & (~has_arc | (shown != centre[prior_arc]))
            else:
                written = arc[:count] & (shown != np.where(has_arc, centre[prior_arc], state))
            columns.append(self.word_column(letter, shown, written))
            if last_arc[count - 1] >= 0:
                self.ij[axis] = int(centre[last_arc[count - 1]])
        # The feed in force before each row: the last feed or arc's in the run, else the
        # state's; a dwell's F is its time.
        last_feed = np.maximum.accumulate(np.where(feeding, indices, -1))[:count]
        feed_before = np.empty(count, dtype=np.int64)
        feed_before[0] = -1 if self.feed is None else self.feed
        feed_before[1:] = np.where(
            last_feed[:-1] >= 0, feed[np.maximum(last_feed[:-1], 0)], feed_before[0]
        )
        shown_feed = feed[:count]
        written = feeding[:count] & (shown_feed != feed_before)
        column = _distinct_words(shown_feed, written, lambda value: "F" + self.feed_word(value))
        dwells = ~moving[:count]
        _distinct_words(run.tenths[:count], dwells, lambda tenths: f"F{tenths}", column)
        columns.append(column)
        joiner = "\t" if profile.tabs else ""
        lists = [column.tolist() for column in columns]
        if joiner:
            texts = [
                joiner.join([word for word in row if word]) for row in zip(*lists, strict=True)
            ]
        else:
            texts = list(map("".join, zip(*lists, strict=True)))
        if self.carried:
            words = [words[0] for words in lists if words[0]]
            texts[0] = joiner.join(words + [letter + value for letter, value in self.carried])
            self.carried = []
        # What the reader limitation needs (check_reader): the G01-G03 blocks' length.
        continuous = (gcode == 1) | (gcode == 2) | (gcode == 3)
        length = np.zeros(count)
        lines = continuous & ~arc[:count]
        squares = dx[:count] ** 2 + dy[:count] ** 2 + dz[:count] ** 2
        length[lines] = np.sqrt(squares[lines].astype(np.float64)) * fmt.digit_nm / fmt.unit_nm
        # The arcs' lengths as `motion_length` has them (the same floats as a block
        # written alone), from lists: a long CAM file's run has 10^4 arcs. A length
        # depends only on where the arc's ends are from its centre (exact integers): each
        # shape of a pattern's arcs is measured once.
        curved = np.flatnonzero(continuous & arc[:count])
        digit_nm, unit_nm = fmt.digit_nm, fmt.unit_nm
        ocx, ocy = run.cx[curved], run.cy[curved]
        lengths: dict[tuple[int, int, int, int, bool], float] = {}
        measured: list[float] = []
        for shape in zip(
            (sx[curved] - ocx).tolist(),
            (sy[curved] - ocy).tolist(),
            (x[curved] - ocx).tolist(),
            (y[curved] - ocy).tolist(),
            run.clockwise[curved].tolist(),
            strict=True,
        ):
            known = lengths.get(shape)
            if known is None:
                bx, by, ax, ay, cw = shape
                known = arc_length((bx, by), (ax, ay), (0, 0), cw) * digit_nm / unit_nm
                lengths[shape] = known
            measured.append(known)
        length[curved] = measured
        last = count - 1
        self.g = str(_G_WORDS[gcode[last]])[1:] if moving[last] else None
        motion = int(last_motion[last])
        if motion >= 0:
            self.pos = [
                int(x[motion]),
                int(y[motion]),
                pos[2] if z is None else int(z[motion]),
            ]
        if last_feed[last] >= 0:
            self.feed = int(feed[last_feed[last]])
        return LineRun(
            texts,
            run.block[:count],
            continuous,
            length,
            np.where(feed_before >= 0, feed_before, shown_feed),
            shown_feed,
        )

    def word_column(
        self, letter: str, values: npt.NDArray[np.int64], written: npt.NDArray[np.bool_]
    ) -> npt.NDArray[np.object_]:
        """`letter` and `digits` of each value where written, else ''."""
        if self.profile.leading_zeros:
            digits = self.digits
            return _distinct_words(values, written, lambda value: letter + digits(value))
        # str of a negative int is its sign and digits: `digits` without zeros.
        return _distinct_words(values, written, lambda value: f"{letter}{value}")

    def digits(self, units: int) -> str:
        """A motion word's digits: sign only when negative, no point; leading zeros only
        with zeros=0 (then every digit of the format is punched)."""
        digits = str(abs(units))
        if self.profile.leading_zeros:
            digits = digits.zfill(self.fmt.int_digits + self.fmt.frac_digits)
        return ("-" if units < 0 else "") + digits

    def feed_word(self, value: int) -> str:
        """An F word's digits (F3.1: four, F4: four), leading zeros only with zeros=0."""
        return str(value).zfill(4) if self.profile.leading_zeros else str(value)


def _distinct_words(
    values: npt.NDArray[np.int64],
    written: npt.NDArray[np.bool_],
    word: Callable[[int], str],
    column: npt.NDArray[np.object_] | None = None,
) -> npt.NDArray[np.object_]:
    """`word(value)` of each of `values` where written, else '' (or what `column` has
    there). Each distinct value is made once (a run repeats its Z levels, a grid its X and
    Y, a CAM file its few feeds)."""
    if column is None:
        column = np.full(len(values), "", dtype=object)
    distinct, where = np.unique(values[written], return_inverse=True)
    words = [word(value) for value in distinct.tolist()]
    column[written] = np.array(words, dtype=object)[where.reshape(-1)]
    return column


def spindle_words(words: list[tuple[str, str]], s_code: str | None) -> list[tuple[str, str]]:
    """Drop an S word that repeats the speed already set (S is modal)."""
    return [(k, v) for k, v in words if not (k == "S" and v == s_code)]


def check_reader(
    lines: Iterator[Line | LineRun], fmt: TapeFormat, report: Report
) -> Iterator[Line | LineRun]:
    """The lines, checked as they pass for seed 000 §3 "Reader Limitation" (scan-damaged
    formulas, DESIGN.md's reading): T1 = 60·L / ((F1 + F2)/2) to execute a non-decelerated
    block, T2 = 0.010 + (N − 1)/300 to read the next one (N characters, its End of Block
    included); warn where T2 > T1. A run's blocks are checked in columns, and where T2 and
    T1 are near each other each block is checked as a `Line`."""
    previous: Line | None = None
    for line in lines:
        if isinstance(line, LineRun):
            texts = line.texts
            characters = np.fromiter(map(len, texts), dtype=np.int64, count=len(texts)) + 1
            ahead = line.continuous[:-1] & (line.length[:-1] > 0)
            with np.errstate(divide="ignore", invalid="ignore"):
                t1 = (
                    60
                    * line.length[:-1]
                    / (
                        (
                            line.feed_start[:-1] * fmt.feed_unit_nm / fmt.unit_nm
                            + line.feed_end[:-1] * fmt.feed_unit_nm / fmt.unit_nm
                        )
                        / 2
                    )
                )
            t2 = 0.010 + (characters[1:] - 1) / 300
            near = np.flatnonzero(ahead & (t2 > t1 * (1 - 1e-9)))
            if previous is not None:
                _check_read(previous, texts[0], fmt, report)
            for k in near.tolist():
                _check_read(line.line(k), texts[k + 1], fmt, report)
            yield line
            previous = line.line(len(texts) - 1)
            continue
        if previous is not None and previous.continuous:
            _check_read(previous, line.text, fmt, report)
        yield line
        previous = line


def _check_read(previous: Line, text: str, fmt: TapeFormat, report: Report) -> None:
    """Warn when the block `text` takes longer to read than `previous` to execute."""
    if not (previous.continuous and previous.length > 0):
        return
    characters = len(text) + 1
    f1 = previous.feed_start * fmt.feed_unit_nm / fmt.unit_nm
    f2 = previous.feed_end * fmt.feed_unit_nm / fmt.unit_nm
    t1 = 60 * previous.length / ((f1 + f2) / 2)
    t2 = 0.010 + (characters - 1) / 300
    if t2 > t1:
        shown = previous.text.split(" (")[0].replace(chr(9), " ")
        report.warning(
            previous.block,
            f"reader limitation: {shown} moves {previous.length:.4f} "
            f"{fmt.unit} in {t1:.3f} s but the next block ({characters} characters) "
            f"takes {t2:.3f} s to read: the slides may stop and dwell (seed 000 §3)",
            same="the same reader limitation",
            at=shown,
        )
