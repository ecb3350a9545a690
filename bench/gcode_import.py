"""G-code import: lines per second of our reader (+ compiler) against LinuxCNC's
`rs274 -g` and pygcode, on the same 100 000-line file.

The file is written here, deterministically, in the style of our gcode-linuxcnc target
(G20, G54 set by G10 L2, tool lengths by G10 L1 + G43 H): a grid of cells, each a bolt
circle of G82 drilled holes, a pecked hole written as explicit moves, a circle pocket with
G3 arcs and a short G1/G2 contour. The grid is COLUMNS x ROWS cells (about 120 000
lines), cut again from its first cell when a file is longer, so every coordinate of a file
of any size stays inside the ±99.999 in a dimension may have (app.cnc.limits). It is
padded with single-axis G1 moves to exactly the line count. rs274 must accept it (its exit
status is checked), so all three readers see a valid program.

- ours: `app.cnc.formats.reading.read_as` with the G-code importer (parse, motion, recognition of
  data blocks; without the web's and CLI's size limits), then `compile_program()` of the
  program it returns — as the installed app runs it: the wheel with the importer compiled
  by mypyc (`make wheel-native`, built and installed into a fresh environment by
  `bench.common.installed_wheel`), and again from the same wheel's sources
  (MILLBLOCKS_NATIVE=0) for the compiled build's own ratio. Each is the faster of two
  fresh processes, as rs274 is. Whole `millblocks` processes are in bench/cli.py.
- rs274: LinuxCNC's interpreter in batch mode (`-g`), canonical calls to /dev/null; wall
  time of the process (its start-up, ~20 ms, is included and reported).
- pygcode 0.2.1: `Line(text)` per line and `Machine.process_block` (its own interpreter);
  stopped after a time limit, the rate taken on the lines it got through.

Target (issue 10): our import at least as fast as rs274.
"""

from __future__ import annotations

import math
import resource
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

from bench.common import (
    InstalledWheel,
    Result,
    Section,
    fmt_bytes,
    fmt_count,
    fmt_rate,
    fmt_ratio,
    fmt_seconds,
    installed_wheel,
    measure,
    run_child,
    table,
)

LINES = 100_000
# The grid of cells: centres at X 2 to 90.2 in, Y 2 to 96.4 in (a cell reaches 1 in further
# in X, 0.5 in in Y; G54 adds 1 in), so no coordinate passes 99.999 in.
COLUMNS, ROWS = 50, 60
PYGCODE_LIMIT = 60.0

HEADER = [
    "%",
    "(BENCH IMPORT PART 1 MILLBLOCKS)",
    "G17 G20 G40 G80 G90 G94",
    "G10 L2 P1 X1.0000 Y1.0000 Z0",
    "G54",
    "G10 L1 P1 Z0.0000 R0.1250",
    "G43 H1",
    "G0 Z0.1000",
    "S1200 M3",
]
FOOTER = ["G0 Z0.2000", "M5", "M30", "%"]


def _f(value: float) -> str:
    return f"{value:.4f}"


