"""G-code targets: what each dialect writes and each option changes.

LinuxCNC's own interpreter (`rs274` from linuxcnc-uspace) referees every dialect over the
golden corpus and generated programs in tests/test_referee.py.
"""

from __future__ import annotations

import re
from decimal import Decimal
from pathlib import Path

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from app.cnc import document
from app.cnc.blocks import (
    DataBlock0,
    Hole,
    HoleOp,
    Pocket,
    PocketLine,
    Program,
    Tool,
)
from app.cnc.compiler import compile_program
from app.cnc.copy import resolve_copies
from app.cnc.formats.gcode.writer import BULK_ROWS, Writer
from app.cnc.formats.targets import Report, Severity, export, get_target
from app.cnc.problems import has_errors
from app.cnc.validate import validate
from tests.strategies import programs

GOLDEN = Path(__file__).parent / "golden"


def load(case: Path) -> Program:
    return resolve_copies(document.loads((case / "program.json").read_text(encoding="utf-8")))


def test_drill_without_pecks_is_g82_from_the_retract_height() -> None:
    """DESIGN.md §4: a DRILL without pecks is `G98 G82 R<Z UP> Z<Z DN> P0.8` on LinuxCNC."""
    text = export(load(GOLDEN / "drill-single"), "gcode-linuxcnc").data.decode()
    assert "G98 G82 X1.0000 Y1.0000 R0.1000 Z-0.5000 P0.8 F5.0" in text
    bore = export(load(GOLDEN / "bore"), "gcode-linuxcnc").data.decode()
    assert "G89" not in bore and "G85" not in bore  # they feed out past Z UP


def test_bolt_circle_holes_share_one_cycle() -> None:
    text = export(load(GOLDEN / "bolt-circle-250"), "gcode-linuxcnc").data.decode()
    assert text.count("G82") == 1
    assert text.splitlines().count("G80") == 1


def test_pecks_are_explicit_unless_g83_is_accepted() -> None:
    program = load(GOLDEN / "drill-12-pecks")
    explicit = export(program, "gcode-linuxcnc")
    assert "G83" not in explicit.data.decode()
    accepted = export(program, "gcode-linuxcnc", {"peck_cycle": "G83"})
    assert "G98 G83 X2.0000 Y1.5000 R0.0500 Z-1.1500 Q0.1000 F4.5" in accepted.data.decode()
    assert any(e.severity is Severity.REWRITTEN for e in accepted.report.entries)


def test_tap_is_explicit_with_spindle_reversal() -> None:
    text = export(load(GOLDEN / "tap-inch"), "gcode-linuxcnc").data.decode()
    lines = text.splitlines()
    down = lines.index("G1 Z-0.5000 F12.5")
    assert lines[down + 1 : down + 4] == ["S400 M3", "Z0.4000", "S400 M4"]


def test_prototrak_dialect_rules() -> None:
    """Seed 003 §2.1: a G code on every motion line, spaces between words, `;` at the end."""
    text = export(load(GOLDEN / "contour-cut-right"), "gcode-prototrak").data.decode()
    blocks = text.splitlines()[1:-1]
    assert all(line.endswith(";") for line in blocks)
    # G28 (the start's retract) is written as seed 003 §2.2.6.2 N12 writes it: `G28 Z…`.
    motion = [
        b
        for b in blocks
        if re.search(r"\b[XYZ]-?\d", b) and not b.startswith("(") and "G28" not in b
    ]
    assert motion and all(re.search(r"\bG0[0-3]\b", b) for b in motion)
    assert all("  " not in b and re.match(r"^(N\d+ |\()", b) for b in blocks)


def test_fanuc_program_number_and_no_spaces() -> None:
    text = export(load(GOLDEN / "bolt-circle-drill"), "gcode-fanuc").data.decode()
    lines = text.splitlines()
    assert lines[0] == "%" and lines[1] == "O4711" and lines[-1] == "%"
    assert all(" " not in line for line in lines if line.startswith("N"))


def test_set_up_offsets_reach_linuxcnc_only_when_asked() -> None:
    """Data Block 0 X 4.5 Y 3.25 and tool 1's TCAL are set-up comments; with
    write-offsets=yes they become G54 through G10 L2 and a G10 L1 length."""
    program = load(GOLDEN / "bolt-circle-drill")
    plain = export(program, "gcode-linuxcnc").data.decode()
    assert "G10" not in plain and "(SET-UP: G54 = PART ZERO AT TABLE X4.5000 Y3.2500)" in plain
    path_text = export(program, "gcode-linuxcnc", {"write-offsets": "yes"}).data.decode()
    assert "G10 L2 P1 X4.5000 Y3.2500 Z0" in path_text
    assert "G10 L1 P1 Z0.0000 R0.1250" in path_text


def test_options_change_the_output() -> None:
    program = load(GOLDEN / "stop-and-tool-changes")
    text = export(
        program,
        "gcode-linuxcnc",
        {"sequence_numbers": "yes", "sequence_start": "100", "sequence_increment": "5"},
    ).data.decode()
    numbered = [line for line in text.splitlines() if line.startswith("N")]
    assert numbered[0].startswith("N100 ") and numbered[1].startswith("N105 ")
    deleted = export(program, "gcode-linuxcnc", {"block_delete": "yes", "end_code": "M02"})
    assert "/M0 (STOP)" in deleted.data.decode() and "M02" in deleted.data.decode()
    kept = export(program, "gcode-fanuc", {"trailing_zeros": "keep"}).data.decode()
    assert "X1.0000" in kept


