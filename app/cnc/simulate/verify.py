"""Verify: the simulated part measured against the part the program means to make.

The intended part is the stock less what each block means to remove (`intended.py`);
findings, each named by the block at fault:

- **gouge**: material removed below what every block means to cut there. Beside a
  finished surface (a compensated contour, a POCKET's wall or island, a CIRCLE/FRAME
  wall: a band two tool radii wide; not the wall of a boss that roughs out a smaller one,
  `Intent.roughing`) it names the surface damaged, else it is material no block means to
  remove. Also a closed contour cut from inside through the stock around
  features of the part: the slug that drops out is the part, cut on the wrong side.
- **rest material**: material left above Z DN that a block means to clear: a POCKET
  routine's inside (a frame whose corner radius is smaller than the tool's), the band one
  tool radius wide beside any CIRCLE/FRAME wall (beside an external thread's minor
  diameter, above where its full form must reach: `Routine.depth`, a lead and a quarter
  above its Z DN, down to which it may cut), an irregular POCKET where the tool fits,
  and the inside of a closed contour cut from inside (blind: an outer profile cut on the
  wrong side leaves the whole part standing in its groove).
- **hole depth**: a DRILL/BORE/TAP hole whose bottom at its centre is shallower or deeper
  than Z DN (a hole through the stock's bottom is through, not shallow). A drill point's
  cone is allowed for between the hole's centre and the centre of the cell it is in.
- **crash**: a rapid move whose tool meets material (the simulation checks each rapid that
  goes below the stock's top against the part as cut so far).
- **process**: what `check` reports too, from the same rules (`app/cnc/process.py`): a TAP
  or BORE with no pilot, a cut below the stock's bottom past its CLEAR.

Everything is measured at the cell centres of the simulation's grid, so a finding is at
least one cell across. Lengths in nm inside, printed in the program's units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from decimal import Decimal
from typing import Any

import numpy as np

from app.cnc import sizes
from app.cnc.blocks import Program
from app.cnc.compiler import compile_program
from app.cnc.plane import Path
from app.cnc.pocketing.regions import offset, path_points
from app.cnc.problems import Rule
from app.cnc.process import in_ring
from app.cnc.simulate.intended import (
    Intent,
    ccw_ring,
    centres,
    clearing,
    distance_to,
    element_measures,
    fill,
    intended,
    is_closed,
    part_inside,
    routine_sdf,
    window,
    window_cells,
)
from app.cnc.simulate.placements import Placed, place
from app.cnc.simulate.programmed import (
    Contour,
    PocketArea,
    Programmed,
    Routine,
    programmed_geometry,
)
from app.cnc.simulate.segments import BOOL, F64, default_diameter
from app.cnc.simulate.stock import (
    Grid,
    Stock,
    auto_resolution,
    extent_stock,
    make_grid,
    program_stock,
)
from app.cnc.simulate.sweep import Simulation, simulate
from app.cnc.units import Units, format_length, to_nm
from app.cnc.validate import validate

DEFAULT_TOLERANCE = {Units.INCH: Decimal("0.001"), Units.MM: Decimal("0.02")}


@dataclass(frozen=True)
class Finding:
    """One thing wrong with the simulated part: `block` is the block at fault, `kind` one of
    gouge, rest, hole, crash; (x, y) where it is worst (nm)."""

    block: int
    kind: str
    message: str
    x: float
    y: float


@dataclass
class Verification:
    """A simulation and what verify found in it."""

    program: Program
    simulation: Simulation
    findings: list[Finding] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    checked: dict[str, int] = field(default_factory=dict)
    tolerance: int = 0

    @property
    def units(self) -> Units:
        return self.program.units

    def by_block(self) -> dict[int, list[Finding]]:
        """Findings grouped by block, in block order."""
        groups: dict[int, list[Finding]] = {}
        for finding in self.findings:
            groups.setdefault(finding.block, []).append(finding)
        return dict(sorted(groups.items()))

    def text(self) -> str:
        """The report: stock, grid, removed volume per tool, notes, then one line a finding."""
        u = self.units
        grid = self.simulation.grid
        cubic = u.nm**3

        def volume(nm3: float) -> str:
            return f"{nm3 / cubic:.4f} {u.symbol}³"

        lines = [
            f"stock: {grid.stock.describe(u)}",
            f"grid: {grid.nx} × {grid.ny} cells of {_len(round(grid.resolution), u)}; "
            f"tolerance {_len(self.tolerance, u)}",
            f"removed: {volume(self.simulation.removed_volume())}"
            + "".join(
                f"; tool {tool} {volume(v)}"
                for tool, v in sorted(self.simulation.removed_by_tool.items())
            ),
            "checked: " + ", ".join(f"{n} {what}" for what, n in self.checked.items()),
        ]
        lines += [f"note: {note}" for note in self.notes]
        lines += [f"block {f.block}: {f.kind}: {f.message}" for f in self.findings]
        count = len(self.findings)
        lines.append(
            "nothing found" if count == 0 else f"{count} finding{'s' if count > 1 else ''}"
        )
        return "\n".join(lines) + "\n"


def stock_of(program: Program, placed: Placed) -> Stock:
    """The program's own stock, else one sized from its extent. Raises StockError."""
    if program.stock is not None:
        return program_stock(program.stock, program.units)
    return extent_stock(placed, program.units)


