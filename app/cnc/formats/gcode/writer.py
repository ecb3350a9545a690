"""G-code targets: LinuxCNC RS274/NGC, Fanuc 6M, and the ProtoTRAK "modified Fanuc 6".

One writer walks the compiled path chunk by chunk with the control's modal state (only
words that change are written) and writes lines as it goes; a `Dialect` (dialects.py) says
what differs (seed 003 §2.1 for the ProtoTRAK: a G code on every line, spaces between
words, `;` at the end of each block). The G/M codes are those of seed 003's RS274/NGC and
Fanuc tables. Lengths are written from integers (`emit.text.Lengths`): a chunk's X, Y, Z, I
and J columns are rounded at once and each distinct value is formatted once.

Canned cycles are written only where the cycle's motion is identical to the block's
(DESIGN.md §4): the compiler marks such holes (`HoleSpan.canned`: an optional rapid across
at the height the hole starts from, a rapid down to Z UP, the feeds and pecks, the dwell, a
rapid back up there), and a DRILL hole without pecks is written `G98 G82 R<Z UP> Z<Z DN>
P…` (the 0.8 s dwell in the dialect's unit); a hole whose moves differ (a retract height
that changed on the way) is written as explicit moves. Pecks (ours return to the level just
cut; G83 backs off above it) and TAP's feed-out to Z UP + 0.3 in are explicit moves unless
the user accepts G83 (`peck-cycle=G83`, for evenly spaced pecks), which the compatibility
report then states.

Part zero and tool lengths are the machine's own settings (DESIGN.md §1: an output never
changes them unless asked): every dialect states them as set-up comments (G54 = part zero
from table zero, each tool's length = its TCAL) and in the report, which the set-up sheet
prints, and applies them with `G43 H` at each tool change. LinuxCNC's `write-offsets=yes`
writes them as `G10 L2 P1` (G54) and `G10 L1` (the tool table), reported as a warning since
they persist on the machine.

Dwell belongs to the dialect: LinuxCNC reads G4 P and G82 P in seconds; a Fanuc reads P in
whole milliseconds (P800) and G04 X in seconds.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from decimal import Decimal
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from app.cnc.blocks import HoleOp, Program
from app.cnc.compiler import peck_levels
from app.cnc.formats.gcode.dialects import FANUC, LINUXCNC, PROTOTRAK, Dialect, dialect_options
from app.cnc.formats.targets import Out, Remedy, Report, Target, register
from app.cnc.formats.text import Lengths, Lines, comment_text
from app.cnc.geometry import arc_points, chord_step
from app.cnc.limits import HELIX_CHORD_INCH, HOLE_DWELL_SECONDS
from app.cnc.motions import is_motion
from app.cnc.path import TAGS, Chunk, CompiledPath, HoleSpan, Op, distinct
from app.cnc.problems import Need
from app.cnc.sizes import ChordRows
from app.cnc.units import Units, to_nm

# A row of a chunk as a tuple (path.MOVE's fields, in order).
Row = tuple[int, int, int, int, int, int, int, int, int, int]


class GcodeTarget(Target):
    """Shared writer; subclasses set `dialect` and the target attributes."""

    dialect: ClassVar[Dialect]
    extension = "ngc"
    needs = frozenset({Need.SPINDLE_SPEEDS})
    reads_back: ClassVar[str | None] = "gcode"
    common = ("sequence-numbers", "canned-cycles", "spindle-speeds", "end-code")

    def needs_for(self, options: Mapping[str, Any]) -> frozenset[Need]:
        # S words need speeds, unless the operator sets them by hand (reported).
        return frozenset() if options.get("spindle-speeds") == "by-hand" else self.needs

    def need_remedy(self, need: Need) -> Remedy | None:
        if need is Need.SPINDLE_SPEEDS:
            return Remedy("spindle-speeds", "by-hand", "set them at the control")
        return None

    def write(
        self,
        program: Program,
        path: CompiledPath,
        options: Mapping[str, Any],
        report: Report,
        out: Out,
    ) -> None:
        lines = Lines(out)
        Writer(self.dialect, program, path, options, report, lines.add, bulk=lines.add_many).write()
        lines.flush()


@register
class LinuxcncTarget(GcodeTarget):
    name = "gcode-linuxcnc"
    label = "LinuxCNC G-code"
    description = "RS274/NGC as LinuxCNC reads it"
    dialect = LINUXCNC
    options = dialect_options(LINUXCNC)


@register
class FanucTarget(GcodeTarget):
    name = "gcode-fanuc"
    label = "Fanuc 6M G-code"
    description = "Fanuc 6M (% and O number, N numbers, no spaces)"
    dialect = FANUC
    # Its own name beside the LinuxCNC file of the same part (part.ngc, part.fanuc.nc).
    extension = "fanuc.nc"
    options = dialect_options(FANUC)


@register
class PrototrakTarget(GcodeTarget):
    name = "gcode-prototrak"
    label = "ProtoTRAK G-code (modified Fanuc 6)"
    description = "ProtoTRAK Plus modified Fanuc 6 (G on every line, spaces, ; end of block)"
    dialect = PROTOTRAK
    extension = "prototrak.nc"
    options = dialect_options(PROTOTRAK)


class Writer:
    """Walks the compiled path once, keeping the modal state of the control, and hands each
    line to `emit` as it is made.

    `z_lift(tool)` is what the Z words add to the tool path's Z for a tool (0 for every
    dialect with length offsets; a tape without them adds the TCAL)."""

    def __init__(
        self,
        dialect: Dialect,
        program: Program,
        path: CompiledPath,
        options: Mapping[str, Any],
        report: Report,
        emit: Callable[[str], None],
        z_lift: Callable[[int], int] | None = None,
        bulk: Callable[[list[str]], None] | None = None,
    ) -> None:
        self.d = dialect
        self.program = program
        self.path = path
        self.o = options
        self.report = report
        self.chord_rows = ChordRows()
        self.emit = emit
        # Where many lines go at once (straight moves written a run at a time); None: one
        # line at a time through `emit`, for writers that watch every line.
        self.bulk = bulk
        self.z_lift = z_lift or (lambda tool: 0)
        self.units: Units = path.units
        self.lengths = Lengths(path.units)
        self.drop_zeros = options["trailing-zeros"] == "drop"
        self.number = int(options["sequence-start"])
        self.separator = "\t" if options["tabs"] else (" " if dialect.spaces else "")
        self.motion: str | None = None
        self.feed: int | None = None
        self.cycle: tuple[str, ...] | None = None  # words of the active canned cycle
        self.xy_known = True
        self.tool = path.initial_tool
        self.lift = self.z_lift(self.tool)
        x, y, z = path.start
        # Where the control is: nm, and as written.
        self.x, self.y, self.z = x, y, z + self.lift
        self.wx, self.wy, self.wz = self.length(x), self.length(y), self.length(self.z)
        self.lines = 0  # lines emitted
        self.bulk_rows = BULK_ROWS
        # The start (`start`): until the first position is written, the tool path's Z-only
        # rapids are held back and the highest of them is where the entry comes down to.
        self.entering = False
        self.entry_z = self.z
        self.entry_fresh = False  # a tool change before the entry: the next rapid sets it

    # -- words and lines ------------------------------------------------------------------

    def code(self, letter: str, value: int) -> str:
        return f"{letter}{value:02d}" if self.d.two_digit_codes else f"{letter}{value}"

    def length(self, nm: int) -> str:
        return self.shown(self.lengths.one(nm))

    def shown(self, text: str) -> str:
        """A length's text as the trailing-zeros option wants it."""
        if self.drop_zeros:
            text = text.rstrip("0")
            return "0" if text in ("0.", "-0.") else text
        return text

    def feed_value(self, nm_per_min: int) -> str:
        text = self.lengths.one(nm_per_min).rstrip("0")
        return text + "0" if text.endswith(".") else text

    def out(self, text: str) -> None:
        self.emit(text)
        self.lines += 1

    def line(self, *words: str, comment: str = "") -> None:
        """One block: N number, words, comment, end of block."""
        parts = [w for w in words if w]
        if self.o["sequence-numbers"]:
            if self.number > self.d.largest_line_number:
                start = int(self.o["sequence-start"])
                self.report.note(
                    None,
                    f"N numbers restart at N{start} after N{self.d.largest_line_number}: the "
                    f"control's line numbers run 0-{self.d.largest_line_number}",
                )
                self.number = start
            parts.insert(0, f"N{self.number}")
            self.number += int(self.o["sequence-increment"])
        if comment:
            parts.append(f"({comment_text(comment)})")
        self.out(self.separator.join(parts) + self.d.end_of_block)

    def comment(self, text: str) -> None:
        self.out(f"({comment_text(text)}){self.d.end_of_block}")

    # -- the program --------------------------------------------------------------------

    def write(self) -> None:
        self.header()
        cycles = bool(self.o["canned-cycles"])
        for chunk in self.path.chunks():
            self.write_chunk(chunk, cycles)
        self.end_cycle()
        self.finish()

    def finish(self) -> None:
        self.out("%")

    def write_chunk(self, chunk: Chunk, cycles: bool) -> None:
        rows = chunk.rows
        ops = rows["op"]
        lift = self.lifts(rows)
        z = rows["z"] + lift if lift is not None else rows["z"]
        shown = self.shown if self.drop_zeros else None
        xs = self.lengths.column(rows["x"], shown)
        ys = self.lengths.column(rows["y"], shown)
        zs = self.lengths.column(z, shown)
        spans = chunk.hole_spans() if cycles else []
        holes = {span.start: span for span in spans}
        # Rapids, feeds and dwells outside the holes that may be cycles go in runs, a run
        # at a time.
        straight = (ops <= Op.FEED) | (ops == Op.DWELL)
        for hole in spans:
            if self.may_cycle(hole):
                straight[hole.start : hole.end] = False
        bulk = self.bulk is not None
        # Rows as tuples for `move`: all of them at once when every row goes that way, else
        # a short run's at once and one at a time for the others.
        table = None if bulk else rows.tolist()
        run_end = _run_ends(straight) if bulk else None
        i = 0
        n = len(rows)
        while i < n:
            if run_end is not None and straight[i] and self.xy_known:
                self.end_cycle()
                end = int(run_end[i])
                if end - i < self.bulk_rows:
                    # A short run: row by row (a hole among them is no cycle), from lists.
                    for each, wx, wy, wz, at in zip(
                        rows[i:end].tolist(),
                        xs[i:end].tolist(),
                        ys[i:end].tolist(),
                        zs[i:end].tolist(),
                        z[i:end].tolist(),
                        strict=True,
                    ):
                        self.move(each, wx, wy, wz, at, chunk)
                    i = end
                    continue
                i += self.straight_run(rows[i:end], xs[i:end], ys[i:end], zs[i:end], z[i:end])
                if i == end:
                    continue
                # The row at i is the line whose number passes the dialect's largest: `move`
                # writes it and restarts the numbers.
            row: Row = table[i] if table is not None else rows[i].tolist()
            span = holes.get(i)
            if span is not None:
                used = self.canned_cycle(span, row[2], int(z[span.end - 1]))
                if used:
                    i = span.end
                    continue
            self.end_cycle()
            self.move(row, str(xs[i]), str(ys[i]), str(zs[i]), int(z[i]), chunk)
            i += 1

    def straight_run(self, rows: Any, xs: Any, ys: Any, zs: Any, z: npt.NDArray[np.int64]) -> int:
        """Write a run of rapids, feeds and dwells (`rows`, with the written X Y Z of each)
        in one go, as `move` writes them one by one: numpy finds the words that change and
        makes the lines. Returns how many rows it wrote: all, or those before the line whose
        number would pass the dialect's largest (`move` writes that one, restarting them)."""
        ops = rows["op"]
        moving = np.flatnonzero(ops <= Op.FEED)
        mx, my, mz = xs[moving], ys[moving], zs[moving]
        changed = [
            column != np.concatenate(([current], column[:-1]))
            for column, current in ((mx, self.wx), (my, self.wy), (mz, self.wz))
        ]
        said = changed[0] | changed[1] | changed[2]
        # The rows that make a line: moves that change a written axis, and every dwell.
        lines = np.sort(np.concatenate((moving[said], np.flatnonzero(ops == Op.DWELL))))
        count = len(lines)
        if self.o["sequence-numbers"]:
            step = int(self.o["sequence-increment"])
            room = max(0, (self.d.largest_line_number - self.number) // step + 1)
            if count > room:
                # Write the rows before the first line without a number left (none of them
                # makes a line past the room), and stop there.
                end = int(lines[room])
                return self.straight_run(rows[:end], xs[:end], ys[:end], zs[:end], z[:end])
        if count:
            self.bulk_lines(rows, lines, said, changed, (mx, my, mz))
        if len(moving):
            last = moving[-1]
            self.x, self.y, self.z = int(rows["x"][last]), int(rows["y"][last]), int(z[last])
            self.wx, self.wy, self.wz = str(mx[-1]), str(my[-1]), str(mz[-1])
        return len(rows)

    def bulk_lines(
        self,
        rows: Any,
        lines: npt.NDArray[np.intp],
        said: npt.NDArray[np.bool_],
        changed: list[npt.NDArray[np.bool_]],
        written: tuple[Any, Any, Any],
    ) -> None:
        """The lines of a run (`lines`: its rows that make one), as `straight_run` found
        them."""
        count = len(lines)
        ops = rows["op"][lines]
        codes = ops.astype(np.int64)
        # Which lines are moves (the others are dwells), and where they are among the lines.
        is_move = ops != Op.DWELL
        move_lines = np.flatnonzero(is_move)
        empty = np.full(count, "", dtype=object)
        g = empty.copy()
        motion = codes[is_move]
        before = np.concatenate(([_MOTION.get(self.motion or "", -1)], motion[:-1]))
        new = np.ones(len(motion), dtype=bool) if self.d.g_on_every_line else motion != before
        mode = np.where(motion == Op.RAPID, self.code("G", 0), self.code("G", 1))
        g[move_lines[new]] = mode[new]
        dwelling = ops == Op.DWELL
        g[dwelling] = self.code("G", 4)
        p = empty.copy()
        values = rows["value"][lines][dwelling]
        texts = {v: self.d.dwell(Decimal(v) / 1000, cycle=False) for v in distinct(values).tolist()}
        p[dwelling] = [texts[v] for v in values.tolist()]
        f = empty.copy()
        feeding = np.flatnonzero(ops == Op.FEED)
        if len(feeding):
            feeds = rows["feed"][lines][feeding]
            previous = np.concatenate(([-1 if self.feed is None else self.feed], feeds[:-1]))
            fresh = feeds != previous
            words = {v: f"F{self.feed_value(v)}" for v in distinct(feeds[fresh]).tolist()}
            f[feeding[fresh]] = [words[v] for v in feeds[fresh].tolist()]
            self.feed = int(feeds[-1])
        axes = []
        for letter, column, change in zip("XYZ", written, changed, strict=True):
            word = empty.copy()
            picked = change[said]
            word[move_lines[picked]] = np.strings.add(letter, column[said][picked]).astype(object)
            axes.append(word)
        columns = [g, *axes, f, p]
        if self.o["sequence-numbers"]:
            step = int(self.o["sequence-increment"])
            numbers = self.number + step * np.arange(count)
            columns.insert(0, np.strings.add("N", numbers.astype(str)).astype(object))
            self.number += step * count
        sep = self.separator
        text = empty.copy()
        for column in columns:
            text = np.where(column != "", text + column + sep, text)
        if sep:
            text = np.strings.rstrip(text.astype(str), sep).astype(object)
        if self.d.end_of_block:
            text = text + self.d.end_of_block
        assert self.bulk is not None
        self.bulk(text.tolist())
        self.lines += count
        if len(motion):
            self.motion = "0" if motion[-1] == Op.RAPID else "1"

    def lifts(self, rows: Any) -> Any:
        """What each row's Z words add (the z_lift of the tool in the spindle), or None
        when nothing is added."""
        ops = rows["op"]
        changes = np.flatnonzero(ops == Op.TOOL)
        if not len(changes) and self.lift == 0:
            return None
        tools = np.full(len(rows), self.tool, dtype=np.int64)
        for k in changes.tolist():
            tools[k:] = rows["value"][k]
        found = distinct(tools)
        lifts = {int(t): self.z_lift(int(t)) for t in found.tolist()}
        if not any(lifts.values()):
            return None
        return np.array([lifts[int(t)] for t in found.tolist()], dtype=np.int64)[
            np.searchsorted(found, tools)
        ]

    def header(self) -> None:
        p = self.program
        label = p.name.upper() if p.name else "MILLBLOCKS"
        # The ProtoTRAK sample (seed 003 §2.2.6.2) opens with `%:LABEL;`; LinuxCNC's reader,
        # our referee, takes `%` only alone on its line, so the label follows as a comment.
        self.out("%")
        if self.d.program_number:
            number = int(p.part_number[-4:]) if p.part_number else 1
            self.out(f"O{number:04d}")
        self.comment(f"{label} PART {p.part_number or '-'} MILLBLOCKS")
        units = self.code("G", 20 if self.units is Units.INCH else 21)
        g = self.code
        self.line(g("G", 17), units, g("G", 40), g("G", 80), g("G", 90), g("G", 94))
        used, cuts_in_z = self.survey()
        self.setup(used)
        for number in sorted(used):
            info = self.path.tools.get(number)
            if info is not None and info.tcal is None and cuts_in_z:
                self.report.warning(
                    None,
                    f"tool {number} is uncalibrated: its Z words are measured from wherever "
                    "the operator sets its length",
                )
        self.start()

    # -- the start ------------------------------------------------------------------------

    def start(self) -> None:
        """The safe start, as a CAM post for a Fanuc-style machining centre writes it (and
        seed 003 §2.2.6.2, the ProtoTRAK's sample, brings each tool in):

            G91 G28 Z0 / G90     Z straight up to the reference point (start-retract)
            T1 M6                the first tool (tool-change)
            S… M3                the spindle, where the program starts it
            G0 X… Y…             across to the first position, at that height
            G43 Z… H1            the length offset with the first Z: down to the clearance

        Where the spindle is when the operator presses cycle start is unknown, so nothing
        moves down before the first X/Y position: the G28 retract only goes up (to the top
        of Z travel on a mill homed there; LinuxCNC's stored G28 position, machine home
        unless G28.1 set another), and the first Z is written with G43, after the move
        across. The tool path's own first moves (Z-only rapids at part zero up to its
        clearance) are not written: the entry takes the highest of them.

        The writer holds the entry until the first motion (`enter`): the spindle and
        coolant the program starts before it stay where they are."""
        if self.o.get("start-retract", True):
            self.line(self.code("G", 91), self.code("G", 28), "Z0")
            self.line(self.code("G", 90))
        tool = self.path.initial_tool
        if tool and self.o.get("tool-change") and not self.changes_first():
            self.line(f"T{tool}", self.code("M", 6))
        self.entering = True
        self.entry_z = self.z
        self.xy_known = False
        self.motion = None

    def changes_first(self) -> bool:
        """Whether the tool path changes tools before its first position (then that change
        calls the first tool). Only the rows up to there are read."""
        for chunk in self.path.chunks():
            rows = chunk.rows
            for op, x, y in zip(
                rows["op"].tolist(), rows["x"].tolist(), rows["y"].tolist(), strict=True
            ):
                if op == Op.TOOL:
                    return True
                if op <= Op.ARC_CCW and not self.absorbs(op, x, y):
                    return False
        return False

    def absorbs(self, op: int, x: int, y: int) -> bool:
        """Whether a row before the entry is a Z-only rapid at the start's X/Y: the tool
        path rising (or settling) to its clearance where the spindle may not be."""
        return op == Op.RAPID and (x, y) == (self.x, self.y)

    def enter(self, x: int, y: int, z: int) -> None:
        """The first position: across to (x, y) at the height the tool is at, then down to
        the entry height with the first tool's length offset, then (when the tool path
        went lower at its start) down to `z`, where the tool path is."""
        self.entering = False
        self.xy_known = True
        wx, wy = self.length(x), self.length(y)
        self.line(self.motion_word("0"), f"X{wx}", f"Y{wy}")
        self.x, self.y, self.wx, self.wy = x, y, wx, wy
        clear = self.length(self.entry_z)
        tool = self.tool
        if tool:
            self.line(
                self.motion_word("0"),
                self.code("G", 43),
                f"Z{clear}",
                self.code("H", tool),
            )
        else:
            self.line(self.motion_word("0"), f"Z{clear}")
        self.report_start(x, y, clear, tool)
        self.z, self.wz = self.entry_z, clear
        if z != self.entry_z:
            wz = self.length(z)
            if wz != self.wz:
                self.line(self.motion_word("0"), f"Z{wz}")
            self.z, self.wz = z, wz

    def report_start(self, x: int, y: int, clear: str, tool: int) -> None:
        """Where the tool must be when the program starts (the report, and so the set-up
        sheet)."""
        offset = f" with {self.code('G', 43)} {self.code('H', tool)}" if tool else ""
        to = f"X{self.length(x)} Y{self.length(y)}"
        if self.o.get("start-retract", True):
            self.report.note(
                None,
                f"start: the first move is Z straight up to the machine's reference point "
                f"({self.code('G', 91)} {self.code('G', 28)} Z0: where the control's G28 "
                f"returns, the top of Z travel on a mill homed there), then across to {to} "
                f"at that height, then down to Z{clear}{offset}; start with the tool where it can "
                "rise straight up",
            )
        else:
            self.report.warning(
                None,
                f"start: start with the tool above the part at Z{clear} or higher (clear of "
                f"every clamp): the first move is across to {to} at the height the tool is "
                f"at, then down to Z{clear}{offset} (start-retract=no)",
            )

    def survey(self) -> tuple[set[int], bool]:
        """The tools the program uses, and whether any rapid or feed leaves the start Z."""
        used = {self.path.initial_tool} if self.path.initial_tool else set()
        start_z = self.path.start[2]
        cuts = False
        for chunk in self.path.chunks():
            ops = chunk.rows["op"]
            used.update(chunk.rows["value"][ops == Op.TOOL].tolist())
            straight = ops <= Op.FEED
            cuts = cuts or bool(np.any(chunk.rows["z"][straight] != start_z))
        return used, cuts

    def setup(self, used_tools: set[int]) -> None:
        """Part zero and tool lengths: set-up comments and report notes, or (write-offsets)
        G10 lines that set them on the machine."""
        ox, oy = self.path.origin
        lengths = self.lengths.one
        offset = f"X{lengths(ox)} Y{lengths(oy)}"
        write = bool(self.o.get("write-offsets"))
        g54 = self.code("G", 54)
        self.comment(f"SET-UP: {g54} = PART ZERO AT TABLE {offset}")
        self.report.note(None, f"set-up: {g54} must hold part zero, table {offset}")
        used = sorted(n for n in self.path.tools if n in used_tools)
        for number in used:
            tool = self.path.tools[number]
            # The diameter too: cutter compensation and routines were planned with it, and an
            # importer needs it to read the tool-centre path back as the blocks it came from.
            dia = "" if tool.diameter is None else f" DIA {lengths(tool.diameter)}"
            if tool.name:
                # What the shop calls it, on a line of its own: the diameter and length
                # comment below stays as readers know it.
                self.comment(f"SET-UP: T{number} IS {tool.name}")
            if tool.tcal is None:
                length = "measured (uncalibrated)"
                self.comment(
                    f"SET-UP: T{number}{dia} LENGTH H{number:02d}: UNCALIBRATED, MEASURE IT"
                )
            else:
                length = lengths(tool.tcal)
                self.comment(f"SET-UP: T{number}{dia} LENGTH H{number:02d} = {length}, ITS TCAL")
            self.report.note(
                None,
                f"set-up: the length of T{number} (H{number:02d}) must be "
                + (length if tool.tcal is None else f"{length}, its TCAL"),
            )
        if not write:
            return
        self.line("G10", "L2", "P1", f"X{self.length(ox)}", f"Y{self.length(oy)}", "Z0")
        self.line("G54")
        for number in used:
            tool = self.path.tools[number]
            words = ["G10", "L1", f"P{number}"]
            if tool.tcal is not None:
                words.append(f"Z{self.length(tool.tcal)}")
            if tool.diameter is not None:
                words.append(f"R{self.length(tool.diameter // 2)}")
            self.line(*words)
        self.report.warning(
            None,
            "write-offsets: the program sets G54 and the tool table's lengths (G10 L2, "
            "G10 L1); they replace the operator's own settings and stay on the machine",
        )

    # -- moves ----------------------------------------------------------------------------

    def axis_words(self, wx: str, wy: str, wz: str | None, down: bool = False) -> list[str]:
        """The axis words of a move to the written (wx, wy, wz): those whose written value
        changes. Until the first move across, the control's XY is unknown: that move names
        both, and so does a first move down (`down`) where the tool path starts at its
        XY (a plunge at part zero: the table is wherever the operator left it)."""
        words = []
        moves_xy = wx != self.wx or wy != self.wy
        name_xy = not self.xy_known and (moves_xy or down)
        if wx != self.wx or name_xy:
            words.append(f"X{wx}")
        if wy != self.wy or name_xy:
            words.append(f"Y{wy}")
        if wz is not None and wz != self.wz:
            words.append(f"Z{wz}")
        self.xy_known = self.xy_known or name_xy
        return words

    def motion_word(self, motion: str) -> str:
        if motion != self.motion or self.d.g_on_every_line:
            self.motion = motion
            return self.code("G", int(motion))
        return ""

    def feed_word(self, feed: int) -> str:
        if feed != self.feed:
            self.feed = feed
            return f"F{self.feed_value(feed)}"
        return ""

    def at(self, row: Row, wx: str, wy: str, wz: str, z: int) -> None:
        self.x, self.y, self.z = row[3], row[4], z
        self.wx, self.wy, self.wz = wx, wy, wz

    def move(self, row: Row, wx: str, wy: str, wz: str, z: int, chunk: Chunk) -> None:
        op, _tag, block, _x, _y, _z, cx, cy, feed, value = row
        if self.entering and op <= Op.ARC_CCW:
            if self.absorbs(op, row[3], row[4]):
                self.entry_z = z if self.entry_fresh else max(self.entry_z, z)
                self.entry_fresh = False
                self.z, self.wz = z, wz
                return
            # A rapid goes straight to its X/Y; a feed or arc starts where the tool is.
            if op == Op.RAPID:
                self.enter(row[3], row[4], self.z)
            else:
                self.enter(self.x, self.y, self.z)
        if op == Op.RAPID or op == Op.FEED:
            words = self.axis_words(wx, wy, wz, down=z < self.z)
            if words:
                if op == Op.RAPID:
                    self.line(self.motion_word("0"), *words)
                else:
                    self.line(self.motion_word("1"), *words, self.feed_word(feed))
            self.at(row, wx, wy, wz, z)
        elif (op == Op.ARC_CW or op == Op.ARC_CCW) and z != self.z and self.d.no_helical:
            self.helix_lines(row, wx, wy, wz, z)
        elif op == Op.ARC_CW or op == Op.ARC_CCW:
            words = [f"X{wx}", f"Y{wy}"]
            if z != self.z:
                words.append(f"Z{wz}")
                if self.d.helical_note:
                    self.report.note(block, self.d.helical_note)
            i, j = cx - self.x, cy - self.y
            self.line(
                self.motion_word("2" if op == Op.ARC_CW else "3"),
                *words,
                f"I{self.length(i)}",
                f"J{self.length(j)}",
                self.feed_word(feed),
            )
            self.at(row, wx, wy, wz, z)
        elif op == Op.DWELL:
            self.line(self.code("G", 4), self.d.dwell(Decimal(value) / 1000, cycle=False))
        elif op == Op.SPINDLE:
            rpm = None if value < 0 else value
            if rpm is None:
                self.report.warning(
                    block,
                    "no RPM: the spindle starts without an S word; set its speed by hand "
                    "(spindle-speeds=by-hand)",
                )
            self.line("" if rpm is None else f"S{rpm}", self.code("M", 3 if feed else 4))
        elif op == Op.SPINDLE_OFF:
            self.line(self.code("M", 5))
        elif op == Op.TOOL:
            self.tool_change(block, value, z)
        elif op == Op.STOP:
            reason = chunk.strings[value]
            stop = self.code("M", 0)
            if reason == "STOP" and self.o["block-delete"]:
                stop = "/" + stop
            self.line(stop, comment=reason)
        elif op == Op.INDEX:
            self.index(block)
        elif op == Op.COOLANT:
            self.line(self.code("M", 8 if value == 1 else 7))
        elif op == Op.COOLANT_OFF:
            self.line(self.code("M", 9))
        elif op == Op.MESSAGE:
            text = chunk.strings[value]
            if self.d.messages:
                # LinuxCNC shows (MSG,…) comments to the operator.
                self.out(f"(MSG,{comment_text(text)})")
            else:
                self.comment(text)
        else:
            assert op == Op.END
            self.line(str(self.o["end-code"]))

    def helix_lines(self, row: Row, wx: str, wy: str, wz: str, z: int) -> None:
        """A helical arc as G1 moves along its chords, for a dialect without helical arcs:
        each chord within limits.HELIX_CHORD_INCH of the helix (app.cnc.geometry)."""
        op, _tag, block, x, y, _z, cx, cy, feed, _value = row
        tolerance = to_nm(HELIX_CHORD_INCH, Units.INCH)
        radius = math.hypot(self.x - cx, self.y - cy)
        points = arc_points(
            (self.x, self.y, self.z),
            (x, y, z),
            (cx, cy),
            op == Op.ARC_CW,
            chord_step(radius, tolerance),
        )
        self.chord_rows.add(len(points), block)
        for px, py, pz in points[:-1]:
            words = self.axis_words(self.length(px), self.length(py), self.length(pz))
            if words:
                self.line(self.motion_word("1"), *words, self.feed_word(feed))
            self.x, self.y, self.z = px, py, pz
            self.wx, self.wy, self.wz = self.length(px), self.length(py), self.length(pz)
        words = self.axis_words(wx, wy, wz)
        if words:
            self.line(self.motion_word("1"), *words, self.feed_word(feed))
        self.at(row, wx, wy, wz, z)
        self.report.rewritten(
            block,
            f"helical arc written as {len(points)} straight moves within {HELIX_CHORD_INCH} in "
            f"of the helix: {self.d.no_helical}",
        )

    def tool_change(self, block: int, tool: int, z: int) -> None:
        self.line(f"T{tool}", self.code("M", 6))
        self.tool = tool
        self.z = z
        self.wz = self.length(z)
        if self.entering:
            # Before the first position this change is the first tool call: the entry
            # writes its G43 with its Z, the clearance the tool path rises to next (the
            # Z at the change is the old tool's head height, which the file never said).
            self.entry_z = z
            self.entry_fresh = True
            return
        self.line(self.code("G", 43), self.code("H", tool))

    def index(self, block: int) -> None:
        code = self.o["index-code"]
        if code is None:
            self.report.unsupported(block, "INDEX: no M code for the rotary table (set index-code)")
        else:
            self.line(self.code("M", int(code)), comment="INDEX")

    # -- canned cycles --------------------------------------------------------------------

    def may_cycle(self, span: HoleSpan) -> bool:
        """Whether a hole can be written as a canned cycle: the compiler marked it canned,
        a DRILL without pecks, or with evenly spaced pecks when G83 is accepted."""
        if not span.canned or span.op is not HoleOp.DRILL:
            return False
        if span.pecks > 1:
            return self.o["peck-cycle"] == "G83" and _even_pecks(span)
        return True

    def canned_cycle(self, span: HoleSpan, block: int, z_end: int) -> bool:
        """Write a G82 (or accepted G83) for a hole the compiler marked canned. False when
        the hole is not such a cycle (then its moves are written one by one)."""
        if not self.may_cycle(span) or z_end != self.z:
            return False
        if self.entering:
            self.enter(span.x, span.y, self.z)
        x, y, r, bottom, feed = span.x, span.y, span.r, span.bottom, span.feed
        z0 = self.z
        lift = self.lift
        pecked = span.pecks > 1
        wx, wy = self.length(x), self.length(y)
        words = self.axis_words(wx, wy, None)
        if not words:
            # A hole where the last one was (written to the same numbers): a cycle line
            # without axis words drills nothing, so it names the position again.
            words = [f"X{wx}", f"Y{wy}"]
        wr, wb = self.length(r + lift), self.length(bottom + lift)
        key: tuple[str, ...]
        if pecked:
            q = self.length(span.step)
            key = ("G83", wr, wb, q, str(feed), str(z0))
            cycle_words = ["G98", "G83", f"R{wr}", f"Z{wb}", f"Q{q}"]
            self.report.rewritten(
                block,
                "pecks written as G83, which backs off a little above each level instead of "
                "returning to the level just cut (accepted with peck-cycle=G83)",
            )
        else:
            key = ("G82", wr, wb, str(feed), str(z0))
            cycle_words = ["G98", "G82", f"R{wr}", f"Z{wb}"]
            cycle_words.append(self.d.dwell(HOLE_DWELL_SECONDS, cycle=True))
        if self.cycle == key:
            # Seed 003 §2.1 rule 1 (ProtoTRAK): a G code on every line, the cycle's too.
            again = self.code("G", int(key[0][1:])) if self.d.g_on_every_line else ""
            self.line(again, *words)
        else:
            self.end_cycle()
            self.feed = feed
            g98, g8x, *rest = cycle_words
            self.line(g98, g8x, *words, *rest, f"F{self.feed_value(feed)}")
            self.cycle = key
            self.motion = None
        self.x, self.y = x, y
        self.wx, self.wy = wx, wy
        return True

    def end_cycle(self) -> None:
        if self.cycle is not None:
            self.line(self.code("G", 80))
            self.cycle = None
            self.motion = None


# The shortest run of straight rows written in one go (`Writer.straight_run`); a shorter one
# goes row by row (`move`), the same lines. A run in one go costs about what 60 rows one by
# one do (numpy's fixed cost over a few rows): a CAM file's runs between its drilling
# cycles are 2-14 rows, and written in one go they took 2.0 s of a 10^5-line file's 2.6 s
# (POCKET passes between arcs: 2.9 s against 0.5 s); a grid's long runs go 2.4× faster in
# one go.
BULK_ROWS = 64

# The motion modes as the writer keeps them, as row ops.
_MOTION = {"0": Op.RAPID, "1": Op.FEED, "2": Op.ARC_CW, "3": Op.ARC_CCW}


def _run_ends(straight: npt.NDArray[np.bool_]) -> npt.NDArray[np.int64]:
    """For each row, where the run of straight rows it is in ends (one past its last)."""
    n = len(straight)
    ends = np.where(~straight, np.arange(n), n)
    # The first non-straight row at or after each row.
    ends = np.minimum.accumulate(ends[::-1])[::-1]
    return ends.astype(np.int64)


def _even_pecks(span: HoleSpan) -> bool:
    """Whether a pecked hole's levels are evenly spaced from Z UP by its first step, as
    G83's Q spaces them (the last level is the bottom)."""
    levels = peck_levels(span.r, span.bottom, span.pecks)
    return all(levels[j] == span.r - span.step * (j + 1) for j in range(len(levels) - 1))


__all__ = ["TAGS", "GcodeTarget", "Writer", "comment_text", "is_motion"]
