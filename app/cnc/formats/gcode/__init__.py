"""G-code: RS274/NGC as LinuxCNC reads it, Fanuc 6M, the ProtoTRAK's modified Fanuc 6, and
the Bridgeport BOSS tape.

dialects.py says what each dialect does differently (and the options they share);
writer.py writes any dialect from a compiled program, boss.py the BOSS's segmented tape;
reader.py reads RS274/NGC, Fanuc and BOSS words into motion, which app.cnc.recognition recognises
as data blocks; bossread.py joins a BOSS tape's segments for it. Here: the two importers'
declarations (their sniffs are light); the reader is imported when a file is read, the
writers when their target is used (app.cnc.formats.TARGET_MODULES).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from typing import BinaryIO

from app.cnc.blocks import Program
from app.cnc.formats.gcode.bossread import looks_segmented
from app.cnc.formats.importers import Content, Importer, Sniff, Strength, register_importer
from app.cnc.recognition import wordaddress
from app.cnc.recognition.common import (
    ImportNote,
    byte_lines,
    chunk_lines,
    decode_text,
)
from app.cnc.sizes import collector_paused

FILE_PART = 1 << 20  # bytes of a file read at a time (GcodeImporter.read_file)


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
        return self._read(byte_lines(data), lambda: data, name)

    def read_file(
        self, file: BinaryIO, name: str, options: Mapping[str, str]
    ) -> tuple[Program, list[ImportNote]]:
        """`read` of the file, a part of FILE_PART bytes at a time: its bytes are never
        held whole, unless streaming must read the whole file (then it is read again)."""

        def whole() -> bytes:
            file.seek(0)
            return file.read()

        parts = iter(lambda: file.read(FILE_PART), b"")
        return self._read(chunk_lines(parts), whole, name)

    def _read(
        self, lines: Iterator[str], whole: Callable[[], bytes], name: str
    ) -> tuple[Program, list[ImportNote]]:
        from app.cnc.formats.gcode.reader import FrontEnd, GcodeStream, parse_gcode
        from app.cnc.recognition.motion import (
            Unstreamable,
            program_from_motion,
            program_from_stream,
        )

        with collector_paused():
            try:
                # Read as it streams (docs/imports.md, "Streaming"): a long file in flat
                # memory. What needs the whole program reads it whole: subroutines and
                # parameters (the front end), and whatever streaming would read otherwise
                # (a refusal among them: the whole file's is the first, bytes not text first).
                program, notes = program_from_stream(GcodeStream(lines, name))
                return program, notes.report()
            except (FrontEnd, Unstreamable):
                pass
            parsed = parse_gcode(decode_text(whole()), name)
            return program_from_motion(parsed), parsed.notes.report()


@register_importer
class BossImporter(Importer):
    """A Bridgeport BOSS tape as `tape-boss` writes it: real-time segments (`%#0 … $`,
    seed 004 §8.1.1) joined into one program, G70 inch and G71 metric."""

    name = "boss"
    label = "a BOSS tape"
    description = "a Bridgeport BOSS tape (segments %#0 … $, G70/G71)"
    rank = 35

    def sniff(self, content: Content) -> Sniff | None:
        if content.text is None:
            return None
        found = looks_segmented(content.plain())
        return Sniff(Strength.CONTENT, found) if found else None

    def read(
        self, data: bytes, name: str, options: Mapping[str, str]
    ) -> tuple[Program, list[ImportNote]]:
        from app.cnc.formats.gcode.bossread import join_segments
        from app.cnc.formats.gcode.reader import parse_gcode
        from app.cnc.recognition.motion import program_from_motion

        with collector_paused():
            tape = join_segments(decode_text(data))
            parsed = parse_gcode(tape.text, name)
            parsed.format = "boss"
            count = len(tape.opened)
            first = tape.opened[0] if tape.opened else None
            segments = "1 segment" if count == 1 else f"{count} segments"
            parsed.notes.became(first, f"{segments} (#0 … $) joined into one program")
            if count and not tape.ended:
                parsed.notes.assumed(
                    None,
                    "the tape does not end '$', '$' (seed 004 §8.1.1 g): read to its end",
                )
            return program_from_motion(parsed), parsed.notes.report()
