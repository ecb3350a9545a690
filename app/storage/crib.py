"""The shop's tool crib in the library: tools with revisions, retired tools, a tool table
read in (app.cnc.tools and app.cnc.tooltable are the core).

As a program's, every save of a tool names the version it was based on; a save based on
an older one is refused (StaleSave, saying what changed meanwhile) and every revision is
kept. Each operation is one transaction: a refused save or a tool table that cannot be
read whole changes nothing. Among the tools in use, each number and each name (whatever
its case) is one tool; retiring a tool keeps it, with its revisions, for the programs that
picked it.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from datetime import datetime
from typing import Any

from sqlalchemy import ColumnElement, func, or_, select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from app.cnc.document import DocumentError, read_fields, write_fields
from app.cnc.numbers import decimal_of
from app.cnc.text import search_terms
from app.cnc.tools import CribTool, tool_changes, tool_faults
from app.cnc.tooltable import TableError, converted, read_table
from app.cnc.units import Units
from app.storage.library import Library, LibraryError, NotFound, StaleSave, _now
from app.storage.models import CribRevisionRow, CribToolRow
from app.storage.revisions import RevisionInfo, Versioned, stale_message

TOOLS = Versioned(CribToolRow, CribRevisionRow, "tool_id")
"""Crib tools and their revisions."""

_REFERENCE = re.compile(r"[Tt#]?([0-9]{1,9})")


class CribError(LibraryError):
    """A crib tool that cannot be kept as given (the message names the field)."""


@dataclass(frozen=True)
class StoredTool:
    """A crib tool as the library keeps it."""

    id: int
    version: int
    tool: CribTool
    updated_at: datetime
    updated_by: str
    retired: bool


@dataclass
class TableImport:
    """What reading a tool table into the crib did: tools added and updated (by number),
    those already as the table says, and the table's notes."""

    added: list[int] = field(default_factory=list)
    updated: list[int] = field(default_factory=list)
    unchanged: list[int] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def text(self) -> str:
        lines = [
            f"{len(self.added)} tools added, {len(self.updated)} updated, "
            f"{len(self.unchanged)} unchanged"
        ]
        return "\n".join(lines + self.notes) + "\n"


def tool_document(tool: CribTool) -> str:
    """A crib tool as the JSON the library stores (fixed key order)."""
    return json.dumps(write_fields(tool), ensure_ascii=False)


def tool_from_document(text: str, where: str = "tool") -> CribTool:
    """A stored crib tool. Raises DocumentError naming the field."""
    return read_fields(CribTool, json.loads(text, parse_float=decimal_of), where)


def checked(tool: CribTool) -> CribTool:
    """`tool` with its name trimmed, if it may be kept; CribError naming every fault."""
    tool = replace(tool, name=tool.name.strip(), notes=tool.notes.strip())
    faults = tool_faults(tool)
    if faults:
        raise CribError("; ".join(f"{label}: {message}" for label, message in faults))
    return tool


def _stored(row: CribToolRow) -> StoredTool:
    try:
        tool = tool_from_document(row.document, f"crib tool {row.number}")
    except DocumentError as exc:
        raise LibraryError(f"crib tool {row.id} cannot be read: {exc}") from None
    return StoredTool(
        row.id, row.version, tool, row.updated_at, row.updated_by, row.deleted_at is not None
    )


