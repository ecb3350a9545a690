"""Tektronix 1704 punched tape: the word-address listing, punch images and a tape drawing.

Seed 000 (the 1704 Programmer's Manual, 1973) is the specification; DESIGN.md §4 ("Tektronix
1704 tape", "1704 motion rules", "Tool length") gives the readings we follow. The listing is
built once from the Toolpath and a machine profile (the options); the punch images and the
drawing are made from the listing, so all five targets say the same thing.

- A tape is leader, the rewind stop and an End of Block, then one block per line, then
  trailer (seed 000 §1 "Block", §2 "Rewind Stop", "Tape Leader"). ASCII tapes open with
  comment blocks for the set-up (part zero, Z zero); EIA has no comments, so the report
  carries them.
- Words `N3 G2 X±2.4 Y±2.4 Z±2.4 I J K R F3.1 S2 T2 M2` in that order (the manuscript's
  column order, Fig. 1-3); the metric option and resolution option 2 make motion words 3.3
  and F a whole number (F4). Leading zeros are dropped, trailing zeros kept, no decimal point
  (§2 "Coordinate Information", "Decimal Point"). Words are modal (§2 "Tape Format
  Definition"); one G and one M per block.
- Motion rules (§2 G00/G01/G02/G03): G01 only into a feed move whose direction changes by
  30° or less, G00 otherwise; G02/G03 likewise, G20/G30 where an arc ends a run. Rapids are
  G50; we read G50 as decelerating at its end like G00 (Table 3-1 ends its tape on a G50
  move, which requirement (d) of G00 would otherwise forbid). Every M code, dwell, preset,
  stop or tool change is its own block after a decelerated one; a spindle start (an "A"
  code, acting when read) rides on the rapid that follows it.
- Arcs are split at the axes so each block stays in one quadrant (§4: "up to 90 degrees
  within one circle quadrant"), both end axes always written; the centre is the absolute
  I J (Table 4-1 N005 `I10000J30000` for a centre at X1.0 Y3.0) and, as the manual allows
  ("the center location does not have to be repeated if it does not change", Table 4-1
  N015), not repeated while it stays the same. Without circular interpolation, chords.
- Z is the control's own Z: each tool's toolpath Z plus its TCAL (the 1704 has no length
  offsets), or with `z-zero=g94` a G94 preset at each tool change. We read G94 as setting
  the axes it names to zero at the present position (`G94Z0`).
- The first motion of the tape and the first after each tool change state every axis, the
  G and the F again: they are where an operator restarts (§4 "Tape Search").
"""

from __future__ import annotations

import enum
import html
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from decimal import Decimal
from fractions import Fraction
from typing import Any, ClassVar

from app.cnc.blocks import BoltCircle, Hole, HoleOp, Program
from app.cnc.emit.target import (
    Option,
    OptionError,
    OptionKind,
    Report,
    Target,
    register,
)
from app.cnc.formats.tape1704 import codes as tapecode
from app.cnc.formats.tape1704.codes import TapeCode
from app.cnc.geometry import arc_sweep
from app.cnc.needs import blocks_text
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
from app.cnc.units import NM_PER_INCH, NM_PER_MM, Units, format_length, to_nm

# --- the machine profile ----------------------------------------------------------------

_BOOL, _INT, _DEC = OptionKind.BOOL, OptionKind.INT, OptionKind.DECIMAL
_CHOICE, _TEXT = OptionKind.CHOICE, OptionKind.TEXT

PROFILE_OPTIONS: tuple[Option, ...] = (
    Option("circular", _BOOL, True, "circular interpolation option (G02/G03/G20/G30); no: chords"),
    Option(
        "tolerance",
        _DEC,
        Decimal("0.001"),
        "chord tolerance on the part, inches, when circular=no (seed 002 TOL)",
        minimum=Decimal("0.0001"),
        maximum=Decimal("0.1"),
    ),
    Option(
        "units",
        _CHOICE,
        "program",
        "program: metric option for a mm program; inch; metric (the metric option, X3.3 F4)",
        choices=("program", "inch", "metric"),
    ),
    Option(
        "resolution",
        _CHOICE,
        "standard",
        "standard 0.0001 in / 200 ipm; option1 0.0002 in / 400 ipm; option2 0.001 in / 2000 ipm",
        choices=("standard", "option1", "option2"),
    ),
    Option(
        "drill-cycle",
        _INT,
        0,
        "fixed cycle G81-G89 the builder set to rapid to R, feed, dwell, rapid to R; 0: none",
        minimum=Decimal(0),
        maximum=Decimal(89),
    ),
    Option(
        "bore-cycle",
        _INT,
        0,
        "fixed cycle G81-G89 the builder set to feed, dwell, feed out to R; 0: none",
        minimum=Decimal(0),
        maximum=Decimal(89),
    ),
    Option("dwell", _BOOL, True, "dwell option (G04 F, 0.1-99.9 s)"),
    Option("quill", _BOOL, False, "two-axis machine with the quill actuator (M51/M50, G99/G98)"),
    Option(
        "spindle-codes",
        _TEXT,
        "",
        "spindle control option: S code table RPM=CODE,...; empty: speeds set by hand",
    ),
    Option(
        "tool-codes",
        _TEXT,
        "",
        "tool control option: T code table TOOL=CODE,... or 'number'; empty: no T words",
    ),
    Option(
        "index-m",
        _INT,
        0,
        "M code wired to the rotary fixture's index (M10-M29, M31-M99); 0: none",
        minimum=Decimal(0),
        maximum=Decimal(99),
    ),
    Option(
        "z-zero",
        _CHOICE,
        "tcal",
        "tcal: Z words include each tool's TCAL; g94: touch off and preset Z at each tool change",
        choices=("tcal", "g94"),
    ),
    Option("sequence", _BOOL, True, "sequence numbers N (seed 002 SEQ/ON)"),
    Option(
        "tape-search",
        _BOOL,
        False,
        "every data block's first move restates X Y Z G F, spindle and coolant (seed 000 §4 "
        "tape search: the operator can restart there); N on every block",
    ),
    Option(
        "sequence-start",
        _INT,
        1,
        "first sequence number",
        minimum=Decimal(0),
        maximum=Decimal(999),
    ),
    Option(
        "sequence-increment",
        _INT,
        1,
        "sequence number increment",
        minimum=Decimal(1),
        maximum=Decimal(999),
    ),
    Option("tabs", _BOOL, False, "a tab before every word but the first (seed 002 TABS)"),
    Option(
        "zeros",
        _CHOICE,
        "2",
        "seed 002 ZEROS: 2 trailing zeros only (leading dropped, as seed 000 §2 writes), 0 "
        "leading and trailing zeros; the 1704 counts digits from the right and ignores a "
        "point, so 1 and 3 would misplace it",
        choices=("2", "0"),
    ),
    Option(
        "end-code",
        _CHOICE,
        "M30",
        "M30 ends and rewinds; M02 ends without rewinding (seed 002 NORWD)",
        choices=("M30", "M02"),
    ),
    Option("ident", _BOOL, True, "punch the title in the leader as letters (seed 002 IDENT)"),
    Option("title", _TEXT, "", "the title; empty: the program name and part number"),
    Option(
        "leader",
        _DEC,
        Decimal(12),
        "leader, inches of blank tape (longer when the title needs it)",
        minimum=Decimal(2),
        maximum=Decimal(240),
    ),
    Option(
        "trailer",
        _DEC,
        Decimal(12),
        "trailer, inches of blank tape",
        minimum=Decimal(0),
        maximum=Decimal(240),
    ),
    Option(
        "tool-change-leader",
        _DEC,
        Decimal(0),
        "blank tape after each tool change but the first, inches (seed 002 TCLDR)",
        minimum=Decimal(0),
        maximum=Decimal(120),
    ),
    Option("decel", _BOOL, False, "decelerate every move: G00 and G20/G30 only (seed 002 DECEL)"),
    Option(
        "xyz",
        _CHOICE,
        "separate",
        "positioning: separate (Z up, XY, Z down: seed 002 XYZ/OFF) or together (XYZ/ON)",
        choices=("separate", "together"),
    ),
)


