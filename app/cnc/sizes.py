"""How big a program or an import may be: the stated limits that bound one request's work.

A program of up to `MAX_BLOCKS` data blocks opens, validates, previews and exports in a
bounded time (docs/security.md gives the measurements); an import is refused, naming the
limit, before its expensive work starts: first by its bytes and lines, then by the blocks
it would make. Pure: no Flask, database or serial code.
"""

from __future__ import annotations

from dataclasses import dataclass

MAX_BLOCKS = 5000
"""Data blocks in one program (document, import, editor)."""

MAX_IMPORT_BYTES = 2 * 1024 * 1024
"""Bytes of one imported file (the web upload limit too)."""

MAX_IMPORT_LINES = 20_000
"""Lines (or tape blocks) of one imported file."""


MAX_EXPANDED_LINES = 50_000
"""Lines one G-code import runs, each time it runs one: a file's subroutines and loops
(app/cnc/formats/gcode/ngc.py) repeat lines, and a loop that never ends must not hold the
request (a loop of expressions refused at this limit: 2 s). Ten lines for every block a
program may have."""


class TooLarge(ValueError):
    """An input past one of the limits above; the message names the limit."""


@dataclass(frozen=True)
class ImportLimits:
    """The bounds of one imported file: its bytes and its lines (a server's are settings,
    MILLBLOCKS_MAX_UPLOAD_BYTES and MILLBLOCKS_MAX_IMPORT_LINES)."""

    bytes: int = MAX_IMPORT_BYTES
    lines: int = MAX_IMPORT_LINES


IMPORT_LIMITS = ImportLimits()
"""The stated limits above."""


def check_import_size(data: bytes, limits: ImportLimits = IMPORT_LIMITS) -> None:
    """Refuse `data` larger than `limits` (before any parsing)."""
    if len(data) > limits.bytes:
        raise TooLarge(
            f"the file has {len(data):,} bytes; an import is at most {limits.bytes:,} bytes"
        )
    lines = data.count(b"\n") + 1
    # A tape's blocks end in CR (ASCII) or EOB (EIA: 0x80); count those too.
    lines = max(lines, data.count(b"\r"), data.count(b"\x80"))
    if lines > limits.lines:
        raise TooLarge(
            f"the file has {lines:,} lines; an import is at most {limits.lines:,} lines "
            f"and {MAX_BLOCKS:,} blocks"
        )


def check_block_count(count: int) -> None:
    """Refuse a program of more than MAX_BLOCKS data blocks."""
    if count > MAX_BLOCKS:
        raise TooLarge(
            f"the program would have {count:,} data blocks; a program has at most {MAX_BLOCKS:,}"
        )
