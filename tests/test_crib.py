"""The shop's tool crib (issue 34 points 1, 2 and 4): crib tools in the library on SQLite and
PostgreSQL, with revisions; Data Block 0 picks them by number or name and keeps its own
copy; the editor says where the crib's tool differs; the command line and the web page;
the TAP rule; the set-up sheet's type and length.
"""

from __future__ import annotations

import io
import json
import re
from collections.abc import Iterator
from dataclasses import replace
from datetime import datetime
from decimal import Decimal as D
from pathlib import Path
from zoneinfo import ZoneInfo

import pytest
from click.testing import CliRunner
from flask import Flask
from flask.testing import FlaskClient
from sqlalchemy import update

from app.cli import main
from app.cnc import document
from app.cnc.blocks import Coolant, Hole, Program, Tool
from app.cnc.crib import copy_of, differences, feed_offers, pick, tool_offer
from app.cnc.cutting import MaterialName, Workpiece
from app.cnc.problems import Rule
from app.cnc.setup import render_text, setup_sheet
from app.cnc.tools import CribTool, Hand, PitchUnit, ToolMaterial, ToolType
from app.cnc.units import Units
from app.cnc.validate import validate
from app.storage.crib import Crib, CribError
from app.storage.library import Library, NotFound, StaleSave, open_library
from app.storage.models import CribToolRow, ProgramRow
from app.web.extensions import get_library
from tests.web_support import PASSWORD, accounts_app, csrf, dispose, local_app, log_in

HERE = Path(__file__).parent
BAD = HERE / "bad"

TAP = CribTool(
    number=12,
    name="1/4-20 TAP",
    kind=ToolType.TAP,
    diameter=D("0.25"),
    flutes=4,
    length=D("1.375"),
    pitch=D(20),
    pitch_unit=PitchUnit.TPI,
)
END_MILL = CribTool(
    number=3,
    name="3/16 END MILL",
    kind=ToolType.END_MILL,
    diameter=D("0.1875"),
    flutes=3,
    material=ToolMaterial.CARBIDE,
    length=D("0.75"),
    tcal=D("2.5"),
)
DRILL = CribTool(number=7, name="#7 DRILL", kind=ToolType.DRILL, diameter=D("0.201"), flutes=2)
M6 = CribTool(
    number=60,
    name="M6X1 TAP",
    kind=ToolType.TAP,
    units=Units.MM,
    diameter=D(6),
    pitch=D(1),
    pitch_unit=PitchUnit.MM,
)


def tapped_part() -> Program:
    """Drill #7, then tap 1/4-20 (the bad corpus's program, its feed made right)."""
    program = document.loads((BAD / "tap-feed-not-the-pitch" / "program.json").read_text())
    tap = program.blocks[1]
    assert isinstance(tap, Hole)
    return replace(program, blocks=(program.blocks[0], replace(tap, feed_z=D(25))))


# -- the program's copy ------------------------------------------------------------------------


def test_a_pick_copies_the_crib_tool_rounded_to_the_program_and_keeps_the_rpm() -> None:
    before = Tool(number=3, diameter=D("0.25"), rpm=2500, coolant=Coolant.FLOOD, name="OLD")
    picked = pick(before, END_MILL, 3, Units.INCH, offered_rpm=4000)
    # 3/16 = 0.1875 in: DIA 0.188 at the program's 0.001 in, as an import rounds it.
    assert (picked.diameter, picked.name, picked.crib) == (D("0.188"), "3/16 END MILL", 3)
    assert (picked.kind, picked.flutes, picked.tool_material) == (
        ToolType.END_MILL,
        3,
        ToolMaterial.CARBIDE,
    )
    assert (picked.length, picked.tcal) == (D("0.750"), D("2.500"))
    # The RPM typed and the coolant stay: an offer never overwrites what was typed.
    assert (picked.rpm, picked.coolant) == (2500, Coolant.FLOOD)
    assert pick(None, END_MILL, 3, Units.INCH, offered_rpm=4000).rpm == 4000
    # Into a metric program: 0.1875 in = 4.7625 mm → 4.76.
    assert copy_of(END_MILL, 3, Units.MM).diameter == D("4.76")
    assert copy_of(M6, 5, Units.INCH).diameter == D("0.236")


