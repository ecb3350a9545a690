"""DXF import (issue 22): drawings written here with ezdxf, read back into blocks.

Each fixture's blocks are a golden JSON document (tests/imports/dxf/<case>.json) with its
import report (<case>.report); `MILLBLOCKS_REGEN_GOLDEN=1` rewrites them. The round trip is
measured, not restated: the blocks' programmed contours (the interpreter's own
`programmed_contour`, CIRCLE/FRAME sizes, BOLT CIR hole positions) must lie within
0.0001 in of the drawing's geometry, measured with shapely.
"""

from __future__ import annotations

import io
import math
from decimal import Decimal
from pathlib import Path

import pytest
from click.testing import CliRunner
from ezdxf.document import Drawing
from ezdxf.filemanagement import new as new_drawing
from shapely.geometry import LineString

from app.cli import main
from app.cnc import document
from app.cnc.blocks import (
    MILL_CONTOUR_CLASSES,
    BoltCircle,
    Circle,
    Comp,
    Frame,
    Hole,
    Program,
)
from app.cnc.formats.dxf.blocks import as_path, contour_blocks
from app.cnc.formats.dxf.reader import parse_options, read_drawing
from app.cnc.formats.reading import ImportFailure, detect_format, read_program
from app.cnc.geometry import bolt_circle_points
from app.cnc.plane import Element
from app.cnc.plane import Path as MillPath
from app.cnc.problems import Rule, Severity
from app.cnc.sequences import programmed_contour
from app.cnc.units import Units, to_nm
from app.cnc.validate import validate
from tests.golden_support import check_golden

HERE = Path(__file__).parent / "imports" / "dxf"
TOL = 2_540  # 0.0001 in
Pt = tuple[float, float]


# -- fixtures, drawn with ezdxf -----------------------------------------------------------------


def write(doc: Drawing) -> bytes:
    stream = io.StringIO()
    doc.write(stream)
    return stream.getvalue().encode("utf-8")


def bracket() -> bytes:
    """An inch bracket: a profile of lines, rounded corners and a chamfer, four holes, a bore
    with six holes on a bolt circle, a slot, and things MillBlocks leaves out."""
    doc = new_drawing(units=1)
    doc.layers.add("PROFILE")
    doc.layers.add("HOLES")
    doc.layers.add("NOTES")
    msp = doc.modelspace()
    p = {"layer": "PROFILE"}
    msp.add_line((0.5, 0), (5.5, 0), dxfattribs=p)
    msp.add_arc((5.5, 0.5), 0.5, 270, 0, dxfattribs=p)
    msp.add_line((6, 0.5), (6, 3.5), dxfattribs=p)
    msp.add_line((6, 3.5), (5.5, 4), dxfattribs=p)  # a chamfer: no FRAME cuts this
    msp.add_line((5.5, 4), (0.5, 4), dxfattribs=p)
    msp.add_arc((0.5, 3.5), 0.5, 90, 180, dxfattribs=p)
    msp.add_line((0, 3.5), (0, 0.5), dxfattribs=p)
    msp.add_arc((0.5, 0.5), 0.5, 180, 270, dxfattribs=p)
    h = {"layer": "HOLES"}
    for x, y in [(0.5, 0.5), (5.5, 0.5), (5.5, 3.5), (0.5, 3.5)]:
        msp.add_circle((x, y), 0.125, dxfattribs=h)
    msp.add_circle((2, 2), 0.5, dxfattribs=h)  # the bore: larger than a hole
    for k in range(6):
        a = math.radians(90 + 60 * k)
        msp.add_circle((2 + math.cos(a), 2 + math.sin(a)), 0.1, dxfattribs=h)
    # A slot 0.5 in wide from (4, 1.5) to (4, 2.5), its lines drawn one way, arcs another.
    msp.add_line((3.75, 1.5), (3.75, 2.5), dxfattribs=p)
    msp.add_arc((4, 2.5), 0.25, 0, 180, dxfattribs=p)
    msp.add_line((4.25, 2.5), (4.25, 1.5), dxfattribs=p)
    msp.add_arc((4, 1.5), 0.25, 180, 360, dxfattribs=p)
    n = {"layer": "NOTES"}
    msp.add_text("BRACKET 6061", dxfattribs=n)
    msp.add_spline([(0, -1), (1, -1.5), (2, -1)], dxfattribs=n)
    msp.add_line((0, -2, 0), (1, -2, 1), dxfattribs=n)  # a 3D line
    return write(doc)


