"""The referees of every output: a reader we did not write where one runs here (LinuxCNC's
`rs274` for G-code), and our own importers for every other format.

`trace` is the comparison: every move of a tool path that goes somewhere, in order, in
three axes — a rapid or a feed to its end (x, y, z) at its feed, an arc to its end about its
centre in its direction — and each tool change. Arcs about one centre in one direction that
follow each other are one arc (a 1704 tape splits arcs at the quadrants), so two paths
compare however their blocks cut the same curve. It is written here, not taken from the
importers, so the tests do not grade an importer with its own arithmetic.

`round_trip` exports a program, reads the bytes back with our importer for that format, and
compares the re-interpreted program's trace with the original's within the format's
resolution. What a format cannot carry is stated by the caller (e.g. the 2-axis events),
never silently ignored here.
"""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
from dataclasses import dataclass, replace
from pathlib import Path

from app.cnc.blocks import Program
from app.cnc.emit.target import Export, export
from app.cnc.imports import read_program
from app.cnc.imports import steps as steps_module
from app.cnc.imports.steps import Parsed
from app.cnc.interpret import interpret
from app.cnc.toolpath import ArcFeed, Feed, Move, Rapid, ToolChange, Toolpath
from app.cnc.units import Units

# The import format that reads each program target back, and its reader options.
READER = {
    "gcode-linuxcnc": "gcode",
    "gcode-fanuc": "gcode",
    "gcode-prototrak": "gcode",
    "tape-ascii": "tape",
    "tape-eia": "tape",
    "punch-ascii": "tape",
    "punch-eia": "tape",
    "events": "events",
    "json": "json",
    "tape-boss": "boss",
}

# The finest step each format writes (nm), by program unit: G-code, BOSS and tape 0.0001 in
# / 0.001 mm, events 0.0001 in / 0.01 mm (seed 003 §2.2.4), the JSON document exact.
RESOLUTION = {
    "gcode": {Units.INCH: 2_540, Units.MM: 1_000},
    "boss": {Units.INCH: 2_540, Units.MM: 1_000},
    "tape": {Units.INCH: 2_540, Units.MM: 1_000},
    "events": {Units.INCH: 2_540, Units.MM: 10_000},
    "json": {Units.INCH: 0, Units.MM: 0},
}
# Feeds: G-code writes them to 0.0001 in/min or 0.001 mm/min, a 1704 tape in 0.1 ipm or
# 1 mm/min (F3.1 / F4).
FEED_STEP = {
    "gcode": {Units.INCH: 2_540, Units.MM: 1_000},
    "boss": {Units.INCH: 2_540, Units.MM: 1_000},
    "tape": {Units.INCH: 2_540_000, Units.MM: 1_000_000},
    # The Plus's feeds top at 99.9 ipm and 2535 mm/min (seed 003 §2.2.4), where MillBlocks
    # allows 100 ipm and 2540 mm/min (read back in steps of 2 mm/min).
    "events": {Units.INCH: 2_540_000, Units.MM: 2_000_000},
    "json": {Units.INCH: 0, Units.MM: 0},
}


@dataclass(frozen=True)
class Step:
    """One move of a trace: kind R(apid), F(eed), A(rc) or T(ool change, `tool` set)."""

    kind: str
    end: tuple[int, int, int]
    feed: int | None = None
    centre: tuple[int, int] | None = None
    clockwise: bool = False
    tool: int = 0


