"""The editor at the machine (issue 20), in a real browser (Playwright, Debian's Chromium).

Each test here is a trap a machinist met in the trial, or what the issue asks the editor
to show; each failed before its fix (the commit that fixed it says how).
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from dataclasses import dataclass

import pytest
from flask import Flask
from playwright.sync_api import Page, expect
from werkzeug.serving import make_server

from app import create_app
from app.cnc.blocks import Program
from app.web import get_library
from bench.programs import editor_program
from tests.test_browser import browser, page, settle, until

# The browser and the page (which fails the test on any console error) are test_browser's.
__all__ = ["browser", "page"]


@dataclass(frozen=True)
class Served:
    url: str
    app: Flask

    def create(self, program: Program) -> int:
        with self.app.app_context():
            return get_library().create(program).id


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    db = tmp_path_factory.mktemp("browser-editor") / "library.db"
    app = create_app({"DATABASE_URL": f"sqlite:///{db}", "SECRET_KEY": "browser-test"})
    http = make_server("127.0.0.1", 0, app, threaded=True)
    thread = threading.Thread(target=http.serve_forever, daemon=True)
    thread.start()
    yield Served(f"http://127.0.0.1:{http.server_port}", app)
    http.shutdown()
    with app.app_context():
        get_library().engine.dispose()


def in_list_view(page: Page, number: int) -> bool:
    """Row `number` is on the list's page and scrolled into the list's visible part."""
    found: bool = page.evaluate(
        """(n) => {
          const row = document.querySelector('.block-row[data-block="' + n + '"]');
          const list = document.querySelector('.block-list');
          if (!row || !list) return false;
          const r = row.getBoundingClientRect(), l = list.getBoundingClientRect();
          return r.top >= l.top - 1 && r.bottom <= l.bottom + 1;
        }""",
        number,
    )
    return found


def test_after_editing_block_301_of_552_the_list_stays_at_it(page: Page, served: Served) -> None:
    """Issue 20 item 4: "after editing block 301 of 552 the list jumps back to the top"."""
    program_id = served.create(editor_program(552))
    page.goto(f"{served.url}/programs/{program_id}?page=4")
    expect(page.locator(".pager").first).to_contain_text("blocks 301–400 of 552")
    page.locator('.block-row[data-block="301"] .block-link').click()
    expect(page.locator("#entry h2")).to_contain_text("Block 301")
    settle(page)
    page.keyboard.type("1.25")  # X, the first prompt
    page.keyboard.press("Control+Enter")
    expect(page.locator('.block-row[data-block="301"] .summary')).to_contain_text("X 1.25")
    expect(page.locator(".pager").first).to_contain_text("blocks 301–400 of 552")
    until(page, "document.querySelector('.block-row[data-block=\"301\"]') !== null")
    assert in_list_view(page, 301)
