"""The editor's preview in a real browser (Playwright, Debian's Chromium): what a machinist
reads at a glance (issue 20, "the preview hides things"), and the large-program drawing.

Programs are put in the library directly (the keyboard is test_browser's subject); each
test opens the editor on one and reads the drawing as a user would: by what is drawn,
where it is on the screen, what the pointer reads.
"""

from __future__ import annotations

import math
import re
import threading
from collections.abc import Iterator
from decimal import Decimal as D

import pytest
from flask import Flask
from playwright.sync_api import Page, expect
from werkzeug.serving import make_server

from app import create_app
from app.cnc.blocks import (
    BoltCircle,
    Circle,
    Comp,
    DataBlock0,
    Direction,
    Frame,
    Hole,
    HoleOp,
    MillLine,
    MillQcir,
    Placement,
    Pos,
    Program,
    Tool,
)
from app.web import get_library
from bench.programs import sized
from tests.test_browser import browser, page, shot, until

# The browser and the page (which fails the test on any console error) are test_browser's.
__all__ = ["browser", "page"]

TOOLS = (
    Tool(number=1, diameter=D("0.25"), rpm=1000, tcal=D(0)),
    Tool(number=2, diameter=D("0.5"), rpm=800, tcal=D(0)),
    Tool(number=3, diameter=D("1"), rpm=300, tcal=D(0)),
)


def drill(x: str, y: str, tool: int = 1, feed_z: str = "5", **kw: object) -> Hole:
    return Hole(
        op=HoleOp.DRILL,
        x=D(x),
        y=D(y),
        z_up=D("0.1"),
        z_dn=D("-0.3"),
        feed_z=D(feed_z),
        tool=tool,
        **kw,  # type: ignore[arg-type]
    )


def program(name: str, *blocks: object) -> Program:
    return Program(
        name=name,
        block0=DataBlock0(current_tool=1, tools=TOOLS),
        blocks=blocks,  # type: ignore[arg-type]
    )


class Library:
    """The app under test and a way to put programs in its library."""

    def __init__(self, app: Flask, url: str) -> None:
        self.app = app
        self.url = url

    def add(self, made: Program) -> str:
        """Store `made` and give the address of its editor."""
        with self.app.app_context():
            info = get_library().create(made)
        return f"{self.url}/programs/{info.id}"


@pytest.fixture(scope="module")
def library(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Library]:
    db = tmp_path_factory.mktemp("preview") / "library.db"
    app = create_app({"DATABASE_URL": f"sqlite:///{db}", "SECRET_KEY": "preview-test" * 32})
    http = make_server("127.0.0.1", 0, app, threaded=True)
    thread = threading.Thread(target=http.serve_forever, daemon=True)
    thread.start()
    yield Library(app, f"http://127.0.0.1:{http.server_port}")
    http.shutdown()
    with app.app_context():
        get_library().engine.dispose()


def test_blocks_with_errors_are_shown_not_hidden(page: Page, library: Library) -> None:
    """Block 2's feed is out of range and block 6's quarter circle is not one: the blocks
    after them are still drawn and timed; the two are drawn in red with their messages, or
    listed with them where there is nothing to draw."""
    url = library.add(
        program(
            "Errors in the middle",
            Pos(x=D(1), y=D(1), tool=1),
            drill("2", "1", feed_z="900"),
            drill("3", "1"),
            drill("1", "3", tool=2),
            MillLine(x=D(2), y=D(3), z_dn=D("-0.3"), feed_xy=D(10), tool=2),
            MillQcir(
                direction=Direction.CCW, x=D(3), y=D("3.5"), z_dn=D("-0.3"), feed_xy=D(10), tool=2
            ),
            drill("4", "3"),
        )
    )
    page.goto(url)
    drawing = page.locator("#preview")
    for number in (3, 4, 5, 7):
        expect(drawing.locator(f'g.block[data-block="{number}"]').first).to_be_attached()
    red = drawing.locator('g.block.problem[data-block="6"]').first
    expect(red).to_be_attached()
    expect(red.locator("title")).to_contain_text("QCIR end point is not a quarter circle")
    # Block 2 cannot be drilled at 900 ipm: it is left out of the drawing, and said so.
    expect(page.locator(".preview .not-drawn")).to_contain_text("block 2")
    expect(page.locator(".preview .not-drawn")).to_contain_text("900 ipm is outside")
    expect(page.locator(".blocks .total")).not_to_contain_text("blocks 1–")
    expect(page.locator('.block-row[data-block="7"] .time')).not_to_have_text("")
    shot(page, "preview-errors")


