"""Property-based tests of validation, the interpreter and the program document.

The programs come from `tests.strategies.programs()`: valid programs (no validation errors,
sometimes warnings) of POS, DRILL/BORE/TAP, bolt circles, DRILL + MILL STD sequences and
nested LOOP/REP, in inch, mm or both. Each property is checked against the readings of
DESIGN.md §3 with helpers written here from the manual, not with the interpreter's own
(`retract_height`, `peck_levels`, `structure`), so a bug there is not copied into the test.

Lengths are compared in integer nanometres, as in the Toolpath.
"""

from __future__ import annotations

import copy
import json
import math
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass
from decimal import Decimal

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as hst

from app.cnc.blocks import (
    BoltCircle,
    Copy,
    Hole,
    HoleOp,
    MillLine,
    Mode,
    Pos,
    Program,
    Rep,
)
from app.cnc.document import as_stored, dumps, loads, to_dict
from app.cnc.formats import canon
from app.cnc.interpret import interpret
from app.cnc.path import distinct
from app.cnc.problems import Severity, has_errors
from app.cnc.toolpath import (
    ArcFeed,
    Dwell,
    Feed,
    Motion,
    Move,
    ProgramEnd,
    ProgramStop,
    Rapid,
    SpindleOff,
    SpindleOn,
    ToolChange,
    Toolpath,
)
from app.cnc.units import Units
from app.cnc.validate import validate
from tests.strategies import programs

# Generous enough to find bugs, small enough that the whole file runs in well under a minute.
PROPERTY = settings(max_examples=50, deadline=None)

NM_PER_UNIT = {Units.INCH: 25_400_000, Units.MM: 1_000_000}
# How far above Z UP a TAP feeds out (seed 001 §3.4.5.1): 0.3 in, which is 7.62 mm.
TAP_LIFT_NM = 7_620_000

Point = tuple[int, int, int]
XY = tuple[int, int]


# -- helpers written from the manual ---------------------------------------------------------


def nm(value: Decimal, units: Units) -> int:
    """A typed length in nanometres; lengths at the programming resolution convert exactly."""
    exact = value * NM_PER_UNIT[units]
    assert exact == exact.to_integral_value(), f"{value} {units.symbol} is not whole nm"
    return int(exact)


def retract_height(z_up: int, z_retract: int) -> int:
    """DESIGN.md §3: Z RET above Z UP, or above tool zero when Z UP is negative."""
    return (z_up if z_up >= 0 else 0) + z_retract


@dataclass(frozen=True)
class Role:
    """What a data block does and the depths that govern its moves (nm).

    `kind` is `pos`, `hole` (a standard hole), `centre` (the block before a BOLT CIR),
    `bolt`, `mill-drill` (a DRILL starting a mill sequence), `mill` or `other`. A BOLT CIR
    takes Z UP/Z DN from its centre block; a MILL STD takes Z UP from the sequence's DRILL
    and Z DN from its own field, else from the block before it. `group` is the number of
    the first block of the unit the control runs together (centre + BOLT CIR, DRILL + mills).
    """

    kind: str
    op: HoleOp | None
    z_up: int | None
    z_dn: int | None
    tool: int | None
    group: int


def roles(program: Program) -> dict[int, Role]:
    """The Role of every data block, by block number."""
    blocks = program.blocks
    result: dict[int, Role] = {}
    for index, block in enumerate(blocks):
        number = index + 1
        nxt = blocks[index + 1] if index + 1 < len(blocks) else None
        if isinstance(block, Hole):
            assert block.z_up is not None and block.z_dn is not None
            kind = "hole"
            if isinstance(nxt, BoltCircle):
                kind = "centre"
            elif isinstance(nxt, MillLine):
                kind = "mill-drill"
            z_up, z_dn = nm(block.z_up, block.units), nm(block.z_dn, block.units)
            result[number] = Role(kind, block.op, z_up, z_dn, block.tool, number)
        elif isinstance(block, BoltCircle):
            centre = result[number - 1]
            result[number] = Role(
                "bolt", block.op, centre.z_up, centre.z_dn, centre.tool, centre.group
            )
        elif isinstance(block, MillLine):
            before = result[number - 1]
            depth = before.z_dn if block.z_dn is None else nm(block.z_dn, block.units)
            result[number] = Role("mill", None, before.z_up, depth, block.tool, before.group)
        elif isinstance(block, Pos):
            result[number] = Role("pos", None, None, None, block.tool, number)
        else:
            result[number] = Role("other", None, None, None, None, number)
    return result