class Crib:
    """The tool crib on the library's database."""

    def __init__(self, library: Library) -> None:
        self.library = library

    # -- reading ---------------------------------------------------------------------------

    def tools(self, query: str = "", retired: bool = False) -> list[StoredTool]:
        """Tools in use (or the retired ones) whose name, type or number matches every word
        of `query`, by number. TextError for a search the text rule refuses."""
        statement = select(CribToolRow).where(
            CribToolRow.deleted_at.is_not(None) if retired else CribToolRow.deleted_at.is_(None)
        )
        for word in search_terms(query):
            found = _REFERENCE.fullmatch(word)
            conditions: list[ColumnElement[bool]] = [
                func.lower(CribToolRow.name).like(f"%{word}%"),
                func.lower(CribToolRow.kind).like(f"%{word}%"),
            ]
            if found:
                conditions.append(CribToolRow.number == int(found.group(1)))
            statement = statement.where(or_(*conditions))
        with self.library.session() as s:
            rows = s.scalars(statement.order_by(CribToolRow.number, CribToolRow.id)).all()
            return [_stored(row) for row in rows]

    def get(self, tool_id: int, include_retired: bool = True) -> StoredTool:
        with self.library.session() as s:
            row = s.get(CribToolRow, tool_id)
            if row is None or (row.deleted_at is not None and not include_retired):
                raise NotFound(f"no tool {tool_id} in the crib")
            return _stored(row)

    def find(self, reference: str) -> StoredTool:
        """A tool in use by its number (`12`, `T12`, `#12`) or its name (any case)."""
        text = reference.strip()
        with self.library.session() as s:
            found = _REFERENCE.fullmatch(text)
            row = None
            if found:
                row = s.scalar(
                    select(CribToolRow).where(
                        CribToolRow.number == int(found.group(1)),
                        CribToolRow.deleted_at.is_(None),
                    )
                )
            if row is None:
                row = s.scalar(
                    select(CribToolRow).where(
                        func.lower(CribToolRow.name) == text.lower(),
                        CribToolRow.deleted_at.is_(None),
                    )
                )
            if row is None:
                raise NotFound(
                    f"no tool {text!r} in the crib; give a tool's number (12 or T12) or its name"
                )
            return _stored(row)

    def by_number(self, numbers: set[int] | None = None) -> dict[int, CribTool]:
        """The tools in use by number (only `numbers`, when given)."""
        statement = select(CribToolRow).where(CribToolRow.deleted_at.is_(None))
        if numbers is not None:
            if not numbers:
                return {}
            statement = statement.where(CribToolRow.number.in_(sorted(numbers)))
        with self.library.session() as s:
            return {row.number: _stored(row).tool for row in s.scalars(statement)}

    def revisions(self, tool_id: int) -> list[RevisionInfo]:
        with self.library.session() as s:
            found = TOOLS.history(s, tool_id)
            if not found:
                raise NotFound(f"no tool {tool_id} in the crib")
            return found

    def revision(self, tool_id: int, version: int) -> CribTool:
        with self.library.session() as s:
            row = TOOLS.revision(s, tool_id, version)
            if row is None:
                raise NotFound(f"crib tool {tool_id} has no version {version}")
            return tool_from_document(row.document)

    # -- writing ---------------------------------------------------------------------------

    def create(self, tool: CribTool, author: str = "") -> StoredTool:
        """Add a tool; its first revision is version 1. CribError for a tool that cannot be
        kept, or whose number or name a tool in use has."""
        tool = checked(tool)
        with self._writing() as s:
            row = self._add(s, tool, author, _now())
            return _stored(row)

    def save(self, tool_id: int, tool: CribTool, based_on: int, author: str = "") -> StoredTool:
        """Store a new version of a tool, based on version `based_on`. Raises StaleSave
        (nothing written) when someone saved after `based_on`."""
        tool = checked(tool)
        with self._writing() as s:
            row = s.get(CribToolRow, tool_id)
            if row is None:
                raise NotFound(f"no tool {tool_id} in the crib")
            if row.version != based_on:
                raise self._stale(s, row, based_on)
            self._unique(s, tool, row.id, row.deleted_at is None)
            old = _stored(row).tool
            self._write(s, row, tool, old, based_on, author, _now())
            return _stored(row)

    def retire(self, tool_id: int) -> None:
        """Take a tool out of use (kept, with its revisions)."""
        with self.library.session() as s:
            row = s.get(CribToolRow, tool_id)
            if row is None or row.deleted_at is not None:
                raise NotFound(f"no tool {tool_id} in use in the crib")
            row.deleted_at = _now()

    def reinstate(self, tool_id: int) -> None:
        """Put a retired tool back in use (refused while a tool in use has its number or
        name)."""
        with self._writing() as s:
            row = s.get(CribToolRow, tool_id)
            if row is None or row.deleted_at is None:
                raise NotFound(f"no retired tool {tool_id} in the crib")
            self._unique(s, _stored(row).tool, row.id, True)
            row.deleted_at = None

    def restore_revision(
        self, tool_id: int, version: int, based_on: int, author: str = ""
    ) -> StoredTool:
        """Make an old version current again, as a new revision."""
        return self.save(tool_id, self.revision(tool_id, version), based_on, author)

    def import_table(self, text: str, units: Units, author: str = "") -> TableImport:
        """Read a LinuxCNC tool table in `units` into the crib: a number the crib has in use
        gets the table's diameter, length offset (TCAL) and, where the comment gives one,
        name (the rest of the tool stays as the crib has it); a new number becomes a new
        tool. All or nothing: CribError (naming the line or tool) changes nothing."""
        try:
            read = read_table(text, units)
        except TableError as exc:
            raise CribError(f"not a tool table MillBlocks reads: {exc}") from None
        result = TableImport(notes=list(read.notes))
        now = _now()
        with self._writing() as s:
            for tool in read.tools:
                row = s.scalar(
                    select(CribToolRow).where(
                        CribToolRow.number == tool.number, CribToolRow.deleted_at.is_(None)
                    )
                )
                try:
                    if row is None:
                        self._add(s, checked(tool), author, now, "read from a tool table")
                        result.added.append(tool.number)
                        continue
                    old = _stored(row).tool
                    merged = _merged(old, tool)
                    if merged == old:
                        result.unchanged.append(tool.number)
                        continue
                    merged = checked(merged)
                    self._unique(s, merged, row.id, True)
                    self._write(s, row, merged, old, row.version, author, now)
                    result.updated.append(tool.number)
                except CribError as exc:
                    raise CribError(f"T{tool.number}: {exc}") from None
        return result

    # -- within a transaction --------------------------------------------------------------

    @contextmanager
    def _writing(self) -> Iterator[Session]:
        """A transaction whose unique-number conflict (another worker took the number
        between the check and the write) is a CribError, not a crash."""
        try:
            with self.library.session() as s:
                yield s
        except IntegrityError:
            raise CribError(
                "NUMBER: another tool in use took this number meanwhile; nothing was saved"
            ) from None

    def _add(
        self, s: Session, tool: CribTool, author: str, now: datetime, summary: str = ""
    ) -> CribToolRow:
        self._unique(s, tool, None, True)
        row = CribToolRow(
            number=tool.number,
            name=tool.name,
            kind=tool.kind.value,
            document=tool_document(tool),
            version=1,
            created_at=now,
            updated_at=now,
            updated_by=author,
        )
        return TOOLS.add_first(s, row, now, author, summary or f"added: {tool.describe()}")

    def _write(
        self,
        s: Session,
        row: CribToolRow,
        tool: CribTool,
        old: CribTool,
        based_on: int,
        author: str,
        now: datetime,
    ) -> None:
        values = {
            "number": tool.number,
            "name": tool.name,
            "kind": tool.kind.value,
            "document": tool_document(tool),
        }
        changes = "; ".join(tool_changes(old, tool)) or "saved without changes"
        if not TOOLS.write(s, row.id, based_on, values, now, author, changes):
            raise StaleSave(
                f"not saved: crib tool T{old.number} was saved by someone else meanwhile; "
                "reload it and make your change again; nothing was overwritten",
                row.version,
                [],
            )
        s.refresh(row)

    def _unique(self, s: Session, tool: CribTool, own: int | None, in_use: bool) -> None:
        """CribError when a tool in use (other than `own`) has this number or name."""
        if not in_use:
            return
        others = select(CribToolRow).where(CribToolRow.deleted_at.is_(None))
        if own is not None:
            others = others.where(CribToolRow.id != own)
        same_number = s.scalar(others.where(CribToolRow.number == tool.number))
        if same_number is not None:
            raise CribError(
                f"NUMBER: T{tool.number} is {same_number.name!r} in the crib already; each "
                "tool in use has a number of its own"
            )
        same_name = s.scalar(others.where(func.lower(CribToolRow.name) == tool.name.lower()))
        if same_name is not None:
            raise CribError(
                f"NAME: {tool.name!r} is T{same_name.number} in the crib already; each tool "
                "in use has a name of its own"
            )

    def _stale(self, s: Session, row: CribToolRow, based_on: int) -> StaleSave:
        base = TOOLS.revision(s, row.id, based_on)
        changes = tool_changes(tool_from_document(base.document), _stored(row).tool) if base else []
        listed = changes or ["nothing of the tool itself"]
        return StaleSave(
            stale_message(f"crib tool T{row.number}", row, based_on, listed, self.library.zone),
            row.version,
            changes,
        )