def test_where_the_program_s_copy_differs_from_the_crib_is_said() -> None:
    copied = pick(None, TAP, 4, Units.INCH)
    assert differences(copied, TAP, Units.INCH) == []
    measured = replace(copied, diameter=D("0.249"), flutes=3)
    changed_in_crib = replace(TAP, pitch=D(28), name="1/4-28 TAP")
    assert differences(measured, TAP, Units.INCH) == [
        "DIA 0.249 here, 0.250 in the crib",
        "FLUTES 3 here, 4 in the crib",
    ]
    assert differences(copied, changed_in_crib, Units.INCH) == [
        "NAME 1/4-20 TAP here, 1/4-28 TAP in the crib",
        "PITCH 20 TPI here, 28 TPI in the crib",
    ]
    assert differences(copied, None, Units.INCH) == ["T12 is no longer in the crib"]
    # A program never changes because the crib did: the copy is the program's.
    assert copied.pitch == D(20)


def test_the_copy_and_the_material_round_trip_through_the_document() -> None:
    program = replace(
        tapped_part(),
        material=Workpiece(name=MaterialName.CUSTOM, surface_speed=D(350), chip_load=D("0.002")),
    )
    program = replace(
        program,
        block0=replace(
            program.block0,
            tools=(*program.block0.tools, replace(pick(None, M6, 5, Units.INCH), hand=Hand.LEFT)),
        ),
    )
    text = document.dumps(program)
    assert document.loads(text) == program
    data = json.loads(text)
    assert data["material"] == {"name": "custom", "surface_speed": 350, "chip_load": 0.002}
    assert list(data)[:7] == [
        "format",
        "version",
        "name",
        "part_number",
        "units",
        "notes",
        "material",
    ]
    m6 = data["data_block_0"]["tools"][-1]
    assert (m6["kind"], m6["pitch"], m6["pitch_unit"], m6["hand"]) == ("tap", 1, "mm", "left")
    # A tool without a copy writes as before: no new keys.
    plain = document.loads(document.dumps(replace(program, material=None)))
    assert "material" not in json.loads(document.dumps(plain))
    assert set(
        json.loads(
            document.dumps(
                Program(
                    name="x",
                    block0=replace(
                        program.block0, tools=(Tool(number=1, diameter=D("0.5"), rpm=1000),)
                    ),
                )
            )
        )["data_block_0"]["tools"][0]
    ) == {"number", "diameter", "rpm", "tcal", "coolant"}


def test_the_tap_rule_names_the_block_and_passes_the_right_feed() -> None:
    program = tapped_part()
    assert not [p for p in validate(program) if p.rule in (Rule.TAP_FEED, Rule.TAP_HAND)]
    tap = program.blocks[1]
    assert isinstance(tap, Hole)
    wrong = replace(program, blocks=(program.blocks[0], replace(tap, feed_z=D(24))))
    found = [p for p in validate(wrong) if p.rule is Rule.TAP_FEED]
    assert [str(p) for p in found] == [
        "block 2, FEEDR Z: 24 ipm does not match tool 2 (1/4-20 TAP): a tap feeds one pitch per "
        "turn, 500 rpm × 20 TPI = 25.0 ipm; change FEEDR Z to 25.0 or the tool's RPM"
    ]
    # A tool without a crib copy (no type, no pitch) is not checked: as before.
    bare = replace(
        wrong,
        block0=replace(
            wrong.block0,
            tools=tuple(
                Tool(number=t.number, diameter=t.diameter, rpm=t.rpm, tcal=t.tcal)
                for t in wrong.block0.tools
            ),
        ),
    )
    assert not [p for p in validate(bare) if p.rule is Rule.TAP_FEED]


def test_feeds_offered_follow_the_tool_s_own_rpm_and_the_entry_form_offers_them() -> None:
    program = replace(tapped_part(), material=Workpiece(name=MaterialName.STEEL_1018))
    offers = feed_offers(program)
    # The tap at its own 500 rpm: 25.0 ipm; the #7 drill at its 1500 rpm: 1500 × .003216 =
    # 4.824 → 4.8 ipm.
    assert offers.for_tool(2) == {"feed_z": "25.0"}
    assert offers.for_tool(1) == {"feed_z": "4.8"}
    offer = tool_offer(program, program.block0.tools[1])
    assert offer is not None and offer.rpm == 762  # offered, not the 500 it runs at


