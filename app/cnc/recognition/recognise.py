"""Recognition: the operations found in imported motion, as the data blocks that make them.

Nothing here guesses geometry. Each recognition proposes blocks and keeps them only when
the blocks make the same motion as the file, within the file's own rounding (half a step of
its finest numbers, `Parsed.tolerance`); otherwise the operations stay explicit blocks.

- **Pecks in a mill sequence**: the same cuts at levels that are MillBlocks' even peck
  levels from Z UP, each re-entered at the level just cut → one DRILL with # PECK.
- **A 2P routine in pecks**: its roughing pass at each such level, the finishing pass after
  the last → one DRILL with # PECK and the 2P routine, where the routine cuts them exactly.
- **CIRCLE / FRAME**: for a mill sequence cut with a tool whose diameter the file gives,
  routine blocks are proposed from its arcs and extent (every placement, 2P or not, the
  direction from the cut) and planned by `app.cnc.sequences` — the same code the interpreter
  cuts with; one whose passes are the file's cuts is kept. Data Block 0's climb or
  conventional is set by the first routine; a later one that needs the other is kept as
  explicit cuts, and reported.
- **BOLT CIR**: three or more holes with the same parameters, equally spaced over the whole
  circle (N holes 360°/N apart), taken clockwise (MillBlocks' order) — or counter-clockwise
  (the ProtoTRAK Plus's order), which becomes the same holes drilled clockwise from the same
  first hole, reported. Centre, radius and angle are rounded to the program resolution and
  0.01°, and the holes MillBlocks makes from them must be the file's.
- **LOOP / REP**: a run of operations repeated, each time shifted by the same step along X
  or along Y (REP steps one axis per count), with one tool; rows of such runs stacked along
  Y become one grid (NX, NY); other repetitions of repetitions nest (up to four deep).
"""

from __future__ import annotations

import math
from collections.abc import Hashable
from dataclasses import dataclass, replace
from decimal import ROUND_HALF_EVEN, Decimal
from typing import Final

from app.cnc import limits
from app.cnc.blocks import (
    Block,
    Circle,
    Comp,
    DataBlock0,
    Frame,
    Hole,
    HoleOp,
    MillingMode,
    Placement,
    Tool,
)
from app.cnc.geometry import bolt_circle_points
from app.cnc.plane import Path
from app.cnc.recognition.common import (
    XY,
    Notes,
    decimal_of,
    feed_decimal,
    quantize_nm,
    resolution_nm,
    show,
)
from app.cnc.recognition.ops import (
    BoltOp,
    Element,
    HoleOpR,
    LoopOp,
    MillOp,
    Op,
    RoutineOp,
    anchor,
    close_numbers,
    signature,
    tools_of,
    units_of,
)
from app.cnc.routines import INSIDE_PLACEMENTS, peck_levels, rough_depth, rough_wall
from app.cnc.sequences import plan_sequence
from app.cnc.units import Units

Pt = tuple[float, float]
Seg = tuple[bool, Pt, Pt | None, bool]  # (is arc, end, centre, clockwise)

MAX_LOOP_BODY = 32  # operations in one repeated pattern
MAX_FRAME_CUTS = 400  # a frame routine's passes are fewer cuts than this
MIN_BOLT_HOLES = 3
HUNDREDTH: Final = Decimal("0.01")  # a BOLT CIR's angle is in hundredths of a degree
_BOLT_NOTE: Final = "holes on a circle read as BOLT CIR"  # what every BOLT CIR's note shares


# -- pecks through a mill sequence ----------------------------------------------------------


