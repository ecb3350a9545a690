"""The web app through Flask's test client: pages, forms without JavaScript, CSRF,
security headers, stale saves, exports and downloads."""

from __future__ import annotations

import html
import re
from collections.abc import Iterator
from pathlib import Path

import pytest
from flask import Flask
from flask.testing import FlaskClient
from sqlalchemy import Engine

from app import create_app
from app.web import get_library


@pytest.fixture
def app(tmp_path: Path) -> Iterator[Flask]:
    app = create_app(
        {"DATABASE_URL": f"sqlite:///{tmp_path / 'web.db'}", "SECRET_KEY": "test" * 32}
    )
    yield app
    get_library_engine(app).dispose()


def get_library_engine(app: Flask) -> Engine:
    with app.app_context():
        return get_library().engine


@pytest.fixture
def client(app: Flask) -> FlaskClient:
    return app.test_client()


def token(client: FlaskClient, url: str = "/") -> str:
    page = client.get(url).get_data(as_text=True)
    found = re.search(r'name="csrf_token" value="([^"]+)"', page)
    assert found, "no CSRF token on the page"
    return found.group(1)


def test_every_page_renders(client: FlaskClient) -> None:
    for url in (
        "/",
        "/trash",
        "/machines",
        "/transfers",
        "/programs/1",
        "/programs/1/db0",
        "/programs/1/export",
        "/programs/1/entry?group=DRILL",
        "/programs/1/entry?kind=DRILL",
        "/programs/1?edit=3",
    ):
        response = client.get(url)
        assert response.status_code == 200, url
        assert "MillBlocks" in response.get_data(as_text=True)


def test_security_headers(client: FlaskClient) -> None:
    response = client.get("/")
    csp = response.headers["Content-Security-Policy"]
    assert "script-src 'self'" in csp and "unsafe-inline" not in csp
    assert "frame-ancestors 'none'" in csp
    assert response.headers["X-Content-Type-Options"] == "nosniff"
    assert response.headers["Referrer-Policy"] == "same-origin"


def test_state_change_without_csrf_token_is_refused(client: FlaskClient) -> None:
    response = client.post("/programs", data={"name": "sneaky"})
    assert response.status_code == 400
    assert "CSRF" in response.get_data(as_text=True)
    assert "sneaky" not in client.get("/").get_data(as_text=True)


def test_create_program_then_enter_a_block_without_javascript(client: FlaskClient) -> None:
    csrf = token(client)
    response = client.post(
        "/programs",
        data={"csrf_token": csrf, "name": "Plate", "part_number": "42", "units": "inch"},
    )
    assert response.status_code == 302
    program_id = int(response.headers["Location"].split("/")[2])
    response = client.post(
        f"/programs/{program_id}/db0",
        data={
            "csrf_token": csrf,
            "version": "1",
            "x_offset": "2",
            "y_offset": "1",
            "current_tool": "1",
            "milling": "climb",
            "z_retract": "0.1",
            "dia_1": "0.25",
            "rpm_1": "1500",
            "tcal_1": "0",
        },
    )
    assert response.status_code == 302
    response = client.post(
        f"/programs/{program_id}/blocks",
        data={
            "csrf_token": csrf,
            "version": "2",
            "kind": "DRILL",
            "at": "1",
            "units": "inch",
            "x": "1",
            "y": "1",
            "z_up": "0.1",
            "z_dn": "-0.5",
            "feed_z": "5",
            "pecks": "2",
            "tool": "1",
        },
    )
    assert response.status_code == 302
    page = client.get(f"/programs/{program_id}").get_data(as_text=True)
    assert "X 1  Y 1  Z UP 0.1  Z DN -0.5  FEEDR Z 5  # PECK 2  TOOL # 1" in page
    assert 'class="hole"' in page  # the preview drew the hole


