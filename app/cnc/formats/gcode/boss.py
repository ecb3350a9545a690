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

from collections.abc import Mapping
from dataclasses import replace
from decimal import Decimal
from typing import Any

from app.cnc.blocks import Program
from app.cnc.emit.target import Option, OptionKind, Report, register
from app.cnc.formats.gcode.dialects import BOSS, dialect_options
from app.cnc.formats.gcode.writer import GcodeTarget, _Writer
from app.cnc.problems import Need
from app.cnc.rotary import MAX_STEP, Boss, feed_number, y_distance
from app.cnc.toolpath import (
    ArcFeed,
    Feed,
    IndexTable,
    Move,
    Rapid,
    ToolChange,
    Toolpath,
)
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


class _BossWriter(_Writer):
    """The G-code writer with the BOSS header, and a note of where segments may break."""

    def __init__(self, *args: Any, rotary: dict[str, Any] | None = None) -> None:
        super().__init__(*args)
        self.rotary = rotary
        self.breaks: set[int] = set()
        self.no_breaks = True

    def header(self) -> None:
        self.line(self.code("G", 70 if self.units is Units.INCH else 71), self.code("G", 90))
        ox, oy = self.tp.origin
        self.report.note(
            None,
            f"set part zero at table X{self.length(ox)} Y{self.length(oy)}; Z words are each "
            "tool's Z plus its TCAL (no tool length offsets on the tape)",
        )
        self.line(self.code("G", 0), f"Z{self.length(self.z)}")
        self.motion = "0"
        self.xy_known = False

    def move(self, move: Move) -> None:
        if isinstance(move, Rapid) and (move.x, move.y) != (self.x, self.y) and move.z == self.z:
            # A rapid across at the travel height: the tool is clear, a segment may end here.
            self.breaks.add(len(self.lines))
        if isinstance(move, IndexTable) and self.rotary is not None:
            self.index(move)
            return
        if isinstance(move, ToolChange):
            # Z words already include each tool's TCAL: no length offset (G43) to apply.
            self.line(f"T{move.tool}", self.code("M", 6))
            self.z = move.z
            return
        super().move(move)

    def index(self, move: IndexTable) -> None:
        rotary = self.rotary
        assert rotary is not None
        distance = y_distance(rotary["degrees"], rotary["boss"], self.units)
        if distance > MAX_STEP[self.units]:
            self.report.error(move.block, f"index Y{distance}: more than one step may turn")
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
    reads_back = None
    description = "Bridgeport BOSS tape: real-time segments (%#0 … $), rotary table on Y"
    extension = "bos"
    dialect = BOSS
    options = _BOSS_OPTIONS

    def needs_for(self, options: Mapping[str, Any]) -> frozenset[Need]:
        # Z words include each tool's TCAL, as on a 1704 tape.
        return super().needs_for(options) | {Need.CALIBRATED_TOOLS}

    def emit(
        self, program: Program, toolpath: Toolpath, options: Mapping[str, Any], report: Report
    ) -> bytes:
        units = toolpath.units
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
            moving_y = _y_moves(toolpath)
            for block in moving_y:
                report.error(
                    block,
                    "moves in Y, but on this machine the Y output drives the rotary table",
                )
        elif any(isinstance(m, IndexTable) for m in toolpath.moves):
            for move in toolpath.moves:
                if isinstance(move, IndexTable):
                    report.unsupported(move.block, "INDEX: no rotary table (set rotary=yes)")
        writer_options = dict(options) | {
            "block-delete": False,
            "end-code": "M02",
            "canned-cycles": False,
            "peck-cycle": "explicit",
            "index-code": None,
        }
        writer = _BossWriter(
            BOSS, program, _machine_z(toolpath), writer_options, report, rotary=rotary
        )
        text = writer.write()
        lines = [line for line in text.splitlines() if line != "%"]
        if any(line.startswith("/") for line in lines):
            report.error(None, "a block delete (/) cannot be used in real-time tape mode")
        end = "\r" if options["line-end"] == "cr" else "\r\n"
        tape = segments(lines, writer.breaks, int(options["segment"]), report)
        return (end.join(tape) + end).encode("ascii")


def _y_moves(toolpath: Toolpath) -> list[int]:
    y = toolpath.start[1]
    blocks: list[int] = []
    for move in toolpath.moves:
        if isinstance(move, Rapid | Feed | ArcFeed):
            if (move.y != y or isinstance(move, ArcFeed)) and move.block not in blocks:
                blocks.append(move.block)
            y = move.y
    return blocks


def _machine_z(toolpath: Toolpath) -> Toolpath:
    """The tool path with every Z as the control sees it: the tool's Z plus its TCAL."""
    tcal = {n: t.tcal or 0 for n, t in toolpath.tools.items()}
    current = tcal.get(toolpath.initial_tool, 0)
    moves: list[Move] = []
    for move in toolpath.moves:
        if isinstance(move, ToolChange):
            current = tcal.get(move.tool, 0)
            moves.append(replace(move, z=move.z + current))
        elif isinstance(move, Rapid | Feed | ArcFeed):
            moves.append(replace(move, z=move.z + current))
        else:
            moves.append(move)
    start = toolpath.start
    first = tcal.get(toolpath.initial_tool, 0)
    return replace(toolpath, start=(start[0], start[1], start[2] + first), moves=moves)


def segments(lines: list[str], breaks: set[int], size: int, report: Report) -> list[str]:
    """The tape: `%#0`, segments of at most `size` characters each ending `$`, and the
    `M02`, `$`, `$` ending (seed 004 §8.1.1 b, c, g). `breaks` are the line indexes where
    a segment may end (the tool is up). One segment when `size` is 0.

    A segment ends at the last safe place before it would overflow. Where a stretch of
    cutting between two safe places is itself longer than a segment, that segment is over
    the limit — an error naming the segment and its size (the control has no room for it)
    — and the later safe places are used as usual, so every such segment is named.
    """
    body = [line for line in lines if line not in ("M02",)]
    cost = [len(line) + 1 for line in body]  # each line and its carriage return
    safe = sorted(b for b in breaks if 0 < b < len(body))
    out = ["%#0"]
    used = 0
    number = 1
    sizes: list[int] = []
    for index, line in enumerate(body):
        if size and index in breaks and used > 0:
            # Will the stretch up to the next safe place still fit? If not, end here.
            following = next((b for b in safe if b > index), len(body))
            if used + sum(cost[index:following]) > size:
                sizes.append(used)
                out += ["$", "#0"]
                used = 0
                number += 1
        out.append(line)
        used += cost[index]
    sizes.append(used)
    for k, length in enumerate(sizes, start=1):
        if size and length > size:
            report.error(
                None,
                f"segment {k} is {length} characters, over the {size}-character segment: it "
                "has no place with the tool up to end it sooner (give the control's real "
                "storage in segment, or split the cut)",
            )
    out += ["M02", "$", "$"]
    return out
