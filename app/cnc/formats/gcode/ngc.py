"""LinuxCNC's O-word subroutines and control flow, Fanuc M98/M99 subprograms, parameters and
expressions: run, and expanded into the plain lines the G-code reader reads.

`reader.py` runs this front end only for a file that needs it: it reads a file straight
until a line has a `#`, a `[`, an O-word or an M98, and then reads it again from the start
with this; every other file keeps the reader's fast path.
`expand` executes the file as LinuxCNC's interpreter (src/emc/rs274ngc, read from its
sources: interp_read.cc, interp_o_word.cc, interp_execute.cc, interp_namedparams.cc) and
yields each line it runs, in the order it runs them, with every parameter and expression
replaced by its value and the O-word and parameter-setting lines taken out. Each `Line`
keeps the file's line number and the column each of its characters came from, so that
whatever the reader then refuses is named where it is in the file (and, inside a
subroutine, from which call).

What LinuxCNC does, and so what this does:

- **Lines** are read without their blanks and in lower case (comments as written):
  `G 1 X [ 1 + 2 ]` is `g1x[1+2]`.
- **Values**: a number, `#n` or `#<name>` (its value), `[expression]`, a function
  (`abs acos asin atan[a]/[b] cos exp exists fix fup ln round sin sqrt tan`, angles in
  degrees; `exists[#<name>]` 1 if the parameter is set), or `+`/`-` before any of these.
- **Binary operators**, left to right within a level, from the tightest: `**`; `* / MOD`;
  `+ -`; `EQ NE GT GE LT LE`; `AND OR XOR`. `-2**2` is 4 (the sign belongs to the
  number), `2**3**2` is 64. MOD is never negative (`-5 MOD 3` is 1); EQ, NE, GE and LE
  take numbers within 1e-6 as equal (LinuxCNC 2.9.0 on); a logical or relational result is
  1 or 0. ROUND rounds half away from zero, FIX down, FUP up. Degrees are converted with a
  long double pi and SIN/COS/TAN are then long double functions, as on a PC (`_trig`).
  Division by zero, a negative number to a fractional power, an argument out of a
  function's range and a result that is not a finite number are refused.
- **Parameters**: `#1`-`#5000` start at 0 (`#1`-`#30` are a call's arguments: saved by
  the call and restored by its return); `#5001` and above hold the machine's state
  (offsets, positions, probe results), which a file does not give: refused. `#<name>` is
  local to the subroutine call (the main program has its own), `#<_name>` global; reading
  one that was never set is refused, as LinuxCNC does — but the name of a `#<name>=` on a
  line exists (at 0) from where it is read, so `#<a>=[#<a>+1]` sets 1. `#<_value>` is the
  last `return [value]`/`endsub [value]` (0 after a return without one), and
  `#<_value_returned>` says whether it had one.
- **Settings take effect after the line**: `#1=5 G1 X#1` moves to the old #1, and
  `#1=2 #2=#1` sets #2 to the old #1.
- **O-words**: `o<name>`/`oNNN` with `sub`/`endsub`/`return` (a subroutine, defined where
  it is written and skipped when the program flows into it), `call [a] [b] …` (up to 30
  arguments as #1-#30), `if`/`elseif`/`else`/`endif`, `while`/`endwhile`, `do`/`while`,
  `repeat [n]`/`endrepeat` (n rounded half to even), `break`/`continue` (of a while or do
  loop). Labels other than subroutines belong to the subroutine they are in; LinuxCNC
  refuses a label used for two blocks in one subroutine, and so does this (as it refuses
  blocks that are not nested in each other, and an `if` without its `endif`). The flow is
  LinuxCNC's own (`_Run.flow`): it skips forward to the next line with a label, and its
  break and continue flags outlive their loops — a break can keep a later do loop from
  going round again — which is reproduced, and reported where it changes the flow.
- **Fanuc subprograms**: `O<n>` alone on a line is a label; `M98 P<n> [L<count>]` (first
  on its line) runs the lines after it up to its `M99` count times, with the caller's
  #1-#30; L0 is refused (LinuxCNC skips the call but stays a call deeper). `M99` in the
  main program ends it (LinuxCNC's preview reads it so; a control would start the program
  again). A file's `O<n>` that the program flows into is its program number.
- **Bounds**: at most 9 calls deep (LinuxCNC's 10 levels, the main program included), and
  at most `MAX_EXPANDED_LINES` lines run in all: a loop that never ends is refused, naming
  it, instead of running forever.

Not read: subroutines in other files (`o<name> call` for a name the file does not define
is refused, naming it), O-word numbers given by expressions, remapped codes and Python
subroutines.

The report names each call and loop: `line 12: o100 call: o100 sub (lines 3-9) expanded,
3 times`, `line 5: o7 while (lines 5-9): run 12 times`, with the same note on many lines
shortened as every note is.
"""

from __future__ import annotations

import math
import re
from collections.abc import Generator, Iterator
from dataclasses import dataclass, field
from decimal import Decimal, localcontext
from fractions import Fraction
from functools import lru_cache
from typing import Final

from app.cnc.numbers import NUMBER_TEXT
from app.cnc.recognition.common import MAX_DIGITS, ImportFailure, Notes, failure
from app.cnc.sizes import MAX_EXPANDED_LINES

CALL_LEVELS: Final = 10  # LinuxCNC's INTERP_SUB_ROUTINE_LEVELS: the main program and 9 calls
SUB_PARAMS: Final = 30  # #1-#30: a call's arguments
USER_PARAMS: Final = 5000  # #1-#5000 are the program's; above, the machine's state
LAST_PARAM: Final = 5601  # LinuxCNC's RS274NGC_MAX_PARAMETERS - 1
EQUAL: Final = 1e-6  # LinuxCNC's TOLERANCE_EQUAL: EQ, NE, GE, LE
PLACES: Final = 8  # decimals a computed value is written with (0.25 nm in inches)
READ_ONLY: Final = frozenset({"_value", "_value_returned"})
BLOCK_DELETE: Final = "block delete (/): imported as run (the block-delete switch off)"
_NUMBER: Final = re.compile(NUMBER_TEXT, re.ASCII)
_COMMENTS: Final = re.compile(r"\([^)]*\)?|;.*")
# A line that may begin with an O-word, M98 or M99 (`_Run.control` reads it).
_CONTROL: Final = re.compile(
    r"[ \t]*/?[ \t]*(?:[nN][ \t]*[0-9][0-9. \t]*)?(?:[oO]|[mM][ \t]*0*9[ \t]*[89])"
)
_WORD: Final = re.compile(r"[a-z]{2,}")  # a command's word, where an O-word's belongs
_ANY_M99: Final = re.compile(r"[mM][ \t]*0*99(?![0-9.])")

