"""THREAD MILL (issue 33 point 3): the passes worked out by hand from the thread's numbers.

The golden cases (tests/golden/thread-mill-internal, thread-mill-external-mm) pin every
target's bytes and go through rs274 (tests/test_referee.py).
"""

from __future__ import annotations

import dataclasses
import math
from decimal import Decimal
from pathlib import Path

import pytest

from app.cnc import document
from app.cnc.blocks import Block, MillingMode, Program, ThreadMill
from app.cnc.formats.reading import read_program
from app.cnc.formats.targets import export
from app.cnc.interpret import interpret
from app.cnc.recognition.common import ImportFailure
from app.cnc.toolpath import ArcFeed, Rapid
from app.cnc.tools import Hand

GOLDEN = Path(__file__).parent / "golden"
IN = 25_400_000
MM = 1_000_000


def golden(name: str) -> Program:
    return document.loads((GOLDEN / name / "program.json").read_text())


def one_thread(name: str, **changes: object) -> Program:
    """The golden case's first THREAD MILL alone (its DRILLs before it kept), changed."""
    program = golden(name)
    blocks: list[Block] = []
    for block in program.blocks:
        if isinstance(block, ThreadMill):
            blocks.append(dataclasses.replace(block, **changes))  # type: ignore[arg-type]
            break
        blocks.append(block)
    return dataclasses.replace(program, blocks=tuple(blocks))


def thread_arcs(program: Program) -> list[tuple[ArcFeed, tuple[int, int, int]]]:
    """The THREAD MILL's arcs, each with where it starts."""
    number = len(program.blocks)
    found = []
    x, y, z = interpret(program).start
    for move in interpret(program).moves:
        if isinstance(move, Rapid | ArcFeed) or hasattr(move, "feed"):
            start = (x, y, z)
            x, y, z = move.x, move.y, move.z  # type: ignore[union-attr]
            if isinstance(move, ArcFeed) and move.block == number:
                found.append((move, start))
    return found


