"""The export page: target and options, compatibility report, text preview, tape picture,
and downloads. Every export is made by the same registry the CLI uses."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any
from urllib.parse import urlencode

from flask import Blueprint, Response, abort, render_template, request
from jinja2_fragments.flask import render_block

from app.cnc.formats.targets import (
    Export,
    ExportError,
    OptionError,
    Remedy,
    Target,
    export,
    get_target,
    targets,
)
from app.cnc.machine import MachineError, MachineModel, read_machine
from app.cnc.options import Option
from app.storage.library import LibraryError
from app.web.downloads import attachment, file_name
from app.web.editor import is_htmx, load
from app.web.extensions import get_library
from app.web.heavy import heavy

bp = Blueprint("export", __name__)
PREVIEW_LINES = 400
DEFAULT_TARGET = "gcode-linuxcnc"  # what a new export or machine starts on


def shown_targets() -> dict[str, Target]:
    """The targets a shop picks from, by name: all but the canonical-move dump, which is
    for tests and the CLI."""
    return {name: target for name, target in targets().items() if name != "canon"}


def options_from(args: Any, target_name: str) -> dict[str, str]:
    """The target's options present in the request (`opt_<name>`), as text."""
    target = targets().get(target_name)
    if target is None:
        return {}
    raw = {}
    for option in target.options:
        key = f"opt_{option.name}"
        if option.kind.value == "bool":
            raw[option.name] = "yes" if args.get(key) == "on" else "no"
        elif args.get(key, "") != "":
            raw[option.name] = args[key]
    return raw


def _machine_options(name: str) -> tuple[str | None, dict[str, str], MachineModel | None]:
    """A library machine's target, options and (when it has limits) the machine model.
    Limits that cannot be read (stored before a rule existed) are a 422 naming them: the
    program is never exported as if the machine had no limits."""
    if not name:
        return None, {}, None
    try:
        machine = get_library().machine(name)
    except LibraryError:
        return None, {}, None
    try:
        model = read_machine(machine.limits) if machine.limits else None
    except MachineError as exc:
        abort(422, f"machine {name!r}, limits: {exc}; correct them on the machines page")
    return machine.target, dict(machine.options), model


def option_groups(target: Target) -> tuple[list[Option], list[Option]]:
    """A target's options as its form shows them: the common ones (in the order the
    target lists them), then the rest, folded. A target that names none shows all."""
    if not target.common:
        return list(target.options), []
    common = [option for option in target.options if option.name in target.common]
    return common, [option for option in target.options if option.name not in target.common]


def form_values(target: Target, effective: Mapping[str, Any]) -> dict[str, str]:
    """Each option's value as its form field shows it (`effective`: parsed options; an
    option missing there shows its default)."""
    return {
        option.name: str(effective.get(option.name, option.default)) for option in target.options
    }


def preview_text(result: Export) -> str:
    """The first PREVIEW_LINES lines of a text export, and how many more the file has."""
    if result.media_type.split(";")[0] != "text/plain" or get_target(result.target).binary:
        return ""
    data = result.head(PREVIEW_LINES * 200)
    lines = data.decode("ascii", "replace").splitlines()
    if len(data) < result.size and not data.endswith((b"\n", b"\r")):
        lines = lines[:-1]  # cut off inside a line: that line is not shown
    total = sum(chunk.count(b"\n") for chunk in result.chunks())
    total = total or sum(chunk.count(b"\r") for chunk in result.chunks())  # CR-only lines
    text = "\n".join(lines[:PREVIEW_LINES])
    if total > PREVIEW_LINES:
        text += f"\n… {total - PREVIEW_LINES} more lines in the download"
    return text


def page_query(
    target: Target, effective: Mapping[str, Any], machine_name: str, remedy: Remedy | None = None
) -> dict[str, str]:
    """The page's (and the download's) query for these options: every option as the page
    shows it, so the file is the preview; with `remedy`, its option set to its value."""
    query: dict[str, str] = {"target": target.name, "go": "1"}
    if machine_name:
        query["machine"] = machine_name
    for option in target.options:
        value = effective.get(option.name, option.default)
        if option.kind.value == "bool":
            if value:
                query[f"opt_{option.name}"] = "on"
        elif value is not None:
            query[f"opt_{option.name}"] = str(value)
    if remedy is not None:
        query[f"opt_{remedy.option}"] = remedy.value
    return query


