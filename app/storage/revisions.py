"""Versioned rows: the one way the library keeps a thing with its revisions.

A program and a crib tool are each a row (the current document, its version, who saved it
when) and a revision row per version. Every save names the version it was based on and
writes only if that is still the current one (a conditional UPDATE, so two workers cannot
both win); a save based on an older version is refused with the same message for both,
saying who saved what meanwhile. These functions do that for any such pair of tables,
within the caller's transaction.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from datetime import datetime, tzinfo
from typing import Any, Generic, Protocol, TypeVar

from sqlalchemy import ColumnElement, select, update
from sqlalchemy.orm import InstrumentedAttribute, Session

from app.settings import shown


class VersionedRow(Protocol):
    id: Any
    document: Any
    version: Any
    updated_at: Any
    updated_by: Any


class RevisionRowLike(Protocol):
    version: Any
    document: Any
    created_at: Any
    author: Any
    summary: Any


Row = TypeVar("Row", bound=VersionedRow)
Rev = TypeVar("Rev", bound=RevisionRowLike)


@dataclass(frozen=True)
class RevisionInfo:
    version: int
    created_at: datetime
    author: str
    summary: str


class RevisionSource(Protocol):
    """One revision as a backup holds it: the document text and who wrote it when."""

    @property
    def version(self) -> int: ...
    @property
    def text(self) -> str: ...
    @property
    def created_at(self) -> datetime: ...
    @property
    def author(self) -> str: ...
    @property
    def summary(self) -> str: ...


@dataclass(frozen=True)
class Versioned(Generic[Row, Rev]):
    """A row table with its revision table; `owner` is the revision's column naming the
    row (`program_id`, `tool_id`)."""

    rows: type[Row]
    revisions: type[Rev]
    owner: str

    def _owned(self, owner_id: int) -> ColumnElement[bool]:
        column: InstrumentedAttribute[int] = getattr(self.revisions, self.owner)
        return column == owner_id

    def add_first(self, s: Session, row: Row, now: datetime, author: str, summary: str) -> Row:
        """Add `row` (version 1, its document set) and its first revision."""
        s.add(row)
        s.flush()
        s.add(
            self.revisions(  # type: ignore[call-arg]
                **{self.owner: row.id},
                version=1,
                document=row.document,
                created_at=now,
                author=author,
                summary=summary,
            )
        )
        return row

    def write(
        self,
        s: Session,
        row_id: int,
        based_on: int,
        values: dict[str, Any],
        now: datetime,
        author: str,
        summary: str,
    ) -> bool:
        """Make `values` (with `document`) version `based_on + 1` of row `row_id`, with its
        revision, if version `based_on` is still the current one; False (nothing written)
        when another save came first."""
        done = s.execute(
            update(self.rows)
            .where(self.rows.id == row_id, self.rows.version == based_on)
            .values(**values, version=based_on + 1, updated_at=now, updated_by=author)
        )
        if done.rowcount != 1:  # type: ignore[attr-defined]
            return False
        s.add(
            self.revisions(  # type: ignore[call-arg]
                **{self.owner: row_id},
                version=based_on + 1,
                document=values["document"],
                created_at=now,
                author=author,
                summary=summary,
            )
        )
        s.flush()
        return True

    def revision(self, s: Session, owner_id: int, version: int) -> Rev | None:
        return s.scalar(
            select(self.revisions).where(self._owned(owner_id), self.revisions.version == version)
        )

    def history(self, s: Session, owner_id: int) -> list[RevisionInfo]:
        """Every revision of row `owner_id`, oldest first (empty when there is none)."""
        rows = s.scalars(
            select(self.revisions).where(self._owned(owner_id)).order_by(self.revisions.version)
        ).all()
        return [RevisionInfo(r.version, r.created_at, r.author, r.summary) for r in rows]

    def add_restored(self, s: Session, row: Row, revisions: Sequence[RevisionSource]) -> Row:
        """Add `row` as a backup gives it, with every one of its revisions."""
        s.add(row)
        s.flush()
        for rev in revisions:
            s.add(
                self.revisions(  # type: ignore[call-arg]
                    **{self.owner: row.id},
                    version=rev.version,
                    document=rev.text,
                    created_at=rev.created_at,
                    author=rev.author,
                    summary=rev.summary,
                )
            )
        s.flush()
        return row


def stale_message(
    what: str, row: VersionedRow, based_on: int, changes: Iterable[str], zone: tzinfo
) -> str:
    """Why a save based on version `based_on` of `what` (e.g. "program 12") was refused:
    who saved which version when (in the shop's time zone), and what they changed."""
    who = row.updated_by or "someone"
    listed = "; ".join(changes)
    return (
        f"not saved: {who} saved {what} at {shown(row.updated_at, zone)} "
        f"(version {row.version}) after the version {based_on} you started from. "
        f"Changed meanwhile: {listed}. Reload it and make your change again; "
        "nothing was overwritten."
    )
