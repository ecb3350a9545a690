"""A referee for every output (issue 16): what we write, read back by a reader, must be the
tool path we meant — over the golden corpus and over programs hypothesis makes.

- **G-code** (LinuxCNC, Fanuc 6M, ProtoTRAK): LinuxCNC's own `rs274` reads the file and its
  canonical calls must be our tool path (tool lengths keyed in from the set-up comments, G54
  left at the machine's zero); our own G-code reader must read the same moves.
- **BOSS tape** (seed 004, one segment or many): our BOSS reader joins the segments and
  its moves must be the tool path's, in three axes; its Z words include each tool's TCAL
  and nothing on it says what that is, so Z is compared as the machine moves it (Z + TCAL),
  as for an EIA tape.
- **1704 tape** (ASCII and EIA listings and punch images): our tape reader's moves must be
  the tool path's, in three axes. ASCII tapes say in their header that Z words include each
  tool's TCAL and what each tool's TCAL is, so the reader gives each tool's own Z; an EIA
  tape carries no comments, so its Z is compared as the machine moves it (Z + TCAL).
- **ProtoTRAK Plus events** carry blocks, not moves, and no depths (a 2-axis control): the
  events read back and interpreted make the program's XY path (`support.two_axis`).
- **JSON**: the document reads back as the very program.

"Within the format's resolution": ends and centres within one step of the file (0.0001 in,
0.001 mm; events 0.01 mm), feeds within one written step (tape: 0.1 ipm, 1 mm/min). The
comparison (`referee.trace`) is written in the tests, not taken from the importers.

Generated programs (`strategies.shop_programs`) go where the corpus never did: arcs over
180° and off their radius, compensated contours with lines that go nowhere, routines, tools
without RPM or TCAL, inch and mm mixed. Every valid one must be processed by every target
(exported, or refused by a need of that target, never a crash), and each export it makes
must pass its referee.
"""

from __future__ import annotations

import dataclasses
import math
from decimal import Decimal
from pathlib import Path

import pytest
from hypothesis import HealthCheck, assume, given, settings

from app.cnc import document
from app.cnc.blocks import (
    ArcEnd,
    BoltCircle,
    Circle,
    Comp,
    Frame,
    Hole,
    MillArc,
    MillLine,
    MillQcir,
    Mode,
    Pocket,
    Program,
)
from app.cnc.estimate import estimate
from app.cnc.formats.gcode.bossread import join_segments
from app.cnc.formats.gcode.reader import parse_gcode
from app.cnc.formats.reading import read_program
from app.cnc.formats.svg import draw
from app.cnc.formats.tape1704.reader import parse_tape
from app.cnc.formats.targets import ExportError, export, targets
from app.cnc.interpret import interpret
from app.cnc.problems import Rule, has_errors
from app.cnc.setup import setup_sheet
from app.cnc.solve import needs_solving
from app.cnc.toolpath import Toolpath
from app.cnc.units import Units, to_nm
from app.cnc.validate import validate
from tests.imports.support import CASES, load, speeds, two_axis, with_rpms
from tests.referee import (
    FEED_STEP,
    READER,
    RESOLUTION,
    chords_as_arcs,
    deviation,
    entered,
    file_trace,
    referee_gcode,
    trace,
)
from tests.strategies import shop_programs

GCODE = ("gcode-linuxcnc", "gcode-fanuc", "gcode-prototrak")
TAPES = ("tape-ascii", "tape-eia", "punch-ascii", "punch-eia")
# Targets whose Z words are the machine's (the tool's Z plus its TCAL) with nothing that says
# the TCAL.
MACHINE_Z = ("tape-eia", "punch-eia", "tape-boss")
# A tape target refuses a program whose tools are not calibrated (its Z words include each
# tool's TCAL): the corpus' one such program goes onto tape with each tool touched off.
TAPE_OPTIONS = {"copy-feed-xy-tool": {"z-zero": "g94"}}


def machine_start(toolpath: Toolpath, machine: bool) -> tuple[int, int, int]:
    """Where the tool path starts, Z as the machine has it when `machine`."""
    x, y, z = toolpath.start
    info = toolpath.tools.get(toolpath.initial_tool)
    if machine and info is not None and info.tcal is not None:
        z += info.tcal
    return x, y, z


