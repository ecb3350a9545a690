"""What every text target shares: lengths written from integers, lines written out as
they are made, and the one way text becomes a comment (`comment_text`).

`Lengths` writes nanometres with fixed decimals in a unit, rounding half-even exactly as
`units.format_length` does, but from integers: a column of a chunk (numpy) is rounded at
once and each distinct value is formatted once. `Lines` batches text lines into a binary
stream, so a writer's memory holds a few thousand lines, never the file.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache

import numpy as np
import numpy.typing as npt

from app.cnc.formats.targets import Out
from app.cnc.units import Units


class Lengths:
    """Lengths (nm) in `units` with `places` decimals (default: the unit's dump places,
    0.0001 in and 0.001 mm), rounded half-even: `1.2500`, `-0.0010`, `0.0000` (no sign on
    a zero)."""

    def __init__(self, units: Units, places: int | None = None) -> None:
        self.places = units.dump_places if places is None else places
        self.step = units.nm // 10**self.places  # nm in one unit of the last decimal
        assert self.step * 10**self.places == units.nm, "a decimal the unit cannot hold"
        self.one = lru_cache(maxsize=1 << 14)(self._one)

    def digits(self, nm: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
        """`nm` in units of the last decimal, rounded half-even."""
        step = self.step
        q = nm // step
        twice = 2 * (nm - q * step)
        up = (twice > step) | ((twice == step) & (q % 2 == 1))
        rounded: npt.NDArray[np.int64] = q + up
        return rounded

    def _one(self, nm: int) -> str:
        q, r = divmod(nm, self.step)
        if 2 * r > self.step or (2 * r == self.step and q % 2):
            q += 1
        return self.text(q)

    def text(self, digits: int) -> str:
        """A value in units of the last decimal as text."""
        scale = 10**self.places
        whole, part = divmod(abs(digits), scale)
        sign = "-" if digits < 0 else ""
        return f"{sign}{whole}.{part:0{self.places}d}"

    def many(self, nm: npt.NDArray[np.int64]) -> list[str]:
        """A column of lengths as text, each distinct value formatted once."""
        result: list[str] = self.column(nm).tolist()
        return result

    def column(
        self, nm: npt.NDArray[np.int64], shown: Callable[[str], str] | None = None
    ) -> npt.NDArray[np.str_]:
        """A column of lengths as a numpy string array, each distinct value formatted once
        (and passed through `shown`, when given)."""
        if not len(nm):
            return np.array([], dtype=str)
        values, where = np.unique(self.digits(nm), return_inverse=True)
        texts = [self.text(v) for v in values.tolist()]
        if shown is not None:
            texts = [shown(t) for t in texts]
        column: npt.NDArray[np.str_] = np.array(texts, dtype=str)[where]
        return column


class Lines:
    """Text lines written to `out` in batches, each ended by `end`, encoded as `encoding`."""

    def __init__(self, out: Out, end: str = "\n", encoding: str = "ascii") -> None:
        self.out = out
        self.end = end
        self.encoding = encoding
        self.pending: list[str] = []

    def add(self, text: str) -> None:
        self.pending.append(text)
        if len(self.pending) >= 4096:
            self.flush()

    def add_many(self, texts: list[str]) -> None:
        self.pending.extend(texts)
        if len(self.pending) >= 4096:
            self.flush()

    def flush(self) -> None:
        if self.pending:
            text = self.end.join(self.pending) + self.end
            self.out.write(text.encode(self.encoding))
            self.pending = []


END_OF_FILE = frozenset("%")
"""Characters that end a file on the wire: `%` is the end of the record on Fanuc and
ProtoTRAK controls (seed 003 §2.2.3): a receiver stops there and drops the rest."""


def comment_text(text: str, allowed: frozenset[str] | None = None, unknown: str = "?") -> str:
    """`text` as every target writes it inside a comment: one line, upper case ASCII.

    What would end the comment, the block or the file never reaches it: `(` and `)`
    become `[` and `]`, `;` (an end of block) `,`, `%` (END_OF_FILE) and control
    characters (line breaks, NUL, XON/XOFF, ^Z) a space; any other non-ASCII character is
    `unknown`. A target whose comments hold fewer characters names them in `allowed`
    (upper case); the rest become `unknown` too.
    """
    cleaned = text.replace("(", "[").replace(")", "]").replace(";", ",")
    cleaned = "".join(
        " "
        if ch in END_OF_FILE or ord(ch) < 32 or ord(ch) == 127
        else ch
        if ch.isascii()
        else unknown
        for ch in cleaned
    ).upper()
    if allowed is not None:
        cleaned = "".join(ch if ch in allowed else unknown for ch in cleaned)
    return cleaned