# Binary operations (interp_read.cc read_operation) and their precedence (interp_internal.cc).
_CLOSE, _AND, _XOR, _OR, _EQ, _NE, _GT, _GE, _LT, _LE = range(10)
_PLUS, _MINUS, _TIMES, _DIVIDE, _MOD, _POWER = range(10, 16)
_PRECEDENCE: Final = (1, 2, 2, 2, 3, 3, 3, 3, 3, 3, 4, 4, 5, 5, 5, 6)
_OPERATIONS: Final = (
    ("**", _POWER),
    ("*", _TIMES),
    ("/", _DIVIDE),
    ("+", _PLUS),
    ("-", _MINUS),
    ("]", _CLOSE),
    ("and", _AND),
    ("mod", _MOD),
    ("or", _OR),
    ("xor", _XOR),
    ("eq", _EQ),
    ("ne", _NE),
    ("gt", _GT),
    ("ge", _GE),
    ("lt", _LT),
    ("le", _LE),
)
FUNCTIONS: Final = (
    "abs",
    "acos",
    "asin",
    "atan",
    "cos",
    "exp",
    "exists",
    "fix",
    "fup",
    "ln",
    "round",
    "sin",
    "sqrt",
    "tan",
)
# O-word keywords in the order LinuxCNC tries them (each a prefix of the rest of the line).
_KEYWORDS: Final = (
    "sub",
    "endsub",
    "call",
    "do",
    "while",
    "repeat",
    "if",
    "elseif",
    "else",
    "endif",
    "break",
    "continue",
    "endwhile",
    "endrepeat",
    "return",
)
_OPENS: Final = frozenset({"if", "while", "do", "repeat"})
_MACHINE_PARAMS: Final = (
    (5061, 5070, "probe results"),
    (5161, 5169, "the G28 home position"),
    (5181, 5189, "the G30 home position"),
    (5210, 5219, "the G92 offsets"),
    (5220, 5390, "the coordinate systems (G54-G59.3)"),
    (5399, 5399, "the M66 input"),
    (5400, 5413, "the tool in the spindle and its offsets"),
    (5420, 5428, "the current position"),
)


def number_text(value: float) -> str:
    """A computed value as a G-code number: at most PLACES decimals (0.25 nm in inches,
    finer than any block holds) and MAX_DIGITS digits, without trailing zeros."""
    places = PLACES
    while True:
        text = f"{value:.{places}f}"
        if "." in text:
            text = text.rstrip("0").rstrip(".")
        digits = len(text.lstrip("-").replace(".", "").lstrip("0"))
        if digits <= MAX_DIGITS or places == 0:
            break
        places -= min(places, digits - MAX_DIGITS)
    return "0" if text in ("-0", "") else text


@dataclass
class Line:
    """One line as the reader is to read it: `number` is the file's line, `columns[k]` the
    file's column of `text[k]` (None: `text` is the line as written), `context` where it
    runs from (` (in o100, called at line 12)`, or empty)."""

    number: int
    text: str
    columns: list[int] | None = None
    context: str = ""
    titles: bool = True  # a comment alone on it may be the program's title

    def moved(self, exc: ImportFailure) -> ImportFailure:
        """The reader's failure on this line, at the file's column and with the context."""
        column = exc.column
        if column is not None and self.columns is not None:
            columns = self.columns
            if not columns:
                column = 1
            elif column - 1 < len(columns):
                column = columns[column - 1]
            else:
                column = columns[-1] + 1
        return failure(self.number, column, exc.message + self.context)


@dataclass
class _Text:
    """A line as LinuxCNC reads it: lower case without blanks, comments as written; `cols`
    the file's column of each character."""

    s: str
    cols: list[int]

    def column(self, k: int) -> int:
        if k < len(self.cols):
            return self.cols[k]
        return self.cols[-1] + 1 if self.cols else 1


def _compact(number: int, raw: str) -> _Text:
    chars: list[str] = []
    cols: list[int] = []
    comment = False
    n = len(raw)
    k = 0
    while k < n:
        ch = raw[k]
        if comment:
            chars.append(ch)
            cols.append(k + 1)
            comment = ch != ")"
        elif ch == ";":
            chars.extend(raw[k:])
            cols.extend(range(k + 1, n + 1))
            break
        elif ch in " \t\r":
            pass
        else:
            if ch == "(":
                comment = True
            chars.append(ch.lower() if "A" <= ch <= "Z" else ch)
            cols.append(k + 1)
        k += 1
    if comment:
        raise failure(number, cols[len(cols) - 1 - chars[::-1].index("(")], _UNCLOSED)
    return _Text("".join(chars), cols)


_UNCLOSED: Final = "comment not closed: '(' without ')'"


@dataclass
class _Control:
    """An O-word line, or an M98/M99 beginning a line: what it is and where it leads."""

    index: int  # the line's index (0-based)
    kind: str  # an O keyword, "label" (O<n> alone), "m98" or "m99"
    label: str  # "<name>" or the number ("" for M98/M99)
    column: int  # of the O (or M)
    text: _Text
    rest: int  # where in text.s the keyword ends
    scope: str = ""  # the label of the subroutine or subprogram the line is in
    group: list[int] = field(default_factory=list)  # an if's branches; a loop's ends
    start: int = -1  # the first line of its block (elseif … continue)
    after: int = -1  # the next line with its label in its scope (what a skip goes to)

    @property
    def key(self) -> str:
        """The label as LinuxCNC scopes it: the subroutine it is in, then its own."""
        return f"{self.scope}#{self.label}"

    @property
    def shown(self) -> str:
        return f"O{self.label}" if self.kind in ("label", "m99") else f"o{self.label}"


@dataclass
class _Frame:
    """A call: of `shown` (at `entry`; the main program has none) from line `caller`."""

    shown: str = ""
    entry: int = -1
    caller: int = 0
    back: int = 0  # where execution continues after the return
    saved: list[float] | None = None  # the caller's #1-#30 (an O-word call)
    again: int = 0  # further runs of an M98 L
    local: dict[str, float] = field(default_factory=dict)


class _Wrong(Exception):
    """A calculation LinuxCNC refuses (the message), located by its caller."""


def expand(lines: list[str], notes: Notes) -> Generator[Line, bool | None, None]:
    """Run `lines` (a file's lines, without line ends) and yield the lines it runs, as
    described above; send True after a line that ends the program (the rest of the file
    then comes as written, outside its subroutines and subprograms). Raises ImportFailure
    naming the file's line and column of the first thing LinuxCNC would refuse, or that
    this cannot run (another file's subroutine, an O-word number from an expression), or
    where the run passes `MAX_EXPANDED_LINES`."""
    return _Run(lines, notes).run()


