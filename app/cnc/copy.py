"""COPY: the editing operation that copies a range of blocks with changes (seed 001 §3.4.6).

COPY exists only while entering a program, and only as a new block at the end. EXEC inserts
the modified copies from the COPY block's number on and removes the COPY block; CANCEL just
removes it. The interpreter never sees a COPY block.
"""

from __future__ import annotations

import dataclasses
from decimal import Decimal
from typing import Any

from app.cnc.blocks import (
    Block,
    BoltCircle,
    Comp,
    Copy,
    CopyAction,
    Hole,
    HoleOp,
    Mode,
    Pos,
    Program,
)
from app.cnc.problems import Rule
from app.cnc.validate import copy_errors


class CopyError(ValueError):
    """A COPY that cannot run; `rule` is COPY_1…COPY_4 and the message is the control's."""

    def __init__(self, block: int, rule: Rule, message: str) -> None:
        super().__init__(f"block {block}: {message}")
        self.block = block
        self.rule = rule
        self.message = message


# Fields a COPY block may change in every block that has them.
_PLAIN_CHANGES = ("z_up", "z_dn", "feed_z", "feed_xy", "tool")


def execute_copy(program: Program, number: int) -> Program:
    """Run COPY block `number` (EXEC): the modified copies replace it at its place.

    Raises CopyError with the control's COPY 1-4 message when the COPY cannot run.
    """
    copy = program.block(number)
    if not isinstance(copy, Copy):
        raise ValueError(f"block {number} is a {copy.title}, not a COPY")
    errors = copy_errors(program, number)
    if errors:
        rule, message = errors[0]
        raise CopyError(number, rule, message)
    span = program.blocks[copy.from_block - 1 : copy.to_block]
    new_blocks: list[Block] = []
    all_incremental = all(b.mode is Mode.INC for b in span)
    if all_incremental and (copy.xof is not None or copy.yof is not None):
        new_blocks.append(_offset_pos(copy, span))
    new_blocks.extend(_copied(block, copy) for block in span)
    blocks = program.blocks[: number - 1] + tuple(new_blocks) + program.blocks[number:]
    return dataclasses.replace(program, blocks=blocks)


def cancel_copy(program: Program, number: int) -> Program:
    """Remove COPY block `number` without copying anything (CANCEL)."""
    if not isinstance(program.block(number), Copy):
        raise ValueError(f"block {number} is not a COPY")
    return dataclasses.replace(
        program, blocks=program.blocks[: number - 1] + program.blocks[number:]
    )


def resolve_copies(program: Program) -> Program:
    """Carry out every COPY block whose operator chose EXEC or CANCEL, first to last.

    COPY blocks still waiting for the choice stay in place (validation warns about them).
    """
    number = 1
    while number <= len(program.blocks):
        block = program.blocks[number - 1]
        if isinstance(block, Copy) and block.action is CopyAction.EXEC:
            program = execute_copy(program, number)
            continue
        if isinstance(block, Copy) and block.action is CopyAction.CANCEL:
            program = cancel_copy(program, number)
            continue
        number += 1
    return program


def _offset_pos(copy: Copy, span: tuple[Block, ...]) -> Pos:
    """The incremental POS the control puts first when the whole range is incremental."""
    tool = copy.tool
    if tool is None:
        tool = next((b.tool_number for b in span if b.tool_number is not None), 1)
    return Pos(
        mode=Mode.INC,
        units=copy.units,
        x=copy.xof if copy.xof is not None else Decimal(0),
        y=copy.yof if copy.yof is not None else Decimal(0),
        tool=tool,
    )


def _copied(block: Block, copy: Copy) -> Block:
    """One block of the range with the COPY's changes applied."""
    changes: dict[str, Any] = {}
    names = {f.name for f in dataclasses.fields(block)}
    for name in _PLAIN_CHANGES:
        value = getattr(copy, name)
        if value is not None and name in names:
            changes[name] = value
    if copy.op is not None and isinstance(block, Hole | BoltCircle):
        changes["op"] = copy.op
        if isinstance(block, Hole) and copy.op is not HoleOp.DRILL:
            # BORE and TAP take no pecks and no cutter compensation (seed 001 §3.4.5.2).
            changes["pecks"] = 1
            changes["comp"] = Comp.NONE
    final_op = changes.get("op", getattr(block, "op", None))
    if copy.pecks is not None and isinstance(block, Hole) and final_op is HoleOp.DRILL:
        changes["pecks"] = copy.pecks
    if block.mode is Mode.ABS and "x" in names and not isinstance(block, BoltCircle):
        if copy.xof is not None:
            changes["x"] = block.x + copy.xof  # type: ignore[attr-defined]
        if copy.yof is not None:
            changes["y"] = block.y + copy.yof  # type: ignore[attr-defined]
    return dataclasses.replace(block, **changes)
