"""G-code dialects: what LinuxCNC, a Fanuc 6M, the ProtoTRAK's modified Fanuc 6 and the
Bridgeport BOSS do differently, and the options every G-code target offers.

The G/M codes are those of seed 003's RS274/NGC and Fanuc tables; the ProtoTRAK's
differences are seed 003 §2.1, the BOSS's seed 004.
"""

from __future__ import annotations

from dataclasses import dataclass
from decimal import Decimal

from app.cnc.options import Option, OptionKind


@dataclass(frozen=True)
class Dialect:
    """What one G-code dialect does differently."""

    two_digit_codes: bool  # G00 / M03 rather than G0 / M3
    spaces: bool  # spaces between words
    end_of_block: str  # appended to every block
    g_on_every_line: bool  # repeat the motion G code on every motion line (seed 003 §2.1)
    program_number: bool  # an O number after the first %
    can_write_offsets: bool  # G10 L2 / G10 L1 exist (LinuxCNC), offered by write-offsets
    messages: bool  # (MSG,…) comments are shown to the operator (LinuxCNC)
    milliseconds: bool  # dwell as P in whole milliseconds (Fanuc), not seconds
    dwell_word: str  # the word of a dwell in seconds: P (LinuxCNC) or X (BOSS)
    keep_trailing_zeros: bool  # the default of the trailing_zeros option
    line_numbers: bool  # the default of the sequence-numbers option
    largest_line_number: int  # N numbers restart after this (seed 003 §2.2.4: 0-999)
    # A helical arc (Z changing with X and Y): "" written as G2/G3 with Z; otherwise why not,
    # and it is written as straight moves within limits.HELIX_CHORD_INCH of the helix.
    no_helical: str = ""
    # Said in the report where a helical arc is written as G2/G3 (what the control needs).
    helical_note: str = ""
    # The default of the tool-change option: T<n> M6 for the first tool (writer.py, "the
    # start"); None: the dialect has no such option (the BOSS tape writes its own start).
    first_tool_change: bool | None = None

    def dwell(self, seconds: Decimal, cycle: bool) -> str:
        """The dwell word of a G04 (`cycle` False) or a G82 canned cycle."""
        if self.milliseconds:
            return f"P{int((seconds * 1000).to_integral_value())}"
        return f"{'P' if cycle else self.dwell_word}{seconds}"


def dialect_options(dialect: Dialect) -> tuple[Option, ...]:
    return (
        Option(
            "sequence-numbers",
            OptionKind.BOOL,
            dialect.line_numbers,
            "write N numbers",
        ),
        Option(
            "sequence-start",
            OptionKind.INT,
            10 if dialect.line_numbers else 1,
            "first N number",
            minimum=Decimal(0),
            maximum=Decimal(dialect.largest_line_number),
        ),
        Option(
            "sequence-increment",
            OptionKind.INT,
            10 if dialect.line_numbers else 1,
            "N number step",
            minimum=Decimal(1),
            maximum=Decimal(1000),
        ),
        Option(
            "trailing-zeros",
            OptionKind.CHOICE,
            "keep" if dialect.keep_trailing_zeros else "drop",
            "zero suppression: keep or drop trailing zeros (the decimal point always stays)",
            ("keep", "drop"),
        ),
        Option("tabs", OptionKind.BOOL, False, "separate words with tabs"),
        Option(
            "block-delete",
            OptionKind.BOOL,
            False,
            "write STOP blocks as /M00 so the block-delete switch can skip them",
        ),
        Option("end-code", OptionKind.CHOICE, "M30", "end of program code", ("M30", "M02")),
        Option(
            "canned-cycles",
            OptionKind.BOOL,
            True,
            "write G82 where the cycle's motion is identical to the hole's",
        ),
        Option(
            "peck-cycle",
            OptionKind.CHOICE,
            "explicit",
            "pecks as explicit moves, or G83 (which backs off above each level; reported)",
            ("explicit", "G83"),
        ),
        *(
            (
                Option(
                    "write-offsets",
                    OptionKind.BOOL,
                    False,
                    "write G54 (G10 L2) and the tool table's lengths and radii (G10 L1) from "
                    "Data Block 0: they replace the machine's own settings",
                ),
            )
            if dialect.can_write_offsets
            else ()
        ),
        *(
            (
                Option(
                    "tool-change",
                    OptionKind.BOOL,
                    dialect.first_tool_change,
                    "write T<n> M6 for the first tool before its first move (the control "
                    "asks for it, or its changer fetches it)",
                ),
                Option(
                    "start-retract",
                    OptionKind.BOOL,
                    True,
                    "raise Z straight up to the machine's reference point (G91 G28 Z0) "
                    "before the first move across; off: the tool must start above the part "
                    "at the height the report gives",
                ),
            )
            if dialect.first_tool_change is not None
            else ()
        ),
        Option(
            "spindle-speeds",
            OptionKind.CHOICE,
            "program",
            "program: every tool needs its RPM (S words); by-hand: a tool without RPM starts "
            "its spindle with no S word and the operator sets the speed (reported)",
            ("program", "by-hand"),
        ),
        Option(
            "index-code",
            OptionKind.INT,
            None,
            "M code that indexes the rotary table (POS INDEX); none: reported as lost",
            minimum=Decimal(0),
            maximum=Decimal(999),
        ),
    )


