"""From a drawing to blocks: the choosing page (issue 22).

The machinist uploads a DXF, clicks contours and holes in the order to cut them, picks each
contour's start, direction and tool side, sees the blocks and the report, and adds them to
a new program or into one. What a user would notice if it were wrong:

- the blocks are the ones chosen, in the order chosen, starting where chosen, with the
  tool on the side chosen; holes chosen in order become a BOLT CIR when they are one;
- everything of the drawing that did not become blocks is in the report (not chosen,
  not readable), never silently dropped;
- blocks go into a program only where they cut what they say: not inside a mill sequence,
  not between a BOLT CIR and its centre, not in front of an incremental block (it would
  move); a refused add, or a stale one, leaves the stored program as it was;
- bad fields name the field and what is allowed; a drawing that is gone is a 404.

The browser test (Playwright, Debian's Chromium) drives the page as a stranger would, by
clicking the drawing.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import replace
from decimal import Decimal
from pathlib import Path

import pytest
from flask import Flask
from flask.testing import FlaskClient

from app.cnc.blocks import BoltCircle, Comp, Hole, HoleOp, Mode, Pos, Program, Tool
from app.cnc.formats.dxf.choice import (
    ChoiceError,
    ContourChoice,
    HoleChoice,
    PlacementError,
    PocketChoice,
    chosen_blocks,
    insert_blocks,
)
from app.cnc.formats.dxf.reader import Drawing, parse_options, read_drawing
from app.cnc.problems import Severity
from app.cnc.validate import validate
from app.web.extensions import get_library
from tests.hostile_corpus import HOSTILE_NUMBERS, UPLOADS
from tests.test_import_dxf import bracket, bulge_part
from tests.test_pocket_block import measure
from tests.web_support import csrf, dispose, local_app


def _bracket() -> Drawing:
    return read_drawing(bracket(), "bracket", parse_options({"hole-diameter": "0.25"}))


# The page's depths, feeds and tool as its fields offer them (inch).
CUTTING = {
    "z_up": "0.100",
    "z_dn": "-0.100",
    "feed_z": "5.0",
    "feed_xy": "10.0",
    "tool": "1",
    "tool_dia": "0.250",
}


def _profile(drawing: Drawing) -> int:
    """The bracket's outside profile: the contour of 8 segments."""
    return next(k for k, c in enumerate(drawing.contours) if len(c.segments) == 8)


# -- the core: choices → blocks ------------------------------------------------------------


def test_chosen_contour_starts_where_chosen_and_runs_the_way_chosen() -> None:
    drawing = _bracket()
    k = _profile(drawing)
    chosen = chosen_blocks(drawing, [ContourChoice(k, start=2, direction="cw", comp=Comp.RIGHT)])
    first = chosen.blocks[0]
    assert isinstance(first, Hole) and first.comp is Comp.RIGHT
    # Segment 3 of the profile (as drawn, counter-clockwise) starts at (6, 0.5); clockwise
    # from the same point the cut goes down the right side first.
    assert (first.x, first.y) == (Decimal("6.000"), Decimal("0.500"))
    assert chosen.blocks[1].title == "MILL QCIR C"
    assert all(b.mode is Mode.ABS for b in chosen.blocks if hasattr(b, "x"))


def test_holes_chosen_in_order_become_a_bolt_circle_and_the_rest_is_reported() -> None:
    drawing = _bracket()
    small = [k for k, h in enumerate(drawing.holes) if h.diameter < 5_100_000]
    assert len(small) == 6
    chosen = chosen_blocks(drawing, [HoleChoice(tuple(small), tool=3)])
    assert [b.title for b in chosen.blocks] == ["DRILL", "BOLT CIR DRILL"]
    bolt = chosen.blocks[1]
    assert isinstance(bolt, BoltCircle) and bolt.holes == 6
    assert [t.number for t in chosen.block0.tools] == [3]
    text = "\n".join(f"{n.where}: {n.kind.value}: {n.message}" for n in chosen.report)
    # Nothing the drawing held is dropped silently: the other holes and contours, and what
    # the reader could not take (a TEXT, a SPLINE, a 3D line).
    assert "a hole not chosen: no blocks" in text
    assert "a contour not chosen: no blocks" in text
    assert "a TEXT is not read" in text and "a SPLINE is not read" in text
    # Without bolt circles, six DRILL blocks in the order chosen.
    plain = chosen_blocks(drawing, [HoleChoice(tuple(small), bolt_circles=False)])
    assert [b.title for b in plain.blocks] == ["DRILL"] * 6