@dataclass(frozen=True)
class TapeFormat:
    """How numbers are punched for one machine configuration (seed 000 §2, §4).

    `step_nm` is the machine resolution positions are rounded to; `digit_nm` what one unit
    of the last digit written is worth (resolution option 1 keeps the 2.4 format with even
    last digits). F words count `feed_unit_nm` per minute, in steps of `feed_step`.
    """

    name: str
    metric: bool
    step_nm: int
    digit_nm: int
    int_digits: int
    frac_digits: int
    feed_unit_nm: int
    feed_step: int
    feed_min: int
    feed_max: int

    @property
    def unit_nm(self) -> int:
        return NM_PER_MM if self.metric else NM_PER_INCH

    @property
    def unit(self) -> str:
        return "mm" if self.metric else "in"

    @property
    def feed_name(self) -> str:
        return "mm/min" if self.metric else "ipm"

    @property
    def max_units(self) -> int:
        """The largest coordinate, radius or centre word (±99.9999 in standard)."""
        top = int(10 ** (self.int_digits + self.frac_digits)) - 1
        ratio = self.step_nm // self.digit_nm
        return top - top % ratio

    def units(self, nm: int) -> int:
        """`nm` rounded once (half-even) to the resolution, in units of the last digit."""
        ratio = self.step_nm // self.digit_nm
        return round(Fraction(nm, self.step_nm)) * ratio

    def show(self, units: int) -> str:
        """A word value as a length for messages, e.g. `99.9999 in`."""
        value = Decimal(units * self.digit_nm) / Decimal(self.unit_nm)
        places = self.frac_digits
        return f"{value.quantize(Decimal(1).scaleb(-places))} {self.unit}"

    def feed_value(self, feed_nm: int) -> int:
        """A feed (nm/min) as its F word value, rounded to the feed step."""
        value = round(Fraction(feed_nm, self.feed_unit_nm * self.feed_step))
        return value * self.feed_step

    def show_feed(self, value: int) -> str:
        number = Fraction(value * self.feed_unit_nm, self.unit_nm)
        return f"{float(number):.1f} {self.feed_name}"

    def show_programmed_feed(self, feed_nm: int) -> str:
        """A feed of the tool path (nm/min) as programmed: `5.1 ipm`, `250 mm/min`."""
        value = Decimal(feed_nm) / Decimal(self.unit_nm)
        shown = value.quantize(Decimal(1) if self.metric else Decimal("0.1"))
        return f"{shown} {self.feed_name}"

    @property
    def feed_step_text(self) -> str:
        """The feed step of F words, e.g. `0.2 ipm`."""
        return self.show_feed(self.feed_step).replace(".0 mm/min", " mm/min")


FORMAT_STANDARD = TapeFormat("inch, 0.0001 in", False, 2540, 2540, 2, 4, 2_540_000, 1, 1, 2000)
FORMAT_OPTION1 = TapeFormat(
    "inch, resolution option 1 (0.0002 in)", False, 5080, 2540, 2, 4, 2_540_000, 2, 2, 4000
)
FORMAT_OPTION2 = TapeFormat(
    "inch, resolution option 2 (0.001 in)", False, 25400, 25400, 3, 3, 25_400_000, 1, 1, 2000
)
FORMAT_METRIC = TapeFormat(
    "metric option (0.001 mm)", True, 1000, 1000, 3, 3, 1_000_000, 1, 1, 2000
)

_RESERVED_M = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 30, 50, 51, 52}


@dataclass(frozen=True)
class Profile:
    """The machine profile: the target options, read and checked."""

    fmt: TapeFormat
    circular: bool
    tolerance_nm: int
    drill_cycle: int
    bore_cycle: int
    dwell: bool
    quill: bool
    spindle_codes: dict[int, int] | None
    tool_codes: dict[int, int] | None
    tool_code_is_number: bool
    index_m: int
    g94: bool
    sequence: bool
    sequence_start: int
    sequence_increment: int
    tabs: bool
    end_code: int
    ident: bool
    title: str
    leader_rows: int
    trailer_rows: int
    tool_change_rows: int
    decel: bool
    xyz_together: bool
    tape_search: bool = False
    leading_zeros: bool = False


def _rows(inches: Decimal) -> int:
    return int((inches * tapecode.ROWS_PER_INCH).to_integral_value())


def _code_table(name: str, text: str, low: int, high: int) -> dict[int, int]:
    """`A=B,C=D` as {A: B}; codes are two digits. Raises OptionError saying what is wrong."""
    result: dict[int, int] = {}
    for part in text.replace(";", ",").split(","):
        if not part.strip():
            continue
        key, sep, value = part.partition("=")
        try:
            number, code = int(key.strip()), int(value.strip())
        except ValueError:
            raise OptionError(f"option {name}: {part.strip()!r} is not NUMBER=CODE") from None
        if not sep or not low <= abs(number) <= high or not 0 <= code <= 99:
            raise OptionError(f"option {name}: {part.strip()!r} is not NUMBER=CODE (code 00-99)")
        result[number] = code
    return result


