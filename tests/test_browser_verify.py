"""The finished part in a real browser: three.js drawing the simulated part with WebGL.

Debian's Chromium renders WebGL in software here (SwiftShader), the way a machine without a
GPU would. A machinist opens a program from the library, opens the editor's verify panel,
goes to its finished part, sees the part drawn, points at the pocket and reads which block
cut it, replays the cut back to before the pocket, moves the section plane, and clicks the
pocket to open its block. The page's console must stay free of errors (a CSP refusal would
show there). Screenshots go to test-output/screenshots/.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator

import pytest
from playwright.sync_api import Browser, Page, expect, sync_playwright

from tests.test_browser import CHROMIUM, page, server, shot, until

# The app server and the page (which fails the test on any console error) are
# test_browser's; the browser they use here is this module's, with software WebGL.
__all__ = ["page", "server"]

WEBGL_ARGS = [
    "--no-sandbox",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--ignore-gpu-blocklist",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


@pytest.fixture(scope="module")
def browser() -> Iterator[Browser]:
    assert shutil.which(CHROMIUM) or os.path.exists(CHROMIUM), "Debian chromium missing"
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=WEBGL_ARGS)
        yield browser
        browser.close()


def view(page: Page, key: str) -> str:
    value: str = page.evaluate(f"document.getElementById('part-view').dataset.{key} || ''")
    return value


# Distinct colours in the WebGL canvas (copied onto a 2D canvas): a blank view has one.
COLOURS = """(() => {
  const gl = document.getElementById('part-canvas');
  const c = document.createElement('canvas');
  c.width = gl.width; c.height = gl.height;
  const ctx = c.getContext('2d');
  ctx.drawImage(gl, 0, 0);
  const data = ctx.getImageData(0, 0, c.width, c.height).data;
  const seen = new Set();
  for (let k = 0; k < data.length; k += 4 * 97) {
    seen.add(data[k] << 16 | data[k + 1] << 8 | data[k + 2]);
  }
  return seen.size;
})()"""


def test_the_finished_part_in_3d(page: Page, server: str) -> None:
    page.goto(server + "/")
    page.get_by_role("link", name="Rectangular pocket").click()
    expect(page.locator("h1")).to_contain_text("Rectangular pocket")
    # The editor's verify panel: opening it simulates the program and reports per block.
    page.locator("details.verify-panel summary").click()
    expect(page.locator(".verify-panel .verify-body")).to_contain_text("Nothing found")
    page.keyboard.press("Alt+v")
    expect(page.locator("h1")).to_contain_text("Finished part")
    expect(page.locator(".message.ok")).to_contain_text("Nothing found")
    until(page, "document.getElementById('part-view').dataset.state === 'ready'", 30)
    until(page, "Number(document.getElementById('part-view').dataset.frames || 0) > 0")
    # Read back as the frames come (under load the first may be read before it is drawn).
    until(page, f"{COLOURS.strip()} > 20", 10)  # the part is drawn
    shot(page, "14-finished-part")

    # Pointing at the middle of the part: the pocket, cut by the FRAME POCKET (block 2).
    canvas = page.locator("#part-canvas")
    box = canvas.bounding_box()
    assert box is not None
    middle = (box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    page.mouse.move(*middle)
    expect(page.locator("#pick")).to_contain_text("cut by block 2 (FRAME POCKET)")

    # Replay back to block 1 (only the plunge), then forward to the end again.
    page.locator("#replay").focus()
    page.keyboard.press("ArrowLeft")
    until(page, "document.getElementById('part-view').dataset.upto === '1'", 30)
    expect(page.locator("#replay-label")).to_have_text("1")
    page.mouse.move(*middle)
    expect(page.locator("#pick")).to_contain_text("uncut stock")
    shot(page, "15-finished-part-replay-block-1")
    page.locator("#replay").focus()
    page.keyboard.press("End")
    until(page, "document.getElementById('part-view').dataset.upto === '2'", 30)

    # The section plane halfway along X.
    frames = int(view(page, "frames"))
    page.locator("#section").fill("500")
    until(page, f"Number(document.getElementById('part-view').dataset.frames) > {frames}")
    shot(page, "16-finished-part-section")

    # Orbit by dragging, then click the pocket: its block opens in the editor.
    frames = int(view(page, "frames"))
    page.mouse.move(*middle)
    page.mouse.down()
    page.mouse.move(middle[0] + 120, middle[1] + 40, steps=12)
    page.mouse.up()
    until(page, f"Number(document.getElementById('part-view').dataset.frames) > {frames}")
    page.locator("#section").focus()
    page.keyboard.press("End")
    box = canvas.bounding_box()
    assert box is not None
    page.mouse.click(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    expect(page.locator("#entry h2")).to_contain_text("Block 2")
    assert "edit=2" in page.url
