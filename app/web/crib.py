"""The shop's tool crib (`/tools`): the list, a tool's form and history, LinuxCNC tool
tables in and out, and a read-only JSON list.

Programmers and admins edit (every POST needs the edit right, app.web.auth); operators see
the list, the tools and their history, and download the tool table. Every form carries its
CSRF token; a tool's form names the version it was based on, so a save over someone
else's is refused with what they changed.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from flask import Blueprint, Response, abort, jsonify, redirect, render_template, request, url_for

from app.cnc.document import write_fields
from app.cnc.numbers import NumberError, parse_decimal, parse_int
from app.cnc.tools import CribTool, Hand, PitchUnit, ToolMaterial, ToolType
from app.cnc.tooltable import crib_table, program_table, write_table
from app.cnc.units import Units
from app.storage.crib import Crib, StoredTool
from app.storage.library import LibraryError, NotFound, StaleSave
from app.web.extensions import get_library

bp = Blueprint("crib", __name__)

MAX_TABLE_BYTES = 1024 * 1024
"""A tool table upload: LinuxCNC's 1000 tools are some 60 kB."""


def crib() -> Crib:
    return Crib(get_library())


def _author() -> str:
    from app.web.auth import current_user

    return current_user().username


# -- the form ----------------------------------------------------------------------------------

FIELDS: tuple[str, ...] = ("number", "name", "kind", "units", "diameter", "flutes", "material")
FIELDS += ("length", "tcal", "pitch", "pitch_unit", "hand", "notes")
CHOICES: dict[str, Any] = {
    "kind": ToolType,
    "units": Units,
    "material": ToolMaterial,
    "pitch_unit": PitchUnit,
    "hand": Hand,
}
LABELS = {
    "number": "NUMBER",
    "name": "NAME",
    "kind": "TYPE",
    "units": "UNITS",
    "diameter": "DIA",
    "flutes": "FLUTES",
    "material": "TOOL MATERIAL",
    "length": "LENGTH OUT",
    "tcal": "TCAL",
    "pitch": "PITCH",
    "pitch_unit": "PITCH UNIT",
    "hand": "HAND",
    "notes": "NOTES",
}


def form_of(tool: CribTool | None) -> dict[str, str]:
    """A tool's fields as form text (a new tool's defaults for None)."""
    if tool is None:
        return {"units": "inch", "material": "hss", "pitch_unit": "tpi", "hand": "right"}
    return {name: _text(getattr(tool, name)) for name in FIELDS}


def _text(value: Any) -> str:
    if value is None:
        return ""
    if hasattr(value, "value"):
        return str(value.value)
    if not isinstance(value, str | int):
        return f"{value:f}"
    return str(value)


def read_form(form: Mapping[str, str]) -> tuple[CribTool | None, dict[str, str]]:
    """A crib tool from its form, or the errors by field (`DIA: 'x' is not a number; …`).
    Ranges and the rest are the crib's own checks (app.cnc.tools.tool_faults)."""
    errors: dict[str, str] = {}
    values: dict[str, Any] = {}
    for name in ("number", "flutes"):
        raw = form.get(name, "").strip()
        if raw == "":
            if name == "number":
                errors[name] = "NUMBER: missing; the tool's T number (12)"
            values[name] = None
            continue
        try:
            values[name] = parse_int(raw)
        except NumberError as exc:
            errors[name] = f"{LABELS[name]}: {exc}"
    for name in ("diameter", "length", "tcal", "pitch"):
        raw = form.get(name, "").strip()
        if raw == "":
            if name == "diameter":
                errors[name] = "DIA: missing; the tool's cutting diameter"
            values[name] = None
            continue
        try:
            values[name] = parse_decimal(raw, exponent=False)
        except NumberError as exc:
            errors[name] = f"{LABELS[name]}: {exc}"
    for name, cls in CHOICES.items():
        raw = form.get(name, "")
        known = {member.value: member for member in cls}
        if raw not in known:
            allowed = ", ".join(known)
            errors[name] = f"{LABELS[name]}: {raw!r} is not one of {allowed}"
        else:
            values[name] = known[raw]
    values["name"] = form.get("name", "").strip()
    values["notes"] = form.get("notes", "").strip()
    if errors:
        return None, errors
    return CribTool(**values), {}


# -- pages -------------------------------------------------------------------------------------


def _index(message: str = "", form: Mapping[str, str] | None = None, status: int = 200) -> Any:
    query = request.args.get("q", "")
    retired = request.args.get("retired") == "1"
    return (
        render_template(
            "crib/index.html",
            tools=crib().tools(query, retired),
            q=query,
            retired=retired,
            form=form if form is not None else form_of(None),
            choices=CHOICES,
            message=message,
        ),
        status,
    )


@bp.get("/tools")
def index() -> Any:
    """The crib: its tools by number, a search, a new tool's form, the tool table."""
    return _index()


@bp.post("/tools")
def create() -> Any:
    tool, errors = read_form(request.form)
    if tool is None:
        return _index("Not added: " + "; ".join(errors.values()), request.form, 422)
    try:
        stored = crib().create(tool, _author())
    except LibraryError as exc:
        return _index(f"Not added: {exc}", request.form, 422)
    return redirect(url_for("crib.tool", tool_id=stored.id, saved=1))


def _stored(tool_id: int) -> StoredTool:
    try:
        return crib().get(tool_id)
    except NotFound:
        abort(404, f"There is no tool {tool_id} in the crib.")
    except LibraryError as exc:
        abort(422, str(exc))