def read_profile(program: Program, options: Mapping[str, Any]) -> Profile:
    """The profile from parsed option values. Raises OptionError for malformed tables and
    fixed-cycle or index codes the 1704 does not have for them."""
    units = options["units"]
    metric = units == "metric" or (units == "program" and program.units is Units.MM)
    resolution = options["resolution"]
    if metric:
        if resolution != "standard":
            raise OptionError(
                "option resolution: options 1 and 2 are inch formats; a metric tape uses the "
                "metric option's X3.3 F4 format (set units=inch for an inch tape)"
            )
        fmt = FORMAT_METRIC
    else:
        fmt = {"standard": FORMAT_STANDARD, "option1": FORMAT_OPTION1}.get(
            resolution, FORMAT_OPTION2
        )
    for name in ("drill-cycle", "bore-cycle"):
        code = int(options[name])
        if code and not 81 <= code <= 89:
            raise OptionError(f"option {name}: the 1704's fixed cycles are G81-G89 (or 0: none)")
    index_m = int(options["index-m"])
    if index_m in _RESERVED_M - {0}:
        raise OptionError(
            f"option index-m: M{index_m:02d} has its own meaning; the user's codes are "
            "M10-M29 and M31-M99 (seed 000 §2)"
        )
    tool_text = str(options["tool-codes"]).strip()
    spindle_text = str(options["spindle-codes"]).strip()
    title = str(options["title"]).strip() or f"{program.name} {program.part_number}".strip()
    return Profile(
        fmt=fmt,
        circular=bool(options["circular"]),
        tolerance_nm=to_nm(Decimal(options["tolerance"]), Units.INCH),
        drill_cycle=int(options["drill-cycle"]),
        bore_cycle=int(options["bore-cycle"]),
        dwell=bool(options["dwell"]),
        quill=bool(options["quill"]),
        spindle_codes=(
            _code_table("spindle-codes", spindle_text, 1, 99999) if spindle_text else None
        ),
        tool_codes=(
            _code_table("tool-codes", tool_text, 0, 99)
            if tool_text and tool_text.lower() != "number"
            else None
        ),
        tool_code_is_number=tool_text.lower() == "number",
        index_m=index_m,
        g94=options["z-zero"] == "g94",
        sequence=bool(options["sequence"]),
        sequence_start=int(options["sequence-start"]),
        sequence_increment=int(options["sequence-increment"]),
        tabs=bool(options["tabs"]),
        end_code=2 if options["end-code"] == "M02" else 30,
        ident=bool(options["ident"]),
        title=title,
        leader_rows=_rows(Decimal(options["leader"])),
        trailer_rows=_rows(Decimal(options["trailer"])),
        tool_change_rows=_rows(Decimal(options["tool-change-leader"])),
        decel=bool(options["decel"]),
        xyz_together=options["xyz"] == "together",
        tape_search=bool(options["tape-search"]),
        leading_zeros=options["zeros"] == "0",
    )


# --- the plan: motions and auxiliary blocks ----------------------------------------------


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


@dataclass
class Tape:
    """A 1704 tape: the listing and how it is punched."""

    code: TapeCode
    title: str
    header: list[str]
    lines: list[Line]
    leader_rows: int
    trailer_rows: int
    fmt: TapeFormat

    @property
    def text(self) -> str:
        """The listing: rewind stop, header comments, one block per line."""
        body = [tapecode.REWIND_STOP_CHAR, *self.header, *(line.text for line in self.lines)]
        return "\n".join(body) + "\n"

    def leader(self, ident: bool) -> bytes:
        """Blank tape, with the title punched as letters after the first 2 in when `ident`."""
        title = tapecode.title_rows(self.title) if ident and self.title else b""
        if not title:
            return bytes(self.leader_rows)
        margin = 2 * tapecode.ROWS_PER_INCH
        after = max(margin, self.leader_rows - margin - len(title))
        return bytes(margin) + title + bytes(after)

    def punch(self, ident: bool = True) -> bytes:
        """The punch image: one row per byte, channel n in bit n-1."""
        return self.rows_and_labels(ident)[0]

    def rows_and_labels(self, ident: bool = True) -> tuple[bytes, list[str]]:
        """The punch image and, for each row, what it is (`` for blank tape)."""
        leader = self.leader(ident)
        rows = bytearray(leader)
        labels = [""] * len(leader)
        names = {
            tapecode.EOB_CHAR: "EOB",
            "\t": "TAB",
            " ": "SP",
            tapecode.REWIND_STOP_CHAR: "ER" if self.code is TapeCode.EIA else "%",
        }

        def put(text: str, blank_after: int = 0) -> None:
            rows.extend(tapecode.encode(text, self.code))
            labels.extend(names.get(ch, ch) for ch in text)
            rows.extend(bytes(blank_after))
            labels.extend([""] * blank_after)

        put(tapecode.REWIND_STOP_CHAR + tapecode.EOB_CHAR)
        for text in self.header:
            put(text + tapecode.EOB_CHAR)
        for line in self.lines:
            put(line.text + tapecode.EOB_CHAR, line.leader_after)
        put("", self.trailer_rows)
        return bytes(rows), labels


def _first_feed(items: list[Item], index: int) -> int:
    """The feed (nm/min) of the first cut of the data block whose first motion is
    `items[index]` (0 when the block does not cut)."""
    block = items[index].block
    for item in items[index:]:
        if item.block != block:
            break
        if isinstance(item, Motion) and item.kind is not Kind.RAPID:
            return item.feed
    return 0


def _sanitize_comment(text: str) -> str:
    """Comment text the ASCII table can punch: upper case, no parentheses, no `%`."""
    allowed = set("ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789 .,-+/:=*#")
    cleaned = "".join(ch if ch in allowed else " " for ch in text.upper())
    return " ".join(cleaned.split())