def test_the_set_up_sheet_lists_each_tool_s_name_type_and_length() -> None:
    sheet = setup_sheet(tapped_part())
    tap = next(t for t in sheet.tools if t.number == 2)
    assert (tap.name, tap.kind, tap.length) == ("1/4-20 TAP", "tap", "")
    program = tapped_part()
    tools = (program.block0.tools[0], replace(program.block0.tools[1], length=D("1.375")))
    with_length = replace(program, block0=replace(program.block0, tools=tools))
    text = render_text(setup_sheet(with_length))
    assert "      1/4-20 TAP (tap, 1.375 in out of the holder)" in text
    assert "      #7 DRILL (drill)" in text


# -- the crib in the library (SQLite and PostgreSQL) -----------------------------------------


@pytest.fixture
def library(database_url: str) -> Iterator[Library]:
    lib = open_library(database_url, seed_demo=False)
    yield lib
    lib.engine.dispose()


def test_crib_tools_keep_revisions_and_refuse_a_stale_save(library: Library) -> None:
    crib = Crib(library)
    stored = crib.create(TAP, "ana")
    saved = crib.save(stored.id, replace(TAP, flutes=3), 1, "ben")
    assert saved.version == 2 and saved.tool.flutes == 3
    assert [(r.version, r.author, r.summary) for r in crib.revisions(stored.id)] == [
        (1, "ana", "added: T12 1/4-20 TAP: tap, 0.25 in, HSS, 4 flutes, 20 TPI, 1.375 in out"),
        (2, "ben", "FLUTES 4 → 3"),
    ]
    with pytest.raises(StaleSave) as stale:
        crib.save(stored.id, replace(TAP, diameter=D("0.251")), 1, "cy")
    assert "ben saved crib tool T12" in str(stale.value)
    assert "Changed meanwhile: FLUTES 4 → 3" in str(stale.value)
    assert crib.get(stored.id).tool.diameter == D("0.25")
    back = crib.restore_revision(stored.id, 1, based_on=2, author="ana")
    assert back.version == 3 and back.tool == TAP


def test_a_stale_tool_save_reads_as_a_stale_program_save(database_url: str) -> None:
    """One rule for both: the refusal names who saved which version when, in the shop's time
    zone with its label (a crib tool's said "UTC" whatever the shop's zone was)."""
    lib = open_library(database_url, seed_demo=False, zone=ZoneInfo("America/Chicago"))
    try:
        noon = datetime(2024, 7, 1, 12, 0)
        crib = Crib(lib)
        tool = crib.create(TAP, "ana")
        crib.save(tool.id, replace(TAP, flutes=3), 1, "ben")
        program = lib.create(Program(name="bracket", units=Units.INCH), "ana")
        lib.save(program.id, Program(name="bracket 2", units=Units.INCH), 1, "ben")
        with lib.session() as s:
            s.execute(update(CribToolRow).values(updated_at=noon))
            s.execute(update(ProgramRow).values(updated_at=noon))
        with pytest.raises(StaleSave) as stale_tool:
            crib.save(tool.id, replace(TAP, flutes=2), 1, "cy")
        with pytest.raises(StaleSave) as stale_program:
            lib.save(program.id, Program(name="bracket 3", units=Units.INCH), 1, "cy")
        assert str(stale_tool.value).startswith(
            "not saved: ben saved crib tool T12 at 2024-07-01 07:00 CDT (version 2) after the "
            "version 1 you started from. Changed meanwhile: FLUTES 4 → 3. Reload it"
        )
        assert str(stale_program.value).startswith(
            f"not saved: ben saved program {program.id} at 2024-07-01 07:00 CDT (version 2) "
            "after the version 1 you started from. Changed meanwhile: "
        )
    finally:
        lib.engine.dispose()


def test_each_number_and_name_in_use_is_one_tool(library: Library) -> None:
    crib = Crib(library)
    first = crib.create(TAP)
    with pytest.raises(CribError, match="NUMBER: T12 is '1/4-20 TAP' in the crib already"):
        crib.create(replace(DRILL, number=12))
    with pytest.raises(CribError, match="NAME: '1/4-20 tap' is T12 in the crib already"):
        crib.create(replace(DRILL, name="1/4-20 tap"))
    # Retired, its number is free; put back, it would be two.
    crib.retire(first.id)
    second = crib.create(replace(DRILL, number=12))
    with pytest.raises(CribError, match="NUMBER: T12"):
        crib.reinstate(first.id)
    assert [s.tool.number for s in crib.tools(retired=True)] == [12]
    assert crib.find("T12").id == second.id
    assert crib.find("#7 drill").id == second.id
    with pytest.raises(NotFound, match="no tool 'T99' in the crib"):
        crib.find("T99")


