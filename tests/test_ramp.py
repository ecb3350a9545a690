"""Ramp entry for CIRCLE/FRAME pockets (issue 33 point 3): the helical and zigzag ramps
worked out by hand from the block, and what the document and Verify make of them.

The golden cases (tests/golden/circle-pocket-helix-ramp, frame-2p-pocket-helix-ramp-mm,
frame-pocket-zigzag-ramp) pin
every target's bytes; rs274 reads their G-code with the same motion (tests/test_referee.py);
the events target and the importers refuse them naming why (test_referee,
test_import_roundtrip); the bad corpus has the errors (tests/bad/ramp-*).
"""

from __future__ import annotations

import dataclasses
import math
from decimal import Decimal
from pathlib import Path

import pytest

from app.cnc import document
from app.cnc.blocks import Circle, Entry, Hole, Program
from app.cnc.interpret import interpret
from app.cnc.problems import Severity
from app.cnc.simulate.verify import verify
from app.cnc.toolpath import ArcFeed, Feed, Rapid
from app.cnc.validate import validate

GOLDEN = Path(__file__).parent / "golden"
IN = 25_400_000  # nm per inch
MM = 1_000_000


def load(name: str) -> Program:
    return document.loads((GOLDEN / name / "program.json").read_text())


def ramps(program: Program) -> list[list[tuple[tuple[int, int, int], ArcFeed]]]:
    """Each run of helical arcs (Z changing along an arc) with the point each starts from."""
    runs: list[list[tuple[tuple[int, int, int], ArcFeed]]] = []
    here = (0, 0, 0)
    previous_helical = False
    for move in interpret(program).moves:
        if not isinstance(move, Rapid | Feed | ArcFeed):
            continue
        helical = isinstance(move, ArcFeed) and move.z != here[2]
        if helical:
            assert isinstance(move, ArcFeed)
            if not previous_helical:
                runs.append([])
            runs[-1].append((here, move))
        previous_helical = helical
        here = (move.x, move.y, move.z)
    return runs


def sweep(start: tuple[int, int, int], arc: ArcFeed) -> float:
    """The angle (radians) an arc turns from `start`: a whole turn where it ends over it."""
    a0 = math.atan2(start[1] - arc.cy, start[0] - arc.cx)
    a1 = math.atan2(arc.y - arc.cy, arc.x - arc.cx)
    turn = (a0 - a1) if arc.clockwise else (a1 - a0)
    turn %= 2 * math.pi
    return 2 * math.pi if turn < 1e-9 else turn


@pytest.mark.parametrize(
    ("name", "angle", "tool", "levels", "unit"),
    [
        # Z UP 0.1 to Z DN -0.3 in 2 pecks: -0.1, then -0.3; tool DIA 0.5 in, 3°.
        ("circle-pocket-helix-ramp", 3, 0.5 * IN, [-0.1 * IN, -0.3 * IN], IN),
        # Z UP 2 to Z DN -8 + 0.13 (2P) in 2 pecks: -2.935, then -7.87; DIA 12 mm, 5°.
        ("frame-2p-pocket-helix-ramp-mm", 5, 12 * MM, [-2.935 * MM, -7.87 * MM], MM),
    ],
)
def test_the_ramp_goes_down_tan_angle_per_length_on_a_circle_half_the_tool_across(
    name: str, angle: int, tool: float, levels: list[float], unit: int
) -> None:
    """Each level's way down is a helix of radius DIA/4 about one centre, falling
    tan(angle) per unit of its length (to 0.0001 in), and it ends at the level over the
    point where the lead-in arc starts (the point a plunge went down at)."""
    program = load(name)
    runs = ramps(program)
    assert len(runs) == len(levels)
    moves = [m for m in interpret(program).moves if isinstance(m, Rapid | Feed | ArcFeed)]
    for run, level in zip(runs, levels, strict=True):
        centre = (run[0][1].cx, run[0][1].cy)
        length = 0.0
        for start, arc in run:
            assert (arc.cx, arc.cy) == centre
            radius = math.dist(start[:2], centre)
            assert radius == pytest.approx(tool / 4, abs=2)
            assert math.dist((arc.x, arc.y), centre) == pytest.approx(tool / 4, abs=2)
            length += radius * sweep(start, arc)
        top, last = run[0][0][2], run[-1][1]
        assert last.z == round(level)
        drop = top - last.z
        assert abs(drop - length * math.tan(math.radians(angle))) <= 0.0001 * IN
        # Then the lead-in: an arc from the ramp's end, the first move at the level.
        after = moves[moves.index(last) + 1]
        assert isinstance(after, ArcFeed) and after.z == last.z and after.tag == "lead-in"


