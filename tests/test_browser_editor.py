"""The editor at the machine (issue 20), in a real browser (Playwright, Debian's Chromium).

Each test here is a trap a machinist met in the trial, or what the issue asks the editor
to show; each failed before its fix (the commit that fixed it says how).
"""

from __future__ import annotations

import re
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from decimal import Decimal

import pytest
from flask import Flask
from playwright.sync_api import Page, expect
from werkzeug.serving import make_server

from app import create_app
from app.cnc.blocks import (
    ArcEnd,
    Block,
    Comp,
    DataBlock0,
    Direction,
    Hole,
    HoleOp,
    MillArc,
    MillLine,
    Mode,
    Pos,
    Program,
    Tool,
)
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


# -- the control's keystrokes (issue 20 items 1-3, 6) --------------------------------------

D = Decimal
TOOLS = (
    Tool(number=1, diameter=D("0.25"), rpm=1200, tcal=D(0)),
    Tool(number=2, diameter=D("0.5"), rpm=800, tcal=D(0)),
)


def program_of(*blocks: Block) -> Program:
    return Program(name="keys", block0=DataBlock0(current_tool=1, tools=TOOLS), blocks=blocks)


def drill(x: str, y: str, **more: object) -> Hole:
    values: dict[str, object] = {
        "op": HoleOp.DRILL,
        "x": D(x),
        "y": D(y),
        "z_up": D("0.1"),
        "z_dn": D("-0.3"),
        "feed_z": D(5),
        "tool": 1,
    }
    return Hole(**{**values, **more})  # type: ignore[arg-type]


def open_editor(page: Page, served: Served, program: Program) -> int:
    program_id = served.create(program)
    page.goto(f"{served.url}/programs/{program_id}")
    expect(page.locator("#entry h2")).to_contain_text(f"Block {len(program.blocks) + 1}: type")
    settle(page)
    return program_id


def saved_blocks(served: Served, program_id: int) -> tuple[Block, ...]:
    with served.app.app_context():
        return get_library().get(program_id).program.blocks


def stored_count(served: Served, program_id: int) -> int:
    return len(saved_blocks(served, program_id))


def enter(page: Page, *values: str) -> None:
    """Type each value and press Enter, as at the control's prompts ("" keeps the value)."""
    for value in values:
        if value:
            page.keyboard.type(value)
        page.keyboard.press("Enter")


def choose(page: Page, key: str, heading: str) -> None:
    """Press `key` on a menu and wait for the next step (its heading has `heading`)."""
    before = page.locator("#entry h2").inner_text()
    page.keyboard.press(key)
    expect(page.locator("#entry h2")).not_to_have_text(before)
    expect(page.locator("#entry h2")).to_contain_text(heading)
    settle(page)


def test_inc_is_a_key_at_x_or_y_not_a_prompt(page: Page, served: Served) -> None:
    """Item 1: `2⏎2⏎.1⏎-.5⏎5⏎` put the second 2 on the INC checkbox and shifted every later
    value. INC is a key pressed at the X or Y prompt (I), the mode is shown, and it carries
    to the block and to new blocks."""
    program_id = open_editor(page, served, program_of())
    choose(page, "2", "DRILL")
    choose(page, "1", "Block 1: DRILL")
    enter(page, "2", "2", ".1", "-.5", "5", "1", "1")
    expect(page.locator('.block-row[data-block="1"] .summary')).to_contain_text(
        "X 2  Y 2  Z UP 0.1  Z DN -0.5  FEEDR Z 5"
    )
    choose(page, "2", "DRILL")
    choose(page, "1", "Block 2: DRILL")
    expect(page.locator("#entry .mode")).to_have_text("ABS")
    page.keyboard.press("i")  # at the X prompt
    expect(page.locator("#entry .mode")).to_have_text("INC")
    assert page.evaluate("document.activeElement.name") == "x"
    enter(page, "1", "0", "", "", "", "", "")
    expect(page.locator('.block-row[data-block="2"] .summary')).to_contain_text("INC  X 1  Y 0")
    choose(page, "2", "DRILL")
    choose(page, "1", "Block 3: DRILL")
    expect(page.locator("#entry .mode")).to_have_text("INC")
    blocks = saved_blocks(served, program_id)
    assert [b.mode for b in blocks] == [Mode.ABS, Mode.INC]
    assert blocks[0] == drill("2", "2", z_up=D(".1"), z_dn=D("-.5"))


def menu_numbers(page: Page) -> dict[str, str]:
    """Each choice of the menu shown: its title → its number."""
    found: dict[str, str] = page.evaluate(
        """() => Object.fromEntries(Array.from(document.querySelectorAll('#entry .choice'))
              .map(c => [(c.querySelector('.what') || c).textContent.replace(/^\\s*\\d+\\s*/, '')
                         .trim(), c.dataset.key]))"""
    )
    return found


