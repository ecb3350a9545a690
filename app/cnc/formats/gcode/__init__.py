"""G-code: RS274/NGC as LinuxCNC reads it, Fanuc 6M, the ProtoTRAK's modified Fanuc 6, and
the Bridgeport BOSS tape.

dialects.py says what each dialect does differently (and the options they share);
writer.py writes any dialect from a compiled program, boss.py the BOSS's segmented tape;
reader.py reads RS274/NGC and Fanuc files into motion, which app.cnc.imports recognises as
data blocks.
"""

from __future__ import annotations

from collections.abc import Mapping

from app.cnc.blocks import Program
from app.cnc.formats.gcode import boss, writer
from app.cnc.formats.gcode.reader import parse_gcode
from app.cnc.imports import wordaddress
from app.cnc.imports.common import ImportNote, collector_paused, decode_text
from app.cnc.imports.motion import program_from_motion
from app.cnc.imports.registry import Content, Importer, Sniff, register_importer

__all__ = ["GcodeImporter", "boss", "writer"]


@register_importer
class GcodeImporter(Importer):
    name = "gcode"
    label = "G-code"
    description = "G-code (RS274/NGC, Fanuc, ProtoTRAK)"
    rank = 30

    def sniff(self, content: Content) -> Sniff | None:
        return wordaddress.sniff(content, gcode=True)

    def read(
        self, data: bytes, name: str, options: Mapping[str, str]
    ) -> tuple[Program, list[ImportNote]]:
        with collector_paused():
            parsed = parse_gcode(decode_text(data), name)
            return program_from_motion(parsed), parsed.notes.report()
