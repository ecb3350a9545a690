"""Drawings: chaining a DXF's lines and choosing among nested contours (issue 30).

Each case reads a generated drawing (a minimal text DXF: its header and its entities,
`tests/hostile_corpus.py`) in a fresh child, the best of up to five runs:

- lines: LINEs end to end, each starting 0.00001 in past the last one's end (within the
  tolerance, so every end is joined and its gap reported), read with `read_drawing` (the
  entity limit lifted for 8 000 lines): ezdxf's reading, then ours — the lines, the
  chaining, the contour. Before issue 30 each end was compared with every end before it.
- squares: concentric squares of four LINEs each, read, then the choosing page's own work
  on them: the sides the rule gives (`cut_sides`), the drawing (`drawing_svg`), every other
  square a POCKET and the others islands (`read_choices`: each pocket's island is the square
  just inside it) and their blocks (`chosen_blocks`). Before issue 30 that tried every
  island against every pair of pockets.

Baseline in the same child: ezdxf reading the same file alone (`recover.read` and the
entities of its model space), what any reading of it pays.
"""

from __future__ import annotations

import io

from bench.common import (
    Result,
    Section,
    best_time,
    fmt_count,
    fmt_ratio,
    fmt_seconds,
    run_child,
    table,
)

CASES = (("lines", 1_000), ("lines", 8_000), ("squares", 30), ("squares", 300))


def drawing_case(case: str, count: int) -> Result:
    """Best times of ezdxf alone and of our reading (and choosing) of one drawing."""
    from ezdxf import recover

    from app.cnc.formats.dxf.blocks import cut_sides
    from app.cnc.formats.dxf.choice import chosen_blocks, drawing_svg
    from app.cnc.formats.dxf.reader import read_drawing
    from app.web.drawings import read_choices
    from tests.hostile_corpus import minimal_dxf, squares, zigzag

    entities = zigzag(count, 0.00001) if case == "lines" else squares(count)
    data = minimal_dxf(entities)

    def ezdxf_alone() -> None:
        doc, _auditor = recover.read(io.BytesIO(data))
        list(doc.modelspace())

    def ours() -> None:
        drawing = read_drawing(data, case, limit=None)
        if case == "squares":
            cut_sides(drawing)
            drawing_svg(drawing)
            form = {"tool_dia": "0.01"}
            for k in range(1, count, 2):
                form[f"c{k}_pocket"] = "pocket"
                form[f"c{k}_order"] = str(k)
                form[f"c{k - 1}_pocket"] = "island"
            chosen_blocks(drawing, read_choices(form, drawing))

    return {
        "entities": len(entities),
        "bytes": len(data),
        "baseline": best_time(ezdxf_alone),
        "seconds": best_time(ours),
    }


def run(timeout: float = 120.0) -> Section:
    section = Section("Drawings: chaining and choosing")
    rows: list[list[str]] = []
    for case, count in CASES:
        what = f"{fmt_count(count)} lines end to end" if case == "lines" else ""
        what = what or f"{fmt_count(count)} concentric squares"
        doing = "read (chained)" if case == "lines" else "read, sides, drawing, pockets, blocks"
        r = run_child("bench.drawings:drawing_case", {"case": case, "count": count}, timeout)
        if "error" in r:
            rows.append([what, f"failed: {r['error']}", "", "", "", ""])
            continue
        rows.append(
            [
                what,
                fmt_count(r["entities"]),
                doing,
                fmt_seconds(r["baseline"]),
                fmt_seconds(r["seconds"]),
                fmt_ratio(r["seconds"] / r["baseline"]),
            ]
        )
    section.lines += [
        "Generated minimal DXF files (`tests/hostile_corpus.py`), each read in a fresh process,",
        "best of up to five; *ezdxf alone* (the baseline, same child) is ezdxf reading the",
        "file and its model space; *ezdxf + ours* is `read_drawing` (its chaining: each end",
        "compared with those in its grid cell and the eight round it) and, for the squares,",
        "the choosing page's work: `cut_sides`, `drawing_svg`, every other square a POCKET",
        "round the next (`read_choices`, `chosen_blocks`). Twice the entities should take",
        "about twice the time.",
        "",
        *table(
            ["drawing", "entities", "what we do", "ezdxf alone", "ezdxf + ours", "× baseline"],
            rows,
        ),
    ]
    return section
