"""Pocket: planning an irregular POCKET (issue 22) against the routines' pockets.

Each golden POCKET program (`tests/golden/pocket-*`) is compiled in a fresh child on a cold
cache: the time is the best of up to five compiles, almost all of it the pocket engine
(pyclipper offsets, the exact rings, the links and the cleanup search). Baseline in the
same child: the golden CIRCLE and FRAME POCKET programs, compiled the same way. What it
tells a programmer: how long an edit of a pocket's blocks takes to answer (an edit of any
other block reuses the compiled pocket), and how many moves the plan makes.

Then issue 30's pocket: one POCKET with 8 islands of PKT LINE / PKT ARC blocks, a small
tool in a large boundary (`tests/hostile_corpus.eight_island_pocket`, 10 in x 8 in),
against the golden pocket-islands in the same child. Before issue 30 its like validated in
75 s (79x the golden); an edit of it is what a programmer waits for.
"""

from __future__ import annotations

from pathlib import Path

from bench.common import (
    ROOT,
    Result,
    Section,
    best_time,
    fmt_count,
    fmt_ratio,
    fmt_seconds,
    run_child,
    table,
)

CASES = ("pocket-islands", "pocket-mm", "pocket-loop")
BASELINES = ("circle-pocket", "frame-pocket")
ISLAND_SIZES = ("10",)  # inches: the 8-island pocket's boundary (20 in: docs/benchmarks.md)


def islands_case(size: str) -> Result:
    """(child) The 8-island pocket of `size` in compiled on a cold cache (best of up to
    three within 10 s), and the golden pocket-islands the same way."""
    from decimal import Decimal

    from app.cnc import document
    from app.cnc.compiler import Cache, compile_program
    from tests.hostile_corpus import eight_island_pocket

    golden = (Path(ROOT) / "tests" / "golden" / "pocket-islands" / "program.json").read_text()
    baseline = document.loads(golden)
    program = eight_island_pocket(Decimal(size))
    base = best_time(lambda: compile_program(baseline, Cache()))
    seconds = best_time(lambda: compile_program(program, Cache()), budget=10.0, most=3)
    compiled = compile_program(program, Cache())
    return {
        "seconds": seconds,
        "baseline": base,
        "moves": len(compiled.path),
        "blocks": len(program.blocks),
        "baseline_blocks": len(baseline.blocks),
        "baseline_moves": len(compile_program(baseline, Cache()).path),
    }


def compile_case(name: str) -> Result:
    """Best cold compile of golden case `name` and what it holds (in a child)."""
    from app.cnc import document
    from app.cnc.compiler import Cache, compile_program
    from app.cnc.interpret import interpret

    text = (Path(ROOT) / "tests" / "golden" / name / "program.json").read_text(encoding="utf-8")
    program = document.loads(text)
    seconds = best_time(lambda: compile_program(program, Cache()))
    moves = len(interpret(program).moves)

    return {"seconds": seconds, "moves": moves, "blocks": len(program.blocks)}


def run(timeout: float = 300.0) -> Section:
    section = Section("Pocket: planning an irregular POCKET")
    base: list[float] = []
    rows: list[list[str]] = []
    for name in (*BASELINES, *CASES):
        r = run_child("bench.pocket:compile_case", {"name": name}, timeout)
        if "error" in r:
            rows.append([name, f"failed: {r['error']}", "", "", ""])
            continue
        if name in BASELINES:
            base.append(r["seconds"])
        ratio = fmt_ratio(r["seconds"] / min(base)) if base else ""
        rows.append(
            [
                f"`{name}`" + (" (baseline)" if name in BASELINES else ""),
                fmt_count(r["blocks"]),
                fmt_count(r["moves"]),
                fmt_seconds(r["seconds"]),
                ratio,
            ]
        )
    section.lines += [
        "Each golden program compiled in a fresh process on a cold cache, best of up to five;",
        "*moves* are its whole tool path's;",
        "*× baseline* is the time over the faster of the CIRCLE and FRAME POCKET goldens,",
        "same run. An edit of a POCKET's blocks replans it; an edit elsewhere does not.",
        "",
        *table(["program", "blocks", "moves", "compile", "× baseline"], rows),
    ]
    islands: list[list[str]] = []
    for size in ISLAND_SIZES:
        r = run_child("bench.pocket:islands_case", {"size": size}, timeout)
        if "error" in r:
            islands.append([f"8 islands, {size} in", f"failed: {r['error']}", "", "", ""])
            continue
        if not islands:
            islands.append(
                [
                    "`pocket-islands` (baseline)",
                    fmt_count(r["baseline_blocks"]),
                    fmt_count(r["baseline_moves"]),
                    fmt_seconds(r["baseline"]),
                    "1×",
                ]
            )
        islands.append(
            [
                f"8 islands, {size} in x {float(size) * 0.8:g} in, 0.125 in tool",
                fmt_count(r["blocks"]),
                fmt_count(r["moves"]),
                fmt_seconds(r["seconds"]),
                fmt_ratio(r["seconds"] / r["baseline"]),
            ]
        )
    section.lines += [
        "",
        "Issue 30's pocket (`tests/hostile_corpus.eight_island_pocket`): one POCKET with 8",
        "islands, compiled on a cold cache in a fresh process (best of up to three), against",
        "the golden pocket-islands compiled in the same child. Before issue 30: 79× the golden",
        "(75 s) on the issue's machine.",
        "",
        *table(["program", "blocks", "moves", "compile", "× pocket-islands"], islands),
    ]
    return section