def test_a_tool_that_cannot_be_kept_is_refused_naming_the_field(library: Library) -> None:
    crib = Crib(library)
    with pytest.raises(CribError) as refused:
        crib.create(replace(TAP, pitch=None, diameter=D("0.25001"), name="TAP (1/4)"))
    assert str(refused.value) == (
        "NAME: has characters a G-code comment cannot hold: '(' ')'; allowed up to 24 letters, "
        "digits, spaces and . , - : / # + = *; DIA: 0.25001 in has too many decimals; a crib "
        "tool's sizes go to 0.0001 in; PITCH: missing; a tap feeds one pitch per turn, so the crib "
        "needs it (threads per inch, 20 for a 1/4-20, or mm, 1 for an M6x1)"
    )
    assert crib.tools() == []


def test_a_tool_table_reads_in_whole_or_not_at_all(library: Library) -> None:
    crib = Crib(library)
    crib.create(TAP)
    table = "T12 P12 D0.2510 Z1.5 ;1/4-20 TAP\nT7 P7 D0.201 Z-0.4 ;#7 DRILL\n"
    done = crib.import_table(table, Units.INCH, "ana")
    assert (done.added, done.updated, done.unchanged) == ([7], [12], [])
    tap = crib.find("12").tool
    # The table's diameter and length; the crib's own flutes, pitch and length out stay.
    assert (tap.diameter, tap.tcal, tap.flutes, tap.pitch, tap.length) == (
        D("0.251"),
        D("1.5"),
        4,
        D(20),
        D("1.375"),
    )
    assert crib.import_table(table, Units.INCH).unchanged == [12, 7]  # in the table's order
    # A bad line: nothing read at all.
    with pytest.raises(CribError, match=r"line 2, column 10: D: '1\.2\.3' is not a number"):
        crib.import_table("T20 P20 D0.5 ;NEW\nT21 P21 D1.2.3\n", Units.INCH)
    with pytest.raises(CribError, match="T21: NAME: 'one' is T20"):
        crib.import_table("T20 P20 D0.5 ;ONE\nT21 P21 D0.5 ;one\n", Units.INCH)
    assert [s.tool.number for s in crib.tools()] == [7, 12]


# -- the command line -------------------------------------------------------------------------


def run(*args: str) -> tuple[int, str, str]:
    result = CliRunner().invoke(main, list(args))
    return result.exit_code, result.stdout, result.stderr


def test_the_command_line_keeps_the_crib_and_its_tool_table(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'crib.db'}")
    code, out, err = run(
        "tools",
        "add",
        "--number",
        "12",
        "--name",
        "1/4-20 TAP",
        "--type",
        "tap",
        "--diameter",
        "0.25",
        "--flutes",
        "4",
        "--pitch",
        "20",
        "--tcal",
        "1.5",
    )
    assert code == 0, err
    assert out == "added T12 1/4-20 TAP: tap, 0.25 in, HSS, 4 flutes, 20 TPI\n"
    code, _, err = run(
        "tools", "add", "--number", "13", "--name", "X", "--type", "tap", "--diameter", "0.25"
    )
    assert code == 1 and "PITCH: missing" in err
    code, out, _ = run("tools", "edit", "T12", "--flutes", "3", "--author", "ana")
    assert out == "saved v2: T12 1/4-20 TAP: tap, 0.25 in, HSS, 3 flutes, 20 TPI\n"
    table = tmp_path / "machine.tbl"
    table.write_text("T7 P3 D0.201 Z-0.4 ;#7 DRILL\n")
    code, out, _ = run("tools", "import", str(table))
    assert out.splitlines() == [
        "1 tools added, 0 updated, 0 unchanged",
        "line 1, T7: pocket P3 is not kept (written as P = T)",
    ]
    code, out, _ = run("tools", "list")
    assert out.splitlines() == [
        "T7 #7 DRILL: drill, 0.201 in, HSS  v1",
        "T12 1/4-20 TAP: tap, 0.25 in, HSS, 3 flutes, 20 TPI  v2",
    ]
    code, out, _ = run("tools", "table")
    assert out == "T7 P7 D0.2010 Z-0.4000 ;#7 DRILL\nT12 P12 D0.2500 Z1.5000 ;1/4-20 TAP\n"
    code, out, _ = run("tools", "show", "1/4-20 tap")
    assert "v2" in out and "FLUTES 4 → 3" in out
    code, _, err = run("tools", "show", "T99")
    assert code == 2 and "no tool 'T99' in the crib" in err


