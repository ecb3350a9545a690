"""The one way MillBlocks remembers what it worked out: bounded, thread-safe memos.

- `Memo`: results by key within a budget of rows (moves), least recently used first out —
  the compile's and the cycle time's per-node results: what a result holds grows with its
  node's moves, so the budget bounds memory, and a result larger than a tenth of the budget
  is not kept (one huge LOOP would push out everything else and is cheap to redo per move
  anyway);
- `Recent`: the last few values by key (parsed documents, blocks read from a document);
- `ByObject`: a value per object by identity (what was worked out for a block object that
  comes back edit after edit).

Facts about a class (its resolved type hints) are worked out once with `functools.cache`:
there are as many as there are classes, so they need no bound.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from typing import Generic, TypeVar

V = TypeVar("V")


class Memo(Generic[V]):
    """Values by key, bounded by `rows` in all (each value's weight is given when put).

    Safe to share between threads (a web server's requests)."""

    def __init__(self, rows: int = 1 << 19) -> None:
        self.budget = rows
        self.held = 0
        self.entries: OrderedDict[object, tuple[V, int]] = OrderedDict()
        self.hits = 0
        self.misses = 0
        self.lock = threading.Lock()

    def get(self, key: object) -> V | None:
        """The value kept for `key` (now the most recently used), or None."""
        with self.lock:
            found = self.entries.get(key)
            if found is None:
                self.misses += 1
                return None
            self.hits += 1
            self.entries.move_to_end(key)
            return found[0]

    def keep(self, key: object, value: V, rows: int) -> None:
        """Keep `value` for `key`, weighing `rows`; not kept when over a tenth of the budget."""
        if rows > self.budget // 10:
            return
        with self.lock:
            if key in self.entries:
                return
            self.entries[key] = (value, rows)
            self.held += rows
            while self.held > self.budget:
                _, (_, dropped) = self.entries.popitem(last=False)
                self.held -= dropped


class Recent(Generic[V]):
    """The last `limit` values kept, by key: the oldest kept goes first, or with `lru` the
    least recently used (a read moves its entry to the end: for the few recent programs a
    request asks for again and again). Reads without `lru` take no lock (a dict read is
    atomic); safe to share between threads."""

    def __init__(self, limit: int, lru: bool = False) -> None:
        self.limit = limit
        self.lru = lru
        self.entries: OrderedDict[object, V] = OrderedDict()
        self.lock = threading.Lock()

    def get(self, key: object) -> V | None:
        if not self.lru:
            return self.entries.get(key)
        with self.lock:
            found = self.entries.get(key)
            if found is not None:
                self.entries.move_to_end(key)
            return found

    def keep(self, key: object, value: V) -> None:
        with self.lock:
            self.entries[key] = value
            self.entries.move_to_end(key)
            while len(self.entries) > self.limit:
                self.entries.popitem(last=False)


class ByObject(Generic[V]):
    """A value per object, by identity (the same block objects come back edit after edit:
    what was worked out for one is looked up without hashing its values). Each entry keeps
    its object alive, so no id in it is reused meanwhile; cleared when `limit` is reached.
    Safe to share between threads."""

    def __init__(self, limit: int = 1 << 15) -> None:
        self.limit = limit
        self.entries: dict[int, tuple[object, V]] = {}
        self.lock = threading.Lock()

    def get(self, obj: object) -> V | None:
        found = self.entries.get(id(obj))
        return found[1] if found is not None and found[0] is obj else None

    def keep(self, obj: object, value: V) -> None:
        with self.lock:
            if len(self.entries) >= self.limit:
                self.entries.clear()
            self.entries[id(obj)] = (obj, value)
