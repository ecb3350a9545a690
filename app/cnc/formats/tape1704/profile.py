"""The 1704 machine profile: the tape targets' options, read and checked (seed 000 §2, §4;
seed 002 §4.1's post-processor words), and the number formats of the 1704's options.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from decimal import Decimal
from fractions import Fraction
from typing import Any

from app.cnc.blocks import Program
from app.cnc.formats.tape1704 import codes
from app.cnc.options import Option, OptionError, OptionKind
from app.cnc.units import NM_PER_INCH, NM_PER_MM, Units, half_even, to_nm

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
        return half_even(nm, self.step_nm) * (self.step_nm // self.digit_nm)

    def show(self, units: int) -> str:
        """A word value as a length for messages, e.g. `99.9999 in`."""
        value = Decimal(units * self.digit_nm) / Decimal(self.unit_nm)
        places = self.frac_digits
        return f"{value.quantize(Decimal(1).scaleb(-places))} {self.unit}"

    def feed_value(self, feed_nm: int) -> int:
        """A feed (nm/min) as its F word value, rounded to the feed step."""
        return half_even(feed_nm, self.feed_unit_nm * self.feed_step) * self.feed_step

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
    return int((inches * codes.ROWS_PER_INCH).to_integral_value())


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
