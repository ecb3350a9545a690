"""The editor's live preview: the tool path drawn, the cycle time per block.

Kept apart from the editor's entry logic (editor.py) because it is the expensive part of an
edit's reply and has its own measurements (bench/preview.py).

The whole program is drawn and timed as far as it compiles: the compiler leaves out only
what cannot be cut (a mill sequence whose geometry has an error) and says why, so a block
with an error never hides the blocks after it. A block whose values the compile cannot
take (out of range, missing) is left out in its place. Blocks with errors are drawn as
problems (red, with their messages); those with nothing to draw are listed beside the
drawing.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import NamedTuple

from app.cnc.blocks import Copy, Program
from app.cnc.compiler import compile_program
from app.cnc.emit.svg import render
from app.cnc.estimate import estimate
from app.cnc.kinds import REGISTRY
from app.cnc.problems import Problem, Rule, Severity
from app.cnc.validate import validate

# Errors of the program as a whole that leave its compile as it is (a name is not motion).
HARMLESS_RULES = frozenset({Rule.NAME, Rule.PART_NUMBER, Rule.MESSAGE})
# A block in the program's place that makes no motion: a pending COPY (the compiler skips
# it), so the blocks after it keep their numbers.
LEFT_OUT = Copy(from_block=0, to_block=0)


@dataclass(frozen=True, slots=True)
class Shown:
    """What the drawing and the cycle time hold of a program with errors.

    `problems` are the blocks with errors, each with its messages, in block order;
    `not_drawn` those of them with nothing drawn (their motion is left out of the cycle
    time too); `program_errors` the errors that belong to no data block; `drawn` False
    when nothing could be drawn (Data Block 0's values are out of range); `large` when the
    drawing is large enough to be painted on a canvas (static/preview.js).
    """

    problems: tuple[tuple[int, tuple[str, ...]], ...] = ()
    not_drawn: tuple[int, ...] = ()
    program_errors: tuple[str, ...] = ()
    drawn: bool = True
    large: bool = False

    @property
    def complete(self) -> bool:
        """True when nothing has an error: the drawing and the time are the program's."""
        return not self.problems and not self.program_errors

    def messages(self, block: int) -> tuple[str, ...]:
        return dict(self.problems).get(block, ())


class Preview(NamedTuple):
    """The preview of a program: SVG, seconds per block, total seconds, what is shown."""

    svg: str
    per_block: dict[int, float]
    total: float
    shown: Shown


def preview(program: Program, problems: list[Problem] | None = None) -> Preview:
    """Draw and time `program` as far as it compiles (see the module docstring).

    `problems` are the program's own, when the caller has validated it already.
    """
    if problems is None:
        problems = validate(program)
    part = _drawable(program, problems)
    errors = part.errors
    if part.program is None:
        # Data Block 0 (tools, retract, offsets) is in every move: nothing to draw yet.
        return Preview(
            "", {}, 0.0, Shown(part.listed(), tuple(sorted(errors)), part.general, False)
        )
    compiled = compile_program(part.program)
    # Validation does not compile a program with values out of range, so the geometry's
    # own errors (found by the compile of what can be drawn) may be news here.
    for finding in compiled.findings:
        if finding.severity is Severity.ERROR:
            message = _said(finding.field, finding.message)
            if message not in errors.get(finding.block, []):
                errors.setdefault(finding.block, []).append(message)
    path = compiled.path
    drawing = render(
        part.program, path, swept=True, grid=True, embedded_style=False, problems=errors
    )
    result = estimate(path)
    shown = Shown(
        problems=part.listed(),
        not_drawn=tuple(b for b in sorted(errors) if b not in drawing.blocks),
        program_errors=part.general,
        large=drawing.large,
    )
    return Preview(drawing.svg, result.per_block, result.total, shown)


def times(program: Program, problems: list[Problem]) -> tuple[dict[int, float], float]:
    """The cycle time of `program` as the preview times it (seconds per block, total),
    without drawing it: what an edit's reply needs (the drawing follows on its own)."""
    part = _drawable(program, problems)
    if part.program is None:
        return {}, 0.0
    result = estimate(compile_program(part.program).path)
    return result.per_block, result.total


@dataclass
class _Drawable:
    """What of a program can be compiled and drawn: `program` (None: nothing, Data Block 0
    or the program as a whole has errors), the error messages per block, and the errors of
    the program as a whole."""

    program: Program | None
    errors: dict[int, list[str]]
    general: tuple[str, ...]

    def listed(self) -> tuple[tuple[int, tuple[str, ...]], ...]:
        return tuple((b, tuple(m)) for b, m in sorted(self.errors.items()))


def _drawable(program: Program, problems: list[Problem]) -> _Drawable:
    errors: dict[int, list[str]] = {}
    general: list[str] = []
    unsafe: set[int] = set()
    whole = False
    for p in problems:
        if p.severity is not Severity.ERROR:
            continue
        if p.block:
            errors.setdefault(p.block, []).append(_said(p.field, p.message))
            # What the compile itself finds (Kind.findings, the geometry) is compiled as
            # it is: the compile leaves the cut out and the drawing shows where it is. Any
            # other error may mean values the compile cannot take (out of range, missing)
            # or work without bound: such a block is left out of the drawing and listed.
            if p.rule not in REGISTRY.geometry_rules():
                unsafe.add(p.block)
        else:
            general.append(str(p))
            whole = whole or p.rule not in HARMLESS_RULES
    if whole:
        return _Drawable(None, errors, tuple(general))
    drawable = program
    if unsafe:
        blocks = tuple(
            LEFT_OUT if n in unsafe else block for n, block in enumerate(program.blocks, start=1)
        )
        drawable = replace(program, blocks=blocks)
    return _Drawable(drawable, errors, tuple(general))


def _said(field: str | None, message: str) -> str:
    """A block's problem as the drawing says it: `FEEDR Z: 900 ipm is …`."""
    return f"{field}: {message}" if field else message
