"""The long fuzz run of the importers (docs/imports.md): N inputs per reader (default 100 000).

    .venv/bin/python bench/fuzz_imports.py [N] [--random]

Runs tests/test_import_fuzz.py with MILLBLOCKS_FUZZ_EXAMPLES=N: each reader (G-code,
events, 1704 listing, punch image, JSON, and format detection) gets N inputs and must raise
nothing but ImportFailure. Derandomized (the same inputs every run) unless --random.
Prints the time taken; the exit status is pytest's.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def main(argv: list[str]) -> int:
    count = next((a for a in argv if a.isdigit()), "100000")
    os.environ["MILLBLOCKS_FUZZ_EXAMPLES"] = count
    if "--random" in argv:
        os.environ["MILLBLOCKS_FUZZ_RANDOM"] = "1"
    os.chdir(ROOT)
    started = time.monotonic()
    status = pytest.main(["-q", "-p", "no:cacheprovider", "tests/test_import_fuzz.py"])
    minutes = (time.monotonic() - started) / 60
    print(f"{count} inputs per reader, 6 readers: {minutes:.1f} min, pytest status {status}")
    return int(status)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