def test_bad_value_is_named_and_nothing_is_saved(client: FlaskClient) -> None:
    csrf = token(client)
    before = client.get("/programs/2").get_data(as_text=True)
    response = client.post(
        "/programs/2/blocks",
        data={
            "csrf_token": csrf,
            "version": "1",
            "kind": "POS",
            "at": "4",
            "x": "1",
            "y": "abc",
            "tool": "1",
        },
    )
    assert response.status_code == 422
    text = response.get_data(as_text=True)
    assert "Not saved: Y: &#39;abc&#39; is not a number" in text
    with client.application.app_context():
        assert get_library().get(2).info.version == 1
    assert before.count("block-row") == client.get("/programs/2").get_data(as_text=True).count(
        "block-row"
    )


def test_out_of_range_value_is_refused_beside_its_field(client: FlaskClient) -> None:
    """As the control refuses a value out of range: nothing is saved, the message stands
    beside the field, the typed values stay in the form."""
    csrf = token(client)
    data = {
        "csrf_token": csrf,
        "version": "1",
        "kind": "DRILL",
        "edit": "2",
        "units": "inch",
        "loop": "on",
        "mode": "inc",
        "x": "0",
        "y": "0",
        "z_up": "0.1",
        "z_dn": "-0.5",
        "feed_z": "300",
        "pecks": "2",
        "tool": "1",
    }
    response = client.post("/programs/2/blocks", data=data)
    assert response.status_code == 422
    page = response.get_data(as_text=True)
    field = page[page.index('for="f-feed_z"') :]
    beside = field[: field.index('<div class="field">')]
    assert "300 ipm is outside the allowed range 0.1 to 250 ipm" in beside
    assert 'value="300"' in beside
    with client.application.app_context():
        assert get_library().get(2).info.version == 1


def db0_form(csrf: str, version: int, rpm: str) -> dict[str, str]:
    return {
        "csrf_token": csrf,
        "version": str(version),
        "x_offset": "0",
        "y_offset": "0",
        "current_tool": "1",
        "milling": "climb",
        "z_retract": "0.1",
        "dia_1": "0.25",
        "rpm_1": rpm,
    }


def test_data_block_0_refuses_values_out_of_range(client: FlaskClient) -> None:
    response = client.post("/programs/2/db0", data=db0_form(token(client), 1, "120000"))
    assert response.status_code == 422
    assert "TOOL 1 RPM: 120000 is not a spindle speed; allowed 1 to 99999" in response.get_data(
        as_text=True
    )
    with client.application.app_context():
        assert get_library().get(2).info.version == 1


def test_an_rpm_beyond_the_control_s_spindle_is_saved_with_a_warning(client: FlaskClient) -> None:
    """9000 rpm was refused: the RPM limit is the machine's (a LinuxCNC mill may run it), so
    the program keeps it and the editor warns that the control's spindle does not."""
    response = client.post("/programs/2/db0", data=db0_form(token(client), 1, "9000"))
    assert response.status_code == 302
    with client.application.app_context():
        assert get_library().get(2).program.block0.tools[0].rpm == 9000
    page = client.get("/programs/2/db0").get_data(as_text=True)
    assert "9000 is outside the control&#39;s spindle range, 60 to 4000 rpm" in page


def test_empty_name_is_refused(client: FlaskClient) -> None:
    csrf = token(client)
    response = client.post(
        "/programs/2/header", data={"csrf_token": csrf, "version": "1", "name": "   "}
    )
    assert response.status_code == 422
    assert "every program needs a name" in response.get_data(as_text=True)


def test_stale_save_is_refused_with_what_changed(client: FlaskClient) -> None:
    csrf = token(client)
    base = {"csrf_token": csrf, "kind": "POS", "at": "4", "x": "5", "y": "5", "tool": "1"}
    assert client.post("/programs/2/blocks", data={**base, "version": "1"}).status_code == 302
    response = client.post("/programs/2/blocks", data={**base, "version": "1", "x": "6"})
    assert response.status_code == 409
    text = response.get_data(as_text=True)
    assert (
        "not saved:" in text and "block 4 POS added" in text and "nothing was overwritten" in text
    )