def loop_pairs(program: Program) -> dict[int, int]:
    """LOOP block index → index of the REP that closes it (0-based)."""
    pairs: dict[int, int] = {}
    open_loops: list[int] = []
    for index, block in enumerate(program.blocks):
        if block.loop:
            open_loops.append(index)
        if isinstance(block, Rep):
            pairs[open_loops.pop()] = index
    assert not open_loops
    return pairs


def patterns(program: Program) -> dict[int, int]:
    """Block number → how often it runs: Π (NX+1)(NY+1) over the LOOP/REP pairs around it."""
    counts = dict.fromkeys(range(1, len(program.blocks) + 1), 1)
    for loop, rep_index in loop_pairs(program).items():
        rep = program.blocks[rep_index]
        assert isinstance(rep, Rep)
        for number in range(loop + 1, rep_index + 2):
            counts[number] *= (rep.nx + 1) * (rep.ny + 1)
    return counts


def end_point(move: Motion) -> Point:
    return (move.x, move.y, move.z)


def tool_change_z(here: Point, move: ToolChange) -> int:
    """Z after a tool change: what the ToolChange reports (Z is measured from the new tool's
    calibrated zero, so the same head height may read differently), or Z unchanged when the
    ToolChange carries no Z.
    """
    z: int = getattr(move, "z", here[2])
    return z


def walk(toolpath: Toolpath) -> Iterator[tuple[Point, Move]]:
    """Every move with the tool position before it, from `toolpath.start`."""
    here = toolpath.start
    for move in toolpath.moves:
        yield here, move
        if isinstance(move, Rapid | Feed | ArcFeed):
            here = end_point(move)
        elif isinstance(move, ToolChange):
            here = (here[0], here[1], tool_change_z(here, move))


def motions(toolpath: Toolpath) -> Iterator[tuple[Point, Motion]]:
    """Every motion with the point it starts from (the end of the one before it)."""
    for here, move in walk(toolpath):
        if isinstance(move, Rapid | Feed | ArcFeed):
            yield here, move


def is_vertical(start: Point, move: Motion) -> bool:
    return (move.x, move.y) == start[:2] and move.z != start[2]


def goes_up(start: Point, move: Motion) -> bool:
    """A move straight up. The checks on depth skip these: a move up ends higher than a
    point already checked, and the climb before a tool change is tagged with the new
    block but measured from the old tool's zero.
    """
    return is_vertical(start, move) and move.z > start[2]


def starts_hole(role: Role, start: Point, move: Motion) -> bool:
    """A feed straight down from Z UP by a hole-making block: a hole (or plunge) begins."""
    return (
        isinstance(move, Feed)
        and role.kind in ("hole", "bolt", "mill-drill")
        and start[2] == role.z_up
        and is_vertical(start, move)
        and move.z < start[2]
    )


def hole_starts(program: Program, toolpath: Toolpath) -> list[tuple[int, XY]]:
    """(block number, XY) of each hole begun, in tool path order."""
    role_of = roles(program)
    return [
        (move.block, (move.x, move.y))
        for start, move in motions(toolpath)
        if starts_hole(role_of[move.block], start, move)
    ]


