"""Picking tools from the crib in Data Block 0, in a real browser (issue 34 point 2),
at 1280 and 800 px: a machinist adds a tool on the crib's page, types a crib number in a
tool's Crib field (Enter) and a name in another's (Tab), sees DIA, NAME and the offered RPM
filled (a typed RPM kept), the feeds offered for 1018 steel, saves with Ctrl+Enter, and a
TAP block is offered the tap's exact feed, changing with the tool typed. Screenshots go to
test-output/screenshots/.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from dataclasses import dataclass
from decimal import Decimal as D

import pytest
from flask import Flask
from playwright.sync_api import Page, expect
from werkzeug.serving import make_server

from app import create_app
from app.cnc.blocks import DataBlock0, Hole, HoleOp, Program, Tool
from app.cnc.cutting import MaterialName, Workpiece
from app.cnc.tools import CribTool, PitchUnit, ToolMaterial, ToolType
from app.storage.crib import Crib
from app.web import get_library
from tests.test_browser import browser, page, shot, until

# The browser and the page (which fails the test on any console error) are test_browser's.
__all__ = ["browser", "page"]

TOOLS = [
    CribTool(
        number=3,
        name="3/16 END MILL",
        kind=ToolType.END_MILL,
        diameter=D("0.1875"),
        flutes=3,
        material=ToolMaterial.CARBIDE,
        length=D("0.75"),
    ),
    CribTool(number=7, name="#7 DRILL", kind=ToolType.DRILL, diameter=D("0.201"), flutes=2),
]


@dataclass(frozen=True)
class Served:
    url: str
    app: Flask

    def program(self) -> int:
        """A part in 1018 steel whose tool 1 is typed by hand (no crib)."""
        program = Program(
            name="Tapped bracket",
            material=Workpiece(name=MaterialName.STEEL_1018),
            block0=DataBlock0(tools=(Tool(number=1, diameter=D("0.5"), rpm=800),)),
            blocks=(
                Hole(
                    op=HoleOp.DRILL,
                    x=D(1),
                    y=D(1),
                    z_up=D("0.1"),
                    z_dn=D("-0.5"),
                    feed_z=D(5),
                    tool=1,
                ),
            ),
        )
        with self.app.app_context():
            return get_library().create(program).id


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    db = tmp_path_factory.mktemp("browser-crib") / "library.db"
    app = create_app({"DATABASE_URL": f"sqlite:///{db}", "SECRET_KEY": "browser-test" * 32})
    with app.app_context():
        crib = Crib(get_library())
        for tool in TOOLS:
            crib.create(tool)
    http = make_server("127.0.0.1", 0, app, threaded=True)
    thread = threading.Thread(target=http.serve_forever, daemon=True)
    thread.start()
    yield Served(f"http://127.0.0.1:{http.server_port}", app)
    http.shutdown()
    with app.app_context():
        get_library().engine.dispose()


def fits(page: Page, selector: str) -> None:
    """The element is on the page without scrolling sideways: inside the window's width,
    and the page itself no wider than the window."""
    box = page.locator(selector).first.bounding_box()
    width = page.evaluate("window.innerWidth")
    assert box is not None and box["x"] >= 0 and box["x"] + box["width"] <= width + 0.5, box
    assert page.evaluate("document.documentElement.scrollWidth") <= width + 1


@pytest.mark.parametrize("width", [1280, 800])
def test_picking_tools_from_the_crib(page: Page, served: Served, width: int) -> None:
    page.set_viewport_size({"width": width, "height": 900})
    # The crib's page: a 1/4-20 tap added from its form (tap numbers differ per width).
    number = str(12 if width == 1280 else 13)
    name = f"1/4-20 TAP {'A' if width == 1280 else 'B'}"
    page.goto(served.url + "/tools")
    form = page.locator("form.tool-form")
    fits(page, "form.tool-form")
    form.get_by_label("Number (T)").fill(number)
    form.get_by_label("Name").fill(name)
    form.get_by_label("Type").select_option("tap")
    form.get_by_label("DIA").fill("0.25")
    form.get_by_label("Flutes").fill("4")
    form.get_by_label("Length out of the holder").fill("1.375")
    form.get_by_label("Pitch (a tap's)").fill("20")
    form.get_by_role("button", name="Add to the crib").click()
    expect(page.locator("h1")).to_contain_text(f"T{number} {name}")
    shot(page, f"15-crib-tool-{width}")

    program_id = served.program()
    db0 = f"{served.url}/programs/{program_id}/db0"
    page.goto(db0)
    fits(page, "table.tools")
    fits(page, 'input[name="crib_3"]')
    # Tool 3 by its crib number, typed, Enter: the row is the crib's tap, its RPM offered
    # (1018, HSS tap: 50 sfm → 763 → 762 rpm, whose feed 38.1 ipm is exact) and the cursor
    # on that RPM.
    crib3 = page.get_by_label("Tool 3 from the crib")
    crib3.click()
    page.keyboard.type(f"T{number}")
    page.keyboard.press("Enter")
    expect(page.get_by_label("Tool 3 name")).to_have_value(name)
    expect(page.get_by_label("Tool 3 DIA")).to_have_value("0.250")
    expect(page.get_by_label("Tool 3 RPM")).to_have_value("762")
    until(page, "document.activeElement && document.activeElement.name === 'rpm_3'")
    expect(page.locator("#tool-3 .tool-offer")).to_contain_text(
        "762 rpm, high gear · FEEDR Z 38.1 ipm"
    )
    expect(page.locator("#tool-3 .tool-copy")).to_contain_text("tap · 4 flutes · HSS · 20 TPI")
    # Tool 4 by name, in any case, Tab: the crib's end mill; its RPM was typed first and
    # stays (the offer, 4000, never overwrites it).
    page.get_by_label("Tool 4 RPM").fill("3000")
    page.get_by_label("Tool 4 from the crib").fill("3/16 end mill")
    page.keyboard.press("Tab")
    expect(page.get_by_label("Tool 4 name")).to_have_value("3/16 END MILL")
    expect(page.get_by_label("Tool 4 DIA")).to_have_value("0.188")
    expect(page.get_by_label("Tool 4 RPM")).to_have_value("3000")
    # 3000 × 3 × chip load at 0.1875 in (1018: .0005 at 1/8, .001 at 1/4 → .00075) = 6.75.
    expect(page.locator("#tool-4 .tool-offer")).to_contain_text("FEEDR XY 6.7 ipm")
    fits(page, "#tool-4 .tool-offer")
    shot(page, f"16-db0-picked-{width}")
    page.keyboard.press("Control+Enter")
    expect(page.locator(".message.ok")).to_have_text("Data Block 0 saved.")
    with served.app.app_context():
        tools = get_library().get(program_id).program.block0
    tap, mill = tools.tool(3), tools.tool(4)
    assert tap is not None and mill is not None
    assert (tap.crib, tap.name, tap.rpm, tap.pitch, tap.pitch_unit) == (
        int(number),
        name,
        762,
        D(20),
        PitchUnit.TPI,
    )
    assert (mill.crib, mill.diameter, mill.rpm) == (3, D("0.188"), 3000)

    # A TAP block: its FEEDR Z offered for the tool typed, from the tool's own RPM.
    page.goto(f"{served.url}/programs/{program_id}?kind=TAP")
    tool = page.locator("#f-tool")
    tool.fill("3")
    tool.dispatch_event("change")
    expect(page.locator("#f-feed_z")).to_have_value("38.1")
    fits(page, "#f-feed_z")
    # A feed typed stays whatever tool is typed after it.
    page.locator("#f-feed_z").fill("20")
    tool.fill("4")
    tool.dispatch_event("change")
    expect(page.locator("#f-feed_z")).to_have_value("20")
    shot(page, f"17-tap-feed-offered-{width}")