def trace(
    toolpath: Toolpath,
    *,
    shortest: int = 0,
    with_z: bool = True,
    machine: bool = False,
    written: int = 0,
) -> list[Step]:
    """The tool path's moves (see the module docstring). A straight move no longer than
    `shortest` nm in every axis from where the last kept move ended is left out: a format
    that writes numbers in steps of that size cannot write it. `written` (nm) rounds every
    end point to that step first, as a file writes it (a move whose ends are written alike
    is no move). `with_z` False compares XY only (a 2-axis format): Z is then 0 throughout
    and tool changes are not steps.

    `machine` True gives Z as the machine moves it, the tool's Z plus its TCAL (an
    uncalibrated tool counting as 0), and tool changes without their numbers: what a format
    that names neither tools nor their calibrations (an EIA tape) carries."""
    steps: list[Step] = []
    tool = toolpath.initial_tool

    def tcal() -> int:
        info = toolpath.tools.get(tool)
        return 0 if not machine or info is None or info.tcal is None else info.tcal

    x, y, z = toolpath.start
    mark = (x, y, z + tcal() if with_z else 0)
    for move in toolpath.moves:
        if isinstance(move, ToolChange):
            tool = move.tool
            z = move.z
            mark = (mark[0], mark[1], z + tcal() if with_z else 0)
            if with_z:
                # Where the head is at a change is the moves' business: only the tool counts.
                steps.append(Step("T", (0, 0, 0), tool=0 if machine else move.tool))
            continue
        if not isinstance(move, Rapid | Feed | ArcFeed):
            continue
        start = (x, y)
        x, y, z = move.x, move.y, move.z
        end = (x, y, z + tcal() if with_z else 0)
        if written:
            end = (_round(end[0], written), _round(end[1], written), _round(end[2], written))
            start = (_round(start[0], written), _round(start[1], written))
        if isinstance(move, ArcFeed):
            step = Step("A", end, move.feed, (move.cx, move.cy), move.clockwise)
            prev = steps[-1] if steps else None
            if (
                prev is not None
                and prev.kind == "A"
                and prev.centre is not None
                and prev.clockwise == step.clockwise
                and prev.feed == step.feed
                and prev.end[2] == end[2]
                and _near(prev.centre, (move.cx, move.cy), 100)
                and (prev.end[0], prev.end[1]) == start
            ):
                steps[-1] = Step("A", end, move.feed, prev.centre, move.clockwise)
            else:
                steps.append(step)
            mark = end
            continue
        if max(abs(a - b) for a, b in zip(end, mark, strict=True)) <= shortest:
            continue
        kind = "R" if isinstance(move, Rapid) else "F"
        steps.append(Step(kind, end, None if isinstance(move, Rapid) else move.feed))
        mark = end
    return steps


def _round(nm: int, step: int) -> int:
    """`nm` to the nearest multiple of `step`, halves to even (as numbers are written)."""
    return round(nm / step) * step


def _near(a: tuple[int, int], b: tuple[int, int], tol: int) -> bool:
    return abs(a[0] - b[0]) <= tol and abs(a[1] - b[1]) <= tol


def deviation(expected: list[Step], actual: list[Step], feed_step: int = 0) -> int:
    """The largest difference (nm) between matching ends and centres of two traces.

    Fails (AssertionError, naming the move) when the traces differ in their moves: count,
    kinds, arc directions, tools, or feeds by more than `feed_step` (nm/min)."""
    for k, (p, q) in enumerate(zip(expected, actual, strict=False)):
        where = f"move {k}: expected {p}, got {q}"
        assert p.kind == q.kind and p.tool == q.tool, where
        assert p.clockwise == q.clockwise, where
        if p.feed is not None and q.feed is not None:
            assert abs(p.feed - q.feed) <= feed_step, where
    assert len(expected) == len(actual), f"{len(expected)} moves expected, {len(actual)} read"
    worst = 0
    for p, q in zip(expected, actual, strict=True):
        worst = max(worst, *(abs(a - b) for a, b in zip(p.end, q.end, strict=True)))
        if p.centre is not None and q.centre is not None:
            worst = max(worst, *(abs(a - b) for a, b in zip(p.centre, q.centre, strict=True)))
    return worst


