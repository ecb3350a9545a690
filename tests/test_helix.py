"""HELIX and helical arcs (issue 33 point 3): the motion worked out by hand, and what each
consumer of a helical arc makes of it.

The golden cases (tests/golden/helix-bore, helix-entry-mm) pin every target's bytes; LinuxCNC's
rs274 and our importers read them back (tests/test_referee.py, tests/test_import_roundtrip.py).
Here the numbers are derived from the block by hand.
"""

from __future__ import annotations

import dataclasses
import math
from decimal import Decimal
from pathlib import Path

import numpy as np
import pytest

from app.cnc import cost, document
from app.cnc.blocks import Helix, MillingMode, Program, Tool
from app.cnc.compiler import compile_program
from app.cnc.estimate import estimate
from app.cnc.formats.gcode.reader import parse_gcode
from app.cnc.formats.reading import read_program
from app.cnc.formats.targets import export
from app.cnc.interpret import interpret
from app.cnc.machine import _enters_zone
from app.cnc.path import MOVE, Op
from app.cnc.recognition.common import ImportFailure
from app.cnc.simulate.segments import Entry, ToolShapes, piece_segments
from app.cnc.simulate.verify import verify
from app.cnc.toolpath import ArcFeed, Feed, Rapid
from app.cnc.units import Units

GOLDEN = Path(__file__).parent / "golden"
IN = 25_400_000  # nm per inch


def bore() -> Program:
    """helix-bore's first block alone: a 1.000 in bore at (1.5, 1.25), tool 1 DIA 0.500,
    Z UP 0.05 to Z DN -0.625 at 0.1 a turn, climb (Data Block 0), 12 ipm."""
    program = document.loads((GOLDEN / "helix-bore" / "program.json").read_text())
    return dataclasses.replace(program, blocks=program.blocks[:1])


def arcs(program: Program) -> list[ArcFeed]:
    return [m for m in interpret(program).moves if isinstance(m, ArcFeed)]


def test_a_helix_goes_down_a_pitch_a_turn_then_turns_once_at_the_bottom() -> None:
    """Tool centre at (DIA - tool DIA) / 2 = 0.25 from the centre, entering at 3 o'clock
    (1.75, 1.25); 0.675 deep at 0.1 a turn is 6 whole turns and 0.75 of one, which ends at
    6 o'clock (1.5, 1.0) going counter-clockwise; then a whole turn at Z DN."""
    moves = interpret(bore()).moves
    motion = [m for m in moves if isinstance(m, Rapid | Feed | ArcFeed)]
    assert motion[:3] == [
        Rapid(1, 0, 0, round(0.15 * IN)),
        Rapid(1, round(1.75 * IN), round(1.25 * IN), round(0.15 * IN)),
        Rapid(1, round(1.75 * IN), round(1.25 * IN), round(0.05 * IN)),
    ]
    turns = arcs(bore())
    centre = (round(1.5 * IN), round(1.25 * IN))
    assert all((a.cx, a.cy) == centre and not a.clockwise for a in turns)
    assert [(a.x, a.y) for a in turns[:6]] == [(round(1.75 * IN), round(1.25 * IN))] * 6
    assert [a.z for a in turns[:6]] == [round((0.05 - 0.1 * k) * IN) for k in range(1, 7)]
    assert (turns[6].x, turns[6].y, turns[6].z) == (
        round(1.5 * IN),
        round(1.0 * IN),
        round(-0.625 * IN),
    )
    # The whole turn at the bottom, then off the wall to the centre (the 0.5 tool covers
    # it: a 1.0 bore has no core), and up.
    assert (turns[7].x, turns[7].y, turns[7].z) == (turns[6].x, turns[6].y, turns[6].z)
    assert len(turns) == 8
    assert motion[-2] == Feed(1, *centre, round(-0.625 * IN), round(12 * IN), "lead-out")
    assert motion[-1] == Rapid(1, *centre, round(0.15 * IN), "retract")


def test_conventional_and_a_reversed_spindle_turn_the_other_way() -> None:
    program = bore()
    helix = program.blocks[0]
    assert isinstance(helix, Helix)
    conventional = dataclasses.replace(helix, milling=MillingMode.CONVENTIONAL)
    assert all(a.clockwise for a in arcs(dataclasses.replace(program, blocks=(conventional,))))
    # Data Block 0's CONV, with the spindle counter-clockwise: climb again (CIRCLE's rule).
    tools = tuple(dataclasses.replace(t, rpm=-2400) for t in program.block0.tools)
    block0 = dataclasses.replace(program.block0, milling=MillingMode.CONVENTIONAL, tools=tools)
    assert not any(a.clockwise for a in arcs(dataclasses.replace(program, block0=block0)))