def test_menu_numbers_never_change(page: Page, served: Served) -> None:
    """Item 2: DRILL CUT LT was 3, or 4 when BOLT CIR was offered; COPY 8, or 9 with REP.
    A number always means the same type; what does not fit is shown with the reason, and
    its number is refused with that reason."""
    open_editor(page, served, program_of(Pos(x=D(0), y=D(0), tool=1)))
    first = menu_numbers(page)
    assert (first.get("REP"), first.get("COPY")) == ("8", "9"), first
    page.keyboard.press("8")
    expect(page.locator("#entry .refused")).to_contain_text("REP closes an open LOOP")
    expect(page.locator("#entry h2")).to_contain_text("Block 2: type")
    choose(page, "2", "DRILL")
    after_pos = menu_numbers(page)
    assert (after_pos.get("DRILL CUT LT"), after_pos.get("BOLT CIR DRILL")) == ("4", "2")
    expect(page.locator('#entry .choice[data-key="2"]')).to_have_class(re.compile("unavailable"))

    open_editor(page, served, program_of(drill("1", "1", loop=True, mode=Mode.INC)))
    in_loop = menu_numbers(page)
    assert (in_loop.get("REP"), in_loop.get("COPY")) == ("8", "9"), in_loop
    choose(page, "2", "DRILL")
    assert menu_numbers(page).get("DRILL CUT LT") == "4"


def test_prefill_comes_from_the_sequence_being_cut(page: Page, served: Served) -> None:
    """Item 3: a MILL STD after an ARC XY-END came with TOOL 1 (the contour uses tool 2) and
    empty Z DN and FEEDR XY; a LOOP DRILL ticked INC but offered the absolute position."""
    contour = program_of(
        drill("0", "-2", comp=Comp.RIGHT, z_dn=D("-0.2"), tool=2),
        MillLine(x=D(3), y=D(-2), z_dn=D("-0.2"), feed_xy=D(10), tool=2),
        MillArc(direction=Direction.CCW, x=D(3), y=D(-1), feed_xy=D(10), tool=2),
        ArcEnd(x=D(3), y=D(0)),
    )
    open_editor(page, served, contour)
    choose(page, "5", "MILL")
    choose(page, "1", "MILL STD")
    values = page.evaluate(
        "Object.fromEntries(Array.from(document.querySelectorAll('#entry [data-field]'))"
        ".map(f => [f.name, f.value]))"
    )
    assert (values["tool"], values["z_dn"], values["feed_xy"]) == ("2", "-0.2", "10")

    open_editor(page, served, program_of(Pos(x=D("1.5"), y=D(5), tool=1)))
    choose(page, "6", "LOOP")
    choose(page, "2", "LOOP")
    choose(page, "1", "LOOP DRILL")
    expect(page.locator("#entry .mode")).to_have_text("INC")
    assert page.locator("#f-x").input_value() == "0" and page.locator("#f-y").input_value() == "0"


def test_a_stray_enter_saves_nothing_and_escape_leaves(page: Page, served: Served) -> None:
    """Item 3: one extra Enter on the menu opened POS, and Enter through it saved an unwanted
    block. Esc leaves a block without saving it."""
    program_id = open_editor(page, served, program_of(Pos(x=D(1), y=D(1), tool=1)))
    page.keyboard.press("Enter")
    page.keyboard.press("Enter")
    expect(page.locator("#entry h2")).to_contain_text("Block 2: type")
    choose(page, "1", "Block 2: POS")
    enter(page, "", "", "", "")  # X, Y, INDEX, TOOL # as offered
    expect(page.locator("#entry .untouched")).to_be_visible()
    expect(page.locator("#entry h2")).to_contain_text("Block 2: POS")
    assert stored_count(served, program_id) == 1
    page.locator("#f-x").focus()
    page.keyboard.type("4")
    page.keyboard.press("Escape")
    expect(page.locator("#entry h2")).to_contain_text("Block 2: type")
    assert stored_count(served, program_id) == 1


def test_data_block_0_enter_reaches_coolant_and_saving_returns(page: Page, served: Served) -> None:
    """Item 6: in Data Block 0 Enter skipped Coolant, and saving stayed on the page."""
    program_id = served.create(program_of())
    page.goto(f"{served.url}/programs/{program_id}/db0")
    until(page, "document.activeElement && document.activeElement.name === 'x_offset'")
    enter(page, "", "", "", "", "")  # X, Y, CUR-TOOL, 0 CONV 1 CLIMB, Z RET
    enter(page, "", "", "")  # tool 1: DIA, RPM, TCAL
    assert page.evaluate("document.activeElement.name") == "coolant_1"
    page.keyboard.press("Control+Enter")
    expect(page.locator("#entry h2")).to_contain_text("Block 1: type")
    expect(page.locator(".message.ok")).to_contain_text("Data Block 0 saved")
    assert f"/programs/{program_id}?" in page.url


def test_the_library_links_each_program_to_its_history(page: Page, served: Served) -> None:
    """Item 6: the library had no History link."""
    program_id = served.create(program_of())
    page.goto(served.url + "/")
    row = page.locator(f'#program-list tr:has(a[href="/programs/{program_id}"])')
    row.get_by_role("link", name="History").click()
    expect(page.locator("h1")).to_contain_text("History")
    assert page.url.endswith(f"/programs/{program_id}/history")
