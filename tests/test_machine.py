"""Machines carry their limits: exports refuse a program that would cross them, naming the
block; the cycle time follows the machine's rates (seed 002 §2 presets)."""

from __future__ import annotations

from dataclasses import replace
from decimal import Decimal as D
from pathlib import Path

import pytest

from app.cnc import document
from app.cnc.blocks import DataBlock0, Hole, HoleOp, Pos, Program, Tool
from app.cnc.compiler import compile_program
from app.cnc.estimate import estimate, report
from app.cnc.formats.targets import ExportError, export
from app.cnc.interpret import interpret
from app.cnc.machine import PRESETS, MachineError, check_travel, read_machine
from app.cnc.path import CompiledPath
from app.cnc.setup import gear
from app.cnc.spindle import read_spindle

GOLDEN = Path(__file__).parent / "golden"


def compiled(program: Program) -> CompiledPath:
    return compile_program(program).path


def part(x_offset: str, y: str, z_dn: str = "-0.5", tcal: str = "0") -> Program:
    """A drill at (1, y) in a part whose zero sits x_offset, 2 in from table zero."""
    tools = (Tool(number=1, diameter=D("0.25"), rpm=1200, tcal=D(tcal)),)
    return Program(
        name="limits",
        block0=DataBlock0(
            x_offset=D(x_offset), y_offset=D(2), current_tool=1, z_retract=D("0.1"), tools=tools
        ),
        blocks=(
            Pos(x=D(0), y=D(0), tool=1),
            Hole(
                op=HoleOp.DRILL,
                x=D(1),
                y=D(y),
                z_up=D("0.1"),
                z_dn=D(z_dn),
                feed_z=D(5),
                tool=1,
            ),
        ),
    )


def test_the_seed_002_presets() -> None:
    """Model 180: 0/20 on every axis; zone Y 2.88 / Z 6.50. Model 800: X 0/43.1535,
    Y 0/35.4, Z 5/36.5, zone Y 4.00 / Z 19.50, rapid 400 ipm."""
    kt180, kt800 = PRESETS["kt-180"], PRESETS["kt-800"]
    assert kt180.travel["x"] == (D(0), D(20)) and kt180.zone == (D("2.88"), D("6.50"))
    assert kt800.travel == {
        "x": (D(0), D("43.1535")),
        "y": (D(0), D("35.4")),
        "z": (D(5), D("36.5")),
    }
    assert kt800.zone == (D("4.00"), D("19.50")) and kt800.rapid == D(400)
    assert PRESETS["kt-200-optional"].travel["x"] == (D(0), D(30))
    spindle = kt180.spindle
    assert spindle is not None and spindle.gears == ((4, 4000),)  # "4 to 4000 rpms"


def test_a_move_past_the_travel_is_refused_with_its_block() -> None:
    """Part zero at X 18.5: the hole at X 1 is at machine X 19.5 (inside 0/20 on the 180),
    but at X 19.5 + 1 = 20.5 with part zero at X 19.5: block 2 crosses X 20. (TCAL 5 keeps
    the drill's Z, 5.2 down to 4.5, inside the Z travel.)"""
    machine = read_machine({"preset": "kt-180", "zone": ""})
    assert check_travel(compiled(part("18.5", "1", tcal="5")), machine) == []
    with pytest.raises(ExportError) as refused:
        export(part("19.5", "1", tcal="5"), "gcode-linuxcnc", machine=machine)
    report = refused.value.report
    assert report is not None
    assert [str(e) for e in report.entries if e.severity.value == "error"] == [
        "error: block 2: X reaches 20.5000 in in machine coordinates; the Kearney & Trecker "
        "Milwaukee-Matic 180 travels 0.0000 in to 20.0000 in"
    ]