def test_export_page_and_downloads(client: FlaskClient) -> None:
    page = client.get("/programs/3/export?target=tape-eia&go=1").get_data(as_text=True)
    assert "Compatibility report for tape-eia" in page
    assert "<svg" in page  # the tape picture
    tape = client.get("/programs/3/export/download?target=tape-eia")
    assert tape.status_code == 200
    assert (
        tape.headers["Content-Disposition"].endswith('.tap"')
        or "attachment" in tape.headers["Content-Disposition"]
    )
    gcode = client.get("/programs/3/export/download?target=gcode-linuxcnc")
    assert gcode.status_code == 200 and gcode.data.startswith(b"%\n")


def test_each_target_downloads_under_its_own_file_name(client: FlaskClient) -> None:
    """A shop exporting one part for LinuxCNC and for the Fanuc keeps both files: the
    downloads have different names (part.ngc, part.fanuc.nc), for every target."""
    from app.cnc.formats.targets import targets

    names = {}
    for name in targets():
        response = client.get(f"/programs/3/export/download?target={name}")
        disposition = response.headers.get("Content-Disposition", "")
        found = re.search(r'filename="([^"]+)"', disposition)
        if response.status_code == 200 and found:
            names[name] = found.group(1)
    assert names["gcode-linuxcnc"].endswith(".ngc")
    assert names["gcode-fanuc"].endswith(".fanuc.nc")
    assert len(set(names.values())) == len(names), names


def test_export_page_names_targets_and_options_in_the_shops_words(client: FlaskClient) -> None:
    """The target menu reads "LinuxCNC G-code", "Tektronix 1704 tape (EIA)", not the
    registry's names; options are labelled by what they do, the common ones first and the
    rest folded away."""
    page = client.get("/programs/3/export").get_data(as_text=True)
    menu = re.search(r'<select name="target".*?</select>', page, re.S)
    assert menu is not None
    shown = re.findall(r"<option value=\"([^\"]+)\"[^>]*>([^<]+)</option>", menu.group(0))
    labels = {value: text.strip() for value, text in shown}
    assert labels["gcode-linuxcnc"] == "LinuxCNC G-code"
    assert labels["tape-eia"] == "Tektronix 1704 tape (EIA)"
    assert all(text != value and not text.startswith(value) for value, text in labels.items())
    assert "Options of LinuxCNC G-code" in page
    assert ">write N numbers" in page  # the option's meaning, not "sequence-numbers"
    folded = page.index("<details")
    assert page.index('name="opt_sequence-numbers"') < folded  # common: shown first
    assert page.index('name="opt_tabs"') > folded  # the rest: folded


def test_machines_page_starts_on_a_real_target_and_lists_the_ports(client: FlaskClient) -> None:
    """A new machine starts on LinuxCNC G-code (not the test dump "canon"), targets are
    named as the export page names them, and the serial port can be picked from the ports
    this computer has (pyserial's list)."""
    from app.dnc.service import available_ports

    page = client.get("/machines").get_data(as_text=True)
    menu = re.search(r'<select name="target".*?</select>', page, re.S)
    assert menu is not None
    selected = re.search(r'<option value="([^"]+)" selected>([^<]+)</option>', menu.group(0))
    assert selected is not None
    assert selected.groups() == ("gcode-linuxcnc", "LinuxCNC G-code")
    assert ">canon<" not in menu.group(0)
    picker = re.search(r'<datalist id="ports">.*?</datalist>', page, re.S)
    assert picker is not None
    for device, _ in available_ports():
        assert f'value="{device}"' in picker.group(0)
    assert 'name="port" list="ports"' in page


