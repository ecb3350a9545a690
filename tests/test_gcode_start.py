"""G-code starts safely (issue 29 point 4): where the spindle is at cycle start is unknown,
so no dialect moves Z down before the first X/Y position; the first tool is called with
`T<n> M6` (an option); the report says where the tool must be at the start.

Read from the output itself and, for every dialect, by LinuxCNC's rs274 with the spindle
starting at the machine's home 10 in above part zero.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from app.cnc.formats.targets import export, get_target
from app.cnc.units import Units
from tests.imports.support import CASES, load
from tests.referee import CALL, RS274, run_rs274

GCODE = ("gcode-linuxcnc", "gcode-fanuc", "gcode-prototrak")
WORD = re.compile(r"([A-Z])\s*([-+]?[0-9.]+)")


def blocks(text: str) -> list[dict[str, list[float]]]:
    """Each line's words (letter -> values), comments and N numbers left out."""
    out = []
    for raw in text.splitlines():
        line = re.sub(r"\(.*?\)", "", raw).split(";")[0].strip().upper()
        if not line or line.startswith(("%", "O")):
            continue
        words: dict[str, list[float]] = {}
        for letter, value in WORD.findall(line):
            words.setdefault(letter, []).append(float(value))
        words.pop("N", None)
        out.append(words)
    return out


def before_first_xy(text: str) -> tuple[list[dict[str, list[float]]], dict[str, list[float]]]:
    """The blocks before the first that names X or Y, and that block."""
    found = blocks(text)
    for k, words in enumerate(found):
        if "X" in words or "Y" in words:
            return found[:k], words
    raise AssertionError("no X/Y position in the output")


@pytest.mark.parametrize("target", GCODE)
@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_no_z_move_before_the_first_xy_position(case: Path, target: str) -> None:
    text = export(load(case), target).data.decode()
    before, first = before_first_xy(text)
    for words in before:
        if "Z" in words:
            # Only the retract to the reference point: incremental 0, straight up.
            assert 28.0 in words.get("G", []) and 91.0 in words["G"], words
            assert words["Z"] == [0.0], words
    # The first position is a rapid across, with no Z: at the height the tool is at.
    assert first.get("G", [0.0]) == [0.0] and "Z" not in first, first


def rs274_motions(text: str, tmp_path: Path) -> list[tuple[str, tuple[float, float, float]]]:
    """rs274's motions of `text` with G54 10 in below the machine's home: the spindle starts
    10 in above part zero (program coordinates)."""
    lines = text.splitlines()
    lines.insert(1, "G20 G10 L2 P1 X0 Y0 Z-10")
    path = tmp_path / "start.ngc"
    path.write_text("\n".join(lines) + "\n")
    result, output = run_rs274(path, None)
    assert result.returncode == 0, output
    motions = []
    for raw in result.stdout.splitlines():
        m = CALL.match(raw)
        if m and m.group(1) in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED", "ARC_FEED"):
            args = [float(a) for a in m.group(2).replace(" ", ",").split(",") if a]
            z = args[5] if m.group(1) == "ARC_FEED" else args[2]
            motions.append((m.group(1), (args[0], args[1], z)))
    return motions


@pytest.mark.skipif(not RS274, reason="rs274 (linuxcnc-uspace) is not installed")
@pytest.mark.parametrize("target", GCODE)
@pytest.mark.parametrize(
    "case", ["stop-and-tool-changes", "pocket-islands", "contour-cut-right", "frame-pocket-mm"]
)
def test_linuxcnc_moves_nothing_down_before_the_first_position(
    case: str, target: str, tmp_path: Path
) -> None:
    program = load(Path(CASES[0]).parent / case)
    text = export(program, target).data.decode()
    _, first = before_first_xy(text)
    start = 10.0 * (
        25.4 if program.units is Units.MM else 1.0
    )  # the G54 Z offset is 10 in below the machine's home
    where = (0.0, 0.0, start)
    for kind, end in rs274_motions(text, tmp_path):
        if end[:2] != where[:2]:
            # The first move across: at the height the spindle started at, to the first
            # position the output names.
            assert kind == "STRAIGHT_TRAVERSE" and end[2] >= start - 1e-6, (kind, end)
            assert (end[0], end[1]) == pytest.approx((first["X"][0], first["Y"][0]))
            return
        assert end[2] >= where[2] - 1e-6, f"{kind} down to Z{end[2]} before any X/Y move"
        where = end
    raise AssertionError("no move across")


@pytest.mark.parametrize("target", GCODE)
def test_the_first_tool_is_called_unless_turned_off(target: str) -> None:
    program = load(Path(CASES[0]).parent / "stop-and-tool-changes")
    option = {o.name: o for o in get_target(target).options}["tool-change"]
    assert option.default is True
    before, _ = before_first_xy(export(program, target).data.decode())
    assert any(w.get("T") == [1.0] and w.get("M") == [6.0] for w in before)
    before, _ = before_first_xy(export(program, target, {"tool-change": "no"}).data.decode())
    assert not any("T" in w for w in before)


@pytest.mark.parametrize("target", GCODE)
def test_the_report_says_where_the_tool_must_be_at_the_start(target: str) -> None:
    program = load(Path(CASES[0]).parent / "stop-and-tool-changes")
    report = export(program, target).report.text()
    assert "start: the first move is Z straight up" in report
    assert "then across to X1" in report and "then down to Z0.2" in report
    without = export(program, target, {"start-retract": "no"})
    assert "start with the tool above the part at Z0.2" in without.report.text()
    before, _ = before_first_xy(without.data.decode())
    assert not any("Z" in w for w in before)