def entered(toolpath: Toolpath, first_z: int) -> Toolpath:
    """The tool path as our G-code moves it (writer.py, `Writer.start`): the tool path's
    Z-only rapids at its start X/Y are not written; the first position is a rapid across to
    the X/Y of the first move that goes anywhere else (a rapid's end, or the start for a
    feed or arc) at `first_z` (the height the tool is at: unknown to the file), then a
    rapid to the highest of those rapids (the entry, with G43), then, before a feed or an
    arc, down to where the tool path is. A tool change among them starts the entry height
    again from the next of those rapids; the first change is the file's first tool call, read
    as the tool the program starts with."""
    x, y, z = toolpath.start
    entry = z
    called = fresh = False
    moves = list(toolpath.moves)
    out: list[Move] = []
    for k, move in enumerate(moves):
        if isinstance(move, ToolChange):
            # The file says no Z before the entry: the change leaves it where it was. The
            # first change calls the first tool (T<n> M6 before any move: the tool the
            # program starts with, for a reader).
            entry = z = move.z
            fresh = True
            if called:
                out.append(ToolChange(move.block, move.tool, first_z))
            called = True
            continue
        if not isinstance(move, Rapid | Feed | ArcFeed):
            out.append(move)
            continue
        if isinstance(move, Rapid) and (move.x, move.y) == (x, y):
            entry, z = (move.z if fresh else max(entry, move.z)), move.z
            fresh = False
            continue
        ex, ey = (move.x, move.y) if isinstance(move, Rapid) else (x, y)
        block = move.block
        out += [Rapid(block, ex, ey, first_z), Rapid(block, ex, ey, entry)]
        if not isinstance(move, Rapid):
            out.append(Rapid(block, ex, ey, z))
        return replace(toolpath, moves=out + moves[k:])
    return replace(toolpath, moves=out)


def file_trace(parsed: Parsed, start: tuple[int, int, int], *, machine: bool = False) -> list[Step]:
    """The moves a file says, as `trace` gives a tool path's: our parser's reading of the
    file (its steps), with each canned cycle's hole expanded here the way seed 003's tables
    and seed 000 §4 define them (rapid across at the current height, rapid to R, feed to the
    bottom, back up at rapid to the clearance height). `machine`: tool numbers not compared
    (a tape that names no tools). `start` is where the tool path starts (the file's first
    move, only in Z, goes there)."""
    steps: list[Step] = []
    x, y, z = start

    def add(kind: str, end: tuple[int, int, int], feed: int | None = None) -> None:
        nonlocal x, y, z
        if end != (x, y, z):
            steps.append(Step(kind, end, feed))
        x, y, z = end

    for step in parsed.steps:
        if isinstance(step, steps_module.ToolChange):
            steps.append(Step("T", (0, 0, 0), tool=0 if machine else step.tool))
        elif isinstance(step, steps_module.Rapid):
            add("R", (step.x, step.y, z if step.z is None else step.z))
        elif isinstance(step, steps_module.Feed):
            add("F", (step.x, step.y, z if step.z is None else step.z), step.feed)
        elif isinstance(step, steps_module.Arc):
            end = (step.x, step.y, z if step.z is None else step.z)
            arc = Step("A", end, step.feed, (step.cx, step.cy), step.clockwise)
            prev = steps[-1] if steps else None
            if (
                prev is not None
                and prev.kind == "A"
                and prev.centre is not None
                and prev.clockwise == step.clockwise
                and prev.feed == step.feed
                and prev.end == (x, y, end[2])
                and _near(prev.centre, (step.cx, step.cy), 100)
            ):
                steps[-1] = Step("A", end, step.feed, prev.centre, step.clockwise)
            else:
                steps.append(arc)
            x, y, z = end
        elif isinstance(step, steps_module.Cycle):
            assert step.peck == 0, "pecks are explicit moves unless G83 is asked for"
            add("R", (step.x, step.y, z))
            add("R", (step.x, step.y, step.r))
            add("F", (step.x, step.y, step.bottom), step.feed)
            add("R", (step.x, step.y, step.clear))
    return steps


def read_back(program: Program, target: str, data: bytes) -> Program:
    """Our importer's reading of an export of `program` to `target` (with the reader options
    the user gives where the file cannot say: the metric option of a tape)."""
    reader = READER[target]
    options = {"units": "metric"} if reader == "tape" and program.units is Units.MM else None
    return read_program(data, program.name, reader, options).program


def exported(program: Program, target: str, options: dict[str, str] | None = None) -> Export:
    return export(program, target, options)


# -- LinuxCNC's rs274 ---------------------------------------------------------------------

