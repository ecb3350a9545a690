"""The plan of a 1704 tape: the compiled path's moves become the blocks to punch (in nm).

Seed 000 §2-§4 and DESIGN.md §4 ("1704 motion rules", "Tool length") are the readings:

- Z is the control's own Z: each tool's tool-path Z plus its TCAL (the 1704 has no length
  offsets), or with `z-zero=g94` a G94 preset at each tool change.
- A hole the profile's fixed cycle makes the same way (DRILL without pecks: rapid down to
  Z UP, feed, dwell; BORE: the same and a feed back out) is one G81-G89 block with R at Z UP;
  the compiler's hole spans say where the holes are.
- Without circular interpolation, arcs are chords (seed 000 §3, Fig. 3-2).
- Every M code, dwell, preset, stop or tool change is its own block; a spindle start rides
  on the rapid that follows it.
- The first motion of the tape and the first after each tool change state every axis, the
  G and the F again (§4 "Tape Search"); with `tape-search` every data block that starts out
  of the work begins with a block the operator can search to.

`Planner.items()` yields the blocks one by one: each stage holds back the one item a later
move may still change, so the plan's memory does not grow with the program. Most blocks
(rapids, feeds, arcs, dwells) come in runs (`Run`, columns of up to `_RUN_ROWS` rows) that
every later stage handles with array operations, to what the items one by one would make
(issue 31: about 10 µs a block in Python stages before). Each stage
reports through its own `Report` (`stages`), so the export's report lists entries in the
order a whole-program pass would have added them.
"""

from __future__ import annotations

import bisect
import enum
import math
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass
from decimal import Decimal
from typing import Any

import numpy as np
import numpy.typing as npt

from app.cnc.blocks import HoleOp, Program
from app.cnc.formats.tape1704.codes import TapeCode
from app.cnc.formats.tape1704.profile import Profile
from app.cnc.formats.targets import Report
from app.cnc.formats.text import comment_text
from app.cnc.geometry import arc_points, chord_step
from app.cnc.needs import blocks_text
from app.cnc.path import TAGS, Chunk, CompiledPath, HoleSpan, Op, as_move
from app.cnc.sizes import ChordRows
from app.cnc.toolpath import (
    ArcFeed,
    CoolantOff,
    CoolantOn,
    Dwell,
    IndexTable,
    Message,
    Move,
    ProgramEnd,
    ProgramStop,
    SpindleOff,
    SpindleOn,
    ToolChange,
)
from app.cnc.units import Units, format_length


class Kind(enum.Enum):
    """What a motion block does."""

    RAPID = "rapid"  # G50
    LINE = "line"  # G00 / G01 at F
    ARC = "arc"  # G02 / G03 / G20 / G30 at F
    CYCLE = "cycle"  # G81-G89: to R, feed to Z, back to R


@dataclass
class Motion:
    """One motion block to be. Coordinates are nm until rounded, then tape units.

    `end` Z is the control's Z (TCAL applied), or None in a two-axis program: no Z word is
    written then. `tag` is the tool path's (`retract`, `peck-…`) for rapids.
    """

    block: int
    kind: Kind
    end: tuple[int, int, int | None]
    centre: tuple[int, int] | None = None
    clockwise: bool = False
    feed: int = 0
    full_circle: bool = False
    quill_cycle: bool = False
    cycle_code: int = 0
    cycle_depth: int = 0
    restart: bool = False
    z_only: bool = False
    tag: str = ""
    gcode: str = ""
    search_feed: int = 0  # a searched block states the feed in force (nm/min) on its rapid


@dataclass
class Aux:
    """A block without motion: M, S, T words, a dwell, a preset; `forward` M codes may ride
    on the rapid block that follows (seed 000 §3: put auxiliary words in another block when
    it does not change the machine's response)."""

    block: int
    words: list[tuple[str, str]]
    comment: str = ""
    forward: bool = False
    preset_z: bool = False
    leader_after: int = 0
    restate: bool = False  # restated for a tape search: its S is written even if the same


Item = Motion | Aux


RAPID, LINE, ARC, DWELL = 0, 1, 2, 3
"""A run's rows (`Run.kind`): a rapid, a feed, an arc at F (circular), a dwell (G04)."""


