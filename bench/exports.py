"""Export: every target of the registry (G-code dialects, the 1704 tapes and punch images,
the tape picture, the BOSS tape, ProtoTRAK Plus events, the document, the tool-path picture,
the canonical listing) for 10^5 and 10^6 moves, time, CPU and peak memory, against
LinuxCNC's `rs274 -g` reading the G-code in the same run.

Each case is a fresh child calling `export(program, target, out=file)` as the CLI does:
COPY resolution, the compile (with its findings), and the target writing to the file as it
goes. *compile only* is the compile alone in its own child, the part every target shares.
The baseline is LinuxCNC's interpreter in batch mode reading the G-code file the export
just wrote (`bench.gcode_import.rs274_case`: the faster of two runs, canonical calls to
/dev/null; rs274 must accept the file). Wall and CPU seconds are both given: on a shared
machine CPU time is the steadier comparison. A target that refuses the program (the
ProtoTRAK Plus's 999 events) says why, and is measured on the first other family it takes.

Targets (issue 18): export of 10^6 moves to LinuxCNC no slower than rs274 reads the output;
peak memory at most 100 MB for every target at 10^6 moves (peak resident size of the child
above what it held before the call, the program's blocks already built).
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

from bench.common import (
    Result,
    Section,
    fmt_bytes,
    fmt_count,
    fmt_ratio,
    fmt_seconds,
    measure,
    run_child,
    table,
)

SIZES = (100_000, 1_000_000)
REFEREED = "gcode-linuxcnc"
FAMILY = "grid"
MEMORY_GOAL = 100_000_000  # bytes


def export_case(family: str, moves: int, target: str) -> Result:
    """(child) Export a `family` program of about `moves` moves to `target`, streaming to a
    file; for the refereed target, rs274 then reads that file."""
    from app.cnc.formats.targets import ExportError, export, targets
    from bench.gcode_import import rs274_case
    from bench.programs import sized

    targets()  # import every emitter module first: its import is no part of an export
    program = sized(family, moves)
    with tempfile.TemporaryDirectory() as tmp:
        file = Path(tmp) / "out"
        with file.open("wb") as out:
            cpu = time.process_time()
            try:
                done, seconds, peak = measure(lambda: export(program, target, out=out))
            except ExportError as error:
                report = error.report.text().splitlines() if error.report else []
                reasons = [line.strip() for line in report if line.strip().startswith("error")]
                return {"refused": "; ".join(reasons) or str(error)}
            cpu = time.process_time() - cpu
        data = file.read_bytes()
        result: Result = {
            "seconds": seconds,
            "cpu": cpu,
            "peak": peak,
            "bytes": len(data),
            "lines": data.count(b"\n") + data.count(b"\r"),
            "report": len(done.report.entries),
        }
        del data
        if target == REFEREED:
            result["rs274"] = rs274_case(str(file))
    return result


def compile_case(family: str, moves: int) -> Result:
    """(child) COPY resolution and the compile alone, walking every chunk once."""
    from app.cnc.compiler import compile_program
    from app.cnc.copy import resolve_copies
    from bench.programs import sized

    program = sized(family, moves)

    def compiled() -> int:
        path = compile_program(resolve_copies(program)).path
        return sum(len(chunk.rows) for chunk in path.chunks())

    cpu = time.process_time()
    rows, seconds, peak = measure(compiled)
    return {"moves": rows, "seconds": seconds, "cpu": time.process_time() - cpu, "peak": peak}


# The program and the pair of targets of issue 32's goal: events against LinuxCNC G-code,
# each written from the same compile (the events writer used to plan the POCKET again).
WARM_PROGRAM = "tests/golden/pocket-islands/program.json"
WARM_TARGETS = ("gcode-linuxcnc", "events")
WARM_GOAL = 2.0


def warm_pair_case(repeats: int = 5) -> Result:
    """(child) Export `WARM_PROGRAM` to each of `WARM_TARGETS` on a warm compile cache (the
    program compiled and each target written once before timing, as the editor's export
    page finds it), in one process: the best of `repeats` calls of each, interleaved so
    the machine's load falls on both alike, and the load average beside them."""
    from app.cnc import document
    from app.cnc.compiler import compile_program
    from app.cnc.copy import resolve_copies
    from app.cnc.formats.targets import export, targets
    from bench.common import ROOT

    targets()
    text = (ROOT / WARM_PROGRAM).read_text(encoding="utf-8")
    program = resolve_copies(document.loads(text))
    compile_program(program)
    best = dict.fromkeys(WARM_TARGETS, float("inf"))
    for target in WARM_TARGETS:
        export(program, target)
    for _ in range(repeats):
        for target in WARM_TARGETS:
            start = time.perf_counter()
            export(program, target)
            best[target] = min(best[target], time.perf_counter() - start)
    return {**best, "load": os.getloadavg()[0]}