class _Builder:
    """Toolpath + profile → Tape, reporting as it goes. One use per export."""

    def __init__(
        self,
        program: Program,
        toolpath: Toolpath,
        profile: Profile,
        code: TapeCode,
        report: Report,
    ) -> None:
        self.program = program
        self.toolpath = toolpath
        self.profile = profile
        self.fmt = profile.fmt
        self.code = code
        self.comments = code is TapeCode.ASCII
        self.report = report
        self.two_axis = program.is_two_axis

    # -- pass 1: moves → items (nm) ------------------------------------------------------

    def machine_z(self, z: int, tool: int) -> int | None:
        """The control's Z for toolpath Z `z` with `tool` (None in a two-axis program).

        With TCAL: Z + TCAL, an uncalibrated tool counting as TCAL 0 as the tool path does
        (toolpath.ToolChange), so head moves stay exact; only where its tip is is unknown.
        With G94: the tool's own Z, zero where the operator touched it off.
        """
        if self.two_axis:
            return None
        if self.profile.g94:
            return z
        info = self.toolpath.tools.get(tool)
        return z + (0 if info is None or info.tcal is None else info.tcal)

    def uncalibrated(self, tool: int) -> bool:
        """True when Z words for `tool` cannot place its tip (TCAL mode, no TCAL)."""
        if self.two_axis or self.profile.g94 or tool == 0:
            return False
        info = self.toolpath.tools.get(tool)
        return info is None or info.tcal is None

    def plan(self) -> list[Item]:
        tp, profile, report = self.toolpath, self.profile, self.report
        items: list[Item] = []
        tool = tp.initial_tool
        x, y, z = tp.start
        changes = 0
        warned_uncalibrated: set[int] = set()
        if profile.quill and not self.two_axis:
            block = next((m.block for m in tp.moves if isinstance(m, Rapid | Feed)), 0)
            report.error(
                block,
                "quill=yes is a two-axis 1704 with a quill actuator: it cannot move Z, and "
                "this program has depths",
            )
        moves = tp.moves
        index = 0
        while index < len(moves):
            move = moves[index]
            index += 1
            if isinstance(move, Rapid | Feed | ArcFeed):
                mz = self.machine_z(move.z, tool)
                if self.uncalibrated(tool):
                    if not isinstance(move, Rapid) or move.z < z:
                        report.error(
                            move.block,
                            f"tool {tool} is not calibrated (TCAL ****): its Z words cannot "
                            "place the tip for this move; calibrate it in Data Block 0 or use "
                            "z-zero=g94",
                        )
                    elif tool not in warned_uncalibrated:
                        warned_uncalibrated.add(tool)
                        report.warning(
                            move.block,
                            f"tool {tool} is not calibrated: its Z words take TCAL as 0, so "
                            "the tip's height above the part is not known",
                        )
                if isinstance(move, Rapid):
                    cycle = self.match_cycle(moves, index - 1, (x, y, z), tool)
                    if cycle is not None:
                        motion, used = cycle
                        items.append(motion)
                        index += used - 1
                        x, y, z = motion_end(moves, index)
                        continue
                    items.append(Motion(move.block, Kind.RAPID, (move.x, move.y, mz), tag=move.tag))
                elif isinstance(move, Feed):
                    items.append(
                        Motion(move.block, Kind.LINE, (move.x, move.y, mz), feed=move.feed)
                    )
                elif profile.circular:
                    items.append(
                        Motion(
                            move.block,
                            Kind.ARC,
                            (move.x, move.y, mz),
                            centre=(move.cx, move.cy),
                            clockwise=move.clockwise,
                            feed=move.feed,
                            full_circle=(move.x, move.y) == (x, y),
                        )
                    )
                else:
                    items.extend(self.chords(move, (x, y), mz, tool))
                x, y, z = move.x, move.y, move.z
                continue
            if isinstance(move, ProgramStop) and self.quill_hole(move, items, (x, y)):
                continue
            items.extend(self.aux(move, changes))
            if isinstance(move, ToolChange):
                # The head does not move; its height reads move.z with the new tool.
                changes += 1
                tool, z = move.tool, move.z
                if profile.g94:
                    # Touched off at its zero, preset there, straight up before anything else.
                    items.append(Aux(move.block, [("G", "94"), ("Z", "0")], preset_z=True))
                    items.append(Motion(move.block, Kind.RAPID, (x, y, z), z_only=True))
        items = self.mark_restarts(items)
        return self.merge_positioning(items) if profile.xyz_together else items

    def quill_hole(self, stop: ProgramStop, items: list[Item], at: tuple[int, int]) -> bool:
        """With the quill actuator, a two-axis hole is its drill cycle (G99): the rapid to
        the hole carries it, or M51 M50 cycle the quill where the table already is. TAP
        stays an operator stop (the quill cannot reverse the spindle). True when handled."""
        text = stop.reason.removeprefix("quill:").strip()
        if not (self.profile.quill and stop.reason.startswith("quill:")):
            return False
        if text.split()[0] not in ("DRILL", "BORE"):
            return False
        self.report.rewritten(stop.block, f"{text}: the quill actuator's drill cycle (G99)")
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

    def mark_restarts(self, items: list[Item]) -> list[Item]:
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
        here: tuple[int, int, int | None] = (
            self.toolpath.start[0],
            self.toolpath.start[1],
            self.machine_z(self.toolpath.start[2], self.toolpath.initial_tool),
        )
        in_cut: list[int] = []  # data blocks that start in a cut: no restart there
        out: list[Item] = []
        for index, item in enumerate(items):
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
                feed = _first_feed(items, index)
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
        if in_cut:
            self.report.note(
                None,
                f"tape search: {blocks_text(in_cut)} continue a cut and are no place to "
                "restart; search to the N of the block that starts the cut",
            )
        return out

    def search_group(
        self,
        item: Motion,
        here: tuple[int, int, int | None],
        feed: int,
        spindle: Aux | None,
        coolant: Aux | None,
    ) -> list[Item]:
        """The blocks before `item` that let the operator start the tape there (see
        `mark_restarts`): the coolant, then the searched positioning where the tool is,
        carrying the spindle and the feed."""
        group: list[Item] = []
        if coolant is not None:
            group.append(Aux(item.block, list(coolant.words)))
        if spindle is not None:
            # S (when a spindle code table gives one) and M03/M04 ride on the searched block.
            group.append(Aux(item.block, list(spindle.words), forward=True, restate=True))
        group.append(Motion(item.block, Kind.RAPID, here, restart=True, search_feed=feed))
        return group

    def merge_positioning(self, items: list[Item]) -> list[Item]:
        """xyz=together (seed 002 XYZ/ON): the positioning rapids of one block (up, across,
        down) become one XYZ move. A retract out of the work (tagged `retract`, `peck-…`)
        is never merged: it stays straight up."""

        def positioning(item: Item | None) -> bool:
            return (
                isinstance(item, Motion)
                and item.kind is Kind.RAPID
                and not item.quill_cycle
                and not item.z_only
                and not item.tag
            )

        merged: list[Item] = []
        for item in items:
            previous = merged[-1] if merged else None
            if (
                positioning(item)
                and positioning(previous)
                and isinstance(item, Motion)
                and isinstance(previous, Motion)
                and previous.block == item.block
            ):
                previous.end = item.end
                self.report.rewritten(
                    item.block,
                    "positioning in one XYZ rapid (xyz=together): check the clearance, the "
                    "head no longer rises before it moves across",
                )
                continue
            merged.append(item)
        return merged

    def chords(self, arc: ArcFeed, start: tuple[int, int], mz: int | None, tool: int) -> list[Item]:
        """The chord method (seed 000 §3, Fig. 3-2): end points on the circle, equal steps.

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
        info = self.toolpath.tools.get(tool)
        tool_radius = 0.0 if info is None or info.diameter is None else info.diameter / 2
        rounding = self.fmt.step_nm * math.sqrt(2) / 2
        allowed = self.profile.tolerance_nm * radius / (radius + tool_radius) - rounding
        if allowed <= 0:
            self.report.error(
                arc.block,
                "the chord tolerance is finer than the tape's resolution can hold on this arc",
            )
            allowed = radius
        step = math.pi / 2 if allowed >= radius else 2 * math.acos(1 - allowed / radius)
        step = min(step, math.pi / 2)
        sweep = arc_sweep((start[0], start[1]), (arc.x, arc.y), (cx, cy), arc.clockwise)
        count = max(1, math.ceil(sweep / step - 1e-9))
        a0 = math.atan2(start[1] - cy, start[0] - cx)
        sign = -1.0 if arc.clockwise else 1.0
        motions: list[Item] = []
        for k in range(1, count + 1):
            if k == count:
                end = (arc.x, arc.y)
            else:
                angle = a0 + sign * sweep * k / count
                end = (round(cx + radius * math.cos(angle)), round(cy + radius * math.sin(angle)))
            motions.append(Motion(arc.block, Kind.LINE, (end[0], end[1], mz), feed=arc.feed))
        self.report.rewritten(
            arc.block,
            f"arc written as {count} chords (no circular interpolation; chord tolerance "
            f"{format_length(self.profile.tolerance_nm, Units.INCH)} in on the part)",
        )
        return motions

    def match_cycle(
        self,
        moves: Sequence[Move],
        index: int,
        at: tuple[int, int, int],
        tool: int,
    ) -> tuple[Motion, int] | None:
        """A hole the profile's fixed cycle makes the same way, starting at moves[index].

        DRILL: rapid down to Z UP, feed to Z DN, dwell (then the retract rapid, written as
        itself). BORE: the same with a feed back out to Z UP. The cycle's R plane is Z UP;
        the head starts above it (sequence 2 of seed 000 §4 "R Clearance Coordinate").
        """
        profile = self.profile
        if not (profile.drill_cycle or profile.bore_cycle) or self.two_axis:
            return None
        window = list(moves[index : index + 4])
        if len(window) < 3:
            return None
        down, feed, dwell = window[0], window[1], window[2]
        x, y, z = at
        if not (
            isinstance(down, Rapid)
            and isinstance(feed, Feed)
            and isinstance(dwell, Dwell)
            and (down.x, down.y) == (x, y)
            and down.z < z
            and (feed.x, feed.y) == (x, y)
            and feed.z < down.z
            and down.block == feed.block == dwell.block
        ):
            return None
        hole = self.hole_block(down.block)
        if hole is None or not hole.has_depth or down.tag:
            return None
        out = window[3] if len(window) > 3 else None
        bore = isinstance(out, Feed) and (out.x, out.y, out.z) == (x, y, down.z)
        if hole.op is HoleOp.DRILL and hole.pecks == 1 and not bore:
            code = profile.drill_cycle
        elif hole.op is HoleOp.BORE and bore:
            code = profile.bore_cycle
        else:
            if hole.op is HoleOp.DRILL and hole.pecks > 1 and profile.drill_cycle:
                self.report.note(
                    down.block,
                    "pecked holes are written as moves: the 1704's deep-hole cycle pecks on "
                    "a timer, not at the program's levels",
                )
            return None
        if not code:
            return None
        r_plane = self.machine_z(down.z, tool)
        depth = self.machine_z(feed.z, tool)
        if r_plane is None or depth is None:
            return None
        self.report.rewritten(
            down.block,
            f"hole as fixed cycle G{code} (R at Z UP): its dwell is the panel timer's "
            f"(1.3-12 s), not {dwell.seconds} s",
        )
        motion = Motion(
            down.block,
            Kind.CYCLE,
            (x, y, r_plane),
            feed=feed.feed,
            cycle_code=code,
            cycle_depth=depth,
        )
        return motion, 4 if bore else 3

    def hole_block(self, number: int) -> Hole | None:
        """The DRILL/BORE/TAP block that gives hole `number`'s parameters (for a BOLT CIR,
        the block before it), or None when block `number` drills no hole."""
        if not 1 <= number <= len(self.program.blocks):
            return None
        block = self.program.block(number)
        if isinstance(block, BoltCircle) and number > 1:
            block = self.program.block(number - 1)
        return block if isinstance(block, Hole) else None

    def aux(self, move: Move, changes: int) -> list[Item]:
        """The blocks for a move that is not motion."""
        profile, report, block = self.profile, self.report, move.block
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
        profile, report = self.profile, self.report
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
        info = self.toolpath.tools.get(tool)
        units = self.toolpath.units
        parts = [f"TOOL {tool}"]
        if info is not None and info.diameter is not None:
            parts.append(f"DIA {format_length(info.diameter, units)}")
        if not self.profile.g94 and info is not None and info.tcal is not None:
            parts.append(f"TCAL {format_length(info.tcal, units)}")
        return " ".join(parts)

    def stop(self, move: ProgramStop) -> list[Item]:
        """STOP is M00; a two-axis program's quill stops use the quill actuator when the
        profile has it (M51 down, M50 up, G99 drill cycles), else M00 with the instruction."""
        report, block, reason = self.report, move.block, move.reason
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
        return [Aux(block, [("M", "00")], _sanitize_comment(text) if self.comments else "")]

    # -- pass 2: round to the tape's resolution, split arcs at the quadrants -------------

    def rounded(self, items: list[Item]) -> list[Item]:
        fmt, report = self.fmt, self.report
        start = self.toolpath.start
        tool = self.toolpath.initial_tool
        sz = self.machine_z(start[2], tool)
        pos: tuple[int, int, int | None] = (
            fmt.units(start[0]),
            fmt.units(start[1]),
            None if sz is None else fmt.units(sz),
        )
        out: list[Item] = []
        carry_restart = False
        for item in items:
            if isinstance(item, Aux):
                if item.preset_z:
                    pos = (pos[0], pos[1], 0)
                out.append(item)
                continue
            ex, ey, ez = item.end
            end = (fmt.units(ex), fmt.units(ey), None if ez is None else fmt.units(ez))
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
                out.append(item)
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
                out.extend(pieces)
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
            out.append(item)
            pos = (end[0], end[1], end[2] if end[2] is not None else pos[2])
        return out

    def check_capacity(self, block: int, point: Sequence[int | None], axes: str = "XYZ") -> None:
        limit = self.fmt.max_units
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
        start: tuple[int, int, int | None],
        end: tuple[int, int, int | None],
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

    # -- pass 3: G codes by the motion rules ---------------------------------------------

    def choose_g(self, items: list[Item]) -> None:
        """G01/G02/G03 only into a feed move whose direction changes by 30° or less; G00,
        G20, G30 otherwise (terminal motion, the last move, before any auxiliary block)."""
        starts = self.starts(items)
        for index, item in enumerate(items):
            if not isinstance(item, Motion):
                continue
            if item.kind is Kind.RAPID:
                item.gcode = "50"
                continue
            if item.kind is Kind.CYCLE:
                item.gcode = f"{item.cycle_code:02d}"
                continue
            following = items[index + 1] if index + 1 < len(items) else None
            smooth = False
            if (
                not self.profile.decel
                and isinstance(following, Motion)
                and following.kind in (Kind.LINE, Kind.ARC)
                and not following.quill_cycle
            ):
                out = tangent_out(item, starts[index])
                into = tangent_in(following, starts[index + 1])
                smooth = turn_degrees(out, into) <= 30.0 + 1e-9
            if item.kind is Kind.LINE:
                item.gcode = "01" if smooth else "00"
            elif item.clockwise:
                item.gcode = "02" if smooth else "20"
            else:
                item.gcode = "03" if smooth else "30"

    def starts(self, items: list[Item]) -> list[tuple[int, int, int | None]]:
        """Where each item starts (tape units), for the direction rules."""
        start = self.toolpath.start
        sz = self.machine_z(start[2], self.toolpath.initial_tool)
        pos: tuple[int, int, int | None] = (
            self.fmt.units(start[0]),
            self.fmt.units(start[1]),
            None if sz is None else self.fmt.units(sz),
        )
        result = []
        for item in items:
            result.append(pos)
            if isinstance(item, Aux):
                if item.preset_z:
                    pos = (pos[0], pos[1], 0)
            else:
                z = item.end[2] if item.end[2] is not None else pos[2]
                pos = (item.end[0], item.end[1], z)
        return result

    # -- pass 4: words ---------------------------------------------------------------------

    def write(self, items: list[Item]) -> list[Line]:
        profile, fmt = self.profile, self.fmt
        lines: list[Line] = []
        g: str | None = None
        pos: list[int | None] = [None, None, None]
        ij: list[int | None] = [None, None]
        feed: int | None = None
        s_code: str | None = None
        g99 = False
        carried: list[tuple[str, str]] = []
        starts = self.starts(items)
        number = profile.sequence_start
        wrapped = False

        def emit(
            words: list[tuple[str, str]],
            block: int,
            comment: str = "",
            motion: Motion | None = None,
            start: tuple[int, int, int | None] | None = None,
            feed_before: int | None = None,
            leader_after: int = 0,
        ) -> None:
            nonlocal number, wrapped
            if profile.sequence:
                if number > 999 and not wrapped:
                    wrapped = True
                    self.report.warning(
                        block,
                        "sequence numbers pass N999 here and start again at N000 (the N word "
                        "has three digits; a tape search stops at the first match)",
                    )
                words = [("N", str(number % 1000)), *words]
                number += profile.sequence_increment
            joiner = "\t" if profile.tabs else ""
            text = joiner.join(letter + value for letter, value in words)
            if comment:
                text += f" ({comment})"
            line = Line(text, block, leader_after=leader_after)
            if motion is not None and start is not None and motion.gcode in ("01", "02", "03"):
                line.continuous = True
                line.length = motion_length(motion, start) * fmt.digit_nm / fmt.unit_nm
                line.feed_end = motion.feed
                line.feed_start = motion.feed if feed_before is None else feed_before
            lines.append(line)

        for index, item in enumerate(items):
            if isinstance(item, Aux):
                following = items[index + 1] if index + 1 < len(items) else None
                if (
                    item.forward
                    and isinstance(following, Motion)
                    and following.kind is Kind.RAPID
                    and not any(letter == "G" for letter, _ in item.words)
                ):
                    carried.extend(
                        item.words if item.restate else self.spindle_words(item.words, s_code)
                    )
                    s_code = next((v for k, v in item.words if k == "S"), s_code)
                    continue
                if g99 and item.words[-1] in (("M", "30"), ("M", "02")):
                    emit([("G", "98")], item.block)  # no drill cycle left on for the next run
                    g99 = False
                words = self.spindle_words(item.words, s_code)
                s_code = next((v for k, v in item.words if k == "S"), s_code)
                if not words and not item.comment:
                    continue
                emit(words, item.block, item.comment, leader_after=item.leader_after)
                if any(letter == "G" for letter, _ in words):
                    g = None  # G04 and G94 act in their block only; state the mode again
                if item.preset_z:
                    pos[2] = 0
                continue
            start = starts[index]
            if item.restart:
                pos = [None, None, None]
                ij = [None, None]
                g, feed = None, None
            if item.quill_cycle != g99:
                emit([("G", "99" if item.quill_cycle else "98")], item.block)
                g99 = item.quill_cycle
                g = None  # state the motion mode again after the quill's G
            words = []
            if item.gcode != g:
                words.append(("G", item.gcode))
            ex, ey, ez = item.end
            arc = item.kind is Kind.ARC
            for axis, value in enumerate((ex, ey)):
                if not item.z_only and (arc or item.quill_cycle or value != pos[axis]):
                    words.append(("XY"[axis], self.number(value)))
            if item.kind is Kind.CYCLE:
                words.append(("Z", self.number(item.cycle_depth)))
                assert ez is not None
                words.append(("R", self.number(ez)))
            elif ez is not None and not arc and ez != pos[2]:
                words.append(("Z", self.number(ez)))
            if arc:
                assert item.centre is not None
                for axis, value in enumerate(item.centre):
                    if value != ij[axis]:
                        words.append(("IJ"[axis], self.number(value)))
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
            emit(words, item.block, motion=item, start=start, feed_before=feed_before)
            g = item.gcode
            pos = [ex, ey, ez if ez is not None else pos[2]]
        if g99:
            emit([("G", "98")], items[-1].block if items else 0)
        return lines

    def spindle_words(
        self, words: list[tuple[str, str]], s_code: str | None
    ) -> list[tuple[str, str]]:
        """Drop an S word that repeats the speed already set (S is modal)."""
        return [(k, v) for k, v in words if not (k == "S" and v == s_code)]

    def number(self, units: int) -> str:
        """A motion word's digits: sign only when negative, no point; leading zeros only
        with zeros=0 (then every digit of the format is punched)."""
        digits = str(abs(units))
        if self.profile.leading_zeros:
            digits = digits.zfill(self.fmt.int_digits + self.fmt.frac_digits)
        return ("-" if units < 0 else "") + digits

    def feed_word(self, value: int) -> str:
        """An F word's digits (F3.1: four, F4: four), leading zeros only with zeros=0."""
        return str(value).zfill(4) if self.profile.leading_zeros else str(value)

    # -- the whole -------------------------------------------------------------------------

    def build(self) -> Tape:
        items = self.rounded(self.plan())
        self.choose_g(items)
        lines = self.write(items)
        tape = Tape(
            code=self.code,
            title=tapecode.title_text(self.profile.title) if self.profile.ident else "",
            header=self.header(),
            lines=lines,
            leader_rows=self.profile.leader_rows,
            trailer_rows=self.profile.trailer_rows,
            fmt=self.fmt,
        )
        if not tapecode.can_encode(tape.text, self.code):
            self.report.error(None, f"the listing has characters {self.code.value} cannot punch")
            return tape
        self.check_reader(tape)
        self.notes(tape)
        return tape

    def header(self) -> list[str]:
        """ASCII only: the set-up a machinist needs, as comment blocks after the rewind stop."""
        tp, program = self.toolpath, self.program
        units = tp.units
        ox, oy = tp.origin
        offsets = f"X{format_length(ox, units)} Y{format_length(oy, units)}"
        if not self.comments:
            if (ox, oy) != (0, 0):
                self.report.unsupported(
                    None,
                    f"Data Block 0 part zero at table {offsets} {units.symbol}: EIA tapes "
                    "carry no comments; set the floating zero there by hand",
                )
            return []
        name = _sanitize_comment(f"{program.name} {program.part_number}")
        start = format_length(tp.start[2], units)
        lines = [
            f"({name})",
            f"(PART ZERO AT TABLE {offsets} {units.symbol.upper()})",
            f"(START OVER PART ZERO, Z{start} ABOVE TOOL ZERO)",
        ]
        if self.two_axis:
            lines.append("(TWO-AXIS PROGRAM: THE QUILL SETS DEPTH)")
        elif self.profile.g94:
            lines.append("(Z ZERO: EACH TOOL TOUCHED OFF AT ITS ZERO, G94)")
        else:
            lines.append("(Z ZERO WHERE TCAL IS 0: Z WORDS INCLUDE EACH TOOL TCAL)")
        if tp.initial_tool:
            # The first tool has no M06 to carry its comment: say here which tool the tape
            # starts with, its diameter and (with TCAL) the calibration its Z words include.
            lines.append(f"(FIRST {_sanitize_comment(self.tool_comment(tp.initial_tool))})")
        return lines

    def check_reader(self, tape: Tape) -> None:
        """Seed 000 §3 "Reader Limitation" (scan-damaged formulas, DESIGN.md's reading):
        T1 = 60·L / ((F1 + F2)/2) to execute a non-decelerated block, T2 = 0.010 + (N − 1)/300
        to read the next one (N characters, its End of Block included); warn where T2 > T1."""
        fmt = tape.fmt
        lines = tape.lines
        for index, line in enumerate(lines[:-1]):
            if not line.continuous or line.length <= 0:
                continue
            following = lines[index + 1]
            characters = len(following.text) + 1
            f1 = line.feed_start * fmt.feed_unit_nm / fmt.unit_nm
            f2 = line.feed_end * fmt.feed_unit_nm / fmt.unit_nm
            t1 = 60 * line.length / ((f1 + f2) / 2)
            t2 = 0.010 + (characters - 1) / 300
            if t2 > t1:
                self.report.warning(
                    line.block,
                    f"reader limitation: {line.text.split(' (')[0].replace(chr(9), ' ')} "
                    f"moves {line.length:.4f} "
                    f"{fmt.unit} in {t1:.3f} s but the next block ({characters} characters) "
                    f"takes {t2:.3f} s to read: the slides may stop and dwell (seed 000 §3)",
                )

    def notes(self, tape: Tape) -> None:
        fmt, report, profile = self.fmt, self.report, self.profile
        digits = f"{fmt.int_digits}.{fmt.frac_digits}"
        feed = "F3.1 (0.1 ipm)" if fmt.feed_unit_nm == 2_540_000 else f"F4 (1 {fmt.feed_name})"
        report.note(
            None,
            f"{self.code.value.upper()} tape, {fmt.name}: X Y Z I J R words {digits} ({fmt.unit}), "
            f"{feed}, leading zeros dropped, no decimal point",
        )
        if fmt.metric != (self.toolpath.units is Units.MM):
            report.rewritten(
                None,
                f"the {self.toolpath.units.value} program is punched in {fmt.unit} "
                "(rounded once to the tape's resolution)",
            )
        elif fmt.metric:
            report.note(None, "metric program: the machine needs the 1704's metric option")
        if self.two_axis:
            report.note(None, "two-axis program: no Z words (the quill sets the depth)")
        elif profile.g94:
            report.note(
                None,
                "Z: start with the first tool touched off at its zero and Z preset to 0 there",
            )
        else:
            report.note(
                None,
                "Z: set the 1704's Z zero where the data-block control's TCAL reads 0; each "
                "Z word is the tool's Z plus its TCAL (the 1704 has no length offsets)",
            )
        start = self.toolpath.start
        units = self.toolpath.units
        report.note(
            None,
            f"start with the spindle over part zero (X0 Y0), the tool "
            f"{format_length(start[2], units)} {units.symbol} above its zero; G50 moves at "
            "the machine's rapid traverse",
        )
        rows = len(tape.punch(profile.ident))
        feet = rows / tapecode.ROWS_PER_INCH / 12
        report.note(
            None,
            f"tape length {feet:.1f} ft ({rows} rows at {tapecode.ROWS_PER_INCH} rows per "
            "inch, leader and trailer included)",
        )