@dataclass
class Run:
    """Items one after another as columns, a row each: rapids, feeds, arcs (with circular
    interpolation) and dwells, most of a program's blocks. The stages handle them a slice
    of the compiled path at a time with array operations, to the same blocks and report
    entries as the items one by one (`items`), which is what a stage does with a run its
    columns do not cover.

    Coordinates in nm until rounded, then tape units; `z` is None in a two-axis program;
    `feed` is 0 on rapids and dwells; `tag` indexes `TAGS`; `cx`, `cy`, `clockwise` and
    `full` are an arc's (`Motion.full_circle`); `tenths` a dwell's G04 F; `restart` is the
    first motion's.
    """

    block: npt.NDArray[np.int64]
    kind: npt.NDArray[np.uint8]
    x: npt.NDArray[np.int64]
    y: npt.NDArray[np.int64]
    z: npt.NDArray[np.int64] | None
    feed: npt.NDArray[np.int64]
    tag: npt.NDArray[np.uint8]
    cx: npt.NDArray[np.int64]
    cy: npt.NDArray[np.int64]
    clockwise: npt.NDArray[np.bool_]
    full: npt.NDArray[np.bool_]
    tenths: npt.NDArray[np.int64]
    restart: bool = False

    def __len__(self) -> int:
        return len(self.block)

    def take(self, rows: Any, restart: bool) -> Run:
        """The rows `rows` (a slice or index array) as a run."""
        return Run(
            self.block[rows],
            self.kind[rows],
            self.x[rows],
            self.y[rows],
            None if self.z is None else self.z[rows],
            self.feed[rows],
            self.tag[rows],
            self.cx[rows],
            self.cy[rows],
            self.clockwise[rows],
            self.full[rows],
            self.tenths[rows],
            restart,
        )

    @staticmethod
    def joined(runs: list[Run]) -> Run:
        """`runs` one after another as one run (the first's restart)."""
        if len(runs) == 1:
            return runs[0]
        zs = [run.z for run in runs]
        return Run(
            np.concatenate([run.block for run in runs]),
            np.concatenate([run.kind for run in runs]),
            np.concatenate([run.x for run in runs]),
            np.concatenate([run.y for run in runs]),
            None if zs[0] is None else np.concatenate([z for z in zs if z is not None]),
            np.concatenate([run.feed for run in runs]),
            np.concatenate([run.tag for run in runs]),
            np.concatenate([run.cx for run in runs]),
            np.concatenate([run.cy for run in runs]),
            np.concatenate([run.clockwise for run in runs]),
            np.concatenate([run.full for run in runs]),
            np.concatenate([run.tenths for run in runs]),
            runs[0].restart,
        )

    def motions(self) -> npt.NDArray[np.intp]:
        """The rows that are motion (not dwells)."""
        return np.flatnonzero(self.kind != DWELL)

    def end(self) -> tuple[int, int, int | None] | None:
        """Where the last motion ends (None: the run has none)."""
        moving = self.motions()
        if not len(moving):
            return None
        k = int(moving[-1])
        return (int(self.x[k]), int(self.y[k]), None if self.z is None else int(self.z[k]))

    def start_of(self, row: int, start: tuple[int, int, int | None]) -> tuple[int, int, int | None]:
        """Where row `row` starts: the end of the last motion before it, else `start`."""
        moving = self.motions()
        moving = moving[moving < row]
        if not len(moving):
            return start
        k = int(moving[-1])
        z = start[2] if self.z is None else int(self.z[k])
        return (int(self.x[k]), int(self.y[k]), z)

    def items(self) -> list[Item]:
        """The run as the items it stands for."""
        count = len(self.block)
        zs: list[int | None] = [None] * count if self.z is None else self.z.tolist()
        items: list[Item] = []
        restart = self.restart
        for block, kind, x, y, z, feed, tag, cx, cy, clockwise, full, tenths in zip(
            self.block.tolist(),
            self.kind.tolist(),
            self.x.tolist(),
            self.y.tolist(),
            zs,
            self.feed.tolist(),
            self.tag.tolist(),
            self.cx.tolist(),
            self.cy.tolist(),
            self.clockwise.tolist(),
            self.full.tolist(),
            self.tenths.tolist(),
            strict=True,
        ):
            if kind == DWELL:
                items.append(Aux(block, [("G", "04"), ("F", str(tenths))]))
                continue
            if kind == RAPID:
                motion = Motion(block, Kind.RAPID, (x, y, z), tag=TAGS[tag])
            elif kind == LINE:
                motion = Motion(block, Kind.LINE, (x, y, z), feed=feed)
            else:
                motion = Motion(
                    block,
                    Kind.ARC,
                    (x, y, z),
                    centre=(cx, cy),
                    clockwise=clockwise,
                    feed=feed,
                    full_circle=full,
                )
            motion.restart, restart = restart, False
            items.append(motion)
        return items


Piece = Item | Run
"""What the stages pass on: an item, or a run of straight moves."""


_SLICE_ROWS = 1024
"""Rows of a chunk `Planner.planned` turns into Python lists at a time (memory, not speed)."""
_RUN_ROWS = 4096
"""The most rows `Planner.planned` joins into one run (each stage's arrays and texts for a
run are about 200 bytes a row)."""
_MIN_RUN_ROWS = 64
"""The fewest rows `Planner.planned` makes a run of (fewer go one by one)."""
_CYCLE_ROWS = 4
"""The most rows a fixed cycle stands for (`Planner.cycle`'s window: down, feed, dwell, out)."""
# The row ops as numpy compares a column with them: an IntEnum member costs numpy about 3 µs
# more a comparison than its int, and a long CAM file makes some 400 runs of a few hundred
# rows, each compared several times.
_OP_RAPID, _OP_FEED, _OP_ARC_CW, _OP_ARC_CCW, _OP_DWELL = (
    int(op) for op in (Op.RAPID, Op.FEED, Op.ARC_CW, Op.ARC_CCW, Op.DWELL)
)

COMMENT_CHARACTERS = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789 .,-+/:=*#")
"""What the 1704's ASCII table punches in a comment."""


def sanitize_comment(text: str) -> str:
    """Comment text the ASCII table can punch (the one comment rule, `comment_text`, with
    the table's characters; any other is a space), spaces run together."""
    return " ".join(comment_text(text.upper(), COMMENT_CHARACTERS, unknown=" ").split())