# What sweeping one group of placements costs beside its cells (its stamps, its batches),
# in cells: a LOOP of many small pieces is slow for its groups, not its cells.
GROUP_WORK = 10_000

# What sweeping one segment costs beside its cells, in cells (about 3-4 µs against 40-50 ns
# a cell here): a HELIX of thousands of turns is millions of short chords, few cells each,
# and took 18-28 s on the 3D view's coarse grid while its work read 47 M cells.
SEGMENT_WORK = 64


class VerifyTooLarge(sizes.TooLarge):
    """Verify of this program would take more work than this server allows (the message
    names the figure, the limit and what to do)."""


def work(grid: Grid, placed: Placed) -> int:
    """The work the simulation of `placed` on `grid` will do, known before it starts: the
    cells every segment's box covers (its length and its tool's diameter at the grid's
    resolution, each placement counted) and SEGMENT_WORK for each segment placed, and
    GROUP_WORK for each group. Time grows with
    it (docs/security.md, "Verify")."""
    res = grid.resolution
    cells = 0.0
    for group in placed.groups:
        s = group.segments
        across = 2 * s.radius / res + 1
        along = np.hypot(s.x1 - s.x0, s.y1 - s.y0) / res + across
        cells += (float((along * across).sum()) + SEGMENT_WORK * len(s.x0)) * len(group.offsets)
    return int(cells) + GROUP_WORK * len(placed.groups)


def check_work(grid: Grid, placed: Placed, units: Units) -> int:
    """The simulation's `work`; raises VerifyTooLarge when it is past `sizes.verify_limit()`."""
    found = work(grid, placed)
    limit = sizes.verify_limit()
    if limit is not None and found > limit:
        raise VerifyTooLarge(
            f"simulating this program means sweeping about {found:,} cells "
            f"({len(placed):,} segments in cells of {_len(grid.resolution, units)}); "
            f"Verify on this server sweeps at most {limit:,}, so that it answers within seconds: "
            "run `millblocks verify` on your own computer, which has no such limit, or make "
            "the program smaller (fewer LOOP patterns, fewer helix turns)"
        )
    return found


def prepare(
    program: Program, resolution: int | None = None, cells: int = 800
) -> tuple[Grid, Placed]:
    """The grid (the program's stock, `resolution` nm cells, or about `cells` along the
    longer side) and the placed segments of a validated program. Raises StockError, and
    VerifyTooLarge when simulating them is past the server's limit (`check_work`)."""
    placed = place(program, compile_program(program).path)
    stock = stock_of(program, placed)
    grid = make_grid(stock, resolution or auto_resolution(stock, program.units, cells))
    check_work(grid, placed, program.units)
    return grid, placed


