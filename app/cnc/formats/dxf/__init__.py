"""DXF drawings (import only): lines, arcs, circles and polylines become data blocks.

reader.py reads the drawing with ezdxf and chains its entities into contours and holes;
blocks.py makes the data blocks (drill cycles, bolt circles, MILL/ARC sequences, CIRCLE and
FRAME routines where exactly equivalent). docs/imports.md has the readings.
"""

from __future__ import annotations

from collections.abc import Mapping

from app.cnc.blocks import Program
from app.cnc.formats.dxf.blocks import program_from_drawing
from app.cnc.formats.dxf.reader import OPTIONS, is_dxf, parse_options, read_drawing
from app.cnc.imports.common import ImportNote
from app.cnc.imports.registry import Content, Importer, Sniff, Strength, register_importer


@register_importer
class DxfImporter(Importer):
    name = "dxf"
    label = "a DXF drawing"
    description = "a DXF drawing (lines, arcs, circles, polylines)"
    rank = 50
    options = OPTIONS
    from_machines = False

    def sniff(self, content: Content) -> Sniff | None:
        return Sniff(Strength.SIGNATURE, "a DXF drawing") if is_dxf(content.data) else None

    def read(
        self, data: bytes, name: str, options: Mapping[str, str]
    ) -> tuple[Program, list[ImportNote]]:
        # The import's limits are its caller's (`read_program`: the file's lines, a binary
        # DXF's tags counted as lines, and the blocks; the command line lifts them for the
        # user's own files). The choosing page reads with the entity limit.
        drawing = read_drawing(data, name, parse_options(options), limit=None)
        return program_from_drawing(drawing), drawing.notes.report()