def test_speeds_prints_the_figures_the_editor_offers() -> None:
    code, out, _ = run(
        "speeds",
        "--material",
        "6061",
        "--diameter",
        "0.5",
        "--flutes",
        "3",
        "--tool-material",
        "carbide",
    )
    assert code == 0
    assert out.splitlines()[-1] == "offered: 4000 rpm, high gear · FEEDR XY 48.0 ipm"
    assert (
        "  RPM 4000: the table's 4583 rpm is above the ProtoTRAK-style control's top speed" in out
    )
    code, out, _ = run(
        "speeds", "--material", "1018", "--diameter", "0.25", "--tap-pitch", "20", "--rpm", "500"
    )
    assert out.splitlines()[-1] == "offered: 762 rpm, high gear · at 500 rpm: FEEDR Z 25.0 ipm"
    code, out, _ = run(
        "speeds",
        "--material",
        "1018",
        "--diameter",
        "6",
        "--units",
        "mm",
        "--tap-pitch",
        "1",
        "--rpm",
        "500",
    )
    assert out.splitlines()[-1].endswith("at 500 rpm: FEEDR Z 500 mm/min")
    code, _, err = run("speeds", "--material", "custom", "--diameter", "0.5")
    assert code == 2 and "a custom material needs its surface speed (sfm)" in err


def test_speeds_keeps_to_a_library_machine_s_spindle(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'm.db'}")
    from app.storage.library import Machine

    lib = open_library(seed_demo=False)
    lib.save_machine(Machine("VMC", "gcode-linuxcnc", {}, {}, limits={"spindle": "100-24000"}))
    lib.engine.dispose()
    code, out, _ = run(
        "speeds",
        "--material",
        "6061",
        "--diameter",
        "0.5",
        "--flutes",
        "3",
        "--tool-material",
        "carbide",
        "--machine",
        "VMC",
    )
    assert code == 0
    assert out.splitlines()[-1] == "offered: 4583 rpm · FEEDR XY 54.9 ipm"
    assert "VMC's spindle (100-24000 rpm)" in out.splitlines()[0]


# -- the web page and Data Block 0 ------------------------------------------------------------

FORM = {
    "number": "12",
    "name": "1/4-20 TAP",
    "kind": "tap",
    "units": "inch",
    "diameter": "0.25",
    "flutes": "4",
    "material": "hss",
    "length": "1.375",
    "tcal": "",
    "pitch": "20",
    "pitch_unit": "tpi",
    "hand": "right",
    "notes": "",
}


@pytest.fixture
def app(tmp_path: Path) -> Iterator[Flask]:
    made = local_app(tmp_path)
    yield made
    dispose(made)


def add(client: FlaskClient, **changes: str) -> str:
    token = csrf(client, "/tools")
    return client.post("/tools", data={"csrf_token": token, **FORM, **changes}).location or ""


def test_the_crib_page_adds_edits_and_refuses_naming_the_field(app: Flask) -> None:
    client = app.test_client()
    assert client.get("/tools").status_code == 200
    location = add(client)
    assert location.startswith("/tools/")
    token = csrf(client, "/tools")
    refused = client.post(
        "/tools", data={"csrf_token": token, **FORM, "number": "13", "diameter": "¼"}
    )
    assert refused.status_code == 422
    assert "DIA: &#39;¼&#39; is not a number" in refused.get_data(as_text=True)
    page = client.get(location).get_data(as_text=True)
    assert "T12 1/4-20 TAP" in page and "added: T12" in page
    saved = client.post(location, data={"csrf_token": token, "version": "1", **FORM, "flutes": "3"})
    assert saved.status_code == 302
    stale = client.post(location, data={"csrf_token": token, "version": "1", **FORM})
    assert stale.status_code == 409 and "local saved crib tool T12" in stale.get_data(as_text=True)
    # Without the CSRF token nothing is saved.
    assert client.post("/tools", data={**FORM, "number": "14", "name": "X"}).status_code == 400
    with app.app_context():
        assert [s.tool.number for s in Crib(get_library()).tools()] == [12]
    listing = client.get("/tools.json").get_json()
    assert [(t["number"], t["name"], t["flutes"], t["version"]) for t in listing["tools"]] == [
        (12, "1/4-20 TAP", 3, 2)
    ]
    assert client.get("/tools/table.tbl").get_data(as_text=True) == "T12 P12 D0.2500 ;1/4-20 TAP\n"


