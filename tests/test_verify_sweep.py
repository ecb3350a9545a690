"""The fast sweep against a plain one, on the golden corpus and the benchmark families.

The simulation skips what cannot cut, rasterises flat tools by runs of cells, cuts a LOOP's
repeated pattern once and stamps it at each placement, and reads the compiled path's
arrays. The reference here does none of that: it takes the moves from `interpret()` (the
Toolpath's objects), splits arcs into pieces of at most 90° (a helical arc into the
simulation's chords, going down in proportion), and evaluates every segment's
tool over every cell of its bounding box in float64, one segment at a time, keeping per cell
the deepest cut and, at equal depths, the earliest segment. The two must agree: the
material removed within one cell per segment, no more cells than segments deeper or
shallower (in practice they agree cell for cell but for a few nanometres of float32 on
drill points), and the same block named wherever the heights agree.
"""

from __future__ import annotations

import itertools
import math
from decimal import Decimal
from pathlib import Path

import numpy as np
import pytest

from app.cnc.blocks import Program
from app.cnc.compiler import compile_program
from app.cnc.interpret import interpret
from app.cnc.problems import has_errors
from app.cnc.simulate.segments import DRILL_SLOPE, HELIX_CHORD, drill_point_blocks
from app.cnc.simulate.stock import Grid
from app.cnc.simulate.verify import run_simulation
from app.cnc.toolpath import ArcFeed, Feed, Rapid, ToolChange
from app.cnc.units import Units, to_nm
from app.cnc.validate import validate
from bench.programs import sized
from tests.test_verify import CASES_DIR, INCH, load

GOLDEN_DIR = Path(__file__).parent / "golden"
CORPUS = sorted(
    p for d in (CASES_DIR, GOLDEN_DIR) for p in d.iterdir() if (p / "program.json").exists()
)


def reference_moves(program: Program) -> list[tuple[float, ...]]:
    """(x0, y0, z0, x1, y1, z1, cx, cy, arc, ccw, radius, slope, block) per segment, from
    the interpreter's Move objects, arcs in equal pieces of at most 90°."""
    toolpath = interpret(program)
    pointed = drill_point_blocks(compile_program(program).path)
    default = to_nm(
        Decimal("0.125") if program.units.value == "inch" else Decimal(3), program.units
    )

    def radius(tool: int) -> float:
        info = toolpath.tools.get(tool)
        diameter = info.diameter if info is not None and info.diameter else default
        return diameter / 2

    x, y, z = (float(c) for c in toolpath.start)
    tool = toolpath.initial_tool
    out: list[tuple[float, ...]] = []
    for move in toolpath.moves:
        if isinstance(move, ToolChange):
            tool, z = move.tool, float(move.z)
            continue
        if not isinstance(move, Rapid | Feed | ArcFeed):
            continue
        slope = DRILL_SLOPE if move.block in pointed else 0.0
        ex, ey, ez = float(move.x), float(move.y), float(move.z)
        if isinstance(move, ArcFeed):
            cx, cy = float(move.cx), float(move.cy)
            a0 = math.atan2(y - cy, x - cx)
            turn = (a0 - math.atan2(ey - cy, ex - cx)) * (1 if move.clockwise else -1)
            turn %= 2 * math.pi
            turn = turn if turn > 1e-12 else 2 * math.pi
            helical = ez != z
            ra = math.hypot(x - cx, y - cy)
            # A helical arc (its Z changes): the simulation's chords, each within HELIX_CHORD
            # of the arc and going down (or up) in proportion, in place of flat arc pieces.
            # The same chords as the sweep's: on a helix, where a cell is first reached (so
            # how deep) moves with the chord, and the two sweeps are compared, not chords.
            piece = math.pi / 2
            if helical:
                piece = min(piece, 2 * math.acos(1 - min(HELIX_CHORD, ra) / max(ra, 1.0)))
            n = max(1, math.ceil(turn / piece - 1e-9))
            step = (-turn if move.clockwise else turn) / n
            points = [(x, y)]
            points += [
                (cx + ra * math.cos(a0 + k * step), cy + ra * math.sin(a0 + k * step))
                for k in range(1, n)
            ]
            points.append((ex, ey))
            for k, ((px, py), (qx, qy)) in enumerate(itertools.pairwise(points)):
                ccw = 0.0 if move.clockwise else 1.0
                if helical:
                    pz, qz = z + (ez - z) * k / n, z + (ez - z) * (k + 1) / n
                    out.append(
                        (
                            px,
                            py,
                            pz,
                            qx,
                            qy,
                            qz,
                            0.0,
                            0.0,
                            0.0,
                            0.0,
                            radius(tool),
                            slope,
                            move.block,
                        )
                    )
                    continue
                out.append(
                    (px, py, ez, qx, qy, ez, cx, cy, 1.0, ccw, radius(tool), slope, move.block)
                )
        else:
            out.append((x, y, z, ex, ey, ez, 0.0, 0.0, 0.0, 0.0, radius(tool), slope, move.block))
        x, y, z = ex, ey, ez
    return out