def merge_pecks(ops: list[Op], tolerance: int) -> list[Op]:
    """Consecutive mill sequences that are one DRILL with pecks (seed 001 PECK)."""
    out: list[Op] = []
    i = 0
    while i < len(ops):
        first = ops[i]
        if not isinstance(first, MillOp) or not first.spec.has_depth or first.stop:
            out.append(first)
            i += 1
            continue
        chain = [first]
        while i + len(chain) < len(ops):
            nxt = ops[i + len(chain)]
            if not (isinstance(nxt, MillOp) and _next_level(chain[-1], nxt, tolerance)):
                break
            chain.append(nxt)
            if nxt.stop:
                break
        if len(chain) > 1 and len(chain) <= limits.MAX_PECKS:
            z_up = first.spec.z_up
            bottom = chain[-1].spec.z_dn
            assert z_up is not None and bottom is not None
            levels = [op.spec.z_dn for op in chain]
            even = peck_levels(z_up, bottom, len(chain))
            if all(
                lv is not None and abs(lv - ev) <= tolerance
                for lv, ev in zip(levels, even, strict=True)
            ):
                merged = MillOp(
                    sorted({line for op in chain for line in op.lines}),
                    first.at,
                    replace(first.spec, z_dn=bottom, pecks=len(chain)),
                    first.comp,
                    chain[-1].elements,
                    stop=chain[-1].stop,
                    message=first.message,
                )
                out.append(merged)
                i += len(chain)
                continue
        out.append(first)
        i += 1
    return out


def _next_level(a: MillOp, b: MillOp, tol: int, finish: bool = False) -> bool:
    """Whether `b` cuts `a`'s cuts again at the next peck level down, re-entered at the
    level `a` cut to; `finish`: and goes on cutting after them (a 2P routine's finishing
    pass after its last roughing level)."""
    cuts = a.elements
    if finish and len(b.elements) > len(cuts):
        b = replace(b, elements=b.elements[: len(cuts)])
    elif finish:
        return False
    if not (
        b.spec.has_depth
        and not b.message
        and _close(a.at, b.at, tol)
        and a.comp is b.comp
        and a.spec.tool == b.spec.tool
        and a.spec.units is b.spec.units
        and a.spec.feed_z == b.spec.feed_z
        and a.spec.z_dn is not None
        and b.spec.z_up is not None
        and b.spec.z_dn is not None
        and abs(b.spec.z_up - a.spec.z_dn) <= tol
        and b.spec.z_dn < a.spec.z_dn
        and len(a.elements) == len(b.elements)
    ):
        return False
    for p, q in zip(a.elements, b.elements, strict=True):
        if p.z_dn is not None or q.z_dn is not None or p.feed != q.feed:
            return False
        if (p.centre is None) != (q.centre is None) or p.clockwise != q.clockwise:
            return False
        if not _close(p.end, q.end, tol):
            return False
        if p.centre is not None and q.centre is not None and not _close(p.centre, q.centre, tol):
            return False
    return True


def _close(a: XY | Pt, b: XY | Pt, tol: float) -> bool:
    return abs(a[0] - b[0]) <= tol and abs(a[1] - b[1]) <= tol


def _two_pass_levels(ops: list[Op], i: int, tol: int) -> MillOp | None:
    """The mill sequences from `ops[i]` on that are one 2P routine cut in pecks, as one
    mill sequence with # PECK (its depth the roughing depth, its cuts the last level's:
    the roughing pass, then the finishing pass); None where they are not."""
    first = ops[i]
    if not isinstance(first, MillOp) or not first.spec.has_depth or first.stop:
        return None
    chain = [first]
    for k in range(i + 1, min(len(ops), i + limits.MAX_PECKS)):
        nxt = ops[k]
        if not isinstance(nxt, MillOp):
            return None
        if _next_level(chain[-1], nxt, tol, finish=True):
            chain.append(nxt)
            break
        if nxt.stop or not _next_level(chain[-1], nxt, tol):
            return None
        chain.append(nxt)
    else:
        return None
    z_up, bottom = first.spec.z_up, chain[-1].spec.z_dn
    assert z_up is not None and bottom is not None
    even = peck_levels(z_up, bottom, len(chain))
    levels = [op.spec.z_dn for op in chain]
    if any(lv is None or abs(lv - ev) > tol for lv, ev in zip(levels, even, strict=True)):
        return None
    return MillOp(
        sorted({line for op in chain for line in op.lines}),
        first.at,
        replace(first.spec, z_dn=bottom, pecks=len(chain)),
        first.comp,
        chain[-1].elements,
        stop=chain[-1].stop,
        message=first.message,
    )


# -- CIRCLE and FRAME routines --------------------------------------------------------------


