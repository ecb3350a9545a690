"""The finished-part page over the Flask test client: the report, the surface the 3D view
reads, the PNG and STL downloads, and the stock saved with the program."""

from __future__ import annotations

import struct
from decimal import Decimal
from pathlib import Path

import pytest
from click.testing import CliRunner
from flask import Flask
from flask.testing import FlaskClient

from app.cli import main
from app.cnc import document, sizes
from app.cnc.simulate.verify import prepare, work
from app.web import get_library
from tests.hostile_corpus import helix_of_many_turns, loop_of_holes, verify_past_the_limit
from tests.test_verify import CASES_DIR
from tests.test_web import app, client, token

__all__ = ["app", "client"]


def add(app: Flask, case: str) -> int:
    program = document.loads((CASES_DIR / case / "program.json").read_text())
    with app.app_context():
        return get_library().create(program).id


GOLDEN = Path(__file__).parent / "golden"


def add_golden(app: Flask, case: str) -> int:
    program = document.loads((GOLDEN / case / "program.json").read_text())
    with app.app_context():
        return get_library().create(program).id


def test_the_page_lists_the_findings_by_block_with_links(app: Flask, client: FlaskClient) -> None:
    pid = add(app, "contour-start-gouge-mm")
    page = client.get(f"/programs/{pid}/verify")
    assert page.status_code == 200
    text = page.get_data(as_text=True)
    assert f'href="/programs/{pid}?edit=5"' in text
    assert "gouge: cuts 5.985 mm into the finished contour of block 2" in text
    assert "/static/verify.js" in text and "<script>" not in text and "style=" not in text


def test_the_surface_is_the_height_map_up_to_the_block_asked_for(
    app: Flask, client: FlaskClient
) -> None:
    pid = add(app, "hole-milled-deeper")

    def header(url: str) -> tuple[int, ...]:
        data = client.get(url).data
        assert data[:4] == b"MBS1"
        nx, ny, x0, y0, res, top, bottom, upto, blocks = struct.unpack("<II5dII", data[4:60])
        assert len(data) == 60 + 8 * nx * ny
        assert (top, blocks) == (0.0, 3) and bottom < -0.4
        # The grid covers the pocket of radius 0.6 about (2, 2), in inches.
        assert x0 < 1.4 and y0 < 1.4 and x0 + nx * res > 2.6 and y0 + ny * res > 2.6
        return nx, ny, upto

    whole = header(f"/programs/{pid}/verify/surface")
    assert whole[2] == 3
    assert header(f"/programs/{pid}/verify/surface?upto=1")[2] == 1


def test_png_and_stl_downloads(app: Flask, client: FlaskClient) -> None:
    pid = add(app, "frame-pocket")
    png = client.get(f"/programs/{pid}/verify/part.png")
    assert png.mimetype == "image/png" and png.data.startswith(b"\x89PNG")
    stl = client.get(f"/programs/{pid}/verify/part.stl")
    assert stl.mimetype == "model/stl"
    assert (
        'filename="Frame-pocket-3-x-2--corner-radius-0-375.stl"'
        in stl.headers["Content-Disposition"]
    )
    assert struct.unpack("<I", stl.data[80:84])[0] * 50 + 84 == len(stl.data)
    sheet = client.get(f"/programs/{pid}/setup").get_data(as_text=True)
    assert f'src="/programs/{pid}/verify/part.png"' in sheet


def test_the_stock_is_saved_with_the_program_and_refused_when_wrong(
    app: Flask, client: FlaskClient
) -> None:
    pid = add(app, "frame-pocket")
    url = f"/programs/{pid}/verify"
    fields = {"x": "0.5", "y": "0.5", "z": "0", "xl": "4", "yw": "3", "zh": "0.75"}
    bad = client.post(
        url + "/stock", data={**fields, "zh": "0", "csrf_token": token(client, url), "version": "1"}
    )
    assert bad.status_code == 422
    assert "ZH: must be more than 0" in bad.get_data(as_text=True)
    with app.app_context():
        assert get_library().get(pid).program.stock is None
    saved = client.post(
        url + "/stock", data={**fields, "csrf_token": token(client, url), "version": "1"}
    )
    assert saved.status_code == 302
    with app.app_context():
        stock = get_library().get(pid).program.stock
    assert stock is not None and stock.zh == Decimal("0.75") and stock.xl == Decimal(4)
    with app.app_context():
        history = get_library().revisions(pid)
    assert history[-1].summary.startswith("stock: none (sized from the program's extent) → 4 × 3")
    page = client.get(url).get_data(as_text=True)
    assert (
        "X 0.5000 to 4.5000, Y 0.5000 to 3.5000, Z -0.7500 to 0.0000 in (the program&#39;s stock)"
        in page
    )
    cleared = client.post(
        url + "/stock", data={"action": "clear", "csrf_token": token(client, url), "version": "2"}
    )
    assert cleared.status_code == 302
    with app.app_context():
        assert get_library().get(pid).program.stock is None


