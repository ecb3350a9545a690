"""`make bench`: run every benchmark and write the figures into docs/benchmarks.md.

    .venv/bin/python -m bench.run                  # everything (about 10 minutes on 2 cores)
    .venv/bin/python -m bench.run --quick          # smaller sizes, to try a change out
    .venv/bin/python -m bench.run --only preview,export --no-write

Each benchmark measures its own baseline in the same run and reports ratios against it;
the targets of issue 10 are reported, never asserted. The generated part of the document
sits between `<!-- bench:begin -->` and `<!-- bench:end -->`; the hand-written analysis
around it is kept. Every measurement runs in a child process with its own time limit, and
a section that would start after `--budget` seconds is skipped (and says so), so the run
always ends by itself.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path

from bench import (
    cli,
    drawings,
    editor,
    exports,
    gcode_import,
    interpreter,
    pocket,
    preview,
    simulate,
)
from bench.common import (
    BUDGET,
    ROOT,
    Section,
    git_commit,
    machine_lines,
    replace_between,
    table,
)

DOC = ROOT / "docs" / "benchmarks.md"
PREAMBLE = """# Benchmarks (issue 10)

`make bench` runs `bench/` and rewrites the part of this file between the markers.
"""


def sections(quick: bool) -> dict[str, Callable[[], Section]]:
    sizes = (10_000, 100_000) if quick else interpreter.SIZES
    return {
        "interpreter": lambda: interpreter.run(sizes),
        "gcode": lambda: gcode_import.run((10_000,) if quick else gcode_import.SIZES),
        "preview": lambda: preview.run(sizes),
        "editor": lambda: editor.run(),
        "export": lambda: exports.run((10_000, 100_000) if quick else exports.SIZES),
        "simulate": lambda: simulate.run(10_000 if quick else simulate.MOVES),
        "pocket": lambda: pocket.run(),
        "cli": lambda: cli.run(
            (10_000, 100_000) if quick else cli.IMPORT_SIZES, 100_000 if quick else cli.EXPORT_MOVES
        ),
        "drawings": lambda: drawings.run(),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.run", description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="smaller sizes (not for the docs)")
    parser.add_argument("--only", default="", help="comma-separated: " + ", ".join(sections(False)))
    parser.add_argument("--budget", type=float, default=840.0, help="seconds before skipping")
    parser.add_argument("--output", type=Path, default=DOC)
    parser.add_argument("--no-write", action="store_true", help="print only")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    chosen = sections(args.quick)
    if args.only:
        names = [n.strip() for n in args.only.split(",") if n.strip()]
        unknown = [n for n in names if n not in chosen]
        if unknown:
            parser.error(f"unknown benchmark {', '.join(unknown)}; there are {', '.join(chosen)}")
        chosen = {n: chosen[n] for n in names}
    started = time.monotonic()
    BUDGET.start(args.budget)
    load_before = os.getloadavg()
    done: list[Section] = []
    skipped: list[str] = []
    for name, run in chosen.items():
        elapsed = time.monotonic() - started
        if elapsed > args.budget:
            skipped.append(name)
            continue
        print(f"[{elapsed:5.0f} s] {name} ...", file=sys.stderr, flush=True)
        section = run()
        print(section.text(), flush=True)
        done.append(section)
    total = time.monotonic() - started
    text = render(done, skipped, total, load_before, args.quick)
    if args.only:
        # Some benchmarks only: their sections and target rows replace theirs in the last
        # full run's figures; the others stay as they were.
        previous = read_between(args.output, "bench")
        if previous:
            text = merge(previous, done, render_run(total, load_before, args.quick, args.only))
    if not args.no_write:
        replace_between(args.output, "bench", text, PREAMBLE)
        print(f"written to {args.output} in {total:.0f} s", file=sys.stderr)
    return 0


def read_between(path: Path, key: str) -> str:
    """The text between `<!-- key:begin -->` and `<!-- key:end -->` ('' if absent)."""
    begin, end = f"<!-- {key}:begin -->", f"<!-- {key}:end -->"
    text = path.read_text() if path.exists() else ""
    if begin not in text or end not in text:
        return ""
    return text.split(begin, 1)[1].split(end, 1)[0].strip("\n")


def merge(previous: str, done: list[Section], note: str) -> str:
    """`previous` generated text with the sections of `done` (and their target rows) put
    in place of their earlier versions (or added), and `note` saying when they ran."""
    head, *sections = previous.split("\n### ")
    chunks = {chunk.split("\n", 1)[0]: chunk for chunk in sections}
    targets = chunks.pop("Targets (reported, not asserted)", "Targets (reported, not asserted)\n")
    ours = {row[0] for section in done for row in section.summary}
    rows = [
        line
        for line in targets.splitlines()[1:]
        if not any(line.startswith(f"| {what} |") for what in ours)
    ]
    rows = [line for line in rows if line.strip()]
    rows += [f"| {' | '.join(row)} |" for section in done for row in section.summary]
    if len(rows) < 2:
        rows = table(["what", "target", "measured", "ratio"], []) + rows
    chunks["Targets (reported, not asserted)"] = "\n".join(
        ["Targets (reported, not asserted)", "", *rows, ""]
    )
    for section in done:
        text = section.text().removeprefix("### ")
        chunks[section.title] = text.rstrip("\n") + "\n\n" + note + "\n"
    order = ["Targets (reported, not asserted)"] + [
        title for title in chunks if title != "Targets (reported, not asserted)"
    ]
    return "\n### ".join(
        [head.rstrip("\n") + "\n", *(chunks[t].rstrip("\n") + "\n" for t in order)]
    )


def render_run(
    seconds: float, load_before: tuple[float, float, float], quick: bool, only: str
) -> str:
    """One line saying when and how a section alone was measured."""
    load_after = os.getloadavg()
    return (
        f"*This section alone: `python -m bench.run --only {only}`"
        f"{' --quick' if quick else ''}, {datetime.now(UTC):%Y-%m-%d %H:%M} UTC, commit "
        f"{git_commit()}, {seconds:.0f} s; load average before "
        f"{' / '.join(f'{x:.2f}' for x in load_before)}, after "
        f"{' / '.join(f'{x:.2f}' for x in load_after)}.*"
    )


def render(
    done: list[Section],
    skipped: list[str],
    seconds: float,
    load_before: tuple[float, float, float],
    quick: bool,
) -> str:
    load_after = os.getloadavg()
    lines = [
        "## Last run",
        "",
        *machine_lines(),
        f"- Load average (1/5/15 min) before: {' / '.join(f'{x:.2f}' for x in load_before)}"
        f"; after: {' / '.join(f'{x:.2f}' for x in load_after)} (other work on the machine "
        "slows everything alike; the ratios are taken within the run)",
        f"- Command: `make bench` ({'--quick, ' if quick else ''}{seconds:.0f} s)",
        "",
        "### Targets (reported, not asserted)",
        "",
        *table(
            ["what", "target", "measured", "ratio"],
            [list(row) for section in done for row in section.summary],
        ),
        "",
    ]
    if skipped:
        lines += [f"Skipped (time budget): {', '.join(skipped)}.", ""]
    for section in done:
        lines += [section.text()]
    return "\n".join(lines)


if __name__ == "__main__":
    raise SystemExit(main())
