"""Editor: p50/p95 latency of an edit and of the redrawn preview after it on a 500-block
program, under the production server (gunicorn, `make run`'s default of 2 workers, SQLite).

The program (bench/programs.py `editor_program`: holes, bolt circles, pockets, contours,
LOOPs) is created through the library API in a temporary SQLite database; gunicorn is
started on a free 127.0.0.1 port. One client then does what the editor's htmx form does:
POST /programs/<id>/blocks with `edit=N`, the DRILL's fields and the version it was shown,
and gets the reply back (the entry panel, the rows that changed, the cycle time, and what
changed in the drawing when the edit said which version the page's drawing is, `drawn`, as
static/preview.js sends it); a reply that asks for the whole drawing instead is followed by
its GET, as the page does. *Edit → redrawn preview* is the reply, plus that GET when there
is one. The same edits are made first as the page made them before issue 32 (no `drawn`:
every reply asks for the whole drawing, which the client GETs), then as it makes them now.
Each edit moves one DRILL (block 1, 11, 21... in turn) so every save is a real change and a
new revision. With two workers an edit may land on the worker that did not show the
version it starts from (it then reads that version and works out its rows and drawing).

Baselines in the same run, same server: a static file (the server's floor) and the GET of
the editor page (the same rendering without the save). Then, in a child process, the parts
of one edit timed alone (document JSON, revision summary, validation, interpretation,
estimate, the compile and cycle time of an edited version, the rows of a starting version
another worker saved, drawing, the whole request through Flask's test client) to show where
the time goes. Targets (issues 10, 18 and 32): reply p95 ≤ 50 ms and ≤ 50 kB, edit →
redrawn preview p95 ≤ 100 ms.
"""

from __future__ import annotations