def _merged(old: CribTool, read: CribTool) -> CribTool:
    """A crib tool updated from a tool table line: the table's diameter and length offset
    (in the table's units, converted when the crib keeps the tool in the other), and its
    name when the comment gave one."""
    diameter, tcal = read.diameter, read.tcal
    if read.units is not old.units:
        diameter = converted(diameter, read.units, old.units)
        tcal = None if tcal is None else converted(tcal, read.units, old.units)
    name = read.name if read.name != f"T{read.number}" else old.name
    return replace(old, diameter=diameter, tcal=tcal, name=name)


# -- backups (app/storage/library.py writes and restores them whole) -------------------------


def backup_tools(s: Session, write: Callable[[str, str], None]) -> list[dict[str, Any]]:
    """Every crib tool's revisions written as `tools/<id>/<version>.json` through `write`,
    and the manifest's entries for them."""
    entries: list[dict[str, Any]] = []
    for row in s.scalars(select(CribToolRow).order_by(CribToolRow.id)):
        revisions = []
        for rev in row.revisions:
            name = f"tools/{row.id}/{rev.version}.json"
            write(name, rev.document)
            revisions.append(
                {
                    "version": rev.version,
                    "file": name,
                    "author": rev.author,
                    "summary": rev.summary,
                    "created_at": rev.created_at.isoformat(),
                }
            )
        entries.append(
            {"id": row.id, "retired": row.deleted_at is not None, "revisions": revisions}
        )
    return entries


def restore_tools(s: Session, entries: Iterable[Any], now: datetime) -> None:
    """Add a backup's crib tools (app.storage.backup.ToolEntry) with their revisions, in
    transaction `s`. A tool whose number or name a tool in use already has (in the library
    or earlier in the backup) is added retired, so nothing in use changes."""
    for entry in entries:
        first, last = entry.revisions[0], entry.revisions[-1]
        tool = last.tool
        taken = s.scalar(
            select(CribToolRow).where(
                CribToolRow.deleted_at.is_(None),
                or_(
                    CribToolRow.number == tool.number,
                    func.lower(CribToolRow.name) == tool.name.lower(),
                ),
            )
        )
        row = CribToolRow(
            number=tool.number,
            name=tool.name,
            kind=tool.kind.value,
            document=last.text,
            version=last.version,
            created_at=first.created_at,
            updated_at=last.created_at,
            updated_by=last.author,
            deleted_at=now if entry.retired or taken is not None else None,
        )
        TOOLS.add_restored(s, row, entry.revisions)