def test_a_helix_that_leaves_a_core_rises_where_it_is() -> None:
    """A 0.375 tool in a 1.25 bore leaves a core 0.5 across: the tool goes up at the wall."""
    program = bore()
    tools = (Tool(number=1, diameter=Decimal("0.375"), rpm=3000, tcal=Decimal(0)),)
    helix = program.blocks[0]
    assert isinstance(helix, Helix)
    helix = dataclasses.replace(helix, diameter=Decimal("1.25"))
    program = dataclasses.replace(
        program, blocks=(helix,), block0=dataclasses.replace(program.block0, tools=tools)
    )
    moves = [m for m in interpret(program).moves if isinstance(m, Rapid | Feed | ArcFeed)]
    assert not any(isinstance(m, Feed) and m.tag == "lead-out" for m in moves)
    last_arc = [m for m in moves if isinstance(m, ArcFeed)][-1]
    assert moves[-1] == Rapid(1, last_arc.x, last_arc.y, round(0.15 * IN), "retract")


def test_the_cycle_time_is_the_helix_length_at_the_feed() -> None:
    """Each whole turn is sqrt((2π·0.25)² + 0.1²) in long, the three quarters
    sqrt((1.5π·0.25)² + 0.075²), the turn at the bottom 2π·0.25, the way out 0.25; at
    12 ipm, plus the rapids (0.05 + √(1.75² + 1.25²) + 0.1 + 0.775 in at 250 ipm)."""
    r = 0.25
    cut = 6 * math.hypot(2 * math.pi * r, 0.1) + math.hypot(1.5 * math.pi * r, 0.075)
    cut += 2 * math.pi * r + 0.25
    rapid = 0.05 + math.hypot(1.75, 1.25) + 0.1 + 0.775
    seconds = 60 * cut / 12 + 60 * rapid / 250
    assert estimate(interpret(bore())).per_block[1] == pytest.approx(seconds, abs=1e-6)


def helix_points_off(text: str, centre: tuple[float, float], radius: float) -> float:
    """The farthest (in) a G1 end of `text` is from the helix it stands for: off the
    circle, or off the Z the helix has after the angle turned (one turn 0.1 in down)."""
    worst = 0.0
    x, y, z = 1.75, 1.25, 0.05
    turned = 0.0
    for line in text.splitlines():
        if " G01 " not in f" {line} ":
            continue
        words = {w[0]: float(w[1:].rstrip(";")) for w in line.split()[1:] if w[0] in "XYZ"}
        nx, ny, nz = words.get("X", x), words.get("Y", y), words.get("Z", z)
        if nz >= z and (nx, ny) == (centre[0], centre[1]):
            break  # the way out to the centre
        a0 = math.atan2(y - centre[1], x - centre[0])
        a1 = math.atan2(ny - centre[1], nx - centre[0])
        turned += (a1 - a0) % (2 * math.pi)
        helix_z = max(0.05 - 0.1 * turned / (2 * math.pi), -0.625)
        worst = max(worst, abs(math.hypot(nx - centre[0], ny - centre[1]) - radius))
        worst = max(worst, abs(nz - helix_z))
        x, y, z = nx, ny, nz
    return worst


def test_the_prototrak_gets_the_helix_as_straight_moves_along_it() -> None:
    """The Plus's arcs have no Z: G01 moves whose ends are on the helix (within the
    file's 0.0001 in), each chord within 0.001 in of it, and no G02/G03 with a Z."""
    result = export(bore(), "gcode-prototrak")
    text = result.data.decode()
    assert not any(("G02" in line or "G03" in line) and " Z" in line for line in text.splitlines())
    assert helix_points_off(text, (1.5, 1.25), 0.25) <= 0.0001
    # A chord of a 0.25 circle within 0.001 in turns at most 2·acos(1 − 0.004).
    chords = sum(1 for line in text.splitlines() if " G01 " in f" {line} ")
    # 6.75 turns going down (the turn at the bottom is flat: a G03), and the way out.
    assert chords >= 6.75 * 2 * math.pi / (2 * math.acos(1 - 0.001 / 0.25)) + 1
    assert "helical arc written as" in result.report.text()


def test_linuxcnc_and_fanuc_get_one_g3_with_z_a_turn() -> None:
    linuxcnc = export(bore(), "gcode-linuxcnc").data.decode().splitlines()
    assert "G3 X1.7500 Y1.2500 Z-0.0500 I-0.2500 J0.0000 F12.0" in linuxcnc
    fanuc = export(bore(), "gcode-fanuc")
    assert "helical interpolation option" in fanuc.report.text()