def test_choices_that_name_nothing_are_refused_naming_why() -> None:
    drawing = _bracket()
    cases: list[tuple[list[ContourChoice | HoleChoice], str]] = [
        ([ContourChoice(99)], "contour 100: the drawing has 3 contours"),
        ([ContourChoice(0, start=5)], "segment 6: the contour has 1 segments"),
        ([ContourChoice(0, direction="up")], "direction 'up'; allowed drawn, cw, ccw"),
        ([HoleChoice((0, 0))], "hole 1 is chosen twice"),
        ([HoleChoice((40,))], "hole 41: the drawing has 10 holes"),
        ([ContourChoice(0, tool=25)], "tool 25: allowed 1 to 24"),
    ]
    for choices, message in cases:
        with pytest.raises(ChoiceError) as refused:
            chosen_blocks(drawing, choices)
        assert message in str(refused.value)


def _bore_and_slot(drawing: Drawing) -> tuple[int, int]:
    """The bracket's bore (a circle: one segment) and slot (two lines, two arcs)."""
    bore = next(k for k, c in enumerate(drawing.contours) if len(c.segments) == 1)
    slot = next(k for k, c in enumerate(drawing.contours) if len(c.segments) == 4)
    return bore, slot


def test_a_pocket_chosen_from_a_drawing_clears_round_its_islands() -> None:
    """The profile chosen as a POCKET with the bore and the slot as islands: DRILL at the
    start, POCKET, the profile's PKT blocks, then each ISLAND with its own; the pocket,
    given depths and a tool, cuts nothing of the bore or the slot (measured with shapely)."""
    drawing = _bracket()
    profile = _profile(drawing)
    bore, slot = _bore_and_slot(drawing)
    chosen = chosen_blocks(drawing, [PocketChoice(profile, (bore, slot), start=0, tool=2)])
    titles = [b.title for b in chosen.blocks]
    assert titles[:2] == ["DRILL", "POCKET"]
    assert titles.count("ISLAND") == 2
    assert titles.count("PKT LINE") == 5 + 2  # the profile's lines and the slot's
    assert titles.count("PKT ARC XY-END") == 3 + 2 + 2  # corners, the bore's halves, the slot
    text = "\n".join(f"{n.where}: {n.kind.value}: {n.message}" for n in chosen.report)
    assert "POCKET" in text and "a contour not chosen" not in text
    program = chosen.program("bracket", drawing.units)
    tools = (Tool(number=2, diameter=Decimal("0.25"), rpm=1500, tcal=Decimal(0)),)
    first = program.blocks[0]
    assert isinstance(first, Hole)
    drill = replace(first, z_up=Decimal("0.1"), z_dn=Decimal("-0.2"), feed_z=Decimal(5))
    ready = replace(
        program,
        block0=replace(program.block0, tools=tools, current_tool=2),
        blocks=(drill, *program.blocks[1:]),
    )
    assert [str(p) for p in validate(ready) if p.severity is Severity.ERROR] == []
    for uncut, gouge in measure(ready):
        assert uncut < 1e4 and gouge < 1e4


def test_pocket_choices_that_cannot_be_are_refused_naming_why() -> None:
    drawing = _bracket()
    profile = _profile(drawing)
    bore, slot = _bore_and_slot(drawing)
    cases = [
        (PocketChoice(slot, (profile,)), f"contour {profile + 1} is not inside contour {slot + 1}"),
        (PocketChoice(profile, (profile,)), f"contour {profile + 1} is chosen twice"),
        (PocketChoice(profile, (bore, bore)), f"contour {bore + 1} is chosen twice"),
        (PocketChoice(profile, (), tool=0), "tool 0: allowed 1 to 24"),
    ]
    for choice, message in cases:
        with pytest.raises(ChoiceError) as refused:
            chosen_blocks(drawing, [choice])
        assert message in str(refused.value)


