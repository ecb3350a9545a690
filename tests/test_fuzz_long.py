"""The long fuzz run's harness (bench/fuzz_long.py), bounded for `make test`: a few
hundred inputs per parser, the same generator as the documented 10^6 run."""

from __future__ import annotations

from pathlib import Path

import pytest

from bench.fuzz_long import PARSERS, run_chunk

COUNT = {"backup": 60}


@pytest.mark.parametrize("parser", PARSERS)
def test_no_parser_crashes_or_stalls_on_mutated_golden_exports(parser: str, tmp_path: Path) -> None:
    tally = run_chunk((parser, 0, COUNT.get(parser, 300), 1717, 20.0, str(tmp_path)))
    assert tally.inputs == COUNT.get(parser, 300)
    assert tally.crashes == [] and tally.slow == []
