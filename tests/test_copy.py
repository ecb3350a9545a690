"""COPY (seed 001 §3.4.6): each kind of change, worked out by hand from the manual."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from decimal import Decimal as D
from pathlib import Path

import pytest

from app.cnc import document
from app.cnc.blocks import Copy, CopyAction, Hole, HoleOp, Mode, Pos, Program
from app.cnc.copy import CopyError, cancel_copy, execute_copy, resolve_copies
from app.cnc.problems import Rule

GOLDEN = Path(__file__).parent / "golden"


def golden(name: str) -> Program:
    return document.loads((GOLDEN / name / "program.json").read_text(encoding="utf-8"))


def xy(block: object) -> tuple[D, D]:
    assert isinstance(block, Pos | Hole)
    return block.x, block.y


def test_offsets_added_to_absolute_blocks() -> None:
    """Blocks 1-3: DRILL (1, 1), BORE (2, 1), POS (3, 1); COPY XOF 0.5 YOF 2.

    The copies replace the COPY block as blocks 4-6 at (1.5, 3), (2.5, 3), (3.5, 3); the
    COPY block is gone and nothing else changes.
    """
    program = resolve_copies(golden("copy-offsets-abs"))
    assert len(program.blocks) == 6
    assert [xy(b) for b in program.blocks[3:]] == [
        (D("1.5"), D(3)),
        (D("2.5"), D(3)),
        (D("3.5"), D(3)),
    ]
    assert program.blocks[:3] == golden("copy-offsets-abs").blocks[:3]
    assert not any(isinstance(b, Copy) for b in program.blocks)
    assert isinstance(program.blocks[3], Hole) and program.blocks[3].pecks == 2


def test_operation_tool_and_feed_change() -> None:
    """COPY 1-2 as TAP with tool 3 and FEEDR Z 12.5: the DRILL's 2 pecks go (TAP has none)."""
    new = resolve_copies(golden("copy-change-operation")).blocks[3:]
    assert [b.op for b in new if isinstance(b, Hole)] == [HoleOp.TAP, HoleOp.TAP]
    assert all(isinstance(b, Hole) and b.pecks == 1 for b in new)
    assert all(isinstance(b, Hole) and b.tool == 3 and b.feed_z == D("12.5") for b in new)
    assert [xy(b) for b in new] == [(D(1), D(1)), (D(2), D(1))]


def test_pecks_and_depths_change_where_the_block_has_them() -> None:
    """COPY 1-3 with 5 pecks, Z UP 0.05, Z DN -0.8, YOF 1: pecks change only in the DRILL,
    Z changes in DRILL and BORE, the POS only moves.
    """
    drill, bore, pos = resolve_copies(golden("copy-change-pecks-depths")).blocks[3:6]
    assert isinstance(drill, Hole) and isinstance(bore, Hole) and isinstance(pos, Pos)
    assert (drill.pecks, bore.pecks) == (5, 1)
    assert (drill.z_up, drill.z_dn, bore.z_up, bore.z_dn) == (D("0.05"), D("-0.8")) * 2
    assert [xy(b) for b in (drill, bore, pos)] == [(D(1), D(2)), (D(2), D(2)), (D(3), D(2))]


def test_incremental_range_gets_a_leading_pos() -> None:
    """All blocks of the range incremental: an INC POS of (XOF, YOF) goes first."""
    new = resolve_copies(golden("copy-incremental-range")).blocks[3:]
    assert len(new) == 3
    assert isinstance(new[0], Pos) and new[0].mode is Mode.INC
    assert xy(new[0]) == (D(0), D(1))
    assert [xy(b) for b in new[1:]] == [(D("0.5"), D(0))] * 2


def test_feed_xy_and_tool_change_reach_mill_blocks() -> None:
    program = resolve_copies(golden("copy-feed-xy-tool"))
    drill, mill = program.blocks[2:]
    assert drill.tool_number == 4 and mill.tool_number == 4
    assert getattr(mill, "feed_xy") == D(6)  # noqa: B009
    assert xy(drill) == (D(0), D("0.5"))


def test_cancel_removes_only_the_copy_block() -> None:
    original = golden("copy-cancel")
    assert resolve_copies(original).blocks == original.blocks[:3]
    assert cancel_copy(original, 4).blocks == original.blocks[:3]


def test_pending_copy_stays() -> None:
    program = golden("copy-cancel")
    pending = Copy(from_block=1, to_block=2, xof=D(1))
    waiting = Program(name="p", block0=program.block0, blocks=(*program.blocks[:3], pending))
    assert resolve_copies(waiting) == waiting


@pytest.mark.parametrize(
    ("copy", "rule", "message"),
    [
        (
            Copy(from_block=1, to_block=9, action=CopyAction.EXEC),
            Rule.COPY_1,
            "ERROR: COPY 1 FROM or TO block does not exist.",
        ),
        (
            Copy(from_block=0, to_block=2, action=CopyAction.EXEC),
            Rule.COPY_1,
            "ERROR: COPY 1 FROM or TO block does not exist.",
        ),
    ],
)
def test_execute_refuses_with_the_controls_words(copy: Copy, rule: Rule, message: str) -> None:
    base = golden("copy-cancel")
    program = Program(name="p", block0=base.block0, blocks=(*base.blocks[:3], copy))
    with pytest.raises(CopyError) as caught:
        execute_copy(program, 4)
    assert caught.value.rule is rule
    assert str(caught.value) == f"block 4: {message}"


def test_copy_in_an_inserted_block_is_refused() -> None:
    """COPY 4: a COPY that is not the last block was inserted between existing blocks."""
    base = golden("copy-cancel")
    copy = Copy(from_block=1, to_block=1, action=CopyAction.EXEC)
    program = Program(
        name="p", block0=base.block0, blocks=(base.blocks[0], copy, *base.blocks[1:3])
    )
    with pytest.raises(CopyError, match="COPY 4 COPY is being selected in an inserted data block"):
        execute_copy(program, 2)


def test_a_copied_contour_keeps_its_calculated_values_calculated() -> None:
    """Issue 33: COPY XOF 5 of print-line-tangent-arc's sequence (blocks 1-6). An empty X/Y
    stays empty in the copy (it failed with a TypeError, None + 5), so the copy's points
    are calculated from its shifted blocks: its tool path is the original's, 5 in along X."""
    from app.cnc.interpret import interpret
    from app.cnc.toolpath import ArcFeed, Feed

    original = golden("print-line-tangent-arc")
    count = len(original.blocks)
    copy = Copy(from_block=1, to_block=count, xof=D(5), action=CopyAction.EXEC)
    program = resolve_copies(dataclasses.replace(original, blocks=(*original.blocks, copy)))
    assert program.blocks[count + 2].x is None  # type: ignore[attr-defined]

    def cuts(moves: Sequence[object], blocks: range) -> list[tuple[int, int]]:
        return [(m.x, m.y) for m in moves if isinstance(m, Feed | ArcFeed) and m.block in blocks]

    moves = list(interpret(program).moves)
    first = cuts(moves, range(1, count + 1))
    second = cuts(moves, range(count + 1, 2 * count + 1))
    assert second == [(x + 127_000_000, y) for x, y in first]
