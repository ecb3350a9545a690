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
`check_reader`; each reports through its own `Report`.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

from app.cnc.formats.tape1704.plan import Aux, Item, Kind, Motion, sanitize_comment
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
        cx, cy = motion.centre
        radius = math.hypot(start[0] - cx, start[1] - cy)
        sweep = arc_sweep((start[0], start[1]), (ex, ey), (cx, cy), motion.clockwise)
        return radius * sweep
    dz = 0 if ez is None or start[2] is None else ez - start[2]
    return math.sqrt((ex - start[0]) ** 2 + (ey - start[1]) ** 2 + dz**2)


# -- pass 2: round to the tape's resolution, split arcs at the quadrants -----------------------


class Rounder:
    """Items in nm → items in tape units. `start` is where the tape starts (nm, the
    control's Z)."""

    def __init__(self, fmt: TapeFormat, profile: Profile, start: Point) -> None:
        self.fmt = fmt
        self.profile = profile
        self.start = start
        self.report = Report("rounding")
        self.limit = fmt.max_units

    def first(self) -> Point:
        """The start in tape units."""
        fmt = self.fmt
        x, y, z = self.start
        return (fmt.units(x), fmt.units(y), None if z is None else fmt.units(z))

    def items(self, items: Iterator[Item]) -> Iterator[Item]:
        fmt, report = self.fmt, self.report
        pos = self.first()
        carry_restart = False
        # fmt.units inlined for the end points (three a move): the same half-even rounding.
        step, ratio, limit = fmt.step_nm, fmt.step_nm // fmt.digit_nm, self.limit
        for item in items:
            if isinstance(item, Aux):
                if item.preset_z:
                    pos = (pos[0], pos[1], 0)
                yield item
                continue
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
            item.restart = item.restart or carry_restart
            carry_restart = False
            if item.kind in (Kind.LINE, Kind.ARC, Kind.CYCLE):
                item.feed = self.check_feed(item.block, item.feed)
            if item.search_feed:
                item.search_feed = self.check_feed(item.block, item.search_feed)
            if item.kind is Kind.CYCLE:
                item.cycle_depth = fmt.units(item.cycle_depth)
                self.check_capacity(item.block, (0, 0, item.cycle_depth))
                item.end = end
                yield item
                pos = end
                continue
            if item.kind is Kind.ARC:
                assert item.centre is not None
                centre = (fmt.units(item.centre[0]), fmt.units(item.centre[1]))
                self.check_capacity(item.block, centre, "IJ")
                pieces = self.split_arc(item, pos, end, centre)
                if not pieces:
                    carry_restart = item.restart
                    report.note(item.block, "an arc shorter than the tape's resolution is left out")
                yield from pieces
                if pieces:
                    pos = (end[0], end[1], end[2] if end[2] is not None else pos[2])
                continue
            same_z = end[2] is None or pos[2] is None or end[2] == pos[2]
            searched = item.search_feed or (item.kind is Kind.RAPID and item.restart)
            if (
                (end[0], end[1]) == (pos[0], pos[1])
                and same_z
                and not item.quill_cycle
                and not (searched and self.profile.tape_search)
            ):
                carry_restart = item.restart
                if item.kind is not Kind.RAPID:
                    report.note(item.block, "a move shorter than the tape's resolution is left out")
                continue
            item.end = end
            yield item
            pos = (end[0], end[1], end[2] if end[2] is not None else pos[2])

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
        a0 = math.atan2(sy - cy, sx - cx)
        if arc.full_circle:
            sweep = 2 * math.pi
        else:
            sweep = arc_sweep((sx, sy), (end[0], end[1]), (cx, cy), arc.clockwise)
        quarter = math.pi / 2
        axis_points = ((1, 0), (0, 1), (-1, 0), (0, -1))
        points: list[tuple[int, int]] = []
        if arc.clockwise:
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
            if point not in ((sx, sy), (end[0], end[1])) and (not points or point != points[-1]):
                points.append(point)
            k += step
        points.append((end[0], end[1]))
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


