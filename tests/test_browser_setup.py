"""The set-up sheet at the machine, in a real browser (issue 29 point 7): a machinist names
a tool in Data Block 0, opens the set-up sheet of the metric flange (a pecked bolt circle)
and sees the finished-part picture whole on screen and in print, the stock, the tool's
name and the hole table. Screenshots and the PDF go to test-output/screenshots/.
"""

from __future__ import annotations

from playwright.sync_api import Page, expect

from tests.test_browser import SHOTS, browser, page, server, shot

# The app server, the browser and the page (which fails the test on any console error)
# are test_browser's.
__all__ = ["browser", "page", "server"]

# The picture's box, and whether any ancestor that clips its content (overflow other than
# visible) cuts it, or another element covers its middle.
PICTURE = """(() => {
  const img = document.querySelector('img.sheet-part');
  if (!img) return {found: false};
  const box = img.getBoundingClientRect();
  let clipped = false;
  for (let el = img.parentElement; el; el = el.parentElement) {
    const style = getComputedStyle(el);
    if (style.overflowX !== 'visible' || style.overflowY !== 'visible') {
      const r = el.getBoundingClientRect();
      if (box.left < r.left - 0.5 || box.top < r.top - 0.5 || box.right > r.right + 0.5
          || box.bottom > r.bottom + 0.5) clipped = true;
    }
  }
  img.scrollIntoView();
  const now = img.getBoundingClientRect();
  const hit = document.elementFromPoint(now.left + now.width / 2, now.top + now.height / 2);
  return {found: true, loaded: img.complete && img.naturalWidth > 0, width: box.width,
          height: box.height, clipped: clipped, covered: hit !== img};
})()"""


def picture_shown(page: Page) -> None:
    seen = page.evaluate(PICTURE)
    assert seen["found"] and seen["loaded"], seen
    assert seen["width"] > 100 and seen["height"] > 100, seen
    assert not seen["clipped"], seen
    assert not seen["covered"], seen


def test_the_set_up_sheet_shows_the_part_stock_tool_names_and_holes(
    page: Page, server: str
) -> None:
    page.goto(server + "/")
    href = page.get_by_role("link", name="Metric flange holes").first.get_attribute("href")
    assert href is not None
    program = server + href.rstrip("/")
    # Data Block 0: tool 1 gets its name.
    page.goto(program + "/db0")
    page.get_by_label("Tool 1 name").fill("6 MM DRILL")
    page.get_by_role("button", name="Save Data Block 0").click()
    page.wait_for_url(program + "**")
    page.goto(program + "/setup")
    page.wait_for_load_state("networkidle")
    expect(page.locator("h1")).to_contain_text("Metric flange holes")
    # On screen: the finished part, whole and not covered.
    picture_shown(page)
    # The stock to put in the vise, each tool's name, the holes in cutting order.
    expect(page.locator("tr.stock")).to_contain_text("XL 60.000 × YW 57.000 × ZH 19.000 mm")
    expect(page.locator("table.tools-sheet")).to_contain_text("6 MM DRILL")
    rows = page.locator("table.holes-sheet tbody tr")
    expect(rows).to_have_count(5)
    expect(rows.first).to_contain_text("35.305")
    expect(rows.first).to_contain_text("-12.500")
    expect(rows.first).to_contain_text("drill, 3 pecks")
    shot(page, "14-setup-sheet-holes")
    # In print: the same picture, whole, and in the PDF the browser prints.
    page.emulate_media(media="print")
    picture_shown(page)
    SHOTS.mkdir(parents=True, exist_ok=True)
    pdf = page.pdf(path=str(SHOTS / "14-setup-sheet.pdf"))
    assert b"/Subtype /Image" in pdf
