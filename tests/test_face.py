"""FACE (issue 33 point 3): the passes worked out by hand from the rectangle and the tool.

The golden cases (tests/golden/face-zigzag, face-one-way-mm) pin every target's bytes and go
through rs274 (tests/test_referee.py).
"""

from __future__ import annotations

from decimal import Decimal
from pathlib import Path

import pytest

from app.cnc import document
from app.cnc.blocks import Face, FacePattern, Program
from app.cnc.formats.reading import read_program
from app.cnc.interpret import interpret
from app.cnc.recognition.common import ImportFailure
from app.cnc.simulate.verify import verify
from app.cnc.toolpath import Feed, Rapid

GOLDEN = Path(__file__).parent / "golden"
IN = 25_400_000
MM = 1_000_000


def golden(name: str) -> Program:
    return document.loads((GOLDEN / name / "program.json").read_text())


def cuts(program: Program) -> list[Feed]:
    return [m for m in interpret(program).moves if isinstance(m, Feed) and m.tag == ""]


def test_zigzag_rows_cover_the_plate_and_run_off_its_ends() -> None:
    """4 × 2.5 in centred on (2, 1.25), a 1 in tool, 70 %, CLEAR 0.05 in: passes from
    X -0.55 to 4.55 (the tool's edge 0.05 off each end); rows from Y 0.45 to 2.05 (its edge
    0.05 past each long edge), 1.6 apart in at most 0.7 steps: 4 rows 0.5333 apart; two
    levels, Z -0.025 and -0.05; back and forth."""
    ends = [(m.x, m.y, m.z) for m in cuts(golden("face-zigzag"))]
    rows = [round(IN * (0.45 + 1.6 * k / 3)) for k in range(4)]
    xs = [round(4.55 * IN), round(-0.55 * IN)] * 2
    for level in (-0.025, -0.05):
        for k, y in enumerate(rows):
            assert (xs[k], y, round(level * IN)) in ends
    assert len(ends) == 8
    steps = [m for m in interpret(golden("face-zigzag")).moves if isinstance(m, Feed)]
    assert all(m.x in (round(4.55 * IN), round(-0.55 * IN)) for m in steps if m.tag)


def test_one_way_goes_up_and_back_between_passes() -> None:
    """80 × 50 mm, a 25 mm tool, 60 % (15 mm), CLEAR 3: every pass from X -15.5 to 95.5,
    rows from Y 9.5 to 40.5 (31 apart: 4 rows); up to Z RET and back at rapid between."""
    program = golden("face-one-way-mm")
    ends = [(m.x, m.y, m.z) for m in cuts(program)]
    rows = [round(MM * (9.5 + 31 * k / 3)) for k in range(4)]
    assert ends == [(95_500_000, y, -MM) for y in rows]
    moves = interpret(program).moves
    rapids_up = [m for m in moves if isinstance(m, Rapid) and m.tag == "retract"]
    assert len(rapids_up) == 4


@pytest.mark.parametrize("name", ["face-zigzag", "face-one-way-mm"])
def test_verify_finds_the_plate_faced_and_nothing_else(name: str) -> None:
    """A FACE means to remove what its tool sweeps: the plate's top (4 × 2.5 × 0.05 in;
    80 × 50 × 1 mm) comes off, no gouge, nothing left, no crash beside the stock."""
    result = verify(golden(name))
    assert result.findings == []
    volume = 4 * 2.5 * 0.05 * IN**3 if name == "face-zigzag" else 80 * 50 * 1 * MM**3
    assert result.simulation.removed_volume() == pytest.approx(volume, rel=1e-3)


def gcode(name: str) -> str:
    return (GOLDEN / name / "expected.gcode-linuxcnc").read_text()


def test_our_zigzag_gcode_reads_back_as_its_face_block() -> None:
    """The rows of face-zigzag's G-code are what its FACE cuts: the import is that block
    (CLEAR empty, as it was), not a refusal."""
    program = read_program(gcode("face-zigzag").encode(), "face", "gcode").program
    assert program.blocks == (
        Face(
            pattern=FacePattern.ZIGZAG,
            x=Decimal("2.000"),
            y=Decimal("1.250"),
            xl=Decimal("4.000"),
            yw=Decimal("2.500"),
            z_up=Decimal("0.000"),
            z_dn=Decimal("-0.050"),
            passes=2,
            step=70,
            clear=None,
            feed_xy=Decimal("30.0"),
            tool=1,
        ),
    )


def test_one_way_gcode_reads_back_as_a_face_cutting_the_same_rows() -> None:
    """The file cannot tell CLEAR 3 mm from the rectangle 3.46 mm bigger with CLEAR empty:
    it comes back so, one-way, cutting the very rows the file does."""
    program = read_program(gcode("face-one-way-mm").encode(), "face", "gcode").program
    (block,) = program.blocks
    assert isinstance(block, Face)
    assert block.pattern is FacePattern.ONE_WAY and block.clear is None
    assert (block.xl, block.yw, block.passes) == (Decimal("83.46"), Decimal("53.46"), 1)
    assert [(m.x, m.y, m.z) for m in cuts(program)] == [
        (m.x, m.y, m.z) for m in cuts(golden("face-one-way-mm"))
    ]


def test_a_face_with_one_row_moved_is_refused_at_that_row() -> None:
    """The zig-zag's second row moved up 0.05 in: no FACE's evenly spaced rows are there,
    and the refusal names the line of the step-over that put it there."""
    lines = gcode("face-zigzag").splitlines()
    at = lines.index("Y0.9833")
    lines[at] = "Y1.0333"
    with pytest.raises(ImportFailure) as refused:
        read_program("\n".join(lines).encode(), "bad", "gcode")
    message = str(refused.value)
    assert message.startswith(f"line {at + 1}:")
    assert "not a MillBlocks FACE" in message
    assert "Y1.0333 in is not where a FACE's evenly spaced rows put it (Y0.9833 in" in message
