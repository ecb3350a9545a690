"""Editor: p50/p95 latency of an edit plus preview refresh on a 500-block program, under
the production server (gunicorn, `make run`'s default of 2 workers, SQLite).

The program (bench/programs.py `editor_program`: holes, bolt circles, pockets, contours,
LOOPs) is created through the library API in a temporary SQLite database; gunicorn is
started on a free 127.0.0.1 port. One client then does what the editor's htmx form does:
POST /programs/<id>/blocks with `edit=N`, the DRILL's fields and the version it was shown,
and gets the reply back (the entry panel, the rows that changed, the cycle time), which asks
for the new drawing; the client then GETs it, as the page does. Each edit moves one DRILL
(block 1, 11, 21... in turn) so every save is a real change and a new revision. With two
workers an edit may land on the worker that did not show the version it starts from (it
then reads that version and works out its rows).

Baselines in the same run, same server: a static file (the server's floor) and the GET of
the editor page (the same rendering without the save). Then, in a child process, the parts
of one edit timed alone (document JSON, revision summary, validation, interpretation,
estimate, the compile and cycle time of an edited version, the rows of a starting version
another worker saved, drawing, the whole request through Flask's test client) to show where
the time goes. Targets (issues 10 and 18): p95 ≤ 50 ms, reply ≤ 50 kB.
"""

from __future__ import annotations

import re
import tempfile
import time
from decimal import Decimal
from pathlib import Path
from typing import TYPE_CHECKING

from bench.common import (
    Result,
    Section,
    fmt_ratio,
    fmt_seconds,
    percentile,
    run_child,
    table,
)
from bench.server import Client, production_server

if TYPE_CHECKING:
    from flask import Flask

    from app.cnc.blocks import Program

BLOCKS = 500
EDITS = 40
WORKERS = 2
TIME_LIMIT = 120.0
TARGET_P95 = 0.050
TARGET_BYTES = 50_000  # issue 18: the reply to an edit ≤ 50 kB
HTMX = {"HX-Request": "true"}
# The element of an edit's reply that asks for the new drawing.
DRAWING = re.compile(r'id="drawing-refresh"[^>]*hx-get="([^"]+)"')


# A row's digest of what it shows, as the page keeps it (templates/editor/_row.html).
SHOWN = re.compile(r'name="shown" value="(\d+):([0-9a-f]+)"')


class ShownRows:
    """The rows a browser shows, as digests: read from the pages it opened and from each
    reply's rows; an edit sends those of the edited block's page, as the page does."""

    def __init__(self) -> None:
        self.digests: dict[int, str] = {}

    def read(self, body: str) -> None:
        self.digests.update((int(n), digest) for n, digest in SHOWN.findall(body))

    def of_page(self, block: int, blocks: int) -> list[str]:
        from app.web.editor_page import PAGE_SIZE

        first = (block - 1) // PAGE_SIZE * PAGE_SIZE + 1
        last = min(blocks, first + PAGE_SIZE - 1)
        return [f"{n}:{self.digests[n]}" for n in range(first, last + 1) if n in self.digests]


def _stats(seconds: list[float]) -> dict[str, float]:
    return {
        "n": len(seconds),
        "p50": percentile(seconds, 50),
        "p95": percentile(seconds, 95),
        "max": max(seconds, default=float("nan")),
    }


