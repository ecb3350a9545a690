"""Which side the cutter goes (issue 29 point 3): the DXF choosing page and `millblocks
import` follow one rule: an outline is cut from outside, a slot inside it from inside,
climbing. The page offers the rule's choice as its default and asks for the depths, feeds
and tool the drawing cannot give; the blocks it makes carry them.

The drawing here is the one a machinist sent: an outline drawn counter-clockwise (as CAD
draws it) with a slot inside it drawn clockwise. The page used to default both to "as drawn"
with the tool on the left: inside the outline and outside the slot, into the part.
"""

from __future__ import annotations

import io
import re
from collections.abc import Iterator
from decimal import Decimal
from html.parser import HTMLParser
from pathlib import Path

import pytest
from click.testing import CliRunner
from ezdxf.filemanagement import new as new_drawing
from flask import Flask
from flask.testing import FlaskClient

from app.cli import main
from app.cnc.blocks import Comp, Hole, Program
from app.cnc.formats.dxf.choice import ChoiceError, read_cutting
from app.cnc.units import Units
from app.web.extensions import get_library
from tests.test_import_dxf import _points, programmed, write
from tests.web_support import csrf, dispose, local_app


def outline_and_slot() -> bytes:
    """An inch plate 4 x 3 with one corner chamfered (so no FRAME cuts it), drawn
    counter-clockwise, and a slot 0.5 wide from (1.5, 1.25) to (2.5, 1.25) drawn clockwise."""
    doc = new_drawing(units=1)
    msp = doc.modelspace()
    msp.add_lwpolyline([(0, 0), (4, 0), (4, 2.5), (3.5, 3), (0, 3)], format="xy", close=True)
    msp.add_lwpolyline(
        [(1.5, 1.5, 0), (2.5, 1.5, -1), (2.5, 1.0, 0), (1.5, 1.0, -1)],
        format="xyb",
        close=True,
    )
    return write(doc)


class _Fields(HTMLParser):
    """The values a browser would send from the form `#choices` as the page shows it:
    text inputs, the selected option of each select, checked boxes; disabled ones left out."""

    def __init__(self) -> None:
        super().__init__()
        self.fields: dict[str, str] = {}
        self.inside = False
        self.select: str | None = None
        self.first: str | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if tag == "form":
            self.inside = a.get("id") == "choices"
        if not self.inside or "disabled" in a:
            return
        name = a.get("name")
        if tag == "input" and name:
            kind = a.get("type", "text")
            if kind in ("checkbox", "radio"):
                if "checked" in a:
                    self.fields[name] = a.get("value") or "on"
            else:
                self.fields[name] = a.get("value") or ""
        elif tag == "select" and name:
            self.select, self.first = name, None
        elif tag == "option" and self.select:
            value = a.get("value") or ""
            if self.first is None:
                self.first = value
                self.fields[self.select] = value
            if "selected" in a:
                self.fields[self.select] = value

    def handle_endtag(self, tag: str) -> None:
        if tag == "select":
            self.select = None
        if tag == "form":
            self.inside = False


def shown_fields(page: str) -> dict[str, str]:
    parser = _Fields()
    parser.feed(page)
    return parser.fields


@pytest.fixture
def app(tmp_path: Path) -> Iterator[Flask]:
    app = local_app(tmp_path)
    yield app
    dispose(app)


def _open(client: FlaskClient, data: bytes) -> tuple[str, str]:
    token = csrf(client, "/")
    answer = client.post(
        "/drawings",
        data={"csrf_token": token, "file": (io.BytesIO(data), "plate.dxf")},
        content_type="multipart/form-data",
    )
    assert answer.status_code == 302, answer.get_data(as_text=True)
    location = answer.headers["Location"]
    found = re.search(r"/drawings/([0-9a-f]{64})", location)
    assert found
    return location, found.group(1)


def sides(program: Program) -> dict[tuple[int, ...], tuple[Comp, bool]]:
    """For each milled contour, by its box (in 0.001 in): the tool side on its DRILL and
    whether it goes round clockwise."""
    drills = [b for b in program.blocks if isinstance(b, Hole) and b.comp is not Comp.NONE]
    contours, _ = programmed(program)
    result = {}
    for drill, path in zip(drills, contours, strict=True):
        pts = _points(path)
        area = sum(a[0] * b[1] - b[0] * a[1] for a, b in zip(pts, pts[1:] + pts[:1], strict=True))
        xs, ys = [p[0] for p in pts], [p[1] for p in pts]
        box = tuple(round(v / 25_400) for v in (min(xs), min(ys), max(xs), max(ys)))
        result[box] = (drill.comp, area < 0)
    return result


def _added(app: Flask, answer: object) -> Program:
    location = answer.headers["Location"]  # type: ignore[attr-defined]
    program_id = int(re.search(r"/programs/(\d+)", location).group(1))  # type: ignore[union-attr]
    with app.app_context():
        return get_library().get(program_id).program


