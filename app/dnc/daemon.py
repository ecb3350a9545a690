"""The transfer service (`millblocks dnc`): one process that runs every queued transfer.

A transfer at 4800 baud takes minutes. Run inside a web worker it died with the worker (a
restart, or a worker killed by a slow page, cut a send off half-way). The web page now only
queues it (a row "queued" in the transfer log, app.storage.transfers); this service, a
process of its own beside the web server (systemd unit in docs/deploy.md; `millblocks
serve` starts one too), claims queued transfers and runs each in a thread, one at a time
per machine and any number of machines at once, writing progress into the row as the page
polls it. A web restart touches nothing here. A cancel saved by any web worker reaches the
transfer within a second (`remote_cancel`).

A machine whose serial settings have `requests on` is listened to while it is idle: what
the control sends is either a request naming a program (app.dnc.requests), answered by
queueing that program to the machine (an unknown name answers nothing and is logged), or a
program, received into the library as the Transfers page's Receive would. A queued
transfer for that machine stops the listening (within 50 ms) and takes the port.

When the service stops (SIGTERM, Ctrl-C) it cancels what runs and marks those rows
interrupted, naming them; when it starts after a crash, rows still "running" have lost
their process: it marks them interrupted and says which (the operator checks what the
control has and sends again).
"""

from __future__ import annotations

import contextlib
import logging
import os
import socket
import threading
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta

from sqlalchemy.exc import DBAPIError

from app.dnc import jobs, service
from app.dnc.jobs import JobState, TransferJob
from app.dnc.record import Direction, TransferRecord
from app.dnc.requests import Request, read_request
from app.dnc.settings import port_of
from app.dnc.transfer import (
    Cancel,
    Outcome,
    Progress,
    ReceiveError,
    ReceiveResult,
    TransferError,
    receive,
)
from app.storage.library import Library, LibraryError, Machine, NotFound, StoredProgram
from app.storage.transfers import Transfer, TransferLog

log = logging.getLogger(__name__)

HEARTBEAT_KEY = "dnc_service_heartbeat"
"""The library setting the running service refreshes: its name and the time (UTC)."""
ALIVE = timedelta(seconds=20)
"""A service heard from within this long is taken to be running (the page says so)."""
HEARTBEAT_EVERY = 5.0  # s
RETRY_FIRST = 1.0  # s: the first wait after the database did not answer
RETRY_MOST = 30.0  # s: the longest

INTERRUPTED_BY_CRASH = (
    "the transfer service stopped before this transfer ended (it was restarted); check what "
    "the control has, and send or receive again"
)
INTERRUPTED_BY_STOP = (
    "the transfer service was stopped during this transfer; check what the control has, "
    "and send or receive again"
)


def _now() -> datetime:
    return datetime.now(UTC).replace(tzinfo=None, microsecond=0)


STOPPED = " stopped at "
"""In the heartbeat of a service that stopped as asked (`{name} stopped at {time}`)."""


def _last_heard(library: Library) -> tuple[str, datetime | None, bool]:
    """The last heartbeat: its text, its time (None when there is none), whether the
    service said it stopped."""
    value = library.setting(HEARTBEAT_KEY) or ""
    try:
        seen = datetime.fromisoformat(value.rpartition(" at ")[2])
    except ValueError:
        return value, None, False
    return value, seen, STOPPED in value


def service_alive(library: Library, now: datetime | None = None) -> bool:
    """Whether a transfer service has been heard from lately."""
    _, seen, stopped = _last_heard(library)
    return seen is not None and not stopped and (now or _now()) - seen <= ALIVE


def service_died(library: Library, now: datetime | None = None) -> str | None:
    """The last heartbeat (`{name} at {UTC time}`) of a transfer service that went silent
    without stopping as asked (killed, crashed); None while one runs, after one stopped
    as asked, and where none ever ran."""
    value, seen, stopped = _last_heard(library)
    if seen is None or stopped or (now or _now()) - seen <= ALIVE:
        return None
    return value


@dataclass
class _Running:
    transfer: Transfer
    job: TransferJob


@dataclass
class _Listener:
    thread: threading.Thread
    stop: threading.Event


LISTEN_SECONDS = 3600.0  # s: one wait for the control; then the service listens again
LISTEN_RETRY = 5.0  # s: after a port that could not be opened


def _answers_requests(machine: Machine) -> bool:
    try:
        return service.settings_of(machine).requests and bool(port_of(machine.serial))
    except ValueError:
        return False


