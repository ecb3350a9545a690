"""Interpreter: canonical moves per second and peak memory, against a plain-Python floor.

For each program family (bench/programs.py) at 10^4, 10^5 and 10^6 moves, a fresh child
process builds the program, validates it (timed apart), and interprets it. The floors,
measured in the same run for the same number of moves, are a plain loop appending tuples
and the same loop building the Toolpath's own `Feed` objects: the distance from them is
what the interpreter's logic costs. Target (issue 10): ≥ 1 000 000 moves/s.
"""

from __future__ import annotations

import time
from typing import Any

from bench.common import (
    Result,
    Section,
    best_time,
    fmt_bytes,
    fmt_count,
    fmt_rate,
    fmt_ratio,
    fmt_seconds,
    measure,
    run_child,
    table,
)

SIZES = (10_000, 100_000, 1_000_000)
TARGET_RATE = 1_000_000


def interpret_case(family: str, moves: int) -> Result:
    """(child) Validate and interpret a `family` program of about `moves` moves."""
    from app.cnc.interpret import interpret
    from app.cnc.validate import validate
    from bench.programs import sized

    program = sized(family, moves)
    started = time.perf_counter()
    problems = validate(program)
    validate_seconds = time.perf_counter() - started
    toolpath, seconds, peak = measure(lambda: interpret(program))
    count = len(toolpath.moves)
    del toolpath
    if count <= 200_000:
        seconds = min(seconds, best_time(lambda: interpret(program), budget=3.0))
    return {
        "moves": count,
        "seconds": seconds,
        "peak": peak,
        "validate_seconds": validate_seconds,
        "problems": len(problems),
    }


def _tuples(n: int) -> list[Any]:
    out: list[Any] = []
    append = out.append
    x = 0
    for i in range(n):
        x += 2540
        append((7, x, i, -12_700_000, 127_000_000, ""))
    return out


def _feeds(n: int) -> list[Any]:
    from app.cnc.toolpath import Feed

    out: list[Any] = []
    append = out.append
    x = 0
    for i in range(n):
        x += 2540
        append(Feed(7, x, i, -12_700_000, 127_000_000))
    return out


def floor_case(kind: str, moves: int) -> Result:
    """(child) Build `moves` tuples (`tuples`) or Feed objects (`feeds`) in a plain loop."""
    build = _tuples if kind == "tuples" else _feeds
    out, seconds, peak = measure(lambda: build(moves))
    del out
    if moves <= 200_000:
        seconds = min(seconds, best_time(lambda: build(moves), budget=2.0))
    return {"moves": moves, "seconds": seconds, "peak": peak}


def run(sizes: tuple[int, ...] = SIZES, timeout: float = 240.0) -> Section:
    from bench.programs import FAMILIES, FAMILY_TITLES

    section = Section("Interpreter: moves per second and peak memory")
    rows: list[list[str]] = []
    best_at_largest: float | None = None
    for size in sizes:
        floors = {
            kind: run_child("bench.interpreter:floor_case", {"kind": kind, "moves": size}, timeout)
            for kind in ("tuples", "feeds")
        }
        for kind, label in (("tuples", "floor: tuples"), ("feeds", "floor: Feed objects")):
            f = floors[kind]
            if "error" in f:
                rows.append([label, fmt_count(size), f"failed: {f['error']}", "", "", "", "", ""])
                continue
            rows.append(
                [
                    label,
                    fmt_count(f["moves"]),
                    fmt_seconds(f["seconds"]),
                    fmt_rate(f["moves"] / f["seconds"]),
                    "1×" if kind == "tuples" else _vs(f, floors["tuples"]),
                    "" if kind == "tuples" else "1×",
                    fmt_bytes(f["peak"]),
                    f"{f['peak'] / f['moves']:.0f} B",
                ]
            )
        for family in FAMILIES:
            r = run_child(
                "bench.interpreter:interpret_case", {"family": family, "moves": size}, timeout
            )
            name = f"{family}: {FAMILY_TITLES[family]}"
            if "error" in r:
                rows.append([name, fmt_count(size), f"failed: {r['error']}", "", "", "", "", ""])
                continue
            rate = r["moves"] / r["seconds"]
            if size == sizes[-1]:
                best_at_largest = max(best_at_largest or 0.0, rate)
            note = "" if not r["problems"] else f" ({r['problems']} problems!)"
            rows.append(
                [
                    name + note,
                    fmt_count(r["moves"]),
                    fmt_seconds(r["seconds"]) + f" (+{fmt_seconds(r['validate_seconds'])} check)",
                    fmt_rate(rate),
                    _vs(r, floors["tuples"]),
                    _vs(r, floors["feeds"]),
                    fmt_bytes(r["peak"]),
                    f"{r['peak'] / r['moves']:.0f} B",
                ]
            )
    section.lines += [
        "Each case runs in a fresh process: the time is the best of up to five runs (one at",
        "10^6), `check` is `validate()` before it, the peak is the resident-memory peak above",
        "the size before the call (the whole Toolpath is kept, as `interpret` returns it).",
        "*× tuples* is the time per move over the tuple floor's, *× Feed* over the floor that",
        "builds the Toolpath's own frozen `Feed` objects (the cost of the data model alone),",
        "both measured in this run for the same count.",
        "",
        *table(
            ["case", "moves", "time", "moves/s", "× tuples", "× Feed", "peak memory", "per move"],
            rows,
        ),
    ]
    if best_at_largest is not None:
        section.target(
            f"interpreter, {fmt_count(sizes[-1])} moves (fastest family)",
            f"≥ {fmt_rate(TARGET_RATE)}",
            fmt_rate(best_at_largest),
            fmt_ratio(best_at_largest / TARGET_RATE) + " of target",
        )
    return section


def _vs(case: Result, floor: Result) -> str:
    """Time per move of `case` over time per move of `floor`."""
    if "error" in floor:
        return "–"
    return fmt_ratio((case["seconds"] / case["moves"]) / (floor["seconds"] / floor["moves"]))
