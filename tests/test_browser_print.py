"""Programming from the print in the editor (issue 33), in a real browser (Playwright,
Debian's Chromium): an X left empty is calculated by the compile, shown in the field in
another colour with a title saying so, and a value typed over it replaces it."""

from __future__ import annotations

from decimal import Decimal as D

from playwright.sync_api import Page, expect

from app.cnc.blocks import ArcEnd, Direction, MillArc, MillLine
from tests.test_browser import browser, page, settle
from tests.test_browser_editor import Served, drill, program_of, saved_blocks, served

# The browser, the page (which fails the test on any console error) and the server are
# the editor tests'.
__all__ = ["browser", "page", "served"]


def test_an_empty_x_is_calculated_shown_apart_and_typed_over(page: Page, served: Served) -> None:
    """MILL STD along Y0 into an arc about X3 Y1 of radius 1 (its end X4 Y1): left empty,
    the line's X is where it meets the arc's circle, X3 (hand: y = 0 touches
    (x − 3)² + (y − 1)² = 1 at x = 3 only)."""
    program = program_of(
        drill("0", "0"),
        MillLine(x=D(3), y=D(0), feed_xy=D(10), tool=1),
        MillArc(direction=Direction.CCW, x=D(3), y=D(1), feed_xy=D(10), tool=1),
        ArcEnd(x=D(4), y=D(1)),
    )
    program_id = served.create(program)
    page.goto(f"{served.url}/programs/{program_id}?edit=2")
    expect(page.locator("#entry h2")).to_contain_text("Block 2")
    settle(page)
    x = page.locator("#f-x")
    # Leave X empty: clear what is typed and enter the block.
    x.fill("")
    x.press("Control+Enter")
    expect(page.locator('.block-row[data-block="2"] .summary')).not_to_contain_text("X 3")
    line = saved_blocks(served, program_id)[1]
    assert isinstance(line, MillLine) and line.x is None and line.y == 0

    page.goto(f"{served.url}/programs/{program_id}?edit=2")
    expect(page.locator("#entry h2")).to_contain_text("Block 2")
    settle(page)
    x = page.locator("#f-x")
    expect(x).to_have_value("")
    expect(x).to_have_attribute("placeholder", "3.0000")
    expect(x).to_have_attribute("title", "calculated: 3.0000 (type a value to replace it)")
    expect(x).to_have_class("calculated")
    # Another colour than what is typed: the placeholder's against the typed Y's.
    colours = page.evaluate(
        """() => [getComputedStyle(document.querySelector('#f-x'), '::placeholder').color,
                  getComputedStyle(document.querySelector('#f-y')).color]"""
    )
    assert colours[0] != colours[1], colours
    expect(page.locator("#f-y")).not_to_have_class("calculated")

    # Typed over: the typed value is the block's, and no longer shown as calculated.
    x.fill("3")
    x.press("Control+Enter")
    expect(page.locator('.block-row[data-block="2"] .summary')).to_contain_text("X 3")
    line = saved_blocks(served, program_id)[1]
    assert isinstance(line, MillLine) and line.x == D(3)
    page.goto(f"{served.url}/programs/{program_id}?edit=2")
    settle(page)
    expect(page.locator("#f-x")).to_have_value("3")
    expect(page.locator("#f-x")).not_to_have_class("calculated")


def test_tangent_and_conrad_are_entered_beside_the_prompts(page: Page, served: Served) -> None:
    """The print's CONRAD (like TANGENT, RAD and CHAMFER) is a field of the form beside the
    prompts, outside the Enter sequence the control's prompts keep."""
    program = program_of(
        drill("0", "0"),
        MillLine(x=D(3), y=D(0), feed_xy=D(10), tool=1),
        MillLine(x=D(3), y=D(2), feed_xy=D(10), tool=1),
    )
    program_id = served.create(program)
    page.goto(f"{served.url}/programs/{program_id}?edit=2")
    expect(page.locator("#entry h2")).to_contain_text("Block 2")
    settle(page)
    page.locator("#f-conrad").fill("0.25")
    page.locator("#f-x").press("Control+Enter")
    expect(page.locator('.block-row[data-block="2"] .summary')).to_contain_text("CONRAD 0.25")
    line = saved_blocks(served, program_id)[1]
    assert isinstance(line, MillLine) and line.conrad == D("0.25")