class RoutineFinder:
    """Proposes CIRCLE/FRAME blocks for mill sequences and keeps those that cut the same."""

    def __init__(
        self,
        diameters: dict[int, int],
        rpms: dict[int, int | None],
        tolerance: int,
        notes: Notes,
    ) -> None:
        self.diameters = diameters
        self.rpms = rpms
        self.tol = tolerance + 2
        self.notes = notes
        self.milling: MillingMode | None = None
        self.milling_line: int | None = None
        self.cache: dict[tuple[object, ...], list[tuple[Circle | Frame, XY, MillingMode]]] = {}
        # Each tool's diameter and speed as first asked: a file that streams (its tools'
        # data still being read) checks at the end that they were the file's.
        self.asked: dict[int, tuple[int | None, int | None]] = {}

    def run(self, ops: list[Op]) -> list[Op]:
        return [self.routine(op) if isinstance(op, MillOp) else op for op in ops]

    def two_pass_with_pecks(self, ops: list[Op]) -> list[Op]:
        """2P routines cut with pecks (seed 001 PECK): mill sequences at MillBlocks' even
        peck levels from Z UP down to the roughing depth, each re-entered at the level
        just cut, each the roughing pass, the last followed by the finishing pass. One
        DRILL with # PECK and the 2P routine where the routine cuts them exactly; otherwise
        the sequences stay as they are (each recognised on its own later)."""
        out: list[Op] = []
        i = 0
        while i < len(ops):
            # (Most operations of a file are not mill sequences: no call for those.)
            chain = _two_pass_levels(ops, i, self.tol) if isinstance(ops[i], MillOp) else None
            if chain is not None:
                found = self.routine(chain, two_pass_only=True)
                if isinstance(found, RoutineOp):
                    out.append(found)
                    i += chain.spec.pecks
                    continue
            out.append(ops[i])
            i += 1
        return out

    def routine(self, op: MillOp, two_pass_only: bool = False) -> Op:
        tool = op.spec.tool
        diameter = self.diameters.get(tool)
        if tool not in self.asked:
            self.asked[tool] = (diameter, self.rpms.get(tool))
        if diameter is None or op.comp is not Comp.NONE or not op.elements:
            return op
        # The same cuts elsewhere (a pattern of pockets) are the same routine: planned once.
        # The key holds all the cuts are made of, seen from the plunge point, so the cuts
        # too are the same there (`normalise` compares differences of points alone).
        key = self.key(op, diameter)
        found = self.cache.get(key)
        if found is None:
            cuts = normalise(_f(op.at), _segments(op.elements), self.tol)
            wanted_feed = op.elements[0].feed
            if not cuts or any(e.feed != wanted_feed for e in op.elements):
                found = []  # no cuts, or more than one feed: no routine
            else:
                found = self.search(op, cuts, diameter)
            self.cache[key] = found
        conflict: tuple[Circle | Frame, MillingMode] | None = None
        for block, offset, milling in found:
            if two_pass_only and not block.two_pass:
                continue
            centre = (op.at[0] + offset[0], op.at[1] + offset[1])
            if self.milling is not None and milling is not self.milling:
                conflict = (block, milling)
                continue
            if self.milling is None:
                self.milling, self.milling_line = milling, op.lines[0]
            self.notes.became(
                op.lines[0],
                f"{self.notes.span(op.lines)}: the cuts are a {block.type_name} routine exactly "
                f"(planned as MillBlocks plans it, {milling.value} milling)",
            )
            spec = op.spec
            if block.two_pass and spec.z_dn is not None:
                spec = replace(spec, z_dn=spec.z_dn - rough_depth(spec.units))
            return RoutineOp(op.lines, centre, spec, block, op.stop, op.message)
        if conflict is not None and not two_pass_only:
            block, milling = conflict
            chosen = self.milling.value if self.milling else "-"
            self.notes.ignored(
                op.lines[0],
                f"{self.notes.span(op.lines)} would be a {block.type_name} with "
                f"{milling.value} milling, but Data Block 0 has {chosen} for the routine at "
                f"{self.notes.span([self.milling_line or 0])}: kept as explicit cuts",
            )
        return op

    def key(self, op: MillOp, diameter: int) -> tuple[object, ...]:
        """What decides the routine of a mill sequence, seen from its plunge point."""
        ax, ay = op.at
        step = resolution_nm(op.spec.units)
        shape = tuple(
            (
                e.end[0] - ax,
                e.end[1] - ay,
                None if e.centre is None else (e.centre[0] - ax, e.centre[1] - ay),
                e.clockwise,
                e.z_dn,
                e.feed,
            )
            for e in op.elements
        )
        rpm = self.rpms.get(op.spec.tool)
        return (op.spec, diameter, rpm, ax % step, ay % step, shape)

    def search(
        self, op: MillOp, cuts: list[Seg], diameter: int
    ) -> list[tuple[Circle | Frame, XY, MillingMode]]:
        """The routines (block, centre from the plunge point, milling) that cut `cuts`:
        the first found for each milling mode."""
        found: list[tuple[Circle | Frame, XY, MillingMode]] = []
        modes: set[MillingMode] = set()
        for block, centre in self.candidates(op, cuts, diameter):
            for milling in MillingMode:
                if milling in modes:
                    continue
                if self.matches(op, block, centre, milling, cuts, diameter):
                    found.append((block, (centre[0] - op.at[0], centre[1] - op.at[1]), milling))
                    modes.add(milling)
            if len(modes) == len(MillingMode):
                break
        return found

    def candidates(
        self, op: MillOp, cuts: list[Seg], diameter: int
    ) -> list[tuple[Circle | Frame, XY]]:
        units = op.spec.units
        r = diameter // 2
        allowance = rough_wall(units)
        feed = feed_decimal(op.elements[0].feed, units)
        found: list[tuple[Circle | Frame, XY]] = []
        block: Circle | Frame
        seen: set[tuple[object, ...]] = set()

        def add(block: Circle | Frame, centre: XY) -> None:
            key = (block, centre)
            if key not in seen:
                seen.add(key)
                found.append((block, centre))

        common = {"feed_xy": feed, "tool": op.spec.tool, "units": units}
        # Circles: every full circle of the cuts is a pass of the routine (the first few:
        # a routine has at most a roughing and a finishing wall pass before its inner ones).
        start: Pt = _f(op.at)
        circles = 0
        for is_arc, end, centre, _ in cuts:
            if is_arc and centre is not None and _close(end, start, self.tol) and circles < 4:
                circles += 1
                radius = math.dist(end, centre)
                middle = (
                    quantize_nm(round(centre[0]), units),
                    quantize_nm(round(centre[1]), units),
                )
                for placement in Placement:
                    sign = 1 if placement in INSIDE_PLACEMENTS else -1
                    for two_pass in (False, True):
                        for extra in (0, allowance):
                            size = quantize_nm(round(radius + sign * (r + extra)), units)
                            if size <= 0:
                                continue
                            block = Circle(
                                placement=placement,
                                two_pass=two_pass,
                                radius=decimal_of(size, units),
                                **common,  # type: ignore[arg-type]
                            )
                            add(block, middle)
            start = end
        # Frames: the extent of the cuts is one pass, its corners arcs about the frame's.
        points = [_f(op.at), *[seg[1] for seg in cuts]]
        lines = [seg for seg in cuts if not seg[0]]
        if len(lines) < 4 or len(cuts) > MAX_FRAME_CUTS:
            return found
        x0, x1 = min(p[0] for p in points), max(p[0] for p in points)
        y1 = max(p[1] for p in points)
        bottoms = sorted({round(p[1]) for p in points})[:3]
        radii = {round(math.dist(seg[1], seg[2])) for seg in cuts if seg[0] and seg[2]}
        for placement in Placement:
            inside = placement in INSIDE_PLACEMENTS
            for two_pass in (False, True):
                offsets = [-r] if inside else ([r + allowance, r] if two_pass else [r])
                for edge in offsets:
                    corners = {0}
                    for rad in radii:
                        for off in (r, -r, r + allowance, -(r + allowance)):
                            if rad - off >= 0:
                                corners.add(quantize_nm(rad - off, units))
                    for y0 in bottoms:
                        fx = quantize_nm(round(x0 + edge), units)
                        fy = quantize_nm(round(y0 + edge), units)
                        xl = quantize_nm(round(x1 - x0 - 2 * edge), units)
                        yw = quantize_nm(round(y1 - y0 - 2 * edge), units)
                        if xl <= 0 or yw <= 0:
                            continue
                        for corner in sorted(corners):
                            block = Frame(
                                placement=placement,
                                two_pass=two_pass,
                                xl=decimal_of(xl, units),
                                yw=decimal_of(yw, units),
                                corner_radius=decimal_of(corner, units),
                                **common,  # type: ignore[arg-type]
                            )
                            add(block, (fx, fy))
        return found

    def matches(
        self,
        op: MillOp,
        block: Circle | Frame,
        centre: XY,
        milling: MillingMode,
        cuts: list[Seg],
        diameter: int,
    ) -> bool:
        units = op.spec.units
        rpm = self.rpms.get(op.spec.tool)
        tool = Tool(number=op.spec.tool, diameter=decimal_of(diameter, units), rpm=rpm or 1000)
        block0 = DataBlock0(milling=milling, tools=(tool,))
        drill = Hole(
            op=HoleOp.DRILL,
            x=decimal_of(centre[0], units),
            y=decimal_of(centre[1], units),
            tool=op.spec.tool,
            units=units,
        )
        blocks: tuple[Block, ...] = (drill, block)
        try:
            plan = plan_sequence(blocks, block0, units, 0, (1,), centre)
        except (ValueError, ZeroDivisionError):
            return False
        if not plan.passes or any(f.severity.value == "error" for f in plan.findings):
            return False
        planned = normalise(plan.passes[0].start, _planned(plan.passes), self.tol)
        if not _close(plan.passes[0].start, _f(op.at), self.tol):
            return False
        if len(planned) != len(cuts):
            return False
        for a, b in zip(planned, cuts, strict=True):
            if a[0] != b[0] or not _close(a[1], b[1], self.tol):
                return False
            if a[0] and (a[3] != b[3] or a[2] is None or b[2] is None):
                return False
            if a[2] is not None and b[2] is not None and not _close(a[2], b[2], self.tol):
                return False
        return self.depths_match(op, block)

    def depths_match(self, op: MillOp, block: Circle | Frame) -> bool:
        """The Z of the cuts: one depth, or a 2P roughing depth then Z DN for the finish."""
        changes = [e.z_dn for e in op.elements if e.z_dn is not None]
        if not op.spec.has_depth:
            return not changes
        assert op.spec.z_dn is not None
        if not block.two_pass:
            return not changes
        if len(changes) != 1:
            return False
        return abs(op.spec.z_dn - changes[0] - rough_depth(op.spec.units)) <= self.tol