def motion_end(moves: Sequence[Move], index: int) -> tuple[int, int, int]:
    """The toolpath position after moves[:index] (the last motion's end)."""
    for move in reversed(moves[:index]):
        if isinstance(move, Rapid | Feed | ArcFeed):
            return move.x, move.y, move.z
    raise ValueError("no motion before this point")


Vector = tuple[float, float, float]


def tangent_out(motion: Motion, start: tuple[int, int, int | None]) -> Vector:
    """The direction a motion ends in (an arc's tangent at its end point)."""
    ex, ey, ez = motion.end
    if motion.kind is Kind.ARC and motion.centre is not None:
        rx, ry = ex - motion.centre[0], ey - motion.centre[1]
        return (ry, -rx, 0.0) if motion.clockwise else (-ry, rx, 0.0)
    dz = 0 if ez is None or start[2] is None else ez - start[2]
    return (ex - start[0], ey - start[1], dz)


def tangent_in(motion: Motion, start: tuple[int, int, int | None]) -> Vector:
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


def motion_length(motion: Motion, start: tuple[int, int, int | None]) -> float:
    """A motion's path length in tape units (an arc along its circle)."""
    ex, ey, ez = motion.end
    if motion.kind is Kind.ARC and motion.centre is not None:
        cx, cy = motion.centre
        radius = math.hypot(start[0] - cx, start[1] - cy)
        sweep = arc_sweep((start[0], start[1]), (ex, ey), (cx, cy), motion.clockwise)
        return radius * sweep
    dz = 0 if ez is None or start[2] is None else ez - start[2]
    return math.sqrt((ex - start[0]) ** 2 + (ey - start[1]) ** 2 + dz**2)


