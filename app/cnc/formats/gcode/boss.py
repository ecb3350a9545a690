"""Bridgeport BOSS tape with real-time (segmented) reading, and the rotary table on Y.

Seed 004 §8.1.1: a program longer than the control's storage is read in segments. The tape
starts `%#0` (rewind stop, first segment); each later segment starts with `#0` on a line of
its own and each segment ends with `$` on a line of its own; the last ends `M02`, `$`, `$`.
No slash block delete is written in real-time mode, and no segment ends in a subroutine
call (none are written). Because the machine stops while the reader loads the next
segment, segments break only where the tool is up: before a rapid across at its travel
height (rule e, "a judicious choice of tool position before the $").

The words are RS274-like with decimal points, G70 (inch) / G71 (metric), Z words as the
tool's Z plus its TCAL (no length offsets are written — TLO subroutines would have to lead
the tape — so a tool change is `Tn M06` alone, and every tool that moves down needs its
TCAL). Every line ends in a carriage return (seed 004 §8.1.1: "M02 (cr)$ (cr)$ (cr)"),
or CR LF with `line-end=crlf`. With `rotary`, the Y output drives the rotary table
(§8.2-8.3): the program may not move in Y, and each POS INDEX turns the table by
`index-degrees` (an incremental Y move scaled for BOSS 4/5 or BOSS 6, written with its
decimal point like every length, at rapid or, with `index-feed` and `index-radius`, at a
feed number).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from decimal import Decimal
from typing import Any

from app.cnc.blocks import Program
from app.cnc.formats.gcode.dialects import BOSS, dialect_options
from app.cnc.formats.gcode.writer import GcodeTarget, Row, Writer
from app.cnc.formats.targets import Option, OptionKind, Out, Report, register
from app.cnc.formats.text import Lines
from app.cnc.motions import motions
from app.cnc.path import Chunk, CompiledPath, Op
from app.cnc.problems import Need
from app.cnc.rotary import MAX_STEP, Boss, feed_number, y_distance
from app.cnc.units import Units, to_nm

_BOSS_OPTIONS = (
    *tuple(
        o
        for o in dialect_options(BOSS)
        if o.name not in ("block-delete", "end-code", "canned-cycles", "peck-cycle", "index-code")
    ),
    Option(
        "segment",
        OptionKind.INT,
        0,
        "characters of storage for each main-program segment (0: one segment)",
        minimum=Decimal(0),
        maximum=Decimal(1000000),
    ),
    Option(
        "system", OptionKind.CHOICE, "boss6", "control: BOSS 4/5 or BOSS 6", ("boss45", "boss6")
    ),
    Option("rotary", OptionKind.BOOL, False, "the Y output drives the rotary table"),
    Option(
        "line-end",
        OptionKind.CHOICE,
        "cr",
        "end of each line: cr (seed 004 §8.1.1, the control's own) or crlf",
        ("cr", "crlf"),
    ),
    Option(
        "index-degrees",
        OptionKind.DECIMAL,
        Decimal(90),
        "degrees the table turns at each POS INDEX",
        minimum=Decimal("0.01"),
        maximum=Decimal(640),
    ),
    Option(
        "index-feed",
        OptionKind.DECIMAL,
        None,
        "feed along the cutter path while indexing (per minute); empty: rapid",
        minimum=Decimal("0.1"),
    ),
    Option(
        "index-radius",
        OptionKind.DECIMAL,
        None,
        "cutter-path radius for the index feed number (program units)",
        minimum=Decimal("0.001"),
    ),
)


class _BossWriter(Writer):
    """The G-code writer with the BOSS header, Z words with each tool's TCAL (no length
    offsets), the rotary index, and the places where a segment may end."""

    def __init__(
        self, *args: Any, tape: Segmenter, rotary: dict[str, Any] | None, **kwargs: Any
    ) -> None:
        super().__init__(*args, **kwargs)
        self.tape = tape
        self.rotary = rotary

    def header(self) -> None:
        self.line(self.code("G", 70 if self.units is Units.INCH else 71), self.code("G", 90))
        ox, oy = self.path.origin
        self.report.note(
            None,
            f"set part zero at table X{self.length(ox)} Y{self.length(oy)}; Z words are each "
            "tool's Z plus its TCAL (no tool length offsets on the tape)",
        )
        self.line(self.code("G", 0), f"Z{self.wz}")
        self.motion = "0"
        self.xy_known = False

    def finish(self) -> None:
        pass  # the segments end the tape

    def move(self, row: Row, wx: str, wy: str, wz: str, z: int, chunk: Chunk) -> None:
        op = row[0]
        if op == Op.RAPID and (row[3], row[4]) != (self.x, self.y) and z == self.z:
            # A rapid across at the travel height: the tool is clear, a segment may end here.
            self.tape.may_break()
        if op == Op.INDEX and self.rotary is not None:
            self.index_table(row[2])
            return
        super().move(row, wx, wy, wz, z, chunk)

    def tool_change(self, block: int, tool: int, z: int) -> None:
        # Z words already include each tool's TCAL: no length offset (G43) to apply.
        self.line(f"T{tool}", self.code("M", 6))
        self.tool = tool
        self.lift = self.z_lift(tool)
        self.z = z
        self.wz = self.length(z)

    def index_table(self, block: int) -> None:
        rotary = self.rotary
        assert rotary is not None
        distance = y_distance(rotary["degrees"], rotary["boss"], self.units)
        if distance > MAX_STEP[self.units]:
            self.report.error(block, f"index Y{distance}: more than one step may turn")
        # A length like every other on the tape: its decimal point always stays (Y9., not
        # Y9, which a control reading implied decimals takes for 0.0009 in).
        y = f"Y{self.length(to_nm(distance, self.units))}"
        words = [self.code("G", 91)]
        if rotary["feed_number"] is None:
            words += [self.code("G", 0), y]
        else:
            words += [self.code("G", 1), y, f"F{rotary['feed_number']}"]
        self.line(*words)
        self.line(self.code("G", 90))
        self.motion = None
        self.feed = None


@register
class BossTarget(GcodeTarget):
    name = "tape-boss"
    label = "Bridgeport BOSS tape"
    reads_back = "boss"
    description = "Bridgeport BOSS tape: real-time segments (%#0 … $), rotary table on Y"
    extension = "bos"
    dialect = BOSS
    options = _BOSS_OPTIONS
    common = ("segment", "system", "rotary", "line-end")

    def needs_for(self, options: Mapping[str, Any]) -> frozenset[Need]:
        # Z words include each tool's TCAL, as on a 1704 tape.
        return super().needs_for(options) | {Need.CALIBRATED_TOOLS}

    def write(
        self,
        program: Program,
        path: CompiledPath,
        options: Mapping[str, Any],
        report: Report,
        out: Out,
    ) -> None:
        units = path.units
        rotary = None
        if options["rotary"]:
            boss = Boss(options["system"])
            number = None
            if options["index-feed"] is not None:
                if options["index-radius"] is None:
                    report.error(None, "index-feed needs index-radius (the cutter-path radius)")
                else:
                    try:
                        number = feed_number(
                            options["index-feed"], options["index-radius"], boss, units
                        )
                    except ValueError as exc:
                        report.error(None, f"index feed: {exc}")
            rotary = {"boss": boss, "degrees": options["index-degrees"], "feed_number": number}
            for block in _y_moves(path):
                report.error(
                    block,
                    "moves in Y, but on this machine the Y output drives the rotary table",
                )
        else:
            for block in _index_blocks(path):
                report.unsupported(block, "INDEX: no rotary table (set rotary=yes)")
        writer_options = dict(options) | {
            "block-delete": False,
            "end-code": "M02",
            "canned-cycles": False,
            "peck-cycle": "explicit",
            "index-code": None,
        }
        lines = Lines(out, "\r" if options["line-end"] == "cr" else "\r\n")
        tape = Segmenter(int(options["segment"]), report, lines.add)
        tcal = {n: t.tcal or 0 for n, t in path.tools.items()}
        _BossWriter(
            BOSS,
            program,
            path,
            writer_options,
            report,
            tape.add,
            z_lift=lambda tool: tcal.get(tool, 0),
            tape=tape,
            rotary=rotary,
        ).write()
        tape.close()
        lines.flush()


def _y_moves(path: CompiledPath) -> list[int]:
    """The blocks that move in Y (an arc always does), in order."""
    blocks: dict[int, None] = {}
    for m in motions(path):
        rows = m.rows
        moving = (rows["y"] != m.y0) | (rows["op"] >= Op.ARC_CW)
        blocks.update(dict.fromkeys(rows["block"][moving].tolist()))
    return list(blocks)


def _index_blocks(path: CompiledPath) -> list[int]:
    blocks: list[int] = []
    for chunk in path.chunks():
        blocks += chunk.rows["block"][chunk.rows["op"] == Op.INDEX].tolist()
    return blocks


class Segmenter:
    """The BOSS tape made line by line: `%#0`, segments of at most `size` characters each
    ending `$`, and the `M02`, `$`, `$` ending (seed 004 §8.1.1 b, c, g). A segment may end
    only where `may_break` was called before a line (the tool is up). One segment when
    `size` is 0.

    A segment ends at the last safe place before it would overflow: whether the stretch from
    a safe place to the next still fits is known at the next one, so the lines of one
    stretch wait here. Where a stretch between two safe places is itself longer than a
    segment, that segment is over the limit — an error naming the segment and its size (the
    control has no room for it) — and the later safe places are used as usual, so every
    such segment is named.
    """

    def __init__(self, size: int, report: Report, emit: Callable[[str], None]) -> None:
        self.size = size
        self.report = report
        self.emit = emit
        self.stretch: list[str] = []  # the lines since the last safe place
        self.stretch_cost = 0
        self.at_break = False  # the stretch began at a safe place
        self.next_breaks = False
        self.used = 0  # characters in the segment being written
        self.sizes: list[int] = []
        self.deleted = False
        emit("%#0")

    def may_break(self) -> None:
        """The next line starts where the tool is up: a segment may end before it."""
        self.next_breaks = True

    def add(self, line: str) -> None:
        if line == "M02":
            return  # the tape's own ending has it
        if line.startswith("/"):
            self.deleted = True
        if self.next_breaks:
            self.next_breaks = False
            self.settle()
            self.at_break = True
        self.stretch.append(line)
        self.stretch_cost += len(line) + 1  # each line and its carriage return

    def settle(self) -> None:
        """The stretch is whole: end the segment before it if it no longer fits."""
        fits = self.used + self.stretch_cost <= self.size
        if self.size and self.at_break and self.used > 0 and not fits:
            self.sizes.append(self.used)
            self.emit("$")
            self.emit("#0")
            self.used = 0
        for line in self.stretch:
            self.emit(line)
        self.used += self.stretch_cost
        self.stretch = []
        self.stretch_cost = 0

    def close(self) -> None:
        self.settle()
        self.sizes.append(self.used)
        if self.deleted:
            self.report.error(None, "a block delete (/) cannot be used in real-time tape mode")
        for k, length in enumerate(self.sizes, start=1):
            if self.size and length > self.size:
                self.report.error(
                    None,
                    f"segment {k} is {length} characters, over the {self.size}-character "
                    "segment: it has no place with the tool up to end it sooner (give the "
                    "control's real storage in segment, or split the cut)",
                )
        for line in ("M02", "$", "$"):
            self.emit(line)


def segments(lines: list[str], breaks: set[int], size: int, report: Report) -> list[str]:
    """The tape for `lines`, where the line indexes `breaks` are the safe places (see
    `Segmenter`)."""
    out: list[str] = []
    tape = Segmenter(size, report, out.append)
    for index, line in enumerate(lines):
        if index in breaks and index > 0:
            tape.may_break()
        tape.add(line)
    tape.close()
    return out