def test_a_stock_too_tall_to_simulate_is_refused_not_a_server_error(
    app: Flask, client: FlaskClient
) -> None:
    pid = add(app, "frame-pocket")
    url = f"/programs/{pid}/verify"
    fields = {"x": "0.5", "y": "0.5", "z": "2000", "xl": "4", "yw": "3", "zh": "0.75"}
    bad = client.post(
        url + "/stock", data={**fields, "csrf_token": token(client, url), "version": "1"}
    )
    assert bad.status_code == 422
    assert "Z TOP: must be within ±1000 in, got 2000" in bad.get_data(as_text=True)
    with app.app_context():
        assert get_library().get(pid).program.stock is None


def test_a_program_with_errors_is_not_simulated(app: Flask, client: FlaskClient) -> None:
    text = (CASES_DIR / "frame-pocket" / "program.json").read_text()
    program = document.loads(text.replace('"feed_z": 5', '"feed_z": 900'))
    with app.app_context():
        pid = get_library().create(program).id
    assert client.get(f"/programs/{pid}/verify").status_code == 422
    assert client.get(f"/programs/{pid}/verify/surface").status_code == 422


def test_the_editor_links_to_the_finished_part(app: Flask, client: FlaskClient) -> None:
    pid = add(app, "frame-pocket")
    assert f'href="/programs/{pid}/verify"' in client.get(f"/programs/{pid}").get_data(as_text=True)


def test_the_editor_s_verify_panel_reads_the_findings_per_block(
    app: Flask, client: FlaskClient
) -> None:
    pid = add(app, "contour-start-gouge-mm")
    editor = client.get(f"/programs/{pid}").get_data(as_text=True)
    assert f'data-report="/programs/{pid}/verify/report"' in editor
    fragment = client.get(f"/programs/{pid}/verify/report").get_data(as_text=True)
    assert 'class="finding" data-block="5"' in fragment
    assert f'href="/programs/{pid}?edit=5"' in fragment and "MILL STD" in fragment


def test_a_simulation_past_the_server_s_limit_is_refused_on_every_page(
    app: Flask, client: FlaskClient
) -> None:
    """A HELIX 52 mm deep sweeps ~137 M cells: every page that simulates refuses it before
    the work starts, naming the figure, the limit and what to do; before issue 30 each ran
    it, and the heaviest legal program ran 14-60 s. (Every golden program is within the
    limit: the thread mill, 76 M, is verified on the web in a few seconds.)"""
    with app.app_context():
        pid = get_library().create(verify_past_the_limit()).id
    golden = client.get(f"/programs/{add_golden(app, 'thread-mill-external-mm')}/verify")
    assert golden.status_code == 200, golden.get_data(as_text=True)
    limit = f"sweeps at most {sizes.MAX_VERIFY_WORK:,}"
    page = client.get(f"/programs/{pid}/verify")
    text = page.get_data(as_text=True)
    assert page.status_code == 422, text
    assert "Too much to simulate" in text and limit in text
    assert "simulating this program means sweeping about 136,597,876 cells" in text
    assert "millblocks verify" in text
    report = client.get(f"/programs/{pid}/verify/report").get_data(as_text=True)
    assert limit in report and "millblocks verify" in report
    # The set-up sheet's picture: the same 800 cells along the stock. (The 3D view's
    # surface, at 320, is a sixth of the work, and held to the same limit.)
    picture = client.get(f"/programs/{pid}/verify/part.png")
    assert picture.status_code == 422 and limit in picture.get_data(as_text=True)


