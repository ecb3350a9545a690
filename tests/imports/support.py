"""Helpers for the import tests: the golden corpus, the seed samples, XY tool paths.

`xy_path` is the comparison the round trips use: every move of the tool path that goes
somewhere in X/Y, in order — a line (rapid or feed) to its end, an arc to its end about its
centre in its direction. Arcs about one centre in one direction that follow each other are
one arc (a 1704 tape splits arcs at the quadrants), so the paths of two programs compare
however their blocks cut the same curve. It is written here, not taken from the importer,
so the tests do not grade the importer with its own arithmetic.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from decimal import Decimal
from functools import cache
from pathlib import Path

from app.cnc import document
from app.cnc.blocks import Block, Circle, Frame, Hole, MillingMode, Placement, Program, Tool
from app.cnc.copy import resolve_copies
from app.cnc.interpret import interpret
from app.cnc.routines import routine_clockwise
from app.cnc.toolpath import ArcFeed, Feed, Rapid, Toolpath

HERE = Path(__file__).parent
GOLDEN = HERE.parent / "golden"
CASES = sorted(p for p in GOLDEN.iterdir() if (p / "program.json").exists())


def load(case: Path) -> Program:
    return resolve_copies(document.loads((case / "program.json").read_text(encoding="utf-8")))


def fixture(name: str) -> bytes:
    return (HERE / name).read_bytes()


def fixture_text(name: str) -> str:
    return (HERE / name).read_text(encoding="utf-8")


@dataclass(frozen=True)
class Seg:
    """One move in XY: `centre` None for a line."""

    end: tuple[int, int]
    centre: tuple[int, int] | None
    clockwise: bool
    rapid: bool


def xy_path(toolpath: Toolpath, shortest: int = 0) -> list[Seg]:
    """The tool path's moves in XY (see the module docstring). A straight move that ends
    no more than `shortest` nm (in X and in Y) from where the last recorded move ended is
    left out: a target that writes numbers in steps of that size cannot write it."""
    segs: list[Seg] = []
    x, y = toolpath.start[0], toolpath.start[1]
    mark = (x, y)
    for move in toolpath.moves:
        if not isinstance(move, Rapid | Feed | ArcFeed):
            continue
        start = (x, y)
        x, y = move.x, move.y
        if isinstance(move, ArcFeed):
            mark = (x, y)
            seg = Seg((x, y), (move.cx, move.cy), move.clockwise, False)
            prev = segs[-1] if segs else None
            if (
                prev is not None
                and prev.centre is not None
                and prev.clockwise == seg.clockwise
                and _near(prev.centre, seg.centre, 100)
                and abs(math.dist(start, prev.centre) - math.dist(seg.end, prev.centre)) < 30_000
                and prev.end == start
            ):
                segs[-1] = Seg(seg.end, prev.centre, seg.clockwise, False)
                continue
            segs.append(seg)
        elif (x, y) != start and not _near(mark, (x, y), shortest):
            segs.append(Seg((x, y), None, False, isinstance(move, Rapid)))
            mark = (x, y)
    return segs


def _near(a: tuple[int, int] | None, b: tuple[int, int] | None, tol: int) -> bool:
    return a is not None and b is not None and abs(a[0] - b[0]) <= tol and abs(a[1] - b[1]) <= tol


def deviation(a: list[Seg], b: list[Seg]) -> int:
    """The largest difference (nm) between matching ends and centres of two XY paths.

    Fails (AssertionError) when the paths do not have the same moves of the same kinds."""
    assert len(a) == len(b), f"{len(a)} moves against {len(b)}"
    worst = 0
    for k, (p, q) in enumerate(zip(a, b, strict=True)):
        where = f"move {k}: {p} against {q}"
        assert (p.centre is None) == (q.centre is None), where
        assert p.rapid == q.rapid, where
        worst = max(worst, abs(p.end[0] - q.end[0]), abs(p.end[1] - q.end[1]))
        if p.centre is not None and q.centre is not None:
            assert p.clockwise == q.clockwise, where
            worst = max(worst, abs(p.centre[0] - q.centre[0]), abs(p.centre[1] - q.centre[1]))
    return worst


def with_rpms(program: Program, rpms: dict[int, int], default: int = 1000) -> Program:
    """`program` with the spindle speeds the user enters for tools the file had none for."""
    tools = tuple(
        t if t.rpm is not None else dataclasses.replace(t, rpm=rpms.get(t.number, default))
        for t in program.block0.tools
    )
    return dataclasses.replace(program, block0=dataclasses.replace(program.block0, tools=tools))


def two_axis(program: Program) -> Program:
    """What a ProtoTRAK Plus events file can carry of `program` (seed 003 §2.2, DESIGN.md §4):
    hole blocks without depths or pecks; IN/TAN and OUT/TAN routines as the INSIDE and
    OUTSIDE the events import makes of a G107/G109 (the Plus uses its own entry); routine
    directions kept, with the milling mode that gives them on a clockwise spindle and tool
    speeds made positive (the events have neither)."""
    db0 = program.block0
    rpms = {t.number: t.rpm for t in db0.tools}
    blocks: list[Block] = []
    milling: MillingMode | None = None
    for k, block in enumerate(program.blocks):
        if isinstance(block, Hole):
            block = dataclasses.replace(block, z_up=None, z_dn=None, feed_z=None, pecks=1)
        elif isinstance(block, Circle | Frame):
            placement = {
                Placement.IN_TAN: Placement.INSIDE,
                Placement.OUT_TAN: Placement.OUTSIDE,
            }.get(block.placement, block.placement)
            drill = program.blocks[k - 1]
            rpm = rpms.get(drill.tool_number or 0)
            clockwise = routine_clockwise(block.placement, db0.milling, rpm)
            milling = next(
                m for m in MillingMode if routine_clockwise(placement, m, None) == clockwise
            )
            block = dataclasses.replace(block, placement=placement)
        blocks.append(block)
    tools = tuple(
        dataclasses.replace(t, rpm=None if t.rpm is None else abs(t.rpm)) for t in db0.tools
    )
    db0 = dataclasses.replace(db0, tools=tools, milling=milling or db0.milling)
    return dataclasses.replace(program, blocks=tuple(blocks), block0=db0)


def speeds(program: Program) -> dict[int, int]:
    return {t.number: abs(t.rpm) for t in program.block0.tools if t.rpm is not None}


@cache
def inch(value: str) -> int:
    """A length in inches as nm."""
    return int(Decimal(value) * 25_400_000)


def tool(number: int, diameter: str | None = None, rpm: int | None = None) -> Tool:
    return Tool(number=number, diameter=None if diameter is None else Decimal(diameter), rpm=rpm)


def path_of(program: Program) -> list[Seg]:
    return xy_path(interpret(program))


def describe(block: Block) -> str:
    """A block in a line, for expected values written by hand: `DRILL X0 Y0 Z0.05/-0.1
    F5 T1`, `BOLT CIR DRILL 5 x R1.125 from 225`, `MILL ARC CC XY-CENT X0 Y0 F8`."""
    from app.cnc.blocks import ArcEnd, BoltCircle, MillArc, MillLine, MillQcir, Pos, Rep

    def n(value: Decimal | None) -> str:
        if value is None:
            return "-"
        text = f"{value.normalize():f}"
        return "0" if text in ("-0", "0") else text

    head = ("INC " if block.mode.value == "inc" else "") + block.title
    if isinstance(block, Hole):
        depth = (
            "" if not block.has_depth else f" Z{n(block.z_up)}/{n(block.z_dn)} F{n(block.feed_z)}"
        )
        pecks = f" x{block.pecks}" if block.pecks > 1 else ""
        return f"{head} X{n(block.x)} Y{n(block.y)}{depth}{pecks} T{block.tool}"
    if isinstance(block, BoltCircle):
        return f"{head} {block.holes} x R{n(block.radius)} from {n(block.angle)}"
    if isinstance(block, Pos):
        return f"{head} X{n(block.x)} Y{n(block.y)} T{block.tool}"
    # Calculated geometry (issue 33), shown only when set.
    extra = "".join(
        f" {label}{n(getattr(block, name))}"
        for name, label in (("radius", "RAD"), ("conrad", "CONRAD"), ("chamfer", "CHAMFER"))
        if getattr(block, name, None) is not None
    ) + (" TANGENT" if getattr(block, "tangent", False) else "")
    if isinstance(block, MillLine | MillQcir | MillArc):
        depth = "" if block.z_dn is None else f" Z{n(block.z_dn)}"
        return f"{head} X{n(block.x)} Y{n(block.y)}{depth} F{n(block.feed_xy)}{extra}"
    if isinstance(block, ArcEnd):
        return f"{head} X{n(block.x)} Y{n(block.y)}{extra}"
    if isinstance(block, Rep):
        return f"{head} X{n(block.x)} Y{n(block.y)} NX{block.nx} NY{block.ny}"
    if isinstance(block, Circle):
        return f"{head} R{n(block.radius)} F{n(block.feed_xy)} T{block.tool}"
    if isinstance(block, Frame):
        size = f"{n(block.xl)} x {n(block.yw)} CR{n(block.corner_radius)}"
        return f"{head} {size} F{n(block.feed_xy)} T{block.tool}"
    return head


def describe_all(program: Program) -> list[str]:
    return [describe(b) for b in program.blocks]
