"""Reports that do not repeat themselves (issue 31 goal 4, issue 33's 680 kB tape report).

A note that recurs with its own details at each place — a bolt circle a CAM grid drills
28 606 times, a tape warning on every chord of a helical ramp — is one line of the report:
the first place's note, how many places in all (exact), and the next few places by name
(app.cnc.places). The import report and the export's compatibility report both do it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from app.cnc.compiler import compile_program
from app.cnc.formats.reading import read_program
from app.cnc.formats.targets import Report, export
from app.cnc.path import Op
from app.cnc.places import PLACES
from tests.test_golden import load

GOLDEN = Path(__file__).parent / "golden"


def test_a_recurring_entry_is_one_line_with_its_exact_count_and_first_places() -> None:
    """20 reports at 19 tape blocks (the fourth twice): one line, 20 in all, the first
    place's own message, the next eight places named and the other ten counted."""
    report = Report("tape-eia")
    places = [f"N{n}" for n in (1, 2, 3, 4, 4, *range(5, 20))]
    for n, place in enumerate(places):
        report.warning(2, f"{place} moves {n} in", same="the same limitation", at=place)
    report.note(None, "tape length 1 ft")
    assert report.text() == (
        "Compatibility report for tape-eia:\n"
        "  warning: block 2: N1 moves 0 in (the same limitation: 20 in all; also at N2, N3, "
        "N4, N5, N6, N7, N8, N9 and 10 more)\n"
        "  note: program: tape length 1 ft\n"
    )
    [entry, _] = report.entries
    assert (entry.count, len(entry.places), entry.more) == (20, PLACES, 10)


def test_a_stage_report_merged_keeps_its_count_and_places() -> None:
    """The tape writer's stages report on their own and are merged into the export's
    report: the counts add up, the places are named in the order reported."""
    first, second, merged = Report("plan"), Report("reader"), Report("tape-eia")
    for block in (1, 2):
        first.rewritten(block, f"arc {block}", same="arcs written as chords")
    for block in (3, 3, 4):
        second.rewritten(block, f"arc {block}", same="arcs written as chords")
    second.warning(4, "once")
    merged.merge(first)
    merged.merge(second)
    assert [str(e) for e in merged.entries] == [
        "rewritten: block 1: arc 1 (arcs written as chords: 5 in all; also at block 2, "
        "block 3, block 4)",
        "warning: block 4: once",
    ]
    assert not merged.has_errors


def test_the_helical_ramp_pockets_tape_report_is_a_readable_size() -> None:
    """pocket-islands-helix-ramp to tape-eia: 108 helical arcs become chords and 3 578
    short chords outrun the tape reader (seed 000 §3). The report said each on its own
    line, 680 kB; it says each once with its count (the arcs counted from the compiled
    path: the arcs that climb)."""
    program = load(GOLDEN / "pocket-islands-helix-ramp")
    rows = np.concatenate([chunk.rows for chunk in compile_program(program).path.chunks()])
    arcs = (rows["op"] == Op.ARC_CW) | (rows["op"] == Op.ARC_CCW)
    climbs = rows["z"] != np.concatenate([rows["z"][:1], rows["z"][:-1]])
    helical = int((arcs & climbs).sum())
    text = export(program, "tape-eia").report.text()
    assert len(text) < 4_000, f"{len(text)} characters"
    assert f"(arcs written as chords: {helical} in all)" in text
    assert (
        "warning: block 2: reader limitation: N4G01X19728Y6747Z994F120 moves 0.0112 in in "
        "0.056 s but the next block (18 characters) takes 0.067 s to read: the slides may "
        "stop and dwell (seed 000 §3) (the same reader limitation: 3578 in all; also at "
        "N5X19650Y6667Z988, N6X19587Y6574Z982, N7X19541Y6472Z976, N8X19515Y6363Z971, "
        "N9X19508Y6251Z965, N10X19521Y6140Z959, N11X19555Y6033Z953, N12X19606Y5933Z947 "
        "and 3569 more)"
    ) in text


def _circles(count: int) -> str:
    """G-code drilling `count` bolt circles of 6 holes, each of its own radius (so that
    no LOOP joins them), 3 in apart along X."""
    lines = ["G20 G90", "T1 M6", "S1000 M3", "G0 X0 Y0 Z0.1"]
    for k in range(count):
        radius = 0.5 + k / 10
        for h in range(6):
            angle = np.radians(60 * h)
            x = 3 * k + radius * np.sin(angle)
            y = -radius * np.cos(angle)
            lines += [f"G0 X{x:.4f} Y{y:.4f}", "G1 Z-0.1 F5", "G0 Z0.1"]
    return "\n".join([*lines, "M30", ""])


def test_bolt_circles_are_one_note_with_their_count_and_first_lines() -> None:
    """12 bolt circles: one BOLT CIR note, the first circle's in full, 12 in all, the next
    eight circles' first lines named and three more counted (each circle 18 lines on from
    the last)."""
    result = read_program(_circles(12).encode(), "part", "gcode")
    circles = [b for b in result.program.blocks if b.type_name == "BOLT CIR DRILL"]
    assert len(circles) == 12
    notes = [str(n) for n in result.report if "equally spaced" in n.message]
    starts = ", ".join(str(5 + 18 * k) for k in range(1, 9))
    assert notes == [
        "became: line 5: lines 5-21: 6 holes equally spaced on a circle: BOLT CIR about "
        "X0 in Y0 in, radius 0.5 in, first hole at 0.00° (clockwise from below) (holes on "
        f"a circle read as BOLT CIR: 12 in all; also lines {starts} and 3 more)"
    ]
    assert [n.count for n in result.report if "equally spaced" in n.message] == [12]
