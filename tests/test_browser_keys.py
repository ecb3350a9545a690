"""No key is lost, and Verify is never stale (issue 29 points 2 and 5), in a real browser
(Playwright, Debian's Chromium).

At the control a machinist types ahead of the screen: `5` `1` opens MILL STD whether or not
the MILL menu has been drawn yet, and the values typed after it land in its prompts. The
editor must do the same while its server answers. Each test here failed before its fix.
"""

from __future__ import annotations

from decimal import Decimal

from playwright.sync_api import Page, Request, expect

from app.cnc import document
from app.cnc.blocks import MillLine, Mode
from app.web.forms import kind_of
from tests.test_browser import browser, page, settle
from tests.test_browser_editor import (
    Served,
    choose,
    drill,
    enter,
    open_editor,
    program_of,
    saved_blocks,
    served,
)
from tests.test_verify import CASES_DIR

__all__ = ["browser", "page", "served"]

D = Decimal
ENTRIES = 20


def typed_ahead(page: Page, keys: list[str]) -> None:
    """Press every key in a tight loop: nothing waits for the page between two keys."""
    for key in keys:
        page.keyboard.press(key)


def mill_std_keys(x: str, y: str) -> list[str]:
    """`5` `1` (MILL, STD), X, Y, Z DN as offered, FEEDR XY 10, TOOL # as offered."""
    return ["5", "1", *x, "Enter", *y, "Enter", "Enter", "1", "0", "Enter", "Enter"]


def test_twenty_mill_std_blocks_typed_without_a_pause_lose_no_key(
    page: Page, served: Served
) -> None:
    """Issue 29 point 5: `5` then `1` without a pause stopped at the MILL sub-type menu 4
    times in 5 and opened POS once. Twenty MILL STD blocks, every key pressed the moment the
    one before was, all twenty typed before any answer is awaited: exactly those twenty
    blocks are saved, in order, with the values typed."""
    program_id = open_editor(page, served, program_of(drill("0", "0")))
    expected = [(D(n), D("0.5") if n % 2 else D(0)) for n in range(1, ENTRIES + 1)]
    keys: list[str] = []
    for x, y in expected:
        keys += mill_std_keys(str(x), str(y))
    typed_ahead(page, keys)
    expect(page.locator(f'.block-row[data-block="{ENTRIES + 1}"]')).to_be_visible(timeout=60_000)
    expect(page.locator("#entry h2")).to_contain_text(f"Block {ENTRIES + 2}: type")
    settle(page)
    blocks = saved_blocks(served, program_id)
    assert [kind_of(b) for b in blocks[1:]] == ["MILL_STD"] * ENTRIES
    assert page.url == f"{served.url}/programs/{program_id}"  # all in the page, no reload
    assert blocks[1:] == tuple(
        MillLine(x=x, y=y, z_dn=D("-0.3"), feed_xy=D(10), tool=1, mode=Mode.ABS)
        for x, y in expected
    )


def test_each_block_typed_ahead_of_its_menu(page: Page, served: Served) -> None:
    """The same, one block at a time (the trial's case: `51` and the values typed at once,
    then a look at the screen), twenty times."""
    program_id = open_editor(page, served, program_of(drill("0", "0")))
    for n in range(1, ENTRIES + 1):
        typed_ahead(page, mill_std_keys(str(n), "1"))
        expect(page.locator("#entry h2")).to_contain_text(f"Block {n + 2}: type")
    blocks = saved_blocks(served, program_id)
    assert [(kind_of(b), b.x, b.y) for b in blocks[1:]] == [  # type: ignore[attr-defined]
        ("MILL_STD", D(n), D(1)) for n in range(1, ENTRIES + 1)
    ]


def test_menus_answer_without_a_request(page: Page, served: Served) -> None:
    """A menu is known in the page: the MILL sub-type menu shows at once, without asking
    the server (after closing a pocket's island a menu took 1.9 s); Esc goes back to the
    type menu the same way. Only choosing the block's type asks for its prompts."""
    program_id = open_editor(page, served, program_of(drill("0", "0")))
    asked: list[str] = []

    def record(request: Request) -> None:
        if "/entry" in request.url:
            # Asked by htmx (a fragment), not by leaving the page.
            asked.append(request.url if request.headers.get("hx-request") == "true" else "page")

    page.on("request", record)
    page.keyboard.press("5")
    expect(page.locator("#entry h2")).to_contain_text("Block 2: MILL — sub-type")
    expect(page.locator('#entry .choice[data-key="1"]')).to_contain_text("MILL STD")
    settle(page)
    page.keyboard.press("Escape")
    expect(page.locator("#entry h2")).to_contain_text("Block 2: type")
    settle(page)
    page.keyboard.press("8")  # REP: nothing is open to close
    expect(page.locator("#entry .refused")).to_contain_text("REP")
    expect(page.locator("#entry h2")).to_contain_text("Block 2: type")
    assert asked == []
    page.keyboard.press("5")
    page.keyboard.press("1")
    expect(page.locator("#entry h2")).to_contain_text("Block 2: MILL STD")
    assert len(asked) == 1 and "kind=MILL_STD" in asked[0], asked
    assert page.url == f"{served.url}/programs/{program_id}"