class TransferService:
    """Claims queued transfers and runs them; `run` until `stop` is set."""

    def __init__(self, library: Library, *, poll: float = 0.5, name: str = "") -> None:
        self.library = library
        self.log = TransferLog(library)
        self.poll = poll
        self.name = name or f"{socket.gethostname()} pid {os.getpid()}"
        self.running: dict[str, _Running] = {}  # by machine
        self.listening: dict[str, _Listener] = {}  # by machine
        self._beat = 0.0

    def recover(self) -> list[Transfer]:
        """At start: the transfers a crashed service left running, marked interrupted."""
        return self.log.interrupt_running(INTERRUPTED_BY_CRASH)

    def heartbeat(self, clock: float) -> None:
        if clock - self._beat >= HEARTBEAT_EVERY or not self._beat:
            self._beat = clock
            self.library.set_setting(HEARTBEAT_KEY, f"{self.name} at {_now().isoformat()}")

    def step(self) -> list[Transfer]:
        """Forget finished transfers, then start every queued one whose machine is free;
        those started."""
        for machine, running in list(self.running.items()):
            if running.job.wait(0):
                del self.running[machine]
        for machine, done in list(self.listening.items()):
            if not done.thread.is_alive():
                del self.listening[machine]
        started = []
        queued = self.log.queued()
        for transfer in queued:
            holding = self.listening.get(transfer.machine)
            if holding is not None:
                holding.stop.set()  # it lets go of the port; the transfer starts next time
                continue
            if transfer.machine in self.running or not self.log.claim(transfer.id):
                continue
            job = self._start(transfer)
            self.running[transfer.machine] = _Running(transfer, job)
            started.append(transfer)
            log.info(
                "transfer %d: %s on %s started", transfer.id, transfer.direction, transfer.machine
            )
        waiting = {t.machine for t in queued}
        for profile in self.library.machines():
            name = profile.name
            if name in self.running or name in self.listening or name in waiting:
                continue
            if _answers_requests(profile):
                self.listening[name] = self._listen(profile)
        return started

    def run(
        self, stop: threading.Event, on_start: Callable[[Transfer], object] | None = None
    ) -> list[Transfer]:
        """Run until `stop` is set; then cancel what runs and mark it interrupted. Returns
        the transfers the stop interrupted."""
        import time

        retry = 0.0
        while not stop.is_set():
            try:
                self.heartbeat(time.monotonic())
                for transfer in self.step():
                    if on_start is not None:
                        on_start(transfer)
            except DBAPIError as exc:
                # PostgreSQL restarted, the network dropped, SQLite's file unreadable for a
                # while: the transfers running go on (their rows catch up later), and the
                # queue is looked at again after a wait that doubles up to RETRY_MOST.
                retry = min(RETRY_MOST, retry * 2 or RETRY_FIRST)
                said = " ".join(str(exc.orig).split()) or type(exc.orig).__name__
                log.error("the database does not answer (%s); trying again in %g s", said, retry)
                stop.wait(retry)
                continue
            if retry:
                log.warning("the database answers again; the service carries on")
                retry = 0.0
            stop.wait(self.poll)
        stopped = self.shutdown()
        with contextlib.suppress(DBAPIError):  # a database that is gone: the page says so
            self.library.set_setting(HEARTBEAT_KEY, f"{self.name}{STOPPED}{_now().isoformat()}")
        return stopped

    def shutdown(self, timeout: float = 5.0) -> list[Transfer]:
        """Cancel every running transfer, wait for it to let go of its port, and mark its
        row interrupted (a cancelled send leaves a partial program in the control)."""
        for listener in self.listening.values():
            listener.stop.set()
        for listener in self.listening.values():
            listener.thread.join(timeout)
        self.listening.clear()
        stopped = []
        for running in self.running.values():
            running.job.cancel()
        for machine, running in list(self.running.items()):
            running.job.wait(timeout)
            stopped.append(running.transfer)
            self.log.finish(running.transfer.id, None, "interrupted", INTERRUPTED_BY_STOP)
            del self.running[machine]
        return stopped

    # -- listening for requests -------------------------------------------------------------

    def _listen(self, machine: Machine) -> _Listener:
        stop = threading.Event()
        thread = threading.Thread(
            target=self._listen_once,
            args=(machine, stop),
            name=f"dnc-listen-{machine.name}",
            daemon=True,
        )
        thread.start()
        return _Listener(thread, stop)

    def _listen_once(self, machine: Machine, stop: threading.Event) -> None:
        """Wait for what the control sends (until `stop`), then answer or keep it."""
        try:
            settings = service.settings_of(machine)
            result = receive(
                settings,
                port_of(machine.serial),
                first_byte_timeout=LISTEN_SECONDS,
                idle_timeout=2.0,
                cancel=stop,
            )
        except ReceiveError as exc:
            if exc.result.raw:  # something came, but not a whole program: logged
                self.log.log(TransferRecord.of_receive(exc.result, machine=machine.name))
            return
        except (TransferError, ValueError) as exc:
            log.warning("listening on %s: %s", machine.name, exc)
            stop.wait(LISTEN_RETRY)  # a port that is busy or gone: try again later
            return
        if result.outcome is not Outcome.OK:
            return
        try:
            self.answer(machine, result)
        except Exception:  # a bug must not stop the service's other machines
            log.exception("answering %s", machine.name)

    def answer(self, machine: Machine, result: ReceiveResult) -> Transfer | None:
        """What came from `machine`: a request, answered by queueing the program it names
        (its log row says so; an unknown name is logged and answered with nothing), or a
        program, kept as a receive. Returns the queued send, if any."""
        author = f"request from {machine.name}"
        request = read_request(result.text or result.data.decode("ascii", "replace"))
        if request is None:
            # Not a program either: logged with its reason and the raw capture.
            with contextlib.suppress(service.CaptureImportError):
                service.keep_capture(
                    result,
                    machine,
                    self.library,
                    author=f"sent from {machine.name}",
                    log=self.log.log,
                    compare=self.log.compare_with_last_send,
                )
            return None
        found = self._requested(request)
        if isinstance(found, str):
            self.log.log(
                TransferRecord.of_receive(
                    result,
                    machine=machine.name,
                    author=author,
                    error=f"a request for {request.describe()}: {found}; nothing was sent",
                )
            )
            return None
        self.log.log(
            TransferRecord.of_receive(
                result,
                machine=machine.name,
                author=author,
                program_id=found.info.id,
                program_name=found.info.name,
                report=f"a request for {request.describe()}: {found.info.name} queued\n",
            )
        )
        row = self.log.begin(
            "send",
            machine.name,
            port_of(machine.serial),
            machine.target,
            author,
            program_id=found.info.id,
            program_name=found.info.name,
            queued=True,
        )
        return self.log.get(row)

    def _requested(self, request: Request) -> StoredProgram | str:
        """The library program a request names (part number first, then name), or why none."""
        if request.part_number:
            matches = [
                p
                for p in self.library.programs()
                if (p.part_number.lstrip("0") or "0") == request.part_number
            ]
            if len(matches) == 1:
                return self.library.get(matches[0].id)
            if len(matches) > 1:
                return f"{len(matches)} programs have part number {request.part_number}"
        if request.name:
            try:
                return self.library.find(request.name)
            except LibraryError as exc:
                return str(exc)
        return f"no program with part number {request.part_number} in the library"

    # -- one transfer -----------------------------------------------------------------------

    def _start(self, transfer: Transfer) -> TransferJob:
        """Run the transfer in a thread, mirrored into its row."""
        row_id = transfer.id
        records: list[TransferRecord] = []

        def on_change(job: TransferJob) -> None:
            if job.state is JobState.RUNNING:
                self.log.progress(row_id, job.done, job.total)
                return
            record = job.record or (records[-1] if records else None)
            error = job.message if job.state is JobState.FAILED else ""
            self.log.finish(row_id, record, job.state.value, error)

        def run(progress: Progress, cancel: Cancel) -> TransferRecord:
            return self._work(transfer, records.append, progress, cancel)

        return jobs.start(
            run,
            direction=Direction(transfer.direction),
            machine=transfer.machine,
            port=transfer.port,
            on_change=on_change,
            remote_cancel=lambda: self.log.heartbeat(row_id),
        )

    def _work(
        self,
        transfer: Transfer,
        keep: Callable[[TransferRecord], object],
        progress: Progress,
        cancel: Cancel,
    ) -> TransferRecord:
        """The transfer itself, from what its row says (machine, program, format, name)."""
        try:
            machine = self.library.machine(transfer.machine)
            port_of(machine.serial)
        except LibraryError as exc:
            raise ValueError(f"machine {transfer.machine}: {exc}") from None
        if transfer.direction == Direction.SEND.value:
            if transfer.program_id is None:
                raise ValueError("the program to send was deleted")
            try:
                stored = self.library.get(transfer.program_id)
            except NotFound:
                raise ValueError(f"program {transfer.program_id} no longer exists") from None
            return service.send_program(
                stored.program,
                machine,
                program_id=stored.info.id,
                revision=stored.info.version,
                start_block=transfer.start_block,
                author=transfer.author,
                log=keep,
                progress=progress,
                cancel=cancel,
            ).record
        return service.receive_program(
            machine,
            self.library,
            format=transfer.target if transfer.target != machine.target else None,
            name=transfer.program_name,
            author=transfer.author,
            log=keep,
            progress=progress,
            cancel=cancel,
            compare=self.log.compare_with_last_send,
        ).record