def run_simulation(
    program: Program, resolution: int | None = None, upto: int | None = None, cells: int = 800
) -> Simulation:
    """Simulate a validated program up to block `upto` (None: all); see `prepare`."""
    grid, placed = prepare(program, resolution, cells)
    return simulate(grid, placed, upto, default_tolerance(program.units))


def default_tolerance(units: Units) -> int:
    """0.001 in, or 0.02 mm: in nm."""
    return to_nm(DEFAULT_TOLERANCE[units], units)


def verify(
    program: Program, resolution: int | None = None, tolerance: int | None = None
) -> Verification:
    """Simulate a validated program and check it (see the module's note). `tolerance` (nm)
    defaults to 0.001 in (0.02 mm). Raises StockError for a bad stock."""
    tol = default_tolerance(program.units) if tolerance is None else tolerance
    grid, placed = prepare(program, resolution)
    sim = simulate(grid, placed, None, tol)
    geometry = programmed_geometry(program)
    result = Verification(program, sim, notes=placed.shapes.notes(), tolerance=tol)
    result.checked = {
        "contours": len(geometry.contours),
        "routines": len(geometry.routines),
        "holes": len(geometry.holes),
    }
    if geometry.pockets:
        result.checked["pockets"] = len(geometry.pockets)
    top = grid.stock.top
    if not any((np.minimum(g.segments.z0, g.segments.z1) < top).any() for g in placed.groups):
        result.notes.append(
            "no move goes below the stock's top, so nothing is cut (a 2-axis program "
            "moves the quill by hand)"
        )
    check_part(result, geometry, tol)
    result.findings = sorted(
        result.findings + _process_findings(program), key=lambda f: (f.block, f.kind, f.message)
    )
    return result


def check_part(result: Verification, geometry: Programmed, tol: int) -> None:
    """Measure the simulated part against the part the program means to make (`tol` nm):
    every finding goes into `result.findings`, sorted by block."""
    sim = result.simulation
    heights = sim.heights()
    owners = Owners(sim)
    u = result.units
    default_radius = default_diameter(u) // 2
    grid = sim.grid
    intent = intended(grid, geometry, tol, default_radius)
    # Material removed below what any block means to cut there: gouges. Each is named by
    # the surface it damaged where it lies in one's band, else as waste no block meant.
    gouged = heights < intent.floor - tol
    claimed = np.zeros_like(gouged)
    found: list[Finding] = []
    for k, contour in enumerate(geometry.contours):
        sizes.spend()
        if k not in intent.contours:  # a roughing's wall is no finished surface
            found += _contour_gouges(grid, heights, owners, contour, tol, u, gouged, claimed)
        found += _contour_rest(grid, heights, contour, geometry, tol, u)
    pocket_floor, must_clear = clearing(grid, geometry.routines, tol)
    left_in_pockets = must_clear & (heights > np.maximum(pocket_floor, grid.stock.bottom) + tol)
    # A roughing's wall is no finished surface: nothing is a gouge past it.
    nothing = np.zeros_like(gouged) if intent.roughing else gouged
    for k, routine in enumerate(geometry.routines):
        sizes.spend()
        walled = nothing if k in intent.roughing else gouged
        found += _routine_findings(
            grid, heights, owners, routine, tol, u, walled, claimed, left_in_pockets
        )
    for pocket in geometry.pockets:
        sizes.spend()
        found += _pocket_findings(grid, heights, pocket, tol, u)
    crashed = {crash.block for crash in sim.crashes}
    found += _waste_gouges(grid, heights, owners, intent, gouged & ~claimed, crashed, u)
    if not grid.stock.given:
        result.notes += _unjudged_inner_contours(geometry)
    found += _hole_findings(sim.grid, heights, owners, geometry, tol, u)
    found += _crash_findings(sim, u)
    result.findings = sorted(found, key=lambda f: (f.block, f.kind, f.message))