import re
import tempfile
import time
from decimal import Decimal
from pathlib import Path
from typing import TYPE_CHECKING, Any

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
TARGET_REDRAWN_P95 = 0.100  # issue 32: edit → redrawn preview (moonshot: one frame, 16 ms)
TARGET_BYTES = 50_000  # issue 18: the reply to an edit ≤ 50 kB
HTMX = {"HX-Request": "true"}
# The element of an edit's reply that asks for the new drawing.
DRAWING = re.compile(r'id="drawing-refresh"[^>]*hx-get="([^"]+)"')
# ...or what changed in the drawing, from the version the page showed to the edit's.
PATCH = re.compile(r'<template id="drawing-patch"[^>]*data-to="(\d+)"')


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
    """(child) Start gunicorn on a temporary SQLite library and time edits through it: the
    edits as the page made them before issue 32 (the whole drawing after each), then as it
    makes them now (what changed in the drawing, in the reply)."""
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
            result: Result = {}
            statuses: dict[str, int] = {}
            drawn = version  # the version of the drawing the client shows
            started = time.monotonic()
            for mode in ("whole", "changes"):
                replies: list[float] = []
                redrawn: list[float] = []
                drawings: list[float] = []
                sizes: list[int] = []
                drawing_sizes: list[int] = []
                patched = 0
                for k in range(edits + 2 * workers):
                    if time.monotonic() - started > time_limit:
                        break
                    form = edit_form(csrf, version, k, blocks)
                    sent = {**form, "shown": shown.of_page(int(form["edit"]), blocks)}
                    if mode == "changes":
                        sent["drawn"] = str(drawn)
                    answer = client.post(f"/programs/{program_id}/blocks", sent, HTMX)
                    statuses[str(answer.status)] = statuses.get(str(answer.status), 0) + 1
                    if answer.status != 200:
                        return {"error": f"edit {k} answered {answer.status}: {answer.body[:200]}"}
                    version = answer.version() or version + 1
                    shown.read(answer.body)
                    sizes.append(len(answer.body.encode()))
                    seconds = answer.seconds
                    changed = PATCH.search(answer.body)
                    if changed is not None:
                        drawn = int(changed.group(1))
                        patched += 1
                    else:
                        asked = DRAWING.search(answer.body)
                        if asked is None:
                            return {"error": f"edit {k}'s reply has no drawing, nor asks for one"}
                        drawing = client.get(asked.group(1).replace("&amp;", "&"), HTMX)
                        if drawing.status != 200:
                            return {"error": f"the drawing after edit {k}: {drawing.status}"}
                        drawn = version
                        drawing_sizes.append(len(drawing.body.encode()))
                        seconds += drawing.seconds
                        if k >= 2 * workers:
                            drawings.append(drawing.seconds)
                    if k >= 2 * workers:  # the first edit on each worker warms its caches
                        replies.append(answer.seconds)
                        redrawn.append(seconds)
                result[mode] = {
                    "edits": _stats(replies),
                    "redrawn": _stats(redrawn),
                    "drawings": _stats(drawings),
                    "patched": patched,
                    "fragment_bytes": percentile([float(n) for n in sizes], 95),
                    "drawing_bytes": (
                        percentile([float(n) for n in drawing_sizes], 95) if drawing_sizes else 0
                    ),
                }
        revisions = len(open_library(url, seed_demo=False).revisions(program_id))
    return {
        **result,
        "static": _stats(static),
        "page": _stats(pages),
        "statuses": statuses,
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
    from app.cnc.estimate import estimate
    from app.cnc.formats.svg import draw
    from app.cnc.interpret import interpret
    from app.cnc.validate import validate
    from app.web.editor_page import shown_of
    from app.web.preview import parts as split
    from app.web.preview import patch, preview
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
    before_svg, after_svg = preview(program).svg, preview(edited()).svg
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
        "draw (SVG), nothing kept (as the svg export draws)": lambda: draw(
            program, embedded_style=False
        ),
        "editor preview() of an edited version, nothing kept (validate + compile + estimate"
        " + draw)": lambda: preview(edited(), keep=False),
        "editor preview() of an edited version, the drawings of the nodes it left alone"
        " kept (the same validate + compile + estimate)": lambda: preview(edited()),
        "what changed in the drawing: both drawings split and compared (parts + patch)": (
            lambda: patch(split(before_svg), split(after_svg))
        ),
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
            {"DATABASE_URL": f"sqlite:///{Path(tmp) / 'parts.db'}", "SECRET_KEY": "bench" * 32}
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
            sent = {
                **form,
                "shown": shown.of_page(int(form["edit"]), blocks),
                "drawn": str(version),  # each reply's changes are applied, as the page does
            }
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
        result[
            "whole edit in-process, its reply with the drawing's changes (Flask test client)"
        ] = min(times[2:])
        drawn = []
        for _ in range(5):
            started = time.perf_counter()
            answer = client.get(f"/programs/{program_id}/drawing", headers=HTMX)
            drawn.append(time.perf_counter() - started)
            assert answer.status_code == 200, answer.status_code
        result["the whole drawing (GET), in-process (made once per version)"] = drawn[0]
        result["reply_bytes"] = sizes[-1]
        result["preview_bytes"] = len(preview(library_program(app, program_id))[0].encode())
        with app.app_context():
            get_library().engine.dispose()
    return result


# The phases of one edit's request, as (label, module, function): the function the request
# calls for the phase, wrapped by `phases_case` to add up its time. Indented labels are part
# of the phase above them.
PHASES = (
    ("parse the form, build the block", "app.web.editor", "parse_block"),
    ("validate the new version", "app.web.editor", "value_problems"),
    ("  its cost (moves, before anything compiles)", "app.cnc.validate:_Checker", "check_size"),
    ("  its geometry (the compile)", "app.cnc.validate:_Checker", "check_geometry"),
    ("  the process rules (pilot, stock)", "app.cnc.validate:_Checker", "check_process"),
    ("save (the library's save, the saved version read)", "app.web.editor", "_save"),
    (
        "  the row's columns (cost check, document text, search words)",
        "app.storage.library",
        "_columns",
    ),
    ("  the revision's summary (diff)", "app.storage.library", "summary"),
    ("  the SQL update and revision insert", "app.storage.revisions:Versioned", "write"),
    ("the reply", "app.web.editor", "render_reply"),
    ("  the cycle time (compile + estimate)", "app.web.editor_page", "times"),
    ("  the drawing's changes (draw, split, compare)", "app.web.editor_page", "drawing_patch"),
    ("    the drawing (compile + draw)", "app.web.editor_page", "preview"),
    ("  the templates", "app.web.editor_page", "render_template"),
)


def phases_case(blocks: int, edits: int) -> Result:
    """(child) One process, the Flask test client: the mean time of each phase of an edit
    that says which version the page's drawing is (the reply carries the drawing's changes),
    each phase's function wrapped to add up its time; `request` is the whole request. The
    first edits warm the per-block memos, as a server's first edits do."""
    import importlib

    from app import create_app
    from app.web import get_library
    from bench.programs import editor_program
    from bench.server import CSRF, VERSION

    spent: dict[str, float] = {}

    def timed(label: str, call: Any) -> Any:
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            started = time.perf_counter()
            try:
                return call(*args, **kwargs)
            finally:
                spent[label] = spent.get(label, 0.0) + time.perf_counter() - started

        return wrapper

    for label, where, name in PHASES:
        module_name, _, class_name = where.partition(":")
        owner: Any = importlib.import_module(module_name)
        if class_name:
            owner = getattr(owner, class_name)
        setattr(owner, name, timed(label, getattr(owner, name)))
    with tempfile.TemporaryDirectory() as tmp:
        app = create_app(
            {"DATABASE_URL": f"sqlite:///{Path(tmp) / 'phases.db'}", "SECRET_KEY": "bench" * 32}
        )
        with app.app_context():
            program_id = get_library().create(editor_program(blocks)).id
        client = app.test_client()
        page = client.get(f"/programs/{program_id}?edit=1").get_data(as_text=True)
        csrf_found, version_found = CSRF.search(page), VERSION.search(page)
        assert csrf_found and version_found
        csrf, version = csrf_found.group(1), int(version_found.group(1))
        shown = ShownRows()
        shown.read(page)
        for number in range(2, blocks // 50 + 2):
            shown.read(
                client.get(f"/programs/{program_id}/list?page={number}", headers=HTMX).get_data(
                    as_text=True
                )
            )
        total = 0.0
        warm = 4
        for k in range(warm + edits):
            if k == warm:
                spent.clear()
                total = 0.0
            form = edit_form(csrf, version, k, blocks)
            sent = {
                **form,
                "shown": shown.of_page(int(form["edit"]), blocks),
                "drawn": str(version),
            }
            started = time.perf_counter()
            answer = client.post(f"/programs/{program_id}/blocks", data=sent, headers=HTMX)
            total += time.perf_counter() - started
            assert answer.status_code == 200, answer.status_code
            body = answer.get_data(as_text=True)
            shown.read(body)
            found = VERSION.search(body)
            version = int(found.group(1)) if found else version + 1
        with app.app_context():
            get_library().engine.dispose()
    result: Result = {"request": total / edits}
    for label, _, _ in PHASES:
        result[label] = spent.get(label, 0.0) / edits
    return result


# In the page: when the edit's submit button is clicked, and when the drawing of the version
# asked for (`window.__want`) is in the page and the frame after it painted.
WATCH_REDRAWN = """() => {
  window.__redrawn = [];
  document.addEventListener('click', (e) => {
    if (e.target.closest('#entry button[data-submit]')) window.__clicked = performance.now();
  }, true);
  new MutationObserver(() => {
    const host = document.getElementById('preview');
    if (!host || !window.__want || host.dataset.version !== window.__want) return;
    const clicked = window.__clicked, inPage = performance.now();
    window.__want = null;
    requestAnimationFrame(() => requestAnimationFrame(() => {
      window.__redrawn.push([inPage - clicked, performance.now() - clicked]);
    }));
  }).observe(document.body, {subtree: true, childList: true, attributes: true,
                             attributeFilter: ['data-version']});
}"""


def browser_case(blocks: int, edits: int, workers: int, time_limit: float) -> Result:
    """(child) Edits in Chromium against gunicorn, as a machinist makes them: open DRILL
    1, 11, … 91 in turn, type a new X, press the button; the time from the click to the new
    drawing in the page, and to the frame painted after it. First as the page worked before
    issue 32 (its drawing said to be of no version: each reply asks for the whole drawing,
    which is fetched and swapped in), then as it works now (the reply's changes applied)."""
    from playwright.sync_api import sync_playwright

    from app.storage.library import open_library
    from bench.programs import EDITABLE_STRIDE, editor_program
    from tests.test_browser import CHROMIUM, CHROMIUM_ARGS

    result: Result = {}
    with tempfile.TemporaryDirectory() as tmp:
        url = f"sqlite:///{Path(tmp) / 'bench.db'}"
        library = open_library(url)
        program_id = library.create(editor_program(blocks)).id
        library.engine.dispose()
        with production_server(url, workers, Path(tmp)) as server, sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
            page = browser.new_page(viewport={"width": 1500, "height": 950})
            # The list's first page, where the edited blocks are.
            page.goto(f"http://{server.host}:{server.port}/programs/{program_id}?page=1")
            page.evaluate(WATCH_REDRAWN)
            version = int(page.locator("#preview").get_attribute("data-version") or "1")
            started = time.monotonic()
            timed: dict[str, list[list[float]]] = {"whole": [], "changes": []}
            # The two ways in turn, edit by edit: the machine's load drifts alike for both.
            for k in range(2 * (edits + 2 * workers)):
                if time.monotonic() - started > time_limit:
                    break
                mode = ("whole", "changes")[k % 2]
                block = (k % 10) * EDITABLE_STRIDE + 1
                page.locator(f'.block-row[data-block="{block}"] .block-link').click()
                page.locator("#entry h2", has_text=f"Block {block}:").wait_for()
                # Each edit a new X for its block (the same block comes back every 10 edits).
                x = Decimal(k % 10) + Decimal("0.5") + Decimal((k // 10) % 9 + 1) / 100
                page.locator("#f-x").fill(str(x))
                if mode == "whole":
                    page.evaluate("document.getElementById('preview').dataset.version = '0'")
                version += 1
                page.evaluate(f"window.__want = '{version}'")
                page.locator("#entry button[data-submit]").click()
                deadline = time.monotonic() + 30
                while page.evaluate("window.__redrawn.length") < k + 1:
                    if time.monotonic() > deadline:
                        return {"error": f"{mode} edit {k}: no drawing of v{version}"}
                    time.sleep(0.005)
                if k >= 4 * workers:  # the first edits on each worker warm its caches
                    timed[mode].append(page.evaluate("window.__redrawn")[k])
            for mode, times in timed.items():
                result[mode] = {
                    "in_page": _stats([t[0] / 1000 for t in times]),
                    "painted": _stats([t[1] / 1000 for t in times]),
                }
            browser.close()
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
    phases = run_child("bench.editor:phases_case", {"blocks": BLOCKS, "edits": 30}, timeout)
    browser = run_child(
        "bench.editor:browser_case",
        {"blocks": BLOCKS, "edits": 16, "workers": WORKERS, "time_limit": 60.0},
        timeout,
    )
    if "error" in r:
        section.lines.append(f"**failed**: {r['error']}")
        section.target("edit → redrawn preview, p95", "≤ 100 ms", "failed", "–")
        return section
    floor = r["static"]["p50"]
    rows = []
    whole, now = r["whole"], r["changes"]
    for s, label in (
        (r["static"], "floor: GET /static/app.css"),
        (r["page"], "GET the editor page (no save)"),
        (whole["edits"], "the old way: POST an edit → the reply (asks for the whole drawing)"),
        (whole["drawings"], "the old way: GET the whole drawing the reply asks for"),
        (whole["redrawn"], "**the old way: edit → redrawn preview** (the reply + the GET)"),
        (now["edits"], "the new way: POST an edit → the reply, with what changed in the drawing"),
        (now["drawings"], "the new way: GET the whole drawing (replies that ask for it)"),
        (now["redrawn"], "**the new way: edit → redrawn preview** (the reply alone)"),
    ):
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
        f"answers: {r['statuses']}. *The old way*: the edits as the page made them before",
        "issue 32 (every reply asks for the whole drawing, which the client then GETs, as the",
        f"page did: reply {whole['fragment_bytes'] / 1000:.1f} kB, drawing",
        f"{whole['drawing_bytes'] / 1000:.1f} kB at p95). *The new way*: the edit says which",
        "version the page's drawing is, and the reply carries what changed in it",
        f"({now['patched']} of {now['edits']['n'] + 2 * WORKERS} replies did; reply",
        f"{now['fragment_bytes'] / 1000:.1f} kB at p95). Same server, same run, one after the",
        "other. *× floor* is the p50 over the static file's p50 on the same server.",
        "",
        *table(["request", "n", "p50", "p95", "max", "× floor"], rows),
    ]
    if "error" not in browser:
        rows = [
            [
                label,
                str(browser[mode][key]["n"]),
                fmt_seconds(browser[mode][key]["p50"]),
                fmt_seconds(browser[mode][key]["p95"]),
                fmt_seconds(browser[mode][key]["max"]),
            ]
            for mode, key, label in (
                ("whole", "in_page", "the old way: the whole drawing fetched and swapped in"),
                ("whole", "painted", "the old way: ...and the frame after it painted"),
                ("changes", "in_page", "the new way: the reply's changes applied"),
                ("changes", "painted", "the new way: ...and the frame after it painted"),
            )
        ]
        section.lines += [
            "",
            "In Chromium against the same kind of server, the same edits made through the page",
            "(open the block, type X, press the button), both ways in turn, edit by edit: from",
            "the click to the new version's drawing in the page, and to the frame after it.",
            "",
            *table(["edit → redrawn preview, in the browser", "n", "p50", "p95", "max"], rows),
        ]
    else:
        section.lines += ["", f"(the browser's part failed: {browser['error']})"]
    if "error" not in parts:
        moves = parts.pop("moves")
        reply, drawing = parts.pop("reply_bytes"), parts.pop("preview_bytes")
        section.lines += [
            "",
            f"The reply to an edit in place is {reply / 1000:.1f} kB (entry panel, changed rows,",
            "cycle time, version, what changed in the drawing); the whole drawing is",
            f"{drawing / 1000:.0f} kB.",
            "",
            f"Where an edit's time goes (same program, {moves} moves; each part alone, best",
            "of several, in one process):",
            "",
            *table(["part", "time"], [[name, fmt_seconds(t)] for name, t in parts.items()]),
        ]
    else:
        section.lines += ["", f"(the breakdown failed: {parts['error']})"]
    if "error" not in phases:
        request = phases.pop("request")
        section.lines += [
            "",
            "The phases of one edit's request (one process, the Flask test client, 30 edits",
            "after 4 that warm it; the mean of each phase's function, inside the request's",
            f"{fmt_seconds(request)}; indented rows are part of the row above):",
            "",
            *table(
                ["phase", "time", "share"],
                [[n, fmt_seconds(t), f"{100 * t / request:.0f} %"] for n, t in phases.items()],
            ),
        ]
    else:
        section.lines += ["", f"(the phases failed: {phases['error']})"]
    p95 = now["redrawn"]["p95"]
    section.target(
        f"edit → redrawn preview p95, {BLOCKS} blocks (before: "
        f"{fmt_seconds(whole['redrawn']['p95'])} in the same run)",
        "≤ 100 ms",
        fmt_seconds(p95),
        fmt_ratio(p95 / TARGET_REDRAWN_P95) + " of target",
    )
    reply_p95 = now["edits"]["p95"]
    section.target(
        f"edit reply p95 (with the drawing's changes), {BLOCKS} blocks",
        "≤ 50 ms",
        fmt_seconds(reply_p95),
        fmt_ratio(reply_p95 / TARGET_P95) + " of target",
    )
    size = now["fragment_bytes"]
    section.target(
        f"edit reply p95, {BLOCKS} blocks",
        "≤ 50 kB",
        f"{size / 1000:.1f} kB",
        fmt_ratio(size / TARGET_BYTES) + " of target",
    )
    return section
