"""The compiler (issue 18): one pass, per block, cached, compact — and total.

What a user would notice if it were wrong:

- an edit answered from the cache must be the program's path, not an older one's
  (a cached node reused where its entry state or its blocks differ would move the tool);
- a LOOP's patterns placed by translation must be the moves the control makes, pattern by
  pattern, and the preview's repetitions must still name them;
- validation is the compile's problems: a program that validates clean exports, and any
  program at all — blocks deleted, swapped, duplicated, ABS/INC flipped — validates
  without a crash (the editor and every import run it on half-finished programs);
- the compact path is small: a program of 10^5 moves that repeats a pattern holds its
  pattern once.
"""

from __future__ import annotations

import dataclasses
from decimal import Decimal

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.cnc.blocks import (
    Block,
    DataBlock0,
    Direction,
    Hole,
    HoleOp,
    MillLine,
    MillQcir,
    Mode,
    Program,
    Tool,
)
from app.cnc.compiler import Cache, compile_program
from app.cnc.formats import canon
from app.cnc.formats.targets import ExportError, export, targets
from app.cnc.interpret import interpret
from app.cnc.path import Op, Run, walk
from app.cnc.problems import Severity
from app.cnc.toolpath import Toolpath
from app.cnc.validate import validate
from tests.imports.support import CASES, load
from tests.strategies import shop_programs

SETTINGS = settings(
    max_examples=120, deadline=None, suppress_health_check=list(HealthCheck), database=None
)


def _dump(program: Program, cache: Cache | None) -> str:
    path = compile_program(program, cache).path
    return canon.dump(path.toolpath())


def test_every_corpus_program_compiles_the_same_cold_and_warm() -> None:
    """A shared cache warmed by every other program changes nothing in any program's path."""
    warm = Cache()
    for case in CASES:
        compile_program(load(case), warm)
    for case in CASES:
        program = load(case)
        assert _dump(program, warm) == _dump(program, Cache()), case.name


@st.composite
def mangled(draw: st.DrawFn) -> Program:
    """A shop program, then broken the ways editing breaks one."""
    program = draw(shop_programs(rpm_optional=True))
    blocks: list[Block] = list(program.blocks)
    for _ in range(draw(st.integers(1, 4))):
        if not blocks:
            break
        k = draw(st.integers(0, len(blocks) - 1))
        action = draw(st.sampled_from(("delete", "swap", "duplicate", "flip")))
        if action == "delete":
            del blocks[k]
        elif action == "swap" and k + 1 < len(blocks):
            blocks[k], blocks[k + 1] = blocks[k + 1], blocks[k]
        elif action == "duplicate":
            blocks.insert(k, blocks[k])
        elif action == "flip" and hasattr(blocks[k], "mode"):
            mode = blocks[k].mode
            flipped = Mode.INC if mode is Mode.ABS else Mode.ABS
            blocks[k] = dataclasses.replace(blocks[k], mode=flipped)
    return dataclasses.replace(program, blocks=tuple(blocks))


@SETTINGS
@given(program=mangled())
def test_any_program_validates_and_compiles_without_a_crash(program: Program) -> None:
    problems = validate(program)
    compiled = compile_program(program, Cache())
    assert all(f.block >= 1 for f in compiled.findings)
    if not any(p.severity is Severity.ERROR for p in problems):
        # What validates clean has a whole tool path, ending in END.
        path = interpret(program)
        assert path.moves[-1].__class__.__name__ == "ProgramEnd"


@SETTINGS
@given(program=shop_programs(rpm_optional=True))
def test_what_validates_clean_exports_or_is_refused_by_name(program: Program) -> None:
    if any(p.severity is Severity.ERROR for p in validate(program)):
        return
    for target in targets():
        try:
            export(program, target)
        except ExportError as refused:
            assert str(refused).strip(), target


