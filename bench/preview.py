"""Preview: the editor's drawing and cycle time on the server, and its first paint and
panning in Chromium.

Server, a fresh child per case (family at 10^4-10^6 moves):
- *compile*: `compile_program` the first time (the core's cost, cached per block after);
- *draw*: `render()` of the compiled path (the SVG the editor sends, from the tree);
- *estimate*: the cycle time over the chunks (*moves/s*);
- *preview*: `app.web.preview.preview(program)` once the program has been validated (and
  so compiled) as the editor does: what an edit's reply waits for on top of the compile;
- floors in the same child: *walk*, iterating the chunks (what any consumer of every move
  pays), and *one path*, one f-string per move over the chunks (the least any drawing
  that touches each move costs).

Browser, a fresh child per case: the editor page served by the app (temporary SQLite) in
Debian's Chromium (software rendering). *Server* is the page's time to first byte, the
program compiled already (an edit's case); *first paint* is from the response's end to the
first frame after the drawing is set up (inline SVG, or a canvas for large programs);
*pan* is the frames shown while dragging the drawing for two seconds.

Targets (issue 18): ≤ 300 ms on the server and first paint ≤ 1 s at 10^6 moves.
"""

from __future__ import annotations

import re
import time

from bench.common import (
    Result,
    Section,
    best_time,
    drag,
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
TARGET_SECONDS = 0.300
TARGET_PAINT = 1.0
ELEMENT = re.compile(r"<(?![/?!])")
DRAG_SECONDS = 2.0


def one_path(path: object) -> str:
    """The floor: every motion's XY end point in one path, fixed decimals."""
    from app.cnc.path import CompiledPath, Op

    assert isinstance(path, CompiledPath)
    unit = path.units.nm
    parts = [f"M{path.start[0] / unit:.4f} {path.start[1] / unit:.4f}"]
    append = parts.append
    for chunk in path.chunks():
        rows = chunk.rows[chunk.rows["op"] <= Op.ARC_CCW]
        for x, y in zip(rows["x"].tolist(), rows["y"].tolist(), strict=True):
            append(f"L{x / unit:.4f} {y / unit:.4f}")
    return f'<svg xmlns="http://www.w3.org/2000/svg"><path d="{" ".join(parts)}"/></svg>\n'


def server_case(family: str, moves: int) -> Result:
    """(child) Compile, draw, time and preview a `family` program of about `moves` moves."""
    from app.cnc.compiler import compile_program
    from app.cnc.estimate import estimate
    from app.cnc.formats.svg import render
    from app.cnc.validate import validate
    from app.web.preview import preview
    from bench.programs import sized

    program = sized(family, moves)
    started = time.perf_counter()
    path = compile_program(program).path
    compile_seconds = time.perf_counter() - started
    count = len(path)
    most = 5 if count <= 200_000 else 3
    drawing, draw_seconds, peak = measure(
        lambda: render(program, path, swept=True, grid=True, embedded_style=False)
    )
    draw_seconds = min(draw_seconds, best_time(lambda: render(program, path), 3.0, most))
    estimate_seconds = best_time(lambda: estimate(path), 5.0, most)
    problems = validate(program)
    # Drawn afresh each time, as a program opened the first time (after an edit the editor
    # draws only what it changed: bench/editor.py).
    preview_seconds = best_time(lambda: preview(program, problems, keep=False), 5.0, most)
    walk_seconds = best_time(lambda: sum(len(c.rows) for c in path.chunks()), 5.0, most)
    floor = one_path(path)
    floor_seconds = best_time(lambda: one_path(path), 5.0, 1 if count > 200_000 else 3)
    return {
        "moves": count,
        "compile": compile_seconds,
        "draw": draw_seconds,
        "peak": peak,
        "estimate": estimate_seconds,
        "preview": preview_seconds,
        "walk": walk_seconds,
        "floor": floor_seconds,
        "floor_bytes": len(floor.encode()),
        "bytes": len(drawing.svg.encode()),
        "elements": len(ELEMENT.findall(drawing.svg)),
        "uses": drawing.svg.count("<use"),
        "large": drawing.large,
    }


# The first frame after the page has set its drawing up. Deferred scripts (preview.js
# among them) run after parsing ends and before DOMContentLoaded; readyState is
# "interactive" in between, so only a finished DOMContentLoaded says the drawing is set up.
FIRST_FRAME = """() => new Promise(done => {
  const nav = performance.getEntriesByType('navigation')[0];
  const frame = () => requestAnimationFrame(() => requestAnimationFrame(() => {
    const el = document.querySelector('#preview');
    done([nav.requestStart, nav.responseStart, nav.responseEnd, performance.now(),
          el.classList.contains('large') ? 'canvas' : 'SVG', el.dataset.state || '']);
  }));
  if (nav.domContentLoadedEventEnd > 0) { frame(); }
  else { document.addEventListener('DOMContentLoaded', () => setTimeout(frame, 0)); }
})"""

FRAMES = """() => { window.__frames = 0; const count = () => { window.__frames++;
  if (window.__frames < 100000) requestAnimationFrame(count); }; requestAnimationFrame(count); }"""


def browser_case(family: str, moves: int) -> Result:
    """(child) The editor page in Chromium: server time, first paint, frames while panning."""
    import tempfile
    import threading

    from playwright.sync_api import sync_playwright
    from werkzeug.serving import make_server

    from app import create_app
    from app.cnc import cost
    from app.cnc.compiler import compile_program
    from app.cnc.sizes import MAX_MOVES
    from app.cnc.validate import validate
    from app.web import get_library
    from bench.programs import sized
    from tests.test_browser import CHROMIUM, CHROMIUM_ARGS

    program = sized(family, moves)
    estimated = cost.estimate(program, MAX_MOVES).moves
    if estimated > MAX_MOVES:
        # Past what the server stores (app.cnc.sizes): the largest program it takes.
        program = sized(family, moves * MAX_MOVES // estimated)
    validate(program)  # compiled once, as after the edit that saved it
    with tempfile.TemporaryDirectory() as folder:
        app = create_app({"DATABASE_URL": f"sqlite:///{folder}/bench.db", "SECRET_KEY": "b" * 32})
        with app.app_context():
            pid = get_library().create(program).id
        http = make_server("127.0.0.1", 0, app, threaded=True)
        threading.Thread(target=http.serve_forever, daemon=True).start()
        url = f"http://127.0.0.1:{http.server_port}/programs/{pid}"
        try:
            with sync_playwright() as playwright:
                unpaced = [*CHROMIUM_ARGS, "--disable-gpu-vsync", "--disable-frame-rate-limit"]
                browser = playwright.chromium.launch(executable_path=CHROMIUM, args=unpaced)
                page = browser.new_page(viewport={"width": 1500, "height": 950})
                page.goto(url)  # warm: the library, the templates, the compiled program
                paints = []
                for _ in range(3):
                    page.goto(url, wait_until="commit")
                    request, first_byte, end, frame, kind, state = page.evaluate(FIRST_FRAME)
                    # A canvas is painted by the DOMContentLoaded handler, before the frame.
                    assert kind == "SVG" or state == "drawn", (kind, state)
                    paints.append((first_byte - request, frame - end, frame - request, kind))
                server, paint, total, kind = min(paints, key=lambda p: p[2])
                page.evaluate(FRAMES)
                box = page.locator("#preview").bounding_box()
                elapsed, step = drag(page, box, DRAG_SECONDS, 150)
                frames = int(page.evaluate("window.__frames"))
                browser.close()
        finally:
            http.shutdown()
            with app.app_context():
                get_library().engine.dispose()
    return {
        "moves": len(compile_program(program).path),
        "server": server / 1000,
        "paint": paint / 1000,
        "total": total / 1000,
        "kind": kind,
        "frames": frames,
        "elapsed": elapsed,
        "moves_sent": step,
    }


def _against(seconds: float, baseline: float | None) -> str:
    """`seconds`, with its ratio to the baseline's when there is one."""
    if not baseline:
        return fmt_seconds(seconds)
    return f"{fmt_seconds(seconds)} ({fmt_ratio(seconds / baseline)})"


def _pan(b: Result) -> str:
    return f"{b['frames']} in {b['elapsed']:.1f} s ({b['frames'] / b['elapsed']:.0f}/s)"


def run(sizes: tuple[int, ...] = SIZES, timeout: float = 300.0) -> Section:
    from bench.programs import FAMILIES

    section = Section("Preview: drawing, cycle time and first paint")
    server_rows: list[list[str]] = []
    browser_rows: list[list[str]] = []
    worst: Result | None = None
    slowest_rate: float | None = None
    worst_paint: Result | None = None
    # The same-run baseline in the browser: the editor page of a one-pattern program
    # (a handful of moves), everything but the drawing's size alike.
    base = run_child("bench.preview:browser_case", {"family": "grid", "moves": 1}, timeout)
    if "error" in base:
        browser_rows.append(
            ["baseline: grid, 1 pattern", "", f"failed: {base['error']}"] + [""] * 3
        )
        base = {}
    else:
        browser_rows.append(
            [
                "baseline: grid, 1 pattern",
                fmt_count(base["moves"]),
                base["kind"],
                fmt_seconds(base["server"]),
                fmt_seconds(base["paint"]),
                _pan(base),
            ]
        )
    for size in sizes:
        for family in FAMILIES:
            args = {"family": family, "moves": size}
            r = run_child("bench.preview:server_case", args, timeout)
            if "error" in r:
                server_rows.append([family, fmt_count(size), f"failed: {r['error']}"] + [""] * 7)
            else:
                if size == sizes[-1]:
                    if worst is None or r["preview"] > worst["preview"]:
                        worst = r
                    rate = r["moves"] / r["estimate"]
                    slowest_rate = rate if slowest_rate is None else min(slowest_rate, rate)
                server_rows.append(
                    [
                        family,
                        fmt_count(r["moves"]),
                        fmt_seconds(r["compile"]),
                        fmt_seconds(r["draw"]),
                        f"{fmt_seconds(r['estimate'])} ({fmt_rate(r['moves'] / r['estimate'])})",
                        fmt_seconds(r["preview"]),
                        f"{fmt_bytes(r['bytes'])}, {fmt_count(r['elements'])} elements, "
                        f"{fmt_count(r['uses'])} uses",
                        fmt_bytes(r["peak"]),
                        f"{fmt_seconds(r['walk'])}; {fmt_seconds(r['floor'])}, "
                        f"{fmt_bytes(r['floor_bytes'])}",
                        fmt_ratio(r["preview"] / r["floor"]),
                    ]
                )
            b = run_child("bench.preview:browser_case", args, timeout)
            if "error" in b:
                browser_rows.append([family, fmt_count(size), f"failed: {b['error']}", "", "", ""])
                continue
            if size == sizes[-1] and (worst_paint is None or b["paint"] > worst_paint["paint"]):
                worst_paint = b
            browser_rows.append(
                [
                    family,
                    fmt_count(size),
                    b["kind"],
                    _against(b["server"], base.get("server")),
                    _against(b["paint"], base.get("paint")),
                    _pan(b),
                ]
            )
    section.lines += [
        "Server, one child process per case. *Draw* and *estimate* are the best of up to five",
        "runs (three at 10^6); *preview* is `preview()` after `validate()` (the compile cached,",
        "as in the editor; drawn afresh, as a program opened the first time: after an edit the",
        "editor draws only what changed, see the editor's section). *Floors* (same child):",
        "iterating the chunks; one path through every",
        "move (one f-string per move). *× floor* is preview over the one-path floor.",
        "",
        *table(
            [
                "family",
                "moves",
                "compile (first)",
                "draw",
                "estimate (moves/s)",
                "preview",
                "SVG",
                "peak memory (draw)",
                "floors: walk; one path",
                "× floor",
            ],
            server_rows,
        ),
        "",
        "Chromium (Debian's, software rendering), the editor page from the app on SQLite; the",
        "best of three loads. *Server*: time to first byte (program compiled already); *first",
        "paint*: from the response's end to the first frame with the drawing; *pan*: frames",
        f"shown while dragging for {DRAG_SECONDS:.0f} s (the page's own frame count). Ratios",
        "in brackets are over the baseline's (same run): the page of a one-pattern program.",
        "",
        *table(["family", "moves", "drawn as", "server", "first paint", "pan"], browser_rows),
    ]
    if worst is not None:
        section.target(
            f"preview on the server, {fmt_count(sizes[-1])} moves (slowest family)",
            "≤ 300 ms",
            fmt_seconds(worst["preview"]),
            fmt_ratio(worst["preview"] / TARGET_SECONDS) + " of target",
        )
    if slowest_rate is not None:
        section.target(
            f"cycle time over the chunks, {fmt_count(sizes[-1])} moves (slowest family)",
            "≥ 1 000 000 moves/s",
            fmt_rate(slowest_rate),
            fmt_ratio(slowest_rate / 1_000_000) + " of target",
        )
    if worst_paint is not None:
        section.target(
            f"first paint in Chromium, {fmt_count(sizes[-1])} moves (slowest family)",
            "≤ 1 s",
            fmt_seconds(worst_paint["paint"]),
            fmt_ratio(worst_paint["paint"] / TARGET_PAINT) + " of target",
        )
    return section