def expected_hole_starts(program: Program) -> list[tuple[int, XY]]:
    """An independent model of where seed 001 §3.4.5 makes holes, in order.

    Positions follow ABS/INC from the reference point (the last position: a POS, a hole,
    the last mill end, the last hole of a bolt circle). A LOOP/REP runs its body (the LOOP
    block's own unit first) (NX+1)(NY+1) times, Y rows outer and X inner, pattern (i, j)
    starting from the reference before the LOOP plus (i·ΔX, j·ΔY). A bolt circle's centre
    is not drilled; hole k is at centre + R·(−sin θk, −cos θk), θk = A + k·360°/N. A DRILL
    starting a mill sequence counts once per run, at its own XY.
    """
    blocks = program.blocks
    pairs = loop_pairs(program)
    starts: list[tuple[int, XY]] = []

    def place(block: Pos | Hole | MillLine, ref: XY) -> XY:
        assert block.x is not None and block.y is not None  # generated programs give both
        x, y = nm(block.x, block.units), nm(block.y, block.units)
        return (ref[0] + x, ref[1] + y) if block.mode is Mode.INC else (x, y)

    def run(first: int, stop: int, ref: XY, inside: int | None) -> XY:
        index = first
        while index < stop:
            block = blocks[index]
            nxt = blocks[index + 1] if index + 1 < len(blocks) else None
            if block.loop and index != inside:
                rep = blocks[pairs[index]]
                assert isinstance(rep, Rep)
                step = (nm(rep.x, rep.units), nm(rep.y, rep.units))
                origin = ref
                for j in range(rep.ny + 1):
                    for i in range(rep.nx + 1):
                        pattern = (origin[0] + i * step[0], origin[1] + j * step[1])
                        ref = run(index, pairs[index], pattern, index)
                index = pairs[index] + 1
            elif isinstance(block, Copy):
                index += 1
            elif isinstance(block, Pos):
                ref = place(block, ref)
                index += 1
            elif isinstance(block, Hole) and isinstance(nxt, BoltCircle):
                cx, cy = place(block, ref)
                radius = nm(nxt.radius, nxt.units)
                for k in range(nxt.holes):
                    theta = math.radians(float(nxt.angle) + k * 360.0 / nxt.holes)
                    ref = (
                        cx + round(-radius * math.sin(theta)),
                        cy + round(-radius * math.cos(theta)),
                    )
                    starts.append((index + 2, ref))
                index += 2
            elif isinstance(block, Hole):
                ref = place(block, ref)
                starts.append((index + 1, ref))
                index += 1
                while index < stop and isinstance(blocks[index], MillLine):
                    line = blocks[index]
                    assert isinstance(line, MillLine)
                    ref = place(line, ref)
                    index += 1
            else:
                raise AssertionError(f"block {index + 1}: unexpected {block.title}")
        return ref

    run(0, len(blocks), (0, 0), None)
    return starts


# -- the strategy's own contract ---------------------------------------------------------


@PROPERTY
@given(programs())
def test_generated_programs_are_valid(program: Program) -> None:
    """The strategy's promise: validation finds no errors (warnings are allowed)."""
    problems = validate(program)
    assert not has_errors(problems), [str(p) for p in problems if p.severity is Severity.ERROR]


# -- (a) continuity ----------------------------------------------------------------------------


@PROPERTY
@given(programs())
def test_motion_is_continuous_and_axis_separated(program: Program) -> None:
    """(a) Walking the motions (Rapid, Feed, ArcFeed) from `toolpath.start`:

    - the walk starts over part zero at Z RET above tool zero (DESIGN.md §3);
    - each motion starts where the one before it ended (a move stores only its end point, so
      this is the walk itself) and goes somewhere: a straight move never ends where it
      started (the interpreter drops moves that go nowhere);
    - a straight move (Rapid or Feed) changes either Z alone (at unchanged XY: a hole, a
      plunge, a retract) or XY alone, never both: no diagonal XYZ rapid or feed;
    - an arc stays at its start Z, has a radius, and starts on its own circle;
    - a Feed has a positive feed; the last move is ProgramEnd;
    - the head does not move at a tool change; when the ToolChange reports Z (measured
      from the new tool's calibrated zero), it is the old Z + old TCAL − new TCAL (an
      uncalibrated tool, or none, counts as TCAL 0).
    """
    toolpath = interpret(program)
    z_retract = nm(program.block0.z_retract, program.units)
    tcal = {t.number: nm(t.tcal, program.units) for t in program.block0.tools if t.tcal is not None}
    assert toolpath.start == (0, 0, z_retract)
    tool = toolpath.initial_tool
    for start, move in walk(toolpath):
        if isinstance(move, ToolChange):
            if hasattr(move, "z"):
                expected = start[2] + tcal.get(tool, 0) - tcal.get(move.tool, 0)
                assert tool_change_z(start, move) == expected, move
            tool = move.tool
        if not isinstance(move, Rapid | Feed | ArcFeed):
            continue
        end = end_point(move)
        if isinstance(move, ArcFeed):
            r_start = math.hypot(start[0] - move.cx, start[1] - move.cy)
            r_end = math.hypot(move.x - move.cx, move.y - move.cy)
            assert move.z == start[2], f"arc of block {move.block} changes Z"
            assert r_start > 0 and abs(r_start - r_end) <= 2
            continue
        assert end != start, f"zero-length {type(move).__name__} of block {move.block}"
        xy_changes, z_changes = end[:2] != start[:2], end[2] != start[2]
        assert not (xy_changes and z_changes), f"diagonal move of block {move.block}: {move}"
        if isinstance(move, Feed):
            assert move.feed > 0
    assert isinstance(toolpath.moves[-1], ProgramEnd)


