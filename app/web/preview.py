"""The editor's live preview: the tool path drawn, the cycle time per block.

Kept apart from the editor's entry logic (editor.py) because it is the expensive part of an
edit's reply and has its own measurements (bench/preview.py).

The whole program is drawn and timed as far as it compiles: the compiler leaves out only
what cannot be cut (a mill sequence whose geometry has an error) and says why, so a block
with an error never hides the blocks after it. A block whose values the compile cannot
take (out of range, missing) is left out in its place. Blocks with errors are drawn as
problems (red, with their messages); those with nothing to draw are listed beside the
drawing.

An edit draws only the top-level nodes it changed (the others' drawings are kept, svg.py
`render(keep=True)`), and its reply sends only what changed in the drawing (`parts`,
`patch`, below).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace
from typing import NamedTuple

from app.cnc.blocks import Copy, Program
from app.cnc.compiler import compile_program
from app.cnc.estimate import estimate
from app.cnc.formats.svg import render
from app.cnc.kinds import REGISTRY
from app.cnc.path import CompiledPath
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


def preview(
    program: Program,
    problems: list[Problem] | None = None,
    keep: bool = True,
    timed: tuple[dict[int, float], float] | None = None,
) -> Preview:
    """Draw and time `program` as far as it compiles (see the module docstring).

    `problems` are the program's own, when the caller has validated it already. `keep`:
    each top-level node's drawing is kept in this process and drawn from there when it
    comes again (svg.py `render`), so an edit draws what it changed; False draws it all
    afresh (the same text). `timed`: the cycle time `times(program, problems)` gave
    already (seconds per block, total), not worked out again.
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
        part.program,
        path,
        swept=True,
        grid=True,
        embedded_style=False,
        problems=errors,
        keep=keep,
    )
    per_block, total = timed if timed is not None else _timed(path)
    shown = Shown(
        problems=part.listed(),
        not_drawn=tuple(b for b in sorted(errors) if b not in drawing.blocks),
        program_errors=part.general,
        large=drawing.large,
    )
    return Preview(drawing.svg, per_block, total, shown)


def times(program: Program, problems: list[Problem]) -> tuple[dict[int, float], float]:
    """The cycle time of `program` as the preview times it (seconds per block, total),
    without drawing it: what an edit's reply needs (the drawing follows on its own)."""
    part = _drawable(program, problems)
    if part.program is None:
        return {}, 0.0
    return _timed(compile_program(part.program).path)


def _timed(path: CompiledPath) -> tuple[dict[int, float], float]:
    """The cycle time of a compiled path: seconds per block, total."""
    result = estimate(path)
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


# -- an edit's drawing: what changed ------------------------------------------------------------
#
# The page keeps the drawing it shows; an edit's reply carries what differs between it and the
# new version's (static/preview.js applies it). A drawing (app/cnc/formats/svg.py) is an <svg>
# holding up to three containers, in this order: <defs> (the patterns LOOPs place), the page
# <g> (grid, stock, part zero, then each block's drawing in cutting order) and the hole
# numbers' <g>. Each container's children are compared as text: an edit changes a stretch of
# them (the edited block's drawing, and the ones after it when its end point moved them), so
# what differs is the stretch between the first and the last child that differ.

# Every tag of a drawing (the SVG writer's text: no comments, `<` and `>` escaped in text and
# attribute values).
_TAG = re.compile(r"<(/?)[^>]*>")
CONTAINERS = ("defs", "page", "order")


def _container(open_tag: str) -> str:
    """Which container an element of the drawing's top level is (ValueError: none)."""
    if open_tag == "<defs>":
        return "defs"
    for name in ("page", "order"):
        if open_tag.startswith(f'<g class="{name}"'):
            return name
    raise ValueError(f"a drawing's top level holds {open_tag[:40]!r}, not a container")


@dataclass(frozen=True, slots=True)
class Parts:
    """A drawing split for comparing: the <svg> open tag and, by name, each container's open
    tag and children's texts (in order)."""

    head: str
    containers: dict[str, tuple[str, tuple[str, ...]]]


def parts(svg: str) -> Parts:
    """Split a drawing's text (ValueError: not a drawing as svg.py writes one)."""
    tags = _TAG.finditer(svg)
    root = next(tags, None)
    if root is None or not root.group(0).startswith("<svg "):
        raise ValueError("not an <svg> drawing")
    containers: dict[str, tuple[str, tuple[str, ...]]] = {}
    depth = 1
    open_tag = ""
    children: list[str] = []
    start = 0
    for tag in tags:
        end = tag.end()
        if tag.group(1):  # a closing tag
            depth -= 1
            if depth == 2:
                children.append(svg[start:end])
            elif depth == 1:
                containers[_container(open_tag)] = (open_tag, tuple(children))
            elif depth == 0:
                break
        elif svg[end - 2] == "/":  # an empty element
            if depth == 2:
                children.append(tag.group(0))
            elif depth == 1:
                raise ValueError(f"an empty element {tag.group(0)!r} at a drawing's top level")
        else:
            if depth == 1:
                open_tag, children = tag.group(0), []
            elif depth == 2:
                start = tag.start()
            depth += 1
    if depth != 0:
        raise ValueError("a drawing not closed")
    return Parts(root.group(0), containers)


@dataclass(frozen=True, slots=True)
class Change:
    """One container's change: children `at`…`at + drop` (the page's) give way to `items`
    (the new drawing's), and the container's open tag becomes `open_tag`; `gone` when the
    new drawing has no such container (a new one is `at` 0, `drop` 0)."""

    name: str
    open_tag: str
    at: int = 0
    drop: int = 0
    items: tuple[str, ...] = ()
    gone: bool = False

    @property
    def tagged(self) -> str:
        """The open tag with where the change goes (`data-at`, `data-drop`)."""
        if self.gone:
            return self.open_tag[:-1] + ' data-gone="1">'
        return self.open_tag[:-1] + f' data-at="{self.at}" data-drop="{self.drop}">'

    @property
    def close_tag(self) -> str:
        return "</defs>" if self.name == "defs" else "</g>"


@dataclass(frozen=True, slots=True)
class Patch:
    """What turns one drawing into another: the new <svg> open tag (its extent, the
    viewBox, changes with the program's) and the containers' changes."""

    head: str
    changes: tuple[Change, ...]


def patch(old: Parts, new: Parts) -> Patch:
    """What turns drawing `old` into `new`: per container, the stretch of children that
    differs (none for a container that is the same), in container order."""
    found = []
    for name in CONTAINERS:
        was, now = old.containers.get(name), new.containers.get(name)
        if now is None:
            if was is not None:
                found.append(Change(name, was[0], gone=True))
            continue
        open_tag, items = now
        before = was[1] if was is not None else ()
        if was is not None and was[0] == open_tag and before == items:
            continue
        same = min(len(before), len(items))
        head = 0
        while head < same and before[head] == items[head]:
            head += 1
        tail = 0
        while tail < same - head and before[-1 - tail] == items[-1 - tail]:
            tail += 1
        found.append(
            Change(name, open_tag, head, len(before) - head - tail, items[head : len(items) - tail])
        )
    return Patch(new.head, tuple(found))
