"""Plan an irregular pocket: offset passes from the middle out, a finishing pass at the wall
and round each island, the links between passes, and what the planner found.

The readings we chose (docs/pocketing.md):

- Passes are the boundaries of the pocket region (boundary minus islands) shrunk by
  d = tool radius (the finishing level: the finished surface), then tool radius + finish
  allowance, and on by the step-over, until nothing is left (Clipper computes the regions;
  `exact.py` turns each ring back into exact lines and arcs).
- Cutting order is from the middle out: the deepest rings of a piece first, each ring then
  the one around it, so every ring has uncut material on the same side and climb or
  conventional milling holds for every pass: with a clockwise spindle, climb milling goes
  round the wall-like rings counter-clockwise and round the island-like rings clockwise
  (`app.cnc.routines.routine_clockwise`, DESIGN.md §3), conventional the reverse, a negative RPM
  flips both. The finishing rings come last in their piece.
- The tool goes down (plunge) at a deep point of the first innermost piece: a point where the
  whole tool fits, as far from the walls as the region allows. Where the region had split
  into pieces, each further innermost piece is entered the same way after a retract.
- A ring starts at its point nearest to where the tool is. The move there is a feed when
  the tool stays clear of walls and islands and either moves through cut material or steps
  no farther than its diameter; otherwise the tool retracts and plunges at the ring.
- Material the rings leave (cusps at sharp corners, a middle wider than a step) is found by
  area (Clipper): the pocket a round tool can reach, minus the area swept by the tool. Each
  piece wider than `RESIDUE_NM` gets an out-and-back cleanup move from the nearest ring.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt

from app.cnc import sizes
from app.cnc.blocks import MillingMode, Placement
from app.cnc.plane import (
    Element,
    Path,
    Pt,
    distance_to_element,
    length,
    reverse,
    signed_area,
    sub,
)
from app.cnc.pocketing import nearest, regions
from app.cnc.pocketing.checks import contour_problems, island_problems, show, starts_of
from app.cnc.pocketing.exact import (
    Carrier,
    LevelTable,
    carriers,
    exact_ring,
    level_table,
    matched_sources,
)
from app.cnc.pocketing.model import (
    Link,
    LinkKind,
    Pass,
    PassKind,
    PassLevel,
    PocketFinding,
    PocketIssue,
    PocketPlan,
)
from app.cnc.problems import Severity
from app.cnc.routines import peck_levels, routine_clockwise
from app.cnc.units import Units

DEFAULT_CHORDAL_TOLERANCE = 500  # nm: arcs become chords no farther than this from the arc
RESIDUE_NM = 5_000  # nm: uncut material narrower than this (0.0002 in) is not chased
MAX_LEVELS = 150  # more offset levels than this: the step-over is too small for the pocket
# (each level is a ring per piece, planned in Python: hundreds take tens of seconds)
MAX_CLEANUPS = 400  # cleanup moves per pocket before the planner reports what is left


def plan_pocket(
    boundary: Path,
    islands: Sequence[Path] = (),
    *,
    tool_radius: int,
    step_over: int,
    finish_allowance: int = 0,
    milling: MillingMode = MillingMode.CLIMB,
    rpm: int | None = None,
    block: int = 0,
    units: Units = Units.INCH,
    chordal_tolerance: int = DEFAULT_CHORDAL_TOLERANCE,
) -> PocketPlan:
    """The passes that clear the pocket inside `boundary` around `islands`.

    Contours are closed `mill.Path`s of lines and arcs in nm (either direction); an
    element's `block` names it in findings. `tool_radius`, `step_over` (distance between
    neighbouring rings, 0 < step-over < tool diameter) and `finish_allowance` (stock the
    roughing rings leave on walls and islands, ≥ 0) are nm. `milling` and `rpm` (its sign
    is the spindle direction; None is clockwise) choose each ring's direction; `block` is
    written on every element made; `units` is for messages.

    Raises nothing for bad geometry: errors come back as findings (and no passes); raises
    app.cnc.sizes.OverBudget when a time budget is in force and runs out.

    Python's cyclic garbage collector is paused meanwhile (`sizes.collector_paused`: a
    plan's many small objects live until it is made, and full collections walking them
    again were a quarter of a large pocket's planning).
    """
    with sizes.collector_paused():
        return _plan(
            boundary,
            islands,
            tool_radius=tool_radius,
            step_over=step_over,
            finish_allowance=finish_allowance,
            milling=milling,
            rpm=rpm,
            block=block,
            units=units,
            chordal_tolerance=chordal_tolerance,
        )


def _plan(
    boundary: Path,
    islands: Sequence[Path],
    *,
    tool_radius: int,
    step_over: int,
    finish_allowance: int,
    milling: MillingMode,
    rpm: int | None,
    block: int,
    units: Units,
    chordal_tolerance: int,
) -> PocketPlan:
    """`plan_pocket`'s work, the collector paused."""
    r = float(tool_radius)
    t = float(chordal_tolerance)
    match = 2 * t + 2  # Clipper's points lie this close to the true offsets
    findings = _parameter_problems(tool_radius, step_over, finish_allowance, units)
    names = ["boundary"] + [f"island {k}" for k in range(1, len(islands) + 1)]
    for name, contour in zip(names, [boundary, *islands], strict=True):
        findings += contour_problems(name, contour, units)
    if _errors(findings):
        return PocketPlan((), tuple(findings), t)
    # Region on the left of every element: the boundary counter-clockwise, islands clockwise.
    contours = [_oriented(boundary, ccw=True)] + [_oriented(i, ccw=False) for i in islands]
    rings = [regions.polygon(c, t) for c in contours]
    findings += island_problems(rings[0], rings[1:], t)
    if _errors(findings):
        return PocketPlan((), tuple(findings), t)
    region = regions.difference([rings[0]], rings[1:])
    levels = _levels(contours, r, float(step_over), float(finish_allowance), t)
    if levels is None:
        findings.append(_too_many_levels(step_over, units))
        return PocketPlan((), tuple(findings), t)
    if not levels:
        findings.append(_tool_too_large(r, units))
        return PocketPlan((), tuple(findings), t)
    reachable = levels[0][1]
    opening = regions.offset(reachable, r, t)
    findings += _narrow(
        regions.difference(region, opening), contours, names, r, match, units, rings, t
    )
    planner = _Planner(
        contours=contours,
        names=names,
        levels=levels,
        r=r,
        t=t,
        match=match,
        reverse_rings=routine_clockwise(Placement.POCKET, milling, rpm),
        block=block,
        safe=regions.offset(region, -(r + 2 * t), t),
        moves=regions.offset(region, -(r - t), t),
    )
    planner.cut_all()
    left = planner.clean_up()
    if left:
        findings.append(
            PocketFinding(
                PocketIssue.NARROW,
                Severity.WARNING,
                f"{left} places of uncut material could not be reached by cleanup moves",
            )
        )
    passes = planner.classify_links()
    centres = tuple(tuple((int(x), int(y)) for x, y in ring) for ring in planner.moves)
    return PocketPlan(tuple(passes), tuple(findings), t, centres=centres)


