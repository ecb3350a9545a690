"""LinuxCNC tool tables (issue 34 point 4): the crib written as a `.tbl` is what LinuxCNC's
own interpreter reads (`rs274 -t`: each tool's length offset through G43 H and its diameter
through cutter compensation), and reads back into the crib as it was; a table written by a
LinuxCNC machine reads in with what was not carried reported; a program's own table gives
its G-code's `G43 H` the TCAL the set-up sheet lists.
"""

from __future__ import annotations

import os
import re
import subprocess
from decimal import Decimal as D
from pathlib import Path

import pytest

from app.cnc import document
from app.cnc.formats.targets import export
from app.cnc.tools import CribTool, Hand, PitchUnit, ToolMaterial, ToolType
from app.cnc.tooltable import (
    TableError,
    crib_table,
    parse_table,
    program_table,
    read_table,
    write_table,
)
from app.cnc.units import Units
from tests.referee import RS274

GOLDEN = Path(__file__).parent / "golden"


def run_rs274(table: Path, path: Path) -> subprocess.CompletedProcess[str]:
    """rs274 on G-code file `path` with the tool table `table`. rs274 shares the tool table
    it loads through `$HOME/.tool.mmap`: two runs at once under one HOME read each other's
    tools, so each run gets its own HOME (as tests/referee.run_rs274 does)."""
    assert RS274, "rs274 (Debian linuxcnc-uspace) is not installed: run `make test`"
    home = path.parent / ".rs274-home"
    home.mkdir(exist_ok=True)
    return subprocess.run(
        [RS274, "-t", str(table), "-g", str(path)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
        env={**os.environ, "HOME": str(home)},
    )


CRIB = [
    CribTool(
        number=3,
        name="1/2 END MILL",
        kind=ToolType.END_MILL,
        diameter=D("0.5"),
        flutes=3,
        material=ToolMaterial.CARBIDE,
        length=D("1.25"),
        tcal=D("2.1375"),
    ),
    CribTool(
        number=7,
        name="#7 DRILL",
        kind=ToolType.DRILL,
        diameter=D("0.201"),
        tcal=D("-0.4"),
    ),
    CribTool(
        number=12,
        name="1/4-20 TAP",
        kind=ToolType.TAP,
        diameter=D("0.25"),
        flutes=4,
        pitch=D(20),
        pitch_unit=PitchUnit.TPI,
    ),
    CribTool(
        number=101,
        name="3/16 CARBIDE END MILL",
        kind=ToolType.END_MILL,
        diameter=D("0.1875"),
        material=ToolMaterial.CARBIDE,
        tcal=D("1.5"),
    ),
]
OFFSET = re.compile(r"USE_TOOL_LENGTH_OFFSET\(\S+ \S+ (\S+),")
FEED = re.compile(r"STRAIGHT_FEED\((\S+), (\S+), ")
SELECT = re.compile(r"SELECT_TOOL\((\d+)\)")


def tool_calls(out: str) -> list[tuple[int, float, list[tuple[float, float]]]]:
    """rs274's canonical calls per tool called: (tool, the length offset G43 H applied after
    the call, the feeds' X/Y ends until the next call)."""
    calls: list[tuple[int, float, list[tuple[float, float]]]] = []
    for line in out.splitlines():
        if found := SELECT.search(line):
            calls.append((int(found.group(1)), float("nan"), []))
        elif calls and (found := OFFSET.search(line)):
            tool, _, feeds = calls[-1]
            calls[-1] = (tool, float(found.group(1)), feeds)
        elif calls and (found := FEED.search(line)):
            calls[-1][2].append((float(found.group(1)), float(found.group(2))))
    return calls


def through_rs274(table: str, numbers: list[int], tmp_path: Path) -> dict[int, tuple[float, float]]:
    """What LinuxCNC's interpreter makes of a tool table: for each tool, the length offset
    `G43 H` applies and the radius cutter compensation offsets a cut by (a G41 cut along
    +X at Y0 ends at Y = the radius), as the table's numbers.

    The standalone rs274 reads a tool table in inches, its own units (a machine's LinuxCNC
    reads it in the units of its INI file); the check program is G20, so the figures it
    reports are the table's numbers as they stand, whichever units the table is in."""
    (tmp_path / "crib.tbl").write_text(table)
    lines = ["G20", "G90 G40 G49"]
    for n in numbers:
        lines += [
            f"T{n} M6",
            f"G43 H{n}",
            "G0 X0 Y0 Z1",
            "G41 G1 X100 Y0 F10",
            "G1 X200 Y0",
            "G40",
            "G0 X0 Y-50",
        ]
    (tmp_path / "check.ngc").write_text("\n".join([*lines, "M2", ""]))
    done = run_rs274(tmp_path / "crib.tbl", tmp_path / "check.ngc")
    out = done.stdout + done.stderr
    assert done.returncode == 0 and "PROGRAM_END" in out, out
    found: dict[int, tuple[float, float]] = {}
    for tool, length, feeds in tool_calls(out):
        # The second cut ends at X20 on the compensated line Y = the radius.
        assert feeds[1][0] == pytest.approx(200.0)
        found[tool] = (length, feeds[1][1])
    assert sorted(found) == sorted(numbers)
    return found


def test_the_crib_written_as_a_tool_table_is_what_rs274_reads(tmp_path: Path) -> None:
    text = write_table(crib_table(CRIB, Units.INCH), Units.INCH)
    assert text.splitlines()[0] == "T3 P3 D0.5000 Z2.1375 ;1/2 END MILL"
    assert "T12 P12 D0.2500 ;1/4-20 TAP" in text  # no TCAL: no Z (LinuxCNC's 0)
    seen = through_rs274(text, [t.number for t in CRIB], tmp_path)
    for tool in CRIB:
        length, radius = seen[tool.number]
        assert length == pytest.approx(float(tool.tcal or 0), abs=1e-4), tool.title
        assert radius == pytest.approx(float(tool.diameter) / 2, abs=1e-4), tool.title


def test_the_tool_table_reads_back_into_the_crib_as_it_was(tmp_path: Path) -> None:
    text = write_table(crib_table(CRIB, Units.INCH), Units.INCH)
    read = read_table(text, Units.INCH)
    assert read.notes == []
    by_number = {t.number: t for t in read.tools}
    for tool in CRIB:
        back = by_number[tool.number]
        assert (back.name, back.kind, back.diameter, back.tcal) == (
            tool.name,
            tool.kind,
            tool.diameter,
            tool.tcal,
        )
    # What the names say comes back too: the tap's thread, the carbide.
    assert (by_number[12].pitch, by_number[12].pitch_unit) == (D(20), PitchUnit.TPI)
    assert by_number[101].material is ToolMaterial.CARBIDE
    # And again: written from what was read, the same bytes.
    assert write_table(crib_table(read.tools, Units.INCH), Units.INCH) == text


def test_a_metric_crib_and_an_inch_tool_in_a_metric_table(tmp_path: Path) -> None:
    tools = [
        CribTool(
            number=1,
            name="6 MM END MILL",
            kind=ToolType.END_MILL,
            units=Units.MM,
            diameter=D(6),
            tcal=D("52.5"),
        ),
        CribTool(
            number=2,
            name="M6X1 TAP",
            kind=ToolType.TAP,
            units=Units.MM,
            diameter=D(6),
            pitch=D(1),
            pitch_unit=PitchUnit.MM,
            tcal=D("48.125"),
        ),
        CRIB[0],  # 0.5 in, TCAL 2.1375 in: 12.7 mm, 54.2925 mm → 54.292 (half-even, 0.001 mm)
    ]
    text = write_table(crib_table(tools, Units.MM), Units.MM)
    assert "T3 P3 D12.700 Z54.292 ;1/2 END MILL" in text
    seen = through_rs274(text, [1, 2, 3], tmp_path)
    assert seen[1] == pytest.approx((52.5, 3.0))
    assert seen[2] == pytest.approx((48.125, 3.0))
    assert seen[3] == pytest.approx((54.292, 6.35))
    back = {t.number: t for t in read_table(text, Units.MM).tools}
    assert (back[2].pitch, back[2].pitch_unit) == (D(1), PitchUnit.MM)


MACHINE_TABLE = """\
; written by LinuxCNC's tool editor
T1 P1 D+0.125000 Z+0.511000 ;1/8 end mill
T2 P5 D+0.250000 Z+0.350000 X+0.010000 ;1/4 4FL carbide endmill (TiAlN)
T4 P4 D+0.201000 Z-0.125000 ;#7 drill
T5 P5 D0 Z+1.000000 ;probe
T9 P9 D+0.500000 Z+1.123456 I+0.0 J+0.0 Q0 ;1/2-13 LH tap
T10 P10 D+0.750000 ;
"""


def test_a_machine_s_table_reads_in_with_what_was_not_carried(tmp_path: Path) -> None:
    read = read_table(MACHINE_TABLE, Units.INCH)
    tools = {t.number: t for t in read.tools}
    assert sorted(tools) == [1, 2, 4, 9, 10]  # T5 has no diameter
    assert tools[1].kind is ToolType.END_MILL and tools[1].diameter == D("0.125")
    assert (tools[2].flutes, tools[2].material) == (4, ToolMaterial.CARBIDE)
    assert tools[2].name == "1/4 4FL carbide endmill"
    assert tools[4].kind is ToolType.DRILL and tools[4].tcal == D("-0.125")
    assert tools[9].kind is ToolType.TAP and tools[9].pitch == D(13)
    assert tools[9].hand is Hand.LEFT
    assert tools[10].name == "T10"
    assert read.notes == [
        "line 3, T2: named '1/4 4FL carbide endmill' (the comment '1/4 4FL carbide endmill "
        "(TiAlN)' holds characters a name cannot and is longer than 24 characters)",
        "line 3, T2: pocket P5 is not kept (written as P = T)",
        "line 3, T2: not carried: X0.010000",
        "line 5, T5: no diameter (D0): not read; a crib tool needs its cutting diameter",
        "line 6, T9: Z1.123456 rounded to 1.1235",
        "line 7, T10: named 'T10' (the comment '' is empty)",
        "line 7, T10: the comment names no type: taken as an end mill",
    ]
    # Written back, LinuxCNC reads the same lengths (to the crib's 0.0001 in) and diameters.
    numbers = [1, 2, 4, 9, 10]
    theirs = through_rs274(MACHINE_TABLE, numbers, tmp_path / "a")
    ours = through_rs274(
        write_table(crib_table(read.tools, Units.INCH), Units.INCH),
        numbers,
        tmp_path / "b",
    )
    for n in numbers:
        assert ours[n][0] == pytest.approx(theirs[n][0], abs=5e-5)
        assert ours[n][1] == pytest.approx(theirs[n][1], abs=1e-9)


@pytest.fixture(autouse=True)
def _folders(tmp_path: Path) -> None:
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("T1 P1 D0.25\nT1 P2 D0.5\n", "line 2: T1 is listed twice (also on line 1)"),
        ("T1 P1 D0.2.5\n", "line 1, column 8: D: '0.2.5' is not a number"),
        ("P1 D0.25\n", "line 1, column 1: no T word"),
        ("T1 P1 K0.25\n", "line 1, column 7: K is not a tool table word"),
        ("T1.5 P1\n", "line 1: T1.5 is not a whole number"),
        ("T1 P1 D0.25 D0.5\n", "line 1, column 13: D is given twice"),
        ("T100000 P1\n", "line 1: T100000 is outside the tool numbers 1 to 99999"),
        ("T1 P1 =0.25\n", "line 1, column 7: '=0.25' is not a word of a tool table"),
    ],
)
def test_a_line_that_is_not_a_tool_table_s_is_named_with_its_column(
    text: str, message: str
) -> None:
    with pytest.raises(TableError) as caught:
        parse_table(text)
    assert str(caught.value).startswith(message), str(caught.value)


def test_a_program_s_tool_table_gives_its_g_code_the_tcal_of_the_set_up_sheet(
    tmp_path: Path,
) -> None:
    """The program's own table: its tools by the numbers its G-code calls, Z their TCAL, D
    their DIA; rs274 running the program's G-code with it applies each TCAL at G43 H."""
    program = document.loads((GOLDEN / "coolant-and-messages" / "program.json").read_text())
    tcal = {t.number: t.tcal for t in program.block0.tools}
    assert any(v not in (None, 0) for v in tcal.values())
    table = write_table(program_table(program), program.units)
    (tmp_path / "program.tbl").write_text(table)
    gcode = tmp_path / "program.ngc"
    gcode.write_bytes(export(program, "gcode-linuxcnc").data)
    done = run_rs274(tmp_path / "program.tbl", gcode)
    out = done.stdout + done.stderr
    assert done.returncode == 0 and "PROGRAM_END" in out, out
    calls = tool_calls(out)
    assert len(calls) >= 2
    # Each tool call's G43 H applies that tool's TCAL (the set-up sheet's).
    assert [length for _, length, _ in calls] == pytest.approx(
        [float(tcal[tool] or 0) for tool, _, _ in calls], abs=1e-4
    )