def test_index_without_an_m_code_is_reported() -> None:
    program = load(GOLDEN / "pos-index")
    lost = export(program, "gcode-linuxcnc")
    assert [str(e) for e in lost.report.entries if e.severity is Severity.LOST] == [
        "lost: block 1: INDEX: no M code for the rotary table (set index-code)",
        "lost: block 2: INDEX: no M code for the rotary table (set index-code)",
    ]
    indexed = export(program, "gcode-linuxcnc", {"index_code": "60"})
    assert indexed.data.decode().count("M60 (INDEX)") == 2


@pytest.mark.parametrize("target", ["gcode-linuxcnc", "gcode-fanuc", "gcode-prototrak"])
def test_a_line_break_in_the_name_cannot_put_code_on_the_tape(target: str) -> None:
    import dataclasses

    program = load(GOLDEN / "drill-single")
    hostile = dataclasses.replace(program, name="Bracket\nG0 Z-5\r\nM3")
    text = export(hostile, target).data.decode()
    plain = export(program, target).data.decode()
    assert "(BRACKET G0 Z-5  M3 " in text
    assert len(text.splitlines()) == len(plain.splitlines())
    assert not any(line.strip().startswith("G0 Z-5") for line in text.splitlines())


GCODE_OPTIONS = st.fixed_dictionaries(
    {
        "sequence-numbers": st.sampled_from(["yes", "no"]),
        "sequence-increment": st.sampled_from(["1", "10"]),
        "trailing-zeros": st.sampled_from(["keep", "drop"]),
        "tabs": st.sampled_from(["yes", "no"]),
        "peck-cycle": st.sampled_from(["explicit", "G83"]),
        "spindle-speeds": st.just("by-hand"),
    }
)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    programs(),
    st.sampled_from(["gcode-linuxcnc", "gcode-fanuc", "gcode-prototrak"]),
    GCODE_OPTIONS,
    st.integers(min_value=0, max_value=40),
)
def test_runs_written_in_one_go_are_the_lines_written_one_by_one(
    program: Program, target: str, options: dict[str, str], numbers_left: int
) -> None:
    """The writer writes runs of rapids, feeds and dwells a run at a time (numpy finds the
    words that change); the same program written one line at a time gives the same bytes,
    also when the N numbers pass the control's largest inside a run and start again. A run
    shorter than BULK_ROWS goes one by one; with every run in one go, the same bytes."""
    assume(not has_errors(validate(program)))
    made = get_target(target)
    largest = made.dialect.largest_line_number  # type: ignore[attr-defined]
    step = int(options["sequence-increment"])
    options = {**options, "sequence-start": str(max(0, largest - numbers_left * step))}
    parsed = made.parse_options(options)
    path = compile_program(resolve_copies(program)).path
    texts = []
    for bulk, bulk_rows in ((True, BULK_ROWS), (True, 1), (False, BULK_ROWS)):
        lines: list[str] = []
        writer = Writer(
            made.dialect,  # type: ignore[attr-defined]
            program,
            path,
            parsed,
            Report(target),
            lines.append,
            bulk=lines.extend if bulk else None,
        )
        writer.bulk_rows = bulk_rows
        writer.write()
        texts.append(lines)
    assert texts[0] == texts[2]
    assert texts[1] == texts[2]


# -- the first plunge (found by a review of POCKET; older than it) ---------------------------


def _first_cut_knows_xy(text: str) -> bool:
    """True when X and Y have both been written before the first move down from the start
    height (the machine's XY at the start is wherever the operator left the table)."""
    seen_x = seen_y = False
    start_z: float | None = None
    for line in text.splitlines():
        words = re.findall(r"([XYZ])(-?[0-9.]+)", line.split("(")[0])
        for letter, value in words:
            if letter == "X":
                seen_x = True
            elif letter == "Y":
                seen_y = True
            elif start_z is None:
                start_z = float(value)
            elif float(value) < start_z:
                return seen_x and seen_y
    return True


@pytest.mark.parametrize("target", ["gcode-linuxcnc", "gcode-fanuc", "gcode-prototrak"])
def test_the_first_plunge_names_x_and_y_even_at_part_zero(target: str) -> None:
    """A mill sequence (here a POCKET) whose first plunge is at X0 Y0 went down without any
    X or Y word: the tool went down wherever the table happened to be."""
    d = Decimal
    blocks = (
        Hole(
            op=HoleOp.DRILL, x=d(-1), y=d(-1), z_up=d("0.1"), z_dn=d("-0.25"), feed_z=d(5), tool=1
        ),
        Pocket(feed_xy=d(10), tool=1),
        PocketLine(x=d(1), y=d(-1)),
        PocketLine(x=d(1), y=d(1)),
        PocketLine(x=d(-1), y=d(1)),
        PocketLine(x=d(-1), y=d(-1)),
    )
    tools = (Tool(number=1, diameter=d("0.25"), rpm=1500, tcal=d(0)),)
    program = Program(name="zero", block0=DataBlock0(current_tool=1, tools=tools), blocks=blocks)
    text = export(program, target).data.decode()
    assert _first_cut_knows_xy(text), text[:400]
    for case in sorted((Path(__file__).parent / "golden").iterdir()):
        expected = case / f"expected.{target}"
        if expected.exists():
            assert _first_cut_knows_xy(expected.read_text(encoding="utf-8")), case.name
