"""A request from the control: a short file the operator sends from the control's keypad
naming the program it wants, answered by the transfer service with that program (issue 35).

What a request looks like, per control (docs/rs232.md):

- **ProtoTRAK Plus** (events, seed 003 §2.2): a program with its part number and no
  events — `%` / `PN2262 G20;` / `%`. The `PN` word names it.
- **Fanuc and other G-code controls**: a program with its number and a comment and no
  motion — `%` / `O1234 (BRACKET)` / `M30` / `%`. The number is the part number; the first
  comment is the name.

Anything with a motion word (G0-G3, a canned cycle, X/Y/Z, an event G100-G109 past the
header) is a program, not a request: the service receives it as a new program. Pure: no
Flask, database or serial code.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

_COMMENT = re.compile(r"\(([^)]*)\)")
_PART = re.compile(r"(?<![A-Z])PN\s*([0-9]{1,8})", re.IGNORECASE)
_PROGRAM_NUMBER = re.compile(r"(?<![A-Z])O\s*([0-9]{1,8})", re.IGNORECASE)
# Words a request may hold besides its name: sequence numbers, units, program end, the
# events' header words, block ends. Anything else makes it a program.
_ALLOWED = re.compile(
    r"^(?:N\s*[0-9]+|O\s*[0-9]+|PN\s*[0-9]+|G\s*0?(?:20|21|70|71|90)|M\s*0?(?:2|30)|%|;)$",
    re.IGNORECASE,
)
_WORD = re.compile(r"%|;|[A-Z]+\s*[-+]?[0-9.]+", re.IGNORECASE)


@dataclass(frozen=True)
class Request:
    """What the control asked for: a part number and/or a name (either may be empty)."""

    part_number: str
    name: str

    def describe(self) -> str:
        said = [f"part number {self.part_number}"] if self.part_number else []
        said += [f"name {self.name!r}"] if self.name else []
        return " and ".join(said) or "nothing"


def read_request(text: str) -> Request | None:
    """The request in `text` (what came from the control, as text), or None when it is a
    program (it has a motion word) or names nothing."""
    if len(text) > 1_000:
        return None
    comments = [c.strip() for c in _COMMENT.findall(text) if c.strip()]
    bare = _COMMENT.sub(" ", text)
    for line in bare.splitlines():
        rest = line.strip()
        words = _WORD.findall(rest)
        if _WORD.sub("", rest).strip():
            return None  # something that is not a word: not a request
        if not all(_ALLOWED.match(word.replace(" ", "")) for word in words):
            return None
    part = _PART.search(bare) or _PROGRAM_NUMBER.search(bare)
    number = (part.group(1).lstrip("0") or "0") if part else ""
    found = Request(number, comments[0] if comments else "")
    return found if found.part_number or found.name else None