def _warm_pair(section: Section, timeout: float) -> None:
    """The events export of `WARM_PROGRAM` against its LinuxCNC export (issue 32's goal)."""
    r = run_child("bench.exports:warm_pair_case", {}, timeout)
    gcode, events = WARM_TARGETS
    name = f"`{WARM_PROGRAM.split('/')[-2]}`"
    if "error" in r:
        section.lines += ["", f"Warm-cache pair ({name}): failed: {r['error']}"]
        return
    ratio = r[events] / r[gcode]
    section.lines += [
        "",
        f"Warm-cache pair ({name}, one process, the compile cached, best of 5 each, "
        f"load average {r['load']:.2f}): what each target costs beyond the compile they share.",
        "",
        *table(
            ["target", "time", f"× `{gcode}`"],
            [
                [f"`{gcode}`", fmt_seconds(r[gcode]), "1×"],
                [f"`{events}`", fmt_seconds(r[events]), fmt_ratio(ratio)],
            ],
        ),
    ]
    section.target(
        f"`{events}` export of {name} against `{gcode}`, warm compile cache",
        f"≤ {WARM_GOAL:g}×",
        f"{fmt_seconds(r[events])} against {fmt_seconds(r[gcode])} (load {r['load']:.2f})",
        f"{fmt_ratio(ratio)} ({'met' if ratio <= WARM_GOAL else 'not met'})",
    )


def _refused(reason: str) -> str:
    """A refusal as a table cell: the target's first reason, without its severity."""
    return "refused: " + reason.split(";")[0].removeprefix("error: ")