def build_tape(
    program: Program,
    toolpath: Toolpath,
    options: Mapping[str, Any],
    code: TapeCode,
    report: Report,
) -> Tape:
    """The 1704 tape for a validated program, reporting what it could not express.

    Raises OptionError for malformed option tables (see `read_profile`).
    """
    profile = read_profile(program, options)
    return _Builder(program, toolpath, profile, code, report).build()


# --- the drawing ------------------------------------------------------------------------

# Tape geometry in 0.01 in (EIA RS-227 / ECMA-10, 1-inch 8-track tape): tracks 0.1 in apart,
# the feed-hole track between channels 3 and 4, code holes 0.072 in, feed holes 0.046 in.
_PITCH = 10
_TRACK_Y = {8: 10, 7: 20, 6: 30, 5: 40, 4: 50, 0: 60, 3: 70, 2: 80, 1: 90}  # 0: feed holes


def tape_svg(tape: Tape, ident: bool = True) -> str:
    """The tape drawn at full size like the manual's Fig. 1-4: eight channels (8 at the top),
    the feed-hole track, the punched title, each character named under its row."""
    rows, labels = tape.rows_and_labels(ident)
    left, right, top, tape_height, legend = 40, 20, 45, 100, 30
    width = left + len(rows) * _PITCH + right
    height = top + tape_height + legend
    feet = len(rows) / tapecode.ROWS_PER_INCH / 12
    parity = "odd parity, EIA RS-244" if tape.code is TapeCode.EIA else "even parity, ASCII"
    heading = html.escape(tape.title or "(no title)")
    info = (
        f"Tektronix 1704 tape, {tape.code.value.upper()} ({parity}), {len(rows)} rows at "
        f"{tapecode.ROWS_PER_INCH} per inch, {feet:.1f} ft"
    )
    out = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width / 100:.2f}in" '
        f'height="{height / 100:.2f}in" viewBox="0 0 {width} {height}">',
        f"<title>{heading}</title>",
        f'<text x="{left}" y="16" font-family="monospace" font-size="12">{heading}</text>',
        f'<text x="{left}" y="32" font-family="monospace" font-size="8">{info}</text>',
        f'<rect x="{left}" y="{top}" width="{len(rows) * _PITCH}" height="{tape_height}" '
        'fill="#f2e6c9" stroke="#8a7a5a" stroke-width="0.5"/>',
        '<g font-family="monospace" font-size="7" text-anchor="middle">',
    ]
    for channel, offset in _TRACK_Y.items():
        name = str(channel) if channel else "F"
        out.append(f'<text x="{left - 10}" y="{top + offset + 2}">{name}</text>')
    out.append("</g>")
    out.append('<g fill="#6b6b6b">')
    for index in range(len(rows)):
        x = left + _PITCH // 2 + index * _PITCH
        out.append(f'<circle cx="{x}" cy="{top + _TRACK_Y[0]}" r="2.3"/>')
    out.append("</g>")
    out.append('<g fill="#1a1a1a">')
    for index, row in enumerate(rows):
        x = left + _PITCH // 2 + index * _PITCH
        for channel in range(1, 9):
            if row & (1 << (channel - 1)):
                out.append(f'<circle cx="{x}" cy="{top + _TRACK_Y[channel]}" r="3.6"/>')
    out.append("</g>")
    out.append('<g font-family="monospace" font-size="6">')
    base = top + tape_height + 4
    for index, label in enumerate(labels):
        if label:
            x = left + _PITCH // 2 + index * _PITCH - 2
            out.append(
                f'<text transform="translate({x} {base}) rotate(90)">{html.escape(label)}</text>'
            )
    out.append("</g>")
    out.append("</svg>")
    return "\n".join(out) + "\n"