def test_the_collision_zone_is_refused_with_its_block() -> None:
    """Model 180's zone: Y below 2.88 while Z is below 6.50. Part zero at Y 2: the hole at
    Y 0.5 is at machine Y 2.5; with TCAL 7 the drill is at Z 7.1 … 6.5, out of the zone,
    but with TCAL 6 it feeds down to Z 5.5 there: block 2 enters the zone."""
    machine = PRESETS["kt-180"]
    assert check_travel(compiled(part("5", "0.5", tcal="7")), machine) == []
    crossings = check_travel(compiled(part("5", "0.5", tcal="6")), machine)
    assert [(c.block, c.message) for c in crossings] == [
        (
            2,
            "the move enters the collision zone (Y below 2.8800 in while Z is below "
            "6.5000 in): the spindle head can hit the table",
        )
    ]


def test_arcs_are_checked_at_their_bulge() -> None:
    """A full circle of radius 1.25 about (2, 2) reaches X 3.25 + offset though its start
    and end points do not."""
    program = document.loads((GOLDEN / "circle-outside" / "program.json").read_text())
    toolpath = interpret(program)
    path = compiled(program)
    furthest = max(
        getattr(m, "cx", 0) + abs(getattr(m, "x", 0) - getattr(m, "cx", 0)) for m in toolpath.moves
    )
    assert furthest > 0
    limit = (D(furthest) + D(toolpath.origin[0])) / 25_400_000 - D("0.01")
    machine = read_machine({"x": [0, float(limit)], "units": "inch"})
    assert any("X reaches" in c.message for c in check_travel(path, machine))


def test_bad_machine_descriptions_are_named() -> None:
    with pytest.raises(MachineError, match="preset 'kt-999' is not one of kt-180"):
        read_machine({"preset": "kt-999"})
    with pytest.raises(MachineError, match="x: the minimum 20 is not below the maximum 0"):
        read_machine({"x": "20/0"})
    with pytest.raises(MachineError, match="rapid: -5 must be more than 0"):
        read_machine({"rapid": "-5"})


def test_cycle_time_per_machine() -> None:
    """drill-single's rapids are 2.314214 in (see test_hand_derived): 0.555411 s at 250 ipm,
    0.347132 s at the Model 800's 400 ipm; a 2 ipm feed cap makes the 0.6 in feed take 18 s
    instead of 7.2 s. OTIME (seed 002: "the additional operator time to be added to the
    printed cycle time") is added once, however many stops and tool changes there are."""
    toolpath = interpret(document.loads((GOLDEN / "drill-single" / "program.json").read_text()))
    kt800 = estimate(toolpath, machine=PRESETS["kt-800"])
    assert kt800.rapid == pytest.approx(0.347132, abs=1e-6)
    slow = estimate(toolpath, machine=read_machine({"max_feed": "2", "operator_seconds": "60"}))
    assert slow.cutting == pytest.approx(18.0)
    assert any("limited to the machine's 2 ipm" in a for a in slow.assumptions)
    stops = interpret(
        document.loads((GOLDEN / "stop-and-tool-changes" / "program.json").read_text())
    )
    base = estimate(stops).total
    with_otime = estimate(stops, machine=read_machine({"operator_seconds": "60"}))
    # Two STOPs and three tool changes: still 60 s (it was 60 s at each: +300 s).
    assert with_otime.total - base == pytest.approx(60)
    assert with_otime.operator == 60 and sum(with_otime.per_block.values()) == pytest.approx(base)
    assert "Operator time (OTIME) 1:00.0" in report(with_otime)
    single = estimate(toolpath, machine=read_machine({"operator_seconds": "60"}))
    assert single.total - estimate(toolpath).total == pytest.approx(60)


# -- the spindle ---------------------------------------------------------------------------


def fast(rpm: int) -> Program:
    """The drill of `part`, its tool at `rpm`."""
    program = part("5", "1")
    tool = replace(program.block0.tools[0], rpm=rpm)
    return replace(program, block0=replace(program.block0, tools=(tool,)))


def errors_of(refused: pytest.ExceptionInfo[ExportError]) -> list[str]:
    report = refused.value.report
    assert report is not None
    return [str(e) for e in report.entries if e.severity.value == "error"]