def assert_file_is_the_tool_path(program: Program, target: str, data: bytes) -> None:
    """Our reader's moves of `data` are `program`'s tool path within the file's steps."""
    reader = READER[target]
    units = program.units
    machine = target in MACHINE_Z
    if reader == "gcode":
        parsed = parse_gcode(data.decode("ascii"), program.name)
    elif reader == "boss":
        parsed = parse_gcode(join_segments(data.decode("ascii")).text, program.name)
    else:
        options = {"units": "metric"} if units is Units.MM else {}
        parsed = parse_tape(data, program.name, options)
    toolpath = interpret(program)
    step = RESOLUTION[reader][units]
    if reader == "gcode":
        # The file's safe start: its first move across is at the height it starts at.
        toolpath = entered(toolpath, machine_start(toolpath, machine)[2])
    expected = trace(toolpath, machine=machine, written=step)
    actual = file_trace(parsed, machine_start(toolpath, machine), machine=machine)
    # A target without helical arcs writes each as chords along it (app.cnc.geometry).
    actual = chords_as_arcs(expected, actual, machine_start(toolpath, machine), 2 * step)
    # Two numbers rounded to the file's step each: their difference is off by up to one.
    assert deviation(expected, actual, FEED_STEP[reader][units]) <= step


# -- the golden corpus -----------------------------------------------------------------------


@pytest.mark.parametrize("target", (*GCODE, *TAPES, "tape-boss"))
@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_the_file_says_the_tool_path(case: Path, target: str) -> None:
    program = load(case)
    options = TAPE_OPTIONS.get(case.name, {}) if target in TAPES else {}
    if options.get("z-zero") == "g94":
        pytest.skip("G94 presets Z at each change: the tape's Z is each tool's, from there")
    try:
        data = export(program, target, options).data
    except ExportError:
        assert target == "tape-boss" and case.name in TAPE_OPTIONS
        pytest.skip("the BOSS tape needs each tool's TCAL (it has no G94 option)")
    assert_file_is_the_tool_path(program, target, data)


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_a_segmented_boss_tape_says_the_tool_path(case: Path) -> None:
    """Seed 004 §8.1.1: the tape in segments of 300 characters (each ending where the tool
    is up) says the same moves as the tape in one."""
    program = load(case)
    try:
        data = export(program, "tape-boss", {"segment": "300"}).data
    except ExportError:
        pytest.skip("a stretch longer than a segment, or no TCAL: the export says which")
    assert_file_is_the_tool_path(program, "tape-boss", data)


@pytest.mark.parametrize("target", GCODE)
@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_linuxcnc_reads_our_gcode(case: Path, target: str, tmp_path: Path) -> None:
    program = load(case)
    referee_gcode(program, target, export(program, target).data, tmp_path)


# Programs the Plus's events cannot take, and why (the export's error says so).
HELICAL = "a HELIX or THREAD MILL moves Z with X and Y; the Plus has no Z"
EVENTS_REFUSED = dict.fromkeys(
    ("helix-bore", "helix-entry-mm", "thread-mill-internal", "thread-mill-external-mm"), HELICAL
) | dict.fromkeys(("face-zigzag", "face-one-way-mm"), "a FACE goes down level by level; no Z")
EVENTS_REFUSED |= dict.fromkeys(("engrave-line", "engrave-arc-mm"), "ENGRAVE's strokes need Z")
EVENTS_REFUSED |= dict.fromkeys(
    ("circle-pocket-helix-ramp", "frame-2p-pocket-helix-ramp-mm", "frame-pocket-zigzag-ramp"),
    "a ramp entry moves Z with XY",
)


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_events_read_back_as_the_programs_xy_path(case: Path) -> None:
    program = load(case)
    try:
        data = export(program, "events").data
    except ExportError as refused:
        assert case.name in EVENTS_REFUSED, str(refused)
        pytest.skip(EVENTS_REFUSED[case.name])
    back = read_program(data, case.name, "events").program
    expected = trace(interpret(two_axis(program)), with_z=False)
    actual = trace(interpret(with_rpms(back, speeds(program))), with_z=False)
    worst = deviation(expected, actual, FEED_STEP["events"][program.units])
    assert worst <= RESOLUTION["events"][program.units] + mixed_allowance(program) + (
        pocket_allowance(program) + calculated_allowance(program)
    )


