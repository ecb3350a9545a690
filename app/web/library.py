"""The library page: list, search, sort, new program, import by upload, duplicate, trash."""

from __future__ import annotations

from flask import Blueprint, abort, redirect, render_template, request, url_for
from jinja2_fragments.flask import render_block
from werkzeug.wrappers import Response

from app.cnc.blocks import DataBlock0, Program, Tool
from app.cnc.formats.reading import importers
from app.cnc.sizes import check_import_size
from app.cnc.text import TextError
from app.cnc.units import Units
from app.storage.library import SORTS, LibraryError
from app.web.editor import current_user, is_htmx
from app.web.extensions import get_library, upload_limits

bp = Blueprint("library", __name__)


@bp.get("/")
def index() -> str | tuple[str, int]:
    query = request.args.get("q", "")
    sort = request.args.get("sort", "name")
    if sort not in SORTS:
        sort = "name"
    try:
        programs = get_library().programs(query, sort)
    except TextError as exc:
        return _index_with(f"Not searched: {exc}", 422)
    context = {
        "programs": programs,
        "q": query,
        "sort": sort,
        "sorts": SORTS,
        "message": "",
        "form": None,
        "import_formats": importers(),
    }
    if is_htmx() and request.args.get("fragment") == "list":
        return render_block("library/index.html", "program_list", **context)
    return render_template("library/index.html", **context)


@bp.post("/programs")
def create() -> Response | tuple[str, int]:
    name = request.form.get("name", "").strip()
    part = request.form.get("part_number", "").strip()
    units = Units.MM if request.form.get("units") == "mm" else Units.INCH
    if not name:
        return _index_with("Not created: NAME is missing; every program needs a name.", 422)
    if part and not (part.isdigit() and len(part) <= 8):
        return _index_with(f"Not created: PART NO {part!r}: allowed up to 8 digits.", 422)
    retract = "0.1" if units is Units.INCH else "2.5"
    from decimal import Decimal

    block0 = DataBlock0(
        current_tool=1,
        z_retract=Decimal(retract),
        tools=(Tool(number=1, diameter=None, rpm=None, tcal=None),),
    )
    program = Program(name=name, part_number=part, units=units, block0=block0)
    info = get_library().create(program, author=current_user())
    return redirect(url_for("editor.data_block_0", program_id=info.id))


@bp.post("/programs/import")
def upload() -> Response | tuple[str, int]:
    """Import a file in any import format (detected, or the one chosen) and show the import
    report. A file that cannot be read is refused whole, naming the line and column. The
    format's own options come as `opt_<format>_<name>` fields."""
    from app.cnc.formats.reading import detect_format, read_program

    file = request.files.get("file")
    if file is None or not file.filename:
        return _index_with("Not imported: choose a file to import.", 422)
    chosen = request.form.get("format", "")
    formats = importers()
    if chosen and chosen not in formats:
        return _index_with(
            f"Not imported: format {chosen!r} is not one of {', '.join(formats)}", 422
        )
    data = file.read()
    try:
        check_import_size(data, upload_limits())  # before detection reads it
        reading = chosen or detect_format(data)
    except ValueError as exc:
        return _index_with(f"Not imported: {file.filename}: {exc}", 422)
    options = {
        option.name: request.form[key]
        for option in formats[reading].options
        if request.form.get(key := f"opt_{reading}_{option.name}")
    }
    stem = file.filename.rsplit("/", 1)[-1].rsplit(".", 1)[0]
    try:
        result = read_program(data, stem, reading, options, limits=upload_limits())
    except ValueError as exc:
        return _index_with(f"Not imported: {file.filename}: {exc}", 422)
    info = get_library().create(
        result.program,
        author=current_user(),
        summary_text=f"imported from {file.filename} ({result.format})",
    )
    if result.format == "json":
        return redirect(url_for("editor.edit", program_id=info.id))
    notes = sorted(result.report, key=lambda n: -1 if n.line is None else n.line)
    return render_template(
        "library/imported.html", info=info, result=result, notes=notes, filename=file.filename
    ), 201


@bp.post("/programs/<int:program_id>/duplicate")
def duplicate(program_id: int) -> Response:
    try:
        info = get_library().duplicate(program_id, author=current_user())
    except LibraryError as exc:
        abort(404, str(exc))
    return redirect(url_for("editor.edit", program_id=info.id))


@bp.post("/programs/<int:program_id>/mirror")
def mirror(program_id: int) -> Response:
    """A new program: the mirror image in X, Y or both (each cut's direction kept)."""
    from app.cnc.mirror import Axis
    from app.cnc.mirror import mirror as make_mirror

    axis = request.form.get("axis", "x")
    if axis not in ("x", "y", "xy"):
        abort(422, f"axis {axis!r} is not x, y or xy")
    try:
        stored = get_library().get(program_id)
    except LibraryError as exc:
        abort(404, str(exc))
    result = make_mirror(stored.program, Axis(axis))
    info = get_library().create(
        result.program, author=current_user(), summary_text="; ".join(result.notes)
    )
    return redirect(url_for("editor.edit", program_id=info.id))


@bp.post("/programs/<int:program_id>/delete")
def delete(program_id: int) -> Response:
    try:
        get_library().delete(program_id)
    except LibraryError as exc:
        abort(404, str(exc))
    return redirect(url_for("library.index"))


@bp.get("/trash")
def trash() -> str:
    return render_template("library/trash.html", programs=get_library().programs(trash=True))


@bp.post("/programs/<int:program_id>/restore")
def restore(program_id: int) -> Response:
    try:
        get_library().restore(program_id)
    except LibraryError as exc:
        abort(404, str(exc))
    return redirect(url_for("library.trash"))


def _index_with(message: str, status: int) -> tuple[str, int]:
    programs = get_library().programs()
    context = {
        "programs": programs,
        "q": "",
        "sort": "name",
        "sorts": SORTS,
        "message": message,
        "form": request.form,
        "import_formats": importers(),
    }
    return render_template("library/index.html", **context), status