def _cell(cx: float, cy: float) -> list[str]:
    """One cell of work around (cx, cy): 8-hole bolt circle, pecked hole, pocket, contour."""
    lines = ["G0 Z0.2000", f"X{_f(cx)} Y{_f(cy - 0.5)}"]
    for k in range(8):
        angle = math.radians(k * 45.0)
        x, y = cx - 0.5 * math.sin(angle), cy - 0.5 * math.cos(angle)
        if k == 0:
            lines.append(f"G98 G82 X{_f(x)} Y{_f(y)} R0.1000 Z-0.2000 P0.8 F5.0")
        else:
            lines.append(f"X{_f(x)} Y{_f(y)}")
    lines += ["G80", f"G0 X{_f(cx)} Y{_f(cy)}", "Z0.1000"]
    for level in (-0.1, -0.2, -0.3):
        lines += [f"G1 Z{_f(level)} F4.5", "G0 Z0.1000", f"Z{_f(level)}"]
    lines += [
        "G0 Z0.2000",
        f"X{_f(cx + 0.875)} Y{_f(cy - 0.125)}",
        "Z0.1000",
        "G1 Z-0.2500 F4.0",
        f"G3 X{_f(cx + 1.0)} Y{_f(cy - 0.25)} I0.1250 J0.0000 F9.0",
        f"X{_f(cx + 1.0)} Y{_f(cy - 0.25)} I0.0000 J0.2500",
        f"G1 Y{_f(cy)}",
        "G0 Z0.2000",
        f"X{_f(cx - 0.75)} Y{_f(cy + 0.5)}",
        "Z0.1000",
        "G1 Z-0.1000 F4.0",
        f"X{_f(cx - 0.25)} Y{_f(cy + 0.5)} F8.0",
        f"G2 X{_f(cx)} Y{_f(cy + 0.25)} I0.0000 J-0.2500",
        f"G1 X{_f(cx)} Y{_f(cy + 0.1)}",
    ]
    return lines