class _Run:
    def __init__(self, lines: list[str], notes: Notes) -> None:
        self.lines = lines
        self.notes = notes
        self.controls: dict[int, _Control] = {}
        self.subs: dict[str, int] = {}  # an o-word subroutine's label → its `sub` line
        self.labels: dict[str, int] = {}  # a Fanuc O<n> → its line
        self.regions: list[tuple[int, int, str]] = []  # definitions: first, last, shown
        self.compacted: dict[int, _Text] = {}  # a line's index → the line as it is read
        self.numbered: dict[int, float] = {}
        self.named: dict[str, float] = {"_value": 0.0, "_value_returned": 0.0}
        self.frames: list[_Frame] = [_Frame()]
        self.calls: dict[tuple[int, str], int] = {}  # (call line, what) → how many times
        self.loops: dict[int, int] = {}  # a loop's first line → its runs
        self.called: set[int] = set()  # the definitions run
        self.last_loop = -1
        # LinuxCNC's control-flow state (interp_o_word.cc): the label skipped to, whether an
        # if's branch ran, the break and continue under way (line, label), repeat counts
        self.skipping: str | None = None
        self.executed_if = False
        self.doing_break: tuple[int, str] | None = None
        self.doing_continue: tuple[int, str] | None = None
        self.repeats: dict[str, int] = {}
        # the line being read
        self.number = 0
        self.text = _Text("", [])
        self.k = 0
        self.scan()

    # -- the file's structure ---------------------------------------------------------

    def scan(self) -> None:
        """Find every O-word line and every M98/M99 beginning a line, the subroutines and
        subprograms, and the blocks each label makes; refuse what LinuxCNC refuses about
        them wherever they are (a label used twice, blocks not nested, an open block)."""
        for index, raw in enumerate(self.lines):
            control = self.control(index, raw)
            if control is not None:
                self.controls[index] = control
        self.find_regions()
        open_sub: _Control | None = None
        stacks: dict[str, list[_Control]] = {}
        used: dict[tuple[str, str], _Control] = {}
        last: dict[str, int] = {}  # a label's last line so far
        region_of = {first: (last, name) for first, last, name in self.regions}
        region_end = -1
        scope = ""
        for index in sorted(self.controls):
            c = self.controls[index]
            if region_end >= 0 and index > region_end and open_sub is None:
                scope, region_end = "", -1
            if c.kind == "label" and index in region_of:
                scope, region_end = c.label, region_of[index][0]
            if c.kind == "sub":
                if open_sub is not None:
                    raise self.at(
                        c,
                        f"{c.shown} sub inside {open_sub.shown} sub (line "
                        f"{open_sub.index + 1}): a subroutine cannot be defined inside another",
                    )
                if c.label in self.subs:
                    raise self.at(
                        c, f"{c.shown} sub is defined twice (line {self.subs[c.label] + 1} too)"
                    )
                self.subs[c.label] = index
                open_sub = c
                scope = c.label
                stacks[scope] = []
                continue
            if c.kind in ("endsub", "return"):
                # A return may have any label (LinuxCNC's retval.ngc returns with its if's);
                # an endsub ends the subroutine of its own.
                if open_sub is None or (c.kind == "endsub" and open_sub.label != c.label):
                    inside = "" if open_sub is None else f" inside {open_sub.shown} sub"
                    raise self.at(c, f"{c.shown} {c.kind} without its {c.shown} sub{inside}")
                if c.kind == "endsub":
                    self.close_scope(stacks.get(scope, []), c)
                    open_sub.group = [index]
                    self.regions.append((open_sub.index, index, f"{c.shown} sub"))
                    open_sub = None
                    scope = ""
                continue
            if c.kind == "m99" and open_sub is not None:
                raise self.at(
                    c, f"M99 inside {open_sub.shown} sub: it ends with {open_sub.shown} endsub"
                )
            if c.kind in ("label", "call", "m98", "m99"):
                continue
            c.scope = scope
            self.structure(c, stacks.setdefault(scope, []), used)
            before = last.get(c.key)
            if before is not None:
                self.controls[before].after = index
            last[c.key] = index
        if open_sub is not None:
            raise self.at(open_sub, f"{open_sub.shown} sub has no {open_sub.shown} endsub")
        for stack in stacks.values():
            self.close_scope(stack, None)

    def structure(
        self, c: _Control, stack: list[_Control], used: dict[tuple[str, str], _Control]
    ) -> None:
        """Match one control-flow line with the block it opens, continues or closes."""
        top = stack[-1] if stack else None
        same = top is not None and top.label == c.label
        if c.kind == "while" and same and top is not None and top.kind == "do":
            c.kind, c.start = "enddo", top.index  # the `while` that ends a do loop
            top.group = [c.index]
            stack.pop()
            return
        if c.kind in _OPENS:
            key = (c.scope, c.label)
            if key in used:
                first = used[key]
                raise self.at(
                    c,
                    f"{c.shown} is used already at line {first.index + 1} ({first.shown} "
                    f"{first.kind}): LinuxCNC refuses a label used for two blocks",
                )
            used[key] = c
            c.group = [c.index]
            stack.append(c)
            return
        if c.kind in ("break", "continue"):
            loop = next((o for o in reversed(stack) if o.label == c.label), None)
            if loop is None or loop.kind not in ("while", "do"):
                raise self.at(
                    c,
                    f"{c.shown} {c.kind} outside an {c.shown} while or do loop (LinuxCNC "
                    f"breaks out of and continues while and do loops only)",
                )
            c.start = loop.index
            return
        wants = {
            "elseif": "if",
            "else": "if",
            "endif": "if",
            "endwhile": "while",
            "endrepeat": "repeat",
        }[c.kind]
        if top is None or not same or top.kind != wants:
            if top is not None and top.label != c.label:
                raise self.at(
                    c,
                    f"{c.shown} {c.kind} before {top.shown} {top.kind} (line {top.index + 1}) "
                    f"is closed: blocks must be nested",
                )
            raise self.at(c, f"{c.shown} {c.kind} without its {c.shown} {wants}")
        c.start = top.index
        if c.kind in ("elseif", "else"):
            if self.controls[top.group[-1]].kind == "else":
                raise self.at(c, f"{c.shown} {c.kind} after {c.shown} else")
            top.group.append(c.index)
            return
        top.group.append(c.index)
        stack.pop()

    def close_scope(self, stack: list[_Control], end: _Control | None) -> None:
        if stack:
            c = stack[-1]
            closing = {"if": "endif", "while": "endwhile", "do": "while", "repeat": "endrepeat"}
            where = "" if end is None else f" before {end.shown} endsub (line {end.index + 1})"
            raise self.at(c, f"{c.shown} {c.kind} has no {c.shown} {closing[c.kind]}{where}")

    def find_regions(self) -> None:
        """The Fanuc subprograms: an O<n> line up to the last M99 before the next O<n>,
        subroutine or the end of the file (an O<n> with no M99 is a program number)."""
        marks = [i for i, c in self.controls.items() if c.kind in ("label", "sub")]
        marks.sort()
        for k, first in enumerate(marks):
            c = self.controls[first]
            if c.kind != "label":
                continue
            self.labels.setdefault(c.label, first)
            stop = marks[k + 1] if k + 1 < len(marks) else len(self.lines)
            ends = [i for i in range(first + 1, stop) if self.is_kind(i, "m99")]
            if ends:
                self.regions.append((first, ends[-1], f"O{c.label}"))

    def is_kind(self, index: int, kind: str) -> bool:
        c = self.controls.get(index)
        return c is not None and c.kind == kind

    def control(self, index: int, raw: str) -> _Control | None:
        """The O-word (or leading M98/M99) of one line, or None for any other line."""
        if _CONTROL.match(raw) is None:
            return None
        self.number = index + 1
        text = _compact(self.number, raw)
        s = text.s
        k = 1 if s.startswith("/") else 0
        if s.startswith("n", k):
            k += 1
            while k < len(s) and (s[k].isdigit() or s[k] == "."):
                k += 1
        if s.startswith("m", k):
            j = k + 1
            while j < len(s) and s[j].isdigit():
                j += 1
            if j > k + 1 and (j == len(s) or s[j] != ".") and int(s[k + 1 : j]) in (98, 99):
                kind = "m98" if int(s[k + 1 : j]) == 98 else "m99"
                return _Control(index, kind, "", text.column(k), text, j)
            return None
        if not s.startswith("o", k):
            return None
        column = text.column(k)
        j = k + 1
        if s.startswith("<", j):
            close = s.find(">", j)
            if close < 0:
                raise failure(self.number, text.column(j), "o<name without its closing '>'")
            label = s[j : close + 1]
            j = close + 1
        else:
            m = j
            while m < len(s) and s[m].isdigit():
                m += 1
            if m == j:
                what = (
                    "an O-word number from an expression is not supported"
                    if (s[j : j + 1] in ("#", "["))
                    else "O needs a number or <name>"
                )
                raise failure(self.number, text.column(j), what)
            label = str(int(s[j:m]))
            j = m
        kind = next((w for w in _KEYWORDS if s.startswith(w, j)), "")
        word = None if kind else _WORD.match(s, j)  # (O<n> alone: words may follow it)
        if word is not None:
            raise failure(
                self.number,
                text.column(j),
                f"{word.group().upper()!r} after O{label}: not an O-word command "
                f"({', '.join(_KEYWORDS)})",
            )
        j += len(kind)
        return _Control(index, kind or "label", label, column, text, j)

    # -- running ------------------------------------------------------------------------

    def run(self) -> Generator[Line, bool | None, None]:
        pc = 0
        budget = MAX_EXPANDED_LINES
        ended = False
        n = len(self.lines)
        while True:
            if pc >= n:
                if len(self.frames) > 1:
                    frame = self.frames[-1]
                    raise failure(
                        n,
                        None,
                        f"the file ends inside {frame.shown}, called at line {frame.caller}: "
                        f"no M99 returns from it",
                    )
                break
            budget -= 1
            if budget < 0:
                raise self.endless(pc)
            c = self.controls.get(pc)
            if c is None:
                line = self.plain(pc)
                pc += 1
            else:
                pc, line = self.step(c)
            if line is not None:
                # The reader says whether the program ended with the line (M2, M30, the
                # main program's M99, the closing %): it reads the codes, once.
                ended = bool((yield line))
                if ended:
                    break
        if ended:
            yield from self.after(pc)
        self.report()

    def after(self, pc: int) -> Iterator[Line]:
        """The lines after the program's end, outside the subroutines and subprograms, as
        written (the reader says they are not imported)."""
        inside = [(first, last) for first, last, _ in self.regions]
        for index in range(pc, len(self.lines)):
            if not any(first <= index <= last for first, last in inside):
                yield Line(index + 1, self.lines[index])

    def report(self) -> None:
        for (line, what), times in sorted(self.calls.items()):
            self.notes.became(line, f"{what} expanded{'' if times == 1 else f', {times} times'}")
        for first, runs in sorted(self.loops.items()):
            c = self.controls[first]
            if c.kind == "m98":  # (its note is the call's)
                continue
            last = c.group[-1] if c.group else first
            self.notes.became(
                first + 1,
                f"{c.shown} {c.kind} (lines {first + 1}-{last + 1}): run "
                f"{runs} time{'' if runs == 1 else 's'}",
            )
        for first, last, shown in self.regions:
            if first not in self.called:
                self.notes.ignored(
                    first + 1, f"{shown} (lines {first + 1}-{last + 1}) is never run: not imported"
                )

    def endless(self, pc: int) -> ImportFailure:
        limit = f"{MAX_EXPANDED_LINES:,}"
        if self.last_loop >= 0:
            c = self.controls[self.last_loop]
            runs = self.loops.get(self.last_loop, 0)
            what = "M98" if c.kind == "m98" else f"{c.shown} {c.kind}"
            return failure(
                c.index + 1,
                c.column,
                f"{what} has run {runs:,} times and the program {limit} lines: a loop that "
                f"does not end? (an import runs at most {limit} lines)",
            )
        return failure(
            pc + 1,
            None,
            f"the program runs more than {limit} lines: an import runs at most {limit}",
        )

    def context(self) -> str:
        frame = self.frames[-1]
        return "" if not frame.caller else f" (in {frame.shown}, called at line {frame.caller})"

    def at(self, c: _Control, message: str) -> ImportFailure:
        return failure(c.index + 1, c.column, message)

    def fail(self, k: int, message: str) -> ImportFailure:
        return failure(self.number, self.text.column(k), message + self.context())

    def plain(self, pc: int) -> Line | None:
        """A line that is not an O-word: as written, or with its values in place."""
        raw = self.lines[pc]
        if "#" not in raw and "[" not in raw:
            if len(self.frames) > 1 and _ANY_M99.search(_COMMENTS.sub("", raw)):
                raise failure(pc + 1, None, "M99 must begin its line" + self.context())
            return Line(pc + 1, raw, None, self.context())
        self.number = pc + 1
        text = self.compacted.get(pc)
        if text is None:  # (a line a loop runs is read once)
            text = self.compacted[pc] = _compact(self.number, raw)
        self.text = text
        self.k = 0
        return self.evaluate()

    # -- control flow -------------------------------------------------------------------

    def step(self, c: _Control) -> tuple[int, Line | None]:
        """Run one O-word (or M98/M99) line: where execution goes next, and a line for the
        reader (a program number's rest)."""
        self.number = c.index + 1
        self.text = c.text
        self.k = c.rest
        i = c.index
        kind = c.kind
        if c.text.s.startswith("/"):
            self.notes.assumed(self.number, BLOCK_DELETE)
        if kind == "label":
            return i + 1, self.program_number(c)
        if kind == "sub":
            if len(self.frames) > 1:
                frame = self.frames[-1]
                raise self.at(
                    c,
                    f"{c.shown} sub inside {frame.shown}, called at line {frame.caller} "
                    "(LinuxCNC refuses a subroutine defined there)",
                )
            self.only_comments()
            return c.group[0] + 1, None
        if kind in ("endsub", "return"):
            return self.give_back(c), None
        if kind == "call":
            return self.call(c), None
        if kind == "m98":
            return self.m98(c), None
        if kind == "m99":
            return self.m99(c)
        return self.flow(c), None

    def flow(self, c: _Control) -> int:
        """if … continue as LinuxCNC's convert_control_functions runs them: it skips forward
        to the next line of the label (`skip`), and keeps three flags for the whole run —
        whether an if's branch ran, a break and a continue under way. A break or continue
        can leave its flag set for a later loop, which LinuxCNC then runs differently from
        how the file reads; the report says where that happens."""
        kind = c.kind
        i = c.index
        skipping = self.skipping is not None  # (then for this label: we came by `skip`)
        if kind == "if":
            if self.condition(c):
                self.executed_if = True
                return i + 1
            self.executed_if = False
            return self.skip(c)
        if kind == "elseif":
            if self.executed_if:
                return self.skip(c)
            if self.condition(c):
                self.skipping = None
                self.executed_if = True
                return i + 1
            return self.skip(c) if skipping else i + 1
        if kind == "else":
            if self.executed_if:
                return self.skip(c)
            self.only_comments()
            self.skipping = None
            self.executed_if = True
            return i + 1
        if kind == "endif":
            self.only_comments()
            self.skipping = None
            self.executed_if = True
            return i + 1
        if kind == "while":
            if self.condition(c):
                self.loop(i)
                return i + 1
            return self.skip(c)
        if kind in ("endwhile", "endrepeat"):
            self.only_comments()
            if not skipping:
                return c.start  # round again (the while tests again)
            self.skipping = None
            if self.doing_continue is None:
                return i + 1
            line, key = self.doing_continue
            self.doing_continue = None
            if key != c.key:
                self.notes.assumed(
                    i + 1,
                    f"{c.shown} {c.kind}: LinuxCNC goes round the loop again here, because "
                    f"the continue at line {line} (of another loop) left its flag set",
                )
            return c.start
        if kind == "do":
            self.only_comments()
            self.skipping = None
            self.loop(i)
            return i + 1
        if kind == "enddo":
            again = self.condition(c)
            self.skipping = None
            if again and self.doing_break is None:
                return c.start
            if again and self.doing_break is not None:
                line, key = self.doing_break
                if key != c.key:
                    self.notes.assumed(
                        i + 1,
                        f"{c.shown} while: true, but LinuxCNC does not go round the loop "
                        f"again, because the break at line {line} (of another loop) left its "
                        "flag set",
                    )
            self.doing_break = None
            return i + 1
        if kind == "repeat":
            self.skipping = None
            left = self.repeats.get(c.key)
            if left is None:
                left = round(self.condition_value(c))
            if left > 0:
                self.repeats[c.key] = left - 1
                self.loop(i)
                return i + 1
            self.repeats.pop(c.key, None)
            return self.skip(c)
        self.only_comments()
        if kind == "break":
            self.doing_break = (i + 1, c.key)
            going_on = self.doing_continue
            if (
                going_on is not None
                and going_on[1] == c.key
                and skipping
                and self.controls[c.start].kind == "do"
            ):
                # (In a while loop the endwhile still goes round: the continue's flag wins.)
                self.notes.assumed(
                    i + 1,
                    f"{c.shown} break: LinuxCNC reaches it as it skips to the end of the "
                    f"loop for the continue at line {going_on[0]}, and leaves the loop",
                )
            return self.skip(c)
        if not skipping:  # continue
            self.doing_continue = (i + 1, c.key)
        return self.skip(c)

    def skip(self, c: _Control) -> int:
        """Skip forward to the next line with `c`'s label (LinuxCNC reads the lines between
        and runs none of them)."""
        self.skipping = c.key
        if c.after < 0:  # (the scan found every block closed: not reached)
            raise self.at(c, f"no line after this one has {c.shown}")
        return c.after

    def loop(self, first: int) -> None:
        """A loop's body is entered once more."""
        self.loops[first] = self.loops.get(first, 0) + 1
        self.last_loop = first

    def condition(self, c: _Control) -> bool:
        return self.condition_value(c) != 0.0

    def condition_value(self, c: _Control) -> float:
        self.number = c.index + 1
        self.text = c.text
        self.k = c.rest
        if not c.text.s.startswith("[", c.rest):
            raise self.fail(
                c.rest, f"{c.shown} {c.kind.replace('enddo', 'while')} needs a [condition]"
            )
        value = self.expression()
        self.only_comments()
        return value

    def only_comments(self) -> None:
        """After an O-word's keyword and value: nothing but comments (LinuxCNC)."""
        s = self.text.s
        while self.k < len(s):
            if s[self.k] == ";":
                return
            if s[self.k] == "(":
                self.k = s.index(")", self.k) + 1
                continue
            raise self.fail(self.k, f"unexpected {s[self.k]!r} after the O-word")

    def program_number(self, c: _Control) -> Line | None:
        """O<n> met in the flow of the program: its number (not carried); the rest of the
        line is read as any line."""
        if len(self.frames) == 1:
            self.notes.ignored(self.number, f"program number O{c.label}: not carried")
            if c.index in {first for first, _, _ in self.regions}:
                self.called.add(c.index)
        rest = c.text.s[c.rest :]
        if not rest:
            return None
        self.k = c.rest
        return self.evaluate()

    def call(self, c: _Control) -> int:
        target = self.subs.get(c.label)
        if target is None:
            if c.label in self.labels:
                raise self.at(
                    c,
                    f"{c.shown} call: O{c.label} is a Fanuc subprogram, called with M98 P{c.label}",
                )
            raise self.at(
                c,
                f"{c.shown} call: the file has no {c.shown} sub (LinuxCNC would look for "
                f"{c.label.strip('<>')}.ngc in its subroutine folders: put the subroutine "
                "in this file)",
            )
        args: list[float] = []
        s = self.text.s
        while self.k < len(s) and s[self.k] in "[(":
            if s[self.k] == "(":
                self.k = s.index(")", self.k) + 1
                continue
            if len(args) == SUB_PARAMS:
                raise self.fail(self.k, f"more than {SUB_PARAMS} arguments (#1-#30)")
            args.append(self.expression())
        self.only_comments()
        saved = [self.numbered.get(n, 0.0) for n in range(1, SUB_PARAMS + 1)]
        frame = _Frame(c.shown, target, caller=c.index + 1, back=c.index + 1)
        frame.saved = saved
        self.enter(c, frame)
        for n in range(1, SUB_PARAMS + 1):
            self.numbered[n] = args[n - 1] if n <= len(args) else 0.0
        key = (c.index + 1, f"{c.shown} call: {self.region_text(target)}")
        self.calls[key] = self.calls.get(key, 0) + 1
        return target + 1

    def region_text(self, first: int) -> str:
        for start, last, shown in self.regions:
            if start == first:
                return f"{shown} (lines {first + 1}-{last + 1})"
        return f"O{self.controls[first].label} (line {first + 1})"

    def enter(self, c: _Control, frame: _Frame) -> None:
        if len(self.frames) >= CALL_LEVELS:
            raise self.at(
                c,
                f"{c.shown + ' call' if c.kind == 'call' else 'M98'}: more than "
                f"{CALL_LEVELS - 1} "
                "calls deep (LinuxCNC's limit); does the subroutine call itself without end?",
            )
        self.frames.append(frame)
        self.called.add(frame.entry)

    def give_back(self, c: _Control) -> int:
        """endsub or return, with its optional [value] (#<_value>)."""
        s = self.text.s
        if s.startswith("[", self.k):
            self.named["_value"] = self.expression()
            self.named["_value_returned"] = 1.0
        else:
            self.named["_value"] = 0.0
            self.named["_value_returned"] = 0.0
        self.only_comments()
        if len(self.frames) == 1:  # (a sub's lines run only in its calls: not reached)
            raise self.at(c, f"{c.shown} {c.kind} outside a call")
        frame = self.frames.pop()
        if frame.saved is not None:
            for n, value in enumerate(frame.saved, start=1):
                self.numbered[n] = value
        return frame.back

    def m98(self, c: _Control) -> int:
        p: float | None = None
        count: float | None = None
        s = self.text.s
        while self.k < len(s):
            ch = s[self.k]
            if ch == "(":
                self.k = s.index(")", self.k) + 1
            elif ch == ";":
                break
            elif ch in "pl":
                if (p if ch == "p" else count) is not None:
                    raise self.fail(self.k, f"{ch.upper()} given twice beside M98")
                self.k += 1
                value = self.value()
                if ch == "p":
                    p = value
                else:
                    count = value
            else:
                raise self.fail(
                    self.k,
                    f"{s[self.k].upper()!r} beside M98: M98 takes P "
                    "(the O number) and L (how many times)",
                )
        if p is None:
            raise self.at(c, "M98 with no P (the O number of the subprogram)")
        number = self.whole(p, c.rest)
        if number < 0:
            raise self.at(c, f"M98 P{number}: an O number is 0 or more")
        label = str(number)
        target = self.labels.get(label)
        if target is None:
            if label in self.subs:
                raise self.at(
                    c, f"M98 P{label}: o{label} is an O-word subroutine, called with o{label} call"
                )
            hint = ""
            if len(label) > 4:
                hint = (
                    f" (a Fanuc P of more than four digits may hold a repeat count: for "
                    f"P{label[:-4]} {label[-4:]} write M98 P{int(label[-4:])} "
                    f"L{int(label[:-4])})"
                )
            raise self.at(c, f"M98 P{label}: the file has no O{label}{hint}")
        times = 1 if count is None else round(count)
        if times < 0:
            raise self.at(c, f"M98 L{times}: L is how many times, 0 or more")
        if times == 0:
            # rs274 (2.9) skips the call but enters its frame and never leaves it: the next
            # M99 of the main program returns here. What that runs no file means.
            raise self.at(
                c,
                f"M98 P{label} L0: LinuxCNC skips the call but stays a call deeper (its next "
                "M99 returns here): delete the line",
            )
        frame = _Frame(f"O{label}", target, caller=c.index + 1, back=c.index + 1)
        frame.again = times - 1
        self.enter(c, frame)
        if times > 1:
            self.loop(c.index)
        key = (c.index + 1, f"M98 P{label}: {self.region_text(target)}")
        self.calls[key] = self.calls.get(key, 0) + times
        return target + 1

    def m99(self, c: _Control) -> tuple[int, Line | None]:
        if len(self.frames) == 1:
            return c.index + 1, Line(c.index + 1, self.lines[c.index], None, "")
        frame = self.frames[-1]
        if frame.saved is not None:
            raise self.at(
                c, f"M99 in {frame.shown} sub: it returns with {frame.shown} endsub or return"
            )
        if frame.again > 0:
            frame.again -= 1
            frame.local.clear()
            self.loop(frame.caller - 1)  # (the M98 line: counted as a loop's runs are)
            return frame.entry + 1, None
        self.frames.pop()
        return frame.back, None

    # -- a line's words and values ------------------------------------------------------

    def evaluate(self) -> Line | None:
        """Read the words of the current line from `self.k` (LinuxCNC's read_items), set
        its parameters after it, and return it for the reader with values in place."""
        s = self.text.s
        cols = self.text.cols
        out: list[str] = []
        out_cols: list[int] = []
        settings: list[tuple[int | str, float]] = []
        words = False

        def put(piece: str, columns: list[int]) -> None:
            if out:
                out.append(" ")
                out_cols.append(columns[0])
            out.append(piece)
            out_cols.extend(columns)

        if s.startswith("/", self.k):
            put("/", [cols[self.k]])
            self.k += 1
        while self.k < len(s):
            k = self.k
            ch = s[k]
            if ch == "(":
                close = s.index(")", k)
                put(s[k : close + 1], cols[k : close + 1])
                self.k = close + 1
            elif ch == ";":
                put(s[k:], cols[k:])
                break
            elif ch == "#":
                settings.append(self.setting())
            elif ch.isalpha() or ch in "@^":
                self.k += 1
                literal = self.literal()
                if literal is not None:
                    put(ch.upper() + literal, [cols[k], *cols[k + 1 : self.k]])
                else:
                    value = self.value()
                    piece = number_text(value)
                    put(ch.upper() + piece, [cols[k]] + [cols[k + 1]] * len(piece))
                words = True
            else:
                # Not a word: the reader says what is wrong with it, where.
                put(s[k:], cols[k:])
                words = True
                break
        for key, value in settings:
            self.store(key, value)
        if not out:
            return None
        return Line(
            self.number, "".join(out), out_cols, self.context(), titles=words or not settings
        )

    def literal(self) -> str | None:
        """A plain number at `self.k` (kept as written), or None for any other value."""
        s = self.text.s
        m = _NUMBER.match(s, self.k)
        if m is None:
            return None
        end = m.end()
        if end < len(s) and (s[end] == "." or s[end].isdigit()):
            return None  # (`1.2.3`: the value reader says what is wrong)
        self.k = end
        return m.group()

    def setting(self) -> tuple[int | str, float]:
        """`#n=value` or `#<name>=value` (interp_read.cc read_parameter_setting)."""
        s = self.text.s
        start = self.k
        self.k += 1
        key: int | str
        if s.startswith("<", self.k):
            name = self.name()
            if name in READ_ONLY:
                raise self.fail(start, f"#<{name}> is LinuxCNC's, read-only")
            scope = self.named if name.startswith("_") else self.frames[-1].local
            scope.setdefault(name, 0.0)  # exists from here (LinuxCNC's add_named_param)
            key = name
        else:
            key = self.index(start)
        if not s.startswith("=", self.k):
            raise self.fail(self.k, "'=' missing in a parameter setting (#n=value)")
        self.k += 1
        return key, self.value()

    def store(self, key: int | str, value: float) -> None:
        if isinstance(key, int):
            self.numbered[key] = value
        elif key.startswith("_"):
            self.named[key] = value
        else:
            self.frames[-1].local[key] = value

    def name(self) -> str:
        s = self.text.s
        close = s.find(">", self.k)
        if close < 0:
            raise self.fail(self.k, "#<name without its closing '>'")
        name = s[self.k + 1 : close]
        if not name:
            raise self.fail(self.k, "#<> has no name")
        self.k = close + 1
        return name

    def index(self, start: int) -> int:
        """A numbered parameter's number (after its #)."""
        value = self.value()
        number = self.whole(value, start + 1)
        if not 1 <= number <= LAST_PARAM:
            raise self.fail(start, f"#{number}: parameters are #1-#{LAST_PARAM}")
        if number > USER_PARAMS:
            meaning = next(
                (what for low, high, what in _MACHINE_PARAMS if low <= number <= high),
                "the machine's state",
            )
            raise self.fail(
                start,
                f"#{number} holds {meaning}, which the file does not give (a program's own "
                f"parameters are #1-#{USER_PARAMS} and #<names>)",
            )
        return number

    def whole(self, value: float, k: int) -> int:
        """LinuxCNC's read_integer_value: within 0.0001 of a whole number."""
        low = math.floor(value)
        if value - low > 0.9999:
            return low + 1
        if value - low > 0.0001:
            raise self.fail(k, f"{number_text(value)}: a whole number is needed here")
        return low

    def value(self) -> float:
        """A real value (interp_read.cc read_real_value)."""
        s = self.text.s
        k = self.k
        if k >= len(s):
            raise self.fail(k, "a number, #parameter or [expression] is missing")
        ch = s[k]
        nxt = s[k + 1] if k + 1 < len(s) else ""
        if ch == "[":
            value = self.expression()
        elif ch == "#":
            value = self.parameter()
        elif ch in "+-" and nxt and not nxt.isdigit() and nxt != ".":
            self.k += 1
            value = self.value()
            if ch == "-":
                value = -value
        elif "a" <= ch <= "z":
            value = self.function()
        else:
            j = k
            while j < len(s) and s[j] in "+-":
                j += 1
            while j < len(s) and (s[j].isdigit() or s[j] == "."):
                j += 1
            text = s[k:j]
            if not text or _NUMBER.fullmatch(text) is None:
                found = text or s[k]
                raise self.fail(
                    k, f"{found!r} is not a number (a number, #parameter or [expression] is needed)"
                )
            self.k = j
            value = float(text)
        if not math.isfinite(value):
            raise self.fail(k, "the calculation does not give a finite number")
        return value

    def parameter(self) -> float:
        """The value of #n or #<name> (interp_read.cc read_parameter)."""
        start = self.k
        self.k += 1
        if self.text.s.startswith("<", self.k):
            name = self.name()
            scope = self.named if name.startswith("_") else self.frames[-1].local
            value = scope.get(name)
            if value is None:
                why = (
                    "its own #<_…> parameters hold the machine's state, which the file does "
                    "not give"
                    if name.startswith("_")
                    else "a #<name> belongs to the call it is set in, a #<_name> to the "
                    "whole program"
                )
                raise self.fail(
                    start, f"#<{name}> is read before it is set (LinuxCNC refuses that; {why})"
                )
            return value
        return self.numbered.get(self.index(start), 0.0)

    def expression(self) -> float:
        """`[ … ]` at self.k (interp_read.cc read_real_expression): binary operations left
        to right within a precedence level."""
        self.k += 1
        values = [self.value()]
        operations: list[tuple[int, int]] = []  # (operation, position)
        while True:
            at = self.k
            operation = self.operation()
            while operations and _PRECEDENCE[operations[-1][0]] >= _PRECEDENCE[operation]:
                right = values.pop()
                left = values.pop()
                op, where = operations.pop()
                try:
                    values.append(_binary(left, op, right))
                except _Wrong as exc:
                    raise self.fail(where, str(exc)) from None
            if operation == _CLOSE:
                break
            operations.append((operation, at))
            values.append(self.value())
        value = values[0]
        if not math.isfinite(value):
            raise self.fail(self.k - 1, "the calculation does not give a finite number")
        return value

    def operation(self) -> int:
        s = self.text.s
        for text, operation in _OPERATIONS:
            if s.startswith(text, self.k):
                self.k += len(text)
                return operation
        if self.k >= len(s):
            raise self.fail(self.k, "the expression is not closed: ']' missing")
        raise self.fail(
            self.k,
            f"{s[self.k]!r} where an operation or ']' belongs (+ - * / ** MOD AND OR XOR EQ "
            "NE GT GE LT LE)",
        )

    def function(self) -> float:
        """A unary function at self.k (interp_read.cc read_unary)."""
        s = self.text.s
        start = self.k
        name = next((f for f in FUNCTIONS if s.startswith(f, start)), "")
        if not name:
            end = start
            while end < len(s) and s[end].isalpha():
                end += 1
            raise self.fail(
                start,
                f"{s[start:end].upper()!r} where a value belongs (a number, #parameter, "
                "[expression] or a function: ABS ACOS ASIN ATAN COS EXP EXISTS FIX FUP LN "
                "ROUND SIN SQRT TAN)",
            )
        self.k += len(name)
        if not s.startswith("[", self.k):
            raise self.fail(self.k, f"{name.upper()} needs its argument in [ ]")
        if name == "exists":
            self.k += 1
            if not s.startswith("#", self.k):
                raise self.fail(self.k, "EXISTS needs a #parameter: EXISTS[#<name>]")
            found = self.exists()
            if not s.startswith("]", self.k):
                raise self.fail(self.k, "EXISTS[#…]: ']' missing")
            self.k += 1
            return 1.0 if found else 0.0
        argument = self.expression()
        if name == "atan":
            if not s.startswith("/[", self.k):
                raise self.fail(self.k, "ATAN needs two arguments: ATAN[y]/[x]")
            self.k += 1
            x = self.expression()
            return degrees(math.atan2(argument, x))
        try:
            return _unary(name, argument)
        except _Wrong as exc:
            raise self.fail(start, str(exc)) from None

    def exists(self) -> bool:
        self.k += 1
        s = self.text.s
        if s.startswith("<", self.k):
            name = self.name()
            scope = self.named if name.startswith("_") else self.frames[-1].local
            return name in scope
        value = self.value()
        return 1 <= math.floor(value) <= LAST_PARAM