def test_the_shortcuts_are_shown_on_the_page(page: Page, served: Served) -> None:
    """Point 5: Alt+V and the other shortcuts worked but nothing said so."""
    open_editor(page, served, program_of(drill("0", "0")))
    legend = page.locator(".keys-legend")
    expect(legend).to_be_visible()
    for text in ("Alt+V", "Alt+E", "Alt+H", "Alt+N", "Esc", "Ctrl+Enter"):
        expect(legend).to_contain_text(text)
    link = page.locator("a[accesskey=v]")
    assert "Alt+V" in (link.get_attribute("title") or "")


# -- Verify is never stale (issue 29 point 2) ---------------------------------------------


def finding_links(page: Page) -> list[tuple[str, str, str]]:
    """Each finding's link in the editor's Verify panel: (href, number, title shown)."""
    found: list[tuple[str, str, str]] = page.evaluate(
        """() => Array.from(document.querySelectorAll('.verify-panel a[href*="edit="]'))
              .map(a => [a.getAttribute('href'), a.querySelector('.num').textContent.trim(),
                         a.textContent.replace(/^\\s*\\d+/, '').trim()])"""
    )
    return found


def assert_links_name_their_blocks(page: Page) -> None:
    """Every finding's link opens the block it names, with the title it shows."""
    for href, number, title in finding_links(page):
        assert href.endswith(f"edit={number}"), (href, number)
        row = page.locator(f'.block-row[data-block="{number}"] .title')
        expect(row).to_have_text(title)


def test_the_verify_panel_is_never_stale(page: Page, served: Served) -> None:
    """Issue 29 point 2: after an edit the panel kept its findings under the old numbers
    (its link "9 FRAME POCKET" opened what had become block 9, a MILL ARC). After an edit
    it says it is out of date and links nowhere; Alt+R runs it again, and its links name
    the blocks by their new numbers."""
    program = document.loads((CASES_DIR / "contour-start-gouge-mm" / "program.json").read_text())
    program_id = open_editor(page, served, program)
    page.locator("details.verify-panel summary").click()
    panel = page.locator(".verify-panel .verify-body")
    expect(panel.locator('.finding[data-block="5"] a')).to_have_attribute(
        "href", f"/programs/{program_id}?edit=5"
    )
    title = page.locator('.block-row[data-block="5"] .title').inner_text()
    assert_links_name_their_blocks(page)

    # Insert a POS before block 1: the finding's block is block 6 now.
    page.locator('.block-row[data-block="1"] .block-link').click()
    page.get_by_role("link", name="Insert a block before 1").click()
    expect(page.locator("#entry h2")).to_contain_text("Block 1: type")
    settle(page)
    choose(page, "1", "Block 1: POS")
    enter(page, "0", "0")
    page.keyboard.press("Control+Enter")
    expect(page.locator('.block-row[data-block="1"] .title')).to_have_text("POS")
    expect(page.locator('.block-row[data-block="6"] .title')).to_have_text(title)
    expect(page.locator(".verify-panel")).to_contain_text("Out of date")
    assert finding_links(page) == []
    expect(page.locator(".block-row.has-findings")).to_have_count(0)

    page.keyboard.press("Alt+r")
    expect(panel.locator(".verify-result")).to_be_attached()
    expect(page.locator(".verify-panel")).not_to_contain_text("Out of date")
    expect(panel.locator('.finding[data-block="6"] a')).to_have_attribute(
        "href", f"/programs/{program_id}?edit=6"
    )
    assert_links_name_their_blocks(page)


def test_a_report_answered_after_an_edit_is_out_of_date(page: Page, served: Served) -> None:
    """The report asked for before an edit and answered after it is about the version
    before: the panel says so rather than showing it under the new numbers."""
    program = document.loads((CASES_DIR / "contour-start-gouge-mm" / "program.json").read_text())
    open_editor(page, served, program)
    hold: list[object] = []
    page.route("**/verify/report", lambda route: hold.append(route))
    page.locator("details.verify-panel summary").click()
    while not hold:
        page.wait_for_timeout(20)
    page.locator("#entry .choices").focus()
    count = len(program.blocks)
    choose(page, "1", f"Block {count + 1}: POS")  # a POS at the end
    enter(page, "1", "1")
    page.keyboard.press("Control+Enter")
    expect(page.locator(f'.block-row[data-block="{count + 1}"] .title')).to_have_text("POS")
    hold[0].continue_()  # type: ignore[attr-defined]
    expect(page.locator(".verify-panel")).to_contain_text("Out of date")
    assert finding_links(page) == []