def _unjudged_inner_contours(geometry: Programmed) -> list[str]:
    """The note for closed contours cut from inside when the stock is sized from the
    program: whether they go through (and the slug falls out) is unknown."""
    inner = sorted(
        {
            c.drill
            for c in geometry.contours
            if c.depth is not None
            and is_closed(c)
            and not part_inside(c)
            and not any(c in p.contours for p in geometry.pockets)
        }
    )
    if not inner:
        return []
    which = (
        f"the closed contours from blocks {', '.join(map(str, inner))} are cut with the tool "
        "inside, so what each encloses"
        if len(inner) > 1
        else f"the closed contour from block {inner[0]} is cut with the tool inside, so what "
        "it encloses"
    )
    return [
        which + " is waste; with the stock sized from the program, verify cannot tell whether "
        "the cut goes through, so it does not check that the inside is cleared (save the "
        "stock to have it checked)"
    ]


class Owners:
    """Which block cut each cell, worked out on first use: only a finding needs it, and
    for a large grid it costs more than the checks (`Simulation.owner_blocks`)."""

    def __init__(self, sim: Simulation) -> None:
        self._sim = sim
        self._blocks: np.ndarray | None = None

    def __getitem__(self, key: Any) -> Any:
        if self._blocks is None:
            if isinstance(key, tuple) and all(isinstance(k, int) for k in key):
                return self._sim.owner_at(*key)  # one cell: a hole's finding
            self._blocks = self._sim.owner_blocks()
        return self._blocks[key]


def _process_findings(program: Program) -> list[Finding]:
    """The process rules `check` reports too (a tap's pilot, a cut below the stock), as
    findings: the same problems, from the same code."""
    rules = (Rule.PILOT, Rule.BELOW_STOCK)
    # validate found them already (and keeps the answer for this very program): read them.
    return [
        Finding(p.block or 0, "process", p.message, 0.0, 0.0)
        for p in validate(program)
        if p.rule in rules
    ]


# -- cells near a shape --------------------------------------------------------------------


def _worst(
    mask: BOOL, amount: F64, qx: F64, qy: F64, owners: np.ndarray | None
) -> list[tuple[int, float, float, float, int]]:
    """Per owner block (0 when `owners` is None): (block, worst amount, x, y, cells)."""
    if not mask.any():
        return []
    keys = owners[mask] if owners is not None else np.zeros(int(mask.sum()), dtype=np.int32)
    values, xs, ys = amount[mask], qx[mask], qy[mask]
    out = []
    for block in np.unique(keys).tolist():
        here = keys == block
        k = int(np.argmax(np.where(here, values, -np.inf)))
        out.append((int(block), float(values[k]), float(xs[k]), float(ys[k]), int(here.sum())))
    return out


def _at(x: float, y: float, u: Units) -> str:
    return f"X {format_length(round(x), u)} Y {format_length(round(y), u)}"


def _len(nm: float, u: Units) -> str:
    return f"{format_length(round(nm), u)} {u.symbol}"


# -- compensated contours ------------------------------------------------------------------


