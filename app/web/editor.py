"""The program editor: block list, conversational entry, Data Block 0, live preview.

Each entered block is saved at once as a new revision (like ENTER on the control), based on
the version the page was showing; a stale save is refused with what changed meanwhile.
htmx requests get the `editor` fragment of the page back; without JavaScript every form
posts and redirects the same way.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from decimal import Decimal
from typing import Any

from flask import Blueprint, abort, redirect, render_template, request, url_for
from werkzeug.wrappers import Response

from app.cnc.blocks import (
    MAX_TOOLS,
    Block,
    Coolant,
    DataBlock0,
    MillingMode,
    Program,
    Tool,
)
from app.cnc.copy import CopyError, cancel_copy, execute_copy
from app.cnc.crib import copy_of, differences, machine_limits, pick, tool_offer
from app.cnc.cutting import MaterialName, Offer, Workpiece
from app.cnc.kinds import REGISTRY
from app.cnc.numbers import NumberError, parse_int
from app.cnc.problems import Problem, Rule, Severity
from app.cnc.spindle import Spindle
from app.cnc.tools import CribTool, Hand, PitchUnit, ToolMaterial, ToolType, pitch_text
from app.cnc.units import Units
from app.cnc.validate import validate
from app.storage.crib import Crib
from app.storage.library import LibraryError, NotFound, StaleSave, StoredProgram
from app.web.editor_page import (
    Entry,
    page_of,
    render_drawing,
    render_entry,
    render_list,
    render_page,
    render_reply,
)
from app.web.editor_page import is_htmx as is_htmx  # the other pages ask it from here
from app.web.extensions import get_library
from app.web.forms import (
    defaults_for,
    entry_forms,
    field_values,
    group_kinds,
    group_menu,
    kind_of,
    parse_block,
    read_number,
    read_whole,
    refusal,
)

bp = Blueprint("editor", __name__)


def current_user() -> str:
    """The name recorded with each revision."""
    from app.web.auth import current_user as user

    return user().username


def load(program_id: int) -> StoredProgram:
    try:
        return get_library().get(program_id)
    except NotFound:
        abort(404, f"There is no program {program_id} in the library.")
    except LibraryError as exc:
        abort(422, str(exc))


def follower(blocks: tuple[Block, ...] | list[Block], number: int) -> int:
    """1 when block `number` is entered together with the block after it (an ARC XY-CENT
    and its XY-END), else 0."""
    then = REGISTRY.sub_kind_of(blocks[number - 1]).then
    return int(then is not None and number < len(blocks) and isinstance(blocks[number], then))


def entry_from_args(program: Program, args: Any) -> Entry:
    """The entry panel asked for by query arguments (`at`, `edit`, `group`, `kind`...)."""
    count = len(program.blocks)
    if args.get("edit") is not None:
        number = _int(args.get("edit"), 0)
        if not 1 <= number <= count:
            abort(404, f"There is no block {number}.")
        block = program.blocks[number - 1]
        following = program.blocks[number] if number < count else None
        values = field_values(block, following)
        return Entry(
            at=number,
            editing=True,
            kind=kind_of(block),
            loop=block.loop,
            stop=block.stop,
            values=values,
        )
    at = max(1, min(_int(args.get("at"), count + 1), count + 1))
    group = args.get("group", "")
    kind = args.get("kind", "")
    loop = args.get("loop") == "1"
    stop = args.get("stop") == "1"
    entry = Entry(
        at=at, editing=False, loop=loop, stop=stop, page=max(0, _int(args.get("page"), 0))
    )
    if group:
        # A number always means the same choice; one that does not fit here is refused
        # with the reason, and the menu stays.
        choice = next((c for c in group_menu(program, at, loop, stop) if c.key == group), None)
        if choice is None or choice.reason:
            entry.refused = f"{group} {choice.reason}" if choice else f"no such type {group!r}"
        elif group in ("LOOP", "STOP"):
            entry.loop, entry.stop = loop or group == "LOOP", stop or group == "STOP"
        else:
            entry.group = group
            only = group_kinds().get(group, ())
            if len(only) == 1 and not kind:
                kind = only[0]
    forms = entry_forms()
    if kind in forms:
        form = forms[kind]
        reason = refusal(program, at, kind)
        if not reason and loop and not form.loopable:
            reason = REGISTRY.loop_refusal()
        if reason:
            entry.refused = f"{form.title} {reason}"
            entry.group = form.group if len(group_kinds().get(form.group, ())) > 1 else ""
        else:
            entry.group = form.group
            entry.kind = kind
            entry.values = defaults_for(program, at, kind, loop)
    return entry


MISSING_VERSION = (
    "Not saved: the form did not say which version of the program it was based on "
    "(version); reload the page and make the change again."
)


def form_version() -> int | None:
    """The version the submitted form was based on, or None when it is missing or not a
    whole number (such a save is refused: without it no stale save could be noticed)."""
    raw = request.form.get("version", "")
    value, error = read_whole(raw)
    return None if error or value is None or value < 1 else value


def _int(text: str | None, default: int) -> int:
    """A whole number from a query argument or a hidden field, read by the one number
    reader (app.cnc.numbers); `default` when there is none or it is not one."""
    try:
        return parse_int(text or "")
    except NumberError:
        return default


# -- routes ------------------------------------------------------------------------------------


@bp.get("/programs/<int:program_id>")
def edit(program_id: int) -> tuple[str, int]:
    stored = load(program_id)
    entry = entry_from_args(stored.program, request.args)
    if request.args.get("saved") == "db0":
        entry.notice = "Data Block 0 saved."
    return render_page(stored, entry, crib_notes=crib_notes(stored.program))


def crib_notes(program: Program) -> list[str]:
    """`tool 4 (T12 1/4-20 TAP): DIA 0.25 here, 0.251 in the crib` for each tool of Data
    Block 0 whose crib tool now differs (the crib is read only for programs that picked)."""
    linked = [tool for tool in program.block0.tools if tool.crib is not None]
    if not linked:
        return []
    crib = _crib_of(program).by_number
    notes = []
    for tool in linked:
        found = differences(tool, crib.get(tool.crib or 0), program.units)
        if found:
            notes.append(f"tool {tool.number} (T{tool.crib} {tool.name}): " + "; ".join(found))
    return notes


@bp.get("/programs/<int:program_id>/entry")
def entry(program_id: int) -> tuple[str, int]:
    """The entry panel for the choice made (a fragment for htmx, the page otherwise)."""
    stored = load(program_id)
    return render_entry(stored, entry_from_args(stored.program, request.args))


@bp.get("/programs/<int:program_id>/drawing")
def drawing(program_id: int) -> Response | tuple[str, int]:
    """The preview's drawing of the program as stored (an edit's reply asks for it after it
    answers; `v` only keeps browsers from reusing an older drawing)."""
    stored = load(program_id)
    if not is_htmx():
        return redirect(url_for("editor.edit", program_id=program_id))
    return render_drawing(stored)


@bp.get("/programs/<int:program_id>/list")
def block_list(program_id: int) -> Response | tuple[str, int]:
    """Another page of the block list (a fragment for htmx, the page otherwise)."""
    stored = load(program_id)
    page = max(1, _int(request.args.get("page"), 1))
    if not is_htmx():
        return redirect(url_for("editor.edit", program_id=program_id, page=page))
    count = len(stored.program.blocks)
    return render_list(stored, Entry(at=count + 1, editing=False, page=page))


@bp.post("/programs/<int:program_id>/blocks")
def save_block(program_id: int) -> Response | tuple[str, int]:
    stored = load(program_id)
    program = stored.program
    form = request.form
    kind = form.get("kind", "")
    editing = form.get("edit", "") != ""
    at = _int(form.get("edit") if editing else form.get("at"), len(program.blocks) + 1)
    last = len(program.blocks) if editing else len(program.blocks) + 1
    if not 1 <= at <= last:
        abort(404, f"There is no block {at} to {'edit' if editing else 'insert before'}.")
    parsed = parse_block(kind, form)
    entry = Entry(
        at=at,
        editing=editing,
        kind=kind,
        loop=form.get("loop") == "on",
        stop=form.get("stop") == "on",
        values=dict(form),
        errors=parsed.errors,
    )
    if parsed.errors:
        entry.message = "Not saved: " + "; ".join(parsed.errors.values())
        return render_entry(stored, entry, 422)
    blocks = list(program.blocks)
    in_place = False
    if editing:
        # An ARC is entered as its XY-CENT and XY-END blocks: both are replaced (the
        # XY-END is added when it was missing).
        span = 1 + (follower(blocks, at) if len(parsed.blocks) == 2 else 0)
        if len(parsed.blocks) == 2 and span == 1:
            blocks.insert(at, parsed.blocks[1])
        in_place = span == len(parsed.blocks)
        blocks[at - 1 : at - 1 + span] = parsed.blocks
    else:
        blocks[at - 1 : at - 1] = parsed.blocks
    new_program = dataclasses.replace(program, blocks=tuple(blocks))
    action = form.get("action", "")
    if kind == "COPY" and action in ("exec", "cancel"):
        try:
            number = at
            if action == "exec":
                new_program = execute_copy(new_program, number)
            else:
                new_program = cancel_copy(new_program, number)
        except CopyError as exc:
            entry.message = f"Not done: {exc.message}"
            entry.errors = {"from_block": exc.message}
            return render_entry(stored, entry, 422)
    # An EXEC'd COPY puts its copies where it stood: the blocks after it move.
    in_place = in_place and len(new_program.blocks) == len(program.blocks)
    refused = value_problems(new_program, range(at, at + len(parsed.blocks)))
    if refused:
        # As the control refuses an out-of-range entry: nothing is saved, the values stay
        # in the form and each message stands beside its field.
        entry.errors = {name: f"{p.field}: {p.message}" for name, p in refused}
        entry.message = "Not saved: " + "; ".join(f"{p.location}: {p.message}" for _, p in refused)
        return render_entry(stored, entry, 422)
    saved = _save(stored, new_program, entry)
    if isinstance(saved, tuple):
        return saved
    next_at = len(saved.program.blocks) + 1 if editing else at + len(parsed.blocks)
    if kind == "COPY":
        next_at = len(saved.program.blocks) + 1
    next_entry = Entry(at=min(next_at, len(saved.program.blocks) + 1), editing=False)
    # The list stays where the machinist was: at the edited block, or where they insert.
    focus = at if editing else next_entry.at
    if is_htmx():
        return render_reply(program, stored.info.version, saved, next_entry, focus, in_place)
    if editing:
        return redirect(url_for("editor.edit", program_id=program_id, page=page_of(focus)))
    return redirect(url_for("editor.edit", program_id=program_id, at=next_entry.at))


# The problems that are wrong values in the block itself (refused at entry, as the control
# refuses them); the others (a LOOP still waiting for its REP…) belong to the program.
VALUE_RULES = frozenset(
    {
        Rule.RANGE,
        Rule.RESOLUTION,
        Rule.FEED_STEP,
        Rule.MISSING,
        Rule.DEPTH_ORDER,
        Rule.PECKS_NOT_DRILL,
        Rule.MESSAGE,
        Rule.QCIR_CENTRE_LINES,
    }
)


def value_problems(program: Program, numbers: range) -> list[tuple[str, Problem]]:
    """(form field name, problem) for the value errors of blocks `numbers` of `program`."""
    found = []
    for problem in validate(program):
        number = problem.block
        if number is not None and number in numbers and problem.rule in VALUE_RULES:
            if problem.severity is not Severity.ERROR:
                continue
            block = program.blocks[number - 1]
            name = REGISTRY.name_of(type(block), problem.field or "") or "x"
            # The second block of a two-block entry (an ARC's XY-END) has `end_` fields.
            found.append(("end_" + name if number > numbers.start else name, problem))
    return found


def _save(stored: StoredProgram, program: Program, entry: Entry) -> StoredProgram | tuple[str, int]:
    """Save a new version based on the one the form showed; the entry panel with a message
    if someone saved in between (nothing is overwritten)."""
    based_on = form_version()
    if based_on is None:
        entry.message = MISSING_VERSION
        return render_entry(stored, entry, 422)
    library = get_library()
    try:
        library.save(stored.info.id, program, based_on=based_on, author=current_user())
    except StaleSave as exc:
        entry.message = str(exc)
        return render_entry(library.get(stored.info.id), entry, 409)
    except LibraryError as exc:  # e.g. past the block limit
        entry.message = f"Not saved: {exc}"
        return render_entry(stored, entry, 422)
    # Reads no document: the library keeps what it just wrote.
    return library.get(stored.info.id)


@bp.post("/programs/<int:program_id>/blocks/<int:number>/delete")
def delete_block(program_id: int, number: int) -> Response | tuple[str, int]:
    stored = load(program_id)
    blocks = list(stored.program.blocks)
    if not 1 <= number <= len(blocks):
        abort(404, f"There is no block {number}.")
    span = 1 + follower(blocks, number)
    del blocks[number - 1 : number - 1 + span]
    entry = Entry(at=len(blocks) + 1, editing=False)
    saved = _save(stored, dataclasses.replace(stored.program, blocks=tuple(blocks)), entry)
    if isinstance(saved, tuple):
        return saved
    focus = min(number, len(blocks) + 1)
    if is_htmx():
        return render_reply(
            stored.program, stored.info.version, saved, entry, focus, in_place=False
        )
    return redirect(url_for("editor.edit", program_id=program_id, page=page_of(focus)))


@bp.post("/programs/<int:program_id>/blocks/<int:number>/move")
def move_block(program_id: int, number: int) -> Response | tuple[str, int]:
    stored = load(program_id)
    before, version = stored.program, stored.info.version
    blocks = list(before.blocks)
    if not 1 <= number <= len(blocks):
        abort(404, f"There is no block {number}.")
    target = number - 1 if request.form.get("direction") == "up" else number + 1
    entry = Entry(at=len(blocks) + 1, editing=False)
    focus = number
    if 1 <= target <= len(blocks):
        blocks[number - 1], blocks[target - 1] = blocks[target - 1], blocks[number - 1]
        saved = _save(stored, dataclasses.replace(before, blocks=tuple(blocks)), entry)
        if isinstance(saved, tuple):
            return saved
        stored, focus = saved, target
    if is_htmx():
        return render_reply(before, version, stored, entry, focus, in_place=False)
    return redirect(url_for("editor.edit", program_id=program_id, page=page_of(focus)))


@bp.post("/programs/<int:program_id>/header")
def save_header(program_id: int) -> Response | tuple[str, int]:
    """Name, part number, units and notes."""
    stored = load(program_id)
    form = request.form
    units = Units.MM if form.get("units") == "mm" else Units.INCH
    program = dataclasses.replace(
        stored.program,
        name=form.get("name", "").strip(),
        part_number=form.get("part_number", "").strip(),
        units=units,
        notes=form.get("notes", ""),
    )
    if "material" in form:
        material, error = read_material(form)
        if error:
            return render_template(
                "errors/error.html", title="Not saved", message=f"Not saved: {error}"
            ), 422
        program = dataclasses.replace(program, material=material)
    entry = Entry(at=len(program.blocks) + 1, editing=False)
    wrong = [p for p in validate(program) if p.block is None and p.severity is Severity.ERROR]
    if wrong:
        message = "Not saved: " + "; ".join(str(p) for p in wrong)
        return render_template("errors/error.html", title="Not saved", message=message), 422
    saved = _save(stored, program, entry)
    if isinstance(saved, tuple):
        return saved
    return redirect(url_for("editor.edit", program_id=program_id))


# -- Data Block 0 --------------------------------------------------------------------------------


@bp.route("/programs/<int:program_id>/db0", methods=["GET", "POST"])
def data_block_0(program_id: int) -> Response | tuple[str, int]:
    stored = load(program_id)
    errors: dict[str, str] = {}
    message = ""
    block0 = stored.program.block0
    speeds = Speeds.of(request.values.get("machine", ""), stored.program.units)
    if request.method == "POST":
        block0, errors = parse_block0(request.form, stored.program, speeds)
        based_on = form_version()
        if based_on is None:
            errors["version"] = MISSING_VERSION.removeprefix("Not saved: ")
        if not errors:
            candidate = dataclasses.replace(stored.program, block0=block0)
            for problem in validate(candidate):
                if problem.block == 0 and problem.severity is Severity.ERROR:
                    errors[_db0_field(problem.field)] = str(problem)
        if not errors:
            program = dataclasses.replace(stored.program, block0=block0)
            try:
                get_library().save(
                    program_id,
                    program,
                    based_on=based_on or 0,
                    author=current_user(),
                )
                # Like leaving Data Block 0 on the control: back to the data blocks.
                return redirect(url_for("editor.edit", program_id=program_id, saved="db0"))
            except StaleSave as exc:
                message = str(exc)
                stored = get_library().get(program_id)
        else:
            message = "Not saved: " + "; ".join(errors.values())
    problems = [p for p in validate(stored.program) if p.block == 0]
    status = 422 if errors else 409 if message else 200
    shown = block0 if errors else stored.program.block0
    program = dataclasses.replace(stored.program, block0=shown)
    crib = _crib_of(program)
    rows = [
        tool_row(program, n, shown.tool(n), crib, speeds, request.form if errors else None)
        for n in range(1, MAX_TOOLS + 1)
    ]
    return (
        render_template(
            "editor/db0.html",
            stored=stored,
            program_id=program_id,
            block0=shown,
            rows=rows,
            errors=errors,
            message=message,
            problems=problems,
            crib_tools=crib.in_use,
            machines=get_library().machines(),
            machine_name=speeds.machine_name,
            materials=list(MaterialName),
        ),
        status,
    )


@bp.get("/programs/<int:program_id>/db0/tool/<int:number>", endpoint="tool_row")
def tool_row_fragment(program_id: int, number: int) -> Response | tuple[str, int]:
    """One tool of Data Block 0 as the form stands (the row's fields in the query), with
    the crib tool typed or chosen in it picked (a fragment for htmx; the page otherwise)."""
    if not 1 <= number <= MAX_TOOLS:
        abort(404, f"Data Block 0 has tools 1 to {MAX_TOOLS}.")
    stored = load(program_id)
    if not is_htmx():
        return redirect(url_for("editor.data_block_0", program_id=program_id))
    speeds = Speeds.of(request.args.get("machine", ""), stored.program.units)
    errors: dict[str, str] = {}
    crib = _crib_of(stored.program)
    tool = read_tool_row(request.args, number, stored.program, crib, speeds, errors)
    program = stored.program
    row = tool_row(program, number, tool, crib, speeds, request.args if errors else None)
    return (
        render_template(
            "editor/_tool_row.html",
            r=row,
            errors=errors,
            program_id=program_id,
            machine_name=speeds.machine_name,
            picked=True,
        ),
        200,
    )


tool_row_fragment.__name__ = "tool_row"
bp.add_url_rule("/programs/<int:program_id>/db0/tool/<int:number>", "tool_row", tool_row_fragment)


@dataclasses.dataclass(frozen=True)
class Speeds:
    """The machine whose spindle the offered RPM is kept to (none chosen: the control's)."""

    machine_name: str = ""
    spindle: Spindle | None = None
    max_feed: Decimal | None = None

    @classmethod
    def of(cls, name: str, units: Units) -> Speeds:
        from app.web.export import _machine_options

        _, _, model = _machine_options(name)
        spindle, max_feed = machine_limits(model, units)
        return cls(name if model is not None else "", spindle, max_feed)


@dataclasses.dataclass
class CribView:
    """The crib as Data Block 0 reads it: the tools in use (by number) and a lookup."""

    in_use: list[CribTool]

    @property
    def by_number(self) -> dict[int, CribTool]:
        return {tool.number: tool for tool in self.in_use}

    def find(self, text: str) -> CribTool | None:
        """A tool in use by its number (12, T12, #12) or its name (any case)."""
        wanted = text.strip()
        digits = wanted.lstrip("Tt#")
        if digits.isascii() and digits.isdigit() and len(digits) <= 9:
            found = self.by_number.get(int(digits))
            if found is not None:
                return found
        return next((t for t in self.in_use if t.name.lower() == wanted.lower()), None)


def _crib_of(program: Program) -> CribView:
    return CribView([s.tool for s in Crib(get_library()).tools()])


@dataclasses.dataclass
class ToolRow:
    """What a tool's row of Data Block 0 shows: its fields as text, the copy of the crib
    tool it carries, where the crib differs, and the speeds and feeds offered."""

    number: int
    values: dict[str, str]
    copy: str = ""
    lines: list[str] = dataclasses.field(default_factory=list)
    differences: list[str] = dataclasses.field(default_factory=list)
    crib_known: bool = False
    offer: Offer | None = None
    invalid: bool = False


ROW_KEYS: tuple[str, ...] = ("dia", "rpm", "tcal", "coolant", "name", "crib", "crib_was")
ROW_KEYS += ("kind", "flutes", "tmat", "length", "pitch", "punit", "hand")


def _value_text(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, Decimal):
        return f"{value:f}"
    if hasattr(value, "value"):
        return str(value.value)
    return str(value)


def tool_row(
    program: Program,
    number: int,
    tool: Tool | None,
    crib: CribView,
    speeds: Speeds,
    form: Any = None,
) -> ToolRow:
    """Tool `number` as its row shows it (`form`: the values as typed, when refused)."""
    if form is not None:
        values = {key: str(form.get(f"{key}_{number}", "")) for key in ROW_KEYS}
        return ToolRow(number, values, invalid=True)
    if tool is None:
        values = dict.fromkeys(ROW_KEYS, "") | {"coolant": "off"}
        return ToolRow(number, values)
    values = {
        "dia": _value_text(tool.diameter),
        "rpm": _value_text(tool.rpm),
        "tcal": _value_text(tool.tcal),
        "coolant": tool.coolant.value,
        "name": tool.name,
        "crib": _value_text(tool.crib),
        "crib_was": _value_text(tool.crib),
        "kind": _value_text(tool.kind),
        "flutes": _value_text(tool.flutes),
        "tmat": _value_text(tool.tool_material),
        "length": _value_text(tool.length),
        "pitch": _value_text(tool.pitch),
        "punit": tool.pitch_unit.value if tool.pitch is not None else "",
        "hand": tool.hand.value if tool.hand is Hand.LEFT else "",
    }
    row = ToolRow(number, values, copy=copy_text(tool, program.units))
    if tool.crib is not None:
        linked = crib.by_number.get(tool.crib)
        row.crib_known = linked is not None
        row.differences = differences(tool, linked, program.units)
    if program.material is not None:
        row.offer = tool_offer(program, tool, speeds.spindle, speeds.max_feed)
        if row.offer is None and tool.kind is None and (tool.diameter or tool.name):
            row.lines.append("pick it from the crib for its speeds and feeds")
    return row


def copy_text(tool: Tool, units: Units) -> str:
    """The crib's description a program keeps: `T12 · tap · 4 flutes · HSS · 20 TPI`."""
    parts = []
    if tool.crib is not None:
        parts.append(f"T{tool.crib}")
    if tool.kind is not None:
        parts.append(tool.kind.label)
    if tool.flutes is not None:
        parts.append(f"{tool.flutes} flutes")
    if tool.tool_material is not None:
        parts.append(tool.tool_material.label)
    if tool.pitch is not None:
        parts.append(pitch_text(tool.pitch, tool.pitch_unit))
        if tool.hand is Hand.LEFT:
            parts.append("left hand")
    if tool.length is not None:
        parts.append(f"{tool.length:f} {units.symbol} out of the holder")
    return " · ".join(parts)


def _db0_field(label: str | None) -> str:
    """The form input of a Data Block 0 problem's field (`TOOL 3 RPM` → `rpm_3`)."""
    text = label or ""
    if text.startswith("TOOL ") and " " in text[5:]:
        number, what = text[5:].split(" ", 1)
        fields = {"DIA": "dia", "RPM": "rpm", "TCAL": "tcal", "NAME": "name", "CRIB #": "crib"}
        return fields.get(what, "dia") + f"_{number}"
    return {"X": "x_offset", "Y": "y_offset", "CUR-TOOL": "current_tool", "Z RET": "z_retract"}.get(
        text, "x_offset"
    )


def _form_value(
    form: Any,
    errors: dict[str, str],
    name: str,
    label: str,
    reader: Callable[[str], tuple[Any, str]],
    required: bool = False,
) -> Any:
    """Form field `name` read by `reader` (the one number reader's `read_number` or
    `read_whole`); None when empty. A bad value, or an empty `required` one, is put in
    `errors` under `name`, labelled `label`."""
    raw = form.get(name, "").strip()
    if raw == "":
        if required:
            errors[name] = f"{label}: missing; enter a value"
        return None
    value, error = reader(raw)
    if error:
        errors[name] = f"{label}: {error}"
    return value


def read_tool_row(
    form: Any,
    n: int,
    program: Program,
    crib: CribView,
    speeds: Speeds,
    errors: dict[str, str],
    repick: bool = False,
) -> Tool | None:
    """Tool `n` from its row of the form (None: an empty row). A crib number or name in
    its Crib field that is not the one the row was showing (`crib_was_n`), or `repick`,
    picks that crib tool (app.cnc.crib.pick: the crib's DIA, name and description; the
    RPM as typed, else the offered one); else the row's fields are the program's own."""

    def number(name: str, label: str) -> Decimal | None:
        return _form_value(form, errors, name, label, read_number)  # type: ignore[no-any-return]

    def whole(name: str, label: str) -> int | None:
        return _form_value(form, errors, name, label, read_whole)  # type: ignore[no-any-return]

    def choice(name: str, cls: Any, default: Any = None) -> Any:
        raw = form.get(name, "")
        return next((m for m in cls if m.value == raw), default)

    dia = number(f"dia_{n}", f"TOOL {n} DIA")
    rpm = whole(f"rpm_{n}", f"TOOL {n} RPM")
    tcal = number(f"tcal_{n}", f"TOOL {n} TCAL")
    coolant = {"flood": Coolant.FLOOD, "mist": Coolant.MIST}.get(
        form.get(f"coolant_{n}", ""), Coolant.OFF
    )
    # The name as typed (validation says what it may hold, naming the tool).
    name = form.get(f"name_{n}", "").strip()
    typed = form.get(f"crib_{n}", "").strip()
    was = whole(f"crib_was_{n}", f"TOOL {n} CRIB #")
    chosen: CribTool | None = None
    link = None
    if typed:
        chosen = crib.find(typed)
        if chosen is not None:
            link = chosen.number
        elif was is not None and typed.lstrip("Tt#") == str(was):
            link = was  # picked before and retired from the crib since: the copy stays
        else:
            errors[f"crib_{n}"] = (
                f"TOOL {n} CRIB: no tool {typed!r} in the crib; give a tool's number (12 or "
                "T12) or its name, or leave it empty"
            )
    tool = Tool(
        number=n,
        diameter=dia,
        rpm=rpm,
        tcal=tcal,
        coolant=coolant,
        name=name,
        crib=link,
        kind=choice(f"kind_{n}", ToolType),
        flutes=whole(f"flutes_{n}", f"TOOL {n} FLUTES"),
        tool_material=choice(f"tmat_{n}", ToolMaterial),
        length=number(f"length_{n}", f"TOOL {n} LENGTH OUT"),
        pitch=number(f"pitch_{n}", f"TOOL {n} PITCH"),
        pitch_unit=choice(f"punit_{n}", PitchUnit, PitchUnit.TPI),
        hand=choice(f"hand_{n}", Hand, Hand.RIGHT),
    )
    if chosen is not None and (repick or chosen.number != was):
        offered = tool_offer(
            program, copy_of(chosen, n, program.units), speeds.spindle, own_rpm=False
        )
        tool = pick(tool, chosen, n, program.units, offered.rpm if offered else None)
    empty = Tool(number=n)
    return None if dataclasses.replace(tool, coolant=Coolant.OFF) == empty else tool


def parse_block0(
    form: Any, program: Program | None = None, speeds: Speeds | None = None
) -> tuple[DataBlock0, dict[str, str]]:
    """Data Block 0 from its form: offsets, current tool, milling, Z RET, 24 tool lines
    (number, DIA, RPM, TCAL, coolant, name, and the crib tool each was picked from)."""
    errors: dict[str, str] = {}
    program = program or Program(name="")
    crib = (
        _crib_of(program)
        if any(form.get(f"crib_{n}", "").strip() for n in range(1, 25))
        else CribView([])
    )
    repick = _int(form.get("repick"), 0)

    def number(name: str, label: str, required: bool = True) -> Decimal | None:
        return _form_value(  # type: ignore[no-any-return]
            form, errors, name, label, read_number, required
        )

    def whole(name: str, label: str) -> int | None:
        return _form_value(form, errors, name, label, read_whole)  # type: ignore[no-any-return]

    tools = []
    for n in range(1, MAX_TOOLS + 1):
        tool = read_tool_row(form, n, program, crib, speeds or Speeds(), errors, repick == n)
        if tool is not None:
            tools.append(tool)
    block0 = DataBlock0(
        x_offset=number("x_offset", "X") or Decimal(0),
        y_offset=number("y_offset", "Y") or Decimal(0),
        current_tool=whole("current_tool", "CUR-TOOL") or 0,
        milling=MillingMode.CLIMB if form.get("milling") == "climb" else MillingMode.CONVENTIONAL,
        z_retract=number("z_retract", "Z RET") or Decimal(0),
        tools=tuple(tools),
    )
    return block0, errors


def read_material(form: Any) -> tuple[Workpiece | None, str]:
    """The workpiece material from the program form (None: not stated), or what is wrong
    with it (the figures' ranges are validation's)."""
    raw = form.get("material", "")
    if raw == "":
        return None, ""
    name = next((m for m in MaterialName if m.value == raw), None)
    if name is None:
        allowed = ", ".join(m.value for m in MaterialName)
        return None, f"program, MATERIAL: {raw!r} is not one of {allowed}"
    figures: dict[str, Decimal | None] = {"surface_speed": None, "chip_load": None}
    if name is MaterialName.CUSTOM:
        for key, label in (("surface_speed", "SURFACE SPEED"), ("chip_load", "CHIP LOAD")):
            text = form.get(key, "").strip()
            if text:
                value, error = read_number(text)
                if error:
                    return None, f"program, {label}: {error}"
                figures[key] = value
    return Workpiece(name=name, **figures), ""


def problem_text(problems: list[Problem]) -> str:
    return "; ".join(str(p) for p in problems)


# -- history ------------------------------------------------------------------------------


@bp.get("/programs/<int:program_id>/history")
def history(program_id: int) -> str:
    """Every saved version: when, by whom, what changed; diff and restore."""
    stored = load(program_id)
    library = get_library()
    revisions = library.revisions(program_id)
    compare = _int(request.args.get("diff"), 0)
    changes: list[str] = []
    if 2 <= compare <= stored.info.version:
        changes = library.diff(program_id, compare - 1, compare)
    return render_template(
        "editor/history.html",
        stored=stored,
        revisions=list(reversed(revisions)),
        compare=compare,
        changes=changes,
    )


@bp.post("/programs/<int:program_id>/history/<int:version>/restore")
def restore_version(program_id: int, version: int) -> Response | tuple[str, int]:
    load(program_id)
    based_on = form_version()
    if based_on is None:
        return render_template(
            "errors/error.html", title="Not restored", message=MISSING_VERSION
        ), 422
    try:
        get_library().restore_revision(
            program_id,
            version,
            based_on=based_on,
            author=current_user(),
        )
    except StaleSave as exc:
        return render_template("errors/error.html", title="Not restored", message=str(exc)), 409
    except LibraryError as exc:
        abort(404, str(exc))
    return redirect(url_for("editor.history", program_id=program_id))
