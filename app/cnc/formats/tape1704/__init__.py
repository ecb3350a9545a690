"""Tektronix 1704 punched tape (seed 000): listings, punch images, a picture, and reading
them back.

codes.py holds the EIA RS-244 and ASCII character codes; profile.py the machine profile (the
targets' options); plan.py turns the compiled path into the blocks to be; words.py rounds
them, chooses their G codes and writes their words; image.py lays the blocks out on tape
(listing, punch rows); picture.py draws the tape (svgwrite); targets.py makes a tape through
those stages and offers the five targets; reader.py reads a listing or a punch image into
motion, which app.cnc.recognition recognises as data blocks. Here: the importer's declaration
(its options, its sniff); the reader is imported when a tape is read.
"""

from __future__ import annotations

from collections.abc import Mapping

from app.cnc.blocks import Program
from app.cnc.formats.importers import Content, Importer, Sniff, Strength, register_importer
from app.cnc.options import Option, OptionKind
from app.cnc.recognition import wordaddress
from app.cnc.recognition.common import ImportNote

# Options the user gives where a tape cannot say (the tape target has the same two).
READER_OPTIONS: tuple[Option, ...] = (
    Option(
        "units",
        OptionKind.CHOICE,
        "",
        "inch (the standard) or metric (the metric option); empty: from the tape's header",
        ("", "inch", "metric"),
    ),
    Option(
        "resolution",
        OptionKind.CHOICE,
        "standard",
        "standard 0.0001 in; option1 0.0002 in; option2 0.001 in",
        ("standard", "option1", "option2"),
    ),
)


@register_importer
class TapeImporter(Importer):
    name = "tape"
    label = "a 1704 tape"
    description = "a Tektronix 1704 tape (listing or punch image)"
    rank = 40
    options = READER_OPTIONS

    def sniff(self, content: Content) -> Sniff | None:
        if content.text is None:
            # Bytes that are not text: punch rows (ASCII rows carry a parity bit, EIA rows
            # are codes in channels 1-8); the reader tells the codes by their parity.
            return Sniff(Strength.CONTENT, "punch image rows")
        return wordaddress.sniff(content, gcode=False)

    def read(
        self, data: bytes, name: str, options: Mapping[str, str]
    ) -> tuple[Program, list[ImportNote]]:
        from app.cnc.formats.tape1704.reader import read_tape

        program, notes = read_tape(data, name, options)
        return program, notes.report()