# --- the targets --------------------------------------------------------------------------


class _TapeTarget(Target):
    """Shared by the five 1704 targets: the profile options and the tape they are made of."""

    code: ClassVar[TapeCode] = TapeCode.EIA
    options: ClassVar[tuple[Option, ...]] = PROFILE_OPTIONS
    reads_back: ClassVar[str | None] = "tape"
    picture = "tape-svg"

    def picture_options(self, options: Mapping[str, str]) -> dict[str, str]:
        # The same tape, drawn in this target's code.
        return dict(options) | {"code": self.code.value}

    def needs_for(self, options: Mapping[str, Any]) -> frozenset[Need]:
        # Without a spindle code table the tape has no S word: the speed is set by hand. Z
        # words include each tool's TCAL unless each tool is touched off (G94).
        needs = set()
        if str(options["spindle-codes"]).strip():
            needs.add(Need.SPINDLE_SPEEDS)
        if options["z-zero"] == "tcal":
            needs.add(Need.CALIBRATED_TOOLS)
        return frozenset(needs)

    def need_hint(self, need: Need) -> str:
        if need is Need.CALIBRATED_TOOLS:
            return "or export with z-zero=g94 to touch off each tool at its change"
        return ""

    def tape(
        self,
        program: Program,
        toolpath: Toolpath,
        options: Mapping[str, Any],
        report: Report,
        code: TapeCode | None = None,
    ) -> Tape:
        return build_tape(program, toolpath, options, code or self.code, report)

    def emit(
        self, program: Program, toolpath: Toolpath, options: Mapping[str, Any], report: Report
    ) -> bytes:
        return self.tape(program, toolpath, options, report).text.encode("ascii")