def _tool_page(
    stored: StoredTool,
    form: Mapping[str, str] | None = None,
    message: str = "",
    status: int = 200,
) -> Any:
    return (
        render_template(
            "crib/tool.html",
            stored=stored,
            form=form if form is not None else form_of(stored.tool),
            choices=CHOICES,
            revisions=list(reversed(crib().revisions(stored.id))),
            message=message,
            saved=request.args.get("saved") == "1",
        ),
        status,
    )


@bp.get("/tools/<int:tool_id>")
def tool(tool_id: int) -> Any:
    return _tool_page(_stored(tool_id))


@bp.post("/tools/<int:tool_id>")
def save(tool_id: int) -> Any:
    stored = _stored(tool_id)
    based_on = _version()
    tool, errors = read_form(request.form)
    if based_on is None:
        errors["version"] = "the form did not say which version it was based on; reload it"
    if tool is None or errors:
        return _tool_page(stored, request.form, "Not saved: " + "; ".join(errors.values()), 422)
    try:
        crib().save(tool_id, tool, based_on or 0, _author())
    except StaleSave as exc:
        return _tool_page(_stored(tool_id), request.form, str(exc), 409)
    except LibraryError as exc:
        return _tool_page(stored, request.form, f"Not saved: {exc}", 422)
    return redirect(url_for("crib.tool", tool_id=tool_id, saved=1))


def _version() -> int | None:
    try:
        value = parse_int(request.form.get("version", ""))
    except NumberError:
        return None
    return value if value >= 1 else None


@bp.post("/tools/<int:tool_id>/retire")
def retire(tool_id: int) -> Any:
    try:
        crib().retire(tool_id)
    except LibraryError as exc:
        abort(404, str(exc))
    return redirect(url_for("crib.index"))


@bp.post("/tools/<int:tool_id>/reinstate")
def reinstate(tool_id: int) -> Any:
    try:
        crib().reinstate(tool_id)
    except NotFound as exc:
        abort(404, str(exc))
    except LibraryError as exc:
        return _tool_page(_stored(tool_id), None, f"Not put back: {exc}", 422)
    return redirect(url_for("crib.tool", tool_id=tool_id))


@bp.post("/tools/<int:tool_id>/history/<int:version>/restore")
def restore_version(tool_id: int, version: int) -> Any:
    based_on = _version()
    stored = _stored(tool_id)
    if based_on is None:
        return _tool_page(stored, None, "Not restored: the form named no version", 422)
    try:
        crib().restore_revision(tool_id, version, based_on, _author())
    except StaleSave as exc:
        return _tool_page(_stored(tool_id), None, str(exc), 409)
    except NotFound as exc:
        abort(404, str(exc))
    except LibraryError as exc:
        return _tool_page(stored, None, f"Not restored: {exc}", 422)
    return redirect(url_for("crib.tool", tool_id=tool_id))


# -- tool tables and the JSON list ------------------------------------------------------------


def _units_arg(raw: str | None) -> Units:
    return Units.MM if raw == "mm" else Units.INCH


@bp.get("/tools/table.tbl")
def table() -> Response:
    """The crib as a LinuxCNC tool table (`?units=mm` for a metric machine)."""
    units = _units_arg(request.args.get("units"))
    text = write_table(crib_table([s.tool for s in crib().tools()], units), units)
    return _download(text, f"crib-{units.value}.tbl")


@bp.post("/tools/table")
def import_table() -> Any:
    """Read an uploaded LinuxCNC tool table into the crib (all or nothing)."""
    upload = request.files.get("file")
    if upload is None or not upload.filename:
        return _index("Not read: choose a tool table file (.tbl)", None, 422)
    data = upload.read(MAX_TABLE_BYTES + 1)
    if len(data) > MAX_TABLE_BYTES:
        return _index("Not read: a tool table is at most 1 MB", None, 422)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        return _index(f"Not read: {upload.filename} is not text (byte {exc.start})", None, 422)
    try:
        done = crib().import_table(text, _units_arg(request.form.get("units")), _author())
    except LibraryError as exc:
        return _index(f"Not read: {upload.filename}: {exc}", None, 422)
    return (
        render_template(
            "crib/imported.html", name=upload.filename, done=done, units=request.form.get("units")
        ),
        200,
    )


@bp.get("/programs/<int:program_id>/tools.tbl")
def program_tool_table(program_id: int) -> Response:
    """A program's Data Block 0 tools as a LinuxCNC tool table, by the numbers its G-code
    calls (D: DIA, Z: TCAL where known), in the program's units."""
    from app.web.editor import load

    program = load(program_id).program
    text = write_table(program_table(program), program.units)
    return _download(text, f"program-{program_id}-tools.tbl")


def _download(text: str, name: str) -> Response:
    response = Response(text, mimetype="text/plain")
    response.headers["Content-Disposition"] = f'attachment; filename="{name}"'
    return response


@bp.get("/tools.json")
def tools_json() -> Response:
    """The tools in use, read-only: `{"tools": [{"id", "version", "number", "name", …}]}`
    (each tool's fields as the library stores them)."""
    query = request.args.get("q", "")
    return jsonify(
        {
            "tools": [
                {"id": s.id, "version": s.version, **write_fields(s.tool)}
                for s in crib().tools(query)
            ]
        }
    )


def for_datalist() -> list[CribTool]:
    """The tools in use, for the pickers of Data Block 0."""
    return [s.tool for s in crib().tools()]
