"""Process rules: what a machinist checks before the first chip, read from the compiled path.

Two rules that need no simulation, so `check` and the editor report them as the blocks are
typed, and Verify reports the same problems as findings (one rule, one place):

- **Pilot.** A TAP or BORE needs a hole already there: an earlier DRILL, BORE or TAP at the
  same point, smaller than this tool and at least as deep, or a pocket (CIRCLE/FRAME
  POCKET, an irregular POCKET) already cleared to that depth around the point. A tap
  driven into solid metal breaks; a boring bar plunged into it does too. Earlier means an
  earlier block: within a LOOP the patterns' own order does not matter, since a pilot
  drilled at the same point by a later pattern is still a later block's hole only when
  the blocks say so.
- **Below the stock.** With the program's own stock, no move goes lower than the stock's
  bottom less its CLEAR (the parallels' height): deeper is the vise, the parallels or the
  table. A through hole is declared by giving the stock that room.

Both are warnings: the program can still run (a tapped hole's pilot may come from an earlier
set-up), but the programmer must look. Lengths in nm inside, printed in the program's units.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass

from app.cnc.blocks import (
    HoleOp,
    Placement,
    Program,
)
from app.cnc.compiler import Compiled
from app.cnc.memo import Memo
from app.cnc.path import (
    HOLE_OPS,
    CompiledPath,
    Node,
    Run,
    Seq,
    lowest_by_block,
    pieces,
    placed_holes,
    placed_mills,
    size,
)
from app.cnc.problems import Problem, Rule, Severity
from app.cnc.routines import routine_outline
from app.cnc.units import Units, format_length

# Two holes this close (nm) are at the same point: half the finest step a program can type
# (0.001 mm), far below any drill's wander.
SAME_POINT = 500


@dataclass(frozen=True, slots=True)
class PlacedHole:
    """A hole where it is cut: `block` (the TAP block, or the BOLT CIR that placed it),
    the operation, (x, y) and `bottom` (Z DN) in nm, and its tool's diameter (None: not
    given in Data Block 0)."""

    block: int
    op: HoleOp
    x: int
    y: int
    bottom: int
    diameter: int | None


@dataclass(frozen=True, slots=True)
class Cleared:
    """An area a mill sequence clears to `depth` before block `block` is cut: `outline`
    (float nm, a closed polygon) with nothing left inside."""

    block: int
    outline: tuple[tuple[float, float], ...]
    depth: int


def placed_hole_list(path: CompiledPath) -> list[PlacedHole]:
    """Every hole of the compiled program in cutting order (LOOP patterns and bolt circles
    placed), each with its tool's diameter (the compiled hole's own tool)."""
    found: list[PlacedHole] = []
    for block, op, x, y, bottom, tool in _holes_placed(path.root):
        info = path.tools.get(tool)
        diameter = None if info is None else info.diameter
        found.append(PlacedHole(block, HOLE_OPS[op], x, y, bottom, diameter))
    return found


Hole = tuple[int, int, int, int, int, int]  # block, op, x, y, bottom, tool
# Each compiled top-level node's holes as it was compiled (blocks relative to it, not
# placed), by node: the compile keeps the nodes of the blocks an edit left alone (its
# per-node memo), so an edit reads the holes of the node it changed, not every piece's
# arrays again. Weighed by the node's moves, so the nodes it keeps alive stay bounded.
_NODE_HOLES: Memo[tuple[Node, list[Hole]]] = Memo()


def _holes_placed(root: Node) -> Iterator[Hole]:
    """(block, op, x, y, bottom, tool) of every hole under `root`, placed, in cutting
    order."""
    tops = root.nodes if isinstance(root, Seq) else [root]
    for top in tops:
        if not (isinstance(top, Run) and len(top.offsets) == 1):
            yield from _hole_rows(top)
            continue
        dx, dy = top.offsets[0].tolist()
        base = top.base
        for block, op, x, y, bottom, tool in _node_holes(top.node):
            yield block + base, op, x + dx, y + dy, bottom, tool


def _node_holes(node: Node) -> list[Hole]:
    kept = _NODE_HOLES.get(id(node))
    if kept is not None and kept[0] is node:
        return kept[1]
    found = list(_hole_rows(node))
    _NODE_HOLES.keep(id(node), (node, found), size(node) + 1)
    return found


def _hole_rows(node: Node) -> Iterator[Hole]:
    for blocks, holes in placed_holes(node):
        yield from zip(
            blocks.tolist(),
            holes["op"].tolist(),
            holes["x"].tolist(),
            holes["y"].tolist(),
            holes["bottom"].tolist(),
            holes["tool"].tolist(),
            strict=True,
        )


def cleared_areas(path: CompiledPath) -> list[Cleared]:
    """The pockets the program clears, where each is cut (CIRCLE/FRAME POCKET routines and
    irregular POCKETs; a sequence whose plan has errors clears nothing), from the outlines
    the compile planned."""
    # The pocket engine (and pyclipper) is loaded here, not by every validation.
    from app.cnc.pocketing.regions import path_points

    found: list[Cleared] = []
    for mill in placed_mills(path.root):
        if not mill.routine or mill.start == mill.end or mill.depth is None:
            continue
        shape = mill.shape()
        outlines = dict(mill.outlines())
        if "boundary" in outlines:
            outline = outlines["boundary"]
        elif shape is not None and shape.placement is Placement.POCKET:
            outline = routine_outline(shape)
        else:
            continue
        found.append(Cleared(mill.routine, tuple(path_points(outline, 2_000)), mill.depth))
    return found


def in_ring(outline: Sequence[tuple[float, float]], x: float, y: float) -> bool:
    """Whether the closed polygon `outline` holds the point (even-odd)."""
    inside = False
    for (ax, ay), (bx, by) in zip(outline, [*outline[1:], *outline[:1]], strict=True):
        if (ay > y) != (by > y) and x < ax + (y - ay) * (bx - ax) / (by - ay):
            inside = not inside
    return inside


def _length(nm: int, units: Units) -> str:
    return f"{format_length(nm, units)} {units.symbol}"


def _at(hole: PlacedHole, units: Units) -> str:
    return f"X {format_length(hole.x, units)} Y {format_length(hole.y, units)}"


def pilot_problems(program: Program, compiled: Compiled) -> list[Problem]:
    """A TAP or BORE with no smaller, deep enough hole or cleared pocket before it at its
    point: one warning per block (a bolt circle's holes counted), naming the first."""
    path = compiled.path
    units = program.units
    # Asked of the pieces first: a long CAM file drills 10^5 holes, and a list of them
    # takes about 330 bytes a hole (80 MB for a 10^6-line file's), for nothing to pilot.
    # A placement does not change a hole's operation, so each piece is read once, not once
    # per LOOP pattern (0.3 s for a 10^5-line file's nested LOOPs).
    drill = HOLE_OPS.index(HoleOp.DRILL)
    if all((piece.holes["op"] == drill).all() for piece in pieces(path.root)):
        return []
    holes = placed_hole_list(path)
    # The pockets are drawn only for a hole that no earlier hole pilots (the usual
    # program has none).
    cleared: list[Cleared] | None = None
    # Earlier holes by point, on a lattice of SAME_POINT cells (a point's neighbours too).
    by_cell: dict[tuple[int, int], list[PlacedHole]] = {}
    for hole in holes:
        by_cell.setdefault((hole.x // SAME_POINT, hole.y // SAME_POINT), []).append(hole)
    # Per block: (count, first hole, why) of its holes without a pilot.
    faults: dict[int, tuple[int, PlacedHole, str, str | None]] = {}
    for hole in holes:
        if hole.op is HoleOp.DRILL:
            continue
        cx, cy = hole.x // SAME_POINT, hole.y // SAME_POINT
        before = [
            other
            for i in (-1, 0, 1)
            for j in (-1, 0, 1)
            for other in by_cell.get((cx + i, cy + j), ())
            if other.block < hole.block
            and abs(other.x - hole.x) <= SAME_POINT
            and abs(other.y - hole.y) <= SAME_POINT
        ]
        why, field = _no_pilot(hole, before, units)
        if not why:
            continue
        if cleared is None:
            cleared = cleared_areas(path)
        if any(
            area.block < hole.block
            and area.depth <= hole.bottom
            and in_ring(area.outline, hole.x, hole.y)
            for area in cleared
        ):
            continue
        count, first, first_why, first_field = faults.get(hole.block, (0, hole, why, field))
        faults[hole.block] = (count + 1, first, first_why, first_field)
    problems = []
    for block, (count, first, why, field) in sorted(faults.items()):
        what = first.op.value
        many = f"{count} {what} holes; the first, " if count > 1 else ""
        problems.append(
            Problem(
                block,
                field,
                Severity.WARNING,
                f"{many}{what} at {_at(first, units)}: {why}",
                Rule.PILOT,
            )
        )
    return problems


def _no_pilot(hole: PlacedHole, before: list[PlacedHole], units: Units) -> tuple[str, str | None]:
    """Why the holes `before` (earlier, at the same point) are no pilot for `hole`, and the
    field to change; ("", None) when one of them is."""
    tool = "tap" if hole.op is HoleOp.TAP else "boring bar"
    if not before:
        depth = format_length(hole.bottom, units)
        return (
            f"nothing is drilled there before it, so the {tool} goes into solid material; "
            f"drill a smaller hole there first, at least to Z DN {depth}",
            None,
        )
    smaller = [
        h
        for h in before
        if h.diameter is None or hole.diameter is None or h.diameter < hole.diameter
    ]
    if not smaller:
        widest = before[-1]
        assert widest.diameter is not None and hole.diameter is not None
        return (
            f"the hole of block {widest.block} there ({_length(widest.diameter, units)}) is "
            f"not smaller than this tool ({_length(hole.diameter, units)}), so the {tool} "
            "cuts nothing; drill the pilot with a smaller drill",
            None,
        )
    deepest = min(smaller, key=lambda h: h.bottom)
    if deepest.bottom > hole.bottom:
        depth = format_length(hole.bottom, units)
        return (
            f"goes to Z DN {depth}, {_length(deepest.bottom - hole.bottom, units)} below the "
            f"bottom of the hole of block {deepest.block} there (Z DN "
            f"{format_length(deepest.bottom, units)}), so the {tool} bottoms in solid "
            f"material; drill deeper first, or {'tap' if hole.op is HoleOp.TAP else 'bore'} "
            "shallower",
            "Z DN",
        )
    return "", None


def below_stock_problems(program: Program, compiled: Compiled) -> list[Problem]:
    """Moves below the bottom of the program's own stock, past its CLEAR: one warning per
    block, with how far. Nothing without a stock (one sized from the program holds every
    cut)."""
    stock = program.stock
    if stock is None:
        return []
    # The simulation's stock (and its segment arrays) loads with a program that has a
    # stock, not with every validation (issue 31.3).
    from app.cnc.simulate.stock import stock_box

    units = program.units
    box = stock_box(stock, units)
    bottom, room = box.bottom, box.clear
    floor = bottom - room
    problems = []
    for block, low in sorted(lowest_by_block(compiled.path.root).items()):
        if low >= floor or block <= 0:
            continue
        under = f", {_length(room, units)} of room under it" if room else ""
        advice = (
            "more than the room under it: cut shallower or give the stock more CLEAR"
            if room
            else "into the vise, the parallels or the table: cut shallower, or give the "
            "stock its CLEAR (the parallels' height) for a through cut"
        )
        problems.append(
            Problem(
                block,
                "Z DN",
                Severity.WARNING,
                f"cuts to Z {format_length(low, units)}, {_length(bottom - low, units)} below "
                f"the stock's bottom (Z {format_length(bottom, units)}{under}): {advice}",
                Rule.BELOW_STOCK,
            )
        )
    return problems


def process_problems(program: Program, compiled: Compiled) -> list[Problem]:
    """Both process rules' warnings, in block order."""
    found = pilot_problems(program, compiled) + below_stock_problems(program, compiled)
    return sorted(found, key=lambda p: p.block or 0)