def test_a_machines_options_are_the_fields_of_its_target(client: FlaskClient) -> None:
    """Options are chosen in fields labelled by what they do (as on the export page), not
    typed as NAME=VALUE lines; only what differs from the target's defaults is kept."""
    page = client.get("/machines?target=gcode-fanuc").get_data(as_text=True)
    assert 'name="options"' not in page
    assert ">write N numbers" in page and 'name="opt_sequence-increment"' in page
    fields = client.get("/machines/options?target=tape-eia").get_data(as_text=True)
    assert 'name="options_for" value="tape-eia"' in fields
    form = {
        "csrf_token": token(client, "/machines"),
        "name": "Fanuc mill",
        "target": "gcode-fanuc",
        "options_for": "gcode-fanuc",
        "opt_sequence-numbers": "on",  # ticked, as the page shows these four
        "opt_canned-cycles": "on",
        "opt_start-retract": "on",
        "opt_tool-change": "on",
        "opt_sequence-increment": "5",
        "opt_trailing-zeros": "drop",  # the Fanuc default: not kept
    }
    assert client.post("/machines", data=form).status_code == 302
    with client.application.app_context():
        saved = get_library().machine("Fanuc mill")
    assert saved.options == {"sequence-increment": "5"}
    page = client.get("/machines?edit=Fanuc+mill").get_data(as_text=True)
    assert 'name="opt_sequence-increment" value="5"' in page


def test_oversized_upload_gets_413(client: FlaskClient) -> None:
    csrf = token(client)
    boundary = "mbtest"
    body = (
        (
            f'--{boundary}\r\nContent-Disposition: form-data; name="csrf_token"\r\n\r\n{csrf}\r\n'
            f'--{boundary}\r\nContent-Disposition: form-data; name="file"; filename="big.json"\r\n'
            "Content-Type: application/json\r\n\r\n"
        ).encode()
        + b"x" * (3 * 1024 * 1024)
        + f"\r\n--{boundary}--\r\n".encode()
    )
    response = client.post(
        "/programs/import", data=body, content_type=f"multipart/form-data; boundary={boundary}"
    )
    assert response.status_code == 413
    assert "larger than the 2,097,152 bytes" in response.get_data(as_text=True)


def test_markup_in_names_renders_inert(client: FlaskClient) -> None:
    csrf = token(client)
    client.post(
        "/programs", data={"csrf_token": csrf, "name": "<script>alert(1)</script>", "units": "inch"}
    )
    page = client.get("/").get_data(as_text=True)
    assert "<script>alert(1)</script>" not in page
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in page


def test_mirror_makes_a_new_program(client: FlaskClient) -> None:
    csrf = token(client)
    response = client.post("/programs/3/mirror", data={"csrf_token": csrf, "axis": "x"})
    assert response.status_code == 302
    new_id = int(response.headers["Location"].split("/")[2])
    with client.application.app_context():
        stored = get_library().get(new_id)
        original = get_library().get(3)
    assert stored.program.name == f"{original.program.name} (mirror X)"


def test_setup_sheet_page(client: FlaskClient) -> None:
    page = client.get("/programs/1/setup?target=tape-eia").get_data(as_text=True)
    assert "Set-up sheet" in page and "Tape length" in page and "ft (" in page
    assert "high gear" in page and "First cut" in page and "<svg" in page


def test_download_is_what_the_page_shows(client: FlaskClient) -> None:
    """Opened fresh (no Preview pressed), the download link still carries every option as
    shown, so the file equals the default export."""
    from app.cnc.formats.targets import export as make

    page = client.get("/programs/3/export?target=tape-eia").get_data(as_text=True)
    link = re.search(r'id="download" accesskey="d" href="([^"]+)"', page)
    assert link
    data = client.get(link.group(1).replace("&amp;", "&")).data
    with client.application.app_context():
        expected = make(get_library().get(3).program, "tape-eia").data
    assert data == expected


def test_rep_s_nx_and_ny_say_they_count_repeats_not_patterns(client: FlaskClient) -> None:
    """NX 2 makes three patterns in X (seed 001 §3.4.5.3); the prompts said only "NX"."""
    page = client.get("/programs/2?edit=3").get_data(as_text=True)
    for axis in "XY":
        assert (
            f"repeats in {axis} after the first pattern, not the number of patterns "
            "(2: three in all)" in page
        )


