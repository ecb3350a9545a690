"""Transfers: sending programs to controls and receiving them back over RS-232 (issue 8).

The page queues a transfer (a row "queued" in the transfer log); the transfer service
(`millblocks dnc`, app.dnc.daemon), a process of its own, runs it, so restarting the web
server or losing a worker never cuts a send off. The row is what the page shows, so a poll
answered by any worker process sees its progress, and a cancel saved by any worker reaches
it within a second. Only machines configured on the Machines page can be used: the port
comes from the machine, never from the form.
"""

from __future__ import annotations

from flask import Blueprint, abort, redirect, render_template, request, url_for
from jinja2_fragments.flask import render_block
from werkzeug.wrappers import Response

from app.cnc.formats.reading import importers
from app.cnc.formats.targets import targets
from app.cnc.numbers import NumberError, parse_int
from app.cnc.restart import RestartError, restart_from
from app.cnc.text import NAME_LENGTH, check_text
from app.dnc import service
from app.dnc.daemon import service_alive
from app.dnc.settings import SettingsError, port_of
from app.storage.library import LibraryError, Machine, NotFound
from app.storage.transfers import QUEUED, RUNNING, TransferLog
from app.web.auth import current_user
from app.web.downloads import attachment
from app.web.extensions import get_library

bp = Blueprint("transfers", __name__)


def _machines() -> list[Machine]:
    return [m for m in get_library().machines() if m.serial.get("port")]


def _page(message: str = "", status: int = 200) -> tuple[str, int]:
    library = get_library()
    transfers = TransferLog(library).recent()
    return (
        render_template(
            "transfers/index.html",
            machines=_machines(),
            programs=library.programs(),
            transfers=transfers,
            running=any(t.outcome in (QUEUED, RUNNING) for t in transfers),
            service_alive=service_alive(library),
            formats={n: f for n, f in importers().items() if f.from_machines},
            targets=targets(),
            message=message,
            chosen_program=request.values.get("program_id", ""),
        ),
        status,
    )


@bp.get("/transfers")
def index() -> tuple[str, int]:
    return _page()


@bp.get("/transfers/log")
def log_rows() -> str:
    """The log table alone, for the page's poll while a transfer runs."""
    library = get_library()
    transfers = TransferLog(library).recent()
    running = any(t.outcome in (QUEUED, RUNNING) for t in transfers)
    return render_block(
        "transfers/index.html",
        "log",
        transfers=transfers,
        running=running,
        service_alive=service_alive(library),
    )


def _machine(name: str) -> Machine:
    try:
        machine = get_library().machine(name)
    except LibraryError:
        raise _Refused(f"no machine named {name!r}; choose one from the Machines page") from None
    try:
        service.settings_of(machine)
        port_of(machine.serial)
    except SettingsError as exc:
        raise _Refused(f"machine {name}: {exc}") from None
    return machine


def _start_block(text: str) -> int | None:
    """The form's "from block" (empty: the whole program)."""
    text = text.strip()
    if not text:
        return None
    try:
        number = parse_int(text)
    except NumberError as exc:
        raise _Refused(
            f"from block {text!r}: {exc}; give a block number, or leave it empty"
        ) from None
    return number


class _Refused(Exception):
    """A transfer that is not started; the message says why."""


@bp.post("/transfers/send")
def send() -> Response | tuple[str, int]:
    library = get_library()
    try:
        machine = _machine(request.form.get("machine", ""))
        program_id = request.form.get("program_id", "")
        try:
            number = parse_int(program_id)
        except NumberError:
            raise _Refused("choose a program to send") from None
        stored = library.get(number)
        start_block = _start_block(request.form.get("from_block", ""))
        if start_block is not None:
            restart_from(stored.program, start_block)  # refused here, before it is queued
    except (_Refused, NotFound, RestartError) as exc:
        return _page(f"Not sent: {exc}", 422)
    TransferLog(library).begin(
        "send",
        machine.name,
        port_of(machine.serial),
        machine.target,
        current_user().username,
        program_id=stored.info.id,
        program_name=stored.program.name,
        queued=True,
        start_block=start_block,
    )
    return redirect(url_for("transfers.index"), 303)


@bp.post("/transfers/receive")
def receive() -> Response | tuple[str, int]:
    library = get_library()
    form_format = request.form.get("format", "")
    try:
        machine = _machine(request.form.get("machine", ""))
        formats = [n for n, f in importers().items() if f.from_machines]
        if form_format and form_format not in formats:
            raise _Refused(
                f"format {form_format!r} is not one of {', '.join(formats)} "
                "(or empty for the machine's own)"
            )
    except _Refused as exc:
        return _page(f"Not started: {exc}", 422)
    TransferLog(library).begin(
        "receive",
        machine.name,
        port_of(machine.serial),
        form_format or machine.target,
        current_user().username,
        program_name=check_text(request.form.get("name", "").strip(), "name", NAME_LENGTH),
        queued=True,
    )
    return redirect(url_for("transfers.index"), 303)


@bp.post("/transfers/<int:transfer_id>/cancel")
def cancel(transfer_id: int) -> Response:
    try:
        TransferLog(get_library()).cancel(transfer_id)
    except NotFound:
        abort(404)
    return redirect(url_for("transfers.index"), 303)


@bp.get("/transfers/<int:transfer_id>/raw")
def raw(transfer_id: int) -> Response:
    """What a receive captured, byte for byte (for a capture that was refused)."""
    try:
        data = TransferLog(get_library()).raw(transfer_id)
    except NotFound as exc:
        abort(404, str(exc))
    return Response(
        data,
        mimetype="application/octet-stream",
        headers={"Content-Disposition": attachment(f"transfer-{transfer_id}.bin")},
    )