def calculated_allowance(program: Program) -> int:
    """Points the compile calculates (issue 33: an empty X/Y, a tangency, a radius) are on
    no grid: the events file writes them to its 0.0001 in, and the importer rounds each to
    the programming resolution (what a block holds): up to a step (nm) from the solved
    path."""
    if not needs_solving(program.blocks, tuple(range(len(program.blocks)))):
        return 0
    return to_nm(program.units.resolution, program.units)


def pocket_allowance(program: Program) -> int:
    """A POCKET's passes are computed points; the events file writes them at the
    programming resolution (what the Plus's blocks hold and what reads back), an arc's end
    moved to a grid point on its radius: up to a step (nm) from the computed path."""
    if not any(isinstance(b, Pocket) for b in program.blocks):
        return 0
    return to_nm(program.units.resolution, program.units)


def mixed_allowance(program: Program) -> int:
    """A block in the other unit comes back in the file's (G20/G21 decides, issue 16 #8),
    rounded to that unit's programming resolution: up to a step (nm) more."""
    units = program.units
    if all(b.units is units for b in program.blocks):
        return 0
    # One step: a routine's size and corner radius are rounded each, and add up.
    return 25_400 if units is Units.INCH else 10_000


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_json_reads_back_as_the_program(case: Path) -> None:
    program = load(case)
    assert read_program(export(program, "json").data, case.name).program == program


def test_every_program_target_has_a_referee() -> None:
    """A new target that writes a program (not a picture) needs its reader here."""
    pictures = {"svg", "tape-svg", "canon"}
    assert set(targets()) - pictures == set(READER)


# -- generated programs --------------------------------------------------------------------

GENERATED = settings(
    max_examples=60,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[
        HealthCheck.too_slow,
        HealthCheck.data_too_large,
        HealthCheck.filter_too_much,
    ],
)


def valid(program: Program) -> Program:
    """`program` when validation finds nothing that stops its tool path (needs aside)."""
    assume(not has_errors(validate(program), frozenset()))
    return program


@GENERATED
@given(program=shop_programs(rpm_optional=True))
def test_what_check_accepts_every_consumer_processes(program: Program) -> None:
    """The rule of issue 16 #4: a program validation lets through is drawn, timed, put on a
    set-up sheet, and exported to every target — or refused by that target for something it
    needs, named — never a crash."""
    program = valid(program)
    toolpath = interpret(program)
    estimate(toolpath)
    draw(program)
    setup_sheet(program)
    for name in targets():
        try:
            export(program, name)
        except ExportError as refused:
            assert refused.problems or refused.report is not None, name


@GENERATED
@given(program=shop_programs())
def test_generated_gcode_is_what_linuxcnc_and_we_read(
    program: Program, tmp_path_factory: pytest.TempPathFactory
) -> None:
    program = valid(program)
    for target in GCODE:
        data = export(program, target).data
        assert_file_is_the_tool_path(program, target, data)
    referee_gcode(
        program,
        "gcode-linuxcnc",
        export(program, "gcode-linuxcnc").data,
        tmp_path_factory.mktemp("g"),
    )


@GENERATED
@given(program=shop_programs())
def test_generated_tapes_are_what_we_read(program: Program) -> None:
    program = valid(program)
    for target in ("tape-ascii", "punch-eia"):
        try:
            data = export(program, target).data
        except ExportError:
            continue  # a need of the tape (calibrated tools) or of the 1704 (feeds, size)
        assert_file_is_the_tool_path(program, target, data)


