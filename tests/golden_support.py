"""Shared helpers for golden-file tests: compare, or rewrite when asked.

Set MILLBLOCKS_REGEN_GOLDEN=1 (`make regen-golden`) to rewrite expected files from the
current code; review the diff before committing, since a regenerated file only restates
the code. The hand-derived tests (test_hand_derived.py) are what pin the behaviour.
"""

from __future__ import annotations

import os
from pathlib import Path

REGENERATE = os.environ.get("MILLBLOCKS_REGEN_GOLDEN") == "1"


def check_golden(path: Path, actual: str) -> None:
    """Assert `actual` equals the file at `path` (or write it when regenerating)."""
    if REGENERATE:
        path.write_text(actual, encoding="utf-8")
        return
    assert path.exists(), f"{path} is missing; run `make regen-golden` and review it"
    expected = path.read_text(encoding="utf-8")
    assert actual == expected, f"{path} differs from the output (diff them)"
