"""The transfer log entry: what went over which port, when, and how it ended.

The caller stores it (the transfer-log table); `as_row` gives the column values. A receive
keeps its raw capture, including garbage that was refused, so the user can see what came.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from app.dnc.transfer import Outcome, ReceiveResult, SendResult


class Direction(enum.Enum):
    SEND = "send"  # to the control
    RECEIVE = "receive"  # from the control


@dataclass(frozen=True)
class TransferRecord:
    """One transfer. `bytes_done` are wire bytes sent (leader and trailer included) or
    bytes received (raw, leader included); `bytes_total` is the send's total (None for a
    receive). Datetimes are UTC without a time zone. `raw` is the receive's capture;
    `report` the import report of what it became (empty for a MillBlocks document)."""

    direction: Direction
    machine: str
    port: str
    target: str
    settings: str
    bytes_done: int
    bytes_total: int | None
    started: datetime
    finished: datetime
    outcome: Outcome
    error: str = ""
    program_id: int | None = None
    program_name: str = ""
    author: str = ""
    raw: bytes | None = None
    report: str = ""
    revision: int | None = None  # a send: the program's version
    checksum: str = ""  # a send: SHA-256 (hex) of the export
    start_block: int | None = None  # a send begun at this data block (a restart)

    @classmethod
    def of_send(
        cls,
        result: SendResult,
        *,
        machine: str,
        program_id: int | None = None,
        program_name: str = "",
        author: str = "",
        revision: int | None = None,
        checksum: str = "",
        start_block: int | None = None,
    ) -> TransferRecord:
        return cls(
            direction=Direction.SEND,
            machine=machine,
            port=result.port,
            target=result.settings.target,
            settings=result.settings.describe(),
            bytes_done=result.sent,
            bytes_total=result.total,
            started=result.started,
            finished=result.finished,
            outcome=result.outcome,
            error=result.error,
            program_id=program_id,
            program_name=program_name,
            author=author,
            revision=revision,
            checksum=checksum,
            start_block=start_block,
        )

    @classmethod
    def of_receive(
        cls,
        result: ReceiveResult,
        *,
        machine: str,
        program_id: int | None = None,
        program_name: str = "",
        author: str = "",
        error: str | None = None,
        report: str = "",
    ) -> TransferRecord:
        """`error` overrides the result's (an import that failed after a good receive)."""
        failed = error is not None or result.outcome is Outcome.FAILED
        return cls(
            direction=Direction.RECEIVE,
            machine=machine,
            port=result.port,
            target=result.settings.target,
            settings=result.settings.describe(),
            bytes_done=len(result.raw),
            bytes_total=None,
            started=result.started,
            finished=result.finished,
            outcome=Outcome.FAILED if failed else result.outcome,
            error=result.error if error is None else error,
            program_id=program_id,
            program_name=program_name,
            author=author,
            raw=result.raw,
            report=report,
        )

    @property
    def seconds(self) -> float:
        return (self.finished - self.started).total_seconds()

    def summary(self) -> str:
        """One line: `send events 461/461 bytes to Bridgeport on /dev/ttyUSB0: ok`."""
        done = (
            f"{self.bytes_done}/{self.bytes_total}"
            if self.bytes_total is not None
            else str(self.bytes_done)
        )
        way = "to" if self.direction is Direction.SEND else "from"
        what = f" {self.program_name!r}" if self.program_name else ""
        line = (
            f"{self.direction.value}{what} {self.target} {done} bytes {way} {self.machine} on "
            f"{self.port} in {self.seconds:.1f} s: {self.outcome.value}"
        )
        return f"{line}: {self.error}" if self.error else line

    def as_row(self) -> dict[str, Any]:
        """Column name → value for the transfer-log table (enums as their text values)."""
        return {
            "direction": self.direction.value,
            "machine": self.machine,
            "port": self.port,
            "target": self.target,
            "settings": self.settings,
            "bytes_done": self.bytes_done,
            "bytes_total": self.bytes_total,
            "started_at": self.started,
            "finished_at": self.finished,
            "outcome": self.outcome.value,
            "error": self.error,
            "program_id": self.program_id,
            "program_name": self.program_name,
            "author": self.author,
            "raw": self.raw,
        }
