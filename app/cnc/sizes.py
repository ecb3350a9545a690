"""How big a program or an import may be: the stated limits that bound one request's work.

A program of up to `MAX_BLOCKS` data blocks opens, validates, previews and exports in a
bounded time (docs/security.md gives the measurements); an import is refused, naming the
limit, before its expensive work starts: first by its bytes and lines, then by the blocks
it would make. Pure: no Flask, database or serial code.
"""

from __future__ import annotations

MAX_BLOCKS = 5000
"""Data blocks in one program (document, import, editor)."""

MAX_IMPORT_BYTES = 2 * 1024 * 1024
"""Bytes of one imported file (the web upload limit too)."""

MAX_IMPORT_LINES = 20_000
"""Lines (or tape blocks) of one imported file; a binary DXF counts two lines a tag, as its
text form has them."""

MAX_DRAWING_ENTITIES = 5_000
"""Entities in a DXF drawing's model space (each line, arc, circle, text…, a polyline's
vertices one each): as many as a program has blocks. Checked as ezdxf gives them, before
any is read; the line limit keeps an uploaded file under it, this keeps every reading of a
stored drawing there too."""


class TooLarge(ValueError):
    """An input past one of the limits above; the message names the limit."""


def check_import_size(data: bytes) -> None:
    """Refuse `data` larger than the import limits (before any parsing). Raises TooLarge
    naming the limit."""
    if len(data) > MAX_IMPORT_BYTES:
        raise TooLarge(
            f"the file has {len(data):,} bytes; an import is at most {MAX_IMPORT_BYTES:,} bytes"
        )
    from app.cnc.formats.dxf.reader import binary_dxf_tags, is_binary_dxf

    if is_binary_dxf(data):
        # Its tags are not lines: counted (up to past the limit) as its text form's lines.
        tags = binary_dxf_tags(data, MAX_IMPORT_LINES // 2 + 1)
        if 2 * tags > MAX_IMPORT_LINES:
            raise TooLarge(
                f"the file has more than {MAX_IMPORT_LINES:,} lines (binary DXF: two lines a "
                f"tag, as in its text form); an import is at most {MAX_IMPORT_LINES:,} lines "
                f"and {MAX_BLOCKS:,} blocks"
            )
        return
    lines = data.count(b"\n") + 1
    # A tape's blocks end in CR (ASCII) or EOB (EIA: 0x80); count those too.
    lines = max(lines, data.count(b"\r"), data.count(b"\x80"))
    if lines > MAX_IMPORT_LINES:
        raise TooLarge(
            f"the file has {lines:,} lines; an import is at most {MAX_IMPORT_LINES:,} lines "
            f"and {MAX_BLOCKS:,} blocks"
        )


def check_block_count(count: int) -> None:
    """Refuse a program of more than MAX_BLOCKS data blocks."""
    if count > MAX_BLOCKS:
        raise TooLarge(
            f"the program would have {count:,} data blocks; a program has at most {MAX_BLOCKS:,}"
        )