def pass_levels(
    plan: PocketPlan, z_up: int, z_dn: int, pecks: int = 1, floor_allowance: int = 0
) -> tuple[PassLevel, ...]:
    """Which passes run at which depth (nm), as the manual's routines peck: the whole plan
    at each of `pecks` levels evenly spaced from Z UP down to Z DN (+ `floor_allowance`),
    and with a floor allowance (a 2P roughing) the whole plan once more at Z DN — the pocket
    is cleared again (DESIGN.md §3). Between levels the interpreter retracts and goes back
    to the first plunge point."""
    levels = [PassLevel(z, plan.passes) for z in peck_levels(z_up, z_dn + floor_allowance, pecks)]
    if floor_allowance > 0:
        levels.append(PassLevel(z_dn, plan.passes))
    return tuple(levels)


# -- the planner -----------------------------------------------------------------------------


Level = tuple[float, list[regions.Ring]]
FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


@dataclass
class _Node:
    level: int
    component: regions.Component
    children: list[_Node] = field(default_factory=list)


@dataclass
class _Planner:
    contours: list[Path]
    names: list[str]
    levels: list[Level]
    r: float
    t: float
    match: float
    reverse_rings: bool
    block: int
    safe: list[regions.Ring]
    moves: list[regions.Ring]
    passes: list[Pass] = field(default_factory=list)
    position: Pt | None = None
    cleared: regions.SweptIndex | None = None
    _carriers: dict[int, tuple[list[Carrier], LevelTable]] = field(default_factory=dict)
    _points: dict[Path, list[Pt]] = field(default_factory=dict)
    # The same by the path's id (kept with it): a pass is asked for many times, and a
    # path's hash is made again from all its elements each time.
    _points_by_id: dict[int, tuple[Path, list[Pt]]] = field(default_factory=dict)
    _sweeps: dict[Path, regions.Swept] = field(default_factory=dict)
    # The rings each level's passes were made from (by level): what the passes sweep.
    _cut_rings: dict[int, list[regions.Ring]] = field(default_factory=dict)
    _narrow_sweeps: dict[Path, regions.Swept] = field(default_factory=dict)
    _pieces: dict[tuple[int, int], regions.Swept] = field(default_factory=dict)
    _tables: dict[int, tuple[Path, nearest.Elements]] = field(default_factory=dict)
    _every: tuple[list[Path], nearest.Elements, IntArray, IntArray] | None = None

    _move_boxes: list[regions.Box | None] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.cleared = self._index()
        self._move_boxes = [regions.box_of([ring]) for ring in self.moves]

    def _inside(self, a: Pt, b: Pt) -> bool:
        """True when the tool may feed straight from `a` to `b` (clear of every wall)."""
        return regions.segment_inside(self.moves, a, b, self._move_boxes)

    def _index(self) -> regions.SweptIndex:
        return regions.SweptIndex(self.r, self.t, self._pieces)

    # -- order -------------------------------------------------------------------------------

    def cut_all(self) -> None:
        for root in self._tree():
            self._cut(root)

    def _tree(self) -> list[_Node]:
        layers = [
            [_Node(k, c) for c in sorted(regions.components(rings), key=_key)]
            for k, (_, rings) in enumerate(self.levels)
        ]
        for k in range(1, len(layers)):
            for node in layers[k]:
                for parent in layers[k - 1]:
                    if regions.inside(parent.component.rings, node.component.outer[0]):
                        parent.children.append(node)
                        break
        return layers[0]

    def _cut(self, node: _Node) -> None:
        for child in node.children:
            self._cut(child)
        rings = list(node.component.rings)
        # Each ring's points as numpy reads them and its key, made once: the nearest ring
        # is asked again after every ring cut (a component's outer ring and its holes).
        arrays = [np.asarray(g, dtype=np.float64) for g in rings]
        keys = [_key_ring(g) for g in rings]
        leaf_entry = not node.children
        while rings:
            here = self.position
            k = min(
                range(len(rings)),
                key=lambda i: (_ring_distance(rings[i], here, arrays[i]), keys[i]),
            )
            ring = rings.pop(k)
            del arrays[k], keys[k]
            self._add_ring(node, ring, plunge_deep=leaf_entry)
            leaf_entry = False

    def _add_ring(self, node: _Node, ring: regions.Ring, plunge_deep: bool) -> None:
        sizes.spend()
        d, _ = self.levels[node.level]
        finish = node.level == 0
        tag = "finish" if finish else "rough"
        level, table = self._level_carriers(node.level, d)
        exact = exact_ring(ring, level, self.match, self.block, tag, table)
        if exact is not None:
            path, sources, is_exact = exact.path, exact.sources, True
        else:
            path = _polyline(ring, self.block, tag)
            sources, is_exact = matched_sources(ring, level, 2 * self.match), False
        if self.reverse_rings:
            path = reverse(path)
        entry, path = self._link(node, path, plunge_deep)
        names = tuple(dict.fromkeys(self.names[c] for c, _ in sources)) if finish else ()
        kind = PassKind.FINISH if finish else PassKind.ROUGH
        self.passes.append(Pass(kind, path, d, is_exact, entry, names))
        self._cut_rings.setdefault(node.level, []).append(ring)
        assert self.cleared is not None
        self.cleared.add(self._path_points(entry.path))
        self.cleared.add(self._path_points(path))
        self.position = _end(path)

    def _link(self, node: _Node, ring: Path, plunge_deep: bool) -> tuple[Link, Path]:
        """The way into a ring and the ring started where that way ends.

        A retract is the last resort: first a straight feed to the ring's nearest point
        (through cut material, or one step no longer than the tool diameter), then the same
        from the point of the previous ring nearest to this one (going along the previous
        ring, already cut, the shorter way round)."""
        here = self.position
        if here is None or plunge_deep:
            path = ring if here is None else rotate(ring, here)
            kind = LinkKind.PLUNGE if here is None else LinkKind.RETRACT
            deep = regions.deep_point(node.component, self.t)
            at = (float(deep[0]), float(deep[1]))
            if here is None:
                path = rotate(ring, at)
            if at != path.start and self._inside(at, path.start):
                return Link(kind, Path(at, (Element(self.block, path.start, tag="link"),))), path
            return Link(kind, Path(path.start, ())), path
        direct = rotate(ring, here)
        step = self._step(here, direct.start, direct)
        if step is LinkKind.CLEARED:
            return self._feed(step, Path(here, ()), direct), direct
        previous = self.passes[-1].path
        along, closest = _way_round(previous, ring, self.r / 8)
        shifted = rotate(ring, closest)
        other = self._step(closest, shifted.start, shifted)
        if (
            other is not None
            and along.elements
            and math.dist(closest, shifted.start) < math.dist(here, direct.start)
        ):
            return self._feed(other, along, shifted), shifted
        if step is not None:
            return self._feed(step, Path(here, ()), direct), direct
        return Link(LinkKind.RETRACT, Path(direct.start, ())), direct

    def _step(self, a: Pt, b: Pt, then: Path) -> LinkKind | None:
        """CLEARED or CUTTING for a straight feed from `a` to `b` before the pass `then`;
        None when the tool would touch a wall or island or cut farther than its
        diameter."""
        if math.dist(a, b) < 1.0:
            return LinkKind.CLEARED
        if not self._inside(a, b):
            return None
        move = Path(a, (Element(self.block, b, tag="link"),))
        if self._through_cleared(move, then):
            return LinkKind.CLEARED
        return LinkKind.CUTTING if math.dist(a, b) <= 2 * self.r else None

    def _feed(self, kind: LinkKind, along: Path, ring: Path) -> Link:
        elements = list(along.elements)
        end = _end(along)
        if math.dist(end, ring.start) >= 1.0:
            elements.append(Element(self.block, ring.start, tag="link"))
        return Link(kind, Path(along.start, tuple(elements)))

    def _level_carriers(self, k: int, d: float) -> tuple[list[Carrier], LevelTable]:
        """Level `k`'s carriers and their table (`level_table`), kept: a level has many
        rings."""
        if k not in self._carriers:
            level = carriers(self.contours, d, self.t)
            self._carriers[k] = (level, level_table(level, self.match))
        return self._carriers[k]

    # -- areas -------------------------------------------------------------------------------

    def _path_points(self, path: Path) -> list[Pt]:
        """The polyline of a path (its start alone when it has no elements), kept: a pass
        is swept and searched several times."""
        kept = self._points_by_id.get(id(path))
        if kept is not None and kept[0] is path:
            return kept[1]
        # By the path's value too: a link is asked about as a move, then made again equal.
        found = self._points.get(path)
        if found is None:
            found = regions.path_points(path, self.t) if path.elements else [path.start]
            self._points[path] = found
        self._points_by_id[id(path)] = (path, found)
        return found

    def _swept(self, path: Path) -> regions.Swept:
        found = self._sweeps.get(path)
        if found is None:
            found = regions.sweep_lines([self._path_points(path)], self.r, self.t)
            self._sweeps[path] = found
        return found

    def _through_cleared(self, move: Path, then: Path) -> bool:
        """True when the tool moving along `move` cuts nothing but what is already cut or
        what the pass `then` (the one it leads to) cuts. Only what was cut near the move is
        read (`SweptIndex`): the answer is the same, at the cost of the place, not of
        every pass so far.

        The move is swept by a radius a tolerance short of the tool's: the chords of a
        move along a pass and of the pass differ by that much. A straight move (every link
        the planner weighs) is answered from its distances to the passes near it
        (`regions.move_covered`); Clipper's sweeps are made only when that cannot tell, or
        for a link along a pass: the same answer (tests/test_pocketing.py holds them to
        it), without sweeping and uniting every pass beside a long link."""
        assert self.cleared is not None
        points = self._path_points(move)
        boxes = self.cleared.boxes(points)
        also = [self._path_points(then)]
        if len(points) == 2:
            starts, ends = self.cleared.segments_near(boxes, also)
            found = regions.move_covered(
                points[0], points[1], self.r - self.t, self.r, starts, ends, RESIDUE_NM, self.t
            )
            if found is not None:
                return found
        return self._through_cleared_by_area(move, then)

    def _through_cleared_by_area(self, move: Path, then: Path) -> bool:
        """`_through_cleared` asked of Clipper: the move's sweep less the sweeps of the
        passes near it, by one boolean operation (united as it is subtracted)."""
        assert self.cleared is not None
        points = self._path_points(move)
        swept = self._narrow_sweeps.get(move)
        if swept is None:
            swept = regions.sweep_lines([points], self.r - self.t, self.t)
            self._narrow_sweeps[move] = swept
        if not swept:
            return True
        near = self.cleared.near(self.cleared.boxes(points), [self._path_points(then)])
        extra = regions.difference(swept, near)
        return not regions.thicker_than(extra, RESIDUE_NM, self.t)

    def clean_up(self) -> int:
        """Add cleanup moves until the tool has swept all it can reach; how many pieces of
        material are left that no move could reach (0 normally)."""
        links = [s for p in self.passes for s in self._swept(p.entry.path)]
        residue = regions.difference(self._left_by_rings(), links)
        unreachable: list[Pt] = []
        for _ in range(MAX_CLEANUPS):
            sizes.spend()
            pieces = [
                c
                for c in regions.components(residue)
                if regions.thicker_than(c.rings, RESIDUE_NM, self.t)
            ]
            targets = []
            for piece in pieces:
                deep = regions.deep_point(piece, self.t)
                target = self._reachable(deep)
                if all(math.dist(target, u) > 1.0 for u in unreachable):
                    targets.append(target)
            if not targets:
                return len(pieces)
            spikes = []
            for target in targets:
                spike = self._spike(target)
                if spike is None:
                    unreachable.append(target)
                else:
                    spikes.append(spike)
            # What is left: the pieces wide enough to chase less what this round's moves
            # sweep, not the whole pocket less everything swept again (a narrow piece stays
            # narrow; the cusps of a many-island pocket are hundreds).
            kept = [ring for piece in pieces for ring in piece.rings]
            residue = regions.difference(kept, regions.sweep_lines(spikes, self.r, self.t))
        return 0

    def _left_by_rings(self) -> list[regions.Ring]:
        """The material within the tool's reach that the rings leave (links and cleanup
        moves aside), from each level's two offsets rather than a sweep of every pass.

        A level's rings are the edges of its region C; the tool going round them sweeps
        the band between C grown by the tool radius r and C shrunk by r. The levels nest
        (each region inside the one before), so a point the tool reaches and no ring
        sweeps lies, for the deepest level k whose C grown by r holds it, inside C_k
        shrunk by r and outside C_k+1 grown by r: the material left is the union of
        those differences, one per level, disjoint, without uniting any sweep. (Grown,
        not the contours shrunk by d - r: at a corner of C the grown region is round,
        the other sharp, and the corner cusps are what the cleanup looks for.) Were a
        level's region not inside the one before, the answer would only hold more (a
        point is in it if it is left), never less. Its edges lie within the chordal
        tolerance of the passes' sweeps: the pieces narrower than `RESIDUE_NM` that
        the difference makes are not chased."""
        cut = self._cut_rings
        grown = {k: regions.offset_raw(rings, self.r, self.t) for k, rings in cut.items() if k}
        left: list[regions.Ring] = []
        for k, rings in sorted(cut.items()):
            sizes.spend()
            inner = regions.offset_raw(rings, -self.r, self.t)
            left += regions.difference(inner, grown.get(k + 1, []))
        return left

    def _reachable(self, p: IPtF) -> Pt:
        """The point nearest `p` where the tool centre may go (inside `safe`): the first
        nearest point on the edges of `safe`, measured exactly where `nearest` cannot rule
        an edge out."""
        point = (float(p[0]), float(p[1]))
        if regions.inside(self.safe, (round(point[0]), round(point[1]))):
            return point
        edges = [
            (a, b) for ring in self.safe for a, b in zip(ring, ring[1:] + ring[:1], strict=True)
        ]
        if not edges:
            return point
        distances = nearest.segment_distances(point, self.safe)
        best, best_d = point, math.inf
        for k in np.flatnonzero(distances <= distances.min() + nearest.MARGIN).tolist():
            a, b = edges[k]
            fa, fb = (float(a[0]), float(a[1])), (float(b[0]), float(b[1]))
            q = _closest_on_segment(point, fa, fb)
            if math.dist(q, point) < best_d:
                best, best_d = q, math.dist(q, point)
        return best

    def _spike(self, target: Pt) -> list[Pt] | None:
        """Insert an out-and-back move to `target` into the nearest pass that can reach it
        in a straight line; the move's two points, or None. The twelve nearest places on
        the passes are tried, nearest first (`nearest` finds the few that can be among
        them; those are measured exactly)."""
        every, owners, firsts = self._every_element()
        count = len(owners)
        if not count:
            return None
        lower, upper = nearest.bounds(np.array([target], dtype=np.float64), every)
        twelfth = float(np.partition(upper[0], min(11, count - 1))[min(11, count - 1)])
        candidates: list[tuple[float, int, int, Pt]] = []
        for k in np.flatnonzero(lower[0] <= twelfth + nearest.MARGIN).tolist():
            i = int(owners[k])
            j = k - int(firsts[i])
            path = self.passes[i].path
            start = path.start if j == 0 else path.elements[j - 1].end
            q = _closest_on_element(target, start, path.elements[j])
            candidates.append((math.dist(q, target), i, j, q))
        candidates.sort()
        for _, i, j, q in candidates[:12]:
            if self._inside(q, target):
                made = self.passes[i]
                self.passes[i] = replace(made, path=_insert_spike(made.path, j, q, target))
                self._every_element_changed(i)
                return [q, target]
        return None

    def _every_element(self) -> tuple[nearest.Elements, IntArray, IntArray]:
        """The elements of every pass as one table (`_table`s one after another), each
        row's pass (`owners`), and where each pass's rows begin (`firsts`, and the end
        after the last): kept between cleanup moves, which change one pass each
        (`_every_element_changed`), not joined again from every pass for each move."""
        paths = [made.path for made in self.passes]
        kept = self._every
        if (
            kept is None
            or len(kept[0]) != len(paths)
            or any(a is not b for a, b in zip(kept[0], paths, strict=True))
        ):
            tables = [self._table(path) for path in paths]
            sizes_ = [len(t) for t in tables]
            owners = np.repeat(np.arange(len(tables)), sizes_)
            firsts = np.cumsum([0, *sizes_])
            kept = (paths, nearest.joined(tables), owners, firsts)
            self._every = kept
        return kept[1], kept[2], kept[3]

    def _every_element_changed(self, i: int) -> None:
        """`_every_element` after pass `i` was changed: its rows replaced by its new table."""
        kept = self._every
        if kept is None:
            return
        paths, every, owners, firsts = kept
        path = self.passes[i].path
        table = self._table(path)
        every = nearest.spliced(every, int(firsts[i]), int(firsts[i + 1]), table)
        grown = len(table) - int(firsts[i + 1] - firsts[i])
        owners = np.concatenate(
            (
                owners[: firsts[i]],
                np.full(len(table), i, dtype=owners.dtype),
                owners[firsts[i + 1] :],
            )
        )
        firsts = np.concatenate((firsts[: i + 1], firsts[i + 1 :] + grown))
        self._every = ([*paths[:i], path, *paths[i + 1 :]], every, owners, firsts)

    def _table(self, path: Path) -> nearest.Elements:
        """A pass's elements as `nearest` reads them, kept while the pass is unchanged."""
        found = self._tables.get(id(path))
        if found is None or found[0] is not path:
            found = (path, nearest.table(starts_of(path), path.elements))
            self._tables[id(path)] = found
        return found[1]

    def classify_links(self) -> list[Pass]:
        """The passes with each feed link marked CLEARED or CUTTING by the material cut
        before it (cleanup moves included).

        A link found CLEARED when it was planned stays so, unasked: what was cut before it
        then is cut before it now (the cleanup moves only add), and the part of a link
        that runs along the previous pass is inside that pass's cut. Only a CUTTING link
        is asked again (a cleanup move may have cleared its way)."""
        self.cleared = self._index()
        result: list[Pass] = []
        for made in self.passes:
            link = made.entry
            if link.kind is LinkKind.CUTTING:
                through = not link.path.elements or self._through_cleared(link.path, made.path)
                link = replace(link, kind=LinkKind.CLEARED if through else LinkKind.CUTTING)
            result.append(replace(made, entry=link))
            self.cleared.add(self._path_points(link.path))
            self.cleared.add(self._path_points(made.path))
        return result


