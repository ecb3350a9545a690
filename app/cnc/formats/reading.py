"""Imports: files that become editable MillBlocks programs (GitHub issue 5).

    read_program(data, name="", format=None) -> ImportResult
    read_file(file, name="", format=None) -> ImportResult   (the command line's own files)

`format` names an import format of the registry (`importers()`: a MillBlocks program
document, ProtoTRAK Plus events, G-code, a Tektronix 1704 tape, a DXF drawing — each a
package of app.cnc.formats); None detects it from the content (`detect_format`).
The result holds the program, the report (what became what, what was not understood or not
carried, what was assumed, what was rounded, what the user must still supply — each with
its line) and the format read. Every failure is an `ImportFailure` (a ValueError) naming
the line and column, or the tape block and row; nothing half-imported is returned.

What the readers share lives here: the report and the failure (common.py), the motion
vocabulary of word-address files (steps.py), turning motion into operations and blocks
(segment.py, recognise.py, build.py, motion.py) and the evidence that tells a tape from
G-code (wordaddress.py).

Pure core: no web, database or serial code. See docs/imports.md.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import BinaryIO

from app.cnc import cost
from app.cnc.blocks import Program
from app.cnc.formats.importers import Importer, detect, get_importer, importers
from app.cnc.recognition.common import ImportFailure, ImportNote, NoteKind
from app.cnc.sizes import (
    IMPORT_LIMITS,
    ImportLimits,
    TooLarge,
    check_block_count,
    check_import_size,
)

__all__ = [
    "ImportFailure",
    "ImportNote",
    "ImportResult",
    "Importer",
    "NoteKind",
    "detect_format",
    "importers",
    "read_file",
    "read_program",
]


@dataclass(frozen=True)
class ImportResult:
    """An imported program, the report of how it was made, and the format read."""

    program: Program
    report: list[ImportNote] = field(default_factory=list)
    format: str = ""

    def text(self) -> str:
        """The report as lines for a terminal, in file order."""
        return "".join(self.lines())

    def lines(self) -> Iterator[str]:
        """`text()` a line at a time (a long file's report is megabytes of text)."""
        notes = sorted(self.report, key=lambda n: -1 if n.line is None else n.line)
        yield f"Import report ({self.format}):\n"
        if not notes:
            yield "  nothing to report\n"
        for note in notes:
            yield f"  {note}\n"


def detect_format(data: bytes) -> str:
    """The name of the import format `data` is in, from its content. Raises ImportFailure
    when it is empty or could be several formats alike (it then asks for the format)."""
    return detect(data).name


# What detection reads of a file on disk (`read_file`): a long file shows its format in its
# first lines (the word-address evidence looks at 5 000 of them, wordaddress.SNIFF_LINES:
# 256 KiB holds 5 000 lines of 52 characters; a CAM post's are 15-35). Every sniff reads
# all of it, 20 ms a megabyte: a quarter of one is what a long G-code file's command
# waited for before it read a line.
DETECT_BYTES = 1 << 18


def file_head(file: BinaryIO) -> bytes:
    """The start of `file` that detection reads: its first DETECT_BYTES, to the last line
    break in them (the whole file when it is shorter). Leaves `file` at the start."""
    data = file.read(DETECT_BYTES)
    file.seek(0)
    if len(data) < DETECT_BYTES:
        return data
    cut = max(data.rfind(b"\n"), data.rfind(b"\r")) + 1
    return data[:cut] if cut else data


def read_file(
    file: BinaryIO,
    name: str = "",
    format: str | None = None,
    options: Mapping[str, str] | None = None,
) -> ImportResult:
    """`read_program(..., limited=False)` of an open binary file (seekable, at its start),
    for the command line converting the user's own files: the format is detected from its
    start (`file_head`, the same `detect_format` rule), and a format that reads a part at a
    time (G-code) never holds the file's bytes whole. Raises ImportFailure as
    `read_program` does."""
    importer = detect(file_head(file)) if format is None else get_importer(format)
    check_options(importer, options or {})
    program, notes = importer.read_file(file, name, options or {})
    return ImportResult(program, notes, importer.name)


def read_program(
    data: bytes,
    name: str = "",
    format: str | None = None,
    options: Mapping[str, str] | None = None,
    *,
    limited: bool = True,
    limits: ImportLimits = IMPORT_LIMITS,
) -> ImportResult:
    """Import `data` as a program. `name` (e.g. the file name) names a program whose file
    gives no name. `options` are the format's reader options (docs/imports.md): for a tape
    `units` (inch/metric) and `resolution` (standard/option1/option2), as the tape target
    has them; for a DXF `layer`, `hole-diameter`, `tolerance`, `units`, `drawing-units`,
    `feed`.

    Raises ImportFailure for anything it cannot read (and for an unknown `format` or
    option, content that could be either a 1704 tape or G-code when `format` is None, or a
    file past `limits` or the block limit of app.cnc.sizes: refused before it is parsed by
    its bytes and lines, after by its blocks and the moves they expand to, app.cnc.cost).
    `limited=False` lifts those limits: the command line converting the user's own files
    (a long CAM program to a tape) takes files of any size (the moves it may make are then
    validation's and the compile's, `millblocks --max-moves`); the web and the library
    keep them (a server's `limits` are its settings).
    """
    try:
        if limited:
            check_import_size(data, limits)
        importer = detect(data) if format is None else get_importer(format)
        program, notes = read_as(importer, data, name, options or {})
        if limited:
            check_block_count(len(program.blocks))
            cost.check(program)
    except TooLarge as exc:
        raise ImportFailure("", str(exc)) from None
    return ImportResult(program, notes, importer.name)


def read_as(
    importer: Importer, data: bytes, name: str, options: Mapping[str, str]
) -> tuple[Program, list[ImportNote]]:
    """`importer.read`, after refusing options it does not have (no size limits: for
    callers that set their own, such as the benchmarks)."""
    check_options(importer, options)
    return importer.read(data, name, options)


def check_options(importer: Importer, options: Mapping[str, str]) -> None:
    """Raises ImportFailure naming an option `importer` does not have, and its options."""
    known = {option.name for option in importer.options}
    unknown = sorted(set(options) - known)
    if unknown:
        allowed = ", ".join(sorted(known)) or "none"
        raise ImportFailure(
            "", f"{importer.name} import has no option {unknown[0]!r}; its options: {allowed}"
        )
