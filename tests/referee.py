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
from app.cnc.formats.reading import ImportResult, read_program
from app.cnc.formats.targets import Export, export
from app.cnc.interpret import interpret
from app.cnc.recognition import steps as steps_module
from app.cnc.recognition.steps import Parsed
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
    flat = True  # the last arc step stays at one Z
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
                and flat  # a helical arc stays a step of its own
                and _near(prev.centre, (move.cx, move.cy), 100)
                and (prev.end[0], prev.end[1]) == start
            ):
                steps[-1] = Step("A", end, move.feed, prev.centre, move.clockwise)
            else:
                steps.append(step)
                flat = mark[2] == end[2]
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


def chords_as_arcs(
    expected: list[Step], actual: list[Step], start: tuple[int, int, int], tol: int
) -> list[Step]:
    """`actual` with each run of feeds that a target without helical arcs wrote for a
    helical arc of `expected` (chords along it) put back as that arc, ending where the run
    ends. A run stands for the arc only when every chord's end is on the helix within `tol`
    nm: its distance from the centre is the arc's radius, it has turned the arc's way, and
    its Z is where the helix is after that much turning; the run's last end is the arc's.
    Otherwise `actual` is left as it is (and `deviation` names the move that differs)."""
    out: list[Step] = []
    k = 0
    at = start
    for step in expected:
        here = at
        if step.kind != "T":
            at = step.end
        if not (
            step.kind == "A"
            and step.centre is not None
            and step.end[2] != here[2]
            and k < len(actual)
            and actual[k].kind == "F"
        ):
            if k < len(actual):
                out.append(actual[k])
            k += 1
            continue
        cx, cy = step.centre
        radius = math.hypot(here[0] - cx, here[1] - cy)
        a0 = math.atan2(here[1] - cy, here[0] - cx)
        a1 = math.atan2(step.end[1] - cy, step.end[0] - cx)
        sweep = ((a0 - a1) if step.clockwise else (a1 - a0)) % (2 * math.pi)
        if math.hypot(step.end[0] - here[0], step.end[1] - here[1]) <= tol:
            sweep = 2 * math.pi
        turned = 0.0
        previous = a0
        j = k
        matched = False
        while j < len(actual) and actual[j].kind == "F":
            x, y, z = actual[j].end
            angle = math.atan2(y - cy, x - cx)
            delta = ((previous - angle) if step.clockwise else (angle - previous)) % (2 * math.pi)
            turned += delta
            previous = angle
            on_helix = here[2] + (step.end[2] - here[2]) * min(turned, sweep) / sweep
            if abs(math.hypot(x - cx, y - cy) - radius) > tol or abs(z - on_helix) > tol:
                break
            j += 1
            near_end = max(abs(a - b) for a, b in zip(actual[j - 1].end, step.end, strict=True))
            if near_end <= tol and abs(turned - sweep) < 0.5:
                matched = True
                break
        if matched:
            out.append(replace(step, end=actual[j - 1].end, feed=actual[k].feed))
            k = j
        else:
            out.append(actual[k])
            k += 1
    out += actual[k:]
    return out


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
    flat = True  # the last arc step stays at one Z

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
                and flat  # a helical arc stays a step of its own
                and _near(prev.centre, (step.cx, step.cy), 100)
            ):
                steps[-1] = Step("A", end, step.feed, prev.centre, step.clockwise)
            else:
                steps.append(arc)
                flat = z == end[2]
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
    """One canonical motion in program units: kind T(raverse), F(eed) or A(rc), or C, a
    tool change where the tool is (`rs274(changes=True)`)."""

    kind: str
    end: tuple[float, float, float]
    centre: tuple[float, float] | None = None
    clockwise: bool | None = None
    feed: float | None = None
    tool: int = 0  # C: the tool changed to