def test_the_page_offers_the_side_millblocks_import_cuts(
    app: Flask, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Choose the outline and the slot on the page, change nothing else, add them: each is
    cut on the side and the way round `millblocks import` cuts it (outline clockwise from
    outside, slot counter-clockwise from inside, the tool on the left: climbing). Failed
    before the page took its defaults from the import's rule (the outline came out
    counter-clockwise with the tool on the left: inside, into the part)."""
    client = app.test_client()
    location, key = _open(client, outline_and_slot())
    fields = shown_fields(client.get(location).get_data(as_text=True))
    fields["c0_order"], fields["c1_order"] = "1", "2"
    added = client.post(f"/drawings/{key}/add", data={**fields, "target": "new", "name": "P"})
    assert added.status_code == 302, added.get_data(as_text=True)
    from_page = sides(_added(app, added))

    # `millblocks import` of the same file, into the same library.
    monkeypatch.setenv("DATABASE_URL", app.config["DATABASE_URL"])
    path = tmp_path / "plate.dxf"
    path.write_bytes(outline_and_slot())
    result = CliRunner().invoke(main, ["import", str(path)])
    assert result.exit_code == 0, result.stderr
    with app.app_context():
        imported = get_library().get(int(result.stdout.strip().splitlines()[-1])).program
    from_import = sides(imported)

    outline, slot = (0, 0, 4000, 3000), (1250, 1000, 2750, 1500)
    assert from_import == {outline: (Comp.LEFT, True), slot: (Comp.LEFT, False)}
    assert from_page == from_import


def test_the_blocks_carry_the_depths_feeds_and_tool_entered(app: Flask) -> None:
    client = app.test_client()
    location, key = _open(client, outline_and_slot())
    fields = shown_fields(client.get(location).get_data(as_text=True))
    # The defaults are on the page, to be seen and changed.
    for name in ("z_up", "z_dn", "feed_z", "feed_xy", "tool", "tool_dia"):
        assert fields.get(name), name
    fields.update(
        c0_order="1",
        c1_order="2",
        z_up="0.050",
        z_dn="-0.375",
        feed_z="4.0",
        feed_xy="12.5",
        tool="3",
        tool_dia="0.375",
        tool_rpm="2400",
    )
    added = client.post(f"/drawings/{key}/add", data={**fields, "target": "new", "name": "D"})
    assert added.status_code == 302, added.get_data(as_text=True)
    program = _added(app, added)
    drills = [b for b in program.blocks if isinstance(b, Hole)]
    assert len(drills) == 2
    for drill in drills:
        assert (drill.z_up, drill.z_dn, drill.feed_z, drill.tool) == (
            Decimal("0.050"),
            Decimal("-0.375"),
            Decimal("4.0"),
            3,
        )
    # Every mill block's FEEDR XY (an ARC's XY-END block has none of its own).
    assert {getattr(b, "feed_xy", None) for b in program.blocks if not isinstance(b, Hole)} == {
        Decimal("12.5"),
        None,
    }
    tool = program.block0.tool(3)
    assert tool is not None and tool.diameter == Decimal("0.375") and tool.rpm == 2400


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("z_dn", "deep", "Z DN: 'deep' is not a number"),
        ("z_dn", "0.2", "Z DN: 0.2 is not below Z UP 0.100"),
        ("z_up", "", "Z UP: no value given"),
        ("z_up", "0.0001", "Z UP: 0.0001 is finer than the control's 0.001 in"),
        ("feed_xy", "0", "FEEDR XY: 0 ipm; allowed 0.1 to 100"),
        ("feed_xy", "", "FEEDR XY: no number given"),
        ("feed_z", "300", "FEEDR Z: 300 ipm; allowed 0.1 to 250"),
        ("tool", "25", "tool: 25; allowed 1 to 24"),
        ("tool_dia", "0", "tool Ø: 0; the tool's diameter is more than 0"),
        ("tool_rpm", "9000", "RPM: 9000; allowed 60 to 4000"),
    ],
)
def test_bad_depths_feeds_and_tools_are_refused_naming_the_field(
    app: Flask, field: str, value: str, message: str
) -> None:
    client = app.test_client()
    location, key = _open(client, outline_and_slot())
    fields = shown_fields(client.get(location).get_data(as_text=True))
    fields.update(c0_order="1", **{field: value})
    for action in ("preview", "add"):
        answer = client.post(f"/drawings/{key}/{action}", data={**fields, "target": "new"})
        assert answer.status_code == 422
        text = answer.get_data(as_text=True).replace("&#39;", "'")
        assert message in text, (action, text[-2000:])
    with pytest.raises(ChoiceError, match=re.escape(message.replace("&#39;", "'"))):
        read_cutting(Units.INCH, {**fields, field: value})


def test_all_depths_blank_is_a_two_axis_program_and_said_so(app: Flask) -> None:
    client = app.test_client()
    location, key = _open(client, outline_and_slot())
    fields = shown_fields(client.get(location).get_data(as_text=True))
    fields.update(c0_order="1", z_up="", z_dn="", feed_z="")
    shown = client.post(f"/drawings/{key}/preview", data=fields)
    assert shown.status_code == 200
    assert "a 2-axis program" in shown.get_data(as_text=True)


def test_a_3_16_end_mill_is_taken_as_0_188_not_refused(app: Flask) -> None:
    """A 3/16 in end mill is 0.1875 in on the shop's tool list: the page took no tool
    finer than 0.001 in and refused it. Data Block 0 holds 0.188 (rounded half-even, as
    every import's tools are) and the blocks are added."""
    client = app.test_client()
    location, key = _open(client, outline_and_slot())
    fields = shown_fields(client.get(location).get_data(as_text=True))
    fields.update(c0_order="1", c1_order="2", tool="2", tool_dia="0.1875")
    added = client.post(f"/drawings/{key}/add", data={**fields, "target": "new", "name": "E"})
    assert added.status_code == 302, added.get_data(as_text=True)
    tool = _added(app, added).block0.tool(2)
    assert tool is not None and tool.diameter == Decimal("0.188")