def bulge_part() -> bytes:
    """An inch part drawn as polylines with bulges: an outline with a half-round end and
    rounded corners, a 2D POLYLINE window with a rounded end, and an open engraving line."""
    doc = new_drawing(units=1)
    msp = doc.modelspace()
    quarter = math.tan(math.radians(90) / 4)
    msp.add_lwpolyline(
        [
            (0, 0.25, quarter),
            (0.25, 0, 0),
            (3, 0, 1),  # a half circle of radius 1 about (3, 1)
            (3, 2, 0),
            (0.25, 2, quarter),
            (0, 1.75, 0),
        ],
        format="xyb",
        close=True,
    )
    msp.add_polyline2d(
        [(0.75, 0.75, 0, 0, 0), (2, 0.75, 0, 0, 1), (2, 1.25, 0, 0, 0), (0.75, 1.25, 0, 0, 0)],
        format="xyseb",
        close=True,
    )
    msp.add_lwpolyline([(0.5, 1.75), (1.5, 1.75), (1.75, 1.5)], format="xy")
    return write(doc)


def metric_plate() -> bytes:
    """A millimetre plate 100 × 60 with 5 mm corner radii (a FRAME exactly), four 6.6 mm
    holes, and a pocket outline whose last line ends 0.001 mm short of its start."""
    doc = new_drawing(units=4)
    msp = doc.modelspace()
    r = 5
    msp.add_line((r, 0), (100 - r, 0))
    msp.add_arc((100 - r, r), r, 270, 0)
    msp.add_line((100, r), (100, 60 - r))
    msp.add_arc((100 - r, 60 - r), r, 0, 90)
    msp.add_line((100 - r, 60), (r, 60))
    msp.add_arc((r, 60 - r), r, 90, 180)
    msp.add_line((0, 60 - r), (0, r))
    msp.add_arc((r, r), r, 180, 270)
    for x, y in [(10, 10), (90, 10), (90, 50), (10, 50)]:
        msp.add_circle((x, y), 3.3)
    msp.add_line((30, 20), (70, 20))
    msp.add_line((70, 20), (62.5, 40))
    msp.add_line((62.5, 40), (37.5, 40))
    msp.add_line((37.5, 40), (30, 20.001))
    return write(doc)


CASES = {
    "bracket": (bracket, {"hole-diameter": "0.25"}),
    "bulge-part": (bulge_part, {}),
    "metric-plate": (metric_plate, {"hole-diameter": "7"}),
}


# -- golden blocks ------------------------------------------------------------------------------


@pytest.mark.parametrize("case", sorted(CASES))
def test_golden_blocks_and_report(case: str) -> None:
    make, options = CASES[case]
    result = read_program(make(), case, None, options)
    assert result.format == "dxf"
    check_golden(HERE / f"{case}.json", document.dumps(result.program))
    check_golden(HERE / f"{case}.report", result.text())
    errors = [p for p in validate(result.program) if p.severity is Severity.ERROR]
    # What validation still asks for is what the report says the user must enter: the
    # tool's diameter and RPM (Data Block 0, TOOL 1 RPM).
    assert {p.rule for p in errors} <= {Rule.TOOL_NO_RPM, Rule.TOOL_NO_DIAMETER}


def test_import_is_deterministic() -> None:
    make, options = CASES["bracket"]
    first = read_program(make(), "b", None, options)
    assert document.dumps(first.program) == document.dumps(
        read_program(make(), "b", None, options).program
    )
    assert first.text() == read_program(make(), "b", None, options).text()


# -- the round trip: blocks back to geometry -----------------------------------------------------


def _points(path: MillPath) -> list[Pt]:
    """Points along a path (arcs every 0.001 rad), independent of the planner's sampling."""
    points = [path.start]
    x, y = path.start
    for e in path.elements:
        if e.centre is not None:
            cx, cy = e.centre
            radius = math.dist((x, y), (cx, cy))
            a0 = math.atan2(y - cy, x - cx)
            a1 = math.atan2(e.end[1] - cy, e.end[0] - cx)
            turn = ((a0 - a1) if e.clockwise else (a1 - a0)) % (2 * math.pi) or 2 * math.pi
            n = max(8, math.ceil(turn / 0.001))
            sign = -1 if e.clockwise else 1
            points += [
                (
                    cx + radius * math.cos(a0 + sign * turn * i / n),
                    cy + radius * math.sin(a0 + sign * turn * i / n),
                )
                for i in range(1, n)
            ]
        points.append(e.end)
        x, y = e.end
    return points