def test_a_right_hand_internal_thread_cut_climb_goes_up_counter_clockwise() -> None:
    """1/2-13 UNC inside, a 0.300 in thread mill, two passes: lead 1/13 in, depth 5/8 H =
    5/8 × √3/2 / 13 = 0.041634 in; the tool's centre goes round at 0.25 − 0.15 = 0.1 in
    on the last pass and 0.020817 in less on the first. Climb inside with a clockwise
    spindle is counter-clockwise (G3), which on a right-hand thread rises: bottom-up, from
    Z DN -0.5 to Z UP 0, the lead-in and lead-out a quarter lead each."""
    arcs = thread_arcs(one_thread("thread-mill-internal"))
    lead = IN / 13
    depth = 5 / 8 * math.sqrt(3) / 2 * lead
    assert not any(a.clockwise for a, _ in arcs)
    turns = [(a, s) for a, s in arcs if a.tag == ""]
    radii = sorted({round(math.dist((a.x, a.y), (a.cx, a.cy))) for a, _ in turns})
    assert radii == pytest.approx([0.1 * IN - depth / 2, 0.1 * IN], abs=1)
    for arc, start in turns:
        assert arc.z > start[2]  # up
        assert (arc.cx, arc.cy) == (IN, IN)
    # Between the lead-in and lead-out: 0.5 in less two quarter leads (488 461 nm each) is
    # 11 723 078 nm, six turns of 1 953 846 nm and 2 nm, which the sixth takes.
    whole = [a.z - s[2] for a, s in turns if (a.x, a.y) == s[:2]]
    assert whole == ([round(lead)] * 5 + [round(lead) + 2]) * 2
    lead_in = [(a, s) for a, s in arcs if a.tag == "lead-in"]
    assert [s[2] for _, s in lead_in] == [round(-0.5 * IN)] * 2
    assert [a.z for a, _ in lead_in] == [round(-0.5 * IN) + round(lead) // 4] * 2
    lead_out = [a for a, _ in arcs if a.tag == "lead-out"]
    assert [(a.x, a.y, a.z) for a in lead_out] == [(IN, IN, 0)] * 2


def test_the_hand_and_conventional_each_turn_it_round() -> None:
    """Conventional inside goes clockwise (G2), down on a right-hand thread; a left-hand
    thread cut climb (G3) goes down too; left-hand and conventional (G2) goes up."""
    cases = [
        (MillingMode.CONVENTIONAL, Hand.RIGHT, True, False),
        (MillingMode.CLIMB, Hand.LEFT, False, False),
        (MillingMode.CONVENTIONAL, Hand.LEFT, True, True),
    ]
    for milling, hand, clockwise, up in cases:
        program = one_thread("thread-mill-internal", milling=milling, hand=hand)
        turns = [(a, s) for a, s in thread_arcs(program) if a.tag == ""]
        assert {a.clockwise for a, _ in turns} == {clockwise}, (milling, hand)
        assert all((a.z > s[2]) == up for a, s in turns), (milling, hand)


def test_an_external_thread_goes_in_from_outside_its_major_diameter() -> None:
    """M20x1.5 outside, a 10 mm tool, three passes: depth 17/24 H = 0.920 mm; the last pass
    goes round at 10 − 0.920 + 5 = 14.080 mm. Climb outside is clockwise (G2), which on a
    right-hand thread goes down: top-down from Z 0 to Z -12. The tool comes down 1.27 mm
    (0.050 in) outside the major diameter and enters along a half circle the other way
    round (G3), tangent at 3 o'clock."""
    program = golden("thread-mill-external-mm")
    depth = 17 / 24 * math.sqrt(3) / 2 * 1.5 * MM
    arcs = thread_arcs(program)
    turns = [(a, s) for a, s in arcs if a.tag == ""]
    assert {a.clockwise for a, _ in turns} == {True}
    assert all(a.z < s[2] for a, s in turns)
    radii = sorted({round(math.dist((a.x, a.y), (a.cx, a.cy))) for a, _ in turns})
    last = 10 * MM - depth + 5 * MM
    assert radii == pytest.approx([last, last + depth / 3, last + 2 * depth / 3], abs=1)
    rapids = [m for m in interpret(program).moves if isinstance(m, Rapid) and m.z == 0]
    assert {m.x - 30 * MM for m in rapids} == {round(10 * MM + 5 * MM + 1.27 * MM)}
    lead_in = [a for a, _ in arcs if a.tag == "lead-in"]
    assert all(not a.clockwise for a in lead_in)


def test_linuxcnc_writes_each_turn_as_a_g3_with_z() -> None:
    text = export(one_thread("thread-mill-internal"), "gcode-linuxcnc").data.decode()
    assert "G3 X1.0792 Y1.0000 Z-0.4808 I0.0396 J0.0000 F8.0" in text.splitlines()
    assert "X1.0792 Y1.0000 Z-0.4038 I-0.0792 J0.0000" in text.splitlines()


def test_our_thread_mill_gcode_reads_back_as_its_block() -> None:
    """The passes our G-code writes (lead-in, turns, lead-out) are the THREAD MILL's: the
    import is that block, its TPI, hand, climb and passes found from the arcs."""
    program = one_thread("thread-mill-internal")
    data = export(program, "gcode-linuxcnc").data
    assert read_program(data, "thread", "gcode").program.blocks == program.blocks


def test_an_external_thread_reads_back_as_its_block() -> None:
    program = golden("thread-mill-external-mm")
    data = export(program, "gcode-linuxcnc").data
    assert read_program(data, "thread", "gcode").program.blocks == program.blocks


def test_a_thread_with_one_turn_moved_is_refused_at_that_line() -> None:
    """One turn of the external thread's first pass ends 0.1 mm low: no THREAD MILL cuts
    that, and the refusal names its line and where the turn would end."""
    lines = export(golden("thread-mill-external-mm"), "gcode-linuxcnc").data.decode()
    text = lines.splitlines()
    at = text.index("X44.693 Y25.000 Z-6.375 I-14.693 J0.000")
    text[at] = "X44.693 Y25.000 Z-6.475 I-14.693 J0.000"
    with pytest.raises(ImportFailure) as refused:
        read_program("\n".join(text).encode(), "bad", "gcode")
    message = str(refused.value)
    assert message.startswith(f"line {at + 1}:")
    assert "not a MillBlocks THREAD MILL" in message
    assert "(to X44.693 mm Y25 mm Z-6.375 mm)" in message


def test_a_thread_leaves_no_arc_that_a_file_writes_as_a_whole_circle() -> None:
    """6 turns of 1/13 in from -0.4808 to -0.0192 in leave a part of a turn of a few nm:
    written, its end would round onto its start, a whole circle at the control. The last
    whole turn takes it instead: no arc ends within 0.001 in of where it starts but a
    whole turn's end, exactly there."""
    for arc, start in thread_arcs(one_thread("thread-mill-internal")):
        gap = math.dist((arc.x, arc.y), start[:2])
        assert gap == 0 or gap > 25_400, arc


def test_thread_pitch_is_threads_per_inch_or_mm() -> None:
    program = one_thread("thread-mill-internal", pitch=Decimal(20))
    turns = [(a, s) for a, s in thread_arcs(program) if a.tag == "" and (a.x, a.y) == s[:2]]
    assert {a.z - s[2] for a, s in turns} == {IN // 20}
