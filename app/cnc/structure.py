"""How the flat list of data blocks groups into the units the control runs.

A program is a sequence of nodes: a single block, a bolt circle (centre block + BOLT CIR),
a mill sequence (the DRILL that starts it + its mill blocks), or a LOOP…REP pattern whose
body is itself a sequence of nodes (nesting up to four deep). The grouping assumes a
program that validation accepted; `validate` reports what would make it ambiguous.
Block indexes here are 0-based positions in `Program.blocks`.
"""

from __future__ import annotations

from dataclasses import dataclass

from app.cnc.blocks import Block, Copy, Rep
from app.cnc.kinds import REGISTRY, Mill
from app.cnc.memo import Recent


@dataclass(frozen=True, slots=True)
class Single:
    """One block run on its own (POS, a hole)."""

    index: int


@dataclass(frozen=True, slots=True)
class BoltPattern:
    """A standard hole block giving the centre and parameters, and its BOLT CIR block."""

    centre: int
    bolt: int


@dataclass(frozen=True, slots=True)
class MillSequence:
    """The DRILL that sets the depth and the mill blocks cut at that depth."""

    drill: int
    mills: tuple[int, ...]


@dataclass(frozen=True, slots=True)
class LoopPattern:
    """LOOP … REP: `body` starts with the LOOP block's own node; `rep` is the REP index."""

    body: tuple[Node, ...]
    rep: int


Node = Single | BoltPattern | MillSequence | LoopPattern


def is_mill(block: Block) -> bool:
    """True for a MILL line, quarter circle, arc (either block), circle, frame or pocket."""
    return block.KIND.mill in CUTS


CUTS = (Mill.CONTOUR, Mill.ROUTINE)


def starts_mill_sequence(blocks: tuple[Block, ...], index: int) -> bool:
    """True when block `index` is followed by a mill block whose order rule it meets (a
    DRILL, which stays at Z DN) and is not itself one of a sequence's blocks."""
    if index + 1 >= len(blocks) or blocks[index].KIND.mill is not None:
        return False
    nxt = blocks[index + 1]
    return nxt.KIND.mill in CUTS and REGISTRY.joins(blocks[index], nxt)


def mill_sequence_end(blocks: tuple[Block, ...], drill: int) -> int:
    """The index after the last mill block of the sequence started at `drill`: each block
    after the first that meets its order rule after the one before (Kind.follows) is one
    of the sequence. That makes one CIRCLE/FRAME routine, a POCKET and its contour blocks,
    or a run of line, quarter-circle and arc blocks; the head retracts at its end.
    """
    end = drill + 2
    while end < len(blocks) and REGISTRY.joins(blocks[end - 1], blocks[end]):
        end += 1
    return end


def build_nodes(blocks: tuple[Block, ...], *, tolerant: bool = False) -> tuple[Node, ...]:
    """Group a validated program's blocks into nodes. COPY blocks are not motion: skipped.

    Raises ValueError for a program validation refuses — unless `tolerant`: then what can
    run still groups into nodes (a REP without its LOOP and a block that cannot stand where
    it is are left out, a LOOP without its REP runs once), so a program with errors still
    shows what it can (the errors are validation's to report).
    """
    key = (id(blocks), tolerant)
    kept = _GROUPED.get(key)
    if kept is not None and kept[0] is blocks:
        return kept[1]
    nodes, index = _sequence(blocks, 0, inside_loop=False, tolerant=tolerant)
    if index != len(blocks):
        raise ValueError(f"block {index + 1}: REP without LOOP (validate first)")
    _GROUPED.keep(key, (blocks, nodes))
    return nodes


# The last programs' nodes, by their blocks' tuple (the entry keeps it alive, so its id is
# not reused): an edit's version is grouped by its cost and again by its compile.
_GROUPED: Recent[tuple[tuple[Block, ...], tuple[Node, ...]]] = Recent(8)


def _sequence(
    blocks: tuple[Block, ...], index: int, *, inside_loop: bool, tolerant: bool
) -> tuple[tuple[Node, ...], int]:
    nodes: list[Node] = []
    while index < len(blocks):
        block = blocks[index]
        if isinstance(block, Rep):
            if inside_loop:
                return tuple(nodes), index
            if tolerant:
                index += 1
                continue
            raise ValueError(f"block {index + 1}: REP without LOOP (validate first)")
        if block.loop:
            head, after_head = _node(blocks, index, tolerant)
            body, rep = _sequence(blocks, after_head, inside_loop=True, tolerant=tolerant)
            if rep >= len(blocks):
                if not tolerant:
                    raise ValueError(f"block {index + 1}: LOOP without REP (validate first)")
                nodes += [n for n in (head, *body) if n is not None]
                return tuple(nodes), rep
            if head is not None:
                nodes.append(LoopPattern(body=(head, *(n for n in body if n is not None)), rep=rep))
            index = rep + 1
            continue
        if isinstance(block, Copy):
            index += 1
            continue
        node, index = _node(blocks, index, tolerant)
        if node is not None:
            nodes.append(node)
    return tuple(nodes), index


def _node(blocks: tuple[Block, ...], index: int, tolerant: bool = False) -> tuple[Node | None, int]:
    """The node that starts at `index` (ignoring a LOOP qualifier on it) and the next index;
    None (tolerant) for a block that cannot run where it is."""
    block = blocks[index]
    nxt = blocks[index + 1] if index + 1 < len(blocks) else None
    if starts_mill_sequence(blocks, index):
        end = mill_sequence_end(blocks, index)
        mills = tuple(range(index + 1, end))
        if tolerant:
            # An arc without its XY-END (the block its editor sub-kind enters with it):
            # the blocks before it run.
            for k, i in enumerate(mills):
                then = REGISTRY.sub_kind_of(blocks[i]).then
                if then is not None and (i + 1 >= end or not isinstance(blocks[i + 1], then)):
                    mills = mills[:k]
                    break
            if not mills:
                return Single(index=index), end
        return MillSequence(drill=index, mills=mills), end
    if (
        nxt is not None
        and not nxt.loop
        and REGISTRY.of(block).follows is None
        and REGISTRY.of(nxt).mill is None
        and REGISTRY.joins(block, nxt)
    ):
        # A block that stands by itself and the one that follows it: a BOLT CIR's centre.
        return BoltPattern(centre=index, bolt=index + 1), index + 2
    if REGISTRY.of(block).follows is not None:
        # A block that follows another (a mill block, an XY-END, a BOLT CIR) where that
        # other is not: validation says so; what can run still runs (`tolerant`).
        if tolerant:
            return None, index + 1
        raise ValueError(
            f"block {index + 1}: {block.type_name} where it cannot stand (validate first)"
        )
    return Single(index=index), index + 1