# -- angles as LinuxCNC on a PC computes them --------------------------------------------
#
# interp_execute.cc converts degrees with M_PIl, a long double: `sin((x * M_PIl) / 180.0)`
# is, in C++, a long double argument and so sinl (on x86, 64 significant bits), stored as
# a double; an inverse's radians r become degrees as `(r * 180.0) / M_PIl`. In doubles
# SIN[30] would be 0.49999999999999994 and FIX[SIN[30]*2] 0, where LinuxCNC says 1 (and
# TAN[45] 0.9999999999999999): a loop count or a branch could differ. So the conversions
# are done at x86's precision, exactly, and sin, cos and tan of the long double to 40
# digits (an ARM LinuxCNC's long double is wider: the same results where they are exact).

_PI_LONG: Final = Fraction(0xC90FDAA22168C235, 1 << 62)  # M_PIl on x86
_DIGITS: Final = 40


def _long(value: Fraction) -> Fraction:
    """`value` rounded to x86's long double: 64 significant bits, half to even."""
    if not value:
        return value
    size = abs(value)
    shift = 63 - (size.numerator.bit_length() - size.denominator.bit_length())
    scaled = size * Fraction(2) ** shift
    if scaled < 2**63:
        shift += 1
        scaled *= 2
    rounded = Fraction(round(scaled)) / Fraction(2) ** shift
    return rounded if value > 0 else -rounded