def _circle(centre: Pt, radius: float) -> MillPath:
    start = (centre[0], centre[1] - radius)
    return MillPath(start, (Element(0, start, centre=centre),))


def _frame(corner: Pt, width: float, height: float, rad: float) -> MillPath:
    x0, y0 = corner
    x1, y1 = x0 + width, y0 + height
    pts: list[Element] = [
        Element(0, (x1 - rad, y0)),
        Element(0, (x1, y0 + rad), centre=(x1 - rad, y0 + rad)),
        Element(0, (x1, y1 - rad)),
        Element(0, (x1 - rad, y1), centre=(x1 - rad, y1 - rad)),
        Element(0, (x0 + rad, y1)),
        Element(0, (x0, y1 - rad), centre=(x0 + rad, y1 - rad)),
        Element(0, (x0, y0 + rad)),
        Element(0, (x0 + rad, y0), centre=(x0 + rad, y0 + rad)),
    ]
    return MillPath((x0 + rad, y0), tuple(pts))


def programmed(program: Program) -> tuple[list[MillPath], list[Pt]]:
    """The contours and hole centres the blocks program (nm)."""
    blocks = program.blocks
    contours: list[MillPath] = []
    holes: list[Pt] = []
    i = 0
    while i < len(blocks):
        block = blocks[i]
        assert isinstance(block, Hole)
        u = block.units
        at = (to_nm(block.x, u), to_nm(block.y, u))
        nxt = blocks[i + 1] if i + 1 < len(blocks) else None
        if isinstance(nxt, BoltCircle):
            points = bolt_circle_points(at, to_nm(nxt.radius, nxt.units), nxt.holes, nxt.angle)
            holes += [(float(x), float(y)) for x, y in points]
            i += 2
        elif isinstance(nxt, Circle):
            contours.append(_circle((float(at[0]), float(at[1])), to_nm(nxt.radius, u)))
            i += 2
        elif isinstance(nxt, Frame):
            contours.append(
                _frame(
                    (float(at[0]), float(at[1])),
                    to_nm(nxt.xl, u),
                    to_nm(nxt.yw, u),
                    to_nm(nxt.corner_radius, u),
                )
            )
            i += 2
        elif isinstance(nxt, MILL_CONTOUR_CLASSES):
            j = i + 1
            while j < len(blocks) and isinstance(blocks[j], MILL_CONTOUR_CLASSES):
                j += 1
            path, _, _ = programmed_contour(blocks, tuple(range(i + 1, j)), at)
            contours.append(path)
            i = j
        else:
            holes.append((float(at[0]), float(at[1])))
            i += 1
    return contours, holes


@pytest.mark.parametrize("case", sorted(CASES))
def test_blocks_program_the_drawing_within_a_tenth(case: str) -> None:
    make, options = CASES[case]
    data = make()
    drawing = read_drawing(data, case, parse_options(options))
    program = read_program(data, case, None, options).program
    contours, holes = programmed(program)
    assert len(contours) == len(drawing.contours)
    drawn = [LineString(_points(as_path(c))) for c in drawing.contours]
    for path in contours:
        line = LineString(_points(path))
        assert min(line.hausdorff_distance(d) for d in drawn) <= TOL
    expected = sorted((float(h.centre[0]), float(h.centre[1])) for h in drawing.holes)
    assert len(holes) == len(expected)
    for got, want in zip(sorted(holes), expected, strict=True):
        assert math.dist(got, want) <= TOL


def test_what_became_what_in_the_bracket() -> None:
    make, options = CASES["bracket"]
    result = read_program(make(), "bracket", None, options)
    titles = [b.title for b in result.program.blocks]
    assert titles.count("BOLT CIR DRILL") == 1  # the six holes round the bore
    assert "CIRCLE INSIDE" in titles  # the 1 in bore
    assert titles.count("DRILL CUT LT") == 2  # the slot (inside) and the profile (outside)
    assert titles[-1].startswith("MILL")  # the outside profile is cut last
    report = result.text()
    assert "ignored: entity TEXT 49 (layer NOTES): a TEXT is not read" in report
    for kind in ("TEXT", "SPLINE"):
        assert any(n.message.startswith(f"a {kind} is not read") for n in result.report)
    assert any("a 3D line (its Z changes): left out" in n.message for n in result.report)
    assert all("layer NOTES" in n.where for n in result.report if n.kind.value == "ignored")