def test_contour_part_zero_and_stock_are_drawn(page: Page, library: Library) -> None:
    url = library.add(
        program(
            "Contour with a stock",
            drill("0", "0", tool=2, comp=Comp.RIGHT),
            MillLine(x=D(3), y=D(0), z_dn=D("-0.3"), feed_xy=D(10), tool=2),
            MillLine(x=D(3), y=D(2), z_dn=D("-0.3"), feed_xy=D(10), tool=2),
        )
    )
    page.goto(url)
    drawing = page.locator("#preview")
    expect(drawing.locator("path.contour")).not_to_have_count(0)
    expect(drawing.locator("path.feed")).not_to_have_count(0)
    expect(drawing.locator("g.zero")).to_be_attached()
    expect(drawing.locator("g.stock rect")).to_be_attached()
    for name in ("contour", "tool centre", "stock", "part zero"):
        expect(page.locator(".preview .legend")).to_contain_text(name)


def test_holes_are_numbered_in_cutting_order(page: Page, library: Library) -> None:
    url = library.add(
        program(
            "Six on a circle",
            drill("3", "3"),
            BoltCircle(op=HoleOp.DRILL, holes=6, angle=D(0), radius=D(1)),
        )
    )
    page.goto(url)
    labels = page.locator("#preview g.order text")
    expect(labels).to_have_text(["1", "2", "3", "4", "5", "6"])
    # Hole 1 is straight below the centre (angle 0) and hole 4 straight above it: their
    # numbers sit one above the other, 1 lower on the screen. (The holes themselves are one
    # hole drawn once and placed, so they are not each an element to measure.)
    first = labels.nth(0).bounding_box()
    fourth = labels.nth(3).bounding_box()
    assert first is not None and fourth is not None
    assert abs(first["x"] - fourth["x"]) < first["width"]
    assert first["y"] > fourth["y"] + 3 * first["height"]


def test_the_pointer_reads_part_coordinates(page: Page, library: Library) -> None:
    url = library.add(program("One hole at 3, 2", drill("3", "2")))
    page.goto(url)
    hole = page.locator("#preview circle.hole").first.bounding_box()
    assert hole is not None
    page.mouse.move(hole["x"] + hole["width"] / 2, hole["y"] + hole["height"] / 2)
    coarse = assert_pointer(page, 3, 2)
    # Zoomed in with the wheel (about the pointer, so the hole stays under it), the
    # readout resolves finer.
    for _ in range(16):
        page.mouse.wheel(0, -100)
    hole = page.locator("#preview circle.hole").first.bounding_box()
    assert hole is not None
    page.mouse.move(hole["x"] + hole["width"] / 2, hole["y"] + hole["height"] / 2)
    assert assert_pointer(page, 3, 2) > coarse


def assert_pointer(page: Page, x: float, y: float) -> int:
    """The pointer readout says (x, y) in inches to within two screen pixels, with as many
    decimals as a pixel resolves (up to four); the decimals it shows."""
    readout = page.locator(".preview .pointer")
    expect(readout).to_contain_text(" in")
    found = re.fullmatch(r"X (-?[\d.]+) Y (-?[\d.]+) in", readout.inner_text().strip())
    assert found, readout.inner_text()
    pixel = page.evaluate(
        "(() => { const a = window.millblocksPreview.toScreen(0, 0);"
        " const b = window.millblocksPreview.toScreen(1, 0); return 1 / (b[0] - a[0]); })()"
    )
    places = len(found[1].split(".")[1]) if "." in found[1] else 0
    assert places == min(4, math.ceil(-math.log10(pixel)))
    assert abs(float(found[1]) - x) <= 2 * pixel and abs(float(found[2]) - y) <= 2 * pixel
    return places