def test_the_simulation_goes_down_along_the_helix() -> None:
    """Verify's sweep: one turn from Z 0 to Z -1 mm about (0, 0) at radius 5 mm, entered at
    (5, 0, 0). Halfway round the tool is half way down, not at the turn's end."""
    row = (Op.ARC_CCW, 0, 1, 5_000_000, 0, -1_000_000, 0, 0, 100_000_000, 0)
    rows = np.array([row], dtype=MOVE)
    program = Program(name="helix", units=Units.MM)
    shapes = ToolShapes.of(compile_program(program).path)
    segments, leaves = piece_segments(rows, 0, Entry(5_000_000, 0, 0, 0), shapes)
    assert not segments.arc.any()
    assert leaves == Entry(5_000_000, 0, -1_000_000, 0)
    # Each chord's end is on the circle and as far down as the angle it has turned.
    turned = np.arctan2(segments.y1, segments.x1) % (2 * math.pi)
    turned[-1] = 2 * math.pi
    assert np.hypot(segments.x1, segments.y1) == pytest.approx(5_000_000, abs=1)
    assert segments.z1 == pytest.approx(-1_000_000 * turned / (2 * math.pi), abs=1)
    assert segments.z0[1:] == pytest.approx(segments.z1[:-1])
    assert len(segments) > 4  # chords, not four flat quarter arcs


def test_a_helical_arc_going_down_into_the_collision_zone_is_in_it() -> None:
    """A zone Y below 1.1 while Z is below -0.56: an arc round (1.5, 1.25) of radius 0.25
    from 3 o'clock at Z -0.55 three quarters round to 6 o'clock (Y 1.0) at Z -0.625 gets
    there below both."""
    arc = ArcFeed(1, round(1.5 * IN), round(1.0 * IN), round(-0.625 * IN), 0, 0, False, 1)
    arc = dataclasses.replace(arc, cx=round(1.5 * IN), cy=round(1.25 * IN))
    start = (round(1.75 * IN), round(1.25 * IN), round(-0.55 * IN))
    end = (arc.x, arc.y, arc.z)
    zone = (round(1.1 * IN), round(-0.56 * IN))
    assert _enters_zone(start, end, arc, zone, 0, 0)


GCODE_HELIX = """%
G20 G90 G17
(SET-UP: T1 DIA 0.5000 LENGTH H01 = 0.0000, ITS TCAL)
T1 M6
S2000 M3
G0 X1.25 Y0
Z0.05
G3 X1.25 Y0 Z-0.05 I-0.25 J0 F10
X1.25 Y0 Z-0.2 I-0.25 J0
X1.25 Y0 I-0.25 J0
G0 Z0.2
M30
%
"""


def test_a_helix_that_is_not_a_helix_block_is_refused_naming_its_line() -> None:
    """Turns going down 0.1 then 0.15: no HELIX makes them (its pitch is one)."""
    with pytest.raises(ImportFailure) as refused:
        read_program(GCODE_HELIX.encode(), "bad", "gcode")
    assert str(refused.value).startswith("line 8")
    assert "not a MillBlocks HELIX" in str(refused.value)
    assert "do not go down the same 0.125 in each" in str(refused.value)


def test_a_helix_read_from_gcode_is_a_helix_block() -> None:
    text = GCODE_HELIX.replace("Z-0.2 I", "Z-0.15 I")
    program = read_program(text.encode(), "helix", "gcode").program
    assert program.blocks == (
        Helix(
            x=Decimal("1.000"),
            y=Decimal("0.000"),
            diameter=Decimal("1.000"),
            z_up=Decimal("0.050"),
            z_dn=Decimal("-0.150"),
            pitch=Decimal("0.100"),
            milling=MillingMode.CLIMB,
            feed_xy=Decimal("10.0"),
            tool=1,
        ),
    )
    assert parse_gcode(text, "helix").steps  # the parser keeps the helical arcs as steps


def test_verify_takes_a_helix_for_the_bore_it_makes() -> None:
    """Verify's intended part: a HELIX removes its finished DIA to Z DN, so the helical
    entry (its 16 mm tool covers the centre) gouges nothing and leaves nothing; a HELIX
    whose tool leaves a core is named for it, at the centre."""
    entry = document.loads((GOLDEN / "helix-entry-mm" / "program.json").read_text())
    assert verify(entry).findings == []
    program = document.loads((GOLDEN / "helix-bore" / "program.json").read_text())
    assert [(f.block, f.kind, f.message) for f in verify(program).findings] == [
        (
            2,
            "hole depth",
            "the HELIX hole at X 3.5000 Y 1.2500 is 0.3000 in shallower than Z DN -0.3000",
        )
    ]


def test_a_helix_of_many_turns_is_counted_before_it_is_compiled() -> None:
    """The bounded work (app.cnc.cost): a HELIX going down 2 in at 0.001 in a turn makes
    about 2 000 moves, so under a 1 000-move limit it is refused from its numbers, naming
    the block, before its turns are worked out."""
    program = bore()
    helix = program.blocks[0]
    assert isinstance(helix, Helix)
    deep = dataclasses.replace(helix, pitch=Decimal("0.001"), z_dn=Decimal("-1.95"))
    over = cost.estimate(dataclasses.replace(program, blocks=(deep,)), 1000)
    assert over.over == 1 and over.moves > 1000
