"""Tektronix 1704 punched tape: the word-address listing, punch images and a tape drawing.

Seed 000 (the 1704 Programmer's Manual, 1973) is the specification; DESIGN.md §4 ("Tektronix
1704 tape", "1704 motion rules", "Tool length") gives the readings we follow. A tape is made
in stages, each a generator over the one before, so it is written as it is made and its
memory does not grow with the program:

    compiled path → plan.py (blocks to be, nm) → words.py (rounded, G codes, words)
                  → image.py (listing or punch rows) → picture.py (the drawing)

All five targets are the same tape: the listings (EIA, ASCII), the punch images and the
drawing. ASCII tapes open with comment blocks for the set-up (part zero, Z zero); EIA has no
comments, so the report carries them.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any, ClassVar

from app.cnc.blocks import Program
from app.cnc.formats.tape1704 import codes
from app.cnc.formats.tape1704.codes import TapeCode
from app.cnc.formats.tape1704.image import TapeImage
from app.cnc.formats.tape1704.plan import Planner, sanitize_comment
from app.cnc.formats.tape1704.profile import PROFILE_OPTIONS, Profile, read_profile
from app.cnc.formats.tape1704.words import (
    Line,
    LineRun,
    Rounder,
    Words,
    check_reader,
    with_starts,
)
from app.cnc.formats.targets import Option, Out, Remedy, Report, Target, register
from app.cnc.formats.text import Lines
from app.cnc.options import OptionKind
from app.cnc.path import CompiledPath
from app.cnc.problems import Need
from app.cnc.units import Units, format_length


class Tape:
    """One tape being made: its image (leader, header, trailer) and its blocks as they
    come (`lines`). Report entries are collected per stage and given to the export's
    report in the stages' order once the blocks have all been made (`finish`).

    Raises OptionError for malformed option tables (see `read_profile`)."""

    def __init__(
        self,
        program: Program,
        path: CompiledPath,
        options: Mapping[str, Any],
        code: TapeCode,
        report: Report,
    ) -> None:
        self.program = program
        self.path = path
        self.profile: Profile = read_profile(program, options)
        self.fmt = self.profile.fmt
        self.code = code
        self.comments = code is TapeCode.ASCII
        self.report = report
        self.planner = Planner(program, path, self.profile, code)
        start = path.start
        self.rounder = Rounder(
            self.fmt,
            self.profile,
            (start[0], start[1], self.planner.machine_z(start[2], path.initial_tool)),
        )
        self.words = Words(self.fmt, self.profile)
        self.header_report = Report("header")
        self.reader_report = Report("reader")
        self.image = TapeImage(
            code=code,
            title=codes.title_text(self.profile.title) if self.profile.ident else "",
            header=self.header(),
            leader_rows=self.profile.leader_rows,
            trailer_rows=self.profile.trailer_rows,
            ident=self.profile.ident,
        )
        self.rows = 0
        self.encodable = all(codes.can_encode(text, code) for text in self.image.header)

    def lines(self) -> Iterator[Line | LineRun]:
        """The tape's blocks, made as they are asked for (a run's in columns)."""
        items = self.planner.items()
        rounded = self.rounder.items(items)
        lines = self.words.lines(with_starts(rounded, self.rounder.first()))
        rows = self.image.fixed_rows()
        code = self.code
        for line in check_reader(lines, self.fmt, self.reader_report):
            if isinstance(line, LineRun):
                texts = line.texts
                joined = "".join(texts)
                rows += len(joined) + len(texts)
                if codes.can_encode(joined, code):
                    yield line
                    continue
                self.encodable = False
                for k, text in enumerate(texts):
                    if codes.can_encode(text, code):
                        yield line.line(k)
                continue
            rows += len(line.text) + 1 + line.leader_after
            if not codes.can_encode(line.text, code):
                self.encodable = False
                continue
            yield line
        self.rows = rows

    def finish(self) -> None:
        """Hand the stages' report entries to the export's report, then the notes."""
        for stage in [
            *self.planner.stages,
            self.rounder.report,
            self.words.report,
            self.header_report,
        ]:
            self.report.merge(stage)
        if not self.encodable:
            self.report.error(None, f"the listing has characters {self.code.value} cannot punch")
            return
        self.report.merge(self.reader_report)
        self.notes()

    def header(self) -> list[str]:
        """ASCII only: the set-up a machinist needs, as comment blocks after the rewind stop."""
        path, program = self.path, self.program
        units = path.units
        ox, oy = path.origin
        offsets = f"X{format_length(ox, units)} Y{format_length(oy, units)}"
        if not self.comments:
            if (ox, oy) != (0, 0):
                self.header_report.unsupported(
                    None,
                    f"Data Block 0 part zero at table {offsets} {units.symbol}: EIA tapes "
                    "carry no comments; set the floating zero there by hand",
                )
            return []
        name = sanitize_comment(f"{program.name} {program.part_number}")
        start = format_length(path.start[2], units)
        lines = [
            f"({name})",
            f"(PART ZERO AT TABLE {offsets} {units.symbol.upper()})",
            f"(START OVER PART ZERO, Z{start} ABOVE TOOL ZERO)",
        ]
        if self.planner.two_axis:
            lines.append("(TWO-AXIS PROGRAM: THE QUILL SETS DEPTH)")
        elif self.profile.g94:
            lines.append("(Z ZERO: EACH TOOL TOUCHED OFF AT ITS ZERO, G94)")
        else:
            lines.append("(Z ZERO WHERE TCAL IS 0: Z WORDS INCLUDE EACH TOOL TCAL)")
        if path.initial_tool:
            # The first tool has no M06 to carry its comment: say here which tool the tape
            # starts with, its diameter and (with TCAL) the calibration its Z words include.
            described = self.planner.tool_comment(path.initial_tool)
            lines.append(f"(FIRST {sanitize_comment(described)})")
        return lines

    def notes(self) -> None:
        fmt, report, profile = self.fmt, self.report, self.profile
        digits = f"{fmt.int_digits}.{fmt.frac_digits}"
        feed = "F3.1 (0.1 ipm)" if fmt.feed_unit_nm == 2_540_000 else f"F4 (1 {fmt.feed_name})"
        report.note(
            None,
            f"{self.code.value.upper()} tape, {fmt.name}: X Y Z I J R words {digits} ({fmt.unit}), "
            f"{feed}, leading zeros dropped, no decimal point",
        )
        units = self.path.units
        if fmt.metric != (units is Units.MM):
            report.rewritten(
                None,
                f"the {units.value} program is punched in {fmt.unit} "
                "(rounded once to the tape's resolution)",
            )
        elif fmt.metric:
            report.note(None, "metric program: the machine needs the 1704's metric option")
        if self.planner.two_axis:
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
        start = self.path.start
        report.note(
            None,
            f"start with the spindle over part zero (X0 Y0), the tool "
            f"{format_length(start[2], units)} {units.symbol} above its zero; G50 moves at "
            "the machine's rapid traverse",
        )
        feet = self.rows / codes.ROWS_PER_INCH / 12
        report.note(
            None,
            f"tape length {feet:.1f} ft ({self.rows} rows at {codes.ROWS_PER_INCH} rows per "
            "inch, leader and trailer included)",
        )


# --- the targets --------------------------------------------------------------------------


class TapeTarget(Target):
    """Shared by the five 1704 targets: the profile options and the tape they are made of."""

    code: ClassVar[TapeCode] = TapeCode.EIA
    options: ClassVar[tuple[Option, ...]] = PROFILE_OPTIONS
    common: ClassVar[tuple[str, ...]] = (
        "units",
        "resolution",
        "z-zero",
        "sequence",
        "circular",
        "drill-cycle",
    )
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

    def need_remedy(self, need: Need) -> Remedy | None:
        if need is Need.CALIBRATED_TOOLS:
            return Remedy("z-zero", "g94", "touch off each tool at its change")
        return None

    def write(
        self,
        program: Program,
        path: CompiledPath,
        options: Mapping[str, Any],
        report: Report,
        out: Out,
    ) -> None:
        tape = Tape(program, path, options, self.code, report)
        lines = Lines(out)
        for texts in tape.image.listing(tape.lines()):
            lines.add_many(texts)
        lines.flush()
        tape.finish()


@register
class TapeEiaTarget(TapeTarget):
    name = "tape-eia"
    label = "Tektronix 1704 tape (EIA)"
    description = "Tektronix 1704 tape listing for an EIA RS-244 tape (word address text)"
    extension = "eia.txt"
    code = TapeCode.EIA


@register
class TapeAsciiTarget(TapeTarget):
    name = "tape-ascii"
    label = "Tektronix 1704 tape (ASCII)"
    description = "Tektronix 1704 tape listing for an ASCII tape, with comments (text)"
    extension = "ascii.txt"
    code = TapeCode.ASCII


class _PunchTarget(TapeTarget):
    media_type = "application/octet-stream"
    binary = True

    def write(
        self,
        program: Program,
        path: CompiledPath,
        options: Mapping[str, Any],
        report: Report,
        out: Out,
    ) -> None:
        tape = Tape(program, path, options, self.code, report)
        for rows, _ in tape.image.punched(tape.lines()):
            out.write(rows)
        tape.finish()


@register
class PunchEiaTarget(_PunchTarget):
    name = "punch-eia"
    label = "Tektronix 1704 tape, EIA punch image"
    description = "Tektronix 1704 EIA punch image: a byte per row, channel n in bit n-1"
    extension = "eia.punch"
    code = TapeCode.EIA
    end_mark = bytes([codes.EIA_REWIND_STOP])
    # In EIA RS-244 the row 0x13 (DC3, XOFF) is the digit 3 and 0x11 (DC1, XON) is data too.
    flow_codes_in_data = True


@register
class PunchAsciiTarget(_PunchTarget):
    name = "punch-ascii"
    label = "Tektronix 1704 tape, ASCII punch image"
    description = "Tektronix 1704 ASCII punch image: a byte per row, channel n in bit n-1"
    extension = "ascii.punch"
    code = TapeCode.ASCII
    end_mark = codes.encode(codes.REWIND_STOP_CHAR, TapeCode.ASCII)


@register
class TapeSvgTarget(TapeTarget):
    name = "tape-svg"
    label = "Tektronix 1704 tape picture (SVG)"
    description = "drawing of the Tektronix 1704 tape (channels, feed holes, title) as SVG"
    extension = "tape.svg"  # beside the tool-path picture (svg) of the same part
    media_type = "image/svg+xml"
    reads_back = None
    picture = "tape-svg"
    options = (
        *PROFILE_OPTIONS,
        Option("code", OptionKind.CHOICE, "eia", "the tape code drawn", choices=("eia", "ascii")),
    )
    common = ("code", *TapeTarget.common)

    def picture_options(self, options: Mapping[str, str]) -> dict[str, str]:
        return dict(options)

    def write(
        self,
        program: Program,
        path: CompiledPath,
        options: Mapping[str, Any],
        report: Report,
        out: Out,
    ) -> None:
        # The drawing (and svgwrite) is loaded for this target alone, not for every tape.
        from app.cnc.formats.tape1704.picture import draw

        code = TapeCode(options["code"])
        tape = Tape(program, path, options, code, report)

        def emit(text: str) -> None:
            out.write(text.encode("utf-8"))

        draw(tape.image.punched(tape.lines()), code, tape.image.title, emit)
        tape.finish()