def gcode_text(lines: int = LINES) -> str:
    """The benchmark's G-code file, exactly `lines` lines long."""
    body: list[str] = []
    room = lines - len(HEADER) - len(FOOTER)
    k = 0
    while True:
        cell = _cell(2.0 + 1.8 * (k % COLUMNS), 2.0 + 1.6 * (k // COLUMNS % ROWS))
        if len(body) + len(cell) > room:
            break
        body += cell
        k += 1
    step = 0
    while len(body) < room:
        step += 1
        body.append(
            f"G1 X{_f(1.0 + 0.001 * step)} F8.0" if step == 1 else f"X{_f(1.0 + 0.001 * step)}"
        )
    return "\n".join([*HEADER, *body, *FOOTER]) + "\n"


def write_file(directory: Path, lines: int = LINES) -> Path:
    path = directory / f"bench-{lines}.ngc"
    path.write_text(gcode_text(lines))
    return path


# -- the readers (each in its own child process) -----------------------------------------


def ours_case(path: str) -> Result:
    """(child; `run` takes the faster of two) Our reader (`imports.read_as` with the
    G-code importer: the web's and the CLI's size limits are theirs, not the reader's),
    then the compiler on the program it returns."""
    from app.cnc import native
    from app.cnc.compiler import compile_program
    from app.cnc.formats.importers import get_importer
    from app.cnc.formats.reading import read_as

    data = Path(path).read_bytes()
    importer = get_importer("gcode")
    cpu = time.process_time()
    (program, _notes), seconds, peak = measure(lambda: read_as(importer, data, Path(path).name, {}))
    started = time.perf_counter()
    compiled = compile_program(program)
    moves = len(compiled.path)
    compile_seconds = time.perf_counter() - started
    return {
        "lines": data.count(b"\n"),
        "seconds": seconds,
        "cpu": time.process_time() - cpu,
        "compile_seconds": compile_seconds,
        "peak": peak,
        "blocks": len(program.blocks),
        "moves": moves,
        "compiled": sorted(set(native.status().values())) == ["compiled"],
    }


def ours_runs(
    args: dict[str, str], timeout: float, env: dict[str, str], installed: InstalledWheel | None
) -> list[Result]:
    """Ours in two fresh children, as rs274 is run twice: the same treatment for both."""
    target = "bench.gcode_import:ours_case"
    return [run_child(target, args, timeout, env, installed) for _ in range(2)]


def faster(results: list[Result]) -> Result:
    """The run with the shorter total time (read + compile); a failed run if both failed."""
    done = [r for r in results if "seconds" in r]
    if not done:
        return results[0]
    return min(done, key=lambda r: r["seconds"] + r["compile_seconds"])


def children_cpu() -> float:
    """CPU seconds (user + system) used so far by this process's finished children."""
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    return used.ru_utime + used.ru_stime


def rs274_case(path: str) -> Result:
    """(child) LinuxCNC's rs274 in batch mode; the file must be accepted. Wall and CPU
    seconds of the faster of two runs."""
    rs274 = shutil.which("rs274")
    if rs274 is None:
        return {"unavailable": "rs274 is not installed (Debian linuxcnc-uspace)"}
    with tempfile.TemporaryDirectory() as tmp:
        table_file = Path(tmp) / "tools.tbl"
        table_file.write_text("".join(f"T{n} P{n} Z0.0000 D0.2500 ;\n" for n in range(1, 25)))
        empty = Path(tmp) / "empty.ngc"
        empty.write_text("%\nM2\n%\n")

        def run(file: Path) -> tuple[float, float, subprocess.CompletedProcess[bytes]]:
            cpu = children_cpu()
            started = time.perf_counter()
            done = subprocess.run(
                [rs274, "-t", str(table_file), "-g", str(file)],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.PIPE,
                timeout=300,
                check=False,
            )
            return time.perf_counter() - started, children_cpu() - cpu, done

        startup = min(run(empty)[0] for _ in range(3))
        seconds, cpu, done = min((run(Path(path)) for _ in range(2)), key=lambda r: r[0])
    errors = done.stderr.decode(errors="replace").strip()
    if done.returncode != 0 or "error" in errors.lower():
        return {"error": f"rs274 refused the file: {errors.splitlines()[-1] if errors else ''}"}
    return {
        "lines": Path(path).read_text().count("\n"),
        "seconds": seconds,
        "cpu": cpu,
        "startup": startup,
    }


def pygcode_case(path: str, limit: float = PYGCODE_LIMIT) -> Result:
    """(child) pygcode: parse every line and run it through its Machine, for at most
    `limit` seconds."""
    try:
        import pygcode
    except ImportError:
        return {"unavailable": "pygcode is not installed (pip install -r bench/requirements.txt)"}
    lines = Path(path).read_text().splitlines()
    machine = pygcode.Machine()
    done = 0
    failures = 0
    first_failure = ""
    started = time.perf_counter()
    for text in lines:
        try:
            line = pygcode.Line(text)
            if line.block.words:
                machine.process_block(line.block)
        except Exception as exc:  # pygcode raises many kinds; count them, go on
            failures += 1
            first_failure = first_failure or f"{type(exc).__name__}: {exc}"[:100]
        done += 1
        if done % 500 == 0 and time.perf_counter() - started > limit:
            break
    seconds = time.perf_counter() - started
    return {
        "lines": done,
        "of": len(lines),
        "seconds": seconds,
        "failures": failures,
        "first_failure": first_failure,
        "version": pygcode.__version__,
    }


SIZES = (10_000, 100_000, 1_000_000)


def run(sizes: tuple[int, ...] = SIZES, timeout: float = 600.0) -> Section:
    """rs274 and ours on files of each size (linear: the same µs per line at every size),
    pygcode on the 100 000-line file only (its time limit would cut the others short)."""
    section = Section("G-code import: " + ", ".join(fmt_count(n) for n in sizes) + " lines")
    try:
        installed: InstalledWheel | None = installed_wheel()
    except subprocess.SubprocessError as error:
        section.lines.append(f"(the compiled wheel could not be built: {error})")
        installed = None
    rows: list[list[str]] = []
    headline: tuple[float, float, float, float] | None = None
    for lines in sizes:
        with tempfile.TemporaryDirectory() as tmp:
            path = write_file(Path(tmp), lines)
            size = path.stat().st_size
            args = {"path": str(path)}
            results = {
                "rs274": run_child("bench.gcode_import:rs274_case", args, timeout),
                "ours": faster(ours_runs(args, timeout, {}, installed)),
                "sources": faster(ours_runs(args, timeout, {"MILLBLOCKS_NATIVE": "0"}, installed)),
            }
            if lines == LINES:
                results["pygcode"] = run_child(
                    "bench.gcode_import:pygcode_case", {**args, "limit": PYGCODE_LIMIT}, timeout
                )
        referee = results["rs274"]
        base = referee["lines"] / referee["seconds"] if "seconds" in referee else float("nan")
        base_cpu = referee["lines"] / referee["cpu"] if "cpu" in referee else float("nan")
        for name, r in results.items():
            label = {
                "rs274": "LinuxCNC `rs274 -g` (baseline)",
                "ours": "ours: `read_as` + `compile_program`",
                "sources": "ours, from the sources (`MILLBLOCKS_NATIVE=0`)",
                "pygcode": "pygcode `Line` + `Machine.process_block`",
            }[name]
            if "unavailable" in r or "error" in r:
                reason = r.get("unavailable") or r.get("error")
                shown = "**not available**" if "unavailable" in r else "**failed**"
                rows.append([fmt_count(lines), label, f"{shown}: {reason}", "", "", "", "", "", ""])
                continue
            seconds = r["seconds"] + r.get("compile_seconds", 0.0)
            rate = r["lines"] / seconds
            detail = ""
            if name == "rs274":
                detail = f"{fmt_bytes(size)}; process start-up {fmt_seconds(r['startup'])} included"
            elif name in ("ours", "sources"):
                detail = (
                    f"read {fmt_seconds(r['seconds'])} → {r['blocks']} blocks, compile "
                    f"{fmt_seconds(r['compile_seconds'])} → {fmt_count(r['moves'])} moves; "
                    f"peak {fmt_bytes(r['peak'])}"
                )
                if name == "ours":
                    built = "compiled" if r["compiled"] else "**not compiled** (no compiled wheel)"
                    detail = f"{built}; {detail}"
                if name == "ours" and lines == LINES:
                    headline = (seconds, r["cpu"], referee["seconds"], referee["cpu"])
            elif name == "pygcode":
                detail = (
                    f"pygcode {r['version']}; {fmt_count(r['lines'])} of {fmt_count(r['of'])} lines"
                )
                if r["lines"] < r["of"]:
                    detail += f" in the {PYGCODE_LIMIT:.0f} s limit"
                if r["failures"]:
                    detail += f"; {fmt_count(r['failures'])} lines raised ({r['first_failure']})"
            per_line = f"{seconds / r['lines'] * 1e6:.1f} µs"
            cpu = r.get("cpu")
            rows.append(
                [
                    fmt_count(lines),
                    label,
                    fmt_seconds(seconds),
                    "" if cpu is None else fmt_seconds(cpu),
                    fmt_rate(rate),
                    per_line,
                    fmt_ratio(rate / base),
                    "" if cpu is None else fmt_ratio(r["lines"] / cpu / base_cpu),
                    detail,
                ]
            )
    section.lines += [
        "Files written by `bench/gcode_import.py` (bolt circles in G82, pecked holes, G3",
        "pockets, G1/G2 contours, padded with single-axis moves); *× rs274* is lines per",
        "second over rs274's on the same file in the same run, by wall time and by CPU time",
        "(user + system: less moved by other work on the machine); *per line* shows",
        "linearity. *Ours* is the importer as the app runs it, compiled by mypyc",
        "(app/cnc/native.py); *from the sources* is the same code interpreted.",
        "",
        *table(
            [
                "lines",
                "reader",
                "time",
                "CPU",
                "lines/s",
                "per line",
                "× rs274 (wall)",
                "× rs274 (CPU)",
                "notes",
            ],
            rows,
        ),
    ]
    if headline is not None:
        ours, ours_cpu, theirs, theirs_cpu = headline
        section.target(
            "G-code import, 100 000 lines",
            "≥ rs274",
            f"{fmt_seconds(ours)} (CPU {fmt_seconds(ours_cpu)}) against "
            f"{fmt_seconds(theirs)} (CPU {fmt_seconds(theirs_cpu)})",
            f"{fmt_ratio(theirs / ours)} wall, {fmt_ratio(theirs_cpu / ours_cpu)} CPU",
        )
    else:
        section.target("G-code import, 100 000 lines", "≥ rs274", "not available", "–")
    return section