def test_history_diff_and_restore(client: FlaskClient) -> None:
    csrf = token(client)
    client.post(
        "/programs/2/header",
        data={"csrf_token": csrf, "version": "1", "name": "Renamed", "units": "inch"},
    )
    page = client.get("/programs/2/history?diff=2").get_data(as_text=True)
    assert "name: &#39;LOOP and REP example (Fig. 3-14)&#39; → &#39;Renamed&#39;" in page
    response = client.post(
        "/programs/2/history/1/restore", data={"csrf_token": csrf, "version": "2"}
    )
    assert response.status_code == 302
    with client.application.app_context():
        stored = get_library().get(2)
    assert stored.info.version == 3 and stored.program.name.startswith("LOOP and REP")


def test_editing_a_block_that_does_not_exist_is_404(client: FlaskClient) -> None:
    csrf = token(client)
    for edit in ("0", "99"):
        response = client.post(
            "/programs/2/blocks",
            data={
                "csrf_token": csrf,
                "version": "1",
                "kind": "POS",
                "edit": edit,
                "x": "1",
                "y": "1",
                "tool": "1",
            },
        )
        assert response.status_code == 404
    with client.application.app_context():
        assert get_library().get(2).info.version == 1


def test_importing_an_events_file_shows_its_report(client: FlaskClient, app: Flask) -> None:
    import io

    seed = (Path(__file__).parent / "imports" / "seed003-2.2.5.cnc").read_bytes()
    csrf = token(client)
    response = client.post(
        "/programs/import",
        data={"csrf_token": csrf, "file": (io.BytesIO(seed), "seed003-2.2.5.cnc"), "format": ""},
        content_type="multipart/form-data",
    )
    page = response.get_data(as_text=True)
    assert response.status_code == 201, page
    assert "was read as <strong>events</strong>" in page and "Import report" in page
    assert re.search(r"<td>line \d+", page) and "line 1 line 1" not in page
    with app.app_context():
        [new] = [p for p in get_library().programs() if p.name.lower().startswith("seed")]
    assert f'href="/programs/{new.id}"' in page


def test_a_note_on_hundreds_of_lines_names_the_first_few(client: FlaskClient) -> None:
    """A grid of bolt circles repeats its notes on every circle: the report page lists the
    first eight lines and counts the rest, as the command line's report does, instead of
    a column of hundreds of line numbers."""
    import io

    from bench.gcode_import import gcode_text

    response = client.post(
        "/programs/import",
        data={
            "csrf_token": token(client),
            "file": (io.BytesIO(gcode_text(5_000).encode()), "grid.ngc"),
            "format": "",
        },
        content_type="multipart/form-data",
    )
    page = response.get_data(as_text=True)
    assert response.status_code == 201, page
    listed = re.findall(r"\(also lines ([0-9, ]+?)(?: and (\d+) more)?\)</td>", page)
    assert listed and any(int(rest or 0) > 100 for _, rest in listed)
    assert all(len(numbers.split(", ")) <= 8 for numbers, _ in listed)


def test_a_file_that_cannot_be_imported_saves_nothing(client: FlaskClient, app: Flask) -> None:
    import io

    with app.app_context():
        before = get_library().programs()
    csrf = token(client)
    response = client.post(
        "/programs/import",
        data={
            "csrf_token": csrf,
            "file": (io.BytesIO(b"N1 G01 X1 Y\n"), "bad.ngc"),
            "format": "gcode",
        },
        content_type="multipart/form-data",
    )
    page = response.get_data(as_text=True)
    assert response.status_code == 422
    assert "Not imported: bad.ngc: line 1, column " in page
    with app.app_context():
        assert get_library().programs() == before