def test_fit_shows_whole_holes_at_the_edges(page: Page, library: Library) -> None:
    """A 1 in drill at the drawing's corners: fit must show every hole whole, the tool's
    radius included, not only the tool centre's path."""
    url = library.add(
        program(
            "Big holes at the corners",
            drill("0", "0", tool=3),
            drill("4", "0", tool=3),
            drill("4", "0.5", tool=3),
        )
    )
    page.goto(url)
    page.locator("[data-zoom=in]").click()
    page.locator("[data-zoom=fit]").click()
    frame = page.locator("#preview svg").bounding_box()
    assert frame is not None
    holes = page.locator("#preview circle.hole")
    expect(holes).to_have_count(3)
    for k in range(3):
        box = holes.nth(k).bounding_box()
        assert box is not None
        assert box["x"] >= frame["x"] - 0.5 and box["y"] >= frame["y"] - 0.5, (box, frame)
        assert box["x"] + box["width"] <= frame["x"] + frame["width"] + 0.5, (box, frame)
        assert box["y"] + box["height"] <= frame["y"] + frame["height"] + 0.5, (box, frame)


def test_cycle_time_line_with_an_error_in_block_1(page: Page, library: Library) -> None:
    """Block 1 in error used to make the line read "blocks 1–0"; the rest is timed."""
    url = library.add(
        program("Error in block 1", drill("1", "1", feed_z="900"), drill("2", "1"), drill("3", "1"))
    )
    page.goto(url)
    total = page.locator(".blocks .total")
    expect(total).not_to_contain_text("1–0")
    expect(total).to_contain_text("block 1")
    expect(total).not_to_contain_text("0:00.0")
    expect(page.locator('#preview g.block[data-block="3"]').first).to_be_attached()


def test_a_large_program_is_drawn_and_linked(page: Page, library: Library) -> None:
    """60 000 moves of LOOP/REP drilling: drawn from its patterns (a canvas above the
    size a browser lays out quickly as SVG); pointing at a hole and clicking opens its
    block, as in the small drawing."""
    made = sized("grid", 60_000)
    url = library.add(made)
    page.goto(url)
    canvas = page.locator("#preview canvas")
    expect(canvas).to_be_visible()
    until(page, "document.querySelector('#preview').dataset.state === 'drawn'", 20)
    # The first hole of the grid: the drill (block 3) at (1, 1) in.
    spot = page.evaluate("window.millblocksPreview.toScreen(1, 1)")
    page.mouse.move(spot[0], spot[1])
    assert_pointer(page, 1, 1)
    page.mouse.click(spot[0], spot[1])
    expect(page.locator("#entry h2")).to_contain_text("Block 3")
    expect(page.locator('.block-row.selected[data-block="3"]')).to_be_visible()
    shot(page, "preview-large")


def first_row_in_view(page: Page) -> tuple[int, float]:
    """The block list's first row in view and its distance (px) below the list's top."""
    found = page.evaluate(
        """() => {
          const list = document.querySelector('#editor .block-list');
          const top = list.getBoundingClientRect().top;
          for (const row of list.querySelectorAll('.block-row[data-block]')) {
            const box = row.getBoundingClientRect();
            if (box.bottom > top + 1) return [Number(row.dataset.block), box.top - top];
          }
          return [0, 0];
        }"""
    )
    return int(found[0]), float(found[1])


def scroll_list_to(page: Page, number: int) -> None:
    """Scroll the block list so that block `number` is its first row in view."""
    page.evaluate(
        """(number) => {
          const list = document.querySelector('#editor .block-list');
          const row = list.querySelector(`.block-row[data-block="${number}"]`);
          list.scrollTop += row.getBoundingClientRect().top - list.getBoundingClientRect().top;
        }""",
        number,
    )


def assert_list_at(page: Page, number: int) -> None:
    block, offset = first_row_in_view(page)
    assert block == number and abs(offset) <= 1, (block, offset)