def _f(p: XY) -> Pt:
    return (float(p[0]), float(p[1]))


def _segments(elements: list[Element]) -> list[Seg]:
    return [
        (e.centre is not None, _f(e.end), None if e.centre is None else _f(e.centre), e.clockwise)
        for e in elements
    ]


def _planned(passes: list[Path]) -> list[Seg]:
    segs: list[Seg] = []
    for k, path in enumerate(passes):
        if k:
            segs.append((False, path.start, None, False))
        segs += [(e.centre is not None, e.end, e.centre, e.clockwise) for e in path.elements]
    return segs


def normalise(start: Pt, segs: list[Seg], tol: float) -> list[Seg]:
    """A path as cuts: lines that go nowhere dropped, arcs about one centre in one direction
    joined (a tape splits arcs at the quadrants), straight lines in one direction joined."""
    out: list[Seg] = []
    starts: list[Pt] = []
    here = start
    for seg in segs:
        is_arc, end, centre, cw = seg
        if not is_arc and _close(end, here, tol):
            continue
        if out:
            p_arc, _, p_centre, p_cw = out[-1]
            if (
                is_arc
                and p_arc
                and p_cw == cw
                and centre is not None
                and p_centre is not None
                and _close(centre, p_centre, tol)
                and abs(math.dist(here, centre) - math.dist(end, centre)) <= 2 * tol
            ):
                out[-1] = (True, end, p_centre, cw)
                here = end
                continue
            if not is_arc and not p_arc and _collinear(starts[-1], here, end, tol):
                out[-1] = (False, end, None, False)
                here = end
                continue
        out.append(seg)
        starts.append(here)
        here = end
    return out