# -- (b) safety above the stock ------------------------------------------------------------


@PROPERTY
@given(programs())
def test_rapids_stay_above_the_stock(program: Program) -> None:
    """(b) With the stock top of each hole at its block's Z UP, for every Rapid that moves
    across or down (a rapid straight up cannot run into the stock):

    - one made by a hole, BOLT CIR or mill block never ends below the Z UP that governs it
      (its own; the centre block's for BOLT CIR; the DRILL's for a mill block), except a
      rapid tagged `peck-reentry`;
    - one made by any other block (POS, REP, a pending COPY) never ends below the Z UP of
      the last hole-making block run before it;
    - a `peck-reentry` rapid goes straight down from at or above Z UP, at an XY where a
      hole has begun (a feed down from Z UP), and ends no deeper than the deepest Z fed to
      at that XY since the hole began: it re-enters to the level already cut, never below.
    """
    role_of = roles(program)
    toolpath = interpret(program)
    last_z_up: int | None = None
    deepest: dict[XY, int] = {}
    for start, move in motions(toolpath):
        role = role_of[move.block]
        z_up = role.z_up if role.z_up is not None else last_z_up
        xy = (move.x, move.y)
        if starts_hole(role, start, move):
            deepest[xy] = move.z
        elif isinstance(move, Feed | ArcFeed) and xy in deepest:
            deepest[xy] = min(deepest[xy], move.z)
        if isinstance(move, Rapid) and move.tag == "peck-reentry":
            assert z_up is not None and start[2] >= z_up
            assert is_vertical(start, move) and move.z < start[2]
            assert xy in deepest, f"block {move.block} re-enters at {xy} where no hole began"
            assert move.z >= deepest[xy], (
                f"block {move.block} re-enters to {move.z} nm below the {deepest[xy]} nm cut"
            )
        elif isinstance(move, Rapid) and z_up is not None and not goes_up(start, move):
            assert move.z >= z_up, f"rapid of block {move.block} ends below Z UP: {move}"
        if role.z_up is not None:
            last_z_up = role.z_up


# -- (c) depth -------------------------------------------------------------------------------


@PROPERTY
@given(programs())
def test_no_move_below_z_dn(program: Program) -> None:
    """(c) No motion ends below the Z DN of the block that made it: its own Z DN for a
    hole, the centre block's for a BOLT CIR, and for a MILL STD its own Z DN or, without
    one, the depth in force (the MILL STD or DRILL before it). A BOLT CIR centre makes no
    motion at all. Blocks without a Z DN (POS, REP, COPY) never go below the retract height
    in force (that of the last hole-making block run, Z RET before any). Moves straight up
    are not checked (see `goes_up`).

    A mill sequence with pecks runs at each level (seed 001 PECK): until the DRILL has fed
    to its own Z DN, no mill block's move goes below the level the DRILL last fed to.
    """
    role_of = roles(program)
    toolpath = interpret(program)
    z_retract = nm(program.block0.z_retract, program.units)
    retract = z_retract
    level: int | None = None  # the level a mill sequence's DRILL last fed to, above its Z DN
    for start, move in motions(toolpath):
        role = role_of[move.block]
        assert role.kind != "centre", f"the bolt-circle centre block {move.block} moved"
        if goes_up(start, move):
            pass
        elif role.z_dn is not None:
            assert move.z >= role.z_dn, f"block {move.block} goes below its Z DN: {move}"
        else:
            assert move.z >= retract, f"block {move.block} goes below the retract height"
        if role.kind == "mill-drill" and isinstance(move, Feed) and move.z < start[2]:
            level = None if move.z == role.z_dn else move.z
        elif role.kind == "mill" and level is not None:
            assert move.z >= level, f"block {move.block} cuts below the peck level {level} nm"
        elif role.kind != "mill":
            level = None
        if role.z_up is not None:
            retract = retract_height(role.z_up, z_retract)


# -- (d) retract height ------------------------------------------------------------------------