@register
class TapeEiaTarget(_TapeTarget):
    name = "tape-eia"
    label = "1704 tape, EIA (listing)"
    description = "Tektronix 1704 tape listing for an EIA RS-244 tape (word address text)"
    extension = "eia.txt"
    code = TapeCode.EIA


@register
class TapeAsciiTarget(_TapeTarget):
    name = "tape-ascii"
    label = "1704 tape, ASCII (listing)"
    description = "Tektronix 1704 tape listing for an ASCII tape, with comments (text)"
    extension = "ascii.txt"
    code = TapeCode.ASCII


class _PunchTarget(_TapeTarget):
    media_type = "application/octet-stream"
    binary = True

    def emit(
        self, program: Program, toolpath: Toolpath, options: Mapping[str, Any], report: Report
    ) -> bytes:
        tape = self.tape(program, toolpath, options, report)
        return tape.punch(bool(options["ident"]))


@register
class PunchEiaTarget(_PunchTarget):
    name = "punch-eia"
    label = "1704 tape, EIA (punch image)"
    description = "Tektronix 1704 EIA punch image: a byte per row, channel n in bit n-1"
    extension = "eia.punch"
    code = TapeCode.EIA
    end_mark = bytes([tapecode.EIA_REWIND_STOP])
    # In EIA RS-244 the row 0x13 (DC3, XOFF) is the digit 3 and 0x11 (DC1, XON) is data too.
    flow_codes_in_data = True


@register
class PunchAsciiTarget(_PunchTarget):
    name = "punch-ascii"
    label = "1704 tape, ASCII (punch image)"
    description = "Tektronix 1704 ASCII punch image: a byte per row, channel n in bit n-1"
    extension = "ascii.punch"
    code = TapeCode.ASCII
    end_mark = tapecode.encode(tapecode.REWIND_STOP_CHAR, TapeCode.ASCII)


@register
class TapeSvgTarget(_TapeTarget):
    name = "tape-svg"
    label = "1704 tape picture (SVG)"
    reads_back = None
    picture = "tape-svg"
    description = "drawing of the Tektronix 1704 tape (channels, feed holes, title) as SVG"
    extension = "svg"
    media_type = "image/svg+xml"
    options = (
        *PROFILE_OPTIONS,
        Option("code", _CHOICE, "eia", "the tape code drawn", choices=("eia", "ascii")),
    )

    def picture_options(self, options: Mapping[str, str]) -> dict[str, str]:
        return dict(options)

    def emit(
        self, program: Program, toolpath: Toolpath, options: Mapping[str, Any], report: Report
    ) -> bytes:
        code = TapeCode(options["code"])
        tape = self.tape(program, toolpath, options, report, code)
        return tape_svg(tape, bool(options["ident"])).encode("utf-8")
