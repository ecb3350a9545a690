"""Block kinds declared once (issue 18): what the declarations give every reader.

A kind declared here, in the test alone (SPOT: a spot drill at X/Y to a depth), is read,
checked, entered, copied and mirrored without a line of the document, forms, validation,
COPY or mirror code knowing its name.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from dataclasses import dataclass
from decimal import Decimal
from typing import Any, ClassVar

import pytest

from app.cnc import cost, document, limits, sizes
from app.cnc.blocks import (
    MAX_TOOLS,
    Block,
    Circle,
    Copy,
    CopyAction,
    Frame,
    Hole,
    HoleOp,
    Mode,
    Pocket,
    Pos,
    Program,
    field_label,
)
from app.cnc.compiler import compile_program
from app.cnc.copy import execute_copy
from app.cnc.kinds import REGISTRY, Document, Kind, Mill, Role, SubKind, Value, prompt
from app.cnc.mirror import Axis, mirror
from app.cnc.path import Op
from app.cnc.units import Units, to_nm
from app.cnc.validate import validate
from app.web.forms import Choice, entry_forms, group_menu, parse_block, sub_menu


@dataclass(frozen=True, kw_only=True)
class Spot(Block):
    """SPOT (a kind for this test only): spot a hole at X/Y to Z DN."""

    kind: ClassVar[str] = "SPOT"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("SPOT"),),
        editor=(SubKind("SPOT", "SPOT", "DRILL", 5),),
        positioned=True,
        loopable=True,
    )
    x: Decimal = prompt("X", Value.LENGTH, role=Role.X)
    y: Decimal = prompt("Y", Value.LENGTH, role=Role.Y)
    z_dn: Decimal = prompt("Z DN", Value.LENGTH)
    feed_z: Decimal = prompt("FEEDR Z", Value.FEED, feed=limits.FEED_Z)
    tool: int = prompt("TOOL #", Value.TOOL, low=1, high=MAX_TOOLS)


# Declaring SPOT registered it; it is there only while a test below asks for it.
REGISTRY.remove(Spot)


@pytest.fixture
def spot() -> Iterator[type[Spot]]:
    """SPOT registered for one test (declaring it registered it; others do not see it)."""
    REGISTRY.add(Spot)
    yield Spot
    REGISTRY.remove(Spot)


def spotted(*blocks: Block) -> Program:
    return Program(name="spots", blocks=blocks)


def test_a_kind_declared_once_reads_and_writes_in_the_document(spot: type[Spot]) -> None:
    program = spotted(
        spot(x=Decimal("1.5"), y=Decimal(2), z_dn=Decimal("-0.1"), feed_z=Decimal(5), tool=1)
    )
    text = document.dumps(program)
    assert '"type": "SPOT"' in text
    assert document.loads(text) == program
    broken = text.replace('"feed_z": 5', '"feed_z": "fast"')
    with pytest.raises(document.DocumentError, match="block 1, FEEDR Z: expected a number"):
        document.loads(broken)


def test_a_kind_declared_once_is_checked_by_its_limits(spot: type[Spot]) -> None:
    program = spotted(
        spot(x=Decimal(1), y=Decimal(1), z_dn=Decimal(-1), feed_z=Decimal(900), tool=30)
    )
    assert [str(p) for p in validate(program)] == [
        "block 1, FEEDR Z: 900 ipm is outside the allowed range 0.1 to 250 ipm",
        "block 1, TOOL #: 30 is outside the allowed range 1 to 24",
    ]


def test_a_kind_declared_once_is_offered_and_entered(spot: type[Spot]) -> None:
    form = entry_forms()["SPOT"]
    assert (form.title, form.group, form.positioned, form.loopable) == ("SPOT", "DRILL", True, True)
    assert [(f.name, f.label, f.kind) for f in form.fields] == [
        ("x", "X", "length"),
        ("y", "Y", "length"),
        ("z_dn", "Z DN", "length"),
        ("feed_z", "FEEDR Z", "feed"),
        ("tool", "TOOL #", "tool"),
    ]
    parsed = parse_block(
        "SPOT", {"x": "1", "y": "2", "z_dn": "-.1", "feed_z": "5", "tool": "2", "mode": "inc"}
    )
    assert parsed.errors == {}
    assert parsed.blocks == [
        spot(
            mode=Mode.INC,
            x=Decimal(1),
            y=Decimal(2),
            z_dn=Decimal("-.1"),
            feed_z=Decimal(5),
            tool=2,
        )
    ]
    assert parse_block("SPOT", {"x": "1", "y": "two"}).errors["y"].startswith("Y: 'two'")


def test_a_kind_declared_once_is_copied_and_mirrored(spot: type[Spot]) -> None:
    first = spot(x=Decimal(1), y=Decimal(2), z_dn=Decimal(-1), feed_z=Decimal(5), tool=1)
    copy = Copy(from_block=1, to_block=1, xof=Decimal(3), tool=2, action=CopyAction.EXEC)
    copied = execute_copy(spotted(first, copy), 2)
    assert copied.blocks[1] == dataclasses.replace(first, x=Decimal(4), tool=2)
    assert mirror(spotted(first), Axis.X).program.blocks == (
        dataclasses.replace(first, x=Decimal("-1.000"), y=Decimal("2.000")),
    )


def test_field_label_answers_from_a_table_made_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """The editor asked for labels 17 000 times per edit, each scanning the dataclass."""
    assert field_label(Hole, "feed_z") == "FEEDR Z"

    def no_scan(*_: object) -> None:
        raise AssertionError("dataclasses.fields scanned again")

    monkeypatch.setattr(dataclasses, "fields", no_scan)
    block = Hole(op=HoleOp.DRILL, x=Decimal(0), y=Decimal(0), tool=1)
    assert [field_label(block, name) for name in ("z_up", "pecks", "comp")] == [
        "Z UP",
        "# PECK",
        "CUTTER COMP",
    ]
    with pytest.raises(KeyError):
        field_label(block, "nonsense")


def test_every_kind_declares_its_document_editor_and_labels() -> None:
    names = {d.name for cls in REGISTRY.classes for d in REGISTRY.kind(cls).documents}
    assert names == set(REGISTRY.documents())
    for cls in REGISTRY.classes:
        kind = REGISTRY.kind(cls)
        assert kind.documents and kind.editor, cls.__name__
        for f in REGISTRY.fields(cls):
            assert f.label and f.label == field_label(cls, f.name)


def test_routine_kinds_name_planners_that_resolve() -> None:
    routines = REGISTRY.mill_classes(Mill.ROUTINE)
    assert set(routines) == {Circle, Frame, Pocket}
    for cls in routines:
        assert callable(REGISTRY.planner(cls))
    with pytest.raises(LookupError):
        REGISTRY.planner(Pos)


def test_stop_on_an_arc_lands_on_its_xy_end() -> None:
    """The head retracts after the arc's last block: STOP belongs to the XY-END (the
    XY-CENT cannot carry it). Failed before: the form put STOP on the XY-CENT block."""
    form = {"x": "1", "y": "0", "feed_xy": "10", "tool": "1", "end_x": "2", "end_y": "0"}
    parsed = parse_block("ARC_C", {**form, "stop": "on"})
    assert [block.stop for block in parsed.blocks] == [False, True]


@dataclass(frozen=True, kw_only=True)
class Mark(Block):
    """MARK (a kind for this test only): a loopable kind in a first-menu choice of its own."""

    kind: ClassVar[str] = "MARK"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("MARK"),),
        editor=(SubKind("MARK", "MARK", "MARK", 1),),
        choices=((11, "MARK"),),
        positioned=True,
        loopable=True,
    )
    x: Decimal = prompt("X", Value.LENGTH, role=Role.X)
    y: Decimal = prompt("Y", Value.LENGTH, role=Role.Y)
    tool: int = prompt("TOOL #", Value.TOOL, low=1, high=MAX_TOOLS)


REGISTRY.remove(Mark)


def test_which_blocks_carry_loop_is_read_from_the_declarations() -> None:
    """Validation and the editor name the blocks a LOOP may be from `Kind.loopable`: a
    loopable kind declared in a choice of its own is named too, without a line elsewhere."""
    line = Pocket(feed_xy=Decimal(10), tool=1, loop=True)
    message = "a POCKET block cannot carry LOOP; a LOOP is a POS, DRILL, BORE or TAP block"
    assert message in [p.message for p in validate(spotted(line))]
    REGISTRY.add(Mark)
    try:
        assert REGISTRY.loop_groups() == ("POS", "DRILL", "BORE", "TAP", "MARK")
        message = (
            "a POCKET block cannot carry LOOP; a LOOP is a POS, DRILL, BORE, TAP or MARK block"
        )
        # Another block: validation keeps what it found in each block it has seen.
        other = dataclasses.replace(line, feed_xy=Decimal(11))
        assert message in [p.message for p in validate(spotted(other))]
    finally:
        REGISTRY.remove(Mark)


def slot_moves(program: Program, block: Slot) -> int:
    """SLOT's moves estimate (its `Kind.cost`): a pass there and back per 0.1 of its length."""
    return 2 * int(block.length * 10) + 4