def lowest_bottom(segment: tuple[float, ...], qx: np.ndarray, qy: np.ndarray) -> np.ndarray:
    """The lowest the tool's bottom gets over each point along the segment (nm; +inf out
    of reach), in float64: the closed forms of app/cnc/simulate/cells.py written plainly."""
    x0, y0, z0, x1, y1, z1, cx, cy, arc, ccw, r, slope, _ = segment
    if arc:
        sign = 1.0 if ccw else -1.0
        vx, vy = qx - cx, qy - cy
        inside = (sign * ((x0 - cx) * vy - (y0 - cy) * vx) >= 0) & (
            sign * (vx * (y1 - cy) - vy * (x1 - cx)) >= 0
        )
        ends = np.minimum(np.hypot(qx - x0, qy - y0), np.hypot(qx - x1, qy - y1))
        d = np.where(inside, np.abs(np.hypot(vx, vy) - math.hypot(x0 - cx, y0 - cy)), ends)
        return np.where(d <= r, z0 + slope * d, np.inf)
    dx, dy, dz = x1 - x0, y1 - y0, z1 - z0
    c = dx * dx + dy * dy
    wx, wy = qx - x0, qy - y0
    if c == 0:  # a plunge: the bottom of the move
        d = np.hypot(wx, wy)
        return np.where(d <= r, min(z0, z1) + slope * d, np.inf)
    tc = (wx * dx + wy * dy) / c
    # Distances as differences of points, not of squares: exact where a cell centre lies
    # on the tool's edge, as it often does when moves are on the grid's lattice.
    e2 = (wx - tc * dx) ** 2 + (wy - tc * dy) ** 2
    t = np.clip(tc, 0.0, 1.0)
    ok = (wx - t * dx) ** 2 + (wy - t * dy) ** 2 <= r * r
    reach = np.sqrt(np.maximum(r * r - e2, 0.0) / c)
    hi = np.minimum(tc + reach, 1.0)
    lo = np.minimum(np.maximum(tc - reach, 0.0), hi)
    candidates = [lo, hi]
    denom = slope * slope * c - dz * dz
    if denom > 0:
        candidates.append(np.clip(tc - dz * np.sqrt(e2) / math.sqrt(c * denom), lo, hi))
    best = np.min([t * dz + slope * np.sqrt(c * (t - tc) ** 2 + e2) for t in candidates], axis=0)
    return np.where(ok, z0 + best, np.inf)


def reference_part(program: Program, grid: Grid) -> tuple[np.ndarray, np.ndarray]:
    """(heights, blocks): the part cut by every segment, one at a time, on `grid`."""
    moves = reference_moves(program)
    xs, ys = grid.centres()
    top = float(grid.stock.top)
    depth = np.full((grid.ny, grid.nx), top)
    owner = np.full((grid.ny, grid.nx), -1, dtype=np.int64)
    res = grid.resolution
    for k, m in enumerate(moves):
        x0, y0, z0, x1, y1, z1, cx, cy, arc, _, r, _, _ = m
        # Above the stock, or a lift (where the tool goes straight up, it has been).
        if min(z0, z1) >= top or ((x0, y0) == (x1, y1) and z1 > z0 and not arc):
            continue
        reach = r + (math.hypot(x0 - cx, y0 - cy) if arc else 0.0)
        lx = min(x0, x1, cx if arc else x0) - reach
        hx = max(x0, x1, cx if arc else x0) + reach
        ly = min(y0, y1, cy if arc else y0) - reach
        hy = max(y0, y1, cy if arc else y0) + reach
        j0, j1 = (
            max(0, math.floor((lx - grid.x0) / res)),
            min(grid.nx, math.ceil((hx - grid.x0) / res) + 1),
        )
        i0, i1 = (
            max(0, math.floor((ly - grid.y0) / res)),
            min(grid.ny, math.ceil((hy - grid.y0) / res) + 1),
        )
        if i0 >= i1 or j0 >= j1:
            continue
        qx, qy = np.meshgrid(xs[j0:j1], ys[i0:i1])
        z = np.rint(lowest_bottom(m, qx, qy))
        here = depth[i0:i1, j0:j1]
        deeper = z < here  # equal depth: the earlier segment keeps the cell
        here[deeper] = z[deeper]
        owner[i0:i1, j0:j1][deeper] = k
    blocks = np.where(owner >= 0, np.array([m[12] for m in moves] + [0])[owner], 0)
    return np.maximum(depth, grid.stock.bottom), blocks