def test_direction_and_compensation_of_contours() -> None:
    # Climb with a clockwise spindle: the outside profile clockwise, the slot counter-clockwise,
    # both with the tool on the left (CUT LT).
    make, options = CASES["bracket"]
    program = read_program(make(), "bracket", None, options).program
    contours, _ = programmed(program)
    drills = [b for b in program.blocks if isinstance(b, Hole) and b.comp is not Comp.NONE]
    assert [d.comp for d in drills] == [Comp.LEFT, Comp.LEFT]

    def area(path: MillPath) -> float:
        pts = _points(path)
        return sum(a[0] * b[1] - b[0] * a[1] for a, b in zip(pts, pts[1:] + pts[:1], strict=True))

    mills = [c for c in contours if len(c.elements) > 1]
    assert [area(c) > 0 for c in mills] == [True, False]


def test_chaining_joins_ends_within_the_tolerance_and_reports_it() -> None:
    make, options = CASES["metric-plate"]
    result = read_program(make(), "plate", None, options)
    assert result.program.units is Units.MM
    rounded = [n for n in result.report if n.kind.value == "rounded" and "joined" in n.message]
    assert rounded and "0.001 mm from another is joined to it" in rounded[0].message
    # With a tolerance too tight, the pocket outline stays open and is reported so.
    tight = read_program(make(), "plate", None, {**options, "tolerance": "0.0001"})
    assert any(
        "is open: its ends at X30 mm Y20 mm and X30 mm Y20.001 mm" in n.message
        for n in tight.report
    )
    titles = [b.title for b in result.program.blocks]
    assert "FRAME OUTSIDE" in titles


def test_program_units_follow_the_drawing_or_the_option() -> None:
    make, options = CASES["metric-plate"]
    result = read_program(
        make(), "plate", None, {**options, "units": "inch", "hole-diameter": "0.3"}
    )
    assert result.program.units is Units.INCH
    assert any("the program is in in (the units option)" in n.message for n in result.report)


def test_bad_drawings_are_refused_naming_why() -> None:
    doc = new_drawing(units=0)
    doc.modelspace().add_line((0, 0), (1, 0))
    unitless = write(doc)
    with pytest.raises(ImportFailure) as caught:
        read_program(unitless, "x")
    assert str(caught.value) == (
        "header $INSUNITS: the drawing does not say its units ($INSUNITS 0, unitless); give the "
        "option drawing-units=inch or drawing-units=mm"
    )
    assumed = read_program(unitless, "x", None, {"drawing-units": "mm"})
    assert assumed.program.units is Units.MM
    doc = new_drawing(units=3)  # miles
    with pytest.raises(ImportFailure, match=r"units code 3 is not one MillBlocks reads"):
        read_program(write(doc), "x")
    with pytest.raises(ImportFailure, match=r"dxf import has no option 'colour'"):
        read_program(bracket(), "x", None, {"colour": "red"})
    with pytest.raises(ImportFailure, match=r"option hole-diameter='big': a number from 0 to 1000"):
        read_program(bracket(), "x", None, {"hole-diameter": "big"})
    with pytest.raises(
        ImportFailure, match=r'not a DXF drawing ezdxf can read: Invalid group code "hello"'
    ):
        read_program(b"hello", "x", "dxf")
    huge = bracket().replace(b"\n5.5\n", b"\n1e300\n", 1)
    with pytest.raises(
        ImportFailure, match=r"entity LINE 32 \(layer PROFILE\): the number 1e\+300 is not a usable"
    ):
        read_program(huge, "x", None, {"hole-diameter": "0.25"})


def test_detected_by_its_header_text_or_binary() -> None:
    assert detect_format(bracket()) == "dxf"
    doc = new_drawing(units=1)
    doc.modelspace().add_circle((1, 1), 0.5)
    stream = io.BytesIO()
    doc.write(stream, fmt="bin")
    binary = stream.getvalue()
    assert detect_format(binary) == "dxf"
    result = read_program(binary, "bin", None, {"hole-diameter": "1"})
    assert [b.title for b in result.program.blocks] == ["DRILL"]


