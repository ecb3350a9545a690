"""Golden tests: one folder per case under tests/golden/.

Each folder holds `program.json` and one `expected.<format>` per output checked: every case
has `expected.canon` (the canonical dump); `expected.<target>` for any export target
(`expected.json` is the program after COPY blocks are carried out), with
`expected.<target>.report` for its compatibility report; `expected.time` for the
cycle-time report. Each target must have golden files (test_every_target_has_goldens).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from app.cnc import document
from app.cnc.blocks import Program
from app.cnc.copy import resolve_copies
from app.cnc.estimate import estimate, report
from app.cnc.formats import canon
from app.cnc.formats.targets import export, targets
from app.cnc.interpret import interpret
from app.cnc.problems import Severity
from app.cnc.setup import render_text, setup_sheet
from app.cnc.validate import validate
from tests.golden_support import REGENERATE, check_golden

GOLDEN = Path(__file__).parent / "golden"
CASES = sorted(p for p in GOLDEN.iterdir() if (p / "program.json").exists())

FORMATS: dict[str, Callable[[Program], str]] = {
    "canon": lambda p: canon.dump(interpret(p)),
    "json": document.dumps,
    "time": lambda p: report(estimate(interpret(p))),
    # The set-up sheet with the 1704 ASCII tape's report (tape length included).
    "setup": lambda p: render_text(setup_sheet(p, export(p, "tape-ascii").report)),
}


def load(case: Path) -> Program:
    return resolve_copies(document.loads((case / "program.json").read_text(encoding="utf-8")))


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_golden_case(case: Path) -> None:
    program = load(case)
    errors = [str(p) for p in validate(program) if p.severity is Severity.ERROR]
    assert errors == [], "golden programs must be valid"
    for name, render in FORMATS.items():
        path = case / f"expected.{name}"
        if name == "canon" or path.exists():
            check_golden(path, render(program))
    for name in targets():
        path = case / f"expected.{name}"
        wanted = path.exists() or (REGENERATE and case.name in REGENERATE_FOR.get(name, ()))
        if name in FORMATS or not wanted:
            continue
        result = export(program, name)
        check_golden(path, result.data)
        check_golden(case / f"expected.{name}.report", result.report.text())


# Cases whose expected files a target writes when regenerating (add a case name here to
# give a target a new golden file; after that the file's presence keeps it checked).
_TAPE_CASES = (
    "drill-12-pecks",
    "bolt-circle-drill",
    "loop-rep-grid",
    "contour-cut-right",
    "mill-contour-uncompensated",
    "circle-inside",
    "frame-in-tan",
    "tap-metric",
    "circle-inside-mm",
    "stop-and-tool-changes",
    "two-axis",
    "pos-index",
    "coolant-and-messages",
)
_GCODE_CASES = (
    "bolt-circle-drill",
    "contour-cut-right",
    "drill-12-pecks",
    "stop-and-tool-changes",
    "tap-metric",
    "frame-pocket",
    "circle-in-tan-mm",
    "two-axis",
    "coolant-and-messages",
)
# POCKET (issue 22) goes to every target as explicit moves: a golden file for each.
_POCKET_CASES = ("pocket-islands", "pocket-mm", "pocket-loop")
# Calculated geometry, conrads and chamfers (issue 33): the G-code rs274 referees, and
# the events with their CR.
_PRINT_CASES = (
    "print-line-tangent-arc",
    "print-arc-tangent-arc-mm",
    "print-intersections",
    "print-conrad-chamfer",
    "print-conrad-chamfer-mm",
    "print-line-line-mm",
)
# The operations of issue 33 (helical arcs: G2/G3 with Z, or chords where a target has none).
_OPERATION_CASES = (
    "helix-bore",
    "helix-entry-mm",
    "thread-mill-internal",
    "thread-mill-external-mm",
    "face-zigzag",
    "face-one-way-mm",
    "engrave-line",
    "engrave-arc-mm",
    # A pocket's ramp entry (issue 33): helical arcs in place of the plunges.
    "circle-pocket-helix-ramp",
    "frame-2p-pocket-helix-ramp-mm",
    "frame-pocket-zigzag-ramp",
)
REGENERATE_FOR: dict[str, tuple[str, ...]] = {
    "gcode-linuxcnc": _GCODE_CASES + _POCKET_CASES + _PRINT_CASES + _OPERATION_CASES,
    "gcode-fanuc": _GCODE_CASES + _POCKET_CASES + _PRINT_CASES + _OPERATION_CASES,
    "gcode-prototrak": _GCODE_CASES + _POCKET_CASES + _PRINT_CASES + _OPERATION_CASES,
    "svg": (
        "loop-nested-3-deep",
        "contour-cut-right",
        "frame-pocket",
        "bolt-circle-drill",
        *_POCKET_CASES,
        *_OPERATION_CASES,
    ),
    "tape-eia": _TAPE_CASES + _POCKET_CASES + ("print-conrad-chamfer",) + _OPERATION_CASES,
    "tape-ascii": _TAPE_CASES + _POCKET_CASES + _OPERATION_CASES,
    "events": _POCKET_CASES + _PRINT_CASES,
    "punch-eia": ("drill-single", "circle-inside-mm", "frame-in-tan", "stop-and-tool-changes"),
    "punch-ascii": ("drill-single", "tap-metric", "contour-cut-right"),
    "tape-svg": ("drill-single", "pos-basic", "tap-metric"),
    "tape-boss": (
        "loop-rep-grid",
        "contour-cut-right",
        "tap-metric",
        "coolant-and-messages",
        *_OPERATION_CASES,
    ),
}


def test_every_target_has_goldens() -> None:
    for name in targets():
        count = sum(1 for case in CASES if (case / f"expected.{name}").exists())
        assert count >= 3, f"target {name} has {count} golden files; it needs some"


def test_corpus_covers_every_block_type() -> None:
    kinds = set()
    for case in CASES:
        for block in load(case).blocks:
            kinds.add(block.type_name.split()[0] if block.kind == "HOLE" else block.kind)
        raw = document.loads((case / "program.json").read_text(encoding="utf-8"))
        kinds.update(b.kind for b in raw.blocks if b.kind == "COPY")
    expected = {"POS", "DRILL", "BORE", "TAP", "BOLT_CIR", "MILL_STD", "MILL_QCIR"}
    expected |= {"MILL_ARC", "MILL_ARC_END", "REP", "COPY"}
    expected |= {"POCKET", "PKT_LINE", "PKT_ARC", "PKT_ARC_END", "ISLAND"}
    expected |= {"HELIX", "THREAD_MILL", "FACE", "ENGRAVE"}
    assert expected <= kinds, f"no golden case for {sorted(expected - kinds)}"