def assert_agrees(program: Program, resolution: int | None = None) -> None:
    sim = run_simulation(program, resolution=resolution)
    heights, blocks = reference_part(program, sim.grid)
    segments = len(reference_moves(program))
    fast = sim.heights()
    cell = sim.grid.resolution**2 * (sim.grid.stock.top - sim.grid.stock.bottom)
    removed = float((sim.grid.stock.top - heights).sum()) * sim.grid.resolution**2
    assert abs(sim.removed_volume() - removed) <= segments * cell
    # Ramps and drill points are evaluated in float32 (a few nm); 0.1 µm is far below
    # anything the report prints.
    assert (np.abs(fast - heights) > 100).sum() <= segments
    same = fast == heights
    assert (sim.owner_blocks()[same] == blocks[same]).all(), "a later block named at equal depth"


@pytest.mark.parametrize("case", CORPUS, ids=[f"{c.parent.name}/{c.name}" for c in CORPUS])
def test_the_sweep_agrees_with_the_plain_one_on_the_golden_corpus(case: Path) -> None:
    program = load(case / "program.json")
    if has_errors(validate(program)):
        pytest.skip("not a valid program")
    assert_agrees(program)


@pytest.mark.parametrize(
    ("family", "moves", "resolution"),
    [
        # Whole cells between LOOP patterns: stamps.
        ("pockets", 4000, "0.02"),
        ("grid", 3000, "0.01"),
        ("bolts", 3000, "0.01"),
        # A fraction of a cell between patterns: stamps per phase, or sweeping each.
        ("pockets", 4000, "0.023"),
        ("bolts", 3000, "0.0123"),
    ],
)
def test_the_sweep_agrees_with_the_plain_one_on_loops(
    family: str, moves: int, resolution: str
) -> None:
    assert_agrees(sized(family, moves), round(Decimal(resolution) * INCH))


def test_a_bolt_circle_is_simulated_as_one_group_and_cuts_as_its_holes_do() -> None:
    """The compiler places a bolt circle's holes as one piece at many offsets, each hole
    entered from the one before: the simulation made a group (and a sweep) per hole, and the
    bench's LOOP of 250-hole bolt circles took 15 s against the 2 s goal. The holes are one
    group now; the part is the one the same holes cut as DRILL blocks of their own."""
    from dataclasses import replace as replaced

    from app.cnc.blocks import BoltCircle, Hole, HoleOp, Stock
    from app.cnc.compiler import compile_program
    from app.cnc.geometry import bolt_circle_points
    from app.cnc.simulate.placements import place

    d = Decimal
    centre = Hole(
        op=HoleOp.DRILL, x=d(2), y=d(2), z_up=d("0.1"), z_dn=d("-0.3"), feed_z=d(5), tool=1
    )
    bolt = BoltCircle(op=HoleOp.DRILL, holes=12, radius=d("1.25"), angle=d(10))
    stock = Stock(x=d(0), y=d(0), z=d(0), xl=d(4), yw=d(4), zh=d(1))
    circle = replaced(sized("bolts", 1), blocks=(centre, bolt), stock=stock)
    assert not has_errors(validate(circle))
    groups = place(circle, compile_program(circle).path).groups
    assert len(groups) <= 3, [len(g.offsets) for g in groups]
    points = bolt_circle_points(
        (to_nm(d(2), Units.INCH), to_nm(d(2), Units.INCH)), to_nm(d("1.25"), Units.INCH), 12, d(10)
    )
    one_by_one = replaced(
        circle,
        blocks=tuple(
            replaced(centre, x=d(x) / d(25_400_000), y=d(y) / d(25_400_000)) for x, y in points
        ),
    )
    resolution = to_nm(d("0.01"), Units.INCH)
    together = run_simulation(circle, resolution).heights()
    apart = run_simulation(one_by_one, resolution).heights()
    assert np.array_equal(together, apart)


def test_the_time_budget_stops_the_simulation_and_its_checks() -> None:
    """The request time budget (sizes.spend) is the last line of defence inside Verify too:
    with it used up, the sweep and the part's checks stop with a clear refusal (a 503 page
    on the server) instead of running on until gunicorn kills the worker. Before issue 30
    neither asked it: the heaviest legal program ran 60 s past a 20 s budget."""
    from app.cnc import sizes
    from app.cnc.simulate.programmed import programmed_geometry
    from app.cnc.simulate.sweep import simulate
    from app.cnc.simulate.verify import Verification, check_part, default_tolerance, prepare

    program = load(GOLDEN_DIR / "loop-rep-grid" / "program.json")
    grid, placed = prepare(program)  # the compile and the placing: outside the budget
    tol = default_tolerance(program.units)
    with sizes.time_budget(0), pytest.raises(sizes.OverBudget, match="more than the 0 s"):
        simulate(grid, placed, None, tol)
    sim = simulate(grid, placed, None, tol)
    geometry = programmed_geometry(program)
    result = Verification(program, sim, tolerance=tol)
    with sizes.time_budget(0), pytest.raises(sizes.OverBudget, match="millblocks command"):
        check_part(result, geometry, tol)