def remedy_offers(
    target: Target, effective: Mapping[str, Any], machine_name: str, remedies: Iterable[Remedy]
) -> list[tuple[Remedy, str]]:
    """Each remedy with the query that takes it (the page's options, its option set): what
    the export page and the set-up sheet offer instead of the needs a program lacks."""
    return [
        (remedy, urlencode(page_query(target, effective, machine_name, remedy)))
        for remedy in remedies
    ]


@bp.get("/programs/<int:program_id>/export")
@heavy
def page(program_id: int) -> tuple[str, int]:
    stored = load(program_id)
    machine_name = request.args.get("machine", "")
    machine_target, machine_options, model = _machine_options(machine_name)
    target_name = request.args.get("target") or machine_target or DEFAULT_TARGET
    all_targets = targets()
    if target_name not in all_targets:
        target_name = DEFAULT_TARGET
    raw = machine_options | (
        options_from(request.args, target_name) if "go" in request.args else {}
    )
    result: Export | None = None
    error = ""
    options_wrong = False
    problems: list[str] = []
    remedies: tuple[Remedy, ...] = ()
    missing: list[str] = []
    try:
        result = export(stored.program, target_name, raw, model)
    except OptionError as exc:
        error = str(exc)
        options_wrong = True
    except ExportError as exc:
        error = str(exc)
        problems = exc.errors
        remedies = exc.remedies
        missing = sorted({p.need.value for p in exc.problems if p.need is not None})
    target = all_targets[target_name]
    text_preview = preview_text(result) if result is not None else ""
    picture = ""
    drawn_by = target.picture_target()
    if result is not None and drawn_by == target_name:
        picture = result.data.decode()
    elif result is not None and drawn_by in all_targets:
        try:
            picture = export(stored.program, drawn_by, target.picture_options(raw)).data.decode()
        except (OptionError, ExportError):
            picture = ""
    effective = target.parse_options(raw) if not options_wrong else {}
    all_defaults = target.parse_options({})
    values = form_values(target, effective)
    common, more = option_groups(target)
    # A need the program lacks that an option takes away is offered as that choice, with
    # the problems folded under it, rather than a wall of the same error per tool.
    offers = remedy_offers(target, effective, machine_name, remedies)
    context = {
        "stored": stored,
        "common_options": common,
        "more_options": more,
        "targets": shown_targets() | {target_name: all_targets[target_name]},
        "target": all_targets[target_name],
        "target_name": target_name,
        "values": values,
        "result": result,
        "error": error,
        "problems": problems,
        "text_preview": text_preview,
        "picture": picture,
        "machines": get_library().machines(),
        "machine_name": machine_name,
        "download_query": urlencode(page_query(target, effective, machine_name)),
        "offers": offers,
        "missing": missing,
        "needs": sorted(
            n.value for n in all_targets[target_name].needs_for(effective or all_defaults)
        ),
    }
    status = 422 if error else 200
    if is_htmx():
        return render_block("export/index.html", "result", **context), status
    return render_template("export/index.html", **context), status


@bp.get("/programs/<int:program_id>/export/download")
@heavy
def download(program_id: int) -> Response | tuple[str, int]:
    stored = load(program_id)
    target_name = request.args.get("target", DEFAULT_TARGET)
    _, machine_options, model = _machine_options(request.args.get("machine", ""))
    raw = machine_options | options_from(request.args, target_name)
    try:
        result = export(stored.program, target_name, raw, model)
    except OptionError as exc:
        return render_template("errors/error.html", title="Not exported", message=str(exc)), 422
    except ExportError as exc:
        # Why, not only that: this page has no report beside it (the export page has).
        message = exc.explained()
        return render_template("errors/error.html", title="Not exported", message=message), 422
    filename = file_name(stored.program.name, result.extension, "program")
    # The export was spooled as it was made; it goes out a piece at a time.
    response = Response(result.chunks(), mimetype=result.media_type.split(";")[0])
    response.headers["Content-Length"] = str(result.size)
    response.headers["Content-Disposition"] = attachment(filename)
    response.call_on_close(result.close)
    return response