def cut_slot(c: Any, number: int, block: Slot, at: tuple[int, int]) -> None:
    """SLOT's cut (its `Kind.cut`): down at X/Y to Z 0, along +X its LENGTH at 10 a minute,
    up again — through the compiler's motion methods alone."""
    units = block.units
    c.use_tool(number, block.tool)
    c.position(number, at, c.retract)
    c.rapid_z(number, 0)
    c.feed_to(number, (at[0] + to_nm(block.length, units), at[1], 0), to_nm(Decimal(10), units))
    c.retract_up(number)


@dataclass(frozen=True, kw_only=True)
class Slot(Block):
    """SLOT (a kind for this test only): a routine cut from one block, as HELIX or FACE, in
    a first-menu choice of its own, which counts its own moves."""

    kind: ClassVar[str] = "SLOT"
    KIND: ClassVar[Kind] = Kind(
        documents=(Document("SLOT"),),
        editor=(SubKind("SLOT", "SLOT", "SLOT", 1),),
        choices=((11, "SLOT"),),
        cost="tests.test_kinds:slot_moves",
        cut="tests.test_kinds:cut_slot",
        positioned=True,
    )
    x: Decimal = prompt("X", Value.LENGTH, role=Role.X)
    y: Decimal = prompt("Y", Value.LENGTH, role=Role.Y)
    length: Decimal = prompt("LENGTH", Value.LENGTH, positive=True)
    tool: int = prompt("TOOL #", Value.TOOL, low=1, high=MAX_TOOLS)