def _collinear(a: Pt, b: Pt, c: Pt, tol: float) -> bool:
    """True when a→b→c goes on in the same direction along one straight line."""
    ab = (b[0] - a[0], b[1] - a[1])
    bc = (c[0] - b[0], c[1] - b[1])
    length = math.hypot(*ab)
    if length == 0 or ab[0] * bc[0] + ab[1] * bc[1] <= 0:
        return False
    return abs(ab[0] * bc[1] - ab[1] * bc[0]) / length <= tol


# -- bolt circles ---------------------------------------------------------------------------


def find_bolt_circles(ops: list[Op], tolerance: int, notes: Notes) -> list[Op]:
    out: list[Op] = []
    i = 0
    # Every BOLT CIR is one note, the first one's words and the others' lines (`same`):
    # once it is made, a circle's own words would be dropped, and are not written.
    noted = False
    while i < len(ops):
        bolt = _bolt_at(ops, i, tolerance + 2)
        if bolt is None:
            out.append(ops[i])
            i += 1
            continue
        op, count, reordered = bolt
        out.append(op)
        u = op.spec.units
        notes.became(
            op.lines[0],
            ""
            if noted
            else f"{notes.span(op.lines)}: {count} holes equally spaced on a circle: BOLT CIR "
            f"about X{show(op.centre[0], u)} Y{show(op.centre[1], u)}, radius "
            f"{show(op.radius, u)}, first hole at {op.angle}° (clockwise from below)",
            same=_BOLT_NOTE,
        )
        noted = True
        if reordered:
            notes.assumed(
                op.lines[0],
                f"{notes.span(op.lines)} drills the holes counter-clockwise (the ProtoTRAK Plus's "
                "order); a MillBlocks BOLT CIR drills the same holes clockwise from the same "
                "first hole",
            )
        i += count
    return out