def test_operators_see_the_crib_and_programmers_edit_it(tmp_path: Path) -> None:
    app = accounts_app(tmp_path)
    try:
        ana, otto = app.test_client(), app.test_client()
        log_in(ana, "ana")
        log_in(otto, "otto")
        assert add(ana).startswith("/tools/")
        page = otto.get("/tools").get_data(as_text=True)
        assert "1/4-20 TAP" in page and "Add to the crib" not in page
        token = csrf(otto, "/tools")
        refused = otto.post(
            "/tools", data={"csrf_token": token, **FORM, "number": "20", "name": "OTTO"}
        )
        assert refused.status_code == 403
        tool_page = otto.get("/tools/1").get_data(as_text=True)
        assert "Save tool" not in tool_page and "disabled" in tool_page
        assert otto.get("/tools/table.tbl").status_code == 200
    finally:
        dispose(app)


def demo_program(app: Flask) -> int:
    with app.app_context():
        library = get_library()
        info = library.create(tapped_part())
        return info.id


def db0_form(client: FlaskClient, program_id: int) -> dict[str, str]:
    """The Data Block 0 form's fields as the page gives them."""
    page = client.get(f"/programs/{program_id}/db0").get_data(as_text=True)
    form = page[
        page.index('class="db0-form"') : page.index("</form>", page.index('class="db0-form"'))
    ]
    fields = dict(re.findall(r'name="([^"]+)"[^>]*value="([^"]*)"', form))
    for name, value in re.findall(
        r'<select name="([^"]+)"[^>]*>.*?<option selected>([^<]*)<', form, re.S
    ):
        fields[name] = value
    fields["milling"] = "climb"
    return fields


def test_data_block_0_picks_a_crib_tool_by_number_or_name_without_script(app: Flask) -> None:
    client = app.test_client()
    add(client)
    add(
        client,
        number="7",
        name="#7 DRILL",
        kind="drill",
        diameter="0.201",
        flutes="2",
        pitch="",
        length="",
    )
    program_id = demo_program(app)
    form = db0_form(client, program_id)
    # Tool 5 by number, tool 6 by name (any case): the row takes the crib's DIA and name.
    form |= {"crib_5": "T12", "crib_6": "#7 drill"}
    saved = client.post(f"/programs/{program_id}/db0", data=form)
    assert saved.status_code == 302, saved.get_data(as_text=True)
    with app.app_context():
        tools = get_library().get(program_id).program.block0
    five, six = tools.tool(5), tools.tool(6)
    assert five is not None and six is not None
    assert (five.crib, five.diameter, five.name, five.kind, five.pitch, five.length) == (
        12,
        D("0.25"),
        "1/4-20 TAP",
        ToolType.TAP,
        D(20),
        D("1.375"),
    )
    assert (six.crib, six.diameter, six.name) == (7, D("0.201"), "#7 DRILL")
    # A name that is not in the crib is refused naming the tool; nothing is saved.
    form = db0_form(client, program_id) | {"crib_8": "1/2 END MILL"}
    refused = client.post(f"/programs/{program_id}/db0", data=form)
    assert refused.status_code == 422
    assert "TOOL 8 CRIB: no tool &#39;1/2 END MILL&#39; in the crib" in refused.get_data(
        as_text=True
    )


def row_of(page: str, number: int) -> str:
    start = page.index(f'id="tool-{number}"')
    return page[start : page.index("</tbody>", start)]


