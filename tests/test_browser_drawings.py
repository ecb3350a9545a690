"""The choosing page in a real browser (Playwright, Debian's Chromium), as a stranger uses
it: open a drawing from the library, click the outside profile on the side where the cut
should start, click two holes, see the blocks and the report, add them to a new program and
land in the editor on its first block. Screenshots go to test-output/screenshots/.
"""

from __future__ import annotations

import re
from pathlib import Path

from playwright.sync_api import Page, expect

from tests.test_browser import browser, page, server, shot  # noqa: F401 - fixtures
from tests.test_import_dxf import bracket


def open_bracket(tab: Page, address: str, tmp_path: Path) -> None:
    """Upload the bracket drawing from the library page, holes up to 0.25 in, and wait for
    the choosing page to show it."""
    drawing = tmp_path / "bracket.dxf"
    drawing.write_bytes(bracket())
    tab.goto(address + "/")
    card = tab.locator("form.card", has_text="From a drawing (DXF)")
    card.locator('input[type="file"]').set_input_files(str(drawing))
    card.locator('input[name="hole-diameter"]').fill("0.25")
    card.get_by_role("button", name="Open and choose contours").click()
    expect(tab.locator("#dxf-view svg")).to_be_visible()


def test_choose_a_profile_and_holes_from_a_drawing(page: Page, server: str, tmp_path: Path) -> None:  # noqa: F811
    open_bracket(page, server, tmp_path)
    expect(page.locator(".page.drawings .hint").first).to_contain_text("3 contours, 10 holes")
    shot(page, "drawings-1-opened")

    # The outside profile is the contour of 8 segments; its right side (segment 3) is a
    # vertical line: clicked where it is drawn.
    profile = page.locator("#dxf-view g.contour").filter(
        has=page.locator('.segment[data-segment="7"]')
    )
    profile.locator('.segment[data-segment="2"]').click(force=True)
    number = profile.get_attribute("data-contour")
    expect(page.locator(f'input[name="c{number}_order"]')).to_have_value("1")
    expect(page.locator(f'select[name="c{number}_start"]')).to_have_value("3")
    expect(page.locator("#result h2")).to_have_text("9 blocks")
    expect(page.locator(f'#dxf-view g.contour[data-contour="{number}"]')).to_have_class(
        "contour closed chosen"
    )
    # Clockwise, the tool on the right.
    page.locator(f'select[name="c{number}_dir"]').select_option("cw")
    page.locator(f'select[name="c{number}_comp"]').select_option("right")
    page.locator('#dxf-view circle.hole[data-hole="0"]').click()
    page.locator('#dxf-view circle.hole[data-hole="1"]').click()
    expect(page.locator('input[name="h0_order"]')).to_have_value("2")
    expect(page.locator('input[name="h1_order"]')).to_have_value("3")
    expect(page.locator("#result h2")).to_have_text("11 blocks")
    blocks = page.locator("#result ol.blocks li")
    expect(blocks.nth(0)).to_contain_text("DRILL CUT RT")
    expect(blocks.nth(0)).to_contain_text("X 6.000 Y 0.500")
    expect(blocks.nth(9)).to_contain_text("DRILL")
    # What was not chosen, and what the drawing held that cannot be read, is reported.
    report = page.locator("#result table.report")
    expect(report).to_contain_text("a hole not chosen: no blocks")
    expect(report).to_contain_text("a SPLINE is not read")
    expect(page.locator("#result .chosen-preview svg")).to_be_visible()
    shot(page, "drawings-2-chosen")

    page.locator('input[name="name"]').fill("Bracket from DXF")
    page.get_by_role("button", name="Add the blocks").click()
    expect(page).to_have_url(re.compile(r"/programs/\d+\?edit=1$"))
    expect(page.locator('.block-row[data-block="1"]')).to_contain_text("DRILL CUT RT")
    expect(page.locator('.block-row[data-block="11"]')).to_contain_text("DRILL")
    shot(page, "drawings-3-in-the-editor")


def test_choose_a_pocket_with_islands_from_a_drawing(
    page: Page,  # noqa: F811 - the fixture
    server: str,  # noqa: F811
    tmp_path: Path,
) -> None:
    """Click the profile, make it a POCKET and the bore and the slot its islands; the blocks
    and their contours are shown; added to a new program, the editor draws the pocket."""
    open_bracket(page, server, tmp_path)
    profile = page.locator("#dxf-view g.contour").filter(
        has=page.locator('.segment[data-segment="7"]')
    )
    profile.locator('.segment[data-segment="0"]').click(force=True)
    number = profile.get_attribute("data-contour")
    expect(page.locator("#result h2")).to_have_text("9 blocks")
    page.locator(f'select[name="c{number}_pocket"]').select_option("pocket")
    expect(page.locator("#result ol.blocks li").nth(1)).to_contain_text("POCKET")
    others = [
        row.get_attribute("data-contour")
        for row in page.locator("tr.contour-row").all()
        if row.get_attribute("data-contour") != number
    ]
    for other in others:
        page.locator(f'select[name="c{other}_pocket"]').select_option("island")
    expect(page.locator("#result h2")).to_have_text("25 blocks")
    expect(page.locator("#result ol.blocks li", has_text="ISLAND")).to_have_count(2)
    # The drawing has no tool diameter: the pocket's contours are drawn, and the tool's
    # DIA is asked for before it can be cut.
    expect(page.locator("#result .chosen-preview svg path.contour").first).to_be_attached()
    expect(page.locator("#result ul.problems")).to_contain_text("has no DIA")
    shot(page, "drawings-4-pocket-chosen")
    page.locator('input[name="name"]').fill("Bracket pocket")
    page.get_by_role("button", name="Add the blocks").click()
    expect(page).to_have_url(re.compile(r"/programs/\d+\?edit=1$"))
    expect(page.locator('.block-row[data-block="2"]')).to_contain_text("POCKET")
    expect(page.locator('.block-row[data-block="14"]')).to_contain_text("ISLAND")
    shot(page, "drawings-5-pocket-in-the-editor")
