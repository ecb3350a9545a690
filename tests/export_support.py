"""Measuring an export in a test: what it allocates at its worst moment (not how long it
takes: speed is measured in bench/, never in tests)."""

from __future__ import annotations

import tracemalloc

from app.cnc.blocks import Program
from app.cnc.compiler import compile_program
from app.cnc.copy import resolve_copies
from app.cnc.formats.targets import Export, export, targets


def traced_export(program: Program, target: str) -> tuple[Export, int]:
    """The export of `program` to `target` and the peak bytes Python allocated during it
    (tracemalloc). The compile's cache and the targets' modules are made first: they are
    not the export's."""
    compile_program(resolve_copies(program))
    targets()
    tracemalloc.start()
    try:
        made = export(program, target)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return made, peak
