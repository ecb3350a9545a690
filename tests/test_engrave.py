"""ENGRAVE (issue 33 point 3): text in the Hershey single-stroke font along a line or an arc.

The golden cases (tests/golden/engrave-line, engrave-arc-mm) pin every target's bytes, go
through rs274 and read back as the DRILL and MILL STD blocks of their strokes.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from app.cnc import document
from app.cnc.blocks import Engrave, Program
from app.cnc.interpret import interpret
from app.cnc.operations.engrave import along_arc, along_line, glyph_strokes, missing
from app.cnc.simulate.verify import verify
from app.cnc.toolpath import Feed, Rapid

GOLDEN = Path(__file__).parent / "golden"
IN = 25_400_000
MM = 1_000_000


def golden(name: str) -> Program:
    return document.loads((GOLDEN / name / "program.json").read_text())


def test_capitals_stand_height_high_on_the_baseline() -> None:
    """The font's cap line to base line is HEIGHT: "PN" (no descenders) spans exactly 0 to
    HEIGHT across its baseline, whatever the angle the line runs at."""
    height = 0.25 * IN
    flat = [p for s in glyph_strokes("PN", height) for p in s]
    assert min(v for _, v in flat) == pytest.approx(0, abs=1e-6)
    assert max(v for _, v in flat) == pytest.approx(height, abs=1e-6)
    turned = along_line(glyph_strokes("PN", height), (0.5 * IN, 0.5 * IN), 30)
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    back = [(-(x - 0.5 * IN) * s + (y - 0.5 * IN) * c) for stroke in turned for x, y in stroke]
    assert min(back) == pytest.approx(0, abs=1) and max(back) == pytest.approx(height, abs=1)


def test_text_round_an_arc_stands_outward_clockwise_and_inward_counter_clockwise() -> None:
    """RAD 30 mm, 5 mm letters: clockwise the letters stand between 30 and 35 mm from the
    centre and the text goes clockwise from 110°; counter-clockwise between 25 and 30 mm."""
    centre = (40 * MM, 40 * MM)
    out = along_arc(glyph_strokes("TOP", 5 * MM), centre, 30 * MM, 110, clockwise=True)
    radii = [math.dist(p, centre) for s in out for p in s]
    assert min(radii) == pytest.approx(30 * MM, abs=1) and max(radii) <= 35 * MM + 1
    angles = [math.degrees(math.atan2(y - centre[1], x - centre[0])) for x, y in out[-1]]
    assert max(angles) < 110
    inward = along_arc(glyph_strokes("Base", 5 * MM), centre, 30 * MM, 250, clockwise=False)
    radii = [math.dist(p, centre) for s in inward for p in s]
    assert max(radii) == pytest.approx(30 * MM, abs=1) and min(radii) >= 25 * MM - 1


def test_each_stroke_is_cut_as_a_drill_and_its_mill_blocks_would_cut_it() -> None:
    """Across at Z UP + Z RET, down at rapid to Z UP, fed to Z DN at FEEDR Z, along the
    stroke at FEEDR XY, up to the retract height."""
    moves = [m for m in interpret(golden("engrave-line")).moves if isinstance(m, Rapid | Feed)]
    plunges = [m for m in moves if isinstance(m, Feed) and m.feed == 2 * IN]
    assert plunges and all(m.z == round(-0.01 * IN) for m in plunges)
    for k, move in enumerate(moves):
        if move in plunges:
            assert moves[k - 1] == Rapid(1, move.x, move.y, round(0.02 * IN))
            assert moves[k - 2] == Rapid(1, move.x, move.y, round(0.12 * IN))
    cuts = [m for m in moves if isinstance(m, Feed) and m.feed == 10 * IN]
    assert cuts and all(m.z == round(-0.01 * IN) for m in cuts)


def test_a_character_the_font_has_not_is_named() -> None:
    assert missing("PN-42") is None
    assert missing("PN-42°") == "°"
    assert missing("Ø12") == "Ø"


@pytest.mark.parametrize("name", ["engrave-line", "engrave-arc-mm"])
def test_verify_takes_the_strokes_for_what_the_block_removes(name: str) -> None:
    """The intended part: each stroke's swath to Z DN. Nothing gouged, nothing left."""
    program = golden(name)
    assert all(isinstance(b, Engrave) for b in program.blocks)
    result = verify(program)
    assert result.findings == []
    assert result.simulation.removed_volume() > 0