IPtF = tuple[int, int] | tuple[float, float]


# -- paths ------------------------------------------------------------------------------------


def _end(path: Path) -> Pt:
    return path.elements[-1].end if path.elements else path.start


def _closest_on_segment(p: Pt, a: Pt, b: Pt) -> Pt:
    d = sub(b, a)
    denom = d[0] * d[0] + d[1] * d[1]
    if denom == 0:
        return a
    k = max(0.0, min(1.0, ((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / denom))
    return (a[0] + d[0] * k, a[1] + d[1] * k)


def _closest_on_element(p: Pt, start: Pt, element: Element) -> Pt:
    if element.centre is None:
        return _closest_on_segment(p, start, element.end)
    c = element.centre
    radius = math.dist(start, c)
    if math.dist(p, c) == 0:
        return start
    on_circle = (
        c[0] + (p[0] - c[0]) * radius / math.dist(p, c),
        c[1] + (p[1] - c[1]) * radius / math.dist(p, c),
    )
    if distance_to_element(on_circle, start, element) <= 1e-6 * max(radius, 1.0):
        return on_circle
    return min((start, element.end), key=lambda q: math.dist(q, p))


def _way_round(previous: Path, ring: Path, step: float) -> tuple[Path, Pt]:
    """The shorter way along the closed `previous` path from its start to its point nearest
    to `ring` (elements tagged "link"), and that point; points `step` apart are tried.

    Which point: the first sample whose distance to the ring (`_closest_on_element`, exact)
    is smallest. Only the (sample, element) pairs `nearest.nearest_pairs` cannot rule out
    are measured exactly, in order (the others are more than `MARGIN` farther than the
    nearest pair, so could never be the smallest): the same point as measuring them all,
    at the cost of the samples and elements near each other."""
    ring_starts = starts_of(ring)
    # The samples to numpy's rounding for the bounds (a sample's bounds move by about
    # 1e-6 nm, far inside MARGIN), each one measured exactly as `sample` makes it.
    samples = nearest.samples(previous, step)
    points = samples.at
    # Some sample is within its distance to any element's start (a point of the ring): the
    # nearest of those, so that the search's cells are about as small as the rings are
    # near (the ring's start alone put a whole ring in one cell, every pair measured).
    # At most `REACH_POINTS` of them, spread along the ring: the cost is the samples'.
    chosen = np.linspace(0, len(ring_starts) - 1, min(len(ring_starts), REACH_POINTS))
    reach = _reach(points, [ring_starts[k] for k in np.unique(chosen.astype(np.intp)).tolist()])
    table = nearest.table(ring_starts, ring.elements)
    best: tuple[float, Pt] | None = None
    for i, near in nearest.nearest_pairs(points, table, reach):
        point = samples.exact(i)
        for k in near:
            d = math.dist(_closest_on_element(point, ring_starts[k], ring.elements[k]), point)
            if best is None or d < best[0] - 1e-9:
                best = (d, point)
    assert best is not None
    q = best[1]
    way = Path(previous.start, _up_to(previous, q))
    if _length(way) > _length(previous) / 2:
        # Backward from the start to q: the forward piece from q to the start, reversed.
        way = reverse(Path(q, _up_to(rotate(previous, q), previous.start)))
    return Path(way.start, tuple(replace(e, tag="link") for e in way.elements)), q


REACH_POINTS = 64  # ring points a way round measures every sample against, at most


def _reach(points: FloatArray, targets: Sequence[Pt]) -> float:
    """The least distance (nm) from a row of `points` to one of `targets` (a few), as
    numpy finds it."""
    at = np.array(targets, dtype=np.float64).reshape(-1, 2)
    return float(np.hypot(points[:, 0:1] - at[None, :, 0], points[:, 1:2] - at[None, :, 1]).min())


def _up_to(path: Path, point: Pt) -> tuple[Element, ...]:
    """The elements of `path` from its start to `point` (on it), the last one cut there."""
    starts = starts_of(path)
    out: list[Element] = []
    for start, element in zip(starts, path.elements, strict=True):
        q = _closest_on_element(point, start, element)
        if math.dist(q, point) < 1.0:
            out += _split(start, element, point)[:1] if math.dist(start, point) >= 1.0 else []
            return tuple(out)
        out.append(element)
    return tuple(out)


def _length(path: Path) -> float:
    total, current = 0.0, path.start
    for element in path.elements:
        total += length(current, element)
        current = element.end
    return total


def _split(start: Pt, element: Element, at: Pt) -> list[Element]:
    """The element cut in two at a point on it (pieces shorter than 1 nm dropped)."""
    pieces = []
    if math.dist(start, at) >= 1.0:
        pieces.append(replace(element, end=at))
    if math.dist(at, element.end) >= 1.0:
        pieces.append(element)
    return pieces


def _insert_spike(path: Path, index: int, at: Pt, target: Pt) -> Path:
    starts = starts_of(path)
    element = path.elements[index]
    block = element.block
    head, tail = path.elements[:index], path.elements[index + 1 :]
    pieces = _split(starts[index], element, at)
    out = (Element(block, target, tag="cleanup"), Element(block, at, tag="cleanup"))
    if not pieces or math.dist(starts[index], at) < 1.0:
        middle = (*out, *pieces)
    else:
        middle = (pieces[0], *out, *pieces[1:])
    return Path(path.start, (*head, *middle, *tail))


def rotate(path: Path, near: Pt) -> Path:
    """A closed path started at its point nearest to `near` (the same path otherwise)."""
    starts = starts_of(path)
    best = min(
        range(len(path.elements)),
        key=lambda k: (math.dist(_closest_on_element(near, starts[k], path.elements[k]), near), k),
    )
    element = path.elements[best]
    at = _closest_on_element(near, starts[best], element)
    if math.dist(at, starts[best]) < 1.0:
        at = starts[best]
        return Path(at, (*path.elements[best:], *path.elements[:best]))
    if math.dist(at, element.end) < 1.0:
        return Path(element.end, (*path.elements[best + 1 :], *path.elements[: best + 1]))
    first, second = replace(element, end=at), element
    if element.centre is not None and len(path.elements) == 1:
        # A full circle started elsewhere is still a full circle.
        return Path(at, (replace(element, end=at),))
    return Path(at, (second, *path.elements[best + 1 :], *path.elements[:best], first))


def _oriented(path: Path, ccw: bool) -> Path:
    return path if (signed_area(path) > 0) == ccw else reverse(path)


def _polyline(ring: regions.Ring, block: int, tag: str) -> Path:
    points = [(float(x), float(y)) for x, y in ring]
    return Path(points[0], tuple(Element(block, p, tag=tag) for p in [*points[1:], points[0]]))


def _key(component: regions.Component) -> tuple[int, int]:
    return _key_ring(component.outer)


def _key_ring(ring: regions.Ring) -> tuple[int, int]:
    low = min(ring, key=_Y_THEN_X)  # (a key made in C: rings of thousands of points)
    return (low[1], low[0])


_Y_THEN_X = operator.itemgetter(1, 0)


def _ring_distance(ring: regions.Ring, here: Pt | None, at: FloatArray) -> float:
    """The distance from `here` to the nearest point of `ring`, as `math.dist` measures it
    (numpy finds the few points that can be nearest: a ring has thousands). `at`: the
    ring's points as a float array (made once by the caller, who asks many times)."""
    if here is None:
        return 0.0
    squared = (at[:, 0] - here[0]) ** 2 + (at[:, 1] - here[1]) ** 2
    # numpy's squares and math.dist differ in the last bits: every point within a
    # millionth of the least is measured exactly.
    near = np.flatnonzero(squared <= squared.min() * (1 + 1e-6) + 1.0)
    return min(math.dist(here, ring[k]) for k in near.tolist())


# -- levels and findings ----------------------------------------------------------------------


def _levels(
    contours: list[Path], r: float, step: float, allowance: float, t: float
) -> list[Level] | None:
    """(offset, region shrunk by it) from the finishing level inward; None when there would
    be more than MAX_LEVELS. Each level is the contours' own offset (`regions.inset`): its
    cost is the contours' size, whatever the depth."""
    found: list[Level] = []
    d = r
    while len(found) <= MAX_LEVELS:
        sizes.spend()
        shrunk = regions.inset(contours, d, t)
        if not shrunk:
            return found
        found.append((d, shrunk))
        if len(found) == 1:
            d = r + allowance if allowance > t else r + step
        else:
            d += step
    return None


def _narrow(
    residue: list[regions.Ring],
    contours: list[Path],
    names: list[str],
    r: float,
    match: float,
    units: Units,
    rings: list[regions.Ring],
    t: float,
) -> list[PocketFinding]:
    """Material the tool cannot reach that is more than a corner it cannot get into."""
    found = []
    for piece in regions.components(residue):
        if not regions.thicker_than(piece.rings, RESIDUE_NM, match):
            continue
        touched = _touched(piece, contours, 4 * match)
        if _is_corner(touched, contours) or _in_corners(piece, touched, contours, r):
            continue
        if _where_contours_meet(piece, touched, rings, r, t):
            continue
        described = ", ".join(_describe(names, contours, c, e) for c, e in touched[:4])
        if len(touched) > 4:
            described += f" and {len(touched) - 4} more"
        at = piece.outer[0]
        found.append(
            PocketFinding(
                PocketIssue.NARROW,
                Severity.WARNING,
                f"the pocket is narrower than the {show(2 * r, units)} tool near X "
                f"{show(at[0], units)} Y {show(at[1], units)} ({described}): material is "
                "left there",
                names[touched[0][0]] if touched else None,
                touched[0][1] + 1 if touched else None,
                contours[touched[0][0]].elements[touched[0][1]].block if touched else None,
                (float(at[0]), float(at[1])),
            )
        )
    return found


def _touched(piece: regions.Component, contours: list[Path], reach: float) -> list[tuple[int, int]]:
    points = [(float(x), float(y)) for ring in piece.rings for x, y in ring]
    box = regions.box_of(piece.rings)
    assert box is not None
    x0, y0, x1, y1 = box[0] - reach, box[1] - reach, box[2] + reach, box[3] + reach
    touched = []
    for ci, contour in enumerate(contours):
        for ei, (start, element) in enumerate(
            zip(starts_of(contour), contour.elements, strict=True)
        ):
            # An element whose box (its circle's, for an arc) is beyond the piece's grown
            # box is not within reach of it: not measured point by point.
            if element.centre is None:
                ex = (min(start[0], element.end[0]), max(start[0], element.end[0]))
                ey = (min(start[1], element.end[1]), max(start[1], element.end[1]))
            else:
                radius = math.dist(start, element.centre)
                ex = (element.centre[0] - radius, element.centre[0] + radius)
                ey = (element.centre[1] - radius, element.centre[1] + radius)
            if ex[0] > x1 or ex[1] < x0 or ey[0] > y1 or ey[1] < y0:
                continue
            if any(distance_to_element(p, start, element) <= reach for p in points):
                touched.append((ci, ei))
    return touched


def _is_corner(touched: list[tuple[int, int]], contours: list[Path]) -> bool:
    """One element, or two consecutive elements of one contour: a corner's fillet."""
    if len(touched) == 1:
        return True
    if len(touched) != 2 or touched[0][0] != touched[1][0]:
        return False
    n = len(contours[touched[0][0]].elements)
    a, b = touched[0][1], touched[1][1]
    return (b - a) % n in (1, n - 1)


def _in_corners(
    piece: regions.Component, touched: list[tuple[int, int]], contours: list[Path], r: float
) -> bool:
    """True when the piece touches one unbroken stretch of one contour and lies within one
    and a half tool radii of the joints between its elements: the fillets a round tool
    leaves in a curve drawn as short lines (a DXF's polyline), merged along the stretch,
    not a passage narrower than the tool (which reaches farther from every joint)."""
    if not touched or len({c for c, _ in touched}) != 1:
        return False
    contour = contours[touched[0][0]]
    n = len(contour.elements)
    indexes = sorted(e for _, e in touched)
    # One stretch, possibly across the contour's start: at most one gap between neighbours.
    gaps = sum(
        1 for a, b in zip(indexes, indexes[1:] + indexes[:1], strict=True) if (b - a) % n != 1
    )
    if gaps > 1 or len(indexes) == n:
        return False
    joints = [contour.elements[e].end for e in indexes]
    # Every point of the piece's outline, not its vertices only: a long sliver along a
    # wall has vertices near joints at its two ends and none between.
    points: list[Pt] = []
    for ring in piece.rings:
        for (ax, ay), (bx, by) in zip(ring, ring[1:] + ring[:1], strict=True):
            steps = max(1, math.ceil(math.hypot(bx - ax, by - ay) / (r / 2)))
            points += [
                (ax + (bx - ax) * k / steps, ay + (by - ay) * k / steps) for k in range(steps)
            ]
    return all(any(math.dist(p, j) <= 1.5 * r for j in joints) for p in points)


def _where_contours_meet(
    piece: regions.Component,
    touched: list[tuple[int, int]],
    rings: list[regions.Ring],
    r: float,
    t: float,
) -> bool:
    """True when the piece lies within one and a half tool radii of where the contours it
    touches meet (an island against the wall or another island, reported as such): the
    corners there are fillets every round tool leaves, not a narrow passage."""
    touched_contours = sorted({c for c, _ in touched})
    if len(touched_contours) < 2:
        return False
    grown = {c: regions.offset([rings[c]], 2 * t + 2, t) for c in touched_contours}
    meeting: list[regions.Ring] = []
    for k, a in enumerate(touched_contours):
        for b in touched_contours[k + 1 :]:
            meeting += regions.intersection(grown[a], grown[b])
    if not meeting:
        return False
    near = regions.offset(meeting, 1.5 * r, t)
    return all(regions.inside(near, (x, y)) for ring in piece.rings for x, y in ring)


def _describe(names: list[str], contours: list[Path], c: int, e: int) -> str:
    block = contours[c].elements[e].block
    return f"{names[c]} element {e + 1}" + (f" (block {block})" if block else "")


def _parameter_problems(
    radius: int, step: int, allowance: int, units: Units
) -> list[PocketFinding]:
    found = []
    if radius <= 0:
        found.append(
            _step_finding(f"the tool radius must be more than 0 (it is {show(radius, units)})")
        )
    elif not 0 < step < 2 * radius:
        found.append(
            _step_finding(
                f"the step-over {show(step, units)} must be more than 0 and less than the tool "
                f"diameter {show(2 * radius, units)}"
            )
        )
    if allowance < 0:
        found.append(
            _step_finding(f"the finish allowance {show(allowance, units)} must not be negative")
        )
    return found


def _step_finding(message: str) -> PocketFinding:
    return PocketFinding(PocketIssue.STEP_OVER, Severity.ERROR, message)


def _too_many_levels(step: int, units: Units) -> PocketFinding:
    return _step_finding(
        f"a step-over of {show(step, units)} needs more than {MAX_LEVELS} passes for this "
        "pocket; use a larger step-over"
    )


def _tool_too_large(r: float, units: Units) -> PocketFinding:
    return PocketFinding(
        PocketIssue.TOOL_TOO_LARGE,
        Severity.ERROR,
        f"boundary: the {show(2 * r, units)} tool fits nowhere inside the pocket; it is "
        "nowhere wider than the tool",
        "boundary",
    )


def _errors(findings: list[PocketFinding]) -> bool:
    return any(f.severity is Severity.ERROR for f in findings)
