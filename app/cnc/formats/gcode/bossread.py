"""Reading a Bridgeport BOSS tape back: the real-time segments joined into one program.

Seed 004 §8.1.1: a program longer than the control's storage is punched in segments. The
main program starts with the rewind stop `%` (b), each segment opens with `#0` and ends
with `$`, each on a line of its own (c; the first may open `%#0` as in b's example), and the
tape ends `M02`, `$`, `$` (g). TLO subroutines (`Tn/`) and macro definitions (`#n … $`)
would lead the tape (a); MillBlocks writes none and reads none: they are refused, naming line
and column, as is anything a segment cannot hold — a `$` or `#` among a line's words, text
between one segment's `$` and the next `#0`, a tape that ends inside a segment (its rest is
missing: importing half a part would be worse than none).

The words between the marks are the G-code reader's (reader.py), G70 inch and G71 metric
(seed 004 §8.2.3-8.3.2): the marks are blanked, not removed, so every line keeps its number
and every message names the line of the tape.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass

from app.cnc.recognition.common import failure, split_lines

_SUBROUTINE = re.compile(r"T(\d+)\s*/")
_MARK = re.compile(r"#(\d*)")


@dataclass(frozen=True)
class Segments:
    """A BOSS tape with its segment marks blanked (line numbers kept), how many main
    program segments it has, and the line each opened on."""

    text: str
    opened: tuple[int, ...]
    ended: bool  # the tape ends `$`, `$` after its last segment (seed 004 §8.1.1 g)


def join_segments(text: str) -> Segments:
    """The program text of a BOSS tape: each `#0` and `$` line blanked (a `%#0` line becomes
    `%`), so the G-code reader reads the segments as one program. Raises ImportFailure
    naming line and column for what seed 004 §8.1.1 does not allow (see the module)."""
    lines = split_lines(text)
    out: list[str] = []
    opened: list[int] = []
    inside: int | None = None  # the line the open segment began on
    closed = 0  # `$` marks after the last segment closed (the tape's end is the second)
    percent = False
    for number, raw in enumerate(lines, start=1):
        line = raw.rstrip()
        stripped = line.lstrip()
        column = len(line) - len(stripped) + 1
        if not stripped:
            out.append(line)
            continue
        if not percent and inside is None:
            _before_main(number, stripped, column)
        if stripped.startswith("%"):
            rest = stripped[1:].strip()
            if percent or inside is not None:
                raise failure(number, column, "a second rewind stop (%): the tape has one")
            percent = True
            if rest == "#0":
                inside = number
                opened.append(number)
            elif rest:
                raise failure(
                    number,
                    column + 1,
                    f"{rest!r} after the rewind stop: only #0 (the first segment) may follow",
                )
            out.append("%")
            continue
        mark = _MARK.match(stripped)
        if mark:
            if mark.group(1) != "0" or stripped != "#0":
                if stripped.startswith("#0"):
                    raise failure(number, column + 2, "#0 opens a segment on a line of its own")
                raise failure(
                    number,
                    column,
                    f"{mark.group(0)}: subroutine and macro definitions are not supported; "
                    "MillBlocks reads main-program segments (#0 … $)",
                )
            if inside is not None:
                raise failure(
                    number,
                    column,
                    f"#0 inside segment {len(opened)} (opened on line {inside}): a segment "
                    "ends with '$' before the next #0",
                )
            if closed > 1:
                raise failure(number, column, "#0 after the tape's end ($, $)")
            inside = number
            closed = 0
            opened.append(number)
            out.append("")
            continue
        dollar = _outside_comments(line, "$")
        if dollar is not None:
            if stripped != "$":
                raise failure(number, dollar + 1, "'$' ends a segment on a line of its own")
            if inside is None and (not opened or closed > 1):
                raise failure(number, column, "'$' with no segment open (#0 opens one)")
            inside = None
            closed += 1
            out.append("")
            continue
        if inside is None and opened and closed < 2:
            raise failure(
                number,
                column,
                "text between segments: after '$' the tape goes on with #0 on a line of "
                "its own (seed 004 §8.1.1 b, c)",
            )
        out.append(line)
    if inside is not None:
        raise failure(
            inside,
            2 if lines[inside - 1].lstrip().startswith("%") else 1,
            f"the tape ends inside segment {len(opened)} (no '$'): the rest of the tape is missing",
        )
    return Segments("\n".join(out), tuple(opened), closed > 1)


def _before_main(number: int, stripped: str, column: int) -> None:
    """A line before the main program (§8.1.1 a: TLO subroutines and macro definitions)."""
    if _SUBROUTINE.match(stripped):
        found = _SUBROUTINE.match(stripped)
        assert found is not None
        raise failure(
            number,
            column,
            f"a TLO subroutine (T{found.group(1)}/) is not supported: Z words on a MillBlocks "
            "tape include each tool's TCAL",
        )


def _outside_comments(line: str, char: str) -> int | None:
    """The index of `char` in `line` outside parenthesised comments, or None."""
    depth = 0
    for k, ch in enumerate(line):
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth = max(0, depth - 1)
        elif ch == char and depth == 0:
            return k
    return None


def looks_segmented(parts: Iterable[str]) -> str:
    """The first line that only a BOSS real-time tape has (`%#0`, a `#0` or a `$` line),
    as `line N: …`, or ''. `parts`: the text in parts, each but the last ending with a
    line feed."""
    number = 0
    for part in parts:
        lines = split_lines(part)
        if part.endswith("\n"):
            lines.pop()  # (the line after this part's last break begins the next part)
        if "#0" not in part and "$" not in part:
            number += len(lines)  # no line here can be one (a G-code file's every part)
            continue
        for raw in lines:
            number += 1
            stripped = raw.strip()
            if stripped.startswith("%") and stripped[1:].strip() == "#0":
                return f"line {number}: %#0, a BOSS tape's first segment"
            if stripped in ("#0", "$"):
                return f"line {number}: {stripped}, a BOSS tape's segment mark"
    return ""
