"""How big a program or an import may be: the stated limits that bound one request's work.

A program of up to `MAX_BLOCKS` data blocks and `MAX_MOVES` moves opens, validates,
previews and exports in a bounded time (docs/security.md gives the measurements); an
import is refused, naming the limit, before its expensive work starts: first by its bytes
and lines, then by the blocks it would make, then by the moves those blocks expand to
(app/cnc/cost.py). Past the limits, one request's time is bounded too: a caller may set a
time budget (`time_budget`), and the long loops of the core check it (`spend`), so a
request that would run on is refused with a clear message instead of being killed.
Pure: no Flask, database or serial code.
"""

from __future__ import annotations

import gc
import time
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass

MAX_BLOCKS = 5000
"""Data blocks in one program (document, import, editor)."""

MAX_IMPORT_BYTES = 2 * 1024 * 1024
"""Bytes of one imported file (the web upload limit too)."""

MAX_IMPORT_LINES = 20_000
"""Lines (or tape blocks) of one imported file; a binary DXF counts two lines a tag, as its
text form has them."""

MAX_DRAWING_ENTITIES = 5_000
"""Entities in a DXF drawing's model space (each line, arc, circle, text…, a polyline's
vertices one each): as many as a program has blocks. The drawings page checks them as
ezdxf gives them, before any is read, at every reading of a stored drawing; the line limit
keeps an uploaded file under it."""


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
    """Refuse `data` larger than `limits` (before any parsing). Raises TooLarge naming the
    limit."""
    if len(data) > limits.bytes:
        raise TooLarge(
            f"the file has {len(data):,} bytes; an import is at most {limits.bytes:,} bytes"
        )
    from app.cnc.formats.dxf import is_binary_dxf

    if is_binary_dxf(data):
        from app.cnc.formats.dxf.reader import binary_dxf_tags

        # Its tags are not lines: counted (up to past the limit) as its text form's lines.
        tags = binary_dxf_tags(data, limits.lines // 2 + 1)
        if 2 * tags > limits.lines:
            raise TooLarge(
                f"the file has more than {limits.lines:,} lines (binary DXF: two lines a "
                f"tag, as in its text form); an import is at most {limits.lines:,} lines "
                f"and {MAX_BLOCKS:,} blocks"
            )
        return
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


MAX_MOVES = 1_000_000
"""Moves one program may expand to (LOOPs multiplied out): the size every page, export and
command answers within seconds (docs/security.md). The command line may allow more for
the user's own files (`--max-moves`)."""

MAX_POCKET_WORK = 200_000
"""Points one POCKET's planning may shrink: the points its contours are drawn with, times
its levels (one per step-over across it). The planner offsets the contours once per level
and asks its questions of what is near each ring, so its time grows with both
(docs/pocketing.md, "Cost"; docs/security.md, "Pockets")."""

MAX_VERIFY_WORK = 100_000_000
"""The work one Verify on the server may take: the grid cells its segments sweep (each
segment's box at the simulation's resolution, every placement of a LOOP counted) and a
share for each group of placements (`app.cnc.simulate.verify.work`). Chosen so that the
heaviest Verify a page accepts takes a few seconds (docs/security.md, "Verify") and every
golden program is within it (the external thread mill, 76 M, the most). The server
puts it in force for every request (app.web); the command line has none (`millblocks
verify` runs on the user's own computer, and its user chooses the resolution)."""

_VERIFY_LIMIT: ContextVar[int | None] = ContextVar("millblocks_verify_limit", default=None)


def verify_limit() -> int | None:
    """The work a Verify may take here (None: any), as `verify_allowed` says: the server
    allows MAX_VERIFY_WORK."""
    return _VERIFY_LIMIT.get()


@contextmanager
def verify_allowed(limit: int | None) -> Iterator[None]:
    """Allow Verify `limit` work inside the block (None: any)."""
    token = _VERIFY_LIMIT.set(limit)
    try:
        yield
    finally:
        _VERIFY_LIMIT.reset(token)


_MOVE_LIMIT: ContextVar[int] = ContextVar("millblocks_move_limit", default=MAX_MOVES)


def move_limit() -> int:
    """The moves a program may expand to here: MAX_MOVES unless `moves_allowed` says."""
    return _MOVE_LIMIT.get()


@contextmanager
def moves_allowed(limit: int) -> Iterator[None]:
    """Allow programs of up to `limit` moves inside the block (the command line's
    `--max-moves`, for the user's own files on the user's own computer)."""
    token = _MOVE_LIMIT.set(limit)
    try:
        yield
    finally:
        _MOVE_LIMIT.reset(token)


class OutputTooLarge(TooLarge):
    """A target's output past the moves a program may make here (`move_limit`); `block` is
    the block where it went past."""

    def __init__(self, message: str, block: int | None) -> None:
        super().__init__(message)
        self.block = block


class ChordRows:
    """The rows a writer adds by writing arcs as chords (a helix on a tape that has no
    helical arcs), held to `move_limit()`: the compiled path counts a helix's turn as a few
    arcs, so a 5 000-turn HELIX is a small program whose tape would have millions of rows."""

    def __init__(self) -> None:
        self.rows = 0
        self.limit = move_limit()

    def add(self, rows: int, block: int | None) -> None:
        """Count `rows` more for `block`; raises OutputTooLarge past the limit."""
        self.rows += rows
        if self.rows > self.limit:
            raise OutputTooLarge(
                f"its arcs written as chords (this target has no helical arcs) make more "
                f"than {self.limit:,} moves, the most a program may make here: fewer turns "
                "or a coarser PITCH, or a target that writes helical arcs",
                block,
            )


class OverBudget(TooLarge):
    """The work of one request ran past its time budget (the message says what to do)."""


_DEADLINE: ContextVar[tuple[float, float] | None] = ContextVar("millblocks_deadline", default=None)


@contextmanager
def time_budget(seconds: float) -> Iterator[None]:
    """Give the work inside the block `seconds` of wall time: past that, `spend` raises
    OverBudget. For a server's request, the last line of defence behind the size limits."""
    token = _DEADLINE.set((time.monotonic() + seconds, seconds))
    try:
        yield
    finally:
        _DEADLINE.reset(token)


def spend() -> None:
    """Raise OverBudget when the time budget in force (if any) is used up. Called from the
    loops whose work grows with a program (the compile's nodes and patterns, a pocket's
    levels and rings, the walk over every move), it costs a clock read."""
    deadline = _DEADLINE.get()
    if deadline is not None and time.monotonic() > deadline[0]:
        raise OverBudget(
            f"this took more than the {deadline[1]:g} s one request may take on this server, "
            "and was stopped; make the program smaller (fewer LOOP patterns, a larger "
            "step-over) or run it with the millblocks command on your own computer"
        )


@contextmanager
def collector_paused() -> Iterator[None]:
    """Pause Python's cyclic garbage collector for the work inside the block, then restore
    it (as it was: a caller inside another pause leaves it paused).

    Why: an import or a pocket's planning makes hundreds of thousands of small objects that
    live until it ends, and every full collection walks all of them again, with every
    object of the process (a quarter of the recognition's time on a 100 000-line file, a
    fifth to a quarter of the 8-island pocket's planning). Reference counting still frees
    everything as usual; only reference cycles made meanwhile wait for the collector.

    Why memory stays bounded: the work inside is bounded by the limits above before it
    starts, so what it keeps is too — an import by its bytes and lines
    (`check_import_size`), a pocket's planning by its levels times the points of its
    contours (`MAX_POCKET_WORK`, checked by app/cnc/cost.py before the compile) and the
    planner's MAX_LEVELS and MAX_CLEANUPS; the pocket planner makes no reference cycles
    (tests/test_pocketing.py holds it to that), so what it drops is freed at once. The
    collector is the process's: a server's other threads run without it meanwhile too, so
    their cycles wait as long as the work inside does (bounded by the same limits and the
    request's time budget): the pause that found it running gives it back when it ends.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()