LINUXCNC = Dialect(
    two_digit_codes=False,
    spaces=True,
    end_of_block="",
    g_on_every_line=False,
    program_number=False,
    can_write_offsets=True,
    messages=True,
    milliseconds=False,
    dwell_word="P",
    keep_trailing_zeros=True,
    line_numbers=False,
    largest_line_number=99999,
    first_tool_change=True,
)
FANUC = Dialect(
    two_digit_codes=True,
    spaces=False,
    end_of_block="",
    g_on_every_line=False,
    program_number=True,
    can_write_offsets=False,
    messages=False,
    milliseconds=True,
    dwell_word="P",
    keep_trailing_zeros=False,
    line_numbers=True,
    largest_line_number=9999,
    first_tool_change=True,
    helical_note=(
        "helical arc written as G02/G03 with Z: the 6M needs its helical interpolation "
        "option for it (without it the control alarms on this line)"
    ),
)
# The ProtoTRAK's "modified Fanuc 6" (seed 003 §2.1): a Fanuc 6 post's output with a G code
# on every line, spaces between words and `;` ending each block; line numbers 0-999 (§2.2.4).
PROTOTRAK = Dialect(
    two_digit_codes=True,
    spaces=True,
    end_of_block=";",
    g_on_every_line=True,
    program_number=False,
    can_write_offsets=False,
    messages=False,
    milliseconds=True,
    dwell_word="P",
    keep_trailing_zeros=False,
    line_numbers=True,
    largest_line_number=999,
    # Seed 003 §2.1: the Plus converts what a Fanuc 6 post writes for a machining centre
    # with a tool changer; the manual's own sample (§2.2.6.2) calls the first tool at N2
    # (`T1 M16`, which we read as the scan's M06: M16 is in no table of the manual, and
    # the sample changes every later tool with M06).
    first_tool_change=True,
    # Seed 003 §2.1: the Plus is a 2-axis control that turns G codes into its position,
    # mill and arc events, and its arc events (§2.2.5 G102/G103) have no Z.
    no_helical="the Plus's arc events have no Z (seed 003 §2.2.5)",
)
# The Bridgeport BOSS (seed 004): G70/G71, decimal points, a dwell's X in seconds.
BOSS = Dialect(
    two_digit_codes=True,
    spaces=False,
    end_of_block="",
    g_on_every_line=False,
    program_number=False,
    can_write_offsets=False,
    messages=False,
    milliseconds=False,
    dwell_word="X",
    keep_trailing_zeros=False,
    line_numbers=False,
    largest_line_number=99999,
    # Seed 004 shows no helical form (its arcs are G02/G03 in a plane).
    no_helical="seed 004 shows the BOSS no helical arc",
)