class Planner:
    """Compiled path + profile → the items of the tape, reporting as it goes. One use."""

    def __init__(
        self, program: Program, path: CompiledPath, profile: Profile, code: TapeCode
    ) -> None:
        self.program = program
        self.path = path
        self.profile = profile
        self.fmt = profile.fmt
        self.comments = code is TapeCode.ASCII
        self.two_axis = program.is_two_axis
        # One report per stage, in the order the stages come (see the module docstring).
        self.moves_report = Report("plan")
        self.restarts_report = Report("restarts")
        self.merge_report = Report("merge")
        # Runs of straight moves as columns (`Run`) where no stage needs the moves one by
        # one: a tape search looks ahead from each, xyz=together merges them, the quill's
        # drill cycle may change the rapid before its stop.
        self.runs = not (profile.tape_search or profile.xyz_together or profile.quill)
        self.chord_rows = ChordRows()

    @property
    def stages(self) -> list[Report]:
        return [self.moves_report, self.restarts_report, self.merge_report]

    def items(self) -> Iterator[Piece]:
        """The tape's items in order, in nm (see the module docstring), straight moves in
        runs (`Run`) where `runs`."""
        items = self.restarts(self.planned())
        return self.merged(items) if self.profile.xyz_together else items

    # -- Z --------------------------------------------------------------------------------

    def machine_z(self, z: int, tool: int) -> int | None:
        """The control's Z for tool-path Z `z` with `tool` (None in a two-axis program).

        With TCAL: Z + TCAL, an uncalibrated tool counting as TCAL 0 as the tool path does
        (toolpath.ToolChange), so head moves stay exact; only where its tip is is unknown.
        With G94: the tool's own Z, zero where the operator touched it off.
        """
        if self.two_axis:
            return None
        if self.profile.g94:
            return z
        info = self.path.tools.get(tool)
        return z + (0 if info is None or info.tcal is None else info.tcal)

    def uncalibrated(self, tool: int) -> bool:
        """True when Z words for `tool` cannot place its tip (TCAL mode, no TCAL)."""
        if self.two_axis or self.profile.g94 or tool == 0:
            return False
        info = self.path.tools.get(tool)
        return info is None or info.tcal is None

    # -- pass 1: moves → items ------------------------------------------------------------

    def planned(self) -> Iterator[Piece]:
        """The items of the moves, one move at a time but for runs of straight moves; the
        last item is held back while a quill stop after it may still make it the quill's
        drill cycle."""
        path, profile, report = self.path, self.profile, self.moves_report
        runs = self.runs
        tool = path.initial_tool
        x, y, z = path.start
        changes = 0
        warned_uncalibrated: set[int] = set()
        if profile.quill and not self.two_axis:
            report.error(
                _first_straight_block(path),
                "quill=yes is a two-axis 1704 with a quill actuator: it cannot move Z, and "
                "this program has depths",
            )
        items: list[Item] = []
        waiting: list[Run] = []
        waiting_rows = 0
        for chunk in path.chunks():
            cycles = self.cycles(chunk)
            cycle_rows = np.array(sorted(cycles), dtype=np.int64)
            rows, strings = chunk.rows, chunk.strings
            count = len(rows)
            # The chunk's rows as Python lists a slice at a time: a LOOP's chunk grows with
            # its repeats (11 250 rows at 2x10^5 moves), and the whole of it as lists was the
            # writer's memory growing with the program. A slice holds _CYCLE_ROWS more rows
            # than it starts, so a fixed cycle's rows (`cycle`) are always in it.
            # Runs take their rows as arrays: the lists are made when a row is not in one.
            index, base, limit = 0, 0, 0
            table: list[Any] | None = None
            simple: list[bool] = []
            breaks: list[int] = []
            one_by_one = 0  # the rows before it go one by one
            while index < count:
                if len(items) > 1:
                    yield from items[:-1]
                    del items[:-1]
                if index >= limit:
                    base, limit = index, min(count, index + _SLICE_ROWS)
                    table = None
                    if runs:
                        simple, breaks = _simple(rows, base, limit, cycle_rows, profile)
                if runs and index >= one_by_one and simple[index - base]:
                    stop = breaks[bisect.bisect_left(breaks, index)]
                    made = None
                    # A run of a few rows costs more in array operations than its rows one
                    # by one (dwell=no or circular=no cut runs at every hole or arc).
                    if (stop - index < _MIN_RUN_ROWS and not waiting) or self.uncalibrated(tool):
                        one_by_one = stop
                    else:
                        made = self.run(rows[index:stop], tool, (x, y, z))
                    if made is not None:
                        run, (x, y, z) = made
                        yield from items
                        items.clear()
                        # Runs one after another (across slices and chunks) go on as one,
                        # up to _RUN_ROWS: each array operation then covers more rows.
                        waiting.append(run)
                        waiting_rows += len(run)
                        if waiting_rows >= _RUN_ROWS:
                            yield from _joined(waiting)
                            waiting, waiting_rows = [], 0
                        index += len(run)
                        continue
                if table is None:
                    table = rows[base : limit + _CYCLE_ROWS].tolist()
                row = table[index - base]
                # An arc written as chords goes on the waiting run; any other row is an item.
                chordal = row[0] in (Op.ARC_CW, Op.ARC_CCW) and not (
                    profile.circular and row[5] == z
                )
                if waiting and not chordal:
                    yield from _joined(waiting)
                    waiting, waiting_rows = [], 0
                index += 1
                op = row[0]
                if op <= Op.ARC_CCW:
                    # Motion rows straight from the table (no Move object: most rows are
                    # motion, and making one each was a sixth of the tape's time).
                    _, tag, block, mx, my, mz_path, cx, cy, feed, _ = row
                    rapid = op == Op.RAPID
                    mz = self.machine_z(mz_path, tool)
                    if self.uncalibrated(tool):
                        if not rapid or mz_path < z:
                            report.error(
                                block,
                                f"tool {tool} is not calibrated (TCAL ****): its Z words cannot "
                                "place the tip for this move; calibrate it in Data Block 0 or "
                                "use z-zero=g94",
                            )
                        elif tool not in warned_uncalibrated:
                            warned_uncalibrated.add(tool)
                            report.warning(
                                block,
                                f"tool {tool} is not calibrated: its Z words take TCAL as 0, "
                                "so the tip's height above the part is not known",
                            )
                    if rapid:
                        span = cycles.get(index - 1)
                        cycle = self.cycle(span, table, index - 1 - base, (x, y, z), tool)
                        if cycle is not None:
                            motion, used, end_z = cycle
                            items.append(motion)
                            index += used - 1
                            x, y, z = motion.end[0], motion.end[1], end_z
                            continue
                        items.append(Motion(block, Kind.RAPID, (mx, my, mz), tag=TAGS[tag]))
                    elif op == Op.FEED:
                        items.append(Motion(block, Kind.LINE, (mx, my, mz), feed=feed))
                    elif profile.circular and mz_path == z:
                        items.append(
                            Motion(
                                block,
                                Kind.ARC,
                                (mx, my, mz),
                                centre=(cx, cy),
                                clockwise=op == Op.ARC_CW,
                                feed=feed,
                                full_circle=(mx, my) == (x, y),
                            )
                        )
                    else:
                        arc = as_move(row, strings)
                        assert isinstance(arc, ArcFeed)
                        if mz_path != z:
                            report.rewritten(
                                block,
                                "helical arc written as chords: the 1704's arcs stay in "
                                "one plane (seed 000 G20/G30: 'a canted arc or helical "
                                "motion cannot be generated')",
                            )
                        start_z = self.machine_z(z, tool)
                        chords = self.chords(arc, (x, y), start_z, mz, tool)
                        if runs:
                            yield from items
                            items.clear()
                            waiting.append(_chord_run(chords))
                            waiting_rows += len(chords)
                        else:
                            items.extend(chords)
                    x, y, z = mx, my, mz_path
                    continue
                move = as_move(row, strings)
                if isinstance(move, ProgramStop) and self.quill_hole(move, items, (x, y)):
                    continue
                items.extend(self.aux(move, changes))
                if isinstance(move, ToolChange):
                    # The head does not move; its height reads move.z with the new tool.
                    changes += 1
                    tool, z = move.tool, move.z
                    if profile.g94:
                        # Touched off at its zero, preset there, straight up before anything.
                        items.append(Aux(move.block, [("G", "94"), ("Z", "0")], preset_z=True))
                        items.append(Motion(move.block, Kind.RAPID, (x, y, z), z_only=True))
        yield from _joined(waiting)
        yield from items

    def run(
        self, rows: Any, tool: int, at: tuple[int, int, int]
    ) -> tuple[Run, tuple[int, int, int]] | None:
        """Rows of the compiled path `_simple` found (no fixed cycle's, `tool` calibrated or
        its Z words not needing it) as a run, what `planned` makes of each, and where the
        tool path is after them; `at` is where it is before. It stops before an arc that
        leaves its plane (chords); None when the first row is one."""
        ops = rows["op"]
        kind = np.full(len(ops), LINE, dtype=np.uint8)
        kind[ops == _OP_RAPID] = RAPID
        arcs = (ops == _OP_ARC_CW) | (ops == _OP_ARC_CCW)
        kind[arcs] = ARC
        dwell = ops == _OP_DWELL
        kind[dwell] = DWELL
        moving = ~dwell
        # Where each row starts: the last motion's end before it (dwells do not move).
        last = np.maximum.accumulate(np.where(moving, np.arange(len(ops)), -1))
        before = np.empty(len(ops), dtype=np.int64)
        before[0] = -1
        before[1:] = last[:-1]
        path_z = rows["z"]
        start_z = np.where(before >= 0, path_z[np.maximum(before, 0)], at[2])
        helical = np.flatnonzero(arcs & (path_z != start_z))
        if len(helical):
            if helical[0] == 0:
                return None
            return self.run(rows[: helical[0]], tool, at)
        x, y = rows["x"].astype(np.int64), rows["y"].astype(np.int64)
        start_x = np.where(before >= 0, x[np.maximum(before, 0)], at[0])
        start_y = np.where(before >= 0, y[np.maximum(before, 0)], at[1])
        z: npt.NDArray[np.int64] | None = None
        if not self.two_axis:
            z = path_z.astype(np.int64)
            if not self.profile.g94:
                info = self.path.tools.get(tool)
                if info is not None and info.tcal is not None:
                    z += info.tcal
        feeding = (kind == LINE) | arcs
        tenths = np.zeros(len(ops), dtype=np.int64)
        tenths[dwell] = _tenths(rows["value"][dwell])
        run = Run(
            rows["block"].astype(np.int64),
            kind,
            x,
            y,
            z,
            np.where(feeding, rows["feed"], 0).astype(np.int64),
            rows["tag"].copy(),
            rows["cx"].astype(np.int64),
            rows["cy"].astype(np.int64),
            ops == _OP_ARC_CW,
            arcs & (x == start_x) & (y == start_y),
            tenths,
        )
        final = int(last[-1])
        if final < 0:
            return run, at
        return run, (int(x[final]), int(y[final]), int(path_z[final]))

    def quill_hole(self, stop: ProgramStop, items: list[Item], at: tuple[int, int]) -> bool:
        """With the quill actuator, a two-axis hole is its drill cycle (G99): the rapid to
        the hole carries it, or M51 M50 cycle the quill where the table already is. TAP
        stays an operator stop (the quill cannot reverse the spindle). True when handled."""
        text = stop.reason.removeprefix("quill:").strip()
        if not (self.profile.quill and stop.reason.startswith("quill:")):
            return False
        if text.split()[0] not in ("DRILL", "BORE"):
            return False
        self.moves_report.rewritten(stop.block, f"{text}: the quill actuator's drill cycle (G99)")
        last = items[-1] if items else None
        if (
            isinstance(last, Motion)
            and last.kind is Kind.RAPID
            and (last.end[0], last.end[1]) == at
            and not last.quill_cycle
        ):
            last.quill_cycle = True
        else:
            items.append(Aux(stop.block, [("M", "51")]))
            items.append(Aux(stop.block, [("M", "50")]))
        return True

    def cycles(self, chunk: Chunk) -> dict[int, HoleSpan]:
        """The chunk's holes a fixed cycle may make, by the row of their rapid down to Z UP
        (none when the profile has no fixed cycle)."""
        profile = self.profile
        if not (profile.drill_cycle or profile.bore_cycle) or self.two_axis:
            return {}
        rows = chunk.rows
        found: dict[int, HoleSpan] = {}
        for span in chunk.hole_spans():
            if span.op is HoleOp.TAP:
                continue
            for k in range(span.start, span.end):
                op, tag, _, x, y, z = rows[k].tolist()[:6]
                if op == Op.RAPID and (x, y) == (span.x, span.y) and z == span.r:
                    if tag == 0:
                        found[k] = span
                    break
        return found

    def cycle(
        self,
        span: HoleSpan | None,
        table: list[Any],
        index: int,
        at: tuple[int, int, int],
        tool: int,
    ) -> tuple[Motion, int, int] | None:
        """The fixed-cycle block of the hole whose rapid down to Z UP is `table[index]`, the
        rows it stands for and the Z the tool is at after them; None when the profile's
        cycle does not make this hole the same way.

        DRILL: rapid down to Z UP, feed to Z DN, dwell (then the retract rapid, written as
        itself). BORE: the same with a feed back out to Z UP. The cycle's R plane is Z UP;
        the head starts above it (sequence 2 of seed 000 §4 "R Clearance Coordinate").
        """
        if span is None:
            return None
        profile = self.profile
        x, y, z = at
        window = table[index : index + 4]
        if len(window) < 3:
            return None
        down, feed, dwell = window[0], window[1], window[2]
        if not (
            down[0] == Op.RAPID
            and feed[0] == Op.FEED
            and dwell[0] == Op.DWELL
            and (down[3], down[4]) == (x, y)
            and down[5] < z
            and (feed[3], feed[4]) == (x, y)
            and feed[5] < down[5]
        ):
            if span.op is HoleOp.DRILL and span.pecks > 1 and profile.drill_cycle:
                self.moves_report.note(
                    down[2],
                    "pecked holes are written as moves: the 1704's deep-hole cycle pecks on "
                    "a timer, not at the program's levels",
                )
            return None
        out = window[3] if len(window) > 3 else None
        bore = out is not None and out[0] == Op.FEED and (out[3], out[4], out[5]) == (x, y, down[5])
        if span.op is HoleOp.DRILL and span.pecks == 1 and not bore:
            code = profile.drill_cycle
        elif span.op is HoleOp.BORE and bore:
            code = profile.bore_cycle
        else:
            return None
        if not code:
            return None
        r_plane = self.machine_z(down[5], tool)
        depth = self.machine_z(feed[5], tool)
        if r_plane is None or depth is None:
            return None
        seconds = Decimal(dwell[9]) / 1000
        self.moves_report.rewritten(
            down[2],
            f"hole as fixed cycle G{code} (R at Z UP): its dwell is the panel timer's "
            f"(1.3-12 s), not {seconds} s",
        )
        motion = Motion(
            down[2],
            Kind.CYCLE,
            (x, y, r_plane),
            feed=feed[8],
            cycle_code=code,
            cycle_depth=depth,
        )
        return (motion, 4, down[5]) if bore else (motion, 3, feed[5])

    def aux(self, move: Move, changes: int) -> list[Item]:
        """The blocks for a move that is not motion."""
        profile, report, block = self.profile, self.moves_report, move.block
        if isinstance(move, SpindleOn):
            words = [("M", "03" if move.clockwise else "04")]
            if profile.spindle_codes is None:
                speed = "no RPM" if move.rpm is None else f"spindle {move.rpm} rpm"
                report.note(block, f"{speed}: set by hand (no spindle speed option, no S)")
            elif move.rpm in profile.spindle_codes:
                words.insert(0, ("S", f"{profile.spindle_codes[move.rpm]:02d}"))
            else:
                report.error(block, f"spindle-codes has no S code for {move.rpm} rpm")
            return [Aux(block, words, forward=True)]
        if isinstance(move, SpindleOff):
            return [Aux(block, [("M", "05")])]
        if isinstance(move, ToolChange):
            return [self.tool_change(move, changes)]
        if isinstance(move, Dwell):
            if not profile.dwell:
                report.unsupported(block, f"dwell {move.seconds} s: no dwell option (G04)")
                return []
            tenths = int((move.seconds * 10).to_integral_value())
            if not 1 <= tenths <= 999:
                report.error(block, f"dwell {move.seconds} s is outside G04's 0.1-99.9 s")
            return [Aux(block, [("G", "04"), ("F", str(tenths))])]
        if isinstance(move, ProgramStop):
            return self.stop(move)
        if isinstance(move, IndexTable):
            if profile.index_m:
                return [Aux(block, [("M", f"{profile.index_m:02d}")])]
            report.rewritten(
                block,
                "INDEX: the 1704 has no index output; an operator stop (M00) lets the "
                "operator index the fixture (set index-m to the machine's M code)",
            )
            return [Aux(block, [("M", "00")], "INDEX THE FIXTURE" if self.comments else "")]
        if isinstance(move, CoolantOn):
            return [Aux(block, [("M", "08" if move.mode == "flood" else "07")])]
        if isinstance(move, CoolantOff):
            return [Aux(block, [("M", "09")])]
        if isinstance(move, Message):
            if self.comments:
                return [Aux(block, [], move.text)]
            report.unsupported(block, f"message {move.text!r}: EIA tape has no comments")
            return []
        assert isinstance(move, ProgramEnd)
        return [Aux(block, [("M", f"{profile.end_code:02d}")])]

    def tool_change(self, move: ToolChange, changes: int) -> Aux:
        profile, report = self.profile, self.moves_report
        words = [("M", "06")]
        if profile.tool_code_is_number:
            if move.tool > 99:
                report.error(move.block, f"tool {move.tool} has no two-digit T word")
            words.insert(0, ("T", f"{move.tool:02d}"))
        elif profile.tool_codes is not None:
            if move.tool in profile.tool_codes:
                words.insert(0, ("T", f"{profile.tool_codes[move.tool]:02d}"))
            else:
                report.error(move.block, f"tool-codes has no T code for tool {move.tool}")
        if profile.g94:
            report.note(
                move.block,
                f"tool {move.tool}: at M06 change the tool, touch it off at its Z zero, press "
                "CYCLE START; G94 presets Z to zero there",
            )
        described = self.tool_comment(move.tool)
        comment = described if self.comments else ""
        if not self.comments:
            report.note(move.block, f"M06: {described.lower()} (EIA carries no comment)")
        leader = profile.tool_change_rows if changes > 0 else 0
        return Aux(move.block, words, comment, leader_after=leader)

    def tool_comment(self, tool: int) -> str:
        """`TOOL 2 DIA 0.5000 TCAL -1.2500`: what a reader needs to know of a tool. TCAL only
        where the Z words include it (not with G94), so an importer subtracts what was added."""
        info = self.path.tools.get(tool)
        units = self.path.units
        parts = [f"TOOL {tool}"]
        if info is not None and info.diameter is not None:
            parts.append(f"DIA {format_length(info.diameter, units)}")
        if not self.profile.g94 and info is not None and info.tcal is not None:
            parts.append(f"TCAL {format_length(info.tcal, units)}")
        return " ".join(parts)

    def stop(self, move: ProgramStop) -> list[Item]:
        """STOP is M00; a two-axis program's quill stops use the quill actuator when the
        profile has it (M51 down, M50 up, G99 drill cycles), else M00 with the instruction."""
        report, block, reason = self.moves_report, move.block, move.reason
        if not reason.startswith("quill:"):
            return [Aux(block, [("M", "00")])]
        text = reason.removeprefix("quill:").strip()
        if self.profile.quill:
            if text.startswith("lower the quill"):
                return [Aux(block, [("M", "51")])]
            if text.startswith("raise the quill"):
                return [Aux(block, [("M", "50")])]
            report.rewritten(
                block,
                f"operator stop M00 ({text}): the quill's drill cycle cannot reverse the "
                "spindle to tap",
            )
        elif self.comments:
            report.rewritten(block, f"operator stop M00 with the instruction: {text}")
        else:
            report.rewritten(
                block, f"operator stop M00; EIA has no comments, so tell the operator: {text}"
            )
        return [Aux(block, [("M", "00")], text if self.comments else "")]

    def chords(
        self,
        arc: ArcFeed,
        start: tuple[int, int],
        start_z: int | None,
        mz: int | None,
        tool: int,
    ) -> list[Item]:
        """The chord method (seed 000 §3, Fig. 3-2): end points on the circle, equal steps.
        From `start_z` to `mz` (the machine's Z words; None: none written): on a helical
        arc, Z changes in proportion to the angle turned (app.cnc.geometry.arc_points).

        The tolerance is held on the part. The tool path does not say which side the
        material is on, so we take the side that errs more: the manual notes the part error
        exceeds the cutter-path error on inside contours, where the part radius is R + r.
        The cutter-path chord error e is kept to tol·R/(R + r), less what rounding the end
        points to the tape's resolution can add (half a step on each axis).
        """
        cx, cy = arc.cx, arc.cy
        radius = math.hypot(start[0] - cx, start[1] - cy)
        if radius == 0:
            return [Motion(arc.block, Kind.LINE, (arc.x, arc.y, mz), feed=arc.feed)]
        info = self.path.tools.get(tool)
        tool_radius = 0.0 if info is None or info.diameter is None else info.diameter / 2
        rounding = self.fmt.step_nm * math.sqrt(2) / 2
        allowed = self.profile.tolerance_nm * radius / (radius + tool_radius) - rounding
        if allowed <= 0:
            self.moves_report.error(
                arc.block,
                "the chord tolerance is finer than the tape's resolution can hold on this arc",
            )
            allowed = radius
        step = chord_step(radius, allowed)
        rise = 0 if mz is None or start_z is None else mz - start_z
        points = arc_points(
            (start[0], start[1], 0), (arc.x, arc.y, rise), (cx, cy), arc.clockwise, step
        )
        count = len(points)
        self.chord_rows.add(count, arc.block)
        motions: list[Item] = [
            Motion(
                arc.block,
                Kind.LINE,
                (px, py, None if mz is None else mz - rise + pz),
                feed=arc.feed,
            )
            for px, py, pz in points
        ]
        self.moves_report.rewritten(
            arc.block,
            f"arc written as {count} chords (no circular interpolation; chord tolerance "
            f"{format_length(self.profile.tolerance_nm, Units.INCH)} in on the part)",
            same="arcs written as chords",
        )
        return motions

    # -- restarts and tape search ---------------------------------------------------------

    def restarts(self, items: Iterator[Piece]) -> Iterator[Piece]:
        """The first motion of the tape and the first after each tool change write every
        axis (and G and F again): they are where an operator restarts or searches to.

        With tape-search (seed 000 §4: "include all data in the searched block … such as
        feedrate, spindle rotation, and coolant") every data block that starts out of the
        work begins with a block the operator can search to: a rapid with every axis, the
        spindle's S and M03/M04 and the feed of the block's first cut. The coolant's M code
        goes in the block before it (the 1704 takes one M code per block, §2), as at every
        spindle start. A block that continues a cut (a mill block after its DRILL, an arc)
        is not a place to restart — the tool would cut from wherever it was — so it gets
        no such group; the report names them.
        """
        pending = True
        searching = self.profile.tape_search
        spindle: Aux | None = None
        coolant: Aux | None = None
        last_block = -1
        start = self.path.start
        here: tuple[int, int, int | None] = (
            start[0],
            start[1],
            self.machine_z(start[2], self.path.initial_tool),
        )
        in_cut: list[int] = []  # data blocks that start in a cut: no restart there
        ahead = _Ahead(items)
        out: list[Piece] = []
        for item in ahead:
            if len(out) > 1:
                yield from out[:-1]
                del out[:-1]
            if isinstance(item, Run):
                # Made without tape search (Planner.runs): the first motion is where a
                # restart is pending, as for the items one by one below.
                last_block = int(item.block[-1])
                end = item.end()
                if end is not None:
                    item.restart = pending
                    pending = False
                    here = end
                out.append(item)
                continue
            if isinstance(item, Aux):
                codes = {value for letter, value in item.words if letter == "M"}
                if "06" in codes:
                    pending = True
                if codes & {"03", "04"}:
                    spindle = item
                elif "05" in codes:
                    spindle = None
                if codes & {"07", "08"}:
                    coolant = item
                    # Coolant first, so the spindle start rides on the positioning rapid.
                    if out and out[-1] is spindle:
                        out.insert(len(out) - 1, item)
                        continue
                elif "09" in codes:
                    coolant = None
                out.append(item)
                continue
            new_block = item.block != last_block
            last_block = item.block
            if searching and new_block and not item.z_only:
                feed = ahead.first_feed(item)
                if item.kind is not Kind.RAPID or item.tag == "retract":
                    in_cut.append(item.block)
                elif pending:
                    item.search_feed = feed  # after a tool change: it is the searched block
                else:
                    out += self.search_group(item, here, feed, spindle, coolant)
                    pending = True
            if not item.z_only:
                item.restart = pending
                pending = False
            out.append(item)
            end = item.end
            here = end if item.kind is not Kind.CYCLE else (end[0], end[1], here[2])
        yield from out
        if in_cut:
            self.restarts_report.note(
                None,
                f"tape search: {blocks_text(in_cut)} continue a cut and are no place to "
                "restart; search to the N of the block that starts the cut",
            )

    def search_group(
        self,
        item: Motion,
        here: tuple[int, int, int | None],
        feed: int,
        spindle: Aux | None,
        coolant: Aux | None,
    ) -> list[Item]:
        """The blocks before `item` that let the operator start the tape there (see
        `restarts`): the coolant, then the searched positioning where the tool is, carrying
        the spindle and the feed."""
        group: list[Item] = []
        if coolant is not None:
            group.append(Aux(item.block, list(coolant.words)))
        if spindle is not None:
            # S (when a spindle code table gives one) and M03/M04 ride on the searched block.
            group.append(Aux(item.block, list(spindle.words), forward=True, restate=True))
        group.append(Motion(item.block, Kind.RAPID, here, restart=True, search_feed=feed))
        return group

    def merged(self, items: Iterator[Piece]) -> Iterator[Piece]:
        """xyz=together (seed 002 XYZ/ON): the positioning rapids of one block (up, across,
        down) become one XYZ move. A retract out of the work (tagged `retract`, `peck-…`)
        is never merged: it stays straight up."""

        def positioning(item: Piece | None) -> bool:
            return (
                isinstance(item, Motion)
                and item.kind is Kind.RAPID
                and not item.quill_cycle
                and not item.z_only
                and not item.tag
            )

        previous: Piece | None = None
        for item in items:
            if (
                positioning(item)
                and positioning(previous)
                and isinstance(item, Motion)
                and isinstance(previous, Motion)
                and previous.block == item.block
            ):
                previous.end = item.end
                self.merge_report.rewritten(
                    item.block,
                    "positioning in one XYZ rapid (xyz=together): check the clearance, the "
                    "head no longer rises before it moves across",
                )
                continue
            if previous is not None:
                yield previous
            previous = item
        if previous is not None:
            yield previous