RS274 = shutil.which("rs274")
CALL = re.compile(r"^\s*\d+ N[\d.]+\s+(\w+)\((.*)\)\s*$")


@dataclass(frozen=True)
class Motion:
    """One canonical motion in program units: kind T(raverse), F(eed) or A(rc)."""

    kind: str
    end: tuple[float, float, float]
    centre: tuple[float, float] | None = None
    clockwise: bool | None = None
    feed: float | None = None


def run_rs274(table: Path, path: Path) -> subprocess.CompletedProcess[str]:
    """rs274 on G-code file `path` with the tool table `table`, finished.

    rs274 shares the tool table it loads through a file, `$HOME/.tool.mmap` (LinuxCNC's
    tooldata_mmap): two runs at once under one HOME read each other's tools (a length of 0
    where the table says 0.511, now and then, when the suite runs beside another). Each
    run gets a HOME of its own, the G-code's folder."""
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


def rs274(path: Path, lengths: dict[int, float] | None = None) -> list[Motion]:
    """Run rs274 on a file; its motions (zero-length ones dropped). Fails on any error.

    The machine's tool table lists tools 1-24 (as a shop's LinuxCNC would for this control's
    24 tools) with the `lengths` (inches) the operator keys in from the set-up comments.
    """
    table = path.with_suffix(".tbl")
    lengths = lengths or {}
    table.write_text("".join(f"T{n} P{n} Z{lengths.get(n, 0.0):.8f} D0 ;\n" for n in range(1, 25)))
    result = run_rs274(table, path)
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


def ours(toolpath: Toolpath) -> list[Motion]:
    """Our motions as rs274 reports them for our G-code: in program units, from LinuxCNC's
    start on. rs274 starts at machine zero, which is program zero (G54 is the operator's,
    not written), and the G91 G28 Z0 retract goes to machine zero too: the first move
    across is at Z0 there (`entered`)."""
    unit = toolpath.units.nm
    x, y, z = 0.0, 0.0, 0.0
    motions = []
    places = toolpath.units.dump_places
    for move in entered(toolpath, 0).moves:
        if not isinstance(move, Rapid | Feed | ArcFeed):
            continue
        # Compared as written: a move shorter than the output resolution is not written.
        end = (
            round(move.x / unit, places),
            round(move.y / unit, places),
            round(move.z / unit, places),
        )
        if isinstance(move, ArcFeed):
            centre = (move.cx / unit, move.cy / unit)
            motions.append(Motion("A", end, centre, move.clockwise, move.feed / unit))
        elif end != (x, y, z):
            feed = move.feed / unit if isinstance(move, Feed) else None
            motions.append(Motion("T" if isinstance(move, Rapid) else "F", end, feed=feed))
        x, y, z = end
    return motions


def assert_same_motions(actual: list[Motion], expected: list[Motion], tol: float) -> None:
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


def referee_gcode(program: Program, target: str, data: bytes, tmp_path: Path) -> None:
    """rs274 accepts `data` and reports our tool path's motions (tool lengths keyed in
    from the set-up comments, i.e. each tool's TCAL)."""
    path = tmp_path / "program.ngc"
    path.write_bytes(data)
    toolpath = interpret(program)
    tol = 0.0001 if toolpath.units is Units.INCH else 0.001
    inch = 25_400_000
    keyed = {n: t.tcal / inch for n, t in toolpath.tools.items() if t.tcal is not None}
    assert_same_motions(rs274(path, keyed), ours(toolpath), tol + 1e-9)


def arc_radii_agree(toolpath: Toolpath, tol: float) -> bool:
    """True when every arc's end is on its start's radius within `tol` nm."""
    x, y = toolpath.start[0], toolpath.start[1]
    for move in toolpath.moves:
        if isinstance(move, ArcFeed):
            r1 = math.dist((x, y), (move.cx, move.cy))
            r2 = math.dist((move.x, move.y), (move.cx, move.cy))
            if abs(r1 - r2) > tol:
                return False
        if isinstance(move, Rapid | Feed | ArcFeed):
            x, y = move.x, move.y
    return True
