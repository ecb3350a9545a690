"""The interpreter's front door: a validated Program becomes its Toolpath of move objects.

The work is the compiler's (compiler.py: the readings of seed 001 §3.4.5 and DESIGN.md §3
are listed there); this gives the consumers that want every move as an object at once —
small programs, tests, importers' round trips — the compiled path materialized. Consumers
of large programs walk `compile_program(program).path.chunks()` instead.
"""

from __future__ import annotations

from app.cnc.blocks import Program
from app.cnc.compiler import compile_program, peck_levels, retract_height
from app.cnc.problems import Severity
from app.cnc.toolpath import Toolpath

__all__ = ["InterpretError", "interpret", "peck_levels", "retract_height"]


class InterpretError(ValueError):
    """The program asks for motion that cannot be produced (names the block)."""

    def __init__(self, block: int, message: str) -> None:
        super().__init__(f"block {block}: {message}")
        self.block = block
        self.message = message


def interpret(program: Program) -> Toolpath:
    """The tool path of a validated program (a pending COPY block is skipped).

    Raises InterpretError naming the first block whose geometry cannot be cut (a mill
    sequence or routine with an error `validate` reports): a tool path with a piece missing
    must not reach a machine.
    """
    compiled = compile_program(program)
    for finding in compiled.findings:
        if finding.severity is Severity.ERROR:
            raise InterpretError(
                finding.block,
                f"the mill sequence cannot be cut (validate first): {finding.message}",
            )
    return compiled.path.toolpath()
