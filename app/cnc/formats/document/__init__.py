"""The MillBlocks program document (JSON, docs/program-format.md) as a format.

Its model, reader and writer are app/cnc/document.py (the library stores programs in it
and the editor owns it); this package offers it to the two registries: the `json` target
(writer.py) writes the program itself, errors and all, and the `json` importer (here)
reads a document back with its executed or cancelled COPY blocks carried out.
"""

from __future__ import annotations

from collections.abc import Mapping

from app.cnc.blocks import Program
from app.cnc.formats.importers import Content, Importer, Sniff, Strength, register_importer
from app.cnc.recognition.common import ImportFailure, ImportNote, NoteKind, decode_text


@register_importer
class JsonImporter(Importer):
    name = "json"
    label = "a MillBlocks program"
    description = "a MillBlocks program (JSON)"
    rank = 10

    def sniff(self, content: Content) -> Sniff | None:
        text = content.text
        if text is not None and text.lstrip().startswith("{"):
            return Sniff(Strength.SIGNATURE, "a JSON document")
        return None

    def read(
        self, data: bytes, name: str, options: Mapping[str, str]
    ) -> tuple[Program, list[ImportNote]]:
        from app.cnc import document
        from app.cnc.copy import CopyError, resolve_copies

        text = decode_text(data)
        try:
            program = document.loads(text)
        except document.DocumentError as exc:
            raise ImportFailure(exc.where, exc.message) from None
        try:
            program = resolve_copies(program)
        except CopyError as exc:
            raise ImportFailure(f"block {exc.block}", exc.message) from None
        note = ImportNote(NoteKind.BECAME, None, "a MillBlocks program document, as written")
        return program, [note]
