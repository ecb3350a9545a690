"""Answers that cross: the last thing the user asked for is what the page shows.

A search typed on while the first search's answer is still on its way, a second target
chosen before the first export came back: the page must end showing the answer to the last
request, whatever order the answers arrive in. The first answer is held back in the browser's
network (Playwright's routing; the server is the real one) until the second has been asked.

Under htmx 4 a request keeps the element it will swap into from when it was made; a swap of
that element itself (outerHTML) by an earlier answer left a later request's target out of the
page, and its answer was dropped without a word: the list showed the first search's programs
beside the second search's words.
"""

from __future__ import annotations

import contextlib
import re
import time
from collections.abc import Sized

import pytest
from playwright.sync_api import APIResponse, Error, Page, Route, expect

from tests.test_browser import browser, page, server, until  # noqa: F401 - fixtures
from tests.test_browser_preview import Library, drill, library, open_block, program  # noqa: F401


def hold_first(tab: Page, pattern: str) -> list[Route]:
    """Route requests matching `pattern`: the first is held (returned in the list, to be
    let through later), the rest go straight to the server."""
    held: list[Route] = []

    def route(found: Route) -> None:
        if held:
            found.continue_()
        else:
            held.append(found)

    tab.route(pattern, route)
    return held


def wait_for(tab: Page, held: Sized, count: int = 1, timeout: float = 10.0) -> None:
    """Wait until `count` requests are held (polled through Playwright, so that the routing
    callback runs meanwhile)."""
    deadline = time.monotonic() + timeout
    while len(held) < count:
        if time.monotonic() > deadline:
            raise AssertionError(f"request {len(held) + 1} was never made")
        tab.wait_for_timeout(20)


def hold_answers(tab: Page, pattern: str) -> list[tuple[Route, APIResponse]]:
    """Route requests matching `pattern`: each is answered by the server at once, and its
    answer held (in the list, with its route) until the test hands it to the page."""
    held: list[tuple[Route, APIResponse]] = []

    def route(found: Route) -> None:
        held.append((found, found.fetch()))

    tab.route(pattern, route)
    return held


def hand_over(answer: tuple[Route, APIResponse]) -> None:
    """Give a held answer to the page (which may have given its request up meanwhile)."""
    with contextlib.suppress(Error):
        answer[0].fulfill(response=answer[1])


def let_through(route: Route) -> None:
    """Let a held request reach the server (the page may have given it up meanwhile)."""
    with contextlib.suppress(Error):
        route.continue_()


def test_the_list_shows_the_last_search_typed(page: Page, server: str) -> None:  # noqa: F811
    page.goto(server + "/")
    search = page.get_by_label("Search")
    held = hold_first(page, "**/*fragment=list*")
    search.fill("Metric")
    wait_for(page, held)
    search.fill("Bracket")
    rows = page.locator("#program-list tbody tr")
    # The second search goes and answers without waiting for the first.
    expect(rows).to_have_count(1)
    expect(rows.first).to_contain_text("Bracket contour, cutter right")
    let_through(held[0])
    page.wait_for_timeout(500)  # the first answer, if it comes, must not replace the list
    expect(rows).to_have_count(1)
    expect(rows.first).to_contain_text("Bracket contour, cutter right")
    expect(search).to_have_value("Bracket")


def test_the_export_shows_the_last_preview_asked_for(page: Page, server: str) -> None:  # noqa: F811
    page.goto(server + "/")
    page.get_by_label("Search").fill("Bracket")
    expect(page.locator("#program-list tbody tr")).to_have_count(1)
    export = page.locator("#program-list tbody tr").first.get_by_role("link", name="Export")
    page.goto(server + str(export.get_attribute("href")) + "?target=gcode-linuxcnc")
    expect(page.locator("h1")).to_contain_text("Export")
    held = hold_first(page, "**/export?*go=1*")
    page.get_by_role("button", name="Preview").click()
    wait_for(page, held)
    end_code = page.locator('select[name="opt_end-code"]')
    if not end_code.is_visible():
        page.get_by_text("More options").click()
    end_code.select_option("M02")
    page.get_by_role("button", name="Preview").click()
    download = page.locator("#download")
    expect(download).to_have_attribute("href", re.compile("opt_end-code=M02"))
    let_through(held[0])
    page.wait_for_timeout(500)
    expect(download).to_have_attribute("href", re.compile("opt_end-code=M02"))
    expect(page.locator(".listing")).to_contain_text("M02")


def test_a_machine_shows_the_options_of_the_last_target_chosen(page: Page, server: str) -> None:  # noqa: F811
    page.goto(server + "/machines")
    held = hold_first(page, "**/machines/options*")
    target = page.locator('select[name="target"]')
    target.select_option(label="Tektronix 1704 tape (EIA)")
    wait_for(page, held)
    target.select_option(label="Fanuc 6M G-code")
    legend = page.locator("#machine-options legend")
    expect(legend).to_have_text("Options of Fanuc 6M G-code")
    let_through(held[0])
    page.wait_for_timeout(500)
    expect(legend).to_have_text("Options of Fanuc 6M G-code")
    expect(page.locator('input[name="options_for"]')).to_have_value("gcode-fanuc")


@pytest.mark.parametrize("first", ["earlier", "later"])
def test_the_drawing_shows_the_last_edit_when_two_whole_drawings_cross(
    page: Page,  # noqa: F811
    library: Library,  # noqa: F811
    first: str,
) -> None:
    """Two edits in a row that each ask for the whole drawing (a tool Data Block 0 does not
    have leaves nothing to draw; put right, the page's drawing is of another version than
    the edit started from): whichever answer comes first, the drawing ends as the last edit
    left the program, its holes drawn and no "tool 9" message. The answers are made by the
    server in order and handed to the page in the order `first` says. Failed before with
    the earlier answer first: it replaced #drawing-area, which took the later request's
    target out of the page, and the later answer was dropped: the page kept saying that
    nothing could be drawn for tool 9 while the program was right. With the earlier answer
    last, a holder alone (no hx-sync replace) fails too: that answer lands last."""
    page.goto(library.add(program("Crossing drawings", drill("3", "2"), drill("1", "1"))))
    expect(page.locator("#preview circle.hole")).to_have_count(2)
    held = hold_answers(page, "**/drawing?v=*")
    open_block(page, 1)
    page.locator("#f-tool").fill("9")
    page.locator("#entry button[data-submit]").click()
    expect(page.locator("#version")).to_have_text("v2")
    wait_for(page, held)  # the server drew version 2 (nothing): the answer is held
    open_block(page, 1)
    page.locator("#f-tool").fill("1")
    page.locator("#entry button[data-submit]").click()
    expect(page.locator("#version")).to_have_text("v3")
    wait_for(page, held, 2)  # the page asks for version 3's drawing
    order = held if first == "earlier" else held[::-1]
    hand_over(order[0])
    page.wait_for_timeout(300)  # the first answer, if the page takes it, is in
    hand_over(order[1])
    page.wait_for_timeout(300)
    expect(page.locator("#preview circle.hole")).to_have_count(2)
    expect(page.locator("#not-drawn")).not_to_contain_text("tool 9")
    until(page, "document.getElementById('preview').dataset.version === '3'")
    expect(page.locator("#drawing-area")).to_have_count(1)