@SETTINGS
@given(program=shop_programs(rpm_optional=True), data=st.data())
def test_an_edit_answered_from_the_cache_is_the_edited_programs_path(
    program: Program, data: st.DataObject
) -> None:
    """Compile, change one block's X (or a Data Block 0 value), compile again with the same
    cache: the result is what a cold compile of the edited program gives."""
    cache = Cache()
    compile_program(program, cache)
    blocks = list(program.blocks)
    positioned = [k for k, b in enumerate(blocks) if getattr(b, "x", None) is not None]
    edit_a_block: bool = data.draw(st.booleans())
    if positioned and edit_a_block:
        k: int = data.draw(st.sampled_from(positioned))
        moved = blocks[k].x + Decimal("0.5")  # type: ignore[attr-defined]
        blocks[k] = dataclasses.replace(blocks[k], x=moved)  # type: ignore[call-arg]
        edited = dataclasses.replace(program, blocks=tuple(blocks))
    else:
        block0 = program.block0
        retract = block0.z_retract + Decimal("0.1")
        edited = dataclasses.replace(program, block0=dataclasses.replace(block0, z_retract=retract))
    assert _dump(edited, cache) == _dump(edited, Cache())


def test_a_repeated_pattern_is_held_once() -> None:
    """A LOOP's patterns entered alike are one piece placed by translation: the compiled
    path of a 100-pattern grid holds one pattern's moves, however many it makes."""
    program = next(load(c) for c in CASES if c.name == "loop-rep-grid")
    compiled = compile_program(program, Cache()).path
    runs = [n for n in _nodes(compiled.root) if isinstance(n, Run) and n.rep]
    assert runs, "the LOOP is placed by translation"
    stored = sum(len(n.node.rows) for n in runs if hasattr(n.node, "rows"))
    made = sum(len(chunk.rows) for chunk in walk(compiled.root))
    assert stored < made
    # The walked rows are the materialized moves.
    toolpath: Toolpath = compiled.toolpath()
    assert len(toolpath.moves) == made
    assert sum(1 for chunk in walk(compiled.root) for op in chunk.rows["op"] if op == Op.END) == 1


def _nodes(node: object) -> list[object]:
    found = [node]
    inner = getattr(node, "nodes", None)
    if inner is not None:
        for child in inner:
            found += _nodes(child)
    child = getattr(node, "node", None)
    if child is not None:
        found += _nodes(child)
    return found


def test_a_mill_sequence_with_an_error_is_not_cut_but_located() -> None:
    """A contour whose quarter circle is not one is not cut (the compile's finding says
    why), yet its span is kept, without rows, with the programmed contour up to the bad
    block: the preview draws it in red where it would be instead of leaving it out."""
    tool = Tool(number=1, diameter=Decimal("0.5"), rpm=800, tcal=Decimal(0))
    depth = {"z_dn": Decimal("-0.3"), "feed_xy": Decimal(10), "tool": 1}
    program = Program(
        name="bad arc",
        block0=DataBlock0(current_tool=1, tools=(tool,)),
        blocks=(
            Hole(
                op=HoleOp.DRILL,
                x=Decimal(1),
                y=Decimal(3),
                z_up=Decimal("0.1"),
                z_dn=Decimal("-0.3"),
                feed_z=Decimal(5),
                tool=1,
            ),
            MillLine(x=Decimal(2), y=Decimal(3), **depth),  # type: ignore[arg-type]
            MillQcir(direction=Direction.CCW, x=Decimal(3), y=Decimal("3.5"), **depth),  # type: ignore[arg-type]
        ),
    )
    compiled = compile_program(program, Cache())
    assert any(f.severity is Severity.ERROR and f.block == 3 for f in compiled.findings)
    spans = [m for chunk in compiled.path.chunks() for m in chunk.mills]
    assert len(spans) == 1
    (span,) = spans
    assert span.start == span.end and span.drill == 1
    assert (span.x, span.y) == (25_400_000, 76_200_000)
    assert span.contour() is not None