def _host() -> Program:
    """A program with a POS, a mill sequence (blocks 2-4), a DRILL + BOLT CIR (5-6) and an
    incremental POS (7)."""
    drawing = read_drawing(bulge_part(), "part", parse_options({}))
    window = next(k for k, c in enumerate(drawing.contours) if len(c.segments) == 4)
    part = chosen_blocks(drawing, [ContourChoice(window)])
    pos = Pos(x=Decimal(0), y=Decimal(0), tool=1)
    drill = Hole(op=HoleOp.DRILL, x=Decimal(1), y=Decimal(1), tool=1)
    bolt = BoltCircle(op=HoleOp.DRILL, holes=4, angle=Decimal(0), radius=Decimal("0.5"))
    step = Pos(x=Decimal("0.5"), y=Decimal(0), tool=1, mode=Mode.INC)
    return Program(
        name="host",
        units=drawing.units,
        block0=part.block0,
        blocks=(pos, *part.blocks, drill, bolt, step),
    )


def test_blocks_go_in_only_where_they_cut_what_they_say() -> None:
    host = _host()
    drill = [b.title for b in host.blocks].index("DRILL") + 1  # the BOLT CIR's centre
    chosen = chosen_blocks(_bracket(), [ContourChoice(0, tool=2)])
    refusals = {
        2: f"inside the mill sequence of blocks 2-{drill - 1}; insert before block 2 or after",
        drill: f"block {drill + 1} is a BOLT CIR whose centre is block {drill}",
        drill + 1: f"block {drill + 2} is incremental (INC) and would start from the new blocks'",
    }
    for after, message in refusals.items():
        with pytest.raises(PlacementError) as refused:
            insert_blocks(host, chosen, after)
        assert message in str(refused.value), after
    placed, changes = insert_blocks(host, chosen, 1)
    assert placed.blocks[1:3] == chosen.blocks
    assert placed.blocks[3:] == host.blocks[1:]
    # Tool 2 was not in Data Block 0: it is added, and the user is told.
    assert 2 in {t.number for t in placed.block0.tools}
    assert changes == ["tool 2 added to Data Block 0: enter its diameter and RPM"]


def test_blocks_in_other_units_than_the_program_are_refused() -> None:
    host = _host()
    metric = read_drawing(
        bracket(), "b", parse_options({"hole-diameter": "0.25", "units": "metric"})
    )
    chosen = chosen_blocks(metric, [ContourChoice(0)])
    with pytest.raises(PlacementError, match="the blocks are in mm and the program in in"):
        insert_blocks(host, chosen, 0)


# -- the web page --------------------------------------------------------------------------


@pytest.fixture
def app(tmp_path: Path) -> Iterator[Flask]:
    app = local_app(tmp_path)
    yield app
    dispose(app)


def _upload(client: FlaskClient, data: bytes, **fields: str) -> str:
    """Upload a drawing from the library page; the choosing page's address."""
    import io

    token = csrf(client)
    answer = client.post(
        "/drawings",
        data={"csrf_token": token, "file": (io.BytesIO(data), "bracket.dxf"), **fields},
        content_type="multipart/form-data",
    )
    assert answer.status_code == 302, answer.get_data(as_text=True)
    return answer.headers["Location"]


def _key(location: str) -> str:
    found = re.search(r"/drawings/([0-9a-f]{64})", location)
    assert found
    return found.group(1)