REGISTRY.remove(Slot)

THE_FIRST_MENU = ["POS", "DRILL", "BORE", "TAP", "MILL", "LOOP", "STOP", "REP", "COPY", "POCKET"]


def test_a_kind_declares_its_cost_and_its_first_menu_choice() -> None:
    """A routine-like kind counts its own moves and opens a first-menu choice of its own from
    its declaration alone: cost.py and forms.py name no kind. Before, cost.py counted any
    block it did not list as a POS (4 moves) and forms.GROUPS listed the menu by hand."""
    program = spotted(Pos(x=Decimal(0), y=Decimal(0), tool=1))
    assert [c.key for c in group_menu(program, 2)] == THE_FIRST_MENU
    REGISTRY.add(Slot)
    try:
        slot = Slot(x=Decimal(1), y=Decimal(1), length=Decimal(100), tool=1)
        long = spotted(Pos(x=Decimal(0), y=Decimal(0), tool=1), slot)
        assert cost.estimate(long).moves - cost.estimate(program).moves == (
            cost.SPINDLE_ROWS + 2004
        )
        with pytest.raises(sizes.TooLarge, match=r"^block 2: the program would make about 2,"):
            cost.check(long, limit=2000)
        menu = group_menu(program, 2)
        assert [c.key for c in menu] == [*THE_FIRST_MENU, "SLOT"]
        assert menu[-1] == Choice(11, "SLOT", "SLOT")
        assert sub_menu(program, 2, "SLOT") == [Choice(1, "SLOT", "SLOT")]
    finally:
        REGISTRY.remove(Slot)
    assert [c.key for c in group_menu(program, 2)] == THE_FIRST_MENU


def test_a_kind_declares_what_cuts_it() -> None:
    """An operation standing alone is cut by the function its kind declares (`Kind.cut`):
    the compiler names no operation kind (before, a block it did not list could not stand
    on its own: "a SLOT block cannot stand on its own here")."""
    REGISTRY.add(Slot)
    try:
        slot = Slot(x=Decimal(1), y=Decimal(2), length=Decimal("0.5"), tool=1)
        compiled = compile_program(spotted(Pos(x=Decimal(0), y=Decimal(0), tool=1), slot))
        feeds = [
            (int(row["x"]), int(row["y"]), int(row["z"]))
            for chunk in compiled.path.chunks()
            for row in chunk.rows
            if row["op"] == Op.FEED and row["block"] == 2
        ]
        inch = Units.INCH.nm
        assert feeds == [(int(Decimal("1.5") * inch), 2 * inch, 0)]
    finally:
        REGISTRY.remove(Slot)


def test_first_menu_choices_are_declared_once() -> None:
    """A number claimed twice, or left out, is a declaration error naming the kind, not a
    menu whose numbers move (the control's numbers are what the machinist keys)."""
    REGISTRY.add(Mark)
    try:
        assert REGISTRY.first_menu({6: "LOOP", 7: "STOP"})[-1] == "MARK"
        with pytest.raises(ValueError, match=r"^Mark: first-menu choice 11 is SLOT, not MARK$"):
            REGISTRY.first_menu({6: "LOOP", 7: "STOP", 11: "SLOT"})
    finally:
        REGISTRY.remove(Mark)
    with pytest.raises(ValueError, match=r"numbers are \[1, 2, 3, 4, 5, 6, 8, 9, 10\]"):
        REGISTRY.first_menu({6: "LOOP"})


def test_a_sub_kind_under_an_undeclared_choice_is_named(monkeypatch: pytest.MonkeyPatch) -> None:
    """A kind whose menu line sits under a first-menu choice no kind opens would be a line
    no menu shows: the first menu refuses it, naming the kind and the choice."""
    monkeypatch.setattr(Mark, "KIND", dataclasses.replace(Mark.KIND, choices=()))
    REGISTRY.add(Mark)
    try:
        with pytest.raises(ValueError, match=r"^Mark: MARK sits under MARK, which no kind"):
            REGISTRY.first_menu({6: "LOOP", 7: "STOP"})
    finally:
        REGISTRY.remove(Mark)
