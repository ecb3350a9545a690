"""Restart at a block: the program from data block N on, for a control that must start again
after a broken tool, a stop or a cut-off transfer (issue 35).

A conversational program restates its modal state in every block — each block names its
tool, feeds and Z levels, and every target starts a program by changing to the first
tool, starting the spindle and approaching at a safe height — so the program from block N
on, with Data Block 0, is the restart, and every target writes it as it writes any
program. What a restart cannot do is begin in the middle of something the control runs
as one unit, or at a position that depends on blocks left out:

- N must begin a unit the control runs on its own: a POS or hole, a bolt circle (its centre
  block), a mill sequence (the DRILL that starts it; a restart inside a contour would cut
  from wherever the tool stands), or a LOOP pattern (its LOOP block; a REP repeats what
  comes before it in its pattern). A block inside one is refused, naming where to restart.
- Block N must be absolute (ABS): an incremental block's position is measured from where
  the block before it left the tool.

Pure: no Flask, database or serial code.
"""

from __future__ import annotations

import dataclasses

from app.cnc.blocks import Program
from app.cnc.structure import BoltPattern, LoopPattern, MillSequence, Node, Single, build_nodes


class RestartError(ValueError):
    """A restart that cannot be made; the message names the block and where to start instead."""


def _first(node: Node) -> int:
    if isinstance(node, Single):
        return node.index
    if isinstance(node, BoltPattern):
        return node.centre
    if isinstance(node, MillSequence):
        return node.drill
    return _first(node.body[0])


def _last(node: Node) -> int:
    if isinstance(node, Single):
        return node.index
    if isinstance(node, BoltPattern):
        return node.bolt
    if isinstance(node, MillSequence):
        return node.mills[-1] if node.mills else node.drill
    return node.rep


def _what(node: Node) -> str:
    if isinstance(node, BoltPattern):
        return "bolt circle"
    if isinstance(node, MillSequence):
        return "mill sequence"
    if isinstance(node, LoopPattern):
        return "LOOP pattern"
    return "block"


def restart_from(program: Program, number: int) -> Program:
    """The program from data block `number` (1-based) on, named "… FROM BLOCK n".

    Raises RestartError when block `number` does not exist, lies inside a bolt circle, mill
    sequence or LOOP pattern (the message names the block to restart at), or is incremental.
    The program must be one validation accepts (its blocks are grouped as the control runs
    them)."""
    count = len(program.blocks)
    if not 1 <= number <= count:
        raise RestartError(f"restart at block {number}: the program has blocks 1 to {count}")
    index = number - 1
    try:
        nodes = build_nodes(program.blocks)
    except ValueError as exc:
        raise RestartError(f"restart at block {number}: the program has errors ({exc})") from None
    for node in nodes:
        first, last = _first(node), _last(node)
        if first < index <= last:
            raise RestartError(
                f"restart at block {number}: it is inside the {_what(node)} of blocks "
                f"{first + 1}-{last + 1}; restart at block {first + 1}, where it begins"
            )
    block = program.blocks[index]
    if block.mode.value == "inc":
        raise RestartError(
            f"restart at block {number}: it is incremental (INC), so where it goes depends on "
            "where the block before it left the tool; restart at an absolute (ABS) block"
        )
    return dataclasses.replace(
        program,
        name=f"{program.name} FROM BLOCK {number}",
        blocks=program.blocks[index:],
    )