@PROPERTY
@given(programs())
def test_xy_rapids_at_retract_height(program: Program) -> None:
    """(d) DESIGN.md §3's retract height is Z RET above Z UP, or above tool zero when Z UP is
    negative; before any hole block it is Z RET above tool zero. Every Rapid that changes
    XY happens at or above both the retract height in force before it (that of the last
    hole-making block run) and the retract height of the block making it (a POS travels at
    the height in force): the head goes up before it moves across, never across and then
    up. After each operation (when the motions pass from one unit the control runs
    together to another: a block, centre + BOLT CIR, DRILL + mills), at each tool change
    (before and after it), program stop and the program end, the head is at or above the
    retract height in force. A rapid tagged `retract` (climbing to the height in force, or
    above it for a tool change) does not yet put the next block's height in force.
    """
    role_of = roles(program)
    toolpath = interpret(program)
    z_retract = nm(program.block0.z_retract, program.units)
    retract = z_retract
    group: int | None = None
    for here, move in walk(toolpath):
        if isinstance(move, ToolChange | ProgramStop | ProgramEnd):
            assert here[2] >= retract, f"{move} below the retract height {retract} nm"
        if isinstance(move, ToolChange):
            assert tool_change_z(here, move) >= retract, f"{move}: new tool below {retract} nm"
        if not isinstance(move, Rapid | Feed | ArcFeed):
            continue
        role = role_of[move.block]
        if group is not None and role.group != group:
            assert here[2] >= retract, f"block {group}'s unit ends below {retract} nm"
        group = role.group
        own = retract if role.z_up is None else retract_height(role.z_up, z_retract)
        if isinstance(move, Rapid) and (move.x, move.y) != here[:2]:
            needed = max(retract, own)
            assert move.z >= needed, f"XY rapid of block {move.block} at {move.z} < {needed} nm"
        if not (isinstance(move, Rapid) and move.tag == "retract"):
            retract = own


# -- (e) document round trip -------------------------------------------------------------------


@PROPERTY
@given(programs())
def test_document_round_trip(program: Program) -> None:
    """(e) The JSON document is lossless and stable: `loads(dumps(p)) == p` (every typed
    value, enum and text, including programs with warnings) and writing what was read gives
    the same text again.
    """
    text = dumps(program)
    again = loads(text)
    assert again == program
    assert dumps(again) == text
    # dumps assembles the text from each block's own (kept per block object): it is the
    # plain JSON writer's text, and as_stored is the program its document reads back as.
    assert text == json.dumps(to_dict(program), indent=2, ensure_ascii=False) + "\n"
    stored = as_stored(program)
    assert stored == again and repr(stored) == repr(again)


# -- (f) determinism ---------------------------------------------------------------------------


@PROPERTY
@given(programs())
def test_interpretation_is_deterministic(program: Program) -> None:
    """(f) The canonical dump is a pure function of the program: the same bytes when computed
    twice, from a deep copy, and from the program read back from its document (whose
    numbers may be spelled differently, e.g. 1.5 for 1.500).
    """
    first = canon.dump(interpret(program))
    assert canon.dump(interpret(program)) == first
    assert canon.dump(interpret(copy.deepcopy(program))) == first
    assert canon.dump(interpret(loads(dumps(program)))) == first


# -- (g) hole count -----------------------------------------------------------------------------


@PROPERTY
@given(programs())
def test_hole_count(program: Program) -> None:
    """(g) The holes made are the holes programmed. For each block, with P the product of
    (NX+1)(NY+1) over the LOOP/REP pairs around it:

    - a standard hole block makes P holes, a BOLT CIR makes # HOLES × P, a bolt-circle
      centre and a DRILL starting a mill sequence make none;
    - every hole is one feed down that ends at Z DN (the last peck only), and a DRILL or
      BORE hole dwells once there (a TAP never dwells); nothing else dwells.
    """
    role_of = roles(program)
    runs = patterns(program)
    toolpath = interpret(program)
    expected: Counter[int] = Counter()
    for number, role in role_of.items():
        block = program.block(number)
        if role.kind == "hole":
            expected[number] = runs[number]
        elif role.kind == "bolt":
            assert isinstance(block, BoltCircle)
            expected[number] = block.holes * runs[number]
    dwell_expected = Counter(
        {n: count for n, count in expected.items() if role_of[n].op is not HoleOp.TAP}
    )
    dwells: Counter[int] = Counter(m.block for m in toolpath.moves if isinstance(m, Dwell))
    bottoms: Counter[int] = Counter(
        move.block
        for start, move in motions(toolpath)
        if isinstance(move, Feed)
        and role_of[move.block].kind in ("hole", "bolt")
        and move.z == role_of[move.block].z_dn
        and move.z < start[2]
    )
    assert dwells == dwell_expected
    assert bottoms == expected