def rs274(
    path: Path,
    lengths: dict[int, float] | None = None,
    diameters: dict[int, float] | None = None,
    *,
    in_mm: bool = False,
    changes: bool = False,
) -> list[Motion]:
    """Run rs274 on a file; its motions (zero-length ones dropped). Fails on any error.

    The machine's tool table lists tools 1-24 (as a shop's LinuxCNC would for this control's
    24 tools) with the `lengths` (inches) the operator keys in from the set-up comments and
    the `diameters` (inches, the table's unit whatever the file's; 0 where not given) that
    cutter compensation (G41/G42) offsets by; a tool past 24 given either is listed too (a
    CAM library's T32).

    `in_mm`: every motion and feed in millimetres, whatever units the file is in (G20/G21
    may change on the way). Before the file's first G20/G21, rs274 reads millimetres (its
    default); the importers read inches there (docs/imports.md), and so does this, so that a
    file that names no units is compared as the importer reads it.

    `changes`: each tool change is a motion too, of kind C, where it happens.
    """
    result, output = run_rs274(path, lengths, diameters)
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
    scale = 1.0
    defaulted = False  # rs274's own USE_LENGTH_UNITS, before the file says any
    plane = "XY"
    for m in calls:
        if m is None:
            continue
        name, args = m.group(1), [a.strip() for a in m.group(2).split(",")]
        if name == "USE_LENGTH_UNITS" and in_mm:
            scale = 25.4 if "INCHES" in args[0] or not defaulted else 1.0
            defaulted = True
        elif name == "SELECT_PLANE":
            plane = args[0].removeprefix("CANON_PLANE_")
        elif name == "SET_FEED_RATE":
            feed = float(args[0]) * scale
        elif name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
            end = (float(args[0]) * scale, float(args[1]) * scale, float(args[2]) * scale)
            if end != position:
                kind = "T" if name == "STRAIGHT_TRAVERSE" else "F"
                motions.append(Motion(kind, end, feed=None if kind == "T" else feed))
            position = end
        elif name == "CHANGE_TOOL" and changes:
            motions.append(Motion("C", position, tool=int(args[0])))
        elif name == "ARC_FEED":
            # (An arc in another plane names its axes in another order.)
            assert plane == "XY", f"{path.name}: an arc in the {plane} plane"
            end = (float(args[0]) * scale, float(args[1]) * scale, float(args[5]) * scale)
            centre = (float(args[2]) * scale, float(args[3]) * scale)
            motions.append(Motion("A", end, centre, int(args[4]) < 0, feed))
            position = end
    assert "PROGRAM_END" in output
    return motions


def rs274_reads(path: Path, diameters: dict[int, float] | None = None) -> bool:
    """Whether rs274 reads the file to its end without an error (its tool table's
    `diameters` in inches, as `rs274` has them)."""
    result, output = run_rs274(path, None, diameters)
    return result.returncode == 0 and "PROGRAM_END" in output


