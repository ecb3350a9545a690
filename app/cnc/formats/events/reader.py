"""ProtoTRAK Plus events (seed 003 §2.2) read back into a 2-axis MillBlocks program.

The file: an optional `%`, a label line (`PN2 G20;`, or a title as in §2.2.6.3's
`SAMPLE P/N G20;`) whose G20/G21 sets inch or mm for the whole file, then one event per
`;`-ended block, `N… G100…G109 <words>`, comments in parentheses, an optional closing `%`.
The Plus is a 2-axis control (DESIGN.md §4): the program has no depths — hole blocks
without Z UP, Z DN or FEEDR Z, the quill worked by hand — and no spindle speeds (reported:
the user enters them).

Numbers (§2.2.4): a dimension, radius, diameter, conrad, finish cut or offset without a
decimal point has implied decimals (4 in inches, 2 in mm: `+1234` = 0.1234 in, `R135` =
1.35 mm); an angle 3 (`A-300000` = -300.000°); an inch feed 1 (`F1` = 0.1 ipm), a metric
feed none. T, HL, FE, LE, RE, TC, DR, N, PN are whole numbers.

Absolute or incremental (§2.2.4): the A or I tag on an axis word overrides G90/G91
(absolute when neither was given). Incremental from (our readings where §2.2.2 is silent):
X/Y, XB/YB and XC/YC of G104/G108/G109 — the position after the previous event; XE/YE —
the event's begin point XB/YB; XC/YC of an arc — its end point XE/YE (§2.2.2 "incremental
from X ending point"); I/J — the begin point (always incremental); XD/YD — the begin corner.
The position after an event: its end point (G100-G103), the last hole the Plus drills
(G104), the lower-left corner of a rectangle or the centre of a circle (G106-G109, as
MillBlocks leaves the reference after a routine), and after a G105 the last repeated
event's, shifted by the last repeat.

What each event becomes (docs/imports.md has the full table):
- G100 → POS (the Plus has no hole event: whether a hole is made there is not in the file).
- G101-G103 connected into a contour (each CR ≥ 0 and the next begins where it ends, one
  tool, one TC) → a DRILL without depths (CUT RT/LT from TC) and MILL STD / ARC blocks. A
  conrad CR > 0 into the next event becomes the block's CONRAD (the compile rounds the
  corner, app/cnc/solve.py), lines and arcs alike; one that does not fit the cuts is
  reported and the corner left sharp.
- G104 → DRILL + BOLT CIR, angle θ0 = 270° − A, the holes then drilled clockwise (the Plus
  goes counter-clockwise from A): the same holes, the same first hole, reported.
- G105 → LOOP/REP when it repeats the whole operations just before it, with one tool, along
  X or Y (REP steps one axis), by a step at the program resolution; otherwise the repeats
  are written out as blocks, and the report says why.
- G106/G108 → DRILL + FRAME/CIRCLE POCKET; G107/G109 → INSIDE or OUTSIDE from TC and DR
  (inside a clockwise path is right of the travel). DR picks Data Block 0's climb or
  conventional (set by the first routine; a later one that needs the other is reported).
  FC > 0 → 2P (MillBlocks leaves 0.010 in / 0.25 mm, reported when FC differs). TC0 (the
  tool centre on the line) is a contour of the rectangle or circle, not a routine.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from decimal import ROUND_HALF_EVEN, Decimal

from app.cnc.blocks import (
    Circle,
    Comp,
    Frame,
    HoleOp,
    MillingMode,
    Placement,
    Program,
)
from app.cnc.formats.events.model import (
    ARC_CENTRE_WORDS,
    WORDS,
    Bolthole,
    Event,
    Mill,
    Position,
    Repeat,
    Routine,
    implied,
    millblocks_angle,
)
from app.cnc.numbers import NUMBER_TEXT, NumberError, parse_int
from app.cnc.plane import Element as MillElement
from app.cnc.recognition.build import Builder, SetUp, block0, make_program
from app.cnc.recognition.common import (
    MAX_ABS_NM,
    XY,
    ImportFailure,
    Notes,
    arc_end_off,
    check_digits,
    decimal_of,
    failure,
    quantize_nm,
    show,
)
from app.cnc.recognition.ops import (
    BoltOp,
    Element,
    HoleSpec,
    LoopOp,
    MillOp,
    Op,
    PosOp,
    RoutineOp,
    tool_of,
)
from app.cnc.recognition.recognise import find_loops
from app.cnc.recognition.steps import ToolData
from app.cnc.routines import rough_wall, routine_clockwise
from app.cnc.solve import CONRAD, make_corner
from app.cnc.units import Units

# Two-letter codes first, so `XB` is not read as X followed by B.
CODES = [
    "XB",
    "YB",
    "XE",
    "YE",
    "XC",
    "YC",
    "XD",
    "YD",
    "XO",
    "YO",
    "HL",
    "PN",
    "CR",
    "TC",
    "FE",
    "FC",
    "DR",
    "LE",
    "RE",
    "X",
    "Y",
    "I",
    "J",
    "A",
    "R",
    "F",
    "T",
    "D",
    "N",
    "G",
]
AXIS_CODES = {"X", "Y", "XB", "YB", "XE", "YE", "XC", "YC", "XD", "YD"}
NUMBER = re.compile(NUMBER_TEXT)
MAX_EVENTS_EXPANDED = 20_000


@dataclass
class EWord:
    code: str
    text: str
    tag: str
    column: int


@dataclass
class EBlock:
    line: int
    words: dict[str, EWord]
    column: int


def read_events(text: str, name: str = "") -> tuple[Program, Notes]:
    """Read an events file. Raises ImportFailure naming line and column."""
    return _Reader(text, name).run()


class _Reader:
    def __init__(self, text: str, name: str) -> None:
        self.text = text
        self.name = name
        self.notes = Notes()
        self.units: Units | None = None
        self.incremental = False
        self.part_number = ""
        self.title = ""
        self.events: list[Event] = []
        self.after: list[XY] = []  # the position after each event
        self.pos: XY = (0, 0)
        self.tc = 0
        self.numbered_differently = False
        self.builder = Builder(self.notes)
        self.milling: MillingMode | None = None
        self.milling_line = 0
        self.diameters: dict[int, tuple[int, int]] = {}
        self.ops: list[Op] = []
        self.op_events: list[tuple[int, int]] = []  # (first, last) event of each op; 0: a copy
        self.chain: list[tuple[int, Mill]] = []

    # -- text -----------------------------------------------------------------------------

    def run(self) -> tuple[Program, Notes]:
        blocks = self.blocks()
        for block in blocks:
            self.event(block)
        if self.units is None:
            raise ImportFailure("", "no events and no G20/G21: nothing to import")
        if not self.events:
            raise ImportFailure("", "no events (G100-G109) in the file")
        return self.program(), self.notes

    def blocks(self) -> list[EBlock]:
        out: list[EBlock] = []
        percent = 0
        seen_event = False
        for number, raw in enumerate(
            self.text.replace("\r\n", "\n").replace("\r", "\n").split("\n"), start=1
        ):
            start = 0
            for piece in raw.split(";"):
                piece_start = start
                column = start + 1
                start += len(piece) + 1
                stripped = piece.strip()
                if not stripped:
                    continue
                column += len(piece) - len(piece.lstrip())
                if stripped.startswith("%"):
                    percent += 1
                    if stripped != "%":
                        raise failure(
                            number, column + 1, "text after % (the file's first and last character)"
                        )
                    continue
                if percent >= 2:
                    self.notes.ignored(number, "after the closing %: not imported")
                    continue
                if (
                    not seen_event
                    and not _has_event(stripped)
                    and self.label(number, column, piece)
                ):
                    continue
                block = self.parse(number, piece, piece_start)
                if block is None:
                    continue
                if "G" in block.words and _g(block) in range(100, 110):
                    seen_event = True
                out.append(block)
        return out

    def label(self, number: int, column: int, piece: str) -> bool:
        """The label line: a title or PN…, then G20/G21. True when `piece` was one."""
        if self.units is not None:
            return False
        stripped = piece.strip()
        tokens = stripped.split()
        if not tokens:
            return False
        last = tokens[-1].upper()
        if last not in ("G20", "G21"):
            if re.fullmatch(r"(N[0-9]+\s*)?G(90|91|20|21)", stripped.upper()):
                return False
            raise failure(
                number,
                column,
                f"the label line {stripped!r} ends without G20 (inch) or G21 (mm) "
                "(seed 003 §2.2.5 `PN2 G20;`)",
            )
        self.units = Units.INCH if last == "G20" else Units.MM
        title = stripped[: len(stripped) - len(tokens[-1])].strip()
        match = re.fullmatch(r"PN\s*([0-9]{1,8})", title.upper())
        if match:
            self.part_number = match.group(1)
            if match.group(1) != "0":
                self.notes.became(number, f"PN{match.group(1)}: the part number")
        elif title.upper().startswith("PN"):
            raise failure(number, column, f"{title!r}: a part number is one to eight digits")
        elif title:
            self.title = title
            self.notes.became(number, f"label {title!r}: the program name")
        self.notes.became(number, f"{last}: {'inch' if last == 'G20' else 'metric'} program")
        return True

    def parse(self, number: int, piece: str, offset: int) -> EBlock | None:
        words: dict[str, EWord] = {}
        pos = 0
        n = len(piece)
        while pos < n:
            ch = piece[pos]
            if ch in " \t":
                pos += 1
                continue
            if ch == "(":
                close = piece.find(")", pos)
                if close < 0:
                    raise failure(number, offset + pos + 1, "comment not closed: '(' without ')'")
                pos = close + 1
                continue
            column = offset + pos + 1
            run = re.match(r"[A-Za-z]+", piece[pos:])
            if run is None:
                raise failure(
                    number, column, f"unexpected {ch!r}: an event word is a code and a number"
                )
            letters = run.group().upper()
            code = next((c for c in CODES if letters.startswith(c)), None)
            if code is None:
                raise failure(
                    number, column, f"{run.group()!r} is not an event code (§2.2.2-2.2.3)"
                )
            pos += len(code)
            if code in words:
                raise failure(number, column, f"{code} given twice in one event")
            match = NUMBER.match(piece, pos)
            if match is None:
                if code == "CR" and piece[pos : pos + 1] == "-":
                    words[code] = EWord(code, "-", "", column)
                    pos += 1
                    continue
                after = piece[pos : pos + 3]
                hint = ""
                if after[:1].upper() in ("O", "Q"):
                    hint = f" (a misprinted 0? {code}{after[:1]}…)"
                raise failure(
                    number, offset + pos + 1, f"{code} needs a number; found {after!r}{hint}"
                )
            digits = match.group().lstrip("+-").replace(".", "")
            if not check_digits(digits):
                raise failure(number, column, f"{code}{match.group()}: too many digits")
            pos = match.end()
            tag = ""
            # A or I straight after an axis value is its tag, unless a number follows it
            # (then it is the next word: `A45.0`, `I0.5`).
            if (
                code in AXIS_CODES
                and pos < n
                and piece[pos].upper() in "AI"
                and NUMBER.match(piece, pos + 1) is None
            ):
                tag = piece[pos].upper()
                pos += 1
            words[code] = EWord(code, match.group(), tag, column)
        if not words:
            return None
        return EBlock(number, words, offset + len(piece) - len(piece.lstrip()) + 1)

    # -- numbers --------------------------------------------------------------------------

    def units_or_fail(self, block: EBlock) -> Units:
        if self.units is None:
            raise failure(block.line, block.column, "an event before the label line's G20/G21")
        return self.units

    def dim(self, block: EBlock, word: EWord) -> int:
        """A dimension, radius, conrad or offset in nm (§2.2.4 implied decimals)."""
        units = self.units_or_fail(block)
        value = self.number(block, word, 4 if units is Units.INCH else 2)
        nm = int((value * units.nm).to_integral_value(rounding=ROUND_HALF_EVEN))
        if abs(nm) > MAX_ABS_NM:
            raise failure(block.line, word.column, f"{word.code}{word.text} is out of range")
        return nm

    def number(self, block: EBlock, word: EWord, places: int) -> Decimal:
        """A word's number, `places` decimals implied (§2.2.4), read by the one number
        reader; what it refuses is a failure at the word's line and column."""
        try:
            return implied(word.text, places)
        except NumberError as exc:
            raise failure(block.line, word.column, f"{word.code}{word.text}: {exc}") from None

    def positive(self, block: EBlock, word: EWord) -> int:
        nm = self.dim(block, word)
        if nm < 0:
            raise failure(
                block.line, word.column, f"{word.code}{word.text}: no negative signs (§2.2.4)"
            )
        return nm

    def integer(
        self, block: EBlock, code: str, low: int, high: int, default: int | None = None
    ) -> int:
        word = block.words.get(code)
        if word is None:
            if default is None:
                raise failure(block.line, block.column, f"{code} missing")
            return default
        if "." in word.text or word.text.startswith(("+", "-")):
            raise failure(
                block.line, word.column, f"{code}{word.text}: a whole number, no sign or point"
            )
        try:
            value = parse_int(word.text)
        except NumberError as exc:
            raise failure(block.line, word.column, f"{code}{word.text}: {exc}") from None
        if not low <= value <= high:
            raise failure(block.line, word.column, f"{code}{word.text} is outside {low} to {high}")
        return value

    def feed(self, block: EBlock) -> int:
        units = self.units_or_fail(block)
        word = block.words.get("F")
        if word is None:
            default = Decimal("1.0") if units is Units.INCH else Decimal(25)
            self.notes.assumed(
                block.line, f"no F: {default} {units.feed_symbol}, the manual's default"
            )
            return int(default * units.nm)
        value = self.number(block, word, 1 if units is Units.INCH else 0)
        if value <= 0:
            raise failure(block.line, word.column, f"F{word.text}: a feed must be more than 0")
        return int((value * units.nm).to_integral_value())

    def axis(self, block: EBlock, code: str, ref: int) -> int | None:
        """An axis word as an absolute coordinate (nm), or None when absent."""
        word = block.words.get(code)
        if word is None:
            return None
        value = self.dim(block, word)
        incremental = word.tag == "I" or (word.tag == "" and self.incremental)
        return ref + value if incremental else value

    def point(self, block: EBlock, cx: str, cy: str, ref: XY, default: XY | None) -> XY:
        """Two axis words as a point; a missing one is `default`'s (an error without one)."""
        x = self.axis(block, cx, ref[0])
        y = self.axis(block, cy, ref[1])
        if x is None or y is None:
            if default is None:
                raise failure(block.line, block.column, f"{cx if x is None else cy} missing")
            x = default[0] if x is None else x
            y = default[1] if y is None else y
        return x, y

    def tool(self, block: EBlock) -> int:
        if "T" not in block.words:
            self.notes.assumed(block.line, "no T: tool 1, the manual's default")
        return self.integer(block, "T", 1, 99, default=1)

    def diameter(self, block: EBlock) -> int | None:
        word = block.words.get("D")
        return None if word is None else self.positive(block, word)

    # -- events -----------------------------------------------------------------------------

    def event(self, block: EBlock) -> None:
        g = _g(block)
        line = block.line
        if g in (20, 21):
            units = Units.INCH if g == 20 else Units.MM
            if self.units is not None and units is not self.units:
                raise failure(line, block.column, f"G{g}: the units change inside the file")
            self.units = units
            return
        if g in (90, 91):
            self.incremental = g == 91
            return
        if g is None:
            raise failure(line, block.column, "a block without a G code")
        if not 100 <= g <= 109:
            raise failure(
                line,
                block.words["G"].column,
                f"G{g} is not an event (G100-G109); a Fanuc-style file is read as G-code",
            )
        allowed = _ALLOWED[g]
        for code, word in block.words.items():
            if code not in allowed:
                raise failure(line, word.column, f"{code} is not a word of a G{g} event")
        number = len(self.events) + 1
        n_word = block.words.get("N")
        if (
            n_word is not None
            and n_word.text.lstrip("0") != str(number)
            and not self.numbered_differently
        ):
            self.numbered_differently = True
            self.notes.assumed(
                line,
                f"N{n_word.text} is not event {number}: FE/LE count the events in the file's "
                "order (the N numbers are line numbers, §2.2.4)",
            )
        event, after = self.make(g, block)
        self.events.append(event)
        self.after.append(after)
        self.pos = after
        if len(self.events) > MAX_EVENTS_EXPANDED:
            raise failure(line, block.column, "too many events")

    def make(self, g: int, block: EBlock) -> tuple[Event, XY]:
        line = block.line
        here = self.pos
        event: Event
        if g == 100:
            at = self.point(block, "X", "Y", here, here)
            return Position(line, at, self.tool(block)), at
        if g in (101, 102, 103):
            begin = self.point(block, "XB", "YB", here, here)
            end = self.point(block, "XE", "YE", begin, begin)
            centre: XY | None = None
            if g != 101:
                if "I" in block.words or "J" in block.words:
                    if "XC" in block.words or "YC" in block.words:
                        raise failure(line, block.column, "both XC/YC and I/J for the centre")
                    i = self.dim(block, block.words["I"]) if "I" in block.words else 0
                    j = self.dim(block, block.words["J"]) if "J" in block.words else 0
                    centre = (begin[0] + i, begin[1] + j)
                else:
                    centre = self.point(block, "XC", "YC", end, None)
                self.check_arc(block, begin, end, centre)
            tc = self.integer(block, "TC", 0, 2, default=self.tc)
            self.tc = tc
            conrad: int | None = 0
            cr = block.words.get("CR")
            if cr is not None:
                conrad = None if cr.text == "-" else self.dim(block, cr)
                if conrad is not None and conrad < 0:
                    conrad = None
            event = Mill(
                line,
                begin,
                end,
                centre,
                g == 102,
                tc,
                self.feed(block),
                self.diameter(block),
                conrad,
                self.tool(block),
            )
            return event, end
        if g == 104:
            centre = self.point(block, "XC", "YC", here, here)
            holes = self.integer(block, "HL", 1, 999)
            r_word = block.words.get("R")
            if r_word is None:
                raise failure(line, block.column, "R (the bolt circle's radius) missing")
            radius = self.positive(block, r_word)
            if radius == 0:
                raise failure(line, r_word.column, "a bolt circle of radius 0")
            a_word = block.words.get("A")
            angle = Decimal(0) if a_word is None else self.number(block, a_word, 3)
            event = Bolthole(line, centre, holes, radius, angle, self.tool(block))
            last = math.radians(float(angle) + (holes - 1) * 360.0 / holes)
            after = (
                centre[0] + round(radius * math.cos(last)),
                centre[1] + round(radius * math.sin(last)),
            )
            return event, after
        if g == 105:
            number = len(self.events) + 1
            first = self.integer(block, "FE", 1, 255, default=number - 1)
            last = self.integer(block, "LE", 1, 255, default=number - 1)
            if not 1 <= first <= last < number:
                raise failure(
                    line,
                    block.column,
                    f"FE{first} LE{last}: a repeat takes events already given (1 to {number - 1})",
                )
            repeats = self.integer(block, "RE", 1, 999)
            ox = self.dim(block, block.words["XO"]) if "XO" in block.words else 0
            oy = self.dim(block, block.words["YO"]) if "YO" in block.words else 0
            for k in range(first, last + 1):
                if isinstance(self.events[k - 1], Repeat):
                    raise failure(
                        line,
                        block.column,
                        f"FE{first} LE{last} takes in the repeat of event {k}: a repeat of a "
                        "repeat is not in the manual",
                    )
            event = Repeat(
                line, first, last, (ox, oy), repeats, self.tool(block), self.diameter(block)
            )
            base = self.after[last - 1]
            return event, (base[0] + repeats * ox, base[1] + repeats * oy)
        # G106-G109
        if g in (106, 107):
            point = self.point(block, "XB", "YB", here, here)
            diagonal: XY | None = self.point(block, "XD", "YD", point, None)
            if "CR" in block.words and block.words["CR"].text == "-":
                raise failure(
                    line, block.words["CR"].column, "CR- on a rectangle: a corner radius is needed"
                )
            radius = self.positive(block, block.words["CR"]) if "CR" in block.words else 0
        else:
            point = self.point(block, "XC", "YC", here, here)
            diagonal = None
            r_word = block.words.get("R")
            if r_word is None:
                raise failure(line, block.column, "R (the circle's radius) missing")
            radius = self.positive(block, r_word)
            if radius == 0:
                raise failure(line, r_word.column, "a circle of radius 0")
        dr = self.integer(block, "DR", 1, 2)
        tc = self.integer(block, "TC", 0, 2, default=self.tc)
        self.tc = tc
        finish = self.positive(block, block.words["FC"]) if "FC" in block.words else 0
        event = Routine(
            line,
            g in (106, 107),
            g in (106, 108),
            point,
            diagonal,
            radius,
            dr == 1,
            tc,
            finish,
            self.feed(block),
            self.diameter(block),
            self.tool(block),
        )
        return event, point

    def check_arc(self, block: EBlock, begin: XY, end: XY, centre: XY) -> None:
        units = self.units_or_fail(block)
        r1, r2 = math.dist(begin, centre), math.dist(end, centre)
        if r1 == 0:
            raise failure(block.line, block.column, "the arc's centre is its begin point")
        if arc_end_off(r1, r2, units):
            raise failure(
                block.line,
                block.column,
                f"the arc's end is {show(abs(r1 - r2), units)} off its radius: the begin is "
                f"{show(r1, units)} from the centre, the end {show(r2, units)}",
            )

    # -- to blocks -------------------------------------------------------------------------

    def program(self) -> Program:
        assert self.units is not None
        units = self.units
        for number, event in enumerate(self.events, start=1):
            if isinstance(event, Repeat):
                self.close_chain()
                self.repeat(number, event)
            else:
                self.take(number, event, (0, 0))
        self.close_chain()
        ops = find_loops(self.ops, 0, self.notes)
        self.notes.assumed(
            None,
            "the ProtoTRAK Plus is a 2-axis control: no depths (hole blocks without Z UP, Z DN, "
            "FEEDR Z; the quill by hand) and no spindle speeds in the file",
        )
        self.builder.run(ops)
        self.builder.flush_rounding()
        tools = {n: ToolData(diameter=d) for n, (d, _) in self.diameters.items()}
        setup = SetUp(units=units, milling=self.milling, tools=tools)
        for op in ops:
            for t in _tools(op):
                setup.rpms.setdefault(t, None)
        db0 = block0(setup, ops, self.notes)
        return make_program(
            self.title or self.name,
            self.part_number,
            units,
            "imported from ProtoTRAK Plus events",
            db0,
            self.builder.blocks,
        )

    def take(self, number: int, event: Event, shift: XY) -> None:
        """Event `number` (0 for a copy made by a G105), shifted by `shift`."""
        if shift != (0, 0):
            event = event.moved(shift)
        self.note_diameter(event)
        if isinstance(event, Mill):
            if self.chain and not self.continues(self.chain[-1][1], event):
                self.close_chain()
            self.chain.append((number, event))
            if event.conrad is None:
                self.close_chain()
            return
        self.close_chain()
        units = self.units
        assert units is not None
        line = event.source
        if isinstance(event, Position):
            self.add(PosOp([line], event.at, event.tool, units), number, number)
        elif isinstance(event, Bolthole):
            self.bolt(number, event)
        elif isinstance(event, Routine):
            self.routine(number, event)

    def add(self, op: Op, first: int, last: int) -> None:
        self.ops.append(op)
        self.op_events.append((first, last))

    def note_diameter(self, event: Event) -> None:
        if isinstance(event, Position | Bolthole):
            return
        if event.diameter is None:
            return
        tool = event.tool
        known = self.diameters.get(tool)
        if known is None:
            self.diameters[tool] = (event.diameter, event.source)
        elif known[0] != event.diameter:
            assert self.units is not None
            self.notes.assumed(
                event.source,
                f"D{show(event.diameter, self.units)} for tool {tool}: Data Block 0 keeps one "
                f"diameter per tool (D{show(known[0], self.units)} from line {known[1]})",
            )

    def continues(self, previous: Mill, event: Mill) -> bool:
        if previous.conrad is None:
            return False
        if event.begin != previous.end:
            self.notes.assumed(
                event.source,
                "the event before is connected (CR not negative) but this one begins "
                "elsewhere: a new mill sequence",
            )
            return False
        if event.tool != previous.tool:
            self.notes.assumed(event.source, "another tool: a new mill sequence")
            return False
        if event.comp != previous.comp:
            self.notes.assumed(
                event.source,
                f"TC{event.comp} after TC{previous.comp}: MillBlocks sets cutter compensation "
                "once per mill sequence, so a new one starts here",
            )
            return False
        return True

    def close_chain(self) -> None:
        if not self.chain:
            return
        chain, self.chain = self.chain, []
        units = self.units
        assert units is not None
        first = chain[0][1]
        comp = {0: Comp.NONE, 1: Comp.RIGHT, 2: Comp.LEFT}[first.comp]
        elements = [Element(e.source, e.end, e.centre, e.clockwise, None, e.feed) for _, e in chain]
        elements = self.fillets(chain, elements)
        last = chain[-1][1]
        if last.conrad:
            self.notes.ignored(
                last.source,
                f"CR{show(last.conrad, units)} after the last event of a contour: no corner "
                "to round",
            )
        spec = HoleSpec(HoleOp.DRILL, None, None, None, 1, first.tool, units)
        lines = [e.source for _, e in chain]
        op = MillOp(lines, first.begin, spec, comp, elements, quill_stops=2)
        self.add(op, chain[0][0], chain[-1][0])

    def fillets(self, chain: list[tuple[int, Mill]], elements: list[Element]) -> list[Element]:
        """CR > 0 into the next connected event: the conrad of the block (app.cnc.solve
        rounds the corner in the compile), where that arc fits both cuts."""
        units = self.units
        assert units is not None
        out: list[Element] = []
        starts = [chain[0][1].begin] + [e.end for _, e in chain[:-1]]
        for k, element in enumerate(elements):
            event = chain[k][1]
            radius = event.conrad
            if not radius or k + 1 >= len(elements):
                out.append(element)
                continue
            nxt = elements[k + 1]
            made = make_corner(_pt(starts[k]), _cut(element), _cut(nxt), CONRAD, float(radius))
            if isinstance(made, str):
                self.notes.ignored(
                    event.source, f"CR{show(radius, units)}: {made}; the corner stays sharp"
                )
                out.append(element)
                continue
            out.append(
                Element(
                    element.line,
                    element.end,
                    element.centre,
                    element.clockwise,
                    element.z_dn,
                    element.feed,
                    radius,
                )
            )
            self.notes.became(
                event.source,
                f"CR{show(radius, units)}: the corner X{show(element.end[0], units)} "
                f"Y{show(element.end[1], units)} keeps its point, with a CONRAD of that radius "
                "into the next block",
            )
        return out

    def bolt(self, number: int, event: Bolthole) -> None:
        units = self.units
        assert units is not None
        theta = millblocks_angle(event.angle)
        angle = theta.quantize(Decimal("0.01"), rounding=ROUND_HALF_EVEN)
        if angle >= 360:
            angle -= 360
        if angle != theta:
            self.builder.log(event.source, f"angle {theta}° → {angle}°")
        spec = HoleSpec(HoleOp.DRILL, None, None, None, 1, event.tool, units)
        bolt = BoltOp([event.source], event.centre, spec, event.holes, angle, event.radius)
        self.add(bolt, number, number)
        if event.holes >= 3:
            self.notes.assumed(
                event.source,
                f"A{event.angle} (counter-clockwise from +X) is a BOLT CIR angle of {angle}° "
                "(clockwise from below, 270° − A): the same first hole; MillBlocks drills the "
                f"other {event.holes - 1} clockwise, the Plus counter-clockwise",
            )

    def routine(self, number: int, event: Routine) -> None:
        units = self.units
        assert units is not None
        line = event.source
        pocket = event.code in (106, 108)
        rect = event.code in (106, 107)
        b = self.builder
        if not pocket and event.comp == 0:
            self.contour_of(number, event)
            return
        if pocket:
            placement = Placement.POCKET
            expected = 1 if event.clockwise else 2
            if event.comp not in (0, expected):
                self.notes.ignored(
                    line,
                    f"TC{event.comp} on a pocket cut {_turn(event.clockwise)}: the inside is on "
                    "the other side; a pocket is inside by itself (TC not used)",
                )
        else:
            inside = (event.comp == 1) == event.clockwise
            placement = Placement.INSIDE if inside else Placement.OUTSIDE
        two_pass = event.finish > 0
        if two_pass and event.finish != rough_wall(units):
            self.notes.assumed(
                line,
                f"FC{show(event.finish, units)}: 2P, which leaves {show(rough_wall(units), units)} "
                "for the finishing pass",
            )
        feed = b.feed(event.feed, units, line, "FEEDR XY")
        at = event.point
        block: Circle | Frame
        if rect:
            assert event.diagonal is not None
            x0, x1 = sorted((event.point[0], event.diagonal[0]))
            y0, y1 = sorted((event.point[1], event.diagonal[1]))
            if (x0, y0) != event.point:
                self.notes.assumed(
                    line, "XB/YB is not the lower-left corner: the corners are swapped"
                )
            at = (x0, y0)
            xl = b.length(x1 - x0, units, line, "XL")
            yw = b.length(y1 - y0, units, line, "YW")
            corner = b.length(event.radius, units, line, "CR")
            if xl <= 0 or yw <= 0:
                raise failure(line, 1, "a rectangle with no width or no height")
            block = Frame(
                placement=placement,
                two_pass=two_pass,
                xl=decimal_of(xl, units),
                yw=decimal_of(yw, units),
                corner_radius=decimal_of(corner, units),
                feed_xy=feed,
                tool=event.tool,
                units=units,
            )
        else:
            radius = b.length(event.radius, units, line, "R")
            block = Circle(
                placement=placement,
                two_pass=two_pass,
                radius=decimal_of(radius, units),
                feed_xy=feed,
                tool=event.tool,
                units=units,
            )
        mode = next(
            m for m in MillingMode if routine_clockwise(placement, m, None) == event.clockwise
        )
        if self.milling is None:
            self.milling, self.milling_line = mode, line
            self.notes.became(
                line,
                f"DR{1 if event.clockwise else 2}: Data Block 0 {mode.value} milling, so that "
                f"MillBlocks cuts this {block.type_name} "
                f"{'clockwise' if event.clockwise else 'counter-clockwise'} as the Plus does "
                "(with the clockwise spindle of a tool entered without RPM; a negative RPM "
                "turns it the other way)",
            )
        elif mode is not self.milling:
            self.notes.ignored(
                line,
                f"DR{1 if event.clockwise else 2}: the Plus cuts this "
                f"{'clockwise' if event.clockwise else 'counter-clockwise'}; with Data Block "
                f"0's {self.milling.value} milling (line {self.milling_line}) MillBlocks cuts it "
                "the other way",
            )
        spec = HoleSpec(HoleOp.DRILL, None, None, None, 1, event.tool, units)
        self.add(RoutineOp([line], at, spec, block), number, number)
        self.notes.assumed(
            line,
            f"G{event.code}: the Plus cuts it with its own entry and passes; MillBlocks' "
            f"{block.type_name} enters and steps over its own way"
            + (" (IN/TAN or OUT/TAN are other choices)" if not pocket else ""),
        )

    def contour_of(self, number: int, event: Routine) -> None:
        """TC0 on a frame: the tool centre goes round the line itself, a contour."""
        units = self.units
        assert units is not None
        line = event.source
        cw = event.clockwise
        elements: list[Element]
        if event.code == 109:
            cx, cy = event.point
            start = (cx, cy - event.radius)
            elements = [Element(line, start, (cx, cy), cw, None, event.feed)]
        else:
            assert event.diagonal is not None
            x0, x1 = sorted((event.point[0], event.diagonal[0]))
            y0, y1 = sorted((event.point[1], event.diagonal[1]))
            r = min(event.radius, (x1 - x0) // 2, (y1 - y0) // 2)
            start = ((x0 + x1) // 2, y0)
            corners = [
                ((x1 - r, y0), (x1 - r, y0 + r), (x1, y0 + r)),
                ((x1, y1 - r), (x1 - r, y1 - r), (x1 - r, y1)),
                ((x0 + r, y1), (x0 + r, y1 - r), (x0, y1 - r)),
                ((x0, y0 + r), (x0 + r, y0 + r), (x0 + r, y0)),
            ]
            ccw: list[tuple[XY, XY | None]] = []
            for before, centre, after in corners:
                ccw.append((before, None))
                if r > 0:
                    ccw.append((after, centre))
            ccw.append((start, None))
            if cw:
                points = [start] + [p for p, _ in ccw]
                path: list[tuple[XY, XY | None]] = []
                for k in range(len(ccw) - 1, -1, -1):
                    path.append((points[k], ccw[k][1]))
            else:
                path = ccw
            elements = [Element(line, p, c, cw, None, event.feed) for p, c in path]
        spec = HoleSpec(HoleOp.DRILL, None, None, None, 1, event.tool, units)
        self.add(MillOp([line], start, spec, Comp.NONE, elements, quill_stops=2), number, number)
        self.notes.assumed(
            line,
            f"G{event.code} with TC0 (the tool centre on the line): a contour of the "
            f"{'circle' if event.code == 109 else 'rectangle'} from the middle of its lower "
            "side, where MillBlocks starts its routines",
        )

    def repeat(self, number: int, event: Repeat) -> None:
        units = self.units
        assert units is not None
        line = event.source
        # A G105's D is the diameter of its tool (T), as on every other event with D.
        self.note_diameter(event)
        first, last = event.first, event.last
        reason = self.loop_refusal(number, event)
        if reason is None:
            start = next(k for k, (a, _) in enumerate(self.op_events) if a == first)
            body = self.ops[start:]
            step = event.offset
            nx, ny = (event.repeats, 0) if step[1] == 0 else (0, event.repeats)
            loop = LoopOp([line], body, step, nx, ny)
            del self.ops[start:]
            del self.op_events[start:]
            self.add(loop, first, number)
            self.notes.became(
                line,
                f"G105 FE{first} LE{last} RE{event.repeats}: the operations of events {first}-"
                f"{last} repeated, shifted X{show(step[0], units)} Y{show(step[1], units)}: "
                "LOOP … REP",
            )
        else:
            self.notes.assumed(
                line,
                f"G105 FE{first} LE{last} RE{event.repeats}: {reason}, so the repeats are "
                "written out as blocks",
            )
            total = (last - first + 1) * event.repeats
            if len(self.events) + total > MAX_EVENTS_EXPANDED:
                raise failure(line, 1, "the repeats make too many events")
            for k in range(1, event.repeats + 1):
                shift = (k * event.offset[0], k * event.offset[1])
                for n in range(first, last + 1):
                    # A copy is reported as made by the G105's line.
                    self.take(0, replace(self.events[n - 1], source=line), shift)
                self.close_chain()
        tools = {e.tool for e in self.events[first - 1 : last] if not isinstance(e, Repeat)}
        if tools != {event.tool}:
            self.notes.ignored(
                line,
                f"T{event.tool:02d} on the G105: the repeated events keep their own tools",
            )

    def loop_refusal(self, number: int, event: Repeat) -> str | None:
        """Why G105 event `number` cannot be a LOOP/REP (None when it can)."""
        units = self.units
        assert units is not None
        first, last = event.first, event.last
        if last != number - 1:
            return "it repeats events that are not the ones just before it"
        starts = [a for a, _ in self.op_events]
        if first not in starts:
            return "event FE is inside a contour, not at the start of one"
        if self.op_events and self.op_events[-1][1] != last:
            return "event LE is not the end of an operation"
        start = starts.index(first)
        body = self.ops[start:]
        if any(isinstance(op, LoopOp) for op in body):
            return "a repeat of a repeat is written out"
        tools = {t for op in body for t in _tools(op)}
        if len(tools) > 1:
            listed = " and ".join(str(t) for t in sorted(tools))
            return f"the events use tools {listed} and a LOOP has one tool"
        ox, oy = event.offset
        if ox and oy:
            return "the offset is along both X and Y; a REP steps along one axis per count"
        if not ox and not oy:
            return "the offset is zero"
        if quantize_nm(ox, units) != ox or quantize_nm(oy, units) != oy:
            return "the offset is finer than the program resolution"
        return None


# The words an event may have: N and G, the words the model lists, and I J on an arc.
_ALLOWED: dict[int, set[str]] = {
    g: {"N", "G", *words, *(ARC_CENTRE_WORDS if g in (102, 103) else ())}
    for g, words in WORDS.items()
}


def _g(block: EBlock) -> int | None:
    word = block.words.get("G")
    if word is None:
        return None
    if "." in word.text or word.text.startswith(("+", "-")):
        return -1
    return int(word.text)


def _turn(clockwise: bool) -> str:
    return "clockwise" if clockwise else "counter-clockwise"


def _has_event(text: str) -> bool:
    return re.search(r"G\s*10[0-9](?![0-9])", text.upper()) is not None


def _pt(p: XY) -> tuple[float, float]:
    return (float(p[0]), float(p[1]))


def _cut(element: Element) -> MillElement:
    """An imported cut as the milling geometry's element (for the corner rule)."""
    centre = None if element.centre is None else _pt(element.centre)
    return MillElement(element.line, _pt(element.end), centre, element.clockwise)


def _tools(op: Op) -> set[int]:
    if isinstance(op, LoopOp):
        return {t for body in op.body for t in _tools(body)}
    return {tool_of(op)}