def _bolt_at(ops: list[Op], i: int, tol: int) -> tuple[BoltOp, int, bool] | None:
    first = ops[i]
    if not isinstance(first, HoleOpR) or i + MIN_BOLT_HOLES > len(ops):
        return None
    run: list[HoleOpR] = []
    spec = first.spec
    # Indexing, not a slice: a slice would copy up to MAX_BOLT_HOLES ops at every i.
    for k in range(i, min(len(ops), i + limits.MAX_BOLT_HOLES)):
        op = ops[k]
        # (`is` first: the segmenter shares one HoleSpec between holes alike.)
        if not isinstance(op, HoleOpR) or (op.spec is not spec and op.spec != spec):
            break
        if op.message and run:
            break
        run.append(op)
        if op.stop:
            break
    if len(run) < MIN_BOLT_HOLES:
        return None
    # The holes' X and Y as floats, in two lists: a centroid is then one `sum` of a slice.
    xs = [float(h.at[0]) for h in run]
    ys = [float(h.at[1]) for h in run]
    x0, y0, x1, y1 = xs[0], ys[0], xs[1], ys[1]
    rough = _circumcentre((x0, y0), (x1, y1), (xs[2], ys[2]))
    if rough is None:
        return None
    a0 = math.atan2(y0 - rough[1], x0 - rough[0])
    a1 = math.atan2(y1 - rough[1], x1 - rough[0])
    delta = math.remainder(a1 - a0, 2 * math.pi)
    if abs(delta) < 1e-9:
        return None
    guess = round(2 * math.pi / abs(delta))
    # Three neighbouring holes of many fix the centre badly: the holes of a whole circle
    # have it as their centroid, which gives a better count, and so on.
    for _ in range(3):
        guess = min(guess, len(run))
        if guess < MIN_BOLT_HOLES:
            break
        cx, cy = sum(xs[:guess]) / guess, sum(ys[:guess]) / guess
        b0 = math.atan2(y0 - cy, x0 - cx)
        b1 = math.atan2(y1 - cy, x1 - cx)
        step = abs(math.remainder(b1 - b0, 2 * math.pi))
        if step < 1e-9:
            return None
        better = round(2 * math.pi / step)
        if better == guess:
            break
        guess = better
    # Where the run's stop is (it ends the run): a circle cannot go on past it.
    stopped = len(run) - 1 if run[-1].stop else len(run)
    tried: set[int] = set()
    for count in (guess, guess - 1, guess + 1, guess - 2, guess + 2, len(run)):
        if count in tried:
            continue
        tried.add(count)
        if not MIN_BOLT_HOLES <= count <= len(run) or stopped < count - 1:
            continue
        found = _bolt_of(run, xs, ys, count, tol)
        if found is not None:
            return found
    return None