def with_starts(items: Iterator[Item], start: Point) -> Iterator[tuple[Item, Point]]:
    """Each item with where it starts (tape units), for the direction rules."""
    pos = start
    for item in items:
        yield item, pos
        if isinstance(item, Aux):
            if item.preset_z:
                pos = (pos[0], pos[1], 0)
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

    def lines(self, items: Iterator[tuple[Item, Point]]) -> Iterator[Line]:
        g: str | None = None
        pos: list[int | None] = [None, None, None]
        ij: list[int | None] = [None, None]
        feed: int | None = None
        s_code: str | None = None
        g99 = False
        carried: list[tuple[str, str]] = []
        last_block = 0
        ahead = iter(items)
        current = next(ahead, None)
        while current is not None:
            item, start = current
            following = next(ahead, None)
            last_block = item.block
            if isinstance(item, Aux):
                after = following[0] if following is not None else None
                if (
                    item.forward
                    and isinstance(after, Motion)
                    and after.kind is Kind.RAPID
                    and not any(letter == "G" for letter, _ in item.words)
                ):
                    carried.extend(
                        item.words if item.restate else spindle_words(item.words, s_code)
                    )
                    s_code = next((v for k, v in item.words if k == "S"), s_code)
                    current = following
                    continue
                if g99 and item.words[-1] in (("M", "30"), ("M", "02")):
                    yield self.line([("G", "98")], item.block)  # no drill cycle left on
                    g99 = False
                words = spindle_words(item.words, s_code)
                s_code = next((v for k, v in item.words if k == "S"), s_code)
                if words or item.comment:
                    yield self.line(words, item.block, item.comment, leader_after=item.leader_after)
                    if any(letter == "G" for letter, _ in words):
                        g = None  # G04 and G94 act in their block only; state the mode again
                    if item.preset_z:
                        pos[2] = 0
                current = following
                continue
            if following is None:
                self.choose_g(item, start, None, start)
            else:
                self.choose_g(item, start, following[0], following[1])
            if item.restart:
                pos = [None, None, None]
                ij = [None, None]
                g, feed = None, None
            if item.quill_cycle != g99:
                yield self.line([("G", "99" if item.quill_cycle else "98")], item.block)
                g99 = item.quill_cycle
                g = None  # state the motion mode again after the quill's G
            words = []
            if item.gcode != g:
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
            feed_before = feed
            if item.kind is not Kind.RAPID and item.feed != feed:
                words.append(("F", self.feed_word(item.feed)))
                feed = item.feed
            elif item.kind is Kind.RAPID and item.search_feed:
                words.append(("F", self.feed_word(item.search_feed)))
                feed = item.search_feed
            words.extend(carried)
            carried = []
            yield self.line(words, item.block, motion=item, start=start, feed_before=feed_before)
            g = item.gcode
            pos = [ex, ey, ez if ez is not None else pos[2]]
            current = following
        if g99:
            yield self.line([("G", "98")], last_block)

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


def spindle_words(words: list[tuple[str, str]], s_code: str | None) -> list[tuple[str, str]]:
    """Drop an S word that repeats the speed already set (S is modal)."""
    return [(k, v) for k, v in words if not (k == "S" and v == s_code)]


def check_reader(lines: Iterator[Line], fmt: TapeFormat, report: Report) -> Iterator[Line]:
    """The lines, checked as they pass for seed 000 §3 "Reader Limitation" (scan-damaged
    formulas, DESIGN.md's reading): T1 = 60·L / ((F1 + F2)/2) to execute a non-decelerated
    block, T2 = 0.010 + (N − 1)/300 to read the next one (N characters, its End of Block
    included); warn where T2 > T1."""
    previous: Line | None = None
    for line in lines:
        if previous is not None and previous.continuous and previous.length > 0:
            characters = len(line.text) + 1
            f1 = previous.feed_start * fmt.feed_unit_nm / fmt.unit_nm
            f2 = previous.feed_end * fmt.feed_unit_nm / fmt.unit_nm
            t1 = 60 * previous.length / ((f1 + f2) / 2)
            t2 = 0.010 + (characters - 1) / 300
            if t2 > t1:
                text = previous.text.split(" (")[0].replace(chr(9), " ")
                report.warning(
                    previous.block,
                    f"reader limitation: {text} moves {previous.length:.4f} "
                    f"{fmt.unit} in {t1:.3f} s but the next block ({characters} characters) "
                    f"takes {t2:.3f} s to read: the slides may stop and dwell (seed 000 §3)",
                    same="the same reader limitation",
                    at=text,
                )
        yield line
        previous = line
