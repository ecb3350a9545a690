"""Editor: p50/p95 latency of an edit plus preview refresh on a 500-block program, under
the production server (gunicorn, `make run`'s default of 2 workers, SQLite).

The program (bench/programs.py `editor_program`: holes, bolt circles, pockets, contours,
LOOPs) is created through the library API in a temporary SQLite database; gunicorn is
started on a free 127.0.0.1 port. One client then does what the editor's htmx form does:
POST /programs/<id>/blocks with `edit=N`, the DRILL's fields and the version it was shown,
and gets the editor fragment back with the new block list and SVG preview. Each edit moves
one DRILL (block 1, 11, 21... in turn) so every save is a real change and a new revision.

Baselines in the same run, same server: a static file (the server's floor) and the GET of
the editor page (the same rendering without the save). Then, in a child process, the parts
of one edit timed alone (document JSON, revision summary, validation, interpretation,
estimate, drawing, the whole request through Flask's test client) to show where the time
goes. Target (issue 10): p95 ≤ 50 ms.
"""

from __future__ import annotations

import tempfile
import time
from decimal import Decimal
from pathlib import Path

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

BLOCKS = 500
EDITS = 40
WORKERS = 2
TIME_LIMIT = 120.0
TARGET_P95 = 0.050
HTMX = {"HX-Request": "true"}


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
            page = client.get(f"/programs/{program_id}")
            csrf, version = page.csrf_token(), page.version()
            if page.status != 200 or csrf is None or version is None:
                return {"error": f"editor page answered {page.status} without a form"}
            static = [client.get("/static/app.css").seconds for _ in range(30)]
            pages = [client.get(f"/programs/{program_id}").seconds for _ in range(10)]
            latencies: list[float] = []
            statuses: dict[str, int] = {}
            fragment = 0
            started = time.monotonic()
            for k in range(edits + 2 * workers):
                if time.monotonic() - started > time_limit:
                    break
                answer = client.post(
                    f"/programs/{program_id}/blocks", edit_form(csrf, version, k, blocks), HTMX
                )
                statuses[str(answer.status)] = statuses.get(str(answer.status), 0) + 1
                if answer.status != 200:
                    return {"error": f"edit {k} answered {answer.status}: {answer.body[:200]}"}
                version = answer.version() or version + 1
                fragment = len(answer.body.encode())
                if k >= 2 * workers:  # the first edit on each worker warms its caches
                    latencies.append(answer.seconds)
        revisions = len(open_library(url, seed_demo=False).revisions(program_id))
    return {
        "edits": _stats(latencies),
        "static": _stats(static),
        "page": _stats(pages),
        "statuses": statuses,
        "fragment_bytes": fragment,
        "revisions": revisions,
    }


def parts_case(blocks: int) -> Result:
    """(child) The parts of one edit, each timed alone (best of 5) on the same program."""
    import dataclasses

    from app import create_app
    from app.cnc import document
    from app.cnc.diff import summary
    from app.cnc.emit.svg import draw
    from app.cnc.estimate import estimate
    from app.cnc.interpret import interpret
    from app.cnc.validate import validate
    from app.web.preview import preview
    from bench.common import best_time
    from bench.programs import editor_program

    program = editor_program(blocks)
    moved = dataclasses.replace(program, blocks=program.blocks[1:] + program.blocks[:1])
    text = document.dumps(program)
    toolpath = interpret(program)
    parts = {
        "document.loads (×3 per edit)": lambda: document.loads(text),
        "document.dumps (×2 per edit)": lambda: document.dumps(program),
        "diff summary for the revision": lambda: summary(program, moved),
        "validate (×2 per edit)": lambda: validate(program),
        "interpret": lambda: interpret(program),
        "estimate": lambda: estimate(toolpath),
        "draw (SVG)": lambda: draw(program, embedded_style=False),
        "editor preview() = validate + interpret + estimate + draw": lambda: preview(program),
    }
    result: Result = {"moves": len(toolpath.moves)}
    for name, call in parts.items():
        result[name] = best_time(call, budget=3.0)
    # One error early in the program: preview() draws and times the rest (it used to look
    # for the longest valid prefix by validating every prefix from the whole program down).
    from app.cnc.blocks import Hole

    first = program.blocks[0]
    assert isinstance(first, Hole)
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
            result["library.get (loads the document)"] = best_time(
                lambda: library.get(program_id), budget=3.0
            )
            versions = iter(range(stored.info.version, stored.info.version + 100))
            shifted = [program, moved]

            def save() -> None:
                version = next(versions)
                library.save(program_id, shifted[version % 2], based_on=version)

            result["library.save (read, loads, diff, 2 dumps, commit)"] = best_time(
                save, budget=3.0
            )
        with app.test_request_context(f"/programs/{program_id}", headers=HTMX):
            from jinja2_fragments.flask import render_block

            from app.web import editor as web

            stored = get_library().get(program_id)
            entry = web.Entry(at=len(stored.program.blocks) + 1, editing=False)
            result["editor context (validate + preview())"] = best_time(
                lambda: web.context(stored, entry), budget=3.0
            )
            ctx = web.context(stored, entry)
            result["render the editor fragment (Jinja)"] = best_time(
                lambda: render_block("editor/program.html", "editor", **ctx), budget=3.0
            )
        client = app.test_client()
        page = client.get(f"/programs/{program_id}").get_data(as_text=True)
        from bench.server import CSRF, VERSION

        csrf_found, version_found = CSRF.search(page), VERSION.search(page)
        assert csrf_found and version_found
        csrf, version = csrf_found.group(1), int(version_found.group(1))
        times = []
        for k in range(12):
            started = time.perf_counter()
            answer = client.post(
                f"/programs/{program_id}/blocks",
                data=edit_form(csrf, version, k, blocks),
                headers=HTMX,
            )
            times.append(time.perf_counter() - started)
            assert answer.status_code == 200, answer.status_code
            found = VERSION.search(answer.get_data(as_text=True))
            version = int(found.group(1)) if found else version + 1
        result["whole edit in-process (Flask test client, SQLite)"] = min(times[2:])
        with app.app_context():
            get_library().engine.dispose()
    return result


def run(timeout: float = 300.0) -> Section:
    section = Section(f"Editor: edit + preview refresh, {BLOCKS}-block program, gunicorn")
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
        ("edits", "POST an edit → editor fragment with preview"),
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
        f"answers: {r['statuses']}; the fragment is {r['fragment_bytes'] / 1000:.0f} kB.",
        "*× floor* is the p50 over the static file's p50 on the same server.",
        "",
        *table(["request", "n", "p50", "p95", "max", "× floor"], rows),
    ]
    if "error" not in parts:
        moves = parts.pop("moves")
        section.lines += [
            "",
            f"Where an edit's time goes (same program, {moves} moves; each part alone, best",
            "of five, in one process):",
            "",
            *table(["part", "time"], [[name, fmt_seconds(t)] for name, t in parts.items()]),
        ]
    else:
        section.lines += ["", f"(the breakdown failed: {parts['error']})"]
    p95 = r["edits"]["p95"]
    section.target(
        f"edit + preview p95, {BLOCKS} blocks",
        "≤ 50 ms",
        fmt_seconds(p95),
        fmt_ratio(p95 / TARGET_P95) + " of target",
    )
    return section