def _bolt_of(
    run: list[HoleOpR], xs: list[float], ys: list[float], count: int, tol: int
) -> tuple[BoltOp, int, bool] | None:
    """The first `count` holes of `run` (X and Y in `xs`, `ys`) as one BOLT CIR, if
    MillBlocks' holes of it are the file's within `tol` (nm)."""
    first = run[0]
    x0, y0 = xs[0], ys[0]
    centre = (sum(xs[:count]) / count, sum(ys[:count]) / count)
    radius = math.dist((x0, y0), centre)
    a0 = math.atan2(y0 - centre[1], x0 - centre[0])
    a1 = math.atan2(ys[1] - centre[1], xs[1] - centre[0])
    delta = math.remainder(a1 - a0, 2 * math.pi)
    if abs(abs(delta) * count - 2 * math.pi) > 0.01:
        return None
    units = first.spec.units
    cq = (quantize_nm(round(centre[0]), units), quantize_nm(round(centre[1]), units))
    rq = quantize_nm(round(radius), units)
    if rq <= 0:
        return None
    dx, dy = x0 - centre[0], y0 - centre[1]
    theta = math.degrees(math.atan2(-dx, -dy)) % 360
    angle = Decimal(repr(theta)).quantize(HUNDREDTH, rounding=ROUND_HALF_EVEN)
    if angle >= 360:
        angle -= 360
    made = bolt_circle_points(cq, rq, count, angle)
    clockwise = delta < 0
    order = made if clockwise else [made[0], *reversed(made[1:])]
    holes = run[:count]
    for h, q in zip(holes, order, strict=True):
        at = h.at
        if abs(at[0] - q[0]) > tol or abs(at[1] - q[1]) > tol:
            return None
    lines = sorted({line for h in holes for line in h.lines})
    bolt = BoltOp(lines, cq, first.spec, count, angle, rq, holes[-1].stop, first.message)
    return bolt, count, not clockwise


def _circumcentre(a: Pt, b: Pt, c: Pt) -> Pt | None:
    d = 2 * (a[0] * (b[1] - c[1]) + b[0] * (c[1] - a[1]) + c[0] * (a[1] - b[1]))
    if abs(d) < 1e-6:
        return None
    a2, b2, c2 = a[0] ** 2 + a[1] ** 2, b[0] ** 2 + b[1] ** 2, c[0] ** 2 + c[1] ** 2
    ux = (a2 * (b[1] - c[1]) + b2 * (c[1] - a[1]) + c2 * (a[1] - b[1])) / d
    uy = (a2 * (c[0] - b[0]) + b2 * (a[0] - c[0]) + c2 * (b[0] - a[0])) / d
    return (ux, uy)


# -- LOOP / REP -------------------------------------------------------------------------------


def find_loops(ops: list[Op], tolerance: int, notes: Notes) -> list[Op]:
    """Repeated runs of operations as LOOP/REP, passes repeated until nothing changes."""
    finder = _LoopFinder(tolerance, notes)
    while True:
        new = finder.one_pass(ops)
        if len(new) == len(ops):
            return new
        ops = new


def nesting(op: Op) -> int:
    """How many LOOPs deep an operation is (0 for one that is not a LOOP)."""
    if not isinstance(op, LoopOp):
        return 0
    return 1 + max(nesting(body) for body in op.body)