def test_cli_import_with_layer_hole_and_tolerance_options(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'lib.db'}")
    path = tmp_path / "bracket.dxf"
    path.write_bytes(bracket())
    runner = CliRunner()
    result = runner.invoke(
        main,
        [
            "import",
            str(path),
            "--layer",
            "HOLES",
            "--hole-diameter",
            "0.25",
            "--tolerance",
            "0.0002",
        ],
    )
    assert result.exit_code == 0, result.stderr
    assert result.stdout.strip().splitlines()[-1].isdigit()
    assert result.stderr.startswith("Import report (dxf):\n")
    assert "entity LINE" in result.stderr and "on a layer not chosen" in result.stderr
    # Any command takes the drawing as a FILE; until the tool has a diameter and a speed,
    # `check` lists those errors (exit 1, not 2: the file itself was read).
    checked = runner.invoke(main, ["check", str(path)])
    assert checked.exit_code == 1
    assert "Data Block 0" in checked.stdout + checked.stderr
    bad = tmp_path / "unitless.dxf"
    doc = new_drawing(units=0)
    bad.write_bytes(write(doc))
    refused = runner.invoke(main, ["import", str(bad)])
    assert refused.exit_code == 2
    assert "give the option drawing-units=inch" in refused.stderr


def test_a_chosen_contour_with_its_start_direction_and_side() -> None:
    make, options = CASES["bulge-part"]
    drawing = read_drawing(make(), "part", parse_options(options))
    outline = next(c for c in drawing.contours if len(c.segments) == 6)
    blocks, report = contour_blocks(drawing, outline, start=2, clockwise=False, comp=Comp.RIGHT)
    first = blocks[0]
    assert isinstance(first, Hole) and first.comp is Comp.RIGHT
    # Segment 2 of the outline starts at (3, 0), the half circle's start; counter-clockwise.
    assert (first.x, first.y) == (Decimal("3.000"), Decimal("0.000"))
    assert blocks[1].title == "MILL ARC CC XY-CENT"
    assert any(n.kind.value == "became" for n in report)
    # Clockwise from the same point: along the bottom first, the half circle last.
    reverse, _ = contour_blocks(drawing, outline, start=2, clockwise=True)
    assert [b.title for b in reverse] == [
        "DRILL CUT LT",
        "MILL STD",
        "MILL QCIR C",
        "MILL STD",
        "MILL QCIR C",
        "MILL STD",
        "MILL ARC C XY-CENT",
        "MILL ARC XY-END",
    ]
    assert isinstance(reverse[0], Hole) and (reverse[0].x, reverse[0].y) == (first.x, first.y)


def test_a_drawing_without_tool_diameters_converts_to_json(tmp_path: Path) -> None:
    """An imported drawing's tools have no diameter yet: G-code refuses it, the JSON
    document takes it (issue 29 point 6), so it can be loaded, fixed and saved."""
    path = tmp_path / "bracket.dxf"
    path.write_bytes(bracket())
    out = tmp_path / "bracket.json"
    runner = CliRunner()
    converted = runner.invoke(main, ["export", str(path), "--to", "json", "-o", str(out)])
    refused = runner.invoke(main, ["export", str(path), "--to", "gcode-linuxcnc"])
    assert refused.exit_code == 1 and "has no DIA in Data Block 0" in refused.stderr
    assert converted.exit_code == 0, converted.stderr
    assert "has no DIA in Data Block 0" in converted.stderr
    program = document.loads(out.read_text())
    assert program == read_program(bracket(), "bracket", None, {}).program


def test_a_line_drawn_twice_is_named_and_cut_once() -> None:
    """A rectangle of four lines with its bottom line drawn a second time (backwards):
    before, the repeat became a cut-twice "open contour" whose two ends were the same
    point; now it is left out, named as a repeat, and the rectangle stays one closed
    contour."""
    doc = new_drawing(units=1)
    msp = doc.modelspace()
    corners = [(0, 0), (4, 0), (4, 3), (0, 3)]
    for a, b in zip(corners, corners[1:] + corners[:1], strict=True):
        msp.add_line(a, b)
    msp.add_line((4, 0), (0, 0))  # the bottom again
    result = read_program(write(doc), "twice", None, None)
    notes = [n.message for n in result.report]
    assert any("repeats LINE" in n and "the same line drawn twice" in n for n in notes), notes
    assert not any("is open" in n for n in notes), notes
    # The rectangle alone: one DRILL and its FRAME, no MILL line for the repeat.
    assert [b.title for b in result.program.blocks] == ["DRILL", "FRAME OUTSIDE"]
