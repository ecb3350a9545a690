"""COPY: the editing operation that copies a range of blocks with changes (seed 001 §3.4.6).

COPY exists only while entering a program, and only as a new block at the end. EXEC inserts
the modified copies from the COPY block's number on and removes the COPY block; CANCEL just
removes it. The interpreter never sees a COPY block.
"""

from __future__ import annotations

import dataclasses
from decimal import Decimal
from typing import Any

from app.cnc.blocks import Block, Copy, CopyAction, Mode, Pos, Program
from app.cnc.kinds import REGISTRY, Role
from app.cnc.problems import Rule
from app.cnc.validate import copy_errors


class CopyError(ValueError):
    """A COPY that cannot run; `rule` is COPY_1…COPY_4 and the message is the control's."""

    def __init__(self, block: int, rule: Rule, message: str) -> None:
        super().__init__(f"block {block}: {message}")
        self.block = block
        self.rule = rule
        self.message = message


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
    """One block of the range with the COPY's changes applied, as the declarations say:
    each COPY field names the field it `changes`; a STEP (XOF, YOF) adds to the position of
    an absolute block, the others replace the value in every block that has the field.
    A field that no longer applies afterwards (BORE and TAP take no pecks and no cutter
    compensation, seed 001 §3.4.5.2) goes back to its default."""
    cls = type(block)
    target = {f.name: f for f in REGISTRY.fields(cls)}
    changes: dict[str, Any] = {}
    for change in REGISTRY.fields(Copy):
        value = getattr(copy, change.name)
        name = change.prompt.changes
        if value is None or name not in target:
            continue
        if change.prompt.role in (Role.STEP_X, Role.STEP_Y):
            current = getattr(block, name)
            # An empty X/Y stays empty: calculated from the shifted blocks around it.
            if (
                block.mode is Mode.ABS
                and target[name].prompt.role in (Role.X, Role.Y)
                and current is not None
            ):
                changes[name] = current + value
        else:
            changes[name] = value
    values = {name: changes.get(name, getattr(block, name)) for name in target}
    for name, f in target.items():
        if f.prompt.only_when and not REGISTRY.applies(cls, f, values):
            changes[name] = f.default
    return dataclasses.replace(block, **changes)