def test_the_circle_ramp_stays_inside_the_pocket_and_verify_finds_nothing() -> None:
    """A ramp removes material inside the pocket only: every ramp position of the 0.5 in
    tool is within 1.25 in of the pocket's centre (2, 2) less the tool's radius, and
    Verify reports no gouge."""
    program = load("circle-pocket-helix-ramp")
    for run in ramps(program):
        for _, arc in run:
            centre = (arc.cx, arc.cy)
            # The farthest point of the ramp's circle from the pocket centre.
            far = math.dist(centre, (2 * IN, 2 * IN)) + math.dist((arc.x, arc.y), centre)
            assert far <= (1.25 - 0.25) * IN + 2
    assert verify(program).findings == []
    # The 2P frame in mm too: its ramps stay inside the roughing pass.
    assert verify(load("frame-2p-pocket-helix-ramp-mm")).findings == []


def test_a_plunging_pocket_is_unchanged_by_the_new_fields() -> None:
    """ENTRY empty is the plunge: the same moves as before, and the document writes
    neither field (every existing golden stays byte-identical: tests/test_golden.py)."""
    ramped = load("circle-pocket-helix-ramp")
    circle = ramped.blocks[1]
    assert isinstance(circle, Circle) and circle.entry is Entry.HELIX
    assert circle.ramp_angle == Decimal(3)
    plunging = dataclasses.replace(
        ramped,
        blocks=(ramped.blocks[0], dataclasses.replace(circle, entry=None, ramp_angle=None)),
    )
    text = document.dumps(plunging)
    assert '"entry"' not in text and '"ramp_angle"' not in text
    assert ramps(plunging) == []
    back = document.loads(document.dumps(ramped))
    assert back.blocks[1] == circle
    # null reads as empty: the plunge.
    assert document.loads(text.replace('"tool": 2\n', '"tool": 2, "entry": null\n')) == plunging


def test_the_default_angle_is_three_degrees() -> None:
    """RAMP ANGLE empty: 3°, the same ramp as RAMP ANGLE 3."""
    stated = load("circle-pocket-helix-ramp")
    circle = stated.blocks[1]
    assert isinstance(circle, Circle)
    empty = dataclasses.replace(
        stated, blocks=(stated.blocks[0], dataclasses.replace(circle, ramp_angle=None))
    )
    assert [e for e in validate(empty) if e.severity is Severity.ERROR] == []
    assert interpret(empty).moves == interpret(stated).moves


def test_the_bounded_work_estimate_counts_the_ramps_turns() -> None:
    """A 0.062 in tool ramping at 0.5° down 2 in turns 2π × 0.0155 × tan 0.5° = 0.000850 in
    a turn: about 2 353 rows, which the estimate (app/cnc/cost.py) must not count fewer
    of than the compile makes, so such a ramp is weighed before it is compiled."""
    from app.cnc import cost
    from app.cnc.compiler import Cache, compile_program

    golden = load("circle-pocket-helix-ramp")
    drill, circle = golden.blocks
    assert isinstance(drill, Hole) and isinstance(circle, Circle)
    tool = dataclasses.replace(golden.block0.tools[0], diameter=Decimal("0.062"))
    program = dataclasses.replace(
        golden,
        block0=dataclasses.replace(golden.block0, tools=(tool, *golden.block0.tools[1:])),
        blocks=(
            dataclasses.replace(drill, z_up=Decimal("0.1"), z_dn=Decimal("-1.9")),
            dataclasses.replace(circle, radius=Decimal("0.2"), ramp_angle=Decimal("0.5")),
        ),
    )
    assert [e for e in validate(program) if e.severity is Severity.ERROR] == []
    rows = len(compile_program(program, Cache()).path)
    assert rows > 2_353
    assert rows <= cost.estimate(program).moves


def zigzags(program: Program) -> list[list[tuple[tuple[int, int, int], Feed]]]:
    """Each run of straight feeds that move Z with X or Y, with the point each starts from."""
    runs: list[list[tuple[tuple[int, int, int], Feed]]] = []
    here = (0, 0, 0)
    previous = False
    for move in interpret(program).moves:
        if not isinstance(move, Rapid | Feed | ArcFeed):
            continue
        ramping = isinstance(move, Feed) and move.z != here[2] and (move.x, move.y) != here[:2]
        if ramping:
            assert isinstance(move, Feed)
            if not previous:
                runs.append([])
            runs[-1].append((here, move))
        previous = ramping
        here = (move.x, move.y, move.z)
    return runs