def run(sizes: tuple[int, ...] = SIZES, timeout: float = 420.0) -> Section:
    from app.cnc.formats.targets import targets
    from bench.programs import FAMILIES

    names = tuple(targets())
    section = Section(f"Export: every target ({FAMILY} family)")
    rows: list[list[str]] = []
    largest: dict[str, Result] = {}
    for size in sizes:
        args = {"family": FAMILY, "moves": size}
        base = run_child("bench.exports:compile_case", args, timeout)
        if "error" in base:
            rows.append([f"{fmt_count(size)} moves", f"failed: {base['error']}"] + [""] * 6)
            continue
        moves = base["moves"]
        rows.append(
            [
                f"compile only ({fmt_count(moves)} moves)",
                fmt_seconds(base["seconds"]),
                fmt_seconds(base["cpu"]),
                "",
                "",
                fmt_bytes(base["peak"]),
                "",
                "",
            ]
        )
        for target in names:
            r = run_child("bench.exports:export_case", {**args, "target": target}, timeout)
            case = f"`{target}`"
            if "refused" in r:
                # A target that cannot take this program (the Plus's 999 events) is
                # measured on the first other family it takes, at the same size.
                rows.append([case, _refused(r["refused"])] + [""] * 6)
                for family in (f for f in FAMILIES if f != FAMILY):
                    other = {"family": family, "moves": size, "target": target}
                    r = run_child("bench.exports:export_case", other, timeout)
                    if "refused" not in r:
                        case = f"`{target}`, {family} family"
                        r["family"] = family
                        break
            if "error" in r or "refused" in r:
                problem = f"failed: {r['error']}" if "error" in r else _refused(r["refused"])
                rows.append([case, problem] + [""] * 6)
                if size == sizes[-1]:
                    largest[target] = {**r, "moves": moves}
                continue
            referee: Result = r.get("rs274", {})
            ratios = ["", ""]
            if "seconds" in referee:
                ratios = [
                    fmt_ratio(r["seconds"] / referee["seconds"]),
                    fmt_ratio(r["cpu"] / referee["cpu"]),
                ]
            rows.append(
                [
                    case,
                    fmt_seconds(r["seconds"]),
                    fmt_seconds(r["cpu"]),
                    *ratios,
                    fmt_bytes(r["peak"]),
                    fmt_bytes(r["bytes"]),
                    fmt_count(r["lines"]),
                ]
            )
            if "seconds" in referee:
                rows.append(
                    [
                        "LinuxCNC `rs274 -g` reading it (baseline)",
                        fmt_seconds(referee["seconds"]),
                        fmt_seconds(referee["cpu"]),
                        "1×",
                        "1×",
                        "",
                        "",
                        fmt_count(referee["lines"]),
                    ]
                )
            elif referee:
                said = referee.get("error") or referee.get("unavailable")
                rows.append(["LinuxCNC `rs274 -g`", str(said)] + [""] * 6)
            if size == sizes[-1]:
                largest[target] = {**r, "moves": moves}
    section.lines += [
        "*time* and *CPU* are the whole `export()` call writing to a file (COPY resolution,",
        "the compile and the target), wall and user + system seconds; *× rs274* compares",
        "them with LinuxCNC's `rs274 -g` reading the G-code file the export wrote, same run.",
        "*Peak memory* is the child's peak resident size above what it held before the call.",
        "*lines* counts line ends (a punch image has none; an SVG is a few long lines).",
        "",
        *table(
            [
                "case",
                "time",
                "CPU",
                "× rs274 (wall)",
                "× rs274 (CPU)",
                "peak memory",
                "output",
                "lines",
            ],
            rows,
        ),
    ]
    _targets(section, largest, names)
    _warm_pair(section, timeout)
    return section


def _targets(section: Section, largest: dict[str, Result], names: tuple[str, ...]) -> None:
    """The Targets rows: memory of every target at the largest size (the worst named), and
    the G-code export against rs274."""
    measured = {name: r for name, r in largest.items() if "peak" in r}
    if measured:
        moves = fmt_count(next(iter(measured.values()))["moves"])
        worst = max(measured, key=lambda name: measured[name]["peak"])
        over = sorted(name for name, r in measured.items() if r["peak"] > MEMORY_GOAL)
        refused = sorted(name for name, r in largest.items() if "refused" in r)
        failed = sorted(set(names) - set(measured) - set(refused))
        said = [
            f"{len(measured) - len(over)} of {len(measured)} within; worst `{worst}` "
            f"{fmt_bytes(measured[worst]['peak'])}"
        ]
        said += [f"over: {', '.join(f'`{n}`' for n in over)}"] if over else []
        said += [f"refuse the program: {', '.join(f'`{n}`' for n in refused)}"] if refused else []
        elsewhere = sorted(
            f"`{n}` on the {r['family']} family" for n, r in measured.items() if "family" in r
        )
        said += [f"measured {', '.join(elsewhere)}"] if elsewhere else []
        said += [f"not measured: {', '.join(f'`{n}`' for n in failed)}"] if failed else []
        section.target(
            f"every export target, {moves} moves (peak memory)",
            "≤ 100 MB each",
            "; ".join(said),
            "met" if not over and not failed else "not met",
        )
    r = largest.get(REFEREED, {})
    referee = r.get("rs274", {})
    if "seconds" in referee:
        section.target(
            f"`{REFEREED}` export against rs274 reading it, {fmt_count(r['moves'])} moves",
            "≤ 1× rs274",
            f"{fmt_seconds(r['seconds'])} (CPU {fmt_seconds(r['cpu'])}) against "
            f"{fmt_seconds(referee['seconds'])} (CPU {fmt_seconds(referee['cpu'])})",
            f"{fmt_ratio(r['seconds'] / referee['seconds'])} wall, "
            f"{fmt_ratio(r['cpu'] / referee['cpu'])} CPU",
        )
