"""G-code targets: LinuxCNC RS274/NGC, Fanuc 6M, and the ProtoTRAK "modified Fanuc 6".

One writer walks the Toolpath with modal state (only words that change are written); a
`Dialect` says what differs (seed 003 §2.1 for the ProtoTRAK: a G code on every line,
spaces between words, `;` at the end of each block). The G/M codes are those of seed 003's
RS274/NGC and Fanuc tables.

Canned cycles are written only where the cycle's motion is identical to the block's
(DESIGN.md §4): a DRILL hole without pecks is `G98 G82 R<Z UP> Z<Z DN> P…` from its
retract height (the 0.8 s dwell in the dialect's unit); the writer recognises those move
sequences in the Toolpath, so a hole whose moves differ (a retract height that changed on
the way) is written as explicit moves. Pecks (ours return to the level just cut; G83 backs off above
it) and TAP's feed-out to Z UP + 0.3 in are explicit moves unless the user accepts G83
(`peck-cycle=G83`), which the compatibility report then states.

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

from collections.abc import Mapping
from typing import Any, ClassVar

from app.cnc.blocks import Program
from app.cnc.emit.target import Report, Target, register
from app.cnc.formats.gcode.dialects import FANUC, LINUXCNC, PROTOTRAK, Dialect, dialect_options
from app.cnc.limits import HOLE_DWELL_SECONDS
from app.cnc.problems import Need
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
    SpindleOff,
    SpindleOn,
    ToolChange,
    Toolpath,
)
from app.cnc.units import Units, format_length


class GcodeTarget(Target):
    """Shared writer; subclasses set `dialect` and the target attributes."""

    dialect: ClassVar[Dialect]
    extension = "ngc"
    needs = frozenset({Need.SPINDLE_SPEEDS})
    reads_back: ClassVar[str | None] = "gcode"

    def needs_for(self, options: Mapping[str, Any]) -> frozenset[Need]:
        # S words need speeds, unless the operator sets them by hand (reported).
        return frozenset() if options.get("spindle-speeds") == "by-hand" else self.needs

    def need_hint(self, need: Need) -> str:
        return "or export with spindle-speeds=by-hand to set them at the control"

    def emit(
        self, program: Program, toolpath: Toolpath, options: Mapping[str, Any], report: Report
    ) -> bytes:
        writer = _Writer(self.dialect, program, toolpath, options, report)
        return writer.write().encode("ascii")


@register
class LinuxcncTarget(GcodeTarget):
    name = "gcode-linuxcnc"
    label = "LinuxCNC (RS274/NGC)"
    description = "RS274/NGC as LinuxCNC reads it"
    dialect = LINUXCNC
    options = dialect_options(LINUXCNC)


@register
class FanucTarget(GcodeTarget):
    name = "gcode-fanuc"
    label = "Fanuc 6M"
    description = "Fanuc 6M (% and O number, N numbers, no spaces)"
    dialect = FANUC
    options = dialect_options(FANUC)


@register
class PrototrakTarget(GcodeTarget):
    name = "gcode-prototrak"
    label = "ProtoTRAK G-code (modified Fanuc 6)"
    description = "ProtoTRAK Plus modified Fanuc 6 (G on every line, spaces, ; end of block)"
    dialect = PROTOTRAK
    options = dialect_options(PROTOTRAK)


class _Writer:
    """Walks the tool path once, keeping the modal state of the control."""

    def __init__(
        self,
        dialect: Dialect,
        program: Program,
        toolpath: Toolpath,
        options: Mapping[str, Any],
        report: Report,
    ) -> None:
        self.d = dialect
        self.program = program
        self.tp = toolpath
        self.o = options
        self.report = report
        self.units: Units = toolpath.units
        self.lines: list[str] = []
        self.number = int(options["sequence-start"])
        self.motion: str | None = None
        self.feed: int | None = None
        self.x, self.y, self.z = toolpath.start
        self.cycle: tuple[str, ...] | None = None  # words of the active canned cycle
        self.xy_known = True

    # -- words and lines ------------------------------------------------------------------

    def code(self, letter: str, value: int) -> str:
        return f"{letter}{value:02d}" if self.d.two_digit_codes else f"{letter}{value}"

    def length(self, nm: int) -> str:
        text = format_length(nm, self.units)
        if self.o["trailing-zeros"] == "drop":
            text = text.rstrip("0")
            text = "0" if text in ("0.", "-0.") else text
        return text

    def feed_value(self, nm_per_min: int) -> str:
        text = format_length(nm_per_min, self.units).rstrip("0")
        return text + "0" if text.endswith(".") else text

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
            parts.append(f"({_comment(comment)})")
        separator = "\t" if self.o["tabs"] else (" " if self.d.spaces else "")
        self.lines.append(separator.join(parts) + self.d.end_of_block)

    def comment(self, text: str) -> None:
        self.lines.append(f"({_comment(text)}){self.d.end_of_block}")

    # -- the program --------------------------------------------------------------------

    def write(self) -> str:
        self.header()
        moves = self.tp.moves
        i = 0
        while i < len(moves):
            consumed = self.canned_cycle(moves, i) if self.o["canned-cycles"] else 0
            if consumed:
                i += consumed
                continue
            self.end_cycle()
            self.move(moves[i])
            i += 1
        self.end_cycle()
        self.lines.append("%")
        return "\n".join(self.lines) + "\n"

    def header(self) -> None:
        p = self.program
        label = p.name.upper() if p.name else "MILLBLOCKS"
        # The ProtoTRAK sample (seed 003 §2.2.6.2) opens with `%:LABEL;`; LinuxCNC's reader,
        # our referee, takes `%` only alone on its line, so the label follows as a comment.
        self.lines.append("%")
        if self.d.program_number:
            number = int(p.part_number[-4:]) if p.part_number else 1
            self.lines.append(f"O{number:04d}")
        self.comment(f"{label} PART {p.part_number or '-'} MILLBLOCKS")
        units = self.code("G", 20 if self.units is Units.INCH else 21)
        g = self.code
        self.line(g("G", 17), units, g("G", 40), g("G", 80), g("G", 90), g("G", 94))
        self.setup()
        for number in sorted(self.used_tools()):
            info = self.tp.tools.get(number)
            if info is not None and info.tcal is None and self.cuts_in_z():
                self.report.warning(
                    None,
                    f"tool {number} is uncalibrated: its Z words are measured from wherever "
                    "the operator sets its length",
                )
        if self.tp.initial_tool:
            self.line(self.code("G", 43), self.code("H", self.tp.initial_tool))
        # Only Z is known at the start: the first move across writes both X and Y.
        self.line(self.code("G", 0), f"Z{self.length(self.z)}")
        self.motion = "0"
        self.xy_known = False

    def setup(self) -> None:
        """Part zero and tool lengths: set-up comments and report notes, or (write-offsets)
        G10 lines that set them on the machine."""
        ox, oy = self.tp.origin
        offset = f"X{format_length(ox, self.units)} Y{format_length(oy, self.units)}"
        write = bool(self.o.get("write-offsets"))
        g54 = self.code("G", 54)
        self.comment(f"SET-UP: {g54} = PART ZERO AT TABLE {offset}")
        self.report.note(None, f"set-up: {g54} must hold part zero, table {offset}")
        used = sorted(n for n in self.tp.tools if n in self.used_tools())
        for number in used:
            tool = self.tp.tools[number]
            # The diameter too: cutter compensation and routines were planned with it, and an
            # importer needs it to read the tool-centre path back as the blocks it came from.
            dia = (
                "" if tool.diameter is None else f" DIA {format_length(tool.diameter, self.units)}"
            )
            if tool.tcal is None:
                length = "measured (uncalibrated)"
                self.comment(
                    f"SET-UP: T{number}{dia} LENGTH H{number:02d}: UNCALIBRATED, MEASURE IT"
                )
            else:
                length = format_length(tool.tcal, self.units)
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
            tool = self.tp.tools[number]
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

    def used_tools(self) -> set[int]:
        used = {m.tool for m in self.tp.moves if isinstance(m, ToolChange)}
        return used | ({self.tp.initial_tool} if self.tp.initial_tool else set())

    def cuts_in_z(self) -> bool:
        return any(isinstance(m, Rapid | Feed) and m.z != self.tp.start[2] for m in self.tp.moves)

    # -- moves ----------------------------------------------------------------------------

    def axis_words(self, x: int, y: int, z: int | None) -> list[str]:
        """The axis words of a move to (x, y, z): those whose written value changes."""
        words = []
        # Until the first move across, the control's XY is unknown: that move names both.
        new_x, new_y = self.length(x), self.length(y)
        moves_xy = (new_x, new_y) != (self.length(self.x), self.length(self.y))
        if new_x != self.length(self.x) or (moves_xy and not self.xy_known):
            words.append(f"X{new_x}")
        if new_y != self.length(self.y) or (moves_xy and not self.xy_known):
            words.append(f"Y{new_y}")
        if z is not None and self.length(z) != self.length(self.z):
            words.append(f"Z{self.length(z)}")
        self.xy_known = self.xy_known or moves_xy
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

    def move(self, move: Move) -> None:
        if isinstance(move, Rapid):
            words = self.axis_words(move.x, move.y, move.z)
            if words:
                self.line(self.motion_word("0"), *words)
            self.x, self.y, self.z = move.x, move.y, move.z
        elif isinstance(move, Feed):
            words = self.axis_words(move.x, move.y, move.z)
            if words:
                self.line(self.motion_word("1"), *words, self.feed_word(move.feed))
            self.x, self.y, self.z = move.x, move.y, move.z
        elif isinstance(move, ArcFeed):
            words = [f"X{self.length(move.x)}", f"Y{self.length(move.y)}"]
            if move.z != self.z:
                words.append(f"Z{self.length(move.z)}")
            i, j = move.cx - self.x, move.cy - self.y
            self.line(
                self.motion_word("2" if move.clockwise else "3"),
                *words,
                f"I{self.length(i)}",
                f"J{self.length(j)}",
                self.feed_word(move.feed),
            )
            self.x, self.y, self.z = move.x, move.y, move.z
        elif isinstance(move, Dwell):
            self.line(self.code("G", 4), self.d.dwell(move.seconds, cycle=False))
        elif isinstance(move, SpindleOn):
            speed = "" if move.rpm is None else f"S{move.rpm}"
            if move.rpm is None:
                self.report.warning(
                    move.block,
                    "no RPM: the spindle starts without an S word; set its speed by hand "
                    "(spindle-speeds=by-hand)",
                )
            self.line(speed, self.code("M", 3 if move.clockwise else 4))
        elif isinstance(move, SpindleOff):
            self.line(self.code("M", 5))
        elif isinstance(move, ToolChange):
            self.line(f"T{move.tool}", self.code("M", 6))
            self.z = move.z
            self.line(self.code("G", 43), self.code("H", move.tool))
        elif isinstance(move, ProgramStop):
            stop = self.code("M", 0)
            if move.reason == "STOP" and self.o["block-delete"]:
                stop = "/" + stop
            self.line(stop, comment=move.reason)
        elif isinstance(move, IndexTable):
            code = self.o["index-code"]
            if code is None:
                self.report.unsupported(
                    move.block, "INDEX: no M code for the rotary table (set index-code)"
                )
            else:
                self.line(self.code("M", int(code)), comment="INDEX")
        elif isinstance(move, CoolantOn):
            self.line(self.code("M", 8 if move.mode == "flood" else 7))
        elif isinstance(move, CoolantOff):
            self.line(self.code("M", 9))
        elif isinstance(move, Message):
            if self.d.messages:
                # LinuxCNC shows (MSG,…) comments to the operator.
                self.lines.append(f"(MSG,{_comment(move.text)})")
            else:
                self.comment(move.text)
        else:
            assert isinstance(move, ProgramEnd)
            self.line(str(self.o["end-code"]))

    # -- canned cycles --------------------------------------------------------------------

    def canned_cycle(self, moves: list[Move], i: int) -> int:
        """Write a G82/G89 (or accepted G83) for the hole starting at `moves[i]`.

        Returns how many moves it replaced, or 0 when the moves are not such a hole.
        """
        match = _match_hole(moves, i, (self.x, self.y, self.z))
        if match is None:
            return 0
        kind, consumed, (x, y), r, bottom, feed, pecks = match
        if pecks and self.o["peck-cycle"] != "G83":
            return 0
        z0 = self.z
        words = self.axis_words(x, y, None)
        if not words:
            # A hole where the last one was (written to the same numbers): a cycle line
            # without axis words drills nothing, so it names the position again.
            words = [f"X{self.length(x)}", f"Y{self.length(y)}"]
        key: tuple[str, ...]
        if kind == "G83":
            q = pecks
            key = ("G83", self.length(r), self.length(bottom), self.length(q), str(feed), str(z0))
            cycle_words = ["G98", "G83", f"R{self.length(r)}", f"Z{self.length(bottom)}"]
            cycle_words.append(f"Q{self.length(q)}")
            self.report.rewritten(
                moves[i].block,
                "pecks written as G83, which backs off a little above each level instead of "
                "returning to the level just cut (accepted with peck-cycle=G83)",
            )
        else:
            key = (kind, self.length(r), self.length(bottom), str(feed), str(z0))
            cycle_words = ["G98", kind, f"R{self.length(r)}", f"Z{self.length(bottom)}"]
            cycle_words.append(self.d.dwell(HOLE_DWELL_SECONDS, cycle=True))
        if self.cycle == key:
            # Seed 003 §2.1 rule 1 (ProtoTRAK): a G code on every line, the cycle's too.
            again = self.code("G", int(kind[1:])) if self.d.g_on_every_line else ""
            self.line(again, *words)
        else:
            self.end_cycle()
            self.feed = feed
            g98, g8x, *rest = cycle_words
            self.line(g98, g8x, *words, *rest, f"F{self.feed_value(feed)}")
            self.cycle = key
            self.motion = None
        self.x, self.y, self.z = x, y, z0
        return consumed

    def end_cycle(self) -> None:
        if self.cycle is not None:
            self.line(self.code("G", 80))
            self.cycle = None
            self.motion = None


HoleMatch = tuple[str, int, tuple[int, int], int, int, int, int]


def _match_hole(moves: list[Move], i: int, at: tuple[int, int, int]) -> HoleMatch | None:
    """Recognise a G82 (drill + dwell) or pecked hole starting at `moves[i]`.

    The sequence, all from one block and all at one XY: an optional rapid across at the
    current height z0, a rapid down to R, feed(s) down (pecks: feed, rapid up to R, rapid
    back to the level, feed …), a 0.8 s dwell, then a rapid back to z0. Returns (cycle,
    moves used, XY, R, bottom, feed, peck depth or 0) or None.

    BORE has no such cycle: G85/G89 feed out all the way to the clearance plane (with G98,
    the initial level), while the control feeds out only to Z UP and rapids from there.
    """
    x, y, z0 = at
    k = i
    n = len(moves)
    first = moves[i] if i < n else None
    if first is None:
        return None
    block = first.block
    if isinstance(first, Rapid) and first.z == z0 and (first.x, first.y) != (x, y):
        x, y = first.x, first.y
        k += 1
    if k >= n or not isinstance(moves[k], Rapid):
        return None
    down = moves[k]
    assert isinstance(down, Rapid)
    if (down.x, down.y) != (x, y) or down.z >= z0 or down.block != block:
        return None
    r = down.z
    k += 1
    levels: list[int] = []
    feed = 0
    while k < n:
        m = moves[k]
        if isinstance(m, Feed) and (m.x, m.y) == (x, y) and m.z < (levels[-1] if levels else r):
            levels.append(m.z)
            feed = m.feed if not levels[:-1] else feed
            if m.feed != feed:
                return None
            k += 1
            nxt = moves[k] if k < n else None
            back = moves[k + 1] if k + 1 < n else None
            if (
                isinstance(nxt, Rapid)
                and nxt.tag == "peck-retract"
                and isinstance(back, Rapid)
                and back.tag == "peck-reentry"
            ):
                k += 2
                continue
            break
        return None
    if not levels or k >= n or not isinstance(moves[k], Dwell):
        return None
    dwell = moves[k]
    assert isinstance(dwell, Dwell)
    if dwell.seconds != HOLE_DWELL_SECONDS:
        return None
    k += 1
    bottom = levels[-1]
    if k < n and isinstance(moves[k], Rapid):
        up = moves[k]
        assert isinstance(up, Rapid)
        if (up.x, up.y, up.z) != (x, y, z0):
            return None
        if len(levels) == 1:
            return ("G82", k + 1 - i, (x, y), r, bottom, feed, 0)
        step = r - levels[0]
        if all(levels[j] == r - step * (j + 1) for j in range(len(levels) - 1)):
            return ("G83", k + 1 - i, (x, y), r, bottom, feed, step)
    return None


def _comment(text: str) -> str:
    """Comment text the controls accept: no parentheses, upper case ASCII, one line.
    Line breaks and other control characters become spaces: in a name or message they
    would otherwise end the comment's block and put the rest on the tape as code."""
    cleaned = text.replace("(", "[").replace(")", "]").replace(";", ",")
    cleaned = "".join(" " if ord(ch) < 32 or ord(ch) == 127 else ch for ch in cleaned)
    return cleaned.encode("ascii", "replace").decode("ascii").upper()
