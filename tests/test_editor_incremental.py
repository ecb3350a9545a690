"""An edit of one block does the program-wide work once (issue 32, point 4).

Speed is not tested by time: these count how often an edit of one DRILL of the 500-block
program walks the whole program for a figure it needs once, so a change that makes a phase
whole-program again (or makes it twice) fails here. The counters wrap real functions (a
probe, not a mock: each call still does its work); the edit goes through the Flask test
client as the editor's page posts it, its reply carrying what changed in the drawing.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from dataclasses import replace
from decimal import Decimal
from pathlib import Path
from typing import Any

import pytest
from flask import Flask
from flask.testing import FlaskClient

from app import create_app
from app.cnc import cost, path, structure
from app.cnc.blocks import BoltCircle
from app.cnc.problems import Rule
from app.cnc.validate import validate
from app.web import get_library, preview
from bench.editor import HTMX, edit_form
from bench.programs import editor_program

PATCH = re.compile(r'<template id="drawing-patch" hx-swap-oob="true" data-from="(\d+)"')


@pytest.fixture
def app(tmp_path: Path) -> Iterator[Flask]:
    app = create_app({"DATABASE_URL": f"sqlite:///{tmp_path / 'edits.db'}", "SECRET_KEY": "t" * 32})
    yield app
    with app.app_context():
        get_library().engine.dispose()


class Editing:
    """A 500-block program open in the editor; `edit(k)` moves DRILL 10·k + 1 as the page
    does, saying which version its drawing shows (the reply then carries what changed)."""

    def __init__(self, app: Flask) -> None:
        with app.app_context():
            self.program_id = get_library().create(editor_program(500)).id
        self.client: FlaskClient = app.test_client()
        page = self.client.get(f"/programs/{self.program_id}?edit=1").get_data(as_text=True)
        found = re.search(r'name="csrf_token" value="([^"]+)"', page)
        assert found
        self.csrf = found.group(1)
        self.version = 1

    def edit(self, k: int) -> str:
        form = {**edit_form(self.csrf, self.version, k, 500), "drawn": str(self.version)}
        answer = self.client.post(f"/programs/{self.program_id}/blocks", data=form, headers=HTMX)
        assert answer.status_code == 200
        text = answer.get_data(as_text=True)
        # What the user sees: the drawing's changes came with the reply.
        assert PATCH.search(text), text[-600:]
        self.version += 1
        return text


def count_calls(monkeypatch: pytest.MonkeyPatch, owner: Any, name: str) -> list[int]:
    """Count the calls of `owner.name` (it still runs); the count is the list's length."""
    real: Callable[..., Any] = getattr(owner, name)
    calls: list[int] = []

    def counted(*args: Any, **kwargs: Any) -> Any:
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(owner, name, counted)
    return calls


def test_an_edit_walks_the_program_for_its_cost_once(
    app: Flask, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Validation, the compile, the library's check before the save and the preview each ask
    what the new version costs (app/cnc/cost.py); the blocks are walked for it once."""
    editing = Editing(app)
    editing.edit(0)  # the first edit of a process works out every block's parts
    walks = count_calls(monkeypatch, cost, "build_nodes")
    editing.edit(1)
    assert len(walks) == 1


def test_an_edit_times_its_version_once(app: Flask, monkeypatch: pytest.MonkeyPatch) -> None:
    """The reply's cycle time and the drawing's are the same figures, worked out once."""
    editing = Editing(app)
    editing.edit(0)
    timings = count_calls(monkeypatch, preview, "estimate")
    editing.edit(1)
    assert len(timings) == 1


def test_an_edit_places_the_holes_of_the_node_it_changed(
    app: Flask, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The pilot rule (app/cnc/process.py) reads every hole of the program; the holes of
    the compiled nodes an edit left alone are kept, so one edit places the pieces of the
    node it changed (and the program's end), not the 300 pieces with holes."""
    editing = Editing(app)
    editing.edit(0)
    placed = count_calls(monkeypatch, path, "_placed_holes")
    editing.edit(1)
    assert len(placed) <= 5, len(placed)


def test_the_pilot_rule_sees_an_edit_among_kept_holes() -> None:
    """With every other node's holes kept from the version before, turning block 3's bolt
    circle (the BORE of block 4 is bored into its first hole) still warns at block 4, and
    turning it back clears the warning."""
    program = editor_program(500)
    assert not [p for p in validate(program) if p.rule is Rule.PILOT]
    bolt = program.blocks[2]
    assert isinstance(bolt, BoltCircle)
    turned = replace(
        program, blocks=(*program.blocks[:2], replace(bolt, angle=Decimal(45)), *program.blocks[3:])
    )
    warned = [p for p in validate(turned) if p.rule is Rule.PILOT]
    assert [p.block for p in warned] == [4]
    assert "boring bar goes into solid material" in warned[0].message
    back = replace(turned, blocks=(*turned.blocks[:2], bolt, *turned.blocks[3:]))
    assert not [p for p in validate(back) if p.rule is Rule.PILOT]


def test_an_edit_groups_its_blocks_into_nodes_once(
    app: Flask, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The cost and the compile both read the new version's nodes (structure.build_nodes):
    its 500 blocks are grouped once."""
    editing = Editing(app)
    editing.edit(0)
    real = structure._sequence
    groupings: list[int] = []

    def counted(*args: Any, inside_loop: bool, tolerant: bool) -> Any:
        if not inside_loop:  # a whole program's grouping, not a LOOP's body
            groupings.append(1)
        return real(*args, inside_loop=inside_loop, tolerant=tolerant)

    monkeypatch.setattr(structure, "_sequence", counted)
    editing.edit(1)
    assert len(groupings) == 1