def test_a_tape_of_uncalibrated_tools_offers_the_touch_off_choice(
    app: Flask, client: FlaskClient
) -> None:
    """A 1704 tape of a program whose tools have no TCAL opens on the choice the shop has
    (touch off each tool at its change, or fill in the tool table), the per-tool problems
    folded under it; taking the choice exports the tape."""
    from dataclasses import replace

    from app.storage.demo import demo_programs

    sample = demo_programs()[0]
    tools = tuple(replace(t, tcal=None) for t in sample.block0.tools)
    program = replace(sample, block0=replace(sample.block0, tools=tools))
    with app.app_context():
        program_id = get_library().create(program).id
    response = client.get(f"/programs/{program_id}/export?target=tape-eia&go=1")
    page = response.get_data(as_text=True)
    assert response.status_code == 422
    offer = re.search(r'<div class="offer".*?</div>', page, re.S)
    assert offer is not None, page
    assert "needs calibrated tools (TCAL in Data Block 0)" in offer.group(0)
    assert offer.group(0).index("<details>") > offer.group(0).index("Choose:")
    link = re.search(r'href="([^"]*opt_z-zero=g94[^"]*)"', offer.group(0))
    assert link is not None
    assert "touch off each tool at its change" in offer.group(0)
    assert f'href="/programs/{program_id}/db0"' in offer.group(0)
    taken = client.get(link.group(1).replace("&amp;", "&"))
    assert taken.status_code == 200
    assert 'id="download"' in taken.get_data(as_text=True)
    assert "G94" in taken.get_data(as_text=True)


def test_a_machine_preset_fills_the_form_and_saves(app: Flask, client: FlaskClient) -> None:
    """Starting a new machine from a preset fills in its target, options and travel limits;
    every preset saves as it is filled in, and the export page then uses it."""
    from app.web.machines import SHOP_PRESETS

    page = client.get("/machines").get_data(as_text=True)
    assert "Kearney &amp; Trecker Milwaukee-Matic 180, Tektronix 1704 (EIA tape)" in page
    for key, preset in SHOP_PRESETS.items():
        filled = client.get(f"/machines?preset={key}").get_data(as_text=True)
        menu = re.search(r'<select name="target".*?</select>', filled, re.S)
        assert menu is not None
        assert f'<option value="{preset.target}" selected>' in menu.group(0), key
        # The preset menu says which preset filled the form.
        assert f'<option value="{key}" selected>' in filled, key
        form = dict(
            re.findall(
                r'<input name="([^"]+)"[^>]*value="([^"]*)"', filled.split('class="card"')[-1]
            )
        )
        limits = re.search(r'<textarea name="limits"[^>]*>(.*?)</textarea>', filled, re.S)
        assert limits is not None
        for name, value in preset.limits.items():
            assert f"{name}={value}" in limits.group(1)
        csrf = token(client, "/machines")
        saved = client.post(
            "/machines",
            data={
                **form,
                "csrf_token": csrf,
                "name": f"Mill {key}",
                "target": preset.target,
                "limits": limits.group(1),
            },
        )
        assert saved.status_code == 302, saved.get_data(as_text=True)
        with app.app_context():
            machine = get_library().machine(f"Mill {key}")
        assert (machine.target, machine.limits) == (preset.target, dict(preset.limits))
    # The machine's limits now judge the export: the sample part, with its part zero at
    # machine zero, runs into the K&T 180's collision zone.
    exported = client.get("/programs/6/export?machine=Mill+kt-180-1704&go=1")
    assert exported.status_code == 422
    assert "the spindle head can hit the table" in exported.get_data(as_text=True)


def test_the_set_up_sheet_of_uncalibrated_tools_offers_the_touch_off_choice(
    app: Flask, client: FlaskClient
) -> None:
    """The set-up sheet for a 1704 tape of tools without TCAL says what the tape needs and
    offers the touch-off choice (which shows the sheet for it), not a line of errors; its
    target menu names targets as the export page does."""
    from dataclasses import replace

    from app.storage.demo import demo_programs

    sample = demo_programs()[0]
    tools = tuple(replace(t, tcal=None) for t in sample.block0.tools)
    program = replace(sample, block0=replace(sample.block0, tools=tools))
    with app.app_context():
        program_id = get_library().create(program).id
    page = client.get(f"/programs/{program_id}/setup").get_data(as_text=True)
    assert '<option value="tape-eia" selected>Tektronix 1704 tape (EIA)</option>' in page
    offer = re.search(r'<div class="offer.*?</div>', page, re.S)
    assert offer is not None, page
    link = re.search(r'href="([^"]*opt_z-zero=g94[^"]*)"', offer.group(0))
    assert link is not None
    taken = client.get(link.group(1).replace("&amp;", "&")).get_data(as_text=True)
    assert 'class="offer' not in taken and 'role="alert"' not in taken
    assert "Tape length" in taken


