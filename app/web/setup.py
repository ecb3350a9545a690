"""The printable set-up sheet of a program (for a target and machine, when chosen)."""

from __future__ import annotations

from flask import Blueprint, render_template, request

from app.cnc.formats.svg import draw
from app.cnc.formats.targets import ExportError, OptionError, Remedy, export, get_target, targets
from app.cnc.problems import has_errors
from app.cnc.setup import setup_sheet
from app.cnc.validate import validate
from app.web.editor import load
from app.web.export import _machine_options, options_from, remedy_offers, shown_targets
from app.web.heavy import heavy

bp = Blueprint("setup", __name__)


@bp.get("/programs/<int:program_id>/setup")
@heavy
def sheet(program_id: int) -> tuple[str, int]:
    stored = load(program_id)
    program = stored.program
    if has_errors(validate(program)):
        message = "The program has errors; fix them before printing its set-up sheet."
        return render_template("errors/error.html", title="No set-up sheet", message=message), 422
    machine_name = request.args.get("machine", "")
    machine_target, options, model = _machine_options(machine_name)
    target = request.args.get("target") or machine_target or "tape-eia"
    if target not in targets():
        target = "tape-eia"
    options = options | options_from(request.args, target)
    report = None
    error = ""
    offers: list[tuple[Remedy, str]] = []
    try:
        report = export(program, target, options, model).report
    except OptionError as exc:
        error = str(exc)
    except ExportError as exc:
        error = exc.explained()
        # The need an option takes away is offered as that choice (as on the export page).
        effective = get_target(target).parse_options(options)
        offers = remedy_offers(get_target(target), effective, machine_name, exc.remedies)
    picture = draw(program, embedded_style=False)
    return (
        render_template(
            "setup/sheet.html",
            stored=stored,
            sheet=setup_sheet(program, report, model),
            picture=picture,
            error=error,
            targets=shown_targets() | {target: get_target(target)},
            offers=offers,
            target=target,
            machine_name=machine_name,
        ),
        200,
    )