def degrees(radians: float) -> float:
    """`(radians * 180.0) / M_PIl` stored as a double (an inverse function's result)."""
    return float(_long(Fraction(radians * 180.0) / _PI_LONG))


def _trig(name: str, angle: float) -> float:
    """sin, cos or tan of `angle` degrees as LinuxCNC computes it (above)."""
    x = _long(_long(Fraction(angle) * _PI_LONG) / 180)
    whole = len(str(abs(int(x))))  # the digits before the point (pi needs as many more)
    with localcontext() as context:
        context.prec = _DIGITS + 10 + whole
        r = Decimal(x.numerator) / Decimal(x.denominator)
        quarter = _pi(context.prec) / 2
        turns = (r / quarter).to_integral_value()
        r -= turns * quarter  # |r| <= pi/4, in quadrant `turns`
        sin, cos = _sin_cos(r)
        for _ in range(int(turns) % 4):
            sin, cos = cos, -sin
        result = sin if name == "sin" else cos if name == "cos" else sin / cos
        return float(_long(Fraction(result)))


@lru_cache(maxsize=8)
def _pi(digits: int) -> Decimal:
    """pi to `digits` significant digits (Machin: 16 atan 1/5 - 4 atan 1/239)."""
    with localcontext() as context:
        context.prec = digits + 10

        def atan_inverse(n: int) -> Decimal:
            total = term = Decimal(1) / n
            k = 1
            while term:
                term /= -n * n
                total += term / (2 * k + 1)
                k += 1
            return total

        pi = 16 * atan_inverse(5) - 4 * atan_inverse(239)
    with localcontext() as context:
        context.prec = digits
        return +pi


