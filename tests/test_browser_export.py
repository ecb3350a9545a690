"""The export page's choices in a real browser (Playwright driving Debian's Chromium).

A tape of uncalibrated tools offers ways out ("Export with z-zero = g94: …", "Fill in the
tool table"). They rendered broken: each long label squeezed into a 120 px cell of the
editor's menu grid, its border broken at every wrapped line and the next choice's bullet
drawn over it. Each choice must be one button, its whole label inside it, none overlapping.
Screenshots go to test-output/screenshots/.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from playwright.sync_api import Page, expect
from werkzeug.serving import make_server

from app import create_app
from app.cnc import document
from app.web import get_library
from tests.test_browser import browser, page, shot

__all__ = ["browser", "page"]

UNCALIBRATED = Path(__file__).parent / "bad" / "tool-uncalibrated-for-a-tape" / "program.json"


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, int]]:
    db = tmp_path_factory.mktemp("export") / "library.db"
    app = create_app({"DATABASE_URL": f"sqlite:///{db}", "SECRET_KEY": "browser-test" * 32})
    with app.app_context():
        pid = get_library().create(document.loads(UNCALIBRATED.read_text())).id
    http = make_server("127.0.0.1", 0, app, threaded=True)
    thread = threading.Thread(target=http.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{http.server_port}", pid
    http.shutdown()
    with app.app_context():
        get_library().engine.dispose()


Box = tuple[float, float, float, float]


def overlap(a: Box, b: Box) -> bool:
    return a[0] < b[0] + b[2] and b[0] < a[0] + a[2] and a[1] < b[1] + b[3] and b[1] < a[1] + a[3]


@pytest.mark.parametrize("width", [1500, 390])
@pytest.mark.parametrize("where", ["export", "setup"])
def test_the_tape_s_choices_are_whole_buttons(
    page: Page, server: tuple[str, int], width: int, where: str
) -> None:
    url, pid = server
    page.set_viewport_size({"width": width, "height": 900})
    path = "export?go=1&" if where == "export" else "setup?"
    page.goto(f"{url}/programs/{pid}/{path}target=tape-eia")
    choices = page.locator(".offer li a.button")
    expect(choices.first).to_be_visible()
    expect(choices.first).to_contain_text("z-zero = g94")
    shot(page, f"export-choices-{where}-{width}")
    boxes: list[Box] = []
    for k in range(choices.count()):
        choice = choices.nth(k)
        expect(choice).to_be_visible()
        # One box: a button broken across lines has one client rectangle per line.
        rects = choice.evaluate("a => a.getClientRects().length")
        assert rects == 1, f"choice {k + 1} is drawn in {rects} pieces"
        # The whole label inside its button, no list bullet beside it.
        assert choice.evaluate("a => a.scrollWidth <= a.clientWidth + 1")
        assert choice.evaluate("a => getComputedStyle(a.parentElement).listStyleType") == "none"
        box = choice.bounding_box()
        assert box is not None and box["width"] > 150
        assert box["x"] >= 0 and box["x"] + box["width"] <= width
        boxes.append((box["x"], box["y"], box["width"], box["height"]))
    assert len(boxes) >= 2
    for i, a in enumerate(boxes):
        for b in boxes[i + 1 :]:
            assert not overlap(a, b), f"choices overlap: {a} {b}"
