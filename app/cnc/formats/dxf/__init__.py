"""DXF drawings (import only): lines, arcs, circles and polylines become data blocks.

reader.py reads the drawing with ezdxf and chains its entities into contours and holes;
blocks.py makes the data blocks (drill cycles, bolt circles, MILL/ARC sequences, CIRCLE and
FRAME routines where exactly equivalent). docs/imports.md has the readings.

Here: the importer's declaration - its options and how a DXF is recognised - which every
detection asks; the reader (and ezdxf) is imported only when a drawing is read.
"""

from __future__ import annotations

from collections.abc import Mapping

from app.cnc.blocks import Program
from app.cnc.formats.importers import Content, Importer, Sniff, Strength, register_importer
from app.cnc.options import Option, OptionKind
from app.cnc.recognition.common import ImportNote

BINARY_SENTINEL = b"AutoCAD Binary DXF\r\n\x1a\x00"

OPTIONS: tuple[Option, ...] = (
    Option("layer", OptionKind.TEXT, "", "only these layers (comma-separated); empty: all"),
    Option(
        "hole-diameter",
        OptionKind.DECIMAL,
        None,
        "circles this size or smaller are holes (program units); empty: none",
    ),
    Option("tolerance", OptionKind.DECIMAL, None, "ends this close are chained"),
    Option(
        "units",
        OptionKind.CHOICE,
        "",
        "the program's units; empty: the drawing's",
        ("", "inch", "mm"),
    ),
    Option(
        "drawing-units",
        OptionKind.CHOICE,
        "",
        "what a drawing without units is in; empty: refuse it",
        ("", "inch", "mm"),
    ),
    Option("feed", OptionKind.DECIMAL, None, "FEEDR XY of the mill blocks"),
)


def is_dxf(data: bytes) -> bool:
    """True for a binary DXF, or text whose first group is `0` / `SECTION`."""
    if is_binary_dxf(data):
        return True
    head = data[:64].lstrip(b"\xef\xbb\xbf").split(None, 2)
    return len(head) >= 2 and head[0] == b"0" and head[1] == b"SECTION"


def is_binary_dxf(data: bytes) -> bool:
    return data.startswith(BINARY_SENTINEL)


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
        from app.cnc.formats.dxf.blocks import program_from_drawing
        from app.cnc.formats.dxf.reader import parse_options, read_drawing

        # The import's limits are its caller's (`read_program`: the file's lines, a binary
        # DXF's tags counted as lines, and the blocks; the command line lifts them for the
        # user's own files). The choosing page reads with the entity limit.
        drawing = read_drawing(data, name, parse_options(options), limit=None)
        return program_from_drawing(drawing), drawing.notes.report()
