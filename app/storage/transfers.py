"""The transfer log on the library's database (issue 8): every send and receive, with its
progress while it runs and a cancel flag any web worker can set.

It is also the transfer service's queue (issue 35): the web page and `millblocks send
--queue` add a row "queued"; the service (`millblocks dnc`, app.dnc.daemon) claims it —
one atomic UPDATE from "queued" to "running", so two services never run one transfer —
and runs it, writing its progress here."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from typing import Any

from sqlalchemy import CursorResult, select, update

from app.cnc.blocks import Program
from app.cnc.diff import diff
from app.dnc.record import TransferRecord
from app.storage.library import Library, LibraryError, NotFound
from app.storage.models import TransferRow

STALE = timedelta(seconds=60)
"""A running transfer unheard of this long has lost its process (the web job reports at
least every second, sending, receiving or waiting for the control)."""

INTERRUPTED = (
    "the server process running this transfer stopped (restarted?) before it ended; "
    "check what the control has, and send or receive again"
)
QUEUED = "queued"
RUNNING = "running"


def _now() -> datetime:
    return datetime.now(UTC).replace(tzinfo=None, microsecond=0)


@dataclass(frozen=True)
class Transfer:
    id: int
    direction: str
    machine: str
    port: str
    target: str
    settings: str
    bytes_done: int
    bytes_total: int | None
    started_at: datetime
    finished_at: datetime | None
    outcome: str
    error: str
    report: str
    program_id: int | None
    program_name: str
    author: str
    has_raw: bool
    cancel_requested: bool
    revision: int | None = None
    checksum: str = ""
    start_block: int | None = None

    @property
    def percent(self) -> int | None:
        if not self.bytes_total:
            return None
        return min(100, self.bytes_done * 100 // self.bytes_total)


def _view(row: TransferRow) -> Transfer:
    return Transfer(
        row.id,
        row.direction,
        row.machine,
        row.port,
        row.target,
        row.settings,
        row.bytes_done,
        row.bytes_total,
        row.started_at,
        row.finished_at,
        row.outcome,
        row.error,
        row.report,
        row.program_id,
        row.program_name,
        row.author,
        row.raw is not None,
        row.cancel_requested,
        row.revision,
        row.checksum,
        row.start_block,
    )


class TransferLog:
    def __init__(self, library: Library) -> None:
        self.library = library

    def begin(
        self,
        direction: str,
        machine: str,
        port: str,
        target: str,
        author: str,
        program_id: int | None = None,
        program_name: str = "",
        *,
        queued: bool = False,
        start_block: int | None = None,
    ) -> int:
        """A transfer's row, running (or `queued` for the transfer service); its id. A
        queued receive keeps the format asked for in `target` and the new program's name
        in `program_name`."""
        with self.library.session() as s:
            row = TransferRow(
                direction=direction,
                machine=machine,
                port=port,
                target=target,
                author=author,
                program_id=program_id,
                program_name=program_name,
                started_at=_now(),
                updated_at=_now(),
                outcome=QUEUED if queued else RUNNING,
                start_block=start_block,
            )
            s.add(row)
            s.flush()
            return row.id

    def progress(
        self,
        transfer_id: int,
        done: int,
        total: int | None,
        outcome: str = "running",
        error: str = "",
    ) -> None:
        with self.library.session() as s:
            row = s.get(TransferRow, transfer_id)
            if row is not None:
                row.bytes_done, row.bytes_total = done, total
                row.outcome, row.error = outcome, error or row.error
                row.updated_at = _now()

    def heartbeat(self, transfer_id: int) -> bool:
        """The running transfer is alive; returns whether a cancel was asked for."""
        with self.library.session() as s:
            row = s.get(TransferRow, transfer_id)
            if row is None:
                return True
            row.updated_at = _now()
            return row.cancel_requested

    def finish(
        self, transfer_id: int, record: TransferRecord | None, outcome: str, error: str = ""
    ) -> None:
        """Copy a finished transfer's record into its row (or just the outcome)."""
        with self.library.session() as s:
            row = s.get(TransferRow, transfer_id)
            if row is None:
                return
            row.outcome = outcome
            row.error = error
            row.finished_at = row.updated_at = _now()
            if record is not None:
                self._copy(row, record)

    def log(self, record: TransferRecord) -> int:
        """A whole transfer's row at once (the CLI's transfers)."""
        with self.library.session() as s:
            row = TransferRow(
                direction=record.direction.value, machine=record.machine, started_at=record.started
            )
            self._copy(row, record)
            s.add(row)
            s.flush()
            return row.id

    @staticmethod
    def _copy(row: TransferRow, record: TransferRecord) -> None:
        row.port = record.port
        row.target = record.target
        row.settings = record.settings
        row.bytes_done = record.bytes_done
        row.bytes_total = record.bytes_total
        row.started_at = record.started
        row.finished_at = record.finished
        row.outcome = record.outcome.value
        row.error = record.error or row.error
        row.report = record.report or row.report
        row.program_id = record.program_id if record.program_id is not None else row.program_id
        row.program_name = record.program_name or row.program_name
        row.author = record.author or row.author
        if record.raw is not None:
            row.raw = record.raw[:1_000_000]
        if record.revision is not None:
            row.revision = record.revision
        if record.start_block is not None:
            row.start_block = record.start_block
        row.checksum = record.checksum or row.checksum

    def cancel(self, transfer_id: int) -> None:
        """Ask a transfer to stop; a queued one is withdrawn at once."""
        with self.library.session() as s:
            row = s.get(TransferRow, transfer_id)
            if row is None:
                raise NotFound(f"no transfer {transfer_id}")
            row.cancel_requested = True
            if row.outcome == QUEUED:
                row.outcome, row.error = "cancelled", "withdrawn before it started"
                row.finished_at = row.updated_at = _now()

    def last_sent(self, machine: str) -> Transfer | None:
        """The newest whole send to `machine` (outcome ok), if any."""
        with self.library.session() as s:
            row = s.scalars(
                select(TransferRow)
                .where(
                    TransferRow.machine == machine,
                    TransferRow.direction == "send",
                    TransferRow.outcome == "ok",
                )
                .order_by(TransferRow.id.desc())
                .limit(1)
            ).first()
            return None if row is None else _view(row)

    def compare_with_last_send(self, machine: str, program: Program) -> str:
        """How `program` (received from `machine`) differs from the revision last sent to
        that machine, block by block, in the control's words: the operator's edits at the
        control, or an empty line when none. '' when nothing was sent to it, or the program
        sent is no longer in the library."""
        sent = self.last_sent(machine)
        if sent is None or sent.program_id is None:
            return ""
        try:
            if sent.revision is not None:
                before = self.library.revision(sent.program_id, sent.revision)
            else:
                before = self.library.get(sent.program_id).program
        except (NotFound, LibraryError):
            return ""
        version = f" v{sent.revision}" if sent.revision is not None else ""
        what = (
            f"compared with what was last sent to {machine}: {sent.program_name}{version}, "
            f"{sent.started_at:%Y-%m-%d %H:%M} UTC"
        )
        changes = diff(before, program)
        if not changes:
            return f"  {what}: the same program"
        shown = changes[:20]
        more = f"\n    … and {len(changes) - 20} more" if len(changes) > 20 else ""
        lines = "".join(f"\n    {change}" for change in shown)
        count = "1 difference" if len(changes) == 1 else f"{len(changes)} differences"
        return f"  {what}: {count}{lines}{more}"

    # -- the transfer service's queue -------------------------------------------------------

    def queued(self) -> list[Transfer]:
        """The transfers waiting for the service, oldest first."""
        with self.library.session() as s:
            rows = s.scalars(
                select(TransferRow).where(TransferRow.outcome == QUEUED).order_by(TransferRow.id)
            )
            return [_view(r) for r in rows]

    def claim(self, transfer_id: int) -> bool:
        """Take a queued transfer to run it: True when this caller got it (one UPDATE from
        queued to running, so of two services at most one does)."""
        with self.library.session() as s:
            done: CursorResult[Any] = s.execute(  # type: ignore[assignment]
                update(TransferRow)
                .where(TransferRow.id == transfer_id, TransferRow.outcome == QUEUED)
                .values(outcome=RUNNING, started_at=_now(), updated_at=_now())
            )
            return bool(done.rowcount)

    def interrupt_running(self, reason: str) -> list[Transfer]:
        """Mark every running transfer as interrupted with `reason` (the service starting
        after a crash: none of them has a process any more); those transfers."""
        with self.library.session() as s:
            rows = list(s.scalars(select(TransferRow).where(TransferRow.outcome == RUNNING)))
            for row in rows:
                row.outcome, row.error = "interrupted", reason
                row.finished_at = row.updated_at = _now()
            return [_view(r) for r in rows]

    def get(self, transfer_id: int) -> Transfer:
        with self.library.session() as s:
            row = s.get(TransferRow, transfer_id)
            if row is None:
                raise NotFound(f"no transfer {transfer_id}")
            return _view(row)

    def raw(self, transfer_id: int) -> bytes:
        with self.library.session() as s:
            row = s.get(TransferRow, transfer_id)
            if row is None or row.raw is None:
                raise NotFound(f"transfer {transfer_id} kept no capture")
            return bytes(row.raw)

    def recent(self, limit: int = 50) -> list[Transfer]:
        """The newest transfers. A running one unheard of for `STALE` is marked
        interrupted here (its process is gone), so no page waits on it forever."""
        with self.library.session() as s:
            rows = list(
                s.scalars(
                    select(TransferRow)
                    .order_by(TransferRow.started_at.desc(), TransferRow.id.desc())
                    .limit(limit)
                )
            )
            cutoff = _now() - STALE
            for row in rows:
                if row.outcome == "running" and (row.updated_at or row.started_at) < cutoff:
                    row.outcome, row.error = "interrupted", INTERRUPTED
                    row.finished_at = row.updated_at or row.started_at
            return [_view(r) for r in rows]
