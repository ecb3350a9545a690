"""Verify: the stock-removal simulation measured against what the programs ask for.

Golden reports live in tests/verify/<case>/ (program.json + expected.verify; regenerate
with MILLBLOCKS_REGEN_GOLDEN=1 and review the diff). The tests below them pin what a user
relies on: volumes equal to the analytic ones, each deliberate fault found and named by
its block, correct parts reporting nothing.
"""

from __future__ import annotations

import dataclasses
import math
import re
import struct
import zlib
from collections import Counter
from decimal import Decimal
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from app.cli import main
from app.cnc import document
from app.cnc.blocks import (
    Circle,
    DataBlock0,
    Frame,
    Hole,
    HoleOp,
    Placement,
    Program,
    Stock,
    Tool,
)
from app.cnc.copy import resolve_copies
from app.cnc.problems import has_errors
from app.cnc.simulate.image import png_bytes, render
from app.cnc.simulate.mesh import stl_bytes, surface_triangles
from app.cnc.simulate.segments import DRILL_SLOPE
from app.cnc.simulate.stock import StockError
from app.cnc.simulate.verify import run_simulation, verify
from app.cnc.validate import validate
from tests.golden_support import check_golden

CASES_DIR = Path(__file__).parent / "verify"
CASES = sorted(p for p in CASES_DIR.iterdir() if (p / "program.json").exists())
INCH = 25_400_000
IN3 = INCH**3


def load(path: Path) -> Program:
    return resolve_copies(document.loads(path.read_text(encoding="utf-8")))


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_golden_verify_report(case: Path) -> None:
    program = load(case / "program.json")
    assert not has_errors(validate(program)), "verify cases must be valid programs"
    check_golden(case / "expected.verify", verify(program).text())


def findings(case: str) -> list[tuple[int, str]]:
    return [(f.block, f.kind) for f in verify(load(CASES_DIR / case / "program.json")).findings]


@pytest.mark.parametrize(
    "case",
    ["contour-square", "contour-arcs", "frame-pocket", "circle-pocket-2p", "holes", "two-axis"],
)
def test_a_correct_part_reports_nothing(case: str) -> None:
    assert findings(case) == []


def test_a_slot_the_program_cuts_into_a_profile_is_its_intent_not_a_gouge() -> None:
    # Block 8 mills a slot (CUT none) 0.3 in into the part the profile of blocks 1-6
    # finishes: a keyway the program asks for. The intended part is the stock less what
    # every block means to remove, the slot's swath included, so this is no gouge (it
    # was one before verify judged the intended part).
    result = verify(load(CASES_DIR / "slot-into-profile" / "program.json"))
    assert result.findings == []
    grid = result.simulation.grid
    cell = grid.cell_of(round(1.5 * INCH), round(0.2 * INCH))
    assert cell is not None
    assert result.simulation.heights()[cell] == pytest.approx(-0.1 * INCH)


def test_the_compensation_gouge_validation_warns_of_is_found_in_the_part() -> None:
    # validate warns that the compensated path of this closed contour cuts into blocks 2
    # and 5 (it starts on a corner); the simulated part shows both.
    assert findings("contour-start-gouge-mm") == [(1, "gouge"), (5, "gouge")]


def test_sharp_pocket_corners_are_rest_material_of_the_frame_block() -> None:
    result = verify(load(CASES_DIR / "frame-pocket-rest" / "program.json"))
    assert [(f.block, f.kind) for f in result.findings] == [(2, "rest material")]
    # Four corners a 0.5 in tool cannot reach: 4·R²·(1 − π/4) = 0.0537 in².
    assert "(0.05" in result.findings[0].message


def test_a_pocket_over_a_hole_makes_it_deeper_and_names_the_pocket() -> None:
    assert findings("hole-milled-deeper") == [(3, "hole depth")]


def test_rapids_through_a_taller_stock_are_crashes_of_their_blocks() -> None:
    assert findings("crash-tall-stock") == [(1, "crash"), (2, "crash")]


# -- accuracy -----------------------------------------------------------------------------------


def frame_pocket(xl: str, yw: str, corner: str, depth: str) -> Program:
    tools = (Tool(number=1, diameter=Decimal("0.5"), rpm=800, tcal=Decimal(0)),)
    return Program(
        name="frame",
        block0=DataBlock0(current_tool=1, tools=tools),
        blocks=(
            Hole(
                op=HoleOp.DRILL,
                x=Decimal(1),
                y=Decimal(1),
                z_up=Decimal("0.1"),
                z_dn=Decimal(depth),
                feed_z=Decimal(5),
                tool=1,
            ),
            Frame(
                placement=Placement.POCKET,
                xl=Decimal(xl),
                yw=Decimal(yw),
                corner_radius=Decimal(corner),
                feed_xy=Decimal(10),
                tool=1,
            ),
        ),
    )