class _Ahead:
    """Items one at a time, with a look ahead into the rest of a data block (those items
    wait here until their turn)."""

    def __init__(self, items: Iterator[Piece]) -> None:
        self.source = items
        self.waiting: deque[Piece] = deque()

    def __iter__(self) -> Iterator[Piece]:
        while True:
            if self.waiting:
                yield self.waiting.popleft()
                continue
            found = next(self.source, None)
            if found is None:
                return
            yield found

    def first_feed(self, item: Item) -> int:
        """The feed (nm/min) of the first cut of the data block whose first motion is
        `item` (the one just taken; 0 when the block does not cut)."""
        if isinstance(item, Motion) and item.kind is not Kind.RAPID:
            return item.feed
        k = 0
        while True:
            if k == len(self.waiting):
                found = next(self.source, None)
                if found is None:
                    return 0
                self.waiting.append(found)
            following = self.waiting[k]
            assert not isinstance(following, Run)  # no runs with tape search (Planner.runs)
            if following.block != item.block:
                return 0
            if isinstance(following, Motion) and following.kind is not Kind.RAPID:
                return following.feed
            k += 1


def _joined(runs: list[Run]) -> Iterator[Piece]:
    """`runs` as one run, or as their items when they are too few rows to be worth one."""
    if not runs:
        return
    run = Run.joined(runs)
    if len(run) >= _MIN_RUN_ROWS:
        yield run
    else:
        yield from run.items()


