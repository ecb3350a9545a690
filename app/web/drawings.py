"""From a drawing to blocks (issue 22): upload a DXF, choose contours and holes, see the
blocks they make, add them to a program.

The drawing is kept in the library by its content (`Library.put_drawing`) while it is chosen
from. The page is a form: each contour and hole has an order number (blank: not chosen),
each contour its start segment, direction, compensation side, INSIDE/OUTSIDE and tool; the
direction, side and INSIDE/OUTSIDE it offers are the rule `millblocks import` follows
(`cut_sides`: outer contours from outside, inner ones from inside, climb unless the page's
milling option says conventional), and the machinist may change them. The depths, feeds and
the tool (number, diameter, RPM) are asked for, with defaults shown in their fields
(`cutting_defaults`), and checked by `read_cutting`.
Clicking the drawing fills those fields (static/drawings.js); without JavaScript they are
typed. Every request re-reads the drawing with the page's options, so the page is the
whole state and any worker can answer it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any
from urllib.parse import urlencode

from flask import Blueprint, abort, redirect, render_template, request, url_for
from jinja2_fragments.flask import render_block
from werkzeug.wrappers import Response

from app.cnc.blocks import MillingMode
from app.cnc.formats.dxf import is_dxf
from app.cnc.formats.dxf.blocks import cut_sides
from app.cnc.formats.dxf.choice import (
    CUTTING_FIELDS,
    DIRECTIONS,
    Choice,
    ChoiceError,
    Chosen,
    ContourChoice,
    HoleChoice,
    PlacementError,
    PocketChoice,
    chosen_blocks,
    contour_comp,
    cutting_defaults,
    drawing_svg,
    insert_blocks,
    pocket_islands,
    read_cutting,
)
from app.cnc.formats.dxf.reader import Drawing, parse_options, read_drawing
from app.cnc.formats.svg import draw
from app.cnc.numbers import NumberError, parse_int
from app.cnc.problems import Severity
from app.cnc.recognition.common import ImportFailure
from app.cnc.sizes import TooLarge, check_import_size
from app.cnc.units import Units
from app.cnc.validate import validate
from app.storage.library import (
    DRAWING_BYTES_IN_ALL,
    DRAWING_KEEP,
    DRAWINGS_PER_USER,
    DrawingsFull,
    LibraryError,
    NotFound,
    StaleSave,
)
from app.web.editor import current_user
from app.web.editor_page import block_summary, is_htmx
from app.web.extensions import get_library, upload_limits

bp = Blueprint("drawings", __name__)

# The reader options the page carries in its address (names as the CLI's --option takes them).
# FEEDR XY is not one of them here: the page asks for it with the depths (CUTTING_FIELDS).
OPTION_FIELDS = ("units", "drawing-units", "layer", "hole-diameter", "tolerance")
# Climb or conventional milling: the page's option, carried in its address like the units.
MILLING = "milling"


@bp.app_context_processor
def quota() -> dict[str, str]:
    """What happens at the limits on drawings, as the upload form says it."""
    hours = int(DRAWING_KEEP.total_seconds() // 3600)
    return {
        "drawing_quota": (
            f"A drawing is kept {hours} hours for choosing from. You keep your last "
            f"{DRAWINGS_PER_USER}: opening another forgets your oldest. The server keeps "
            f"{DRAWING_BYTES_IN_ALL // (1024 * 1024)} MB of drawings in all; past that a "
            "drawing is refused until the oldest one's time is over."
        )
    }


@bp.post("/drawings")
def upload() -> Response | tuple[str, int]:
    """Keep an uploaded DXF and open the choosing page; a file that cannot be read is
    refused on the library page, naming why."""
    file = request.files.get("file")
    if file is None or not file.filename:
        return _refused("Not opened: choose a DXF drawing to open.")
    data = file.read()
    options = _options(request.form)
    try:
        check_import_size(data, upload_limits())
        if not is_dxf(data):
            raise ImportFailure("", "not a DXF drawing (a DXF starts with a SECTION group)")
        read_drawing(data, file.filename, parse_options(options))
    except (ImportFailure, TooLarge, ValueError) as exc:
        return _refused(f"Not opened: {file.filename}: {exc}")
    stem = file.filename.rsplit("/", 1)[-1].rsplit(".", 1)[0]
    try:
        key = get_library().put_drawing(stem, data, author=current_user())
    except DrawingsFull as exc:
        return _refused(f"Not opened: {file.filename}: {exc}")
    query = urlencode({k: v for k, v in options.items() if v})
    return redirect(url_for("drawings.choose", key=key) + (f"?{query}" if query else ""))


@bp.get("/drawings/<key>")
def choose(key: str) -> tuple[str, int]:
    """The choosing page, with nothing chosen yet."""
    drawing, options = _drawing(key, request.args)
    return _page(key, drawing, options, {}, None, "", 200)


@bp.post("/drawings/<key>/preview")
def preview(key: str) -> tuple[str, int]:
    """The blocks the choices make, their tool path and the report."""
    drawing, options = _drawing(key, request.form)
    try:
        chosen = _chosen(drawing, request.form)
    except ChoiceError as exc:
        return _page(key, drawing, options, request.form, None, str(exc), 422)
    return _page(key, drawing, options, request.form, chosen, "", 200)


@bp.post("/drawings/<key>/add")
def add(key: str) -> Response | tuple[str, int]:
    """Add the chosen blocks to a new program, or into a program after one of its blocks.
    Refused (nothing saved) when nothing is chosen, the place splits a sequence, or the
    program changed since the page was opened."""
    form = request.form
    library = get_library()
    target = form.get("target", "new")
    units_option = _options(form)
    try:
        if target == "new":
            drawing, options = _drawing(key, form)
            chosen = _chosen(drawing, form)
            if not chosen.blocks:
                raise ChoiceError("nothing is chosen: click contours or holes first")
            name = form.get("name", "").strip() or drawing.name
            info = library.create(
                chosen.program(name, drawing.units),
                author=current_user(),
                summary_text=f"made from the drawing {drawing.name}",
            )
            return redirect(url_for("editor.edit", program_id=info.id, edit=1))
        program_id = _whole(form.get("program", ""), "program")
        after = _whole(form.get("after", "0") or "0", "after block")
        stored = library.get(program_id)
        # The blocks are made in the program's units, whatever the drawing's are; the depths
        # and feeds typed on the page are in the page's units, so those must be the same.
        page_drawing, _ = _drawing(key, form)
        if stored.program.units is not page_drawing.units:
            raise PlacementError(
                f"the program is in {stored.program.units.symbol} and the depths and feeds "
                f"on this page in {page_drawing.units.symbol}: choose Program units "
                f"{stored.program.units.symbol}, Read again, and enter them in "
                f"{stored.program.units.symbol}"
            )
        units_option["units"] = "metric" if stored.program.units is Units.MM else "inch"
        drawing, options = _drawing(key, units_option)
        chosen = _chosen(drawing, form)
        if not chosen.blocks:
            raise ChoiceError("nothing is chosen: click contours or holes first")
        program, _added_tools = insert_blocks(stored.program, chosen, after)
        based_on = _whole(form.get("version", "") or str(stored.info.version), "version")
        library.save(program_id, program, based_on=based_on, author=current_user())
        return redirect(url_for("editor.edit", program_id=program_id, edit=after + 1))
    except (ChoiceError, PlacementError, StaleSave, NotFound) as exc:
        drawing, options = _drawing(key, form)
        return _page(key, drawing, options, form, None, f"Not added: {exc}", 422)
    except LibraryError as exc:
        drawing, options = _drawing(key, form)
        return _page(key, drawing, options, form, None, f"Not added: {exc}", 422)


# -- reading the page's fields -------------------------------------------------------------


@dataclass(frozen=True)
class _Item:
    order: int
    what: str  # "contour" or "hole"
    index: int


def milling(source: Any) -> MillingMode:
    """The page's milling option (climb unless it says conventional)."""
    value = source.get(MILLING, "") or ""
    return MillingMode.CONVENTIONAL if value == "conventional" else MillingMode.CLIMB


