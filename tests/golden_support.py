"""Shared helpers for golden-file tests: compare, or rewrite when asked.

Set MILLBLOCKS_REGEN_GOLDEN=1 (`make regen-golden`) to rewrite expected files from the
current code; review the diff before committing, since a regenerated file only restates
the code. The hand-derived tests (test_hand_derived.py) are what pin the behaviour.
"""

from __future__ import annotations

import os
from pathlib import Path

REGENERATE = os.environ.get("MILLBLOCKS_REGEN_GOLDEN") == "1"


def check_golden(path: Path, actual: str | bytes) -> None:
    """Assert `actual` equals the file at `path` (or write it when regenerating)."""
    data = actual.encode("utf-8") if isinstance(actual, str) else actual
    if REGENERATE:
        path.write_bytes(data)
        return
    assert path.exists(), f"{path} is missing; run `make regen-golden` and review it"
    assert data == path.read_bytes(), f"{path} differs from the output (diff them)"