def test_the_block_list_stays_where_it_was_after_an_edit(page: Page, library: Library) -> None:
    """552 blocks, the list scrolled down its page: opening a block and saving it each
    replace the editor, and the list used to start again at the page's top (block 301
    or 501), the edited row out of sight. It stays where it was."""
    blocks = [drill(str(1 + n % 20), str(1 + n // 20)) for n in range(552)]
    url = library.add(program("552 holes", *blocks))
    page.goto(f"{url}?page=4")
    expect(page.locator('.block-row[data-block="301"]')).to_be_visible()
    scroll_list_to(page, 360)
    assert_list_at(page, 360)
    page.locator('.block-row[data-block="360"] .block-link').click()
    expect(page.locator("#entry h2")).to_contain_text("Block 360")
    assert_list_at(page, 360)
    # On the last page (a save answers with the last page, where new blocks go).
    page.goto(f"{url}?page=6")
    scroll_list_to(page, 530)
    page.locator('.block-row[data-block="530"] .block-link').click()
    expect(page.locator("#entry h2")).to_contain_text("Block 530")
    page.locator("#entry [data-field]").first.fill("2.5")
    page.locator("#entry button[data-submit]").click()
    expect(page.locator('.block-row[data-block="530"] .summary')).to_contain_text("X 2.5")
    assert_list_at(page, 530)
    expect(page.locator('.block-row[data-block="530"]')).to_be_in_viewport()


def dark_green_pixels(page: Page) -> int:
    """How many pixels of the drawing are near the holes' stroke colour (#15803d)."""
    import io

    import numpy as np
    from PIL import Image

    image = Image.open(io.BytesIO(page.locator("#preview").screenshot())).convert("RGB")
    pixels = np.asarray(image, dtype=np.int16)
    near = np.abs(pixels - np.array([21, 128, 61], dtype=np.int16)) < 40
    return int(np.count_nonzero(near.all(axis=2)))


def test_holes_of_a_pattern_look_like_a_hole_drawn_alone(page: Page, library: Library) -> None:
    """A bolt circle's holes are one hole drawn once and placed (<use>). They used to come
    out as rings an inch wide: the page's rule for thin strokes named an ancestor outside
    the pattern, which a copy in <use> does not have. Six placed holes must look like six
    times one hole drawn alone (same scale: the same stock, set by Data Block 0's tools)."""
    circle = program(
        "Six on a circle",
        drill("3", "3"),
        BoltCircle(op=HoleOp.DRILL, holes=6, angle=D(0), radius=D(1)),
    )
    alone = program("One hole", drill("3", "2"))
    page.goto(library.add(circle))
    expect(page.locator("#preview use")).to_have_count(5)  # hole 1 drawn, 2-6 placed
    placed = dark_green_pixels(page)
    page.goto(library.add(alone))
    expect(page.locator("#preview use")).to_have_count(0)
    expect(page.locator("#preview circle.hole")).to_have_count(1)
    one = dark_green_pixels(page)
    assert one > 0
    assert 4 * one <= placed <= 8 * one, (placed, one)


def test_an_edit_redraws_the_preview_after_its_reply(page: Page, library: Library) -> None:
    """An edit's reply carries the rows and times, and asks for the new drawing, which
    replaces the old one when it comes (the old one stays until then)."""
    url = library.add(program("One hole", drill("3", "2"), drill("1", "1")))
    page.goto(url)
    expect(page.locator('#preview circle.hole[cx="3"]')).to_have_count(1)
    page.locator('.block-row[data-block="1"] .block-link').click()
    expect(page.locator("#entry h2")).to_contain_text("Block 1")
    page.locator("#entry [data-field]").first.fill("4.5")
    page.locator("#entry button[data-submit]").click()
    expect(page.locator('.block-row[data-block="1"] .summary')).to_contain_text("X 4.5")
    expect(page.locator('#preview circle.hole[cx="4.5"]')).to_have_count(1)
    expect(page.locator('#preview circle.hole[cx="3"]')).to_have_count(0)
    expect(page.locator("#total")).to_contain_text("Cycle time")


def test_tool_width_is_the_tools_width(page: Page, library: Library) -> None:
    """ "tool width" drew the band about four times too wide (the base rule's 1 px stroke, in
    inches, overrode the band's own width): it runs past the wall and over the islands, so
    the part looked gouged. Found by a review of POCKET; FRAME pockets were drawn alike."""
    url = library.add(
        program(
            "Pocket with the tool's width",
            drill("0", "0", tool=2),
            Frame(placement=Placement.POCKET, xl=D(3), yw=D(2), feed_xy=D(10), tool=2),
        )
    )
    page.goto(url)
    page.locator("[data-swept]").check()
    band = page.locator("#preview path.swept").first
    expect(band).to_be_visible()
    widths = band.evaluate(
        "p => [parseFloat(getComputedStyle(p).strokeWidth), p.getAttribute('stroke-width')]"
    )
    assert math.isclose(widths[0], float(widths[1])) and float(widths[1]) == 0.5, widths


# The drawing the page shows, against the one the server draws afresh for the version stored
# (GET .../drawing, as a page opened now would show it): equal as DOM trees, but for what the
# view itself sets (the viewBox while zoomed, the hole numbers' size, the lit block). With
# "fit" the view's viewBox is the drawing's own, so it is compared too, as numbers.
SAME_AS_FRESH = """async () => {
  const host = document.getElementById('preview');
  const answer = await fetch(location.pathname + '/drawing', {headers: {'HX-Request': 'true'}});
  const t = document.createElement('template');
  t.innerHTML = await answer.text();
  const fresh = t.content.querySelector('#preview > svg');
  const shown = host.querySelector(':scope > svg').cloneNode(true);
  const boxes = [shown, fresh].map(s => s.getAttribute('viewBox').split(/\\s+/).map(Number));
  for (const svg of [fresh, shown]) {
    svg.removeAttribute('viewBox');
    svg.querySelectorAll('g.order').forEach(g => g.removeAttribute('font-size'));
    svg.querySelectorAll('.selected').forEach(e => e.classList.remove('selected'));
  }
  const close = boxes[0].every((v, k) => Math.abs(v - boxes[1][k]) < 1e-9);
  const left = [document, t.content].map(d => d.querySelector('#not-drawn').textContent.trim());
  return {same: shown.isEqualNode(fresh), box: close, boxes: boxes, left: left,
          freshVersion: t.content.querySelector('#preview').dataset.version,
          shown: shown.outerHTML, fresh: fresh.outerHTML};
}"""


def assert_drawing_is_fresh(page: Page, version: int) -> None:
    """The page shows `version`'s drawing, the same as a fresh one (after "fit")."""
    expect(page.locator("#version")).to_have_text(f"v{version}")
    until(page, f"document.getElementById('preview').dataset.version === '{version}'")
    page.locator('[data-zoom="fit"]').click()
    found = page.evaluate(SAME_AS_FRESH)
    assert found["freshVersion"] == str(version)
    if not found["same"]:
        a, b = found["shown"], found["fresh"]
        k = next((i for i in range(min(len(a), len(b))) if a[i] != b[i]), min(len(a), len(b)))
        raise AssertionError(
            f"v{version} differs at {k}:\n{a[k - 200 : k + 300]}\n{b[k - 200 : k + 300]}"
        )
    assert found["box"], found["boxes"]
    assert found["left"][0] == found["left"][1], found["left"]


def open_block(page: Page, number: int) -> None:
    page.locator(f'.block-row[data-block="{number}"] .block-link').click()
    expect(page.locator("#entry h2")).to_contain_text(f"Block {number}:")
    expect(page.locator("#entry h2")).to_contain_text("editing")


def test_an_edit_redraws_only_what_changed(page: Page, library: Library) -> None:
    """An edit's reply carries what changed in the drawing (the edited block's drawing, the
    ones after it that its end point moves, the patterns of a LOOP, the hole numbers, the
    extent) and the page applies it: after edits, a LOOP's pattern changed, a reorder, a
    delete, an insert, an edit undone, a block made red and put right, the drawing is each
    time the one a fresh page shows, and the whole drawing was never fetched again (it was
    after every edit); zoomed in, an edit keeps the zoom. An edit that leaves nothing to
    draw, and the one that puts it right, get the whole drawing, as a fresh page."""
    from bench.programs import editor_program

    url = library.add(editor_program(30))
    fetched: list[str] = []
    # The whole drawing a reply asks for (`?v=`; the checks' own fetches have none).
    page.on("request", lambda r: fetched.append(r.url) if "/drawing?v=" in r.url else None)
    page.on("dialog", lambda dialog: dialog.accept())
    page.goto(url)
    expect(page.locator("#preview g.order text")).not_to_have_count(0)
    zoomed = page.locator("#preview > svg").get_attribute("viewBox")
    version = 1

    def saved() -> None:
        nonlocal version
        version += 1
        assert_drawing_is_fresh(page, version)

    # DRILL 1 moves: its hole, its number, and the rapid to block 2 that starts there.
    open_block(page, 1)
    page.locator("#f-x").fill("0.8")
    page.locator("#entry button[data-submit]").click()
    saved()
    # The LOOP's pattern (a <defs> pattern placed by <use>), and the REP placing it.
    open_block(page, 9)
    page.locator("#f-x").fill("0.2")
    page.locator("#entry button[data-submit]").click()
    saved()
    # Blocks 2 and 3 change places (the cutting order, and the hole numbers, change).
    open_block(page, 3)
    page.locator('#entry button[value="up"]').click()
    saved()
    # Block 12 goes: the blocks after it are numbered one less.
    open_block(page, 12)
    page.locator("#entry button.danger").click()
    saved()
    # A new DRILL at the end, far out: the extent (viewBox) grows.
    page.locator(".block-row.new .block-link, .block-row.new a").first.click()
    expect(page.locator("#entry h2")).to_contain_text("type")
    page.keyboard.press("2")
    expect(page.locator("#entry h2")).to_contain_text("sub-type")
    page.keyboard.press("1")
    expect(page.locator("#entry h2")).to_contain_text("DRILL")
    page.locator("#f-x").fill("6")
    page.locator("#f-y").fill("3")
    page.locator("#f-z_up").fill("0.1")
    page.locator("#f-z_dn").fill("-0.3")
    page.locator("#f-feed_z").fill("5")
    page.locator("#f-tool").fill("1")
    page.locator("#entry button[data-submit]").click()
    saved()
    # ...and undone, as typed back: the extent shrinks again.
    open_block(page, 30)
    page.locator("#f-x").fill("0.5")
    page.locator("#f-y").fill("0.5")
    page.locator("#entry button[data-submit]").click()
    saved()
    # A CIRCLE too small for its tool: drawn in red with its message, then put right.
    open_block(page, 6)
    page.locator("#f-radius").fill("0.1")
    page.locator("#entry button[data-submit]").click()
    saved()
    expect(page.locator('#preview g.block.problem[data-block="6"] title')).to_contain_text(
        "not larger than the 0.5000 in tool"
    )
    open_block(page, 6)
    page.locator("#f-radius").fill("0.4")
    page.locator("#entry button[data-submit]").click()
    saved()
    expect(page.locator("#preview g.block.problem")).to_have_count(0)
    assert fetched == [], fetched
    # Zoomed in, an edit keeps the zoom (the drawing is not replaced).
    page.locator('[data-zoom="in"]').click()
    zoomed = page.locator("#preview > svg").get_attribute("viewBox")
    open_block(page, 1)
    page.locator("#f-x").fill("0.7")
    page.locator("#entry button[data-submit]").click()
    expect(page.locator("#version")).to_have_text(f"v{version + 1}")
    until(page, f"document.getElementById('preview').dataset.version === '{version + 1}'")
    assert page.locator("#preview > svg").get_attribute("viewBox") == zoomed
    saved()
    # A tool Data Block 0 does not have: nothing can be drawn (the page is sent no changes
    # and asks for the drawing, which says why); put right, the drawing comes back whole.
    open_block(page, 1)
    page.locator("#f-tool").fill("9")
    page.locator("#entry button[data-submit]").click()
    expect(page.locator("#not-drawn")).to_contain_text("tool 9 is used in block 1")
    expect(page.locator("#preview > svg")).to_have_count(0)
    version += 1
    open_block(page, 1)
    page.locator("#f-tool").fill("1")
    page.locator("#entry button[data-submit]").click()
    saved()
    expect(page.locator("#not-drawn")).to_have_text("")


def test_a_page_showing_another_drawing_gets_the_whole_new_one(
    page: Page, library: Library
) -> None:
    """A reply's changes are from the version the page says it shows: a page whose drawing
    is of another version (another tab saved meanwhile) is sent no changes, and asks for
    the whole new drawing, which is the fresh one."""
    from bench.programs import editor_program

    url = library.add(editor_program(20))
    page.goto(url)
    expect(page.locator("#preview g.block").first).to_be_attached()
    page.evaluate("document.getElementById('preview').dataset.version = '0'")
    open_block(page, 1)
    page.locator("#f-x").fill("0.9")
    with page.expect_request(lambda r: "/drawing?v=" in r.url):
        page.locator("#entry button[data-submit]").click()
    assert_drawing_is_fresh(page, 2)


def row_shown_whole(page: Page, number: int) -> bool:
    """Whether block `number`'s row is wholly inside the block list's visible part."""
    return bool(
        page.evaluate(
            """(number) => {
              const list = document.querySelector('#editor .block-list');
              const row = list.querySelector(`.block-row[data-block="${number}"]`);
              if (!row) return false;
              const l = list.getBoundingClientRect(), r = row.getBoundingClientRect();
              return r.top >= l.top - 1 && r.bottom <= l.bottom + 1;
            }""",
            number,
        )
    )


def last_row_shown_whole(page: Page) -> int:
    return int(
        page.evaluate(
            """() => {
              const list = document.querySelector('#editor .block-list');
              const l = list.getBoundingClientRect();
              let last = 0;
              for (const row of list.querySelectorAll('.block-row[data-block]')) {
                const r = row.getBoundingClientRect();
                const whole = r.top >= l.top - 1 && r.bottom <= l.bottom + 1;
                if (whole) last = Number(row.dataset.block);
              }
              return last;
            }"""
        )
    )


def test_a_block_moved_down_out_of_sight_is_brought_into_it(page: Page, library: Library) -> None:
    """The last row in sight moved down: the list keeps its place, and the moved block, now
    one row lower, is scrolled into sight. Two mechanisms kept the list's place and undid
    each other: app.js scrolled the moved block into sight, then blocklist.js scrolled the
    list back to where it was, the moved block just under the list's bottom edge."""
    blocks = [drill(str(1 + n % 10), str(1 + n // 10)) for n in range(80)]
    url = library.add(program("80 holes", *blocks))
    page.goto(url)
    scroll_list_to(page, 11)
    last = last_row_shown_whole(page)
    assert 11 < last < 80 and not row_shown_whole(page, last + 1)
    open_block(page, last)
    assert_list_at(page, 11)
    page.locator('#entry button[value="down"]').click()
    expect(page.locator("#version")).to_have_text("v2")
    expect(page.locator(f'.block-row[data-block="{last + 1}"] .summary')).to_contain_text(
        f"X {1 + (last - 1) % 10}"
    )
    assert row_shown_whole(page, last + 1)
    # The list moved no more than it had to: the row that was first in sight is close by.
    block, _ = first_row_in_view(page)
    assert 11 <= block <= 13, block


def test_a_pocket_entry_chosen_in_the_editor_is_drawn_as_its_ramp(
    page: Page, library: Library
) -> None:
    """A CIRCLE POCKET 4 in across with the 1 in tool: ENTRY is asked for only while
    PLACEMENT is POCKET (chosen with the pointer or its number typed), RAMP ANGLE only while
    ENTRY is HELIX or ZIGZAG; choosing HELIX at 3° draws the ramp, a circle of radius 0.25 in
    (the tool's DIA / 4) that the plunge did not have."""
    url = library.add(
        program(
            "Ramped pocket",
            drill("2", "2", tool=3),
            Circle(placement=Placement.POCKET, radius=D(2), feed_xy=D(10), tool=3),
        )
    )
    page.goto(url)
    cut = page.locator('#preview g.block[data-block="2"] path.feed')
    ramp = re.compile(r"A0\.25 0\.25 ")
    expect(cut).to_have_count(1)
    assert not ramp.search(cut.get_attribute("d") or "")
    open_block(page, 2)
    expect(page.locator("#f-entry")).to_be_visible()
    expect(page.locator("#f-ramp_angle")).to_be_hidden()
    # PLACEMENT's number typed at the keyboard shows or hides ENTRY as the pointer's choice
    # does (it did not: the number set the value without a change).
    page.locator("#f-placement").focus()
    page.keyboard.press("1")  # INSIDE
    expect(page.locator("#f-entry")).to_be_hidden()
    expect(page.locator("#f-radius")).to_be_focused()
    page.locator("#f-placement").focus()
    page.keyboard.press("5")  # POCKET
    expect(page.locator("#f-entry")).to_be_visible()
    page.locator("#f-entry").select_option("zigzag")
    expect(page.locator("#f-ramp_angle")).to_be_visible()
    page.locator("#f-entry").select_option("")
    expect(page.locator("#f-ramp_angle")).to_be_hidden()
    page.locator("#f-entry").select_option("helix")
    expect(page.locator("#f-ramp_angle")).to_be_visible()
    page.locator("#f-ramp_angle").fill("3")
    page.locator("#entry button[data-submit]").click()
    expect(page.locator("#version")).to_have_text("v2")
    expect(cut).to_have_attribute("d", ramp)
    expect(page.locator("#preview g.block.problem")).to_have_count(0)
    shot(page, "preview-ramp-entry")