def _sin_cos(r: Decimal) -> tuple[Decimal, Decimal]:
    """sin and cos of a small `r` (|r| <= pi/4) by their series, to the context's digits."""
    square = r * r
    sin = term = r
    k = 1
    while abs(term) > Decimal(10) ** -(_DIGITS + 5):
        term = -term * square / ((k + 1) * (k + 2))
        sin += term
        k += 2
    cos = term = Decimal(1)
    k = 0
    while abs(term) > Decimal(10) ** -(_DIGITS + 5):
        term = -term * square / ((k + 1) * (k + 2))
        cos += term
        k += 2
    return sin, cos


def _binary(left: float, operation: int, right: float) -> float:
    """One binary operation as interp_execute.cc execute_binary1/2 computes it."""
    if operation == _PLUS:
        return left + right
    if operation == _MINUS:
        return left - right
    if operation == _TIMES:
        return left * right
    if operation == _DIVIDE:
        if right == 0.0:
            raise _Wrong("division by zero")
        return left / right
    if operation == _MOD:
        if right == 0.0:
            raise _Wrong("MOD 0: the calculation does not give a number")
        result = math.fmod(left, right)
        return result + abs(right) if result < 0.0 else result
    if operation == _POWER:
        if left < 0.0 and math.floor(right) != right:
            raise _Wrong("a negative number to a fractional power")
        try:
            return math.pow(left, right)
        except (OverflowError, ValueError):
            raise _Wrong("the power does not give a finite number") from None
    if operation == _AND:
        return 0.0 if left == 0.0 or right == 0.0 else 1.0
    if operation == _OR:
        return 1.0 if left != 0.0 or right != 0.0 else 0.0
    if operation == _XOR:
        return 1.0 if (left == 0.0) != (right == 0.0) else 0.0
    if operation == _EQ:
        return 1.0 if abs(left - right) < EQUAL else 0.0
    if operation == _NE:
        return 1.0 if abs(left - right) >= EQUAL else 0.0
    if operation == _LE:
        return 1.0 if abs(left - right) < EQUAL or left <= right else 0.0
    if operation == _GE:
        return 1.0 if abs(left - right) < EQUAL or left >= right else 0.0
    if operation == _LT:
        return 1.0 if left < right else 0.0
    return 1.0 if left > right else 0.0  # _GT


def _unary(name: str, value: float) -> float:
    """A function as interp_execute.cc execute_unary computes it (angles in degrees)."""
    if name == "abs":
        return abs(value)
    if name in ("acos", "asin"):
        if not -1.0 <= value <= 1.0:
            raise _Wrong(f"{name.upper()} of {number_text(value)}: only -1 to 1")
        return degrees(math.acos(value) if name == "acos" else math.asin(value))
    if name in ("cos", "sin", "tan"):
        return _trig(name, value)
    if name == "exp":
        try:
            return math.exp(value)
        except OverflowError:
            raise _Wrong("EXP does not give a finite number") from None
    if name == "fix":
        return float(math.floor(value))
    if name == "fup":
        return float(math.ceil(value))
    if name == "ln":
        if value <= 0.0:
            raise _Wrong(f"LN of {number_text(value)}: only of a number above 0")
        return math.log(value)
    if name == "round":
        return float(math.trunc(value + (-0.5 if value < 0.0 else 0.5)))
    if value < 0.0:  # sqrt
        raise _Wrong(f"SQRT of {number_text(value)}: only of 0 or more")
    return math.sqrt(value)