class _LoopFinder:
    def __init__(self, tolerance: int, notes: Notes) -> None:
        self.tol = tolerance + 2
        self.notes = notes

    def one_pass(self, ops: list[Op]) -> list[Op]:
        sigs = [signature(op) for op in ops]
        seen = _Kinds()
        kinds = [seen.of(sig.labels) for sig in sigs]
        anchors = [anchor(op) for op in ops]
        seen_ops = _Seen(
            kinds,
            [a[0] for a in anchors],
            [a[1] for a in anchors],
            [sig.numbers for sig in sigs],
        )
        out: list[Op] = []
        i = 0
        while i < len(ops):
            found = self.best_run(ops, seen_ops, i)
            if found is None:
                out.append(ops[i])
                i += 1
                continue
            length, count, step = found
            body = find_loops(ops[i : i + length], self.tol - 2, self.notes)
            loop = self.make_loop(body, step, count)
            if loop is None:
                out.append(ops[i])
                i += 1
                continue
            out.append(loop)
            i += length * count
        return out

    def best_run(self, ops: list[Op], seen: _Seen, i: int) -> tuple[int, int, XY] | None:
        best: tuple[int, int, XY] | None = None
        n = len(ops)
        tol = self.tol
        kinds, xs, ys, numbers = seen.kinds, seen.xs, seen.ys, seen.numbers
        kind0 = kinds[i]
        x0, y0 = xs[i], ys[i]
        units: Units | None = None
        # Lengths whose every comparison held exactly (no tolerance used), with their count.
        # A multiple m·L of such a length L, m < count, compares the same operations with
        # the same differences up to the one where L stopped, so it repeats count // m
        # times (m·L · count // m <= L · count): it cannot do better, and is not tried.
        exact: list[tuple[int, int]] = []
        for length in range(1, min(MAX_LOOP_BODY, (n - i) // 2) + 1):
            # A body whose first operation does not come again right after it repeats
            # nowhere (an int compare, before any arithmetic).
            if kinds[i + length] != kind0:
                continue
            if any(length % base == 0 and length // base < times for base, times in exact):
                continue
            raw = (xs[i + length] - x0, ys[i + length] - y0)
            along_x = abs(raw[1]) <= tol and abs(raw[0]) > tol
            along_y = abs(raw[0]) <= tol and abs(raw[1]) > tol
            if not (along_x or along_y):
                continue
            if units is None:
                units = _units(ops[i])
            step = (quantize_nm(raw[0], units), 0) if along_x else (0, quantize_nm(raw[1], units))
            if step == (0, 0):
                continue
            sx, sy = step
            count = 1
            held = True  # every comparison so far exact
            while i + (count + 1) * length <= n and count <= limits.MAX_REPEAT:
                base = i + count * length
                dx, dy = count * sx, count * sy
                for t in range(length):
                    here, there = base + t, i + t
                    # Same kind first (an int compare): most candidates fail there.
                    if kinds[here] != kinds[there]:
                        break
                    off_x, off_y = xs[here] - xs[there] - dx, ys[here] - ys[there] - dy
                    if abs(off_x) > tol or abs(off_y) > tol:
                        break
                    # (Equal numbers, the usual repetition, without a call.)
                    shape, first = numbers[here], numbers[there]
                    if shape != first:
                        if not close_numbers(shape, first, tol):
                            break
                        held = False
                    if off_x or off_y:
                        held = False
                else:
                    count += 1
                    continue
                break
            if held:
                exact.append((length, count))
            if count < 2 or count * length < 3:
                continue
            if best is None or count * length > best[0] * best[1]:
                best = (length, count, step)
        return best

    def make_loop(self, body: list[Op], step: XY, count: int) -> LoopOp | None:
        tools = {t for op in body for t in tools_of(op)}
        if len(tools) != 1:
            return None
        depth = max(nesting(op) for op in body) + 1
        inner = body[0] if len(body) == 1 else None
        # A row of rows: one grid, NX along X inside, NY along Y outside (seed 001 REP).
        if (
            isinstance(inner, LoopOp)
            and step[0] == 0
            and inner.step[1] == 0
            and inner.ny == 0
            and not inner.head_added
        ):
            return LoopOp([], inner.body, (inner.step[0], step[1]), inner.nx, count - 1)
        head = isinstance(body[0], LoopOp)
        if depth > limits.MAX_LOOP_DEPTH:
            return None
        nx, ny = (count - 1, 0) if step[1] == 0 else (0, count - 1)
        return LoopOp([], body, step, nx, ny, head_added=head)


@dataclass(frozen=True)
class _Seen:
    """One pass's view of its operations, each a list in their order: their kinds (equal
    labels, equal kind), their anchors' X and Y (nm), their signatures' numbers."""

    kinds: list[int]
    xs: list[int]
    ys: list[int]
    numbers: list[list[int]]


class _Kinds:
    """Numbers for signatures' labels: equal labels, equal number (hashed when they can
    be, else compared with the kinds met so far)."""

    def __init__(self) -> None:
        self.hashed: dict[tuple[Hashable, ...], int] = {}
        self.unhashable: list[list[Hashable]] = []

    def of(self, labels: list[Hashable]) -> int:
        key = tuple(labels)
        try:
            return self.hashed.setdefault(key, len(self.hashed))
        except TypeError:
            for k, other in enumerate(self.unhashable):
                if other == labels:
                    return -1 - k
            self.unhashable.append(labels)
            return -len(self.unhashable)


def _units(op: Op) -> Units:
    return units_of(op)