def _contour_gouges(
    grid: Grid,
    heights: F64,
    owners: Owners,
    contour: Contour,
    tol: int,
    u: Units,
    gouged: BOOL,
    claimed: BOOL,
) -> list[Finding]:
    band = 2.0 * contour.tool_radius
    starts = [contour.start] + [e.end for e in contour.elements[:-1]]
    pts = [p for e in contour.elements for p in (e.end, e.centre) if p is not None]
    pts.append(contour.start)
    reach = band + max(
        (math.dist(s, e.centre) for s, e in zip(starts, contour.elements, strict=True) if e.centre),
        default=0.0,
    )
    xs, ys = [p[0] for p in pts], [p[1] for p in pts]
    rows, cols, qx, qy = window(
        grid, min(xs) - reach, min(ys) - reach, max(xs) + reach, max(ys) + reach
    )
    if qx.size == 0 or not gouged[rows, cols].any():
        return []
    # The nearest element of each cell, kept as the elements go by (the first of equals):
    # stacking every element's measures would hold elements × cells arrays at once.
    best = np.full(qx.shape, np.inf)
    nearest = np.zeros(qx.shape, dtype=np.int64)
    left = np.zeros(qx.shape)
    interior = np.zeros(qx.shape, dtype=bool)
    for k, (s, e) in enumerate(zip(starts, contour.elements, strict=True)):
        dist, side, within = element_measures(qx, qy, s, e)
        closer = dist < best
        best = np.where(closer, dist, best)
        nearest[closer] = k
        left = np.where(closer, side, left)
        interior = np.where(closer, within, interior)
    inward = left if contour.part_left else -left
    mask = interior & (inward > tol) & (inward <= band) & gouged[rows, cols]
    claimed[rows, cols] |= mask
    block_of = np.array([e.block for e in contour.elements])[nearest]
    findings = []
    for culprit, depth, x, y, _ in _worst(mask, inward, qx, qy, owners[rows, cols]):
        near = int(block_of[mask & (owners[rows, cols] == culprit)][0]) if culprit else 0
        least = "at least " if depth > band - grid.resolution else ""
        findings.append(
            Finding(
                culprit or contour.drill,
                "gouge",
                f"cuts {least}{_len(depth, u)} into the finished contour of block {near} "
                f"(the sequence from block {contour.drill}) at {_at(x, y, u)}",
                x,
                y,
            )
        )
    return findings


def _contour_rest(
    grid: Grid,
    heights: F64,
    contour: Contour,
    geometry: Programmed,
    tol: int,
    u: Units,
) -> list[Finding]:
    """A closed contour cut with the tool inside it says the part is outside: what it
    encloses is waste, to be cleared where the tool fits (an inner profile, a pocket's
    wall). Material left standing there is rest material, unless the cut goes through the
    stock and the slug falls out. This is how a contour cut on the wrong side shows: an
    outer profile cut from inside leaves the whole part standing inside its groove."""
    if contour.depth is None or not is_closed(contour) or part_inside(contour):
        return []
    if any(contour in p.contours for p in geometry.pockets):
        return []  # a POCKET's wall: the pocket's own check
    if not grid.stock.given:
        return []  # whether the cut goes through is unknown: check_part notes it
    r = float(contour.tool_radius)
    chord = grid.resolution / 4
    ring = path_points(Path(contour.start, contour.elements), chord)
    side, other = ("RT", "LT") if contour.part_left else ("LT", "RT")
    if contour.depth <= grid.stock.bottom:
        return _slug_findings(grid, contour, ring, geometry, tol, u, side, other)
    xs, ys = [p[0] for p in ring], [p[1] for p in ring]
    rows, cols, qx, qy = window(grid, min(xs), min(ys), max(xs), max(ys))
    if qx.size == 0:
        return []
    inside = fill(grid, [ring])[rows, cols]
    for kept in geometry.contours:
        if kept is not contour and is_closed(kept) and part_inside(kept):
            island = path_points(Path(kept.start, kept.elements), chord)
            inside &= ~fill(grid, [island])[rows, cols]
    for routine in geometry.routines:
        if not routine.inside:
            inside &= routine_sdf(routine, qx, qy, 0.0) > 0
    nearest = distance_to([contour], qx, qy)
    left = heights[rows, cols] - contour.depth
    rest = inside & (nearest >= r + tol) & (left > tol)
    findings = []
    for _, thick, x, y, cells in _worst(rest, left, qx, qy, None):
        area = cells * grid.resolution**2
        findings.append(
            Finding(
                contour.drill,
                "rest material",
                f"{area / u.nm**2:.4f} {u.symbol}² inside the closed contour of block "
                f"{contour.drill} stands {_len(thick, u)} above its Z DN at {_at(x, y, u)}: "
                f"cut {side} puts the tool inside it, so the part is outside and the inside "
                f"is waste; clear it (a POCKET), cut through the stock, or, if the part is "
                f"inside the contour, cut on the other side (CUT {other})",
                x,
                y,
            )
        )
    return findings