def test_upload_choose_preview_and_add_to_a_new_program(app: Flask) -> None:
    client = app.test_client()
    location = _upload(client, bracket(), **{"hole-diameter": "0.25"})
    page = client.get(location).get_data(as_text=True)
    assert 'data-contour="0"' in page and 'data-hole="9"' in page
    token = csrf(client, location)
    key = _key(location)
    drawing = _bracket()
    profile = _profile(drawing)
    form = {
        "csrf_token": token,
        "hole-diameter": "0.25",
        **CUTTING,
        f"c{profile}_order": "2",
        f"c{profile}_start": "3",
        f"c{profile}_dir": "cw",
        f"c{profile}_comp": "right",
        "h0_order": "1",
        "holes_tool": "1",
    }
    shown = client.post(f"/drawings/{key}/preview", data=form)
    text = shown.get_data(as_text=True)
    assert shown.status_code == 200
    assert "10 blocks" in text and "DRILL CUT RT" in text and "a hole not chosen" in text
    added = client.post(f"/drawings/{key}/add", data={**form, "target": "new", "name": "From DXF"})
    assert added.status_code == 302
    program_id = int(re.search(r"/programs/(\d+)", added.headers["Location"]).group(1))  # type: ignore[union-attr]
    with app.app_context():
        stored = get_library().get(program_id)
    assert stored.program.name == "From DXF"
    titles = [b.title for b in stored.program.blocks]
    assert titles[0] == "DRILL" and titles[1] == "DRILL CUT RT" and len(titles) == 10
    # Validation asks only for what was left blank (the tool's RPM): the depths, feeds and
    # diameter were entered, and the geometry chosen is sound.
    rules = {p.rule.name for p in validate(stored.program)}
    assert rules == {"TOOL_NO_RPM"}


def test_the_page_makes_a_pocket_of_a_contour_and_islands_of_those_inside_it(app: Flask) -> None:
    """Pocket "POCKET" on the profile (with its order) and "island" on the bore and the
    slot: the blocks shown are DRILL, POCKET, ..., two ISLANDs; an island given an order, or
    one no pocket holds, is refused naming the contour and what to do."""
    client = app.test_client()
    location = _upload(client, bracket(), **{"hole-diameter": "0.25"})
    token = csrf(client, location)
    key = _key(location)
    drawing = _bracket()
    profile = _profile(drawing)
    bore, slot = _bore_and_slot(drawing)
    form = {
        "csrf_token": token,
        "hole-diameter": "0.25",
        **CUTTING,
        f"c{profile}_order": "1",
        f"c{profile}_pocket": "pocket",
        f"c{bore}_pocket": "island",
        f"c{slot}_pocket": "island",
    }
    shown = client.post(f"/drawings/{key}/preview", data=form)
    text = shown.get_data(as_text=True)
    assert shown.status_code == 200, text
    assert "25 blocks" in text and text.count("<strong>ISLAND</strong>") == 2
    ordered = client.post(f"/drawings/{key}/preview", data={**form, f"c{bore}_order": "2"})
    assert ordered.status_code == 422
    assert f"contour {bore + 1} is an island: it has no order of its own" in ordered.get_data(
        as_text=True
    )
    alone = {**form, f"c{profile}_pocket": ""}
    orphan = client.post(f"/drawings/{key}/preview", data=alone)
    assert orphan.status_code == 422
    assert "is an island, but no contour chosen as a POCKET holds it" in orphan.get_data(
        as_text=True
    )


def test_add_into_a_program_refused_where_it_would_split_it_leaves_it_as_it_was(
    app: Flask,
) -> None:
    client = app.test_client()
    with app.app_context():
        info = get_library().create(_host())
    location = _upload(client, bracket(), **{"hole-diameter": "0.25"})
    key = _key(location)
    token = csrf(client, location)
    form = {
        "csrf_token": token,
        "hole-diameter": "0.25",
        **CUTTING,
        "c0_order": "1",
        "target": "existing",
        "program": str(info.id),
        "after": "2",
    }
    refused = client.post(f"/drawings/{key}/add", data=form)
    assert refused.status_code == 422
    assert "Not added: after block 2: that is inside the mill sequence" in refused.get_data(
        as_text=True
    )
    with app.app_context():
        assert get_library().get(info.id).info.version == info.version
    # A stale page (someone saved meanwhile) is refused too, nothing written.
    stale = client.post(f"/drawings/{key}/add", data={**form, "after": "1", "version": "0"})
    assert stale.status_code == 422
    with app.app_context():
        assert get_library().get(info.id).info.version == info.version
    done = client.post(f"/drawings/{key}/add", data={**form, "after": "1"})
    assert done.status_code == 302
    with app.app_context():
        after = get_library().get(info.id)
    assert after.info.version == info.version + 1
    # The bore (contour 1) is a circle: a CIRCLE routine cuts it exactly, from inside (it
    # lies inside the profile: the rule `millblocks import` follows).
    assert [b.title for b in after.program.blocks[1:3]] == ["DRILL", "CIRCLE INSIDE"]
    assert after.program.blocks[3:] == _host().blocks[1:]