def run_rs274(
    path: Path, lengths: dict[int, float] | None, diameters: dict[int, float] | None = None
) -> tuple[subprocess.CompletedProcess[str], str]:
    """rs274 run on `path` with a tool table beside it (tools 1-24 and any other `lengths`
    or `diameters` name, both in inches); the result, and its output with stderr on a line
    of its own."""
    assert RS274, "rs274 (Debian linuxcnc-uspace) is not installed: run `make test`"
    table = path.with_suffix(".tbl")
    lengths = lengths or {}
    diameters = diameters or {}
    table.write_text(
        "".join(
            f"T{n} P{n} Z{lengths.get(n, 0.0):.8f} D{diameters.get(n, 0.0):.8f} ;\n"
            for n in sorted({*range(1, 25), *lengths, *diameters})
        )
    )
    # rs274 keeps its tool table in $HOME/.tool.mmap, one file for every rs274 the user
    # runs: two runs side by side (tests, or the engineers beside us) overwrite each other's
    # and one dies (SIGBUS) or misses a tool its table lists. Each run gets its own HOME.
    result = subprocess.run(
        [RS274, "-t", str(table), "-g", str(path)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
        env={**os.environ, "HOME": str(path.parent)},
    )
    # (stderr on its own line: stdout need not end with one)
    return result, result.stdout + "\n" + result.stderr


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
    from the set-up comments, i.e. each tool's TCAL). A dialect without helical arcs writes
    each as chords along it: those are compared with the helix (`chords_as_arcs`)."""
    path = tmp_path / "program.ngc"
    path.write_bytes(data)
    toolpath = interpret(program)
    tol = 0.0001 if toolpath.units is Units.INCH else 0.001
    inch = 25_400_000
    keyed = {n: t.tcal / inch for n, t in toolpath.tools.items() if t.tcal is not None}
    expected = ours(toolpath)
    assert_same_motions(_motion_chords(expected, rs274(path, keyed), tol), expected, tol + 1e-9)


def _motion_chords(expected: list[Motion], actual: list[Motion], tol: float) -> list[Motion]:
    """`actual` (rs274's motions) with runs of chords along a helical arc of `expected`
    put back as that arc (`chords_as_arcs`, in units of a millionth of the program's)."""
    if not any(m.kind == "A" for m in expected):
        return actual

    def step(m: Motion) -> Step:
        end = (round(m.end[0] * 1e6), round(m.end[1] * 1e6), round(m.end[2] * 1e6))
        centre = None if m.centre is None else (round(m.centre[0] * 1e6), round(m.centre[1] * 1e6))
        kind = {"T": "R", "C": "T"}.get(m.kind, m.kind)
        return Step(kind, end, None, centre, bool(m.clockwise), m.tool)

    steps = [step(m) for m in expected]
    joined = chords_as_arcs(steps, [step(m) for m in actual], (0, 0, 0), round(2e6 * tol))
    if len(joined) == len(actual):
        return actual
    # Each joined step is one of `actual`'s, or an arc of `expected`'s put back for the
    # run of chords that ends where it ends.
    out: list[Motion] = []
    k = 0
    for n, joined_step in enumerate(joined):
        if joined_step.kind == "A" and actual[k].kind == "F":
            while step(actual[k]).end != joined_step.end:
                k += 1
            out.append(replace(expected[n], feed=actual[k].feed))
        else:
            out.append(actual[k])
        k += 1
    return out


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


# -- the cut path of a file, as rs274 reads it (issue 36) ------------------------------------


@dataclass(frozen=True)
class Cut:
    """One feed move of a cut path (mm, mm/min): a line, or an arc about `centre` turning
    `sweep` radians (a full circle 2π) in its direction."""

    start: tuple[float, float, float]
    end: tuple[float, float, float]
    feed: float
    centre: tuple[float, float] | None = None
    clockwise: bool = False
    sweep: float = 0.0

    @property
    def vertical(self) -> bool:
        return self.centre is None and self.start[:2] == self.end[:2]


# mm: how near a feed down must be to where the last cut ended to cut nothing new there —
# two steps of 0.001 in: the end of the cut before and the DRILL's point are each rounded.
REENTRY = 0.0508


def cut_path(motions: list[Motion]) -> list[Cut]:
    """The feed moves of rs274's `motions` (from its start at 0, 0, 0), each from where the
    tool was: what cuts. Rapids only say where the next feed starts. Three readings make
    two files that cut alike compare alike, and nothing else:

    - a straight feed **up in Z** is left out: it retracts through what the tool has cut
      on its way down (MillBlocks retracts at rapid, and the importers say so);
    - a feed **down in Z** in several moves at one X/Y (a CAM's approach: down to a feed
      height at one rate, into the work at another) is the last rate's run to the bottom:
      a DRILL rapids to Z UP and feeds from there at its one FEEDR Z, and the importer says
      which moves above it it read as the rapid;
    - a feed down a hole the same tool has just cut as deep or deeper (with only rapids
      between: rs274's G83 pecks once more when its pecks divide the depth, rounding) cuts
      nothing and is left out; so does a feed down to where the tool's last cut ended
      (within 0.002 in), as deep or deeper (MillBlocks retracts and comes down again where
      a compensated contour starts or ends: a DRILL of its own).

    Moves are not joined otherwise: two lines that rounding to the blocks' steps puts in
    one line are still two moves, in the file and in the blocks alike.
    """
    cuts: list[Cut] = []
    position = (0.0, 0.0, 0.0)
    joined = False  # the last cut ends where the next move starts (no rapid between)
    bottom: tuple[float, float, float] | None = None  # where the last cut, straight down, ended
    tool = 0
    for motion in motions:
        start, position = position, motion.end
        if motion.kind in "TC":
            joined = False
            if motion.kind == "C" and motion.tool != tool:
                tool, bottom = motion.tool, None
            continue
        assert motion.feed is not None
        if motion.kind == "A":
            assert motion.centre is not None and motion.clockwise is not None
            arc = Cut(
                start,
                motion.end,
                motion.feed,
                motion.centre,
                motion.clockwise,
                _sweep(start, motion.end, motion.centre, motion.clockwise),
            )
            cuts.append(arc)
            joined, bottom = True, motion.end
            continue
        line = Cut(start, motion.end, motion.feed)
        if line.vertical and line.end[2] > line.start[2]:
            joined = False
            continue
        # (Steps of the blocks apart: a compensated contour's DRILL goes down where
        # MillBlocks plans it, from its rounded start; the cut before ends where it rounds.)
        down = line.vertical and bottom is not None and math.dist(bottom[:2], start[:2]) <= REENTRY
        if down and bottom is not None and line.end[2] >= bottom[2] - 1e-9:
            continue  # down a hole this tool has cut deeper already (a peck more)
        bottom = line.end
        prev = cuts[-1] if joined and cuts else None
        if prev is not None and prev.vertical and line.vertical:
            # Down again at the same X/Y: one run at one rate, the approach above it gone.
            if prev.feed == line.feed:
                line = replace(line, start=prev.start)
            cuts.pop()
        cuts.append(line)
        joined = True
    return cuts


def _sweep(
    start: tuple[float, float, float],
    end: tuple[float, float, float],
    centre: tuple[float, float],
    clockwise: bool,
) -> float:
    """How far an arc turns (radians, in (0, 2π]; ends that meet: a full circle)."""
    a0 = math.atan2(start[1] - centre[1], start[0] - centre[0])
    a1 = math.atan2(end[1] - centre[1], end[0] - centre[0])
    turn = (a0 - a1) if clockwise else (a1 - a0)
    turn %= 2 * math.pi
    return turn if turn > 1e-9 else 2 * math.pi


def _bulge(arc: Cut) -> float:
    """How far an arc of at most half a turn strays from its chord (mm)."""
    assert arc.centre is not None
    return math.dist(arc.start[:2], arc.centre) * (1 - math.cos(arc.sweep / 2))


def assert_same_cuts(expected: list[Cut], actual: list[Cut], tol: float, feed_tol: float) -> None:
    """The two cut paths are the same moves in order: ends, starts and centres within `tol`
    (mm), arcs in one direction turning alike (their lengths within a few `tol`), feeds
    within `feed_tol` (mm/min). Within what blocks in steps of `tol` can hold:

    - a straight move no longer than two steps in any axis may be missing on either side
      (rounded to the steps, its ends may meet; the next move starts where it went);
    - an arc so small that it strays no more than `tol` from its chord may be that chord;
    - an arc's end and centre may be two steps off: its centre is rounded to the steps as
      its ends are, and the end on its start's radius moves with it (a short move then goes
      on to the end the blocks hold, within a step of the file's);
    - a plunge may start feeding higher than the file's (a mill sequence's depth change
      feeds from the depth before, at FEEDR Z), never lower — no rapid goes deeper — than
      the bottom our program has already cut there (a DRILL's peck goes back down to the
      level just reached, where G83 stops 0.010 in above it).

    Fails naming the first move that differs."""
    i = j = 0
    slack = tol  # how far a start may be: more just after a short move left out
    while i < len(expected) and j < len(actual):
        e, a = expected[i], actual[j]
        before = actual[j - 1] if j else None
        floor = before.end[2] if before and before.vertical and _same_xy(before, a) else None
        problem = _differs(e, a, tol, slack, feed_tol, floor)
        if problem and _short(e, 2 * tol):
            i, slack = i + 1, 3 * tol
            continue
        if problem and _short(a, 2 * tol):
            j, slack = j + 1, 3 * tol
            continue
        assert not problem, (
            f"cut {i} of {len(expected)} ({problem}): rs274 reads the file as {e}, our program {a}"
        )
        i, j, slack = i + 1, j + 1, tol
    rest = [c for c in expected[i:] if not _short(c, 2 * tol)]
    extra = [c for c in actual[j:] if not _short(c, 2 * tol)]
    assert not rest and not extra, (
        f"rs274 reads {len(expected)} cuts in the file, {len(actual)} in our program; "
        f"left over: {rest[:1] or extra[:1]}"
    )


def _same_xy(a: Cut, b: Cut) -> bool:
    return a.end[:2] == b.start[:2]


def _short(cut: Cut, length: float) -> bool:
    return cut.centre is None and all(
        abs(p - q) <= length for p, q in zip(cut.start, cut.end, strict=True)
    )


def _differs(
    e: Cut, a: Cut, tol: float, slack: float, feed_tol: float, floor: float | None = None
) -> str:
    """What differs between two cuts (see `assert_same_cuts`), or "" when nothing does.
    `floor`: how deep our program has already cut at this X/Y (the last peck's bottom)."""
    if (e.centre is None) != (a.centre is None):
        arc = e if a.centre is None else a
        if arc.sweep > math.pi or _bulge(arc) > tol:
            return "an arc and a line"
    # An arc's centre is rounded to the step as its ends are: the end it reaches on its
    # start's radius may be two steps from the file's (the next step's short move goes on).
    reach = 2 * tol if e.centre is not None and a.centre is not None else tol
    ends_near = all(abs(p - q) <= reach for p, q in zip(e.end, a.end, strict=True))
    starts_near = all(abs(p - q) <= slack for p, q in zip(e.start, a.start, strict=True))
    if not starts_near and e.vertical and a.vertical:
        starts_near = all(
            abs(p - q) <= slack for p, q in zip(e.start[:2], a.start[:2], strict=True)
        ) and (a.start[2] >= e.start[2] - tol or (floor is not None and a.start[2] >= floor - tol))
    if not (ends_near and starts_near):
        return "ends"
    if e.centre is not None and a.centre is not None:
        if any(abs(p - q) > reach for p, q in zip(e.centre, a.centre, strict=True)):
            return "centres"
        if e.clockwise != a.clockwise:
            return "directions"
        radius = math.dist(e.start[:2], e.centre)
        if abs(e.sweep - a.sweep) * radius > 3 * tol:
            return "sweeps"
    if abs(e.feed - a.feed) > feed_tol:
        return "feeds"
    return ""


def referee_import(
    data: bytes,
    tmp_path: Path,
    name: str = "file",
    diameters: dict[int, float] | None = None,
    as_rs274_reads: bytes | None = None,
    any_order: bool = False,
) -> ImportResult:
    """Import G-code `data`, export the program to LinuxCNC's G-code, and have rs274 read
    both: the cut paths (`cut_path`) must agree within what the blocks hold — lengths to
    0.001 in / 0.01 mm, feeds to 0.1 ipm / 2 mm/min (the control's steps). The spindle
    speeds are exported as the file gives them, checked against no machine's range; the
    tool table's `diameters` (inches) are what G41/G42 in the file offset by. Returns the
    import; fails naming the first cut that differs (ImportFailure if it is refused).
    `as_rs274_reads`: the file as rs274 is given it, when it refuses a line the import
    reports as not carried (another control's M code). `any_order`: the cuts compared as a
    set (holes a file drills counter-clockwise, a BOLT CIR drills clockwise)."""
    result = read_program(data, name, "gcode")
    exported = export(result.program, "gcode-linuxcnc", {"spindle-speeds": "by-hand"}).data
    original, ours = tmp_path / f"{name}-original.ngc", tmp_path / f"{name}-ours.ngc"
    # rs274 refuses a UTF-8 byte-order mark (an editor on Windows writes one); the
    # importer reads past it. The G-code after it is the same.
    original.write_bytes(
        (data if as_rs274_reads is None else as_rs274_reads).removeprefix(b"\xef\xbb\xbf")
    )
    ours.write_bytes(exported)
    metric = result.program.units is Units.MM
    tol = (0.01 if metric else 0.0254) + 1e-6
    feed_tol = (2.0 if metric else 2.54) + 1e-6
    theirs = cut_path(rs274(original, diameters=diameters, in_mm=True, changes=True))
    mine = cut_path(rs274(ours, in_mm=True, changes=True))
    if any_order:
        theirs, mine = sorted(theirs, key=_cut_key), sorted(mine, key=_cut_key)
    assert_same_cuts(theirs, mine, tol, feed_tol)
    return result


def _cut_key(cut: Cut) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """A cut's place, rounded below the comparison's tolerance (for `any_order`)."""
    return tuple(round(v, 2) for v in cut.end), tuple(round(v, 2) for v in cut.start)