def _slug_findings(
    grid: Grid,
    contour: Contour,
    ring: list[tuple[float, float]],
    geometry: Programmed,
    tol: int,
    u: Units,
    side: str,
    other: str,
) -> list[Finding]:
    """A closed contour cut from inside through the stock: what it encloses drops out as a
    slug. Features the program cuts in the slug, away from the contour's own tool band,
    say the slug is the part and the contour is cut on the wrong side — unless they clear
    most of it, as a window is roughed out before its wall is finished (a start hole where
    the end mill plunges lies in the band)."""
    r = float(contour.tool_radius)
    chord = grid.resolution / 4
    inner_rings = offset([ccw_ring(ring)], -2 * r - tol, chord)
    if not inner_rings:
        return []
    inner = fill(grid, [[(float(x), float(y)) for x, y in piece] for piece in inner_rings])
    cells = int(inner.sum())
    if not cells:
        return []
    held = [(float(x), float(y)) for x, y in inner_rings[0]]
    # The features the program cuts in the slug, by where each is (a hole's centre, a
    # routine's middle, where a contour or POCKET starts): a start hole at the contour's
    # plunge point is in its band, not in the slug.
    features = Programmed(
        contours=[c for c in geometry.contours if c is not contour and in_ring(held, *c.start)],
        routines=[t for t in geometry.routines if in_ring(held, *_routine_point(t))],
        holes=[h for h in geometry.holes if in_ring(held, h.x, h.y)],
        pockets=[p for p in geometry.pockets if in_ring(held, *p.contours[0].start)],
        slots=[c for c in geometry.slots if in_ring(held, *c.start)],
    )
    inside_blocks = sorted(
        {h.block for h in features.holes}
        | {t.block for t in features.routines}
        | {c.drill for c in features.contours + features.slots}
        | {p.block for p in features.pockets}
    )
    if not inside_blocks:
        return []
    default_radius = default_diameter(u) // 2
    cut = inner & (intended(grid, features, tol, default_radius).floor < grid.stock.top - tol)
    if cut.sum() > cells / 2:
        return []  # they clear most of it: the window roughed out before its wall
    x, y = contour.start
    return [
        Finding(
            contour.drill,
            "gouge",
            f"cut {side} puts the tool inside the closed contour of block {contour.drill} "
            "and the cut goes through the stock, so what it encloses drops out as a slug "
            f"with the features of block{'s' if len(inside_blocks) > 1 else ''} "
            f"{', '.join(map(str, inside_blocks))} in it: if the part is inside the "
            f"contour, cut on the other side (CUT {other}); as programmed it comes out "
            f"{_len(2 * r, u)} undersize",
            x,
            y,
        )
    ]


def _routine_point(routine: Routine) -> tuple[float, float]:
    """A point inside a routine's finished contour: its centre."""
    if routine.is_frame:
        return routine.corner[0] + routine.width / 2, routine.corner[1] + routine.height / 2
    return routine.centre


# -- circle and frame routines -------------------------------------------------------------


