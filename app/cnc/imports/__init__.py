"""Imports: files that become editable MillBlocks programs (GitHub issue 5).

    read_program(data, name="", format=None) -> ImportResult

`format` is "json" (a MillBlocks program document), "events" (ProtoTRAK Plus G100-G109,
seed 003 §2.2), "gcode" (RS274/NGC or Fanuc, seed 003's tables), "tape" (a Tektronix
1704 listing or punch image, EIA or ASCII, seed 000) or "dxf" (a drawing, `dxf.py`); None
detects it from the content.
The result holds the program, the report (what became what, what was not understood or not
carried, what was assumed, what was rounded, what the user must still supply — each with
its line) and the format read. Every failure is an `ImportFailure` (a ValueError) naming
the line and column, or the tape block and row; nothing half-imported is returned.

Pure core: no web, database or serial code. See docs/imports.md.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from app.cnc.blocks import Program
from app.cnc.imports.common import ImportFailure, ImportNote, NoteKind
from app.cnc.imports.detect import FORMATS, detect_format, read
from app.cnc.sizes import TooLarge, check_block_count, check_import_size

__all__ = [
    "FORMATS",
    "ImportFailure",
    "ImportNote",
    "ImportResult",
    "NoteKind",
    "detect_format",
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
        notes = sorted(self.report, key=lambda n: -1 if n.line is None else n.line)
        lines = [f"Import report ({self.format}):"]
        lines += [f"  {note}" for note in notes] or ["  nothing to report"]
        return "\n".join(lines) + "\n"


def read_program(
    data: bytes,
    name: str = "",
    format: str | None = None,
    options: Mapping[str, str] | None = None,
) -> ImportResult:
    """Import `data` as a program. `name` (e.g. the file name) names a program whose file
    gives no name. `options` are reader options (docs/imports.md): for a tape `units`
    (inch/metric) and `resolution` (standard/option1/option2), as the tape target has them;
    for a DXF `layer`, `hole-diameter`, `tolerance`, `units`, `drawing-units`, `feed`.

    Raises ImportFailure for anything it cannot read (and for an unknown `format`, or
    content that could be either a 1704 tape or G-code when `format` is None, or a file
    past the limits of app.cnc.sizes, refused before it is parsed).
    """
    try:
        check_import_size(data)
        program, notes, chosen = read(data, name, format, options or {})
        check_block_count(len(program.blocks))
    except TooLarge as exc:
        raise ImportFailure("", str(exc)) from None
    return ImportResult(program, notes, chosen)
