"""Interpreter (the compiler): canonical moves per second and peak memory, against floors.

For each program family (bench/programs.py) at 10^4, 10^5 and 10^6 moves, a fresh child
process builds the program, validates it (timed apart: the validation compiles, so it is
timed with a cold cache too), and then, with a cold cache, compiles it
(`compile_program`) and walks every chunk of moves (`CompiledPath.chunks()`: every move an
absolute row in a numpy array, as an emitter reads them). That is the interpreter's work
since issue 18. For contrast at 10^4 and 10^5, `interpret()` — the same path materialised
as the Toolpath's Move objects, as the old interpreter returned it.

The floors, measured in the same run for the same number of moves, are a plain loop
appending tuples and the same loop building the Toolpath's own `Feed` objects. Target
(issues 10 and 18): ≥ 1 000 000 moves/s.
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
    """(child) Validate, then compile and walk a `family` program of about `moves` moves,
    each with a cold cache; and (up to 10^5) materialise it as Move objects."""
    from app.cnc.compiler import Cache, compile_program
    from app.cnc.interpret import interpret
    from app.cnc.path import size
    from app.cnc.validate import validate
    from bench.programs import sized

    program = sized(family, moves)

    def compile_and_walk() -> tuple[int, int]:
        path = compile_program(program, Cache()).path
        walked = sum(len(chunk.rows) for chunk in path.chunks())
        return walked, _stored(path.root)

    started = time.perf_counter()
    problems = validate(program)
    validate_seconds = time.perf_counter() - started
    (count, stored), seconds, peak = measure(compile_and_walk)
    if count <= 200_000:
        seconds = min(seconds, best_time(compile_and_walk, budget=3.0))
    compile_seconds = best_time(lambda: compile_program(program, Cache()), budget=2.0)
    objects_seconds = None
    if count <= 200_000:
        objects_seconds = best_time(lambda: interpret(program), budget=3.0)
        assert len(interpret(program).moves) == count
    assert size(compile_program(program, Cache()).path.root) == count
    return {
        "moves": count,
        "stored": stored,
        "seconds": seconds,
        "compile_seconds": compile_seconds,
        "objects_seconds": objects_seconds,
        "peak": peak,
        "validate_seconds": validate_seconds,
        "problems": len(problems),
    }


def _stored(node: object) -> int:
    """Rows the compiled tree holds (a repeated pattern counts once)."""
    from app.cnc.path import Piece, Run

    if isinstance(node, Piece):
        return len(node.rows)
    if isinstance(node, Run):
        return _stored(node.node)
    return sum(_stored(child) for child in getattr(node, "nodes", ()))


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
                rows.append([label, fmt_count(size), f"failed: {f['error']}", *[""] * 6])
                continue
            rows.append(
                [
                    label,
                    fmt_count(f["moves"]),
                    fmt_seconds(f["seconds"]),
                    fmt_rate(f["moves"] / f["seconds"]),
                    "1×" if kind == "tuples" else _vs(f, floors["tuples"]),
                    "" if kind == "tuples" else "1×",
                    "",
                    "",
                    fmt_bytes(f["peak"]),
                ]
            )
        for family in FAMILIES:
            r = run_child(
                "bench.interpreter:interpret_case", {"family": family, "moves": size}, timeout
            )
            name = f"{family}: {FAMILY_TITLES[family]}"
            if "error" in r:
                rows.append([name, fmt_count(size), f"failed: {r['error']}", *[""] * 6])
                continue
            rate = r["moves"] / r["seconds"]
            if size == sizes[-1]:
                best_at_largest = max(best_at_largest or 0.0, rate)
            note = "" if not r["problems"] else f" ({r['problems']} problems!)"
            objects = r["objects_seconds"]
            rows.append(
                [
                    name + note,
                    fmt_count(r["moves"]),
                    fmt_seconds(r["seconds"]) + f" (+{fmt_seconds(r['validate_seconds'])} check)",
                    fmt_rate(rate),
                    _vs(r, floors["tuples"]),
                    _vs(r, floors["feeds"]),
                    fmt_seconds(r["compile_seconds"]) + f", {fmt_count(r['stored'])} rows",
                    "–" if objects is None else fmt_rate(r["moves"] / objects),
                    fmt_bytes(r["peak"]),
                ]
            )
    section.lines += [
        "Each case runs in a fresh process with a cold compile cache: the time is the best of",
        "up to five runs (one at 10^6) of compiling the program and walking every chunk of",
        "absolute moves; `check` is `validate()` before it (which compiles too). *compiled*",
        "is the compile alone and the rows its tree stores (a LOOP's repeated pattern once).",
        "*Move objects* is `interpret()`, the same path materialised as the Toolpath's frozen",
        "objects (what the interpreter returned before issue 18), up to 10^5 moves. The peak",
        "is the resident-memory peak above the size before compile-and-walk.",
        "*× tuples* is the time per move over the tuple floor's, *× Feed* over the floor that",
        "builds the Toolpath's own frozen `Feed` objects, both measured in this run for the",
        "same count.",
        "",
        *table(
            [
                "case",
                "moves",
                "compile + walk",
                "moves/s",
                "× tuples",
                "× Feed",
                "compiled",
                "Move objects",
                "peak memory",
            ],
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
