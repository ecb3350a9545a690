"""G-code targets, refereed by LinuxCNC's own interpreter (`rs274` from linuxcnc-uspace).

For every golden program, `rs274 -g` must accept our gcode-linuxcnc and gcode-prototrak
output, and the STRAIGHT_TRAVERSE / STRAIGHT_FEED / ARC_FEED calls it reports must be our
Toolpath: end points within 0.0001 in (0.001 mm), arc centres and directions, feed rates.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import pytest

from app.cnc import document
from app.cnc.blocks import Program
from app.cnc.copy import resolve_copies
from app.cnc.emit.target import Severity, export
from app.cnc.interpret import interpret
from app.cnc.toolpath import ArcFeed, Feed, Rapid, Toolpath
from app.cnc.units import NM_PER_INCH, Units

GOLDEN = Path(__file__).parent / "golden"
CASES = sorted(p for p in GOLDEN.iterdir() if (p / "program.json").exists())
RS274 = shutil.which("rs274")


@dataclass(frozen=True)
class Motion:
    """One canonical motion in program units: kind T(raverse), F(eed) or A(rc)."""

    kind: str
    end: tuple[float, float, float]
    centre: tuple[float, float] | None = None
    clockwise: bool | None = None
    feed: float | None = None


def load(case: Path) -> Program:
    return resolve_copies(document.loads((case / "program.json").read_text(encoding="utf-8")))


def ours(toolpath: Toolpath, offsets_set: bool) -> list[Motion]:
    """Our motions, in program units, from LinuxCNC's start on.

    rs274 starts at machine zero, which in G54 program coordinates is minus the part
    offsets; our tool path starts over part zero. The exported program moves only Z until
    its first move across (which names X and Y), so until then the XY is the machine's.
    `offsets_set`: the program sets G54 to the part offsets (LinuxCNC); the Fanuc dialects
    leave the work offset to the set-up sheet, so there machine zero is program zero.
    """
    unit = toolpath.units.nm
    home = (0.0, 0.0)
    if offsets_set:
        home = (-toolpath.origin[0] / unit, -toolpath.origin[1] / unit)
    x, y, z = home[0], home[1], 0.0
    motions = []
    sx, sy, sz = (v / unit for v in toolpath.start)
    moved_across = False
    if sz != z:
        motions.append(Motion("T", (x, y, sz)))
        z = sz
    places = toolpath.units.dump_places
    for move in toolpath.moves:
        if not isinstance(move, Rapid | Feed | ArcFeed):
            continue
        # Compared as written: a move shorter than the output resolution is not written.
        end = (
            round(move.x / unit, places),
            round(move.y / unit, places),
            round(move.z / unit, places),
        )
        moved_across = moved_across or (end[0], end[1]) != (sx, sy)
        if not moved_across:
            end = (home[0], home[1], end[2])
        if isinstance(move, ArcFeed):
            centre = (move.cx / unit, move.cy / unit)
            motions.append(Motion("A", end, centre, move.clockwise, move.feed / unit))
        elif end != (x, y, z):
            feed = move.feed / unit if isinstance(move, Feed) else None
            motions.append(Motion("T" if isinstance(move, Rapid) else "F", end, feed=feed))
        x, y, z = end
    return motions


CALL = re.compile(r"^\s*\d+ N[\d.]+\s+(\w+)\((.*)\)\s*$")


def referee(path: Path, lengths: dict[int, float] | None = None) -> list[Motion]:
    """Run rs274 on a file; its motions (zero-length ones dropped). Fails on any error.

    The machine's tool table lists tools 1-24 (as a shop's LinuxCNC would for this
    control's 24 tools). The LinuxCNC program sets their lengths itself with G10 L1; for
    the Fanuc dialects `lengths` are what the operator keys in from the set-up comments.
    """
    assert RS274, "rs274 (Debian linuxcnc-uspace) is not installed: run `make test`"
    table = path.with_suffix(".tbl")
    lengths = lengths or {}
    table.write_text("".join(f"T{n} P{n} Z{lengths.get(n, 0.0):.4f} D0 ;\n" for n in range(1, 25)))
    result = subprocess.run(
        [RS274, "-t", str(table), "-g", str(path)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    output = result.stdout + result.stderr
    calls = [CALL.match(line) for line in output.splitlines()]
    stray = [
        line
        for line, m in zip(output.splitlines(), calls, strict=True)
        if not m and line.strip() not in ("executing", "")
    ]
    assert result.returncode == 0 and not stray, f"rs274 refused {path.name}:\n{output}"
    motions: list[Motion] = []
    position = (0.0, 0.0, 0.0)
    feed = 0.0
    for m in calls:
        if m is None:
            continue
        name, args = m.group(1), [a.strip() for a in m.group(2).split(",")]
        if name == "SET_FEED_RATE":
            feed = float(args[0])
        elif name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
            end = (float(args[0]), float(args[1]), float(args[2]))
            if end != position:
                kind = "T" if name == "STRAIGHT_TRAVERSE" else "F"
                motions.append(Motion(kind, end, feed=None if kind == "T" else feed))
            position = end
        elif name == "ARC_FEED":
            end = (float(args[0]), float(args[1]), float(args[5]))
            centre = (float(args[2]), float(args[3]))
            motions.append(Motion("A", end, centre, int(args[4]) < 0, feed))
            position = end
    assert "PROGRAM_END" in output
    return motions


def assert_same(actual: list[Motion], expected: list[Motion], tol: float) -> None:
    assert len(actual) == len(expected), f"{len(actual)} motions, expected {len(expected)}"
    for n, (a, e) in enumerate(zip(actual, expected, strict=True)):
        where = f"motion {n}: {a} vs {e}"
        assert a.kind == e.kind, where
        assert all(abs(p - q) <= tol for p, q in zip(a.end, e.end, strict=True)), where
        if e.kind == "A":
            assert a.centre is not None and e.centre is not None
            assert all(abs(p - q) <= tol for p, q in zip(a.centre, e.centre, strict=True)), where
            assert a.clockwise == e.clockwise, where
        if e.kind != "T":
            assert a.feed is not None and e.feed is not None
            assert abs(a.feed - e.feed) <= max(tol, 1e-4 * e.feed), where


@pytest.mark.parametrize("target", ["gcode-linuxcnc", "gcode-prototrak"])
@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_linuxcnc_accepts_and_agrees(case: Path, target: str, tmp_path: Path) -> None:
    program = load(case)
    result = export(program, target)
    path = tmp_path / f"{case.name}.ngc"
    path.write_bytes(result.data)
    toolpath = interpret(program)
    tol = 0.0001 if toolpath.units is Units.INCH else 0.001
    # rs274's tool table is in inches, whatever the program's units.
    keyed = {n: t.tcal / NM_PER_INCH for n, t in toolpath.tools.items() if t.tcal is not None}
    lengths = None if target == "gcode-linuxcnc" else keyed
    assert_same(referee(path, lengths), ours(toolpath, target == "gcode-linuxcnc"), tol)


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
    motion = [b for b in blocks if re.search(r"\b[XYZ]-?\d", b) and not b.startswith("(")]
    assert motion and all(re.search(r"\bG0[0-3]\b", b) for b in motion)
    assert all("  " not in b and re.match(r"^(N\d+ |\()", b) for b in blocks)


def test_fanuc_program_number_and_no_spaces() -> None:
    text = export(load(GOLDEN / "bolt-circle-drill"), "gcode-fanuc").data.decode()
    lines = text.splitlines()
    assert lines[0] == "%" and lines[1] == "O4711" and lines[-1] == "%"
    assert all(" " not in line for line in lines if line.startswith("N"))


def test_set_up_offsets_reach_linuxcnc() -> None:
    """Data Block 0 X 4.5 Y 3.25 becomes G54 through G10 L2; tool 1's TCAL a G10 L1 length."""
    path_text = export(load(GOLDEN / "bolt-circle-drill"), "gcode-linuxcnc").data.decode()
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
