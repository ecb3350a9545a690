"""Restart at a block (issue 35): the program from data block N on cuts exactly what the
whole program cuts from block N on; a block inside a unit the control runs whole, or an
incremental one, is refused naming where to restart; the restart goes through every
G-code target, LinuxCNC's rs274 and our own importer read it back, and a DNC send from a
block is logged as such."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from app.cli import main
from app.cnc import document
from app.cnc.blocks import Program
from app.cnc.formats.targets import export
from app.cnc.interpret import interpret
from app.cnc.restart import RestartError, restart_from
from app.cnc.structure import build_nodes
from app.cnc.toolpath import ArcFeed, Feed
from app.cnc.validate import validate
from app.storage.demo import demo_programs
from app.storage.library import open_library
from app.storage.transfers import TransferLog
from tests.referee import FEED_STEP, deviation, read_back, referee_gcode, trace
from tests.simulated_control import SimulatedControl, SocatPair

GOLDEN = Path(__file__).parent / "golden"
CASES = ("drill-12-pecks", "mill-pecks", "contour-cut-right", "pocket-islands", "loop-rep-grid")


def golden(case: str) -> Program:
    return document.loads((GOLDEN / case / "program.json").read_text())


def cuts(program: Program, first_block: int = 1) -> list[tuple[object, ...]]:
    """Every feed move from data block `first_block` on: block (counted from there), end
    point, feed, and an arc's centre and direction (nm, exact)."""
    out: list[tuple[object, ...]] = []
    for move in interpret(program).moves:
        if isinstance(move, Feed | ArcFeed) and move.block >= first_block:
            arc = (move.cx, move.cy, move.clockwise) if isinstance(move, ArcFeed) else ()
            out.append((move.block - first_block + 1, move.x, move.y, move.z, move.feed, *arc))
    return out


def starts(program: Program) -> list[int]:
    """The 1-based numbers of the blocks a restart may begin at (each unit's first)."""
    found = []
    for node in build_nodes(program.blocks):
        first = node
        while hasattr(first, "body"):
            first = first.body[0]
        index = getattr(first, "index", getattr(first, "centre", getattr(first, "drill", None)))
        assert isinstance(index, int)
        found.append(index + 1)
    return found


@pytest.mark.parametrize("case", CASES)
def test_a_restart_cuts_what_the_program_cuts_from_that_block(case: str) -> None:
    program = golden(case)
    numbers = [n for n in starts(program) if program.blocks[n - 1].mode.value == "abs"]
    assert numbers
    for number in numbers:
        restarted = restart_from(program, number)
        assert not [p for p in validate(restarted) if p.severity.value == "error"]
        assert restarted.name.endswith(f"FROM BLOCK {number}")
        assert cuts(restarted) == cuts(program, number), number


def test_a_restart_goes_through_rs274_and_our_importer(tmp_path: Path) -> None:
    """The sample part restarted at its last unit (the contour after the holes): LinuxCNC's
    rs274 reads the same cut as ours, and our importer reads back, from each G-code
    target, the cut the whole program makes from that block."""
    program = demo_programs()[0]
    number = starts(program)[-1]
    assert number > 1
    restarted = restart_from(program, number)
    for target in ("gcode-linuxcnc", "gcode-fanuc", "gcode-prototrak"):
        data = export(restarted, target).data
        if target == "gcode-linuxcnc":
            referee_gcode(restarted, target, data, tmp_path)
        back = read_back(restarted, target, data)
        # Read back as data blocks, which hold 0.001 in: the cut lands within that of ours
        # (compared as the round-trip tests compare, arcs across quadrants as one).
        worst = deviation(
            [s for s in trace(interpret(restarted), shortest=25_400) if s.kind in ("F", "A")],
            [s for s in trace(interpret(back), shortest=25_400) if s.kind in ("F", "A")],
            FEED_STEP["gcode"][program.units],
        )
        assert worst <= 25_400, (target, worst)


def test_a_restart_inside_a_unit_names_where_to_restart() -> None:
    contour = golden("contour-cut-right")
    with pytest.raises(RestartError) as inside:
        restart_from(contour, 4)
    assert str(inside.value) == (
        "restart at block 4: it is inside the mill sequence of blocks 1-8; restart at block 1, "
        "where it begins"
    )
    grid = golden("loop-bolt-circle")
    with pytest.raises(RestartError) as looped:
        restart_from(grid, 3)
    assert "inside the LOOP pattern of blocks 2-4; restart at block 2" in str(looped.value)
    with pytest.raises(RestartError) as incremental:
        restart_from(grid, 2)
    assert "it is incremental (INC)" in str(incremental.value)
    with pytest.raises(RestartError) as beyond:
        restart_from(grid, 9)
    assert str(beyond.value) == "restart at block 9: the program has blocks 1 to 4"


def test_a_send_from_a_block_puts_the_restart_in_the_control_and_logs_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    if shutil.which("socat") is None:
        pytest.fail("socat is not installed: add the Debian package socat (apt-get install socat)")
    database = f"sqlite:///{tmp_path / 'cli.db'}"
    monkeypatch.setenv("DATABASE_URL", database)
    program = golden("drill-12-pecks")
    path = tmp_path / "part.json"
    path.write_text(document.dumps(program), encoding="utf-8")
    number = starts(program)[-1]
    expected = export(restart_from(program, number), "gcode-linuxcnc").data
    with (
        SocatPair() as pair,
        SimulatedControl(pair.control, parity="E", buffer_size=1 << 16) as control,
    ):
        result = CliRunner().invoke(
            main,
            [
                *("send", str(path), "--port", pair.host),
                *("--to", "gcode-linuxcnc", "--from-block", str(number)),
            ],
        )
        assert control.received(expected.replace(b"\n", b"\r\n"), timeout=30)
    assert result.exit_code == 0, result.output
    [sent] = TransferLog(open_library(database)).recent(1)
    assert sent.start_block == number and sent.program_name.endswith(f"FROM BLOCK {number}")
    refused = CliRunner().invoke(
        main, ["send", str(path), "--port", "/dev/null", "--from-block", "99"]
    )
    assert (
        refused.exit_code == 1 and "restart at block 99: the program has blocks" in refused.output
    )