def _routine_findings(
    grid: Grid,
    heights: F64,
    owners: Owners,
    routine: Routine,
    tol: int,
    u: Units,
    gouged: BOOL,
    claimed: BOOL,
    left_in_pockets: BOOL,
) -> list[Finding]:
    """Gouges past a routine's wall, and material left beside it (or, for a POCKET, in it:
    looked for only where `left_in_pockets` says some pocket kept material)."""
    if routine.depth is None or routine.tool_radius <= 0:
        return []
    r = float(routine.tool_radius)
    if routine.is_frame:
        x0, y0 = routine.corner
        x1, y1 = x0 + routine.width, y0 + routine.height
    else:
        (cx, cy), rad = routine.centre, routine.radius
        x0, y0, x1, y1 = cx - rad, cy - rad, cx + rad, cy + rad
    rows, cols = window_cells(grid, x0 - 2 * r, y0 - 2 * r, x1 + 2 * r, y1 + 2 * r)
    wanted = gouged[rows, cols].any() or not routine.pocket or left_in_pockets[rows, cols].any()
    if not wanted:
        return []  # nothing removed past its wall, nothing left in it: the usual case
    rows, cols, qx, qy = window(grid, x0 - 2 * r, y0 - 2 * r, x1 + 2 * r, y1 + 2 * r)
    if qx.size == 0:
        return []
    h = heights[rows, cols]
    own = owners[rows, cols]
    sdf = routine_sdf(routine, qx, qy, 0.0)
    part = sdf if routine.inside else -sdf
    tool_side = -part
    findings = []
    past = (part > tol) & (part <= 2 * r) & gouged[rows, cols]  # a cut reaches a diameter in
    claimed[rows, cols] |= past
    for culprit, depth, x, y, _ in _worst(past, part, qx, qy, own):
        findings.append(
            Finding(
                culprit or routine.block,
                "gouge",
                f"cuts {_len(depth, u)} past the finished wall of block {routine.block} "
                f"at {_at(x, y, u)}",
                x,
                y,
            )
        )
    # The depth it must cut to (a thread's full form, above the Z DN it may cut to).
    floor = max(routine.depth, grid.stock.bottom)
    left = h - floor
    must = (tool_side > tol) & (True if routine.pocket else tool_side <= r)
    rest = must & (left > tol)
    level = (
        "Z DN"
        if routine.allowed is None
        else f"Z {format_length(routine.depth, u)}, where its full form must reach all round "
        f"(Z DN {format_length(routine.allowed, u)}),"
    )
    for _, thick, x, y, cells in _worst(rest, left, qx, qy, None):
        where = "in the pocket" if routine.pocket else "beside the wall"
        area = cells * grid.resolution**2
        findings.append(
            Finding(
                routine.block,
                "rest material",
                f"{_len(thick, u)} of material left above {level} {where} at {_at(x, y, u)} "
                f"({area / u.nm**2:.4f} {u.symbol}² of it)",
                x,
                y,
            )
        )
    return findings


def _waste_gouges(
    grid: Grid,
    heights: F64,
    owners: Owners,
    intent: Intent,
    unclaimed: BOOL,
    crashed: set[int],
    u: Units,
) -> list[Finding]:
    """Material removed below what any block means to cut, beside no finished surface:
    per block that cut it (a rapid's is its crash finding)."""
    if not unclaimed.any():
        return []
    below = intent.floor - heights
    qx, qy = centres(grid)
    findings = []
    for culprit, depth, x, y, cells in _worst(unclaimed, below, qx, qy, owners[:, :]):
        if culprit in crashed:
            continue
        area = cells * grid.resolution**2
        findings.append(
            Finding(
                culprit,
                "gouge",
                f"removes material no block means to remove: {_len(depth, u)} below the part "
                f"as programmed at {_at(x, y, u)} ({area / u.nm**2:.4f} {u.symbol}² of it)",
                x,
                y,
            )
        )
    return findings


# -- irregular pockets ---------------------------------------------------------------------