@pytest.mark.parametrize(
    ("xl", "yw", "corner", "depth"),
    [("3", "2", "0.375", "-0.3"), ("4.5", "1.25", "0.25", "-0.55"), ("2", "2", "0.75", "-0.2")],
)
def test_frame_pocket_volume_is_the_analytic_one_within_1_percent(
    xl: str, yw: str, corner: str, depth: str
) -> None:
    program = frame_pocket(xl, yw, corner, depth)
    sim = run_simulation(program, resolution=round(0.005 * INCH))
    r, w, h, d = float(corner), float(xl), float(yw), -float(depth)
    analytic = (w * h - (4 - math.pi) * r * r) * d
    assert sim.removed_volume() / IN3 == pytest.approx(analytic, rel=0.01)


def test_a_drill_point_hole_has_the_volume_of_a_cylinder_and_a_118_degree_cone() -> None:
    program = frame_pocket("3", "2", "0.375", "-0.3")
    hole = Hole(
        op=HoleOp.DRILL,
        x=Decimal(1),
        y=Decimal(1),
        z_up=Decimal("0.1"),
        z_dn=Decimal("-0.6"),
        feed_z=Decimal(5),
        pecks=3,
        tool=1,
    )
    program = dataclasses.replace(program, blocks=(hole,))
    sim = run_simulation(program, resolution=round(0.002 * INCH))
    r = 0.25
    cone = r * DRILL_SLOPE  # height of the point
    analytic = math.pi * r * r * (0.6 - cone) + math.pi * r * r * cone / 3
    assert sim.removed_volume() / IN3 == pytest.approx(analytic, rel=0.01)


def test_replaying_to_a_block_cuts_only_what_blocks_up_to_it_cut() -> None:
    program = load(CASES_DIR / "hole-milled-deeper" / "program.json")
    after_1 = run_simulation(program, upto=1)
    whole = run_simulation(program)
    assert 0 < after_1.removed_volume() < whole.removed_volume()
    assert set(np.unique(after_1.owner_blocks())) == {0, 1}


def test_the_block_that_cut_a_place_is_the_earliest_to_reach_its_depth() -> None:
    program = frame_pocket("3", "2", "0.375", "-0.3")
    sim = run_simulation(program)
    cell = sim.grid.cell_of(2.5 * INCH, 2 * INCH)  # the middle of the pocket
    assert cell is not None
    assert sim.owner_blocks()[cell] == 2
    outside = sim.grid.cell_of(sim.grid.stock.x0 + 1000, sim.grid.stock.y0 + 1000)
    assert outside is not None and sim.owner_blocks()[outside] == 0


def test_a_tool_without_a_diameter_is_simulated_with_the_stated_default() -> None:
    program = load(CASES_DIR / "holes" / "program.json")
    tools = tuple(dataclasses.replace(t, diameter=None) for t in program.block0.tools)
    program = dataclasses.replace(program, block0=dataclasses.replace(program.block0, tools=tools))
    result = verify(program)
    assert "note: tool 1 has no diameter in Data Block 0: simulated as 0.1250 in" in result.text()
    assert result.simulation.removed_volume() > 0


# -- stock ---------------------------------------------------------------------------------------


def test_the_stock_round_trips_in_the_document_and_is_used() -> None:
    program = load(CASES_DIR / "crash-tall-stock" / "program.json")
    assert program.stock == Stock(
        x=Decimal(0), y=Decimal(0), z=Decimal("0.25"), xl=Decimal(3), yw=Decimal(2), zh=Decimal(1)
    )
    assert document.loads(document.dumps(program)) == program
    assert "the program's stock" in verify(program).text()


def test_a_document_without_a_stock_writes_none() -> None:
    program = load(CASES_DIR / "frame-pocket" / "program.json")
    assert program.stock is None and '"stock"' not in document.dumps(program)


def test_a_stock_of_no_size_is_refused_naming_the_field() -> None:
    program = load(CASES_DIR / "crash-tall-stock" / "program.json")
    assert program.stock is not None
    flat = dataclasses.replace(program, stock=dataclasses.replace(program.stock, zh=Decimal(0)))
    with pytest.raises(StockError, match="stock, ZH: must be more than 0"):
        verify(flat)


@pytest.mark.parametrize(
    ("z", "zh", "message"),
    [
        ("2000", "1", "stock, Z TOP: must be within ±1000 in, got 2000"),
        ("0", "1500", "stock, ZH: the bottom (Z TOP − ZH) must be within ±1000 in, got -1500"),
    ],
)
def test_a_stock_beyond_the_simulation_s_heights_is_refused_naming_the_field(
    z: str, zh: str, message: str
) -> None:
    program = load(CASES_DIR / "crash-tall-stock" / "program.json")
    assert program.stock is not None
    tall = dataclasses.replace(program.stock, z=Decimal(z), zh=Decimal(zh))
    with pytest.raises(StockError, match=re.escape(message)):
        verify(dataclasses.replace(program, stock=tall))


