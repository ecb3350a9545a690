"""Transfers in the background, for the web: a thread per transfer, its progress, and cancel.

A transfer at 4800 baud takes minutes, longer than a request. `start` runs the work in a
daemon thread and returns a `TransferJob` whose state the page shows. The state lives in
this process; with several gunicorn workers a poll may reach another process, so
`on_change` (called at the start, at most every `interval` seconds while bytes move, and at
the end) is where the caller copies the state into its transfer-log row, and
`remote_cancel` (looked at every `interval` seconds) is how a cancel saved by another
process reaches the transfer. Two transfers on one port are refused by the port's own
exclusive lock (`TransferError: port … is busy`), across processes too.
"""

from __future__ import annotations

import enum
import logging
import threading
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime

from app.cnc.formats.targets import ExportError
from app.dnc.record import Direction, TransferRecord
from app.dnc.transfer import Cancel, Outcome, Progress, TransferError

log = logging.getLogger(__name__)

Work = Callable[[Progress, Cancel], TransferRecord]
"""The transfer: given progress and cancel, returns the record (e.g. a lambda calling
`service.send_program(...).record`)."""


class JobState(enum.Enum):
    RUNNING = "running"
    DONE = "done"
    CANCELLED = "cancelled"
    FAILED = "failed"


@dataclass
class TransferJob:
    """One background transfer. Read its fields from any thread; only its thread writes."""

    direction: Direction
    machine: str
    port: str
    label: str
    id: str = field(default_factory=lambda: uuid.uuid4().hex[:12])
    started: datetime = field(default_factory=lambda: datetime.now(UTC).replace(tzinfo=None))
    state: JobState = JobState.RUNNING
    done: int = 0
    total: int | None = None
    message: str = ""
    record: TransferRecord | None = None
    _cancel: threading.Event = field(default_factory=threading.Event, repr=False)
    _finished: threading.Event = field(default_factory=threading.Event, repr=False)

    @property
    def percent(self) -> int | None:
        """Whole percent sent (None while receiving: the length is not known)."""
        if not self.total:
            return None
        return min(100, self.done * 100 // self.total)

    def cancel(self) -> None:
        """Ask the transfer to stop (it stops within 50 ms; a send leaves a partial program)."""
        self._cancel.set()

    def wait(self, timeout: float | None = None) -> bool:
        """Wait for the end; True if it ended."""
        return self._finished.wait(timeout)


_STATES = {
    Outcome.OK: JobState.DONE,
    Outcome.CANCELLED: JobState.CANCELLED,
    Outcome.FAILED: JobState.FAILED,
}


def start(
    work: Work,
    *,
    direction: Direction,
    machine: str,
    port: str,
    label: str = "",
    on_change: Callable[[TransferJob], object] | None = None,
    remote_cancel: Callable[[], bool] | None = None,
    interval: float = 1.0,
) -> TransferJob:
    """Run `work` in a daemon thread and return its job at once. `on_change(job)` and
    `remote_cancel()` are called from that thread (see the module's notes)."""
    job = TransferJob(direction, machine, port, label)
    last = {"change": 0.0, "remote": time.monotonic()}

    def changed(force: bool = False) -> None:
        now = time.monotonic()
        if on_change is not None and (force or now - last["change"] >= interval):
            last["change"] = now
            on_change(job)

    def progress(done: int, total: int | None) -> None:
        job.done, job.total = done, total
        changed()

    def cancelled() -> bool:
        if job._cancel.is_set():
            return True
        if remote_cancel is not None and time.monotonic() - last["remote"] >= interval:
            last["remote"] = time.monotonic()
            if remote_cancel():
                job._cancel.set()
        return job._cancel.is_set()

    def run() -> None:
        try:
            changed(force=True)
            record = work(progress, cancelled)
            job.record = record
            job.done = record.bytes_done
            job.state = _STATES[record.outcome]
            job.message = record.summary()
        except ExportError as exc:  # why, on the transfers page, not only that it failed
            job.state, job.message = JobState.FAILED, exc.explained()
        except (TransferError, ValueError) as exc:
            job.state, job.message = JobState.FAILED, str(exc)
        except Exception as exc:  # a bug: shown on the page and logged, not lost in a thread
            log.exception("transfer %s failed", job.id)
            job.state, job.message = JobState.FAILED, f"internal error: {exc!r}"
        finally:
            try:
                changed(force=True)
            except Exception:
                log.exception("transfer %s: on_change failed", job.id)
            job._finished.set()

    threading.Thread(target=run, name=f"dnc-{job.id}", daemon=True).start()
    return job