def _chord_run(chords: list[Item]) -> Run:
    """An arc's chords (`Planner.chords`: feeds of one block) as a run."""
    motions = [chord for chord in chords if isinstance(chord, Motion)]
    count = len(motions)
    zeros = np.zeros(count, dtype=np.int64)
    ends = [motion.end for motion in motions]
    z: npt.NDArray[np.int64] | None = None
    if count and ends[0][2] is not None:
        z = np.array([end[2] for end in ends], dtype=np.int64)
    return Run(
        np.array([motion.block for motion in motions], dtype=np.int64),
        np.full(count, LINE, dtype=np.uint8),
        np.array([end[0] for end in ends], dtype=np.int64),
        np.array([end[1] for end in ends], dtype=np.int64),
        z,
        np.array([motion.feed for motion in motions], dtype=np.int64),
        np.zeros(count, dtype=np.uint8),
        zeros,
        zeros,
        np.zeros(count, dtype=np.bool_),
        np.zeros(count, dtype=np.bool_),
        zeros,
    )


def _tenths(ms: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """Dwells of `ms` milliseconds in tenths of a second, rounded half-even (`aux`'s G04 F:
    Decimal's to_integral_value of the seconds times ten)."""
    quotient, remainder = np.divmod(ms.astype(np.int64), 100)
    twice = 2 * remainder
    quotient += (twice > 100) | ((twice == 100) & (quotient % 2 == 1))
    result: npt.NDArray[np.int64] = quotient
    return result


def _simple(
    rows: Any, base: int, limit: int, cycle_rows: npt.NDArray[np.int64], profile: Profile
) -> tuple[list[bool], list[int]]:
    """Which rows [base, limit) of a chunk a run may hold (rapids and feeds, not the rapid
    of a fixed cycle's hole; arcs with circular interpolation; dwells G04 can carry), and
    the rows from base on that end a run, `limit` last."""
    part = rows[base:limit]
    ops = part["op"]
    straight = ops <= _OP_FEED
    if profile.circular:
        straight |= (ops == _OP_ARC_CW) | (ops == _OP_ARC_CCW)
    if profile.dwell:
        dwells = np.flatnonzero(ops == _OP_DWELL)
        tenths = _tenths(part["value"][dwells])
        straight[dwells[(tenths >= 1) & (tenths <= 999)]] = True
    inside = cycle_rows[(cycle_rows >= base) & (cycle_rows < limit)]
    straight[inside - base] = False
    breaks = (np.flatnonzero(~straight) + base).tolist()
    breaks.append(limit)
    return straight.tolist(), breaks


def _first_straight_block(path: CompiledPath) -> int:
    """The block of the first rapid or feed (0 when there is none)."""
    for chunk in path.chunks():
        straight = chunk.rows["op"] <= Op.FEED
        if straight.any():
            return int(chunk.rows["block"][straight.argmax()])
    return 0