def edit_form(csrf: str, version: int, k: int, blocks: int) -> dict[str, str]:
    """The form of the k-th edit of a `blocks`-block program: DRILL 10·j + 1 to a new X."""
    from bench.programs import EDITABLE_STRIDE, drill_form

    block = (k % max(1, blocks // EDITABLE_STRIDE)) * EDITABLE_STRIDE + 1
    unit = (block - 1) // EDITABLE_STRIDE
    x = Decimal(unit % 10) + Decimal("0.5") + Decimal(k % 7 + 1) / 100
    y = Decimal((unit // 10) % 10) + Decimal("0.5")
    return {"csrf_token": csrf, "version": str(version), "edit": str(block), **drill_form(x, y)}


def server_case(blocks: int, edits: int, workers: int, time_limit: float) -> Result:
    """(child) Start gunicorn on a temporary SQLite library and time edits through it."""
    from app.storage.library import open_library
    from bench.programs import editor_program

    with tempfile.TemporaryDirectory() as tmp:
        url = f"sqlite:///{Path(tmp) / 'bench.db'}"
        library = open_library(url)
        program_id = library.create(editor_program(blocks)).id
        library.engine.dispose()
        with production_server(url, workers, Path(tmp)) as server:
            client = Client(server.host, server.port)
            page = client.get(
                f"/programs/{program_id}?edit=1"
            )  # the form to edit, as a user opens it
            csrf, version = page.csrf_token(), page.version()
            if page.status != 200 or csrf is None or version is None:
                return {"error": f"editor page answered {page.status} without a form"}
            static = [client.get("/static/app.css").seconds for _ in range(30)]
            pages = [client.get(f"/programs/{program_id}").seconds for _ in range(10)]
            # Each page of the list the edits go to, as the machinist pages to the block.
            shown = ShownRows()
            from app.web.editor_page import page_of

            for number in range(1, page_of(blocks) + 1):
                shown.read(client.get(f"/programs/{program_id}/list?page={number}", HTMX).body)
            latencies: list[float] = []
            drawings: list[float] = []
            statuses: dict[str, int] = {}
            sizes: list[int] = []
            drawing_sizes: list[int] = []
            started = time.monotonic()
            for k in range(edits + 2 * workers):
                if time.monotonic() - started > time_limit:
                    break
                form = edit_form(csrf, version, k, blocks)
                sent = {**form, "shown": shown.of_page(int(form["edit"]), blocks)}
                answer = client.post(f"/programs/{program_id}/blocks", sent, HTMX)
                statuses[str(answer.status)] = statuses.get(str(answer.status), 0) + 1
                if answer.status != 200:
                    return {"error": f"edit {k} answered {answer.status}: {answer.body[:200]}"}
                version = answer.version() or version + 1
                shown.read(answer.body)
                sizes.append(len(answer.body.encode()))
                asked = DRAWING.search(answer.body)
                if asked is None:
                    return {"error": f"edit {k}'s reply asks for no drawing"}
                drawing = client.get(asked.group(1).replace("&amp;", "&"), HTMX)
                if drawing.status != 200:
                    return {"error": f"the drawing after edit {k} answered {drawing.status}"}
                drawing_sizes.append(len(drawing.body.encode()))
                if k >= 2 * workers:  # the first edit on each worker warms its caches
                    latencies.append(answer.seconds)
                    drawings.append(drawing.seconds)
        revisions = len(open_library(url, seed_demo=False).revisions(program_id))
    return {
        "edits": _stats(latencies),
        "drawings": _stats(drawings),
        "drawing_bytes": percentile([float(n) for n in drawing_sizes], 95) if drawing_sizes else 0,
        "static": _stats(static),
        "page": _stats(pages),
        "statuses": statuses,
        "fragment_bytes": percentile([float(n) for n in sizes], 95) if sizes else 0,
        "revisions": revisions,
    }


def parts_case(blocks: int) -> Result:
    """(child) The parts of one edit, each timed alone (best of several) on the same program:
    what an edit does once (save, validate the new version, its preview, the reply) and what
    it no longer does (parse a stored version it has read or written)."""
    import dataclasses
    import itertools

    from app import create_app
    from app.cnc import document
    from app.cnc.blocks import Hole
    from app.cnc.compiler import compile_program
    from app.cnc.diff import summary
    from app.cnc.emit.svg import draw
    from app.cnc.estimate import estimate
    from app.cnc.interpret import interpret
    from app.cnc.validate import validate
    from app.web.editor_page import shown_of
    from app.web.preview import preview
    from bench.common import best_time
    from bench.programs import editor_program

    program = editor_program(blocks)
    first = program.blocks[0]
    assert isinstance(first, Hole)
    counter = itertools.count(1)

    def edited() -> Program:
        """`program` with block 1 moved: a new version, all other blocks the same objects."""
        moved = dataclasses.replace(first, x=first.x + Decimal(next(counter) % 90) / 100)
        return dataclasses.replace(program, blocks=(moved, *program.blocks[1:]))

    text = document.dumps(program)
    toolpath = interpret(program)
    shown_of(program)
    parts = {
        "document.loads (a version not read before; none per edit now)": lambda: document.loads(
            text
        ),
        "document.dumps of an edited version (once per edit)": lambda: document.dumps(edited()),
        "diff summary for the revision": lambda: summary(program, edited()),
        "validate an edited version (once per edit)": lambda: validate(edited()),
        "interpret": lambda: interpret(program),
        "estimate": lambda: estimate(toolpath),
        "compile + cycle time of an edited version (the nodes it left alone are kept)": (
            lambda: estimate(compile_program(edited()).path)
        ),
        "a starting version another worker saved: read it, validate it, time it (rows)": (
            lambda: shown_of(document.loads(text))
        ),
        "draw (SVG)": lambda: draw(program, embedded_style=False),
        "editor preview() = validate + compile + estimate + draw": lambda: preview(program),
    }
    result: Result = {"moves": len(toolpath.moves)}
    for name, call in parts.items():
        result[name] = best_time(call, budget=3.0)
    broken = dataclasses.replace(
        program, blocks=(dataclasses.replace(first, feed_z=Decimal(900)), *program.blocks[1:])
    )
    started = time.perf_counter()
    preview(broken)
    result["editor preview() when block 1 has an error (FEEDR Z 900)"] = (
        time.perf_counter() - started
    )
    with tempfile.TemporaryDirectory() as tmp:
        app = create_app(
            {"DATABASE_URL": f"sqlite:///{Path(tmp) / 'parts.db'}", "SECRET_KEY": "bench"}
        )
        with app.app_context():
            from app.web import get_library

            library = get_library()
            program_id = library.create(program).id
            stored = library.get(program_id)
            versions = iter(range(stored.info.version, stored.info.version + 1000))

            def save() -> None:
                library.save(program_id, edited(), based_on=next(versions))

            result["library.save (dumps, diff, commit)"] = best_time(save, budget=3.0)
            result["library.get of the version just saved (no parse)"] = best_time(
                lambda: library.get(program_id), budget=3.0
            )
        client = app.test_client()
        page = client.get(f"/programs/{program_id}?edit=1").get_data(as_text=True)
        from bench.server import CSRF, VERSION

        csrf_found, version_found = CSRF.search(page), VERSION.search(page)
        assert csrf_found and version_found
        csrf, version = csrf_found.group(1), int(version_found.group(1))
        times, sizes = [], []
        shown = ShownRows()
        shown.read(page)
        shown.read(client.get(f"/programs/{program_id}/list?page=2", headers=HTMX).get_data(True))

        def edit(k: int) -> float:
            nonlocal version
            form = edit_form(csrf, version, k, blocks)
            sent = {**form, "shown": shown.of_page(int(form["edit"]), blocks)}
            started = time.perf_counter()
            answer = client.post(f"/programs/{program_id}/blocks", data=sent, headers=HTMX)
            seconds = time.perf_counter() - started
            assert answer.status_code == 200, answer.status_code
            body = answer.get_data(as_text=True)
            shown.read(body)
            sizes.append(len(body.encode()))
            found = VERSION.search(body)
            version = int(found.group(1)) if found else version + 1
            return seconds

        times = [edit(k) for k in range(12)]
        result["whole edit in-process (Flask test client, SQLite)"] = min(times[2:])
        drawn = []
        for _ in range(5):
            started = time.perf_counter()
            answer = client.get(f"/programs/{program_id}/drawing", headers=HTMX)
            drawn.append(time.perf_counter() - started)
            assert answer.status_code == 200, answer.status_code
        result["the drawing the reply asks for, in-process (made once per version)"] = drawn[0]
        result["reply_bytes"] = sizes[-1]
        result["preview_bytes"] = len(preview(library_program(app, program_id))[0].encode())
        with app.app_context():
            get_library().engine.dispose()
    return result


def library_program(app: Flask, program_id: int) -> Program:
    """The stored program `program_id` (for the size of its drawing)."""
    from app.web import get_library

    with app.app_context():
        return get_library().get(program_id).program


def run(timeout: float = 300.0) -> Section:
    section = Section(f"Editor: an edit and the drawing after it, {BLOCKS}-block program, gunicorn")
    r = run_child(
        "bench.editor:server_case",
        {"blocks": BLOCKS, "edits": EDITS, "workers": WORKERS, "time_limit": TIME_LIMIT},
        timeout,
    )
    parts = run_child("bench.editor:parts_case", {"blocks": BLOCKS}, timeout)
    if "error" in r:
        section.lines.append(f"**failed**: {r['error']}")
        section.target("edit + preview, p95", "≤ 50 ms", "failed", "–")
        return section
    floor = r["static"]["p50"]
    rows = []
    for key, label in (
        ("static", "floor: GET /static/app.css"),
        ("page", "GET the editor page (no save)"),
        ("edits", "POST an edit → the reply (rows, times, entry; asks for the drawing)"),
        ("drawings", "GET the drawing the reply asks for (drawing + cycle-time line)"),
    ):
        s = r[key]
        rows.append(
            [
                label,
                str(s["n"]),
                fmt_seconds(s["p50"]),
                fmt_seconds(s["p95"]),
                fmt_seconds(s["max"]),
                fmt_ratio(s["p50"] / floor),
            ]
        )
    section.lines += [
        f"gunicorn, {WORKERS} sync workers, SQLite (WAL, synchronous FULL), one client in a",
        f"loop; the program has {BLOCKS} blocks. {r['revisions']} revisions stored at the end;",
        f"answers: {r['statuses']}; the reply is {r['fragment_bytes'] / 1000:.1f} kB (p95), the",
        f"drawing it asks for {r['drawing_bytes'] / 1000:.1f} kB (p95). The client asks for",
        "the drawing after each reply, as the page does (the old drawing stays until then).",
        "*× floor* is the p50 over the static file's p50 on the same server.",
        "",
        *table(["request", "n", "p50", "p95", "max", "× floor"], rows),
    ]
    if "error" not in parts:
        moves = parts.pop("moves")
        reply, drawing = parts.pop("reply_bytes"), parts.pop("preview_bytes")
        section.lines += [
            "",
            f"The reply to an edit in place is {reply / 1000:.1f} kB (entry panel, changed rows,",
            "cycle time, version, the request for the drawing); the drawing it asks for is",
            f"{drawing / 1000:.0f} kB.",
            "",
            f"Where an edit's time goes (same program, {moves} moves; each part alone, best",
            "of several, in one process):",
            "",
            *table(["part", "time"], [[name, fmt_seconds(t)] for name, t in parts.items()]),
        ]
    else:
        section.lines += ["", f"(the breakdown failed: {parts['error']})"]
    p95 = r["edits"]["p95"]
    section.target(
        f"edit reply p95 (the drawing follows), {BLOCKS} blocks",
        "≤ 50 ms",
        fmt_seconds(p95),
        fmt_ratio(p95 / TARGET_P95) + " of target",
    )
    drawn = r["drawings"]["p95"]
    section.target(
        f"the drawing after an edit p95, {BLOCKS} blocks",
        "(none; reported)",
        fmt_seconds(drawn),
        "–",
    )
    size = r["fragment_bytes"]
    section.target(
        f"edit reply p95, {BLOCKS} blocks",
        "≤ 50 kB",
        f"{size / 1000:.1f} kB",
        fmt_ratio(size / TARGET_BYTES) + " of target",
    )
    return section