def _chosen(drawing: Drawing, form: Any) -> Chosen:
    """The blocks of the form's choices, with its depths, feeds and tool."""
    if form.get(MILLING, "") not in ("", "climb", "conventional"):
        raise ChoiceError(f"milling {form.get(MILLING)!r}: allowed climb, conventional")
    cutting, tool = read_cutting(drawing.units, form)
    choices = read_choices(form, drawing, tool)
    return chosen_blocks(drawing, choices, cutting, milling(form))


def read_choices(form: Any, drawing: Drawing, tool: int = 1) -> list[Choice]:
    """The choices the form holds, in their order; consecutive holes are one group. A
    contour's direction, tool side or routine placement left blank is the rule's
    (`cut_sides`); its tool left blank is `tool` (the page's tool).

    Raises ChoiceError naming the field for an order that is not a whole number from 1,
    an order given twice, a segment that is not in its contour, or a tool outside 1-24."""
    items: list[_Item] = []
    kinds = {k: form.get(f"c{k}_pocket") for k in range(len(drawing.contours))}
    islands = [k for k, kind in kinds.items() if kind == "island"]
    pockets = [k for k, kind in kinds.items() if kind == "pocket"]
    for what, count in (("contour", len(drawing.contours)), ("hole", len(drawing.holes))):
        for index in range(count):
            text = form.get(f"{what[0]}{index}_order", "").strip()
            if what == "contour" and kinds[index] == "island":
                if text:
                    raise ChoiceError(
                        f"contour {index + 1} is an island: it has no order of its own (its "
                        "pocket's order places it); clear its order or its Pocket choice"
                    )
                continue
            if not text:
                if what == "contour" and kinds[index] == "pocket":
                    raise ChoiceError(
                        f"contour {index + 1} is a POCKET: give it an order number (or click "
                        "it on the drawing)"
                    )
                continue
            order = _whole(text, f"{what} {index + 1} order")
            if order < 1:
                raise ChoiceError(f"{what} {index + 1} order: {order}; allowed 1 and up")
            items.append(_Item(order, what, index))
    seen: dict[int, _Item] = {}
    for item in items:
        if item.order in seen:
            other = seen[item.order]
            raise ChoiceError(
                f"order {item.order} is given twice ({other.what} {other.index + 1} and "
                f"{item.what} {item.index + 1}); give each a number of its own"
            )
        seen[item.order] = item
    items.sort(key=lambda i: i.order)
    held = pocket_islands(drawing, pockets, islands)
    hole_tool = _tool(form.get("holes_tool", "1"), "holes tool")
    bolt = bool(form.get("bolt_circles"))
    choices: list[Choice] = []
    group: list[int] = []
    for item in items:
        if item.what == "hole":
            group.append(item.index)
            continue
        if group:
            choices.append(HoleChoice(tuple(group), hole_tool, bolt))
            group = []
        k = item.index
        start = _whole(form.get(f"c{k}_start", "1") or "1", f"contour {k + 1} start") - 1
        if kinds[k] == "pocket":
            pocket_tool = _tool(form.get(f"c{k}_tool", ""), f"contour {k + 1} tool", tool)
            choices.append(PocketChoice(k, held[k], start, pocket_tool))
            continue
        direction = form.get(f"c{k}_dir", "") or None
        if direction is not None and direction not in DIRECTIONS:
            raise ChoiceError(
                f"contour {k + 1} direction {direction!r}: allowed {', '.join(DIRECTIONS)}"
            )
        comp = form.get(f"c{k}_comp", "") or ""
        if comp not in ("", "left", "right", "none"):
            raise ChoiceError(f"contour {k + 1} tool side {comp!r}: allowed left, right, none")
        routine = form.get(f"c{k}_routine", "") or ""
        if routine not in ("", "inside", "outside"):
            raise ChoiceError(f"contour {k + 1} routine {routine!r}: allowed inside, outside")
        choices.append(
            ContourChoice(
                contour=k,
                start=start,
                direction=direction,
                comp=contour_comp(comp),
                inside=None if not routine else routine == "inside",
                tool=_tool(form.get(f"c{k}_tool", ""), f"contour {k + 1} tool", tool),
            )
        )
    if group:
        choices.append(HoleChoice(tuple(group), hole_tool, bolt))
    placed = {j for c in choices if isinstance(c, PocketChoice) for j in c.islands}
    for j in islands:
        if j not in placed:
            raise ChoiceError(
                f"contour {j + 1} is an island, but no contour chosen as a POCKET holds it"
            )
    return choices