def _pocket_findings(
    grid: Grid, heights: F64, pocket: PocketArea, tol: int, u: Units
) -> list[Finding]:
    """Material left above Z DN where the tool's centre fits: inside the wall, outside every
    island, at least a tool radius from all of them (nearer a wall, material left is a
    corner's fillet, which every round tool leaves, or a gouge's opposite, found by the
    walls' own check)."""
    if pocket.depth is None or pocket.tool_radius <= 0:
        return []
    r = float(pocket.tool_radius)
    chord = grid.resolution / 4  # the outlines as polygons, well within a cell
    outlines = [path_points(Path(c.start, c.elements), chord) for c in pocket.contours]
    xs = [p[0] for p in outlines[0]]
    ys = [p[1] for p in outlines[0]]
    rows, cols, qx, qy = window(grid, min(xs), min(ys), max(xs), max(ys))
    if qx.size == 0:
        return []
    inside = fill(grid, [outlines[0]])[rows, cols]
    for island in outlines[1:]:
        inside &= ~fill(grid, [island])[rows, cols]
    nearest = distance_to(pocket.contours, qx, qy)
    left = heights[rows, cols] - max(pocket.depth, grid.stock.bottom)
    rest = inside & (nearest >= r + tol) & (left > tol)
    findings = []
    for _, thick, x, y, cells in _worst(rest, left, qx, qy, None):
        area = cells * grid.resolution**2
        findings.append(
            Finding(
                pocket.block,
                "rest material",
                f"{_len(thick, u)} of material left above Z DN in the pocket at "
                f"{_at(x, y, u)} ({area / u.nm**2:.4f} {u.symbol}² of it)",
                x,
                y,
            )
        )
    return findings


# -- holes and crashes ---------------------------------------------------------------------


def _hole_findings(
    grid: Grid,
    heights: F64,
    owners: Owners,
    geometry: Programmed,
    tol: int,
    u: Units,
) -> list[Finding]:
    from app.cnc.blocks import HoleOp
    from app.cnc.simulate.segments import DRILL_SLOPE

    findings = []
    # Spot drill, drill, tap: holes at one place go as deep as the deepest of them.
    deepest: dict[tuple[int, int], int] = {}
    for hole in geometry.holes:
        deepest[hole.x, hole.y] = min(hole.depth, deepest.get((hole.x, hole.y), hole.depth))
    for hole in geometry.holes:
        sizes.spend()
        cell = grid.cell_of(hole.x, hole.y)
        if cell is None:
            continue
        i, j = cell
        cx = grid.x0 + (j + 0.5) * grid.resolution
        cy = grid.y0 + (i + 0.5) * grid.resolution
        slack = DRILL_SLOPE * math.hypot(cx - hole.x, cy - hole.y) if hole.op is HoleOp.DRILL else 0
        bottom = float(heights[i, j])
        expected = max(hole.depth, grid.stock.bottom)
        at = _at(hole.x, hole.y, u)
        if bottom > expected + tol + slack:
            findings.append(
                Finding(
                    hole.block,
                    "hole depth",
                    f"the {hole.name} hole at {at} is {_len(bottom - expected, u)} shallower "
                    f"than Z DN {format_length(hole.depth, u)}",
                    hole.x,
                    hole.y,
                )
            )
        elif bottom < deepest[hole.x, hole.y] - tol and bottom > grid.stock.bottom:
            culprit = int(owners[i, j])
            by = f" (cut by block {culprit})" if culprit and culprit != hole.block else ""
            findings.append(
                Finding(
                    culprit or hole.block,
                    "hole depth",
                    f"the {hole.name} hole of block {hole.block} at {at} is "
                    f"{_len(deepest[hole.x, hole.y] - bottom, u)} deeper than Z DN "
                    f"{format_length(deepest[hole.x, hole.y], u)}{by}",
                    hole.x,
                    hole.y,
                )
            )
    return findings


def _crash_findings(sim: Simulation, u: Units) -> list[Finding]:
    worst: dict[int, tuple[int, float, float, float]] = {}
    for crash in sim.crashes:
        count, depth, x, y = worst.get(crash.block, (0, -1.0, 0.0, 0.0))
        if crash.depth > depth:
            depth, x, y = crash.depth, crash.x, crash.y
        worst[crash.block] = (count + 1, depth, x, y)
    findings = []
    for block, (count, depth, x, y) in sorted(worst.items()):
        more = f" ({count} rapid moves of this block hit material)" if count > 1 else ""
        findings.append(
            Finding(
                block,
                "crash",
                f"a rapid move goes {_len(depth, u)} into the material at {_at(x, y, u)}{more}",
                x,
                y,
            )
        )
    return findings