def test_the_crib_s_changes_never_reach_the_program_but_are_shown(app: Flask) -> None:
    client = app.test_client()
    location = add(client)
    program_id = demo_program(app)
    client.post(f"/programs/{program_id}/db0", data=db0_form(client, program_id) | {"crib_4": "12"})
    token = csrf(client, "/tools")
    client.post(location, data={"csrf_token": token, "version": "1", **FORM, "diameter": "0.251"})
    with app.app_context():
        assert get_library().get(program_id).program.block0.tool(4).diameter == D("0.25")  # type: ignore[union-attr]
    page = client.get(f"/programs/{program_id}/db0").get_data(as_text=True)
    assert "Differs from the crib's T12: DIA 0.25 here, 0.251 in the crib" in page
    editor = client.get(f"/programs/{program_id}").get_data(as_text=True)
    assert "tool 4 (T12 1/4-20 TAP): DIA 0.25 here, 0.251 in the crib" in editor
    # "Take the crib's" picks it again.
    client.post(f"/programs/{program_id}/db0", data=db0_form(client, program_id) | {"repick": "4"})
    with app.app_context():
        assert get_library().get(program_id).program.block0.tool(4).diameter == D("0.251")  # type: ignore[union-attr]
    page = client.get(f"/programs/{program_id}/db0").get_data(as_text=True)
    assert "Differs from the crib" not in row_of(page, 4)
    # Tool 1 was picked from T7, which this crib never had: said, not refused.
    assert "T7 is no longer in the crib: the program keeps its copy" in row_of(page, 1)
    # Retired from the crib: Data Block 0 still saves, and says so.
    with app.app_context():
        Crib(get_library()).retire(1)
    assert (
        client.post(f"/programs/{program_id}/db0", data=db0_form(client, program_id)).status_code
        == 302
    )
    page = client.get(f"/programs/{program_id}/db0").get_data(as_text=True)
    assert "T12 is no longer in the crib" in row_of(page, 4)


def test_the_row_picked_offers_its_rpm_and_keeps_a_typed_one(app: Flask) -> None:
    client = app.test_client()
    add(client)
    program_id = demo_program(app)
    token = csrf(client, f"/programs/{program_id}/db0")
    with app.app_context():
        version = get_library().get(program_id).info.version
    program = tapped_part()
    client.post(
        f"/programs/{program_id}/header",
        data={
            "csrf_token": token,
            "version": str(version),
            "name": program.name,
            "part_number": "",
            "units": "inch",
            "notes": "",
            "material": "1018",
        },
    )
    headers = {"HX-Request": "true"}
    row = client.get(f"/programs/{program_id}/db0/tool/9?crib_9=12", headers=headers)
    text = row.get_data(as_text=True)
    assert 'name="rpm_9" value="762"' in text and 'name="dia_9" value="0.250"' in text
    assert "Offered: 762 rpm, high gear · FEEDR Z 38.1 ipm" in text
    typed = client.get(f"/programs/{program_id}/db0/tool/9?crib_9=12&rpm_9=500", headers=headers)
    assert 'name="rpm_9" value="500"' in typed.get_data(as_text=True)
    assert "at 500 rpm: FEEDR Z 25.0 ipm" in typed.get_data(as_text=True)


def test_the_entry_form_offers_the_tool_s_feed_where_nothing_else_does(app: Flask) -> None:
    client = app.test_client()
    program = replace(tapped_part(), material=Workpiece(name=MaterialName.STEEL_1018))
    with app.app_context():
        program_id = get_library().create(program).id
    page = client.get(
        f"/programs/{program_id}/entry?kind=TAP", headers={"HX-Request": "true"}
    ).get_data(as_text=True)
    assert 'name="feed_z" value="25.0"' in page or re.search(
        r'id="f-feed_z" name="feed_z" value="([^"]*)"', page
    )
    value = re.search(r'name="feed_z" value="([^"]*)"', page)
    assert value and value.group(1) in ("25.0", "4.8")
    assert "data-feed-offers='{" in page
    offers = json.loads(re.search(r"data-feed-offers='([^']*)'", page).group(1))  # type: ignore[union-attr]
    assert offers == {"1": {"feed_z": "4.8"}, "2": {"feed_z": "25.0"}}


def test_the_set_up_sheet_and_the_program_s_tool_table(app: Flask) -> None:
    client = app.test_client()
    add(client)
    program_id = demo_program(app)
    client.post(f"/programs/{program_id}/db0", data=db0_form(client, program_id) | {"crib_2": "12"})
    sheet = client.get(f"/programs/{program_id}/setup").get_data(as_text=True)
    assert '<td class="tool-kind">tap</td><td class="tool-length">1.375 in</td>' in sheet
    table = client.get(f"/programs/{program_id}/tools.tbl").get_data(as_text=True)
    assert table.splitlines() == [
        "T1 P1 D0.2010 Z0.0000 ;#7 DRILL",
        "T2 P2 D0.2500 Z0.5000 ;1/4-20 TAP",
    ]