def test_a_machine_s_spindle_range_decides_the_rpm_an_export_takes() -> None:
    """The RPM limit was 4000 for every machine (a validation error); a LinuxCNC mill whose
    profile says its spindle runs 100-24000 rpm takes 9000, and a machine with the control's
    gears, or no machine with a spindle range, refuses it naming the tool."""
    linuxcnc = read_machine({"name": "Mill 2", "spindle": "100-24000"})
    assert linuxcnc.spindle is not None and linuxcnc.spindle.gears == ((100, 24000),)
    assert "S9000 M3" in export(fast(9000), "gcode-linuxcnc", machine=linuxcnc).data.decode()
    assert "S9000 M4" in export(fast(-9000), "gcode-linuxcnc", machine=linuxcnc).data.decode()
    with pytest.raises(ExportError) as refused:
        export(fast(9000), "gcode-linuxcnc")
    assert errors_of(refused) == [
        "error: program: tool 1 runs at 9000 rpm; the ProtoTRAK-style control's spindle runs "
        "60 to 4000 rpm (60-500 low gear, 500-4000 high gear), or -60 to -4000 in reverse (no "
        "machine with a spindle range was chosen): choose a machine whose profile gives its "
        "spindle range (spindle=LOW-HIGH), or change the tool's RPM"
    ]
    geared = read_machine({"name": "Bridgeport", "spindle": "60-500, 500-4000"})
    with pytest.raises(ExportError) as refused:
        export(fast(50), "gcode-linuxcnc", machine=geared)
    assert errors_of(refused) == [
        "error: program: tool 1 runs at 50 rpm; Bridgeport's spindle runs 60 to 4000 rpm "
        "(60-500 low gear, 500-4000 high gear), or -60 to -4000 in reverse: change the tool's "
        "RPM, or choose a machine that runs it"
    ]
    assert export(fast(200), "gcode-linuxcnc", machine=linuxcnc).size > 0


def test_without_s_words_the_spindle_is_not_the_export_s_business() -> None:
    """The JSON document and a tape whose spindle is set by hand write any RPM."""
    assert export(fast(9000), "json").size > 0
    assert export(fast(9000), "tape-eia").size > 0


def test_bad_spindle_ranges_are_named() -> None:
    with pytest.raises(MachineError, match="spindle: 'fast' is not a range of speeds"):
        read_machine({"spindle": "fast"})
    with pytest.raises(MachineError, match="spindle: 4000-500: a gear runs from a lower"):
        read_machine({"spindle": "4000-500"})
    with pytest.raises(MachineError, match="spindle: 60-500: list the gears from the slowest up"):
        read_machine({"spindle": "500-4000, 60-500"})
    assert (
        read_machine({"spindle": [[60, 500], [500, 4000]]}).spindle
        == read_machine({"spindle": "60-500,500-4000"}).spindle
    )


def test_the_set_up_sheet_names_the_gear_of_the_machine_s_spindle() -> None:
    assert gear(300) == "low gear, forward" and gear(-2000) == "high gear, reverse"
    three = read_spindle("50-400, 400-1500, 1500-6000")
    assert gear(5000, three) == "gear 3 of 3, forward"
    assert gear(9000, read_spindle("100-24000")) == "forward"
    assert gear(9000) == "outside the spindle's range (60-500, 500-4000 rpm), forward"


@pytest.mark.parametrize("key", ["X", "x_travel", "travel", "Rapid", "max-feed"])
def test_an_unknown_key_is_an_error_naming_it_and_the_allowed_keys(key: str) -> None:
    with pytest.raises(MachineError, match=f"unknown key '{key}'") as caught:
        read_machine({"x": "0 10", key: "0 0.5"})
    assert "allowed: preset, name, units, x, y, z, zone, rapid, max_feed" in str(caught.value)
    if key.lower() in ("x", "rapid"):
        assert f"(did you mean '{key.lower()}'?)" in str(caught.value)