def test_an_unknown_stock_field_is_a_document_error() -> None:
    text = (CASES_DIR / "crash-tall-stock" / "program.json").read_text()
    with pytest.raises(document.DocumentError, match="stock: unknown field 'depth'"):
        document.loads(text.replace('"zh"', '"depth"'))


# -- outputs -------------------------------------------------------------------------------------


def test_the_stl_is_a_closed_solid_with_the_part_s_volume() -> None:
    program = frame_pocket("3", "2", "0.375", "-0.3")
    sim = run_simulation(program, cells=60)
    triangles = surface_triangles(sim.grid, sim.heights())
    edges: Counter[tuple[tuple[float, ...], tuple[float, ...]]] = Counter()
    for tri in triangles:
        points = [tuple(p) for p in tri]
        for i, j in ((0, 1), (1, 2), (2, 0)):
            edges[points[i], points[j]] += 1
    # Closed and consistently oriented: every directed edge once, its reverse once.
    assert all(n == 1 and edges[(q, p)] == 1 for (p, q), n in edges.items())
    # The divergence theorem gives the solid's volume; it must be the material under the
    # triangulated top: each triangle's plan area times its mean height above the bottom.
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    volume = float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum()) / 6
    h = sim.heights() - sim.grid.stock.bottom
    quads = (h[:-1, :-1] + h[:-1, 1:] + h[1:, 1:]) / 3 + (h[:-1, :-1] + h[1:, 1:] + h[1:, :-1]) / 3
    expected = float(quads.sum()) * sim.grid.resolution**2 / 2
    assert volume == pytest.approx(expected, rel=1e-9)
    data = stl_bytes(sim.grid, sim.heights())
    assert data[:80].startswith(b"MillBlocks simulated part")
    assert struct.unpack("<I", data[80:84])[0] == len(triangles)
    assert len(data) == 84 + 50 * len(triangles)
    assert stl_bytes(sim.grid, sim.heights()) == data


def test_the_png_is_a_picture_of_the_grid() -> None:
    sim = run_simulation(frame_pocket("3", "2", "0.375", "-0.3"), cells=100)
    pixels = render(sim.grid, sim.heights(), width=400)
    data = png_bytes(pixels)
    assert data.startswith(b"\x89PNG\r\n\x1a\n")
    width, height = struct.unpack(">II", data[16:24])
    assert (height, width) == pixels.shape[:2]
    idat = data.index(b"IDAT")
    length = struct.unpack(">I", data[idat - 4 : idat])[0]
    raw = zlib.decompress(data[idat + 4 : idat + 4 + length])
    assert len(raw) == height * (1 + 3 * width)
    # The pocket (middle) is darker than the untouched stock (a corner).
    assert pixels[height // 2, width // 2].sum() < pixels[1, 1].sum()
    assert png_bytes(render(sim.grid, sim.heights(), width=400)) == data


# -- the command line ------------------------------------------------------------------------------


def test_cli_verify_prints_the_report_and_exits_1_on_findings(tmp_path: Path) -> None:
    runner = CliRunner()
    good = runner.invoke(main, ["verify", str(CASES_DIR / "frame-pocket" / "program.json")])
    assert good.exit_code == 0, good.output
    assert "removed: 1.76" in good.output and "nothing found" in good.output
    png, stl = tmp_path / "part.png", tmp_path / "part.stl"
    bad = runner.invoke(
        main,
        [
            "verify",
            str(CASES_DIR / "contour-start-gouge-mm" / "program.json"),
            "--png",
            str(png),
            "--stl",
            str(stl),
            "--resolution",
            "0.2",
        ],
    )
    assert bad.exit_code == 1
    assert "block 5: gouge: cuts 5.900 mm into the finished contour of block 2" in bad.output
    assert png.read_bytes().startswith(b"\x89PNG") and stl.stat().st_size > 84


def test_cli_verify_of_a_missing_file_exits_2() -> None:
    result = CliRunner().invoke(main, ["verify", "no-such-program.json"])
    assert result.exit_code == 2
    assert "cannot read" in result.output


def test_cli_verify_refuses_a_bad_stock_with_exit_1(tmp_path: Path) -> None:
    text = (CASES_DIR / "crash-tall-stock" / "program.json").read_text()
    path = tmp_path / "p.json"
    path.write_text(text.replace('"xl": 3', '"xl": -3'))
    result = CliRunner().invoke(main, ["verify", str(path)])
    assert result.exit_code == 1
    assert "stock, XL: must be more than 0, got -3" in result.output


def test_a_circle_pocket_volume_is_pi_r_squared_times_depth() -> None:
    program = frame_pocket("3", "2", "0.375", "-0.3")
    hole = program.blocks[0]
    circle = Circle(placement=Placement.POCKET, radius=Decimal("1.2"), feed_xy=Decimal(9), tool=1)
    program = dataclasses.replace(program, blocks=(hole, circle))
    sim = run_simulation(program, resolution=round(0.004 * INCH))
    assert sim.removed_volume() / IN3 == pytest.approx(math.pi * 1.2**2 * 0.3, rel=0.01)
