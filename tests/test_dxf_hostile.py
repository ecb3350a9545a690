"""Drawings bounded and crash-free (issue 30, point 3).

What one user could do to the shop's server with a drawing, and what must happen instead:

- a binary DXF was not counted by the 20 000-line import limit: it counts two lines a tag,
  as its text form has them, and the drawings page refuses a model space past
  `MAX_DRAWING_ENTITIES` entities (a polyline's vertices each counted), naming the limit;
- chaining compared every end with every other (8 000 lines: the upload killed at 30 s):
  each end is compared only with the ends in its own cell of a grid and the eight round it;
- the choosing page tried every contour against every other, and every island against
  every pocket and every other pocket (300 concentric squares: killed at 30 s): which
  contour is inside which is found once per drawing, each contour tried first against the
  smallest contour round it;
- ezdxf's own exceptions went through (500s, tracebacks): each is the importer's error,
  with a place, and no message holds a lone surrogate.

The work counts below are the deterministic stand-in for time (no timed tests): doubling
the drawing at most doubles them; bench/drawings.py has the seconds.
"""

from __future__ import annotations

import html
import io
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pyclipper
import pytest
from ezdxf.filemanagement import new as new_drawing

from app.cnc.formats.dxf.blocks import cut_sides
from app.cnc.formats.dxf.choice import PocketChoice, chosen_blocks
from app.cnc.formats.dxf.reader import parse_options, read_drawing
from app.cnc.formats.reading import ImportFailure, read_program
from app.cnc.pocketing import regions
from app.cnc.sizes import MAX_DRAWING_ENTITIES, MAX_IMPORT_LINES
from app.web.drawings import read_choices
from app.web.extensions import get_library
from tests.hostile_corpus import DXF_READ, DXF_UPLOADS, minimal_dxf, squares, zigzag
from tests.test_import_dxf import write
from tests.web_support import dispose, local_app


def binary(doc: Any) -> bytes:
    stream = io.BytesIO()
    doc.write(stream, fmt="bin")
    return stream.getvalue()


# -- limits ---------------------------------------------------------------------------------


def test_a_binary_drawing_counts_two_lines_a_tag_as_its_text_does() -> None:
    doc = new_drawing(units=1)
    msp = doc.modelspace()
    for k in range(1_500):
        msp.add_line((k / 100, 0), ((k + 1) / 100, k % 2 / 200))
    for data in (write(doc), binary(doc)):
        with pytest.raises(ImportFailure) as caught:
            read_program(data, "lines", None)
        assert f"an import is at most {MAX_IMPORT_LINES:,} lines" in str(caught.value)
    assert "binary DXF: two lines a tag" in str(caught.value)


def polyline_past_the_limit() -> bytes:
    """One light polyline of MAX_DRAWING_ENTITIES vertices and a line: one entity too many."""
    vertices = "".join(f"10\n{k / 100}\n20\n{k % 2 / 200}\n" for k in range(MAX_DRAWING_ENTITIES))
    polyline = (
        f"0\nLWPOLYLINE\n100\nAcDbEntity\n8\n0\n100\nAcDbPolyline\n90\n{MAX_DRAWING_ENTITIES}\n"
    )
    return minimal_dxf([polyline + "70\n0\n" + vertices, *zigzag(1)], version="AC1015")


TOO_MANY = (
    f"model space: the drawing has {MAX_DRAWING_ENTITIES + 1:,} entities (a polyline's "
    f"vertices count one each); a drawing is read with at most {MAX_DRAWING_ENTITIES:,}"
)


def test_a_drawing_past_the_entity_limit_is_refused_naming_it() -> None:
    """More entities than the limit in model space: refused before any is read, whichever
    way the file says it (lines, or one polyline's vertices)."""
    for data in (minimal_dxf(zigzag(MAX_DRAWING_ENTITIES + 1)), polyline_past_the_limit()):
        with pytest.raises(ImportFailure) as caught:
            read_drawing(data, "many")
        assert str(caught.value) == TOO_MANY
    # At the limit it is read.
    assert len(read_drawing(minimal_dxf(zigzag(MAX_DRAWING_ENTITIES)), "at").contours) == 1


