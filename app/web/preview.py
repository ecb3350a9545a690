"""The editor's live preview: the tool path drawn, the cycle time per block.

Kept apart from the editor's entry logic (editor.py) because it is the expensive part of an
edit's reply and has its own measurements (bench/preview.py).
"""

from __future__ import annotations

import dataclasses

from app.cnc.blocks import Program
from app.cnc.emit.svg import draw
from app.cnc.estimate import estimate
from app.cnc.interpret import interpret
from app.cnc.problems import Problem, Severity, has_errors
from app.cnc.validate import validate


def preview(
    program: Program, problems: list[Problem] | None = None
) -> tuple[str, dict[int, float], float, int]:
    """(SVG, seconds per block, total seconds, blocks shown) for the longest valid prefix.

    The search starts before the first block with an error (a prefix cannot be valid past
    it), so a program with an early error costs a few validations, not one per block.
    `problems` are the program's own, when the caller has validated it already.
    """
    if problems is None:
        problems = validate(program)
    errors = [p.block for p in problems if p.severity is Severity.ERROR]
    if any(b is None or b == 0 for b in errors):
        return "", {}, 0.0, 0
    blocks_in_error = [b for b in errors if b is not None]
    shown = min(blocks_in_error) - 1 if blocks_in_error else len(program.blocks)
    while shown >= 0:
        part = dataclasses.replace(program, blocks=program.blocks[:shown])
        if not has_errors(validate(part)):
            toolpath = interpret(part)
            result = estimate(toolpath)
            svg = draw(toolpath, swept=True, grid=True, embedded_style=False)
            return svg, result.per_block, result.total, shown
        shown -= 1
    return "", {}, 0.0, 0