# -- (h) LOOP/REP patterns ----------------------------------------------------------------------


@PROPERTY
@given(programs())
def test_loop_patterns(program: Program) -> None:
    """(h) A LOOP/REP repeats its body (NX+1)(NY+1) times, multiplied through nesting:

    - every hole-making block (standard hole, BOLT CIR, DRILL starting a mill sequence)
      begins a hole (feeds down from Z UP) P × (# HOLES for BOLT CIR, else 1) times, P the
      product of (NX+1)(NY+1) of the pairs around it;
    - and the holes begin in the order and at the XY of an independent model of the
      patterns (`expected_hole_starts`): row by row, each pattern offset by (i·ΔX, j·ΔY)
      from where the LOOP started, nested pairs inside each outer pattern.
    """
    toolpath = interpret(program)
    actual = hole_starts(program, toolpath)
    runs = patterns(program)
    expected_counts: Counter[int] = Counter()
    for number, role in roles(program).items():
        block = program.block(number)
        if role.kind in ("hole", "mill-drill"):
            expected_counts[number] = runs[number]
        elif role.kind == "bolt":
            assert isinstance(block, BoltCircle)
            expected_counts[number] = block.holes * runs[number]
    assert Counter(number for number, _ in actual) == expected_counts
    assert actual == expected_hole_starts(program)


# -- (i) STOP and the spindle ---------------------------------------------------------------


@PROPERTY
@given(programs())
def test_stop_and_spindle(program: Program) -> None:
    """(i) STOP and the spindle (seed 001 §3.4.4, §3.4.5.3):

    - a unit the control runs together (a block, centre + BOLT CIR, DRILL + mills) with a
      STOP on any of its blocks stops the program once per run (P times, as in (g)), after
      its last block, with the spindle already stopped;
    - the spindle turns whenever the tool feeds, at the |RPM| of the block's tool, clockwise
      for a positive RPM, except a TAP's feed out of the hole, which runs reversed and
      ends 0.3 in (7.62 mm) above Z UP.
    """
    role_of = roles(program)
    runs = patterns(program)
    toolpath = interpret(program)
    rpm_of = {t.number: t.rpm for t in program.block0.tools}
    stop_groups = {role_of[n].group for n, b in enumerate(program.blocks, 1) if b.stop}
    last_of_group = {role.group: number for number, role in role_of.items()}
    expected = Counter({last_of_group[g]: runs[g] for g in stop_groups})
    stops = Counter(
        m.block for m in toolpath.moves if isinstance(m, ProgramStop) and m.reason == "STOP"
    )
    assert stops == expected
    spindle: SpindleOn | None = None
    for here, move in walk(toolpath):
        if isinstance(move, SpindleOn):
            spindle = move
        elif isinstance(move, SpindleOff):
            spindle = None
        elif isinstance(move, ProgramStop) and move.reason == "STOP":
            assert spindle is None, f"STOP after block {move.block} with the spindle on"
        elif isinstance(move, Feed | ArcFeed):
            role = role_of[move.block]
            assert spindle is not None, f"block {move.block} feeds with the spindle stopped"
            assert role.tool is not None
            rpm = rpm_of[role.tool]
            assert rpm is not None
            clockwise = rpm > 0
            if role.op is HoleOp.TAP and goes_up(here, move):
                clockwise = not clockwise
                assert role.z_up is not None
                assert move.z == role.z_up + TAP_LIFT_NM, f"TAP feed out of block {move.block}"
            assert (spindle.rpm, spindle.clockwise) == (abs(rpm), clockwise), move


@given(hst.lists(hst.integers(-(2**63), 2**63 - 1), max_size=200))
def test_distinct_is_numpys_unique(values: list[int]) -> None:
    """path.distinct stands in for np.unique on the export path (np.unique imports
    numpy.ma, issue 31.3): for any int64 column the same values, order and type."""
    column = np.array(values, dtype=np.int64)
    ours, numpys = distinct(column), np.unique(column)
    assert ours.dtype == numpys.dtype
    assert ours.tolist() == numpys.tolist()