def test_the_upload_takes_a_segmented_boss_tape(client: FlaskClient, app: Flask) -> None:
    """Issue 29 #8: a BOSS tape in real-time segments (seed 004 §8.1.1) is one program."""
    import io

    from app.cnc import document
    from app.cnc.formats.targets import export
    from app.cnc.units import Units

    bolt = document.loads(
        (Path(__file__).parent / "golden" / "metric-drill-bolt" / "program.json").read_text()
    )
    tape = export(bolt, "tape-boss", {"segment": "120"}).data
    response = client.post(
        "/programs/import",
        data={
            "csrf_token": token(client),
            "file": (io.BytesIO(tape), "bolt.bos"),
            "format": "",
        },
        content_type="multipart/form-data",
    )
    page = response.get_data(as_text=True)
    assert response.status_code == 201, page
    assert "was read as <strong>boss</strong>" in page
    assert "segments (#0 … $) joined into one program" in page
    with app.app_context():
        [new] = [p for p in get_library().programs() if p.name == "bolt"]
        assert get_library().get(new.id).program.units is Units.MM


def test_a_program_with_errors_downloads_as_its_json_document(app: Flask) -> None:
    """The export page and the download write the JSON document of a program with errors
    (issue 29 point 6), its problems in the report as warnings; G-code still refuses it."""
    from app.cnc import document

    golden = Path(__file__).parent / "golden" / "drill-single" / "program.json"
    program = document.loads(golden.read_text().replace('"feed_z": 5', '"feed_z": 300'))
    with app.app_context():
        program_id = get_library().create(program).id
    client = app.test_client()
    page = client.get(f"/programs/{program_id}/export?target=json&go=1")
    text = page.get_data(as_text=True)
    assert page.status_code == 200
    assert "warning: block 1: error, written as it is" in text
    assert "FEEDR Z: 300 ipm" in text
    download = client.get(f"/programs/{program_id}/export/download?target=json")
    assert download.status_code == 200
    assert document.loads(download.get_data(as_text=True)) == program
    refused = client.get(f"/programs/{program_id}/export/download?target=gcode-linuxcnc")
    assert refused.status_code == 422


def test_the_machine_chosen_for_export_decides_the_rpm(app: Flask, client: FlaskClient) -> None:
    """A tool at 9000 rpm: refused for LinuxCNC G-code with no machine (the control's 60 to
    4000 rpm), written for a LinuxCNC mill whose profile says its spindle runs 100-24000."""
    from app.web.machines import SERIAL_DEFAULTS

    csrf = token(client)
    assert client.post("/programs/2/db0", data=db0_form(csrf, 1, "9000")).status_code == 302
    machine = {**SERIAL_DEFAULTS, "csrf_token": csrf, "name": "Fast mill"}
    bad = client.post(
        "/machines", data={**machine, "target": "gcode-linuxcnc", "limits": "spindle=fast"}
    )
    assert bad.status_code == 422
    assert "Not saved: limits: spindle: &#39;fast&#39; is not a range of speeds" in bad.get_data(
        as_text=True
    )
    saved = client.post(
        "/machines", data={**machine, "target": "gcode-linuxcnc", "limits": "spindle=100-24000"}
    )
    assert saved.status_code == 302
    refused = client.get("/programs/2/export?target=gcode-linuxcnc&go=1")
    assert refused.status_code == 422
    assert (
        "tool 1 runs at 9000 rpm; the ProtoTRAK-style control&#39;s spindle runs 60 to 4000 rpm"
        in refused.get_data(as_text=True)
    )
    exported = client.get("/programs/2/export?machine=Fast+mill&target=gcode-linuxcnc&go=1")
    assert exported.status_code == 200
    assert "S9000 M3" in exported.get_data(as_text=True)


