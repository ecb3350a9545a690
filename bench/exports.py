"""Export: LinuxCNC G-code and Tektronix 1704 tape (EIA listing) for 10^5 and 10^6 moves,
time and peak memory, against LinuxCNC's `rs274 -g` reading the G-code in the same run.

Each case is a fresh child calling `export(program, target, out=file)` as the CLI does:
COPY resolution, the compile (with its findings), and the target writing to the file as it
goes. *compile only* is the compile alone in its own child, the part every target shares.
The baseline is LinuxCNC's interpreter in batch mode reading the G-code file the export
just wrote (`bench.gcode_import.rs274_case`: the faster of two runs, canonical calls to
/dev/null; rs274 must accept the file). Wall and CPU seconds are both given: on a shared
machine CPU time is the steadier comparison.

Targets (issue 18): export of 10^6 moves to LinuxCNC no slower than rs274 reads the output;
peak memory at most 100 MB for every target at 10^6 moves (peak resident size of the child
above what it held before the call, the program's blocks already built).
"""

from __future__ import annotations

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
TARGETS = ("gcode-linuxcnc", "tape-eia")
REFEREED = "gcode-linuxcnc"
FAMILY = "grid"
MEMORY_GOAL = 100_000_000  # bytes


def export_case(family: str, moves: int, target: str) -> Result:
    """(child) Export a `family` program of about `moves` moves to `target`, streaming to a
    file; for the refereed target, rs274 then reads that file."""
    from app.cnc.emit.target import export, targets
    from bench.gcode_import import rs274_case
    from bench.programs import sized

    targets()  # import every emitter module first: its import is no part of an export
    program = sized(family, moves)
    with tempfile.TemporaryDirectory() as tmp:
        file = Path(tmp) / "out"
        with file.open("wb") as out:
            cpu = time.process_time()
            done, seconds, peak = measure(lambda: export(program, target, out=out))
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


def run(sizes: tuple[int, ...] = SIZES, timeout: float = 420.0) -> Section:
    section = Section(f"Export: 1704 tape and G-code ({FAMILY} family)")
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
        for target in TARGETS:
            r = run_child("bench.exports:export_case", {**args, "target": target}, timeout)
            if "error" in r:
                rows.append([f"`{target}`", f"failed: {r['error']}"] + [""] * 6)
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
                    f"`{target}`",
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
                problem = referee.get("error") or referee.get("unavailable")
                rows.append(["LinuxCNC `rs274 -g`", str(problem)] + [""] * 6)
            largest[target] = {**r, "moves": moves}
    section.lines += [
        "*time* and *CPU* are the whole `export()` call writing to a file (COPY resolution,",
        "the compile and the target), wall and user + system seconds; *× rs274* compares",
        "them with LinuxCNC's `rs274 -g` reading the G-code file the export wrote, same run.",
        "*Peak memory* is the child's peak resident size above what it held before the call.",
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
    for target, r in largest.items():
        moves = fmt_count(r["moves"])
        section.target(
            f"`{target}` export, {moves} moves",
            "peak ≤ 100 MB",
            f"{fmt_seconds(r['seconds'])}, peak {fmt_bytes(r['peak'])}",
            "met" if r["peak"] <= MEMORY_GOAL else "not met",
        )
        referee = r.get("rs274", {})
        if "seconds" in referee:
            section.target(
                f"`{target}` export against rs274 reading it, {moves} moves",
                "≤ 1× rs274",
                f"{fmt_seconds(r['seconds'])} (CPU {fmt_seconds(r['cpu'])}) against "
                f"{fmt_seconds(referee['seconds'])} (CPU {fmt_seconds(referee['cpu'])})",
                f"{fmt_ratio(r['seconds'] / referee['seconds'])} wall, "
                f"{fmt_ratio(r['cpu'] / referee['cpu'])} CPU",
            )
    return section
