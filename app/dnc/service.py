"""What the CLI and the web call: send a program to a machine, receive one into the library.

Each call reads the machine's settings, does the transfer, and hands the `TransferRecord`
to `log` (the caller's transfer-log table) whether it ended well, was cancelled or failed —
from the moment the port is tried; errors found before that (settings, export, data) are
raised without a record. A receive saves nothing unless the whole capture imports: garbage,
a partial program or an import error raise, and the library is not touched.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import serial.tools.list_ports

from app.cnc.blocks import Program
from app.cnc.formats.importers import importers
from app.cnc.formats.reading import read_program
from app.cnc.formats.targets import Export, export, targets
from app.cnc.restart import restart_from
from app.cnc.text import NAME_LENGTH, check_text
from app.dnc.record import TransferRecord
from app.dnc.settings import PortSettings, port_of
from app.dnc.transfer import (
    Cancel,
    Outcome,
    Progress,
    ReceiveError,
    ReceiveResult,
    SendError,
    SendResult,
    TransferError,
    receive,
    send,
)

Log = Callable[[TransferRecord], object]


class MachineProfile(Protocol):
    """What a transfer needs of a machine (app.storage.library.Machine has it)."""

    @property
    def name(self) -> str: ...
    @property
    def target(self) -> str: ...
    @property
    def options(self) -> dict[str, str]: ...
    @property
    def serial(self) -> dict[str, Any]: ...


class ProgramSink(Protocol):
    """Where a received program goes (app.storage.library.Library has it)."""

    def create(self, program: Program, author: str = "", summary_text: str = "") -> Any: ...


class CaptureImportError(TransferError, ValueError):
    """A capture that came whole but is not a program in the expected format (or its
    format cannot be imported yet). Nothing was saved."""


def settings_of(machine: MachineProfile) -> PortSettings:
    """The machine's port settings, its own export target unless `serial` names another.
    Raises SettingsError."""
    return PortSettings.from_serial(machine.serial, target=machine.target)


def _hold(settings: PortSettings) -> float:
    """How long the control may hold a send with XOFF (s): the machine's `hold`, 0 for no
    limit (a drip feed)."""
    return math.inf if settings.hold == 0 else float(settings.hold)


def available_ports() -> list[tuple[str, str]]:
    """The serial ports this computer has, as (path, description), for a port picker."""
    return [(p.device, p.description) for p in sorted(serial.tools.list_ports.comports())]


@dataclass(frozen=True)
class Sent:
    export: Export
    result: SendResult
    record: TransferRecord


def send_program(
    program: Program,
    machine: MachineProfile,
    *,
    port: str | None = None,
    program_id: int | None = None,
    revision: int | None = None,
    start_block: int | None = None,
    author: str = "",
    log: Log | None = None,
    progress: Progress | None = None,
    cancel: Cancel | None = None,
    xoff_timeout: float | None = None,
    write_timeout: float = 10.0,
) -> Sent:
    """Export `program` for `machine` (its target and options) and send it to the machine's
    port (or `port`). Returns the export, the send's result (OK or CANCELLED) and the record,
    which names the program's `revision` and the export's SHA-256. `start_block`: send the
    program from that data block on (app.cnc.restart: a restart after a stop or a cut-off
    transfer; RestartError, a ValueError, when it cannot begin there).

    Raises SettingsError, OptionError/ExportError (the program cannot be exported) or
    DataError before the port is tried (no record); SendError after (record logged).
    """
    settings = settings_of(machine)
    path = port or port_of(machine.serial)
    options = machine.options if settings.target == machine.target else {}
    if start_block is not None:
        program = restart_from(program, start_block)
    made = export(program, settings.target, options)
    digest = hashlib.sha256()
    for piece in made.chunks():
        digest.update(piece)

    def record(result: SendResult) -> TransferRecord:
        entry = TransferRecord.of_send(
            result,
            machine=machine.name,
            program_id=program_id,
            program_name=program.name,
            author=author,
            revision=revision,
            checksum=digest.hexdigest(),
            start_block=start_block,
        )
        if log is not None:
            log(entry)
        return entry

    try:
        result = send(
            made.chunks,
            settings,
            path,
            progress=progress,
            cancel=cancel,
            xoff_timeout=_hold(settings) if xoff_timeout is None else xoff_timeout,
            write_timeout=write_timeout,
        )
    except SendError as exc:
        record(exc.result)
        raise
    return Sent(made, result, record(result))


@dataclass(frozen=True)
class Received:
    """A receive: the program and what the library returned for it (None when cancelled)."""

    result: ReceiveResult
    record: TransferRecord
    program: Program | None
    stored: Any
    report: str = ""


def receive_program(
    machine: MachineProfile,
    library: ProgramSink,
    *,
    port: str | None = None,
    format: str | None = None,
    name: str = "",
    author: str = "",
    log: Log | None = None,
    progress: Progress | None = None,
    cancel: Cancel | None = None,
    idle_timeout: float = 5.0,
    first_byte_timeout: float = 120.0,
    max_bytes: int = 1_000_000,
    compare: Callable[[str, Program], str] | None = None,
) -> Received:
    """Receive a program from `machine`'s port (or `port`), import it as `format` (default:
    the machine's target) and add it to `library` (revision summary: where it came from).
    `compare(machine name, program)` says how it differs from what was last sent to that
    machine (app.storage.transfers.TransferLog.compare_with_last_send); its text goes into
    the report.

    Raises SettingsError, or TextError for a `name` the library cannot store
    (app.cnc.text), before the port is tried; ReceiveError (garbage, timeout, vanished
    port) or CaptureImportError (not a program) after, with the record logged and nothing
    saved.
    """
    check_text(name, "name", NAME_LENGTH)
    settings = settings_of(machine)
    path = port or port_of(machine.serial)

    def record(result: ReceiveResult, **extra: Any) -> TransferRecord:
        entry = TransferRecord.of_receive(result, machine=machine.name, author=author, **extra)
        if log is not None:
            log(entry)
        return entry

    try:
        result = receive(
            settings,
            path,
            idle_timeout=idle_timeout,
            first_byte_timeout=first_byte_timeout,
            max_bytes=max_bytes,
            progress=progress,
            cancel=cancel,
        )
    except ReceiveError as exc:
        record(exc.result)
        raise
    if result.outcome is Outcome.CANCELLED:
        return Received(result, record(result), None, None)
    return keep_capture(
        result,
        machine,
        library,
        format=format,
        name=name,
        author=author,
        log=log,
        compare=compare,
    )


def keep_capture(
    result: ReceiveResult,
    machine: MachineProfile,
    library: ProgramSink,
    *,
    format: str | None = None,
    name: str = "",
    author: str = "",
    log: Log | None = None,
    compare: Callable[[str, Program], str] | None = None,
) -> Received:
    """Import what came from `machine` (a whole receive) as `format` (default: the machine's
    target) and add it to `library`, its record logged (see `receive_program`). Raises
    CaptureImportError (not a program; the record logged, nothing saved)."""
    settings = settings_of(machine)

    def record(**extra: Any) -> TransferRecord:
        entry = TransferRecord.of_receive(result, machine=machine.name, author=author, **extra)
        if log is not None:
            log(entry)
        return entry

    try:
        program, report = import_capture(result, format or settings.target, name)
    except CaptureImportError as exc:
        record(error=str(exc))
        raise
    if compare is not None:  # before the name given here, which is not the control's edit
        compared = compare(machine.name, program)
        if compared:
            report = "\n".join(part for part in (report.rstrip("\n"), compared) if part) + "\n"
    if name:
        program = dataclasses.replace(program, name=name)
    stored = library.create(program, author, f"received from {machine.name} on {result.port}")
    entry = record(program_id=getattr(stored, "id", None), program_name=program.name, report=report)
    return Received(result, entry, program, stored, report)


def import_format(name: str) -> str:
    """The import format that reads what a machine sends: `name` itself when it is an import
    format, else the one that reads back the output of the export target `name` (its
    `reads_back`). Raises CaptureImportError when nothing reads it."""
    if name in importers():
        return name
    target = targets().get(name)
    if target is not None and target.reads_back:
        return target.reads_back
    formats = ", ".join(importers())
    raise CaptureImportError(
        f"nothing reads {name} output back into a program; receive it as one of {formats}"
    )


def program_from_capture(result: ReceiveResult, format: str, name: str = "") -> Program:
    """The program in a capture (see `import_capture`)."""
    return import_capture(result, format, name)[0]


def import_capture(result: ReceiveResult, format: str, name: str = "") -> tuple[Program, str]:
    """The program in a capture and its import report (empty for a MillBlocks document),
    read by app.cnc.formats.reading as `format` (an import format or an export target's name).
    Raises CaptureImportError saying why, with the importer's line and column; nothing is
    returned half-read."""
    chosen = import_format(format)
    try:
        found = read_program(result.data, name or "received", chosen)
    except ValueError as exc:
        what = importers()[chosen].label
        raise CaptureImportError(f"what came is not {what}: {exc}; nothing was saved") from None
    return found.program, ("" if found.format == "json" else found.text())