def _whole(text: str, label: str) -> int:
    try:
        return parse_int(text)
    except NumberError as exc:
        raise ChoiceError(f"{label}: {exc}") from None


def _tool(text: str, label: str, blank: int = 1) -> int:
    tool = _whole(text or str(blank), label)
    if not 1 <= tool <= 24:
        raise ChoiceError(f"{label}: {tool}; allowed 1 to 24")
    return tool


def _options(source: Any) -> dict[str, str]:
    """The reader options a form or query string carries (empty ones left out)."""
    return {name: source.get(name, "").strip() for name in OPTION_FIELDS if source.get(name)}


def _drawing(key: str, source: Any) -> tuple[Drawing, dict[str, str]]:
    """The stored drawing `key` read with the options `source` carries (404 if gone)."""
    try:
        name, data = get_library().drawing(key)
    except NotFound as exc:
        abort(404, str(exc))
    options = _options(source)
    try:
        return read_drawing(data, name, parse_options(options)), options
    except (ImportFailure, ValueError) as exc:
        abort(422, f"The drawing {name} cannot be read with these options: {exc}")


# -- the page ------------------------------------------------------------------------------


def _page(
    key: str,
    drawing: Drawing,
    options: dict[str, str],
    form: Any,
    chosen: Chosen | None,
    error: str,
    status: int,
) -> tuple[str, int]:
    preview_svg = ""
    problems: list[Any] = []
    if chosen is not None and chosen.blocks:
        program = chosen.program(drawing.name, drawing.units)
        problems = [p for p in validate(program) if p.severity is Severity.ERROR]
        # The tool centre (cutter compensation as the control cuts it) and the band the
        # tool's diameter sweeps: which side of each contour the cutter goes.
        preview_svg = draw(program, swept=True, embedded_style=False)
    mode = milling(form or request.args)
    cutting = cutting_defaults(drawing.units)
    context = {
        "key": key,
        "drawing": drawing,
        "options": options,
        "form": form,
        "svg": drawing_svg(drawing),
        "chosen": chosen,
        "preview_svg": preview_svg,
        "problems": problems,
        "error": error,
        "directions": DIRECTIONS,
        "sides": cut_sides(drawing, mode),
        "milling": mode.value,
        "cutting_fields": CUTTING_FIELDS,
        "cutting": {name: form.get(name, cutting[name]) for name in cutting},
        "programs": get_library().programs("", "name"),
        "units": drawing.units,
        "scale": 1 / drawing.units.nm,
        "block_summary": block_summary,
    }
    if is_htmx() and request.method == "POST" and request.endpoint == "drawings.preview":
        return render_block("drawings/choose.html", "result", **context), status
    return render_template("drawings/choose.html", **context), status


def _refused(message: str) -> tuple[str, int]:
    from app.web.library import _index_with

    return _index_with(message, 422)
