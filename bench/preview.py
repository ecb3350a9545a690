"""Preview: SVG bytes, element count and drawing time of `app.cnc.emit.svg.draw`.

For each program family at 10^4-10^6 moves, a fresh child interprets the program (not
timed here), then draws it as the editor does (`embedded_style=False`). The floor, in the
same child and run: one `<path>` through every motion's end point with the same number
format, the least any drawing that touches each move can cost. The editor's whole preview
(`app.web.editor.preview`: validate + interpret + estimate + draw) is reported as the sum
of its parts, measured in the same child.

Targets (issue 10): ≤ 300 ms and ≤ 1 MB for 10^6 moves.
"""

from __future__ import annotations

import re
import time

from bench.common import (
    Result,
    Section,
    best_time,
    fmt_bytes,
    fmt_count,
    fmt_ratio,
    fmt_seconds,
    measure,
    run_child,
    table,
)

SIZES = (10_000, 100_000, 1_000_000)
TARGET_SECONDS = 0.300
TARGET_BYTES = 1_000_000
ELEMENT = re.compile(r"<(?![/?!])")


def naive_svg(toolpath: object) -> str:
    """The floor: every motion's XY end point in one path, fixed decimals."""
    from app.cnc.toolpath import MOTION_TYPES, Toolpath

    assert isinstance(toolpath, Toolpath)
    unit = toolpath.units.nm
    parts = [f"M{toolpath.start[0] / unit:.4f} {toolpath.start[1] / unit:.4f}"]
    append = parts.append
    for move in toolpath.moves:
        if isinstance(move, MOTION_TYPES):
            append(f"L{move.x / unit:.4f} {move.y / unit:.4f}")
    return f'<svg xmlns="http://www.w3.org/2000/svg"><path d="{" ".join(parts)}"/></svg>\n'


def preview_case(family: str, moves: int) -> Result:
    """(child) Draw a `family` program of about `moves` moves; the floor; the editor's sum."""
    from app.cnc.emit.svg import draw
    from app.cnc.estimate import estimate
    from app.cnc.interpret import interpret
    from app.cnc.validate import validate
    from bench.programs import sized

    program = sized(family, moves)
    started = time.perf_counter()
    validate(program)
    validate_seconds = time.perf_counter() - started
    started = time.perf_counter()
    toolpath = interpret(program)
    interpret_seconds = time.perf_counter() - started
    svg, seconds, peak = measure(lambda: draw(toolpath, embedded_style=False))
    small = len(toolpath.moves) <= 200_000
    if small:
        seconds = min(seconds, best_time(lambda: draw(toolpath, embedded_style=False), 3.0))
    floor_svg = naive_svg(toolpath)
    floor_seconds = best_time(lambda: naive_svg(toolpath), 3.0, most=5 if small else 1)
    started = time.perf_counter()
    estimate(toolpath)
    estimate_seconds = time.perf_counter() - started
    return {
        "moves": len(toolpath.moves),
        "seconds": seconds,
        "peak": peak,
        "bytes": len(svg.encode()),
        "elements": len(ELEMENT.findall(svg)),
        "symbols": svg.count("<symbol"),
        "uses": svg.count("<use"),
        "floor_seconds": floor_seconds,
        "floor_bytes": len(floor_svg.encode()),
        "editor_seconds": validate_seconds + interpret_seconds + estimate_seconds + seconds,
    }


def run(sizes: tuple[int, ...] = SIZES, timeout: float = 300.0) -> Section:
    from bench.programs import FAMILIES

    section = Section("Preview: SVG drawing")
    rows: list[list[str]] = []
    worst: Result | None = None
    for size in sizes:
        for family in FAMILIES:
            r = run_child("bench.preview:preview_case", {"family": family, "moves": size}, timeout)
            if "error" in r:
                rows.append([family, fmt_count(size), f"failed: {r['error']}"] + [""] * 6)
                continue
            if size == sizes[-1] and (worst is None or r["seconds"] > worst["seconds"]):
                worst = r
            rows.append(
                [
                    family,
                    fmt_count(r["moves"]),
                    fmt_seconds(r["seconds"]),
                    fmt_ratio(r["seconds"] / r["floor_seconds"]),
                    fmt_bytes(r["bytes"]) + f" ({fmt_ratio(r['bytes'] / r['floor_bytes'])})",
                    f"{fmt_count(r['elements'])} ({r['symbols']} symbols, {r['uses']} uses)",
                    fmt_bytes(r["peak"]),
                    f"{fmt_seconds(r['floor_seconds'])}, {fmt_bytes(r['floor_bytes'])}",
                    fmt_seconds(r["editor_seconds"]),
                ]
            )
    section.lines += [
        "`draw` time is the best of up to five runs (one at 10^6); *× floor* is its time over",
        "the floor's (one path through every move, same run); bytes in brackets are over the",
        "floor's bytes (LOOP patterns drawn once as `<symbol>` and placed with `<use>`). *Editor",
        "preview* is validate + interpret + estimate + draw: what one edit in the editor waits",
        "for on such a program.",
        "",
        *table(
            [
                "family",
                "moves",
                "draw",
                "× floor",
                "SVG bytes (× floor)",
                "elements",
                "peak memory",
                "floor",
                "editor preview",
            ],
            rows,
        ),
    ]
    if worst is not None:
        section.target(
            f"preview time, {fmt_count(sizes[-1])} moves (slowest family)",
            "≤ 300 ms",
            fmt_seconds(worst["seconds"]),
            fmt_ratio(worst["seconds"] / TARGET_SECONDS) + " of target",
        )
        section.target(
            f"preview size, {fmt_count(sizes[-1])} moves (that family)",
            "≤ 1 MB",
            fmt_bytes(worst["bytes"]),
            fmt_ratio(worst["bytes"] / TARGET_BYTES) + " of target",
        )
    return section