def events_carry(program: Program) -> bool:
    """False for compensated contours the events cannot give back to the step, each
    reported by the export or the import:

    - the depth changes on the way: the Plus uses Z to tell whether events connect (seed
      003 §2.2.4), so each piece is compensated on its own there;
    - an arc ends off its radius (a divot): its end on the radius, a computed point, is
      read back as a block rounded to the programming resolution, and the divot line
      with it;
    - a segment shorter than ten programming steps: the same, for its offset's corners;
    - routines cut with spindles turning both ways: the events give each routine's
      direction (DR), the file no spindle directions, and Data Block 0 has one milling
      mode, so one of them comes back the other way round (the import reports it).
    """
    blocks = program.blocks
    divots = {p.block for p in validate(program) if p.rule is Rule.ARC_RADIUS}
    if divots:
        return False
    turning = set()
    for block in blocks:
        if isinstance(block, Circle | Frame):
            tool = program.block0.tool(block.tool)
            turning.add(tool is None or tool.rpm is None or tool.rpm > 0)
    if len(turning) > 1:
        return False
    for k, block in enumerate(blocks):
        if not (isinstance(block, Hole) and block.comp is not Comp.NONE):
            continue
        depth = block.z_dn
        for after in blocks[k + 1 :]:
            if not isinstance(after, MillLine | MillQcir | MillArc | ArcEnd):
                break
            z_dn = getattr(after, "z_dn", None)
            if z_dn is not None and z_dn != depth:
                return False
            ten = 10 * after.units.resolution
            x, y = after.x or Decimal(0), after.y or Decimal(0)  # (generated: both given)
            if after.mode is Mode.INC and 0 < max(abs(x), abs(y)) < ten:
                return False
    return True


@GENERATED
@given(program=shop_programs(rpm_optional=True))
def test_generated_events_and_json_read_back(program: Program) -> None:
    program = valid(program)
    back = read_program(export(program, "json").data, "g").program
    assert document.dumps(back) == document.dumps(program)
    # Events are blocks (read back rounded to the programming resolution), not moves: a
    # program of one unit, whose compensated contours the events carry (`events_carry`),
    # whose bolt-circle holes are at least 0.01 in apart (closer ones run together).
    assume(all(b.units is program.units for b in program.blocks))
    assume(events_carry(program) and holes_apart(program))
    events = export(program, "events").data
    imported = read_program(events, "g", "events").program
    # A generated program's points may be off its grid (an INC block after a bolt circle's
    # last hole): the import rounds them to it, and an arc's centre to the grid point that
    # keeps its radii closest — within one programming step; a move shorter than half a
    # step may vanish in that rounding, or appear.
    step = 25_400 if program.units is Units.INCH else 10_000
    expected = trace(interpret(plus_feeds(two_axis(program))), with_z=False, shortest=step // 2)
    imported = with_rpms(imported, speeds(program))
    actual = trace(interpret(imported), with_z=False, shortest=step // 2)
    worst = deviation(expected, actual, FEED_STEP["events"][program.units])
    assert worst <= RESOLUTION["events"][program.units] + step


def holes_apart(program: Program) -> bool:
    """True when every bolt circle's holes are at least 0.01 in (0.25 mm) apart."""
    for block in program.blocks:
        if isinstance(block, BoltCircle) and block.holes > 1:
            chord = 2 * float(block.radius) * math.sin(math.pi / block.holes)
            if chord < (0.01 if block.units is Units.INCH else 0.25):
                return False
    return True


def plus_feeds(program: Program) -> Program:
    """`program` with its XY feeds as the Plus takes them: 0.1-99.9 ipm, 5-2535 mm/min
    (seed 003 §2.2.4; the export reports the change)."""
    low = {Units.INCH: Decimal("0.1"), Units.MM: Decimal(5)}
    top = {Units.INCH: Decimal("99.9"), Units.MM: Decimal(2535)}
    return dataclasses.replace(
        program,
        blocks=tuple(
            dataclasses.replace(b, feed_xy=min(max(b.feed_xy, low[b.units]), top[b.units]))
            if isinstance(b, MillLine | MillQcir | MillArc | Circle | Frame)
            else b
            for b in program.blocks
        ),
    )


def test_referee_catches_a_wrong_z() -> None:
    """The referee is not blind to Z: the tape reader that ignored TCAL (defect 1) fails."""
    program = load(CASES[[c.name for c in CASES].index("stop-and-tool-changes")])
    data = export(program, "tape-ascii").data
    shifted = data.replace(b"(Z ZERO WHERE TCAL IS 0: Z WORDS INCLUDE EACH TOOL TCAL)\n", b"")
    with pytest.raises(AssertionError):
        assert_file_is_the_tool_path(dataclasses.replace(program), "tape-ascii", shifted)
