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

from playwright.sync_api import Error, Page, Route, expect

from tests.test_browser import browser, page, server  # noqa: F401 - fixtures


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


def wait_for(tab: Page, held: list[Route], timeout: float = 10.0) -> None:
    """Wait until the first request is held (polled through Playwright, so that the routing
    callback runs meanwhile)."""
    deadline = time.monotonic() + timeout
    while not held:
        if time.monotonic() > deadline:
            raise AssertionError("the first request was never made")
        tab.wait_for_timeout(20)


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