def test_the_heaviest_legal_loop_of_holes_is_refused_not_simulated_for_a_minute(
    app: Flask, client: FlaskClient
) -> None:
    """Issue 30's program: within the moves limit, yet 14-60 s of Verify on a shop server;
    the page now says at once that it is too much to simulate here."""
    with app.app_context():
        pid = get_library().create(loop_of_holes(15)).id
    report = client.get(f"/programs/{pid}/verify/report").get_data(as_text=True)
    assert f"sweeps at most {sizes.MAX_VERIFY_WORK:,}" in report, report


def test_a_helix_of_thousands_of_turns_is_refused_on_every_page_that_would_chord_it(
    app: Flask, client: FlaskClient
) -> None:
    """An audit of issue 30: a 5 000-turn HELIX (a small compiled path, millions of chords)
    passed the work limit on the 3D view's coarse grid (47 M cells) and its surface took
    18-28 s and the STL 28 s; the tape picture and punch image 19-30 s. A segment's own
    cost now counts (SEGMENT_WORK), and a tape's chords are held to the moves a program may
    make; LinuxCNC's G-code, which writes helical arcs, still exports it."""
    with app.app_context():
        pid = get_library().create(helix_of_many_turns()).id
    limit = f"sweeps at most {sizes.MAX_VERIFY_WORK:,}"
    for page in ("verify/surface", "verify/part.stl", "verify/part.png", "verify"):
        answer = client.get(f"/programs/{pid}/{page}")
        assert answer.status_code == 422, page
        assert limit in answer.get_data(as_text=True), page
    for target in ("tape-eia", "tape-svg"):
        refused = client.get(f"/programs/{pid}/export/download?target={target}")
        text = refused.get_data(as_text=True)
        assert refused.status_code == 422, target
        assert "its arcs written as chords (this target has no helical arcs) make more than" in text
        assert "1,000,000 moves" in text
    gcode = client.get(f"/programs/{pid}/export/download?target=gcode-linuxcnc")
    assert gcode.status_code == 200 and b"G2" in gcode.data


def test_the_command_line_verifies_what_the_server_refuses(tmp_path: Path) -> None:
    """`millblocks verify` has no work limit: the user's own computer, the user's time."""
    program = verify_past_the_limit()
    grid, placed = prepare(program)
    assert work(grid, placed) > sizes.MAX_VERIFY_WORK
    path = tmp_path / "helix.json"
    path.write_text(document.dumps(program))
    result = CliRunner().invoke(main, ["verify", str(path)])
    assert "sweeps at most" not in result.output
    assert "removed" in result.output, result.output


def test_a_heavy_request_waits_its_turn_then_hears_the_server_is_busy(
    app: Flask, client: FlaskClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    """One heavy request (Verify, the set-up sheet, an export) at a time per process: while
    one runs, another waits at most HEAVY_WAIT and is then told to try again (503, a
    page that says so), and a light page is answered meanwhile."""
    from app.web import heavy

    pid = add(app, "frame-pocket")
    monkeypatch.setattr(heavy, "HEAVY_WAIT", 0.01)
    assert heavy._RUNNING.acquire(timeout=5)  # another heavy request is running
    try:
        for path in ("verify", "verify/report", "verify/part.png", "setup", "export/download"):
            busy = client.get(f"/programs/{pid}/{path}")
            text = busy.get_data(as_text=True)
            assert busy.status_code == 503, (path, busy.status_code)
            assert "working on other large programs" in text and "again in a few" in text, path
            assert busy.headers["Retry-After"] == "5"
        assert client.get(f"/programs/{pid}").status_code == 200
    finally:
        heavy._RUNNING.release()
    assert client.get(f"/programs/{pid}/verify").status_code == 200
    # Two heavy requests already here (one running, one waiting): a third is told at once,
    # however long it might have waited, so that they never hold every thread.
    monkeypatch.setattr(heavy, "HEAVY_WAIT", 60.0)
    for _ in range(heavy.HEAVY_ADMITTED):
        assert heavy._ADMITTED.acquire(timeout=5)
    try:
        assert client.get(f"/programs/{pid}/setup").status_code == 503
    finally:
        for _ in range(heavy.HEAVY_ADMITTED):
            heavy._ADMITTED.release()
    assert client.get(f"/programs/{pid}/setup").status_code == 200
