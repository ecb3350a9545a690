"""What may follow what, declared once (issue 32): each kind's `Follows` is the rule that
validation reports, structure groups by and the editor's menus grey.

The rule is worked out here from the declaration's data alone (the JSON types and mill
families it names, the fields the block before must share) for every pair of editor
sub-kinds, and the three readers are asked what they make of that pair: a special case
added to any one of them, or a kind whose declaration says something its readers do not
do, fails here.
"""

from __future__ import annotations

import dataclasses
import enum
import typing
from decimal import Decimal
from typing import Any

import pytest

from app.cnc.blocks import Block, Program
from app.cnc.kinds import REGISTRY, Follows, SubKind, Value
from app.cnc.structure import BoltPattern, LoopPattern, MillSequence, Node, Single, build_nodes
from app.cnc.validate import validate
from app.web.forms import refusal

SAMPLE = {
    Value.LENGTH: Decimal(1),
    Value.FEED: Decimal(10),
    Value.ANGLE: Decimal(0),
    Value.TOOL: 1,
    Value.FLAG: False,
    Value.TEXT: "",
}


def sample(cls: type[Block], sub: SubKind) -> Block:
    """A block of sub-kind `sub` with plain values in range (its fixed ones as it fixes them)."""
    hints = typing.get_type_hints(cls)
    prompts = {f.name: f.prompt for f in REGISTRY.fields(cls)}
    values: dict[str, Any] = {}
    for f in dataclasses.fields(cls):
        if f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING:
            continue
        prompt = prompts[f.name]
        if prompt.value is Value.CHOICE:
            choices = list(typing.get_args(hints[f.name]) or (hints[f.name],))
            enum_type = next(t for t in choices if isinstance(t, type) and issubclass(t, enum.Enum))
            values[f.name] = next(iter(enum_type))
        elif prompt.value is Value.COUNT:
            values[f.name] = prompt.low if isinstance(prompt.low, int) else 1
        else:
            values[f.name] = SAMPLE[prompt.value]
    values.update(dict(sub.fixed))
    return cls(**values)


SUBS = {key: (cls, sub) for key, (cls, sub) in REGISTRY.sub_kinds().items()}
SAMPLES = {key: sample(cls, sub) for key, (cls, sub) in SUBS.items()}
FOLLOWERS = sorted(key for key, block in SAMPLES.items() if REGISTRY.of(block).follows)


def declared(follows: Follows, previous: Block | None, block: Block) -> bool:
    """The rule as its declaration states it."""
    if previous is None:
        return False
    kind = REGISTRY.of(previous)
    names = {d.name for d in kind.documents if all(getattr(previous, n) == v for n, v in d.fixed)}
    named = bool(names & set(follows.after)) or kind.mill in follows.after
    return named and all(getattr(previous, f) == getattr(block, f) for f in follows.same)


def lead_in(key: str) -> tuple[Block, ...]:
    """The shortest run of sample blocks ending in `key`'s sample in which each block meets
    its declared rule (a PKT LINE: DRILL, POCKET, PKT LINE)."""
    runs: list[tuple[Block, ...]] = [
        (block,) for block in SAMPLES.values() if REGISTRY.of(block).follows is None
    ]
    for _ in range(len(SAMPLES)):
        for run in runs:
            if run[-1] is SAMPLES[key]:
                return run
        longer: list[tuple[Block, ...]] = []
        for run in runs:
            for block in SAMPLES.values():
                follows = REGISTRY.of(block).follows
                if follows is not None and declared(follows, run[-1], block):
                    longer.append((*run, block))
        runs = longer
    raise AssertionError(f"no block may stand before {key}")


def _group_of(nodes: tuple[Node, ...], index: int) -> int | None:
    """The first index of the node that holds block `index` (None: left out)."""
    for node in nodes:
        if isinstance(node, Single) and node.index == index:
            return index
        if isinstance(node, BoltPattern) and index in (node.centre, node.bolt):
            return node.centre
        if isinstance(node, MillSequence) and (index == node.drill or index in node.mills):
            return node.drill
        if isinstance(node, LoopPattern):
            found = _group_of(node.body, index)
            if found is not None:
                return found
    return None


def _then(key: str) -> tuple[Block, ...]:
    """The block the editor enters with sub-kind `key` (an XY-CENT's XY-END), if any."""
    then = SUBS[key][1].then
    if then is None:
        return ()
    end_key = next(k for k, (cls, _) in SUBS.items() if cls is then)
    return (SAMPLES[end_key],)


@pytest.mark.parametrize("key", FOLLOWERS)
def test_validation_structure_and_menus_apply_each_declared_order_rule(key: str) -> None:
    block = SAMPLES[key]
    follows = REGISTRY.of(block).follows
    assert follows is not None
    sub = SUBS[key][1]
    for previous_key in [None, *SUBS]:
        previous = None if previous_key is None else SAMPLES[previous_key]
        before = () if previous_key is None else lead_in(previous_key)
        blocks = (*before, block)
        number = len(blocks)
        may = declared(follows, previous, block)
        pair = f"{key} after {previous_key}"

        # Validation: the kind's message, exactly, when the rule fails; never when it holds.
        said = "block " + str(number - 1) + " is " + previous.title if previous else "it is first"
        what = follows.what.format_map(block.__dict__)
        message = follows.message.format(type_name=block.type_name, what=what, before=said)
        found = [
            p.message
            for p in validate(Program(name="order", blocks=(*blocks, *_then(key))))
            if p.block == number and p.rule is follows.rule
        ]
        assert (message in found) is not may, (pair, found)

        # The editor: a sub-kind in a menu is greyed with the same words where the rule
        # fails, if its kind says the menu enforces it (else offered anywhere).
        if sub.menu:
            reason = refusal(Program(name="menu", blocks=blocks[:-1]), number, key)
            refused = follows.in_menu and not may
            assert reason == ("follows " + what if refused else ""), pair

        # Structure: the block is grouped with the block before it exactly when it may
        # follow it (an XY-CENT's next block is its XY-END: that pair rule is the XY-CENT's).
        then = None if previous_key is None else SUBS[previous_key][1].then
        if then is not None and not isinstance(block, then):
            continue
        nodes = build_nodes((*blocks, *_then(key)), tolerant=True)
        group = _group_of(nodes, number - 1)
        together = number >= 2 and group is not None and group == _group_of(nodes, number - 2)
        assert together is may, (pair, nodes)


def test_a_kind_without_an_order_rule_stands_by_itself() -> None:
    """Structure groups a block with the one before only by a declared rule: a block of a
    kind without one (POS, a hole) is a node of its own after any block."""
    for key, block in SAMPLES.items():
        if REGISTRY.of(block).follows is not None or not build_nodes((block,), tolerant=True):
            continue  # a follower, or not motion (REP, COPY)
        for previous_key in SUBS:
            blocks = (*lead_in(previous_key), block)
            nodes = build_nodes(blocks, tolerant=True)
            last = len(blocks) - 1
            assert _group_of(nodes, last) == last, (key, previous_key, nodes)
