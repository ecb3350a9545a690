"""Export: Tektronix 1704 tape (EIA listing) and LinuxCNC G-code for 10^5 and 10^6 moves,
time and peak memory, against floors measured in the same run.

Each case is a fresh child calling `export(program, target)` (COPY resolution, validation,
interpretation and the emitter: what the CLI and the download do). The interpreter alone
is measured in its own child on the same program, so the emitter's share of time and
memory is the difference. Floors, in one child: a plain writer that formats every motion
as a G-code line (`G1 X… Y… Z…` with fixed decimals) into a list and joins it, and the
same writer streaming to a file: the memory a writer needs beyond the tool path when it
builds its output in memory, and when it does not.

Target (issue 10): exports in constant memory, i.e. the emitter's extra peak per move
falling toward zero as the program grows.
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
TARGETS = ("tape-eia", "gcode-linuxcnc")
FAMILY = "grid"


def export_case(family: str, moves: int, target: str) -> Result:
    """(child) Export a `family` program of about `moves` moves to `target`."""
    from app.cnc.emit.target import export, targets
    from bench.programs import sized

    targets()  # import every emitter module first: its import is no part of an export
    program = sized(family, moves)
    result, seconds, peak = measure(lambda: export(program, target))
    return {
        "seconds": seconds,
        "peak": peak,
        "bytes": len(result.data),
        "lines": result.data.count(b"\n") + result.data.count(b"\r"),
        "report": len(result.report.entries),
    }


def _lines(toolpath: object) -> list[str]:
    from app.cnc.toolpath import MOTION_TYPES, Toolpath

    assert isinstance(toolpath, Toolpath)
    unit = toolpath.units.nm
    return [
        f"G1 X{m.x / unit:.4f} Y{m.y / unit:.4f} Z{m.z / unit:.4f}"
        for m in toolpath.moves
        if isinstance(m, MOTION_TYPES)
    ]


def floor_case(family: str, moves: int) -> Result:
    """(child) The plain writer, in memory then streaming, after interpreting the program."""
    from app.cnc.interpret import interpret
    from app.cnc.toolpath import MOTION_TYPES
    from bench.programs import sized

    toolpath = interpret(sized(family, moves))
    unit = toolpath.units.nm

    def streamed() -> int:
        with tempfile.TemporaryDirectory() as tmp, (Path(tmp) / "out.ngc").open("w") as out:
            for m in toolpath.moves:
                if isinstance(m, MOTION_TYPES):
                    out.write(f"G1 X{m.x / unit:.4f} Y{m.y / unit:.4f} Z{m.z / unit:.4f}\n")
            return out.tell()

    _, stream_seconds, stream_peak = measure(streamed)
    data, seconds, peak = measure(lambda: ("\n".join(_lines(toolpath)) + "\n").encode())
    return {
        "moves": len(toolpath.moves),
        "seconds": seconds,
        "peak": peak,
        "bytes": len(data),
        "stream_seconds": stream_seconds,
        "stream_peak": stream_peak,
    }


def interpret_case(family: str, moves: int) -> Result:
    """(child) Validation and interpretation alone, the part of an export before the emitter."""
    from app.cnc.interpret import interpret
    from app.cnc.validate import validate
    from bench.programs import sized

    program = sized(family, moves)
    started = time.perf_counter()
    validate(program)
    checked = time.perf_counter() - started
    toolpath, seconds, peak = measure(lambda: interpret(program))
    return {"moves": len(toolpath.moves), "seconds": seconds + checked, "peak": peak}


def run(sizes: tuple[int, ...] = SIZES, timeout: float = 420.0) -> Section:
    section = Section(f"Export: 1704 tape and G-code ({FAMILY} family)")
    rows: list[list[str]] = []
    extra_per_move: dict[str, list[float]] = {t: [] for t in TARGETS}
    largest: dict[str, Result] = {}
    for size in sizes:
        args = {"family": FAMILY, "moves": size}
        base = run_child("bench.exports:interpret_case", args, timeout)
        floor = run_child("bench.exports:floor_case", args, timeout)
        if "error" in base or "error" in floor:
            failed = base.get("error") or floor.get("error")
            rows.append([f"{fmt_count(size)} moves", f"failed: {failed}"] + [""] * 6)
            continue
        moves = base["moves"]
        rows.append(
            [
                f"interpret only ({fmt_count(moves)} moves)",
                fmt_seconds(base["seconds"]),
                "",
                fmt_bytes(base["peak"]),
                "",
                "",
                "",
                "",
            ]
        )
        rows.append(
            [
                "floor: plain writer, in memory",
                fmt_seconds(floor["seconds"]),
                "1×",
                fmt_bytes(floor["peak"]),
                f"{floor['peak'] / moves:.0f} B",
                fmt_bytes(floor["bytes"]),
                "",
                "",
            ]
        )
        rows.append(
            [
                "floor: plain writer, streaming to a file",
                fmt_seconds(floor["stream_seconds"]),
                fmt_ratio(floor["stream_seconds"] / floor["seconds"]),
                fmt_bytes(floor["stream_peak"]),
                f"{floor['stream_peak'] / moves:.1f} B",
                "",
                "",
                "",
            ]
        )
        for target in TARGETS:
            r = run_child("bench.exports:export_case", {**args, "target": target}, timeout)
            if "error" in r:
                rows.append([target, f"failed: {r['error']}"] + [""] * 6)
                continue
            emitter_seconds = max(0.0, r["seconds"] - base["seconds"])
            extra = r["peak"] - base["peak"]
            extra_per_move[target].append(extra / moves)
            largest[target] = {**r, "extra": extra, "moves": moves}
            rows.append(
                [
                    f"`{target}`",
                    fmt_seconds(r["seconds"]),
                    fmt_ratio(emitter_seconds / floor["seconds"]),
                    fmt_bytes(r["peak"]),
                    f"{extra / moves:.0f} B",
                    fmt_bytes(r["bytes"]),
                    fmt_count(r["lines"]),
                    fmt_seconds(emitter_seconds),
                ]
            )
    section.lines += [
        "*time* is the whole `export()` call; *emitter* is that minus *interpret only* (the",
        "validation and interpretation it starts with); *× floor* compares the emitter's time",
        "with the plain in-memory writer's. *Extra per move* is the peak above the",
        "interpreter's own peak, per move: constant memory would make it fall toward 0 as",
        "the program grows, as it does for the streaming floor.",
        "",
        *table(
            [
                "case",
                "time",
                "emitter × floor",
                "peak memory",
                "extra per move",
                "output",
                "lines",
                "emitter",
            ],
            rows,
        ),
    ]
    for target, r in largest.items():
        trend = extra_per_move[target]
        shape = (
            "constant" if len(trend) > 1 and trend[-1] < trend[0] / 4 else "grows with the program"
        )
        section.target(
            f"`{target}` export, {fmt_count(r['moves'])} moves",
            "constant memory",
            f"{fmt_seconds(r['seconds'])}, peak {fmt_bytes(r['peak'])} "
            f"({fmt_bytes(r['extra'])} above the interpreter)",
            shape,
        )
    return section