def test_bad_fields_and_unknown_drawings_are_answered_plainly(app: Flask) -> None:
    client = app.test_client()
    location = _upload(client, bracket(), **{"hole-diameter": "0.25"})
    key = _key(location)
    token = csrf(client, location)
    base = {"csrf_token": token, "hole-diameter": "0.25", **CUTTING}
    cases = {
        "c0_order=x": ({"c0_order": "x"}, "contour 1 order: &#39;x&#39; is not a whole number"),
        "twice": (
            {"c0_order": "1", "h2_order": "1"},
            "order 1 is given twice (contour 1 and hole 3)",
        ),
        "tool": ({"c0_order": "1", "c0_tool": "30"}, "contour 1 tool: 30; allowed 1 to 24"),
        "nothing": ({}, "nothing is chosen"),
    }
    for name, (fields, message) in cases.items():
        url = f"/drawings/{key}/add" if name == "nothing" else f"/drawings/{key}/preview"
        answer = client.post(url, data={**base, **fields})
        assert answer.status_code == 422, name
        assert message in answer.get_data(as_text=True), name
    assert client.get("/drawings/" + "0" * 64).status_code == 404
    assert client.get("/drawings/not-a-key").status_code == 404
    import io

    not_dxf = client.post(
        "/drawings",
        data={"csrf_token": token, "file": (io.BytesIO(b"G0 X1\n"), "part.dxf")},
        content_type="multipart/form-data",
    )
    assert not_dxf.status_code == 422
    assert "Not opened: part.dxf: not a DXF drawing" in not_dxf.get_data(as_text=True)


# -- hostile input on the new entry points -------------------------------------------------


@pytest.fixture(scope="module")
def hostile_app(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Flask]:
    app = local_app(tmp_path_factory.mktemp("drawings-hostile"))
    yield app
    dispose(app)


@pytest.mark.parametrize(("name", "data"), [(n, d) for n, d, _ in UPLOADS])
def test_hostile_files_are_not_opened(hostile_app: Flask, name: str, data: bytes) -> None:
    import io

    client = hostile_app.test_client()
    token = csrf(client)
    answer = client.post(
        "/drawings",
        data={"csrf_token": token, "file": (io.BytesIO(data), name)},
        content_type="multipart/form-data",
    )
    assert answer.status_code == 422
    assert f"Not opened: {name}: " in answer.get_data(as_text=True)


@pytest.mark.parametrize("value", list(HOSTILE_NUMBERS))
def test_hostile_values_in_every_field_are_answered_not_crashed(
    hostile_app: Flask, value: str
) -> None:
    client = hostile_app.test_client()
    location = _upload(client, bracket(), **{"hole-diameter": "0.25"})
    key = _key(location)
    token = csrf(client, location)
    fields = ["c0_order", "c0_start", "c0_tool", "h0_order", "holes_tool", "after", "program"]
    fields += [*CUTTING, "tool_rpm", "c0_dir", "c0_comp", "c0_routine", "milling"]
    for field in fields:
        form = {
            "csrf_token": token,
            "hole-diameter": "0.25",
            **CUTTING,
            "c0_order": "1",
            field: value,
        }
        for action in ("preview", "add"):
            extra = {"target": "existing"} if field in ("after", "program") else {}
            answer = client.post(f"/drawings/{key}/{action}", data={**form, **extra})
            assert answer.status_code in (200, 302, 404, 422), (field, action)
    for option in ("hole-diameter", "tolerance", "units", "layer", "feed", "drawing-units"):
        answer = client.get(f"/drawings/{key}", query_string={option: value})
        assert answer.status_code in (200, 422), option
    with hostile_app.app_context():
        programs = get_library().programs()
    # Nothing hostile made a program (only the demo set is there).
    assert all(not p.name.startswith("bracket") for p in programs)
