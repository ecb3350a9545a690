"""The editor's reply to an edit (issue 18): what changed, not the whole page.

A 500-block program is edited through the Flask test client the way the editor's htmx form
posts; the answer must carry the edited row, the cycle time and the drawing out of band,
and leave the other rows alone.
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

from app import create_app
from app.cnc.blocks import Copy, Hole
from app.web import get_library
from bench.editor import HTMX, edit_form
from bench.programs import editor_program

OOB_ROW = re.compile(r'<li class="block-row[^"]*" data-block="(\d+)" id="b-\1" hx-swap-oob="true"')


@pytest.fixture
def app(tmp_path: Path) -> Iterator[Flask]:
    app = create_app({"DATABASE_URL": f"sqlite:///{tmp_path / 'reply.db'}", "SECRET_KEY": "t" * 32})
    yield app
    with app.app_context():
        get_library().engine.dispose()


def csrf_of(page: str) -> str:
    found = re.search(r'name="csrf_token" value="([^"]+)"', page)
    assert found
    return found.group(1)


def edit_drill_11(
    client: FlaskClient, program_id: int, page: str, version: int, shown: list[str] | None = None
) -> tuple[str, set[int]]:
    """Move DRILL 11 to a new X from the editor `page` showing `version` (sending the rows'
    digests `shown`, as the page does, when given): the reply and the rows it sends."""
    form: dict[str, str | list[str]] = {**edit_form(csrf_of(page), version, 1, 500)}
    if shown is not None:
        form["shown"] = shown
    answer = client.post(f"/programs/{program_id}/blocks", data=form, headers=HTMX)
    assert answer.status_code == 200
    text = answer.get_data(as_text=True)
    return text, {int(n) for n in OOB_ROW.findall(text)}


def test_an_edit_answers_with_the_rows_it_changed(app: Flask) -> None:
    with app.app_context():
        program_id = get_library().create(editor_program(500)).id
    client: FlaskClient = app.test_client()
    page = client.get(f"/programs/{program_id}?edit=11").get_data(as_text=True)
    text, rows = edit_drill_11(client, program_id, page, 1)
    assert 11 in rows and len(rows) <= 3, rows  # the DRILL, and what its move retimed
    assert 'id="total" hx-swap-oob="true"' in text
    assert 'id="version" data-version="2" hx-swap-oob="true">v2<' in text
    # The drawing is not in the reply: the reply asks for it, and it follows.
    assert "<svg" not in text
    asked = re.search(r'id="drawing-refresh"[^>]*hx-get="([^"]+)"[^>]*hx-trigger="load"', text)
    assert asked is not None, text[-600:]
    assert len(text.encode()) < 15_000
    drawing = client.get(asked.group(1).replace("&amp;", "&"), headers=HTMX)
    assert drawing.status_code == 200
    shown = drawing.get_data(as_text=True)
    assert (
        shown.lstrip().startswith('<div id="drawing-area">') or '<div id="drawing-area">' in shown
    )
    assert "<svg" in shown and 'id="total" hx-swap-oob="true"' in shown
    # DRILL 11's new X is in the drawing the reply asked for.
    assert "Cycle time" in shown


def test_an_edit_from_a_version_another_worker_showed_answers_with_its_rows(app: Flask) -> None:
    """Under gunicorn the page of the version an edit starts from may have come from the
    other worker, so this one never worked out that version's rows: the reply is still the
    rows that changed (worked out from the stored version), not the whole list page."""
    program = editor_program(500)
    with app.app_context():
        library = get_library()
        program_id = library.create(program).id
        client: FlaskClient = app.test_client()
        page = client.get(f"/programs/{program_id}?edit=11").get_data(as_text=True)
        # The other worker saves version 2 (DRILL 21 moved) and shows it; this process has
        # worked out only version 1's rows.
        first = program.blocks[20]
        assert isinstance(first, Hole)
        moved = replace(first, x=first.x + Decimal("0.03"))
        blocks = (*program.blocks[:20], moved, *program.blocks[21:])
        library.save(program_id, replace(program, blocks=blocks), based_on=1)
    text, rows = edit_drill_11(client, program_id, page, 2)
    assert 11 in rows and len(rows) <= 3, rows
    assert 'id="version" data-version="3" hx-swap-oob="true">v3<' in text
    assert 'id="blocks"' not in text
    assert len(text.encode()) < 15_000


def test_a_copy_that_makes_more_blocks_answers_with_the_list(app: Flask) -> None:
    """EXEC of a COPY of blocks 1-3 puts three blocks where the COPY stood: the blocks after
    it move, so the reply is the whole list page (it answered 500 before: the rows were
    compared one for one with a version of fewer blocks)."""
    program = editor_program(20)
    program = replace(program, blocks=(*program.blocks, Copy(from_block=1, to_block=3)))
    count = len(program.blocks)
    with app.app_context():
        program_id = get_library().create(program).id
    client: FlaskClient = app.test_client()
    page = client.get(f"/programs/{program_id}?edit={count}").get_data(as_text=True)
    form = {
        "csrf_token": csrf_of(page),
        "version": "1",
        "edit": str(count),
        "kind": "COPY",
        "units": "inch",
        "from_block": "1",
        "to_block": "3",
        "xof": "1",
        "action": "exec",
    }
    answer = client.post(f"/programs/{program_id}/blocks", data=form, headers=HTMX)
    assert answer.status_code == 200
    text = answer.get_data(as_text=True)
    assert 'id="blocks"' in text and 'data-block="23"' in text
    with app.app_context():
        assert len(get_library().get(program_id).program.blocks) == count + 2


SHOWN = re.compile(r'name="shown" value="(\d+):([0-9a-f]+)"')


def test_an_edit_sent_with_the_rows_shown_answers_with_the_rows_that_differ(app: Flask) -> None:
    """The page keeps a digest of what each row shows and an edit sends them back: the reply
    holds the rows that differ from what the browser shows, whichever worker showed them
    (here row 5 is shown stale, as if it were left from an older version)."""
    with app.app_context():
        program_id = get_library().create(editor_program(500)).id
    client: FlaskClient = app.test_client()
    page = client.get(f"/programs/{program_id}?edit=11").get_data(as_text=True)
    shown = dict(SHOWN.findall(page))
    assert sorted(int(n) for n in shown) == list(range(1, 101))
    shown["5"] = "0" * 16
    text, rows = edit_drill_11(client, program_id, page, 1, [f"{n}:{d}" for n, d in shown.items()])
    assert {5, 11} <= rows and len(rows) <= 4, rows
    # Each row sent carries its new digest, so the next edit sends what is shown now.
    sent = dict(SHOWN.findall(text))
    assert set(sent) == {str(n) for n in rows} and sent["5"] == shown_now(client, program_id, 5)
    assert 'id="blocks"' not in text


def shown_now(client: FlaskClient, program_id: int, number: int) -> str:
    """The digest the page shows now for row `number`."""
    page = client.get(f"/programs/{program_id}?edit={number}").get_data(as_text=True)
    digests: dict[str, str] = dict(SHOWN.findall(page))
    return digests[str(number)]


PATCH = re.compile(
    r'<template id="drawing-patch" hx-swap-oob="true" data-from="(\d+)" data-to="(\d+)"'
)
PAGE_CHANGE = re.compile(r'<g class="page"[^>]*data-at="(\d+)" data-drop="(\d+)">')


def test_an_edit_from_the_drawing_shown_answers_with_what_changed_in_it(app: Flask) -> None:
    """The page says which version its drawing is (`drawn`): the reply carries what changed
    in it (DRILL 11's drawing and the rapid into the block after it), not a request for the
    whole drawing (110 kB on this program), and still under 15 kB; with another version
    shown, the reply asks for the whole drawing as before."""
    with app.app_context():
        program_id = get_library().create(editor_program(500)).id
    client: FlaskClient = app.test_client()
    page = client.get(f"/programs/{program_id}?edit=11").get_data(as_text=True)
    assert 'id="preview" class="drawing" data-units="inch" data-version="1"' in page
    form = {**edit_form(csrf_of(page), 1, 1, 500), "drawn": "1"}
    answer = client.post(f"/programs/{program_id}/blocks", data=form, headers=HTMX)
    text = answer.get_data(as_text=True)
    found = PATCH.search(text)
    assert found and found.groups() == ("1", "2"), text[-800:]
    assert "hx-get" not in text[text.index('id="drawing-refresh"') :]
    change = PAGE_CHANGE.search(text)
    assert change is not None and int(change.group(2)) <= 3, change
    assert 'data-block="11"' in text[found.start() :]
    assert 'id="not-drawn" hx-swap-oob="true"' in text
    assert len(text.encode()) < 15_000
    # A page showing version 1's drawing still, after version 2 was saved: no changes
    # from version 2 for it; it is asked to fetch the whole drawing.
    form = {**edit_form(csrf_of(page), 2, 2, 500), "drawn": "1"}
    text = client.post(f"/programs/{program_id}/blocks", data=form, headers=HTMX).get_data(True)
    assert PATCH.search(text) is None
    assert re.search(r'id="drawing-refresh"[^>]*hx-get="[^"]+v=3"', text)
