"""ProtoTRAK Plus events G100-G109 (seed 003 §2.2): the Plus's RS-232 program format.

model.py declares the events once (their fields, words and numbers); reader.py reads a
file into events and then into a 2-axis program; writer.py makes events from a program's
blocks, checks them against its tool path and writes the file (the `events` target). Here:
the importer's declaration; the reader is imported when a file is read.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

from app.cnc.blocks import Program
from app.cnc.formats.importers import Content, Importer, Sniff, Strength, register_importer
from app.cnc.recognition.common import ImportNote, decode_text

# A G100-G109 word (seed 003 §2.2.1): no G-code or tape has those.
_EVENT = re.compile(r"(?<![A-Z0-9.])G10[0-9](?![0-9.])", re.IGNORECASE)


@register_importer
class EventsImporter(Importer):
    name = "events"
    label = "ProtoTRAK Plus events"
    description = "ProtoTRAK Plus events (G100-G109)"
    rank = 20

    def sniff(self, content: Content) -> Sniff | None:
        # (Part by part: an event word is within a line, and a part ends at a line break.)
        for part in content.plain():
            # A part without the word's letters cannot hold one: the case-blind search with
            # its look-arounds tries every character (4 ms a part, most of detecting a long
            # G-code file, and nearly every part of one has no G10).
            if "G10" not in part and "g10" not in part:
                continue
            found = _EVENT.search(part)
            if found is not None:
                return Sniff(Strength.CONTENT, f"the event {found.group()}")
        return None

    def read(
        self, data: bytes, name: str, options: Mapping[str, str]
    ) -> tuple[Program, list[ImportNote]]:
        from app.cnc.formats.events.reader import read_events

        program, notes = read_events(decode_text(data), name)
        return program, notes.report()