def test_the_zigzag_goes_back_and_forth_on_a_straight_the_tool_across_at_tan_angle() -> None:
    """FRAME 3 x 2 in at (2, 2), corner 0.25, tool DIA 0.5 in, ENTRY ZIGZAG at 2°, Z UP 0.1
    to Z DN -0.25 in 2 pecks (-0.075, then -0.25). The first pass enters at (3.375, 2.375)
    (its lead-in arc's start, 0.125 in over the wall pass at Y 2.25): each level's way down
    goes back and forth between there and 0.5 in straight in, (3.375, 2.875), falling
    tan 2° per unit of its length (to 0.0001 in), and ends at the level over the entry point,
    where the lead-in arc starts. Verify finds nothing."""
    program = load("frame-pocket-zigzag-ramp")
    entry, far = (3.375 * IN, 2.375 * IN), (3.375 * IN, 2.875 * IN)
    runs = zigzags(program)
    assert len(runs) == 2
    moves = [m for m in interpret(program).moves if isinstance(m, Rapid | Feed | ArcFeed)]
    for run, level in zip(runs, [-0.075 * IN, -0.25 * IN], strict=True):
        length = 0.0
        for start, leg in run:
            assert start[0] == leg.x == round(entry[0])  # along the straight
            assert entry[1] - 1 <= leg.y <= far[1] + 1 and entry[1] - 1 <= start[1] <= far[1] + 1
            length += math.dist(start[:2], (leg.x, leg.y))
        # Whole legs are the tool's DIA, turning at the straight's ends.
        assert [round(leg.y) for _, leg in run[1:]] == [
            round(far[1] if k % 2 == len(run) % 2 else entry[1]) for k in range(1, len(run))
        ]
        top, last = run[0][0][2], run[-1][1]
        assert (last.x, last.y, last.z) == (round(entry[0]), round(entry[1]), round(level))
        assert abs(top - last.z - length * math.tan(math.radians(2))) <= 0.0001 * IN
        after = moves[moves.index(last) + 1]
        assert isinstance(after, ArcFeed) and after.z == last.z and after.tag == "lead-in"
    assert verify(program).findings == []


def test_ramp_angle_is_asked_for_and_copied_with_either_ramp() -> None:
    """RAMP ANGLE applies with ENTRY HELIX or ZIGZAG (a COPY keeps a zigzag's angle), and
    not with the plunge."""
    from app.cnc.blocks import Frame
    from app.cnc.kinds import REGISTRY

    frame = load("frame-pocket-zigzag-ramp").blocks[1]
    assert isinstance(frame, Frame)
    field = next(f for f in REGISTRY.fields(Frame) if f.name == "ramp_angle")
    values = {"placement": frame.placement}
    for entry, applies in ((Entry.ZIGZAG, True), (Entry.HELIX, True), (None, False)):
        assert REGISTRY.applies(Frame, field, {**values, "entry": entry}) is applies


def test_the_bounded_work_estimate_counts_the_zigzags_legs() -> None:
    """A 0.062 in tool zigzagging at 0.5° down 2 in goes 0.062 × tan 0.5° = 0.000541 in down
    a leg: about 3 696 rows, which the estimate must not count fewer of than the compile
    makes (a helix's turn is π/2 times as long: counted as turns, it fell short)."""
    from app.cnc import cost
    from app.cnc.compiler import Cache, compile_program

    golden = load("circle-pocket-helix-ramp")
    drill, circle = golden.blocks
    assert isinstance(drill, Hole) and isinstance(circle, Circle)
    tool = dataclasses.replace(golden.block0.tools[0], diameter=Decimal("0.062"))
    program = dataclasses.replace(
        golden,
        block0=dataclasses.replace(golden.block0, tools=(tool, *golden.block0.tools[1:])),
        blocks=(
            dataclasses.replace(drill, z_up=Decimal("0.1"), z_dn=Decimal("-1.9")),
            dataclasses.replace(
                circle, radius=Decimal("0.2"), entry=Entry.ZIGZAG, ramp_angle=Decimal("0.5")
            ),
        ),
    )
    assert [e for e in validate(program) if e.severity is Severity.ERROR] == []
    rows = len(compile_program(program, Cache()).path)
    assert rows > 3_696
    assert rows <= cost.estimate(program).moves
