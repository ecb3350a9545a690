"""Block-level differences between two versions of a program, in the control's words.

Used for revision summaries ("block 3 DRILL: Z DN -0.5 → -0.6"), for the message of a
refused stale save, and for the diff between two revisions.
"""

from __future__ import annotations

import dataclasses
import difflib
import enum
import threading
from collections.abc import Sequence
from decimal import Decimal
from typing import Any

from app.cnc.blocks import Block, DataBlock0, Program, Stock, field_label
from app.cnc.kinds import REGISTRY
from app.cnc.memo import ByObject
from app.cnc.units import Units


def _show(value: Any) -> str:
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, enum.Enum):
        return str(value.value)
    if isinstance(value, Decimal):
        return f"{value:f}"
    return str(value)


def _key(block: Block) -> tuple[Any, ...]:
    return (type(block).__name__, *(getattr(block, f.name) for f in REGISTRY.fields(type(block))))


# Each distinct block content as a small number (`_tokens`), and each block object's number
# (two versions of a program share most of their block objects: the key of each is made
# once). Cleared when full; a clear happens only between two diffs' numberings.
TOKENS = 1 << 15
_BY_KEY: dict[tuple[Any, ...], int] = {}
_BY_OBJECT: ByObject[int] = ByObject(TOKENS)
_LOCK = threading.Lock()


def _tokens(old: Sequence[Block], new: Sequence[Block]) -> tuple[list[int], list[int]]:
    """The blocks of two versions as numbers, equal where their keys are equal: what the
    sequence matcher compares (the same matches as comparing the keys, without hashing
    every block's values on every save)."""
    with _LOCK:
        if len(_BY_KEY) + len(old) + len(new) > TOKENS:
            _BY_OBJECT.entries.clear()
            _BY_KEY.clear()
        return [_token(b) for b in old], [_token(b) for b in new]


def _token(block: Block) -> int:
    token = _BY_OBJECT.get(block)
    if token is None:
        token = _BY_KEY.setdefault(_key(block), len(_BY_KEY))
        _BY_OBJECT.keep(block, token)
    return token


def field_changes(old: Any, new: Any) -> list[str]:
    """`LABEL old → new` for each dataclass field that differs (same class assumed)."""
    changes = []
    for f in dataclasses.fields(old):
        a, b = getattr(old, f.name), getattr(new, f.name)
        if a != b and f.name != "tools":
            changes.append(f"{field_label(old, f.name)} {_show(a)} → {_show(b)}")
    return changes


def _tool_changes(old: DataBlock0, new: DataBlock0) -> list[str]:
    changes = []
    before = {t.number: t for t in old.tools}
    after = {t.number: t for t in new.tools}
    for number in sorted(set(before) | set(after)):
        a, b = before.get(number), after.get(number)
        if a is None:
            changes.append(f"tool {number} added")
        elif b is None:
            changes.append(f"tool {number} removed")
        elif a != b:
            changes.append(f"tool {number}: " + ", ".join(field_changes(a, b)))
    return changes


def _length(value: Decimal) -> str:
    return f"{value.normalize():f}"


def _stock(stock: Stock | None, program: Program) -> str:
    """The stock as the History reads it: its size, then where its corner and top are."""
    if stock is None:
        return "none (sized from the program's extent)"
    unit = "in" if program.units is Units.INCH else "mm"
    size = " × ".join(_length(v) for v in (stock.xl, stock.yw, stock.zh))
    corner = ", ".join(f"{k} {_length(v)}" for k, v in (("X", stock.x), ("Y", stock.y)))
    return f"{size} {unit} at {corner}, Z TOP {_length(stock.z)}"


def diff(old: Program, new: Program) -> list[str]:
    """What changed from `old` to `new`, one line per change, block numbers as in `new`."""
    lines: list[str] = []
    for name, label in (("name", "name"), ("part_number", "part number"), ("notes", "notes")):
        a, b = getattr(old, name), getattr(new, name)
        if a != b:
            lines.append(f"{label}: {a!r} → {b!r}")
    if old.units != new.units:
        lines.append(f"units: {old.units.value} → {new.units.value}")
    if old.stock != new.stock:
        lines.append(f"stock: {_stock(old.stock, old)} → {_stock(new.stock, new)}")
    if old.block0 != new.block0:
        details = field_changes(old.block0, new.block0) + _tool_changes(old.block0, new.block0)
        lines.append("Data Block 0: " + "; ".join(details))
    a_keys, b_keys = _tokens(old.blocks, new.blocks)
    matcher = difflib.SequenceMatcher(a=a_keys, b=b_keys, autojunk=False)
    for op, i1, i2, j1, j2 in matcher.get_opcodes():
        if op == "equal":
            continue
        pairs = min(i2 - i1, j2 - j1) if op == "replace" else 0
        for k in range(pairs):
            a, b = old.blocks[i1 + k], new.blocks[j1 + k]
            if type(a) is type(b):
                lines.append(f"block {j1 + k + 1} {b.title}: " + ", ".join(field_changes(a, b)))
            else:
                lines.append(f"block {j1 + k + 1}: {a.title} replaced by {b.title}")
        for k in range(i1 + pairs, i2):
            lines.append(f"block {k + 1} {old.blocks[k].title} deleted (old numbering)")
        for k in range(j1 + pairs, j2):
            lines.append(f"block {k + 1} {new.blocks[k].title} added")
    return lines


def summary(old: Program | None, new: Program, limit: int = 4) -> str:
    """A one-line summary of a save for the revision list."""
    if old is None:
        return f"created with {len(new.blocks)} blocks"
    changes = diff(old, new)
    if not changes:
        return "saved without changes"
    shown = "; ".join(changes[:limit])
    more = f"; and {len(changes) - limit} more" if len(changes) > limit else ""
    return shown + more