@pytest.mark.parametrize("limits", ["X=0 0.5", "x_travel=0 0.5", "x=0 10\nY=0 0.5"])
def test_a_travel_limit_under_an_unknown_key_is_refused_naming_it(
    app: Flask, client: FlaskClient, limits: str
) -> None:
    """`X=0 0.5` (or `x_travel=…`) was saved and never checked, while `x=0 0.5` refused the
    same program: a machine that let a program past its travel."""
    from app.cnc.machine import KEYS
    from app.web.machines import SERIAL_DEFAULTS

    csrf = token(client)
    machine = {**SERIAL_DEFAULTS, "csrf_token": csrf, "name": "Small mill"}
    bad = client.post("/machines", data={**machine, "target": "gcode-linuxcnc", "limits": limits})
    assert bad.status_code == 422
    key = [line.split("=")[0] for line in limits.splitlines() if line.split("=")[0] not in KEYS]
    page = html.unescape(bad.get_data(as_text=True))
    assert f"Not saved: limits: unknown key '{key[0]}'" in page
    assert f"allowed: {', '.join(KEYS)}" in page
    with app.app_context():
        assert get_library().machines() == []
    # The same travel under its own key refuses the sample part, which reaches X 3.
    saved = client.post(
        "/machines", data={**machine, "target": "gcode-linuxcnc", "limits": "x=0 0.5"}
    )
    assert saved.status_code == 302
    refused = client.get("/programs/1/export?machine=Small+mill&target=gcode-linuxcnc&go=1")
    assert refused.status_code == 422
    assert "X reaches" in refused.get_data(as_text=True)


def test_a_machine_stored_with_an_unknown_key_is_never_exported_as_unlimited(
    app: Flask, client: FlaskClient
) -> None:
    """A machine saved before the rule, with `X` for `x`: its exports are refused naming the
    key (they were made as if the machine had no limits at all)."""
    from sqlalchemy import update

    from app.storage.library import Machine
    from app.storage.models import MachineRow

    with app.app_context():
        library = get_library()
        library.save_machine(Machine("Old mill", "gcode-linuxcnc", {}, {}, "", {"x": "0 10"}))
        with library.session() as s:
            s.execute(update(MachineRow).values(limits='{"X": "0 0.5"}'))
    for url in (
        "/programs/1/export?machine=Old+mill&target=gcode-linuxcnc&go=1",
        "/programs/1/export/download?machine=Old+mill&target=gcode-linuxcnc",
        "/programs/1/setup?machine=Old+mill",
    ):
        response = client.get(url)
        assert response.status_code == 422, url
        assert "machine &#39;Old mill&#39;, limits: unknown key &#39;X&#39; (did you mean" in (
            response.get_data(as_text=True)
        )


def test_a_download_the_target_refuses_says_why(app: Flask, client: FlaskClient) -> None:
    """The audit of issue 31: a program of more events than the Plus numbers (1 203; its
    line numbers run to 999) was a 422 saying only "events cannot take this program". The
    page now gives the export's own reason, as the command line prints it."""
    from decimal import Decimal

    from app.cnc.blocks import Rep
    from tests.test_events import loop

    with app.app_context():
        program_id = (
            get_library().create(loop(Rep(x=Decimal(5), y=Decimal("0.15"), nx=1, ny=600))).id
        )
    refused = client.get(f"/programs/{program_id}/export/download?target=events")
    assert refused.status_code == 422
    assert (
        "events cannot take this program (program: 1203 events: line numbers run to 999 "
        "(seed 003 §2.2.4))"
    ) in html.unescape(refused.get_data(as_text=True))