def test_the_choosing_page_refuses_a_stored_drawing_past_the_entity_limit(
    tmp_path: Path,
) -> None:
    """A drawing kept before the limits (or by another way in) is read again by every
    request of the choosing page: refused there too, naming the limit."""
    app = local_app(tmp_path)
    try:
        with app.app_context():
            key = get_library().put_drawing("many", polyline_past_the_limit())
        answer = app.test_client().get(f"/drawings/{key}")
        assert answer.status_code == 422
        assert TOO_MANY in html.unescape(answer.get_data(as_text=True))
    finally:
        dispose(app)


# -- work in proportion to the drawing ------------------------------------------------------


def counted(monkeypatch: pytest.MonkeyPatch, owner: Any, name: str) -> Callable[[], int]:
    """Count the calls of `owner.name` (the real function still answers each)."""
    real = getattr(owner, name)
    calls = [0]

    def counting(*args: Any) -> Any:
        calls[0] += 1
        return real(*args)

    monkeypatch.setattr(owner, name, counting)
    return lambda: calls[0]


def test_chaining_compares_each_end_with_its_neighbours_only(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Each line's end is compared with the ends near it, not with every end before it:
    twice the lines, at most twice the distances taken. (Each line starts 0.00001 in after
    the last one ends, inside the tolerance: ends that are one point need no distance.)"""
    distances = counted(monkeypatch, math, "dist")
    work = []
    for count in (400, 800):
        before = distances()
        drawing = read_drawing(minimal_dxf(zigzag(count, 0.00001)), "zigzag")
        work.append(distances() - before)
        assert len(drawing.contours) == 1 and len(drawing.contours[0].segments) == count
    assert 0 < work[1] <= 2.2 * work[0], work


def test_which_contour_is_inside_which_is_found_without_trying_every_pair(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Concentric squares, every other one a POCKET and the others its islands: the rule's
    sides, the islands of each pocket and the blocks take rings made and points tried in
    proportion to the squares (twice the squares, at most about twice the work), and each
    pocket's island is the square just inside it."""
    rings = counted(monkeypatch, regions, "to_ring")
    tries = counted(monkeypatch, pyclipper, "PointInPolygon")
    work = []
    for count in (20, 40):
        drawing = read_drawing(minimal_dxf(squares(count)), "squares")
        # Contours come out in drawing order: square k is contour k, k = 0 the smallest.
        form = {"tool_dia": "0.01"}
        for k in range(count):
            form[f"c{k}_pocket"] = "pocket" if k % 2 else "island"
            if k % 2:
                form[f"c{k}_order"] = str(k)
        before = rings() + tries()
        sides = cut_sides(drawing)
        choices = read_choices(form, drawing)
        chosen_blocks(drawing, choices)
        work.append(rings() + tries() - before)
        assert [s.inner for s in sides] == [(count - 1 - k) % 2 == 1 for k in range(count)]
        assert choices == [PocketChoice(k, (k - 1,)) for k in range(1, count, 2)]
    assert 0 < work[1] <= 2.5 * work[0], work


# -- ezdxf's exceptions ---------------------------------------------------------------------


def printable(text: str) -> bool:
    return not any(0xD800 <= ord(c) <= 0xDFFF for c in text)


@pytest.mark.parametrize(("name", "data", "part"), DXF_UPLOADS, ids=[n for n, _, _ in DXF_UPLOADS])
def test_a_drawing_ezdxf_cannot_read_is_refused_with_a_place(
    name: str, data: bytes, part: str
) -> None:
    for options in ({}, {"drawing-units": "inch"}):
        with pytest.raises(ImportFailure) as caught:
            read_program(data, name, None, options)
        message = str(caught.value)
        assert part in message and printable(message), message
        with pytest.raises(ImportFailure):
            read_drawing(data, name, parse_options(options))


@pytest.mark.parametrize(("name", "data", "note"), DXF_READ, ids=[n for n, _, _ in DXF_READ])
def test_an_entity_ezdxf_half_understands_is_named_and_left_out(
    name: str, data: bytes, note: str
) -> None:
    result = read_program(data, name, None, {"drawing-units": "inch"})
    assert any(note in str(n) for n in result.report), result.text()
    assert printable(result.text())