def test_reading_a_tool_table_on_the_page(app: Flask) -> None:
    client = app.test_client()
    token = csrf(client, "/tools")
    done = client.post(
        "/tools/table",
        data={
            "csrf_token": token,
            "units": "inch",
            "file": (io.BytesIO(b"T7 P3 D0.201 Z-0.4 ;#7 DRILL\n"), "mill.tbl"),
        },
        content_type="multipart/form-data",
    )
    text = done.get_data(as_text=True)
    assert done.status_code == 200 and "1 tools added" in text
    assert "line 1, T7: pocket P3 is not kept (written as P = T)" in text
    bad = client.post(
        "/tools/table",
        data={
            "csrf_token": token,
            "units": "inch",
            "file": (io.BytesIO(b"T8 P8 D0.2 Q\n"), "bad.tbl"),
        },
        content_type="multipart/form-data",
    )
    assert bad.status_code == 422 and "line 1, column 12" in bad.get_data(as_text=True)


__all__ = ["PASSWORD"]


def test_a_backup_carries_the_crib_with_its_revisions(library: Library, tmp_path: Path) -> None:
    crib = Crib(library)
    tap = crib.create(TAP, "ana")
    crib.save(tap.id, replace(TAP, flutes=3), 1, "ben")
    drill = crib.create(DRILL)
    crib.retire(drill.id)
    archive = io.BytesIO()
    library.backup(archive)
    fresh = open_library(f"sqlite:///{tmp_path / 'fresh.db'}", seed_demo=False)
    try:
        fresh.restore_backup(io.BytesIO(archive.getvalue()))
        restored = Crib(fresh)
        assert [(s.tool.number, s.version) for s in restored.tools()] == [(12, 2)]
        assert [s.tool.number for s in restored.tools(retired=True)] == [7]
        again = restored.find("T12")
        assert [r.summary for r in restored.revisions(again.id)][1] == "FLUTES 4 → 3"
    finally:
        fresh.engine.dispose()
    # Into the library it came from: its numbers are in use, so the copies come in retired.
    library.restore_backup(io.BytesIO(archive.getvalue()))
    assert [s.tool.number for s in crib.tools()] == [12]
    assert sorted(s.tool.number for s in crib.tools(retired=True)) == [7, 7, 12]


def test_a_backup_with_a_tool_the_crib_cannot_keep_restores_nothing(
    library: Library, tmp_path: Path
) -> None:
    import zipfile

    crib = Crib(library)
    crib.create(TAP)
    archive = io.BytesIO()
    library.backup(archive)
    broken = io.BytesIO()
    with (
        zipfile.ZipFile(io.BytesIO(archive.getvalue())) as source,
        zipfile.ZipFile(broken, "w") as out,
    ):
        for item in source.infolist():
            data = source.read(item)
            if item.filename.startswith("tools/"):
                data = data.replace(b'"pitch": 20', b'"pitch": null')
            out.writestr(item, data)
    fresh = open_library(f"sqlite:///{tmp_path / 'fresh.db'}", seed_demo=False)
    try:
        from app.storage.backup import BackupError

        with pytest.raises(BackupError, match=r"tool 1, revision 1 \(tools/1/1\.json\), PITCH"):
            fresh.restore_backup(io.BytesIO(broken.getvalue()))
        assert Crib(fresh).tools() == [] and fresh.programs() == []
    finally:
        fresh.engine.dispose()


def test_odd_values_in_a_program_or_a_query_never_crash_the_pages(app: Flask) -> None:
    """A document read from a file may hold a tap of pitch 0 (validation's error); a query
    may hold anything: the pages answer, naming what is wrong."""
    client = app.test_client()
    program = tapped_part()
    zero = replace(program.block0.tools[1], pitch=D(0))
    odd = replace(
        program,
        block0=replace(program.block0, tools=(program.block0.tools[0], zero)),
        material=Workpiece(name=MaterialName.STEEL_1018),
    )
    with app.app_context():
        program_id = get_library().create(odd).id
    assert client.get(f"/programs/{program_id}/db0").status_code == 200
    assert client.get(f"/programs/{program_id}?kind=TAP").status_code == 200
    headers = {"HX-Request": "true"}
    for query in ("crib_3=" + "9" * 5000, "crib_3=T٣", "dia_3=1e999&crib_3=x", "rpm_3=--5"):
        answer = client.get(f"/programs/{program_id}/db0/tool/3?{query}", headers=headers)
        assert answer.status_code == 200, query
