"""The Library: programs with revisions, the trash, search, machines, backup and restore.

Every save names the version it was based on. A save based on an older version than the
stored one is refused with `StaleSave`, whose message says who saved what meanwhile;
nothing is overwritten and every revision is kept. Each operation is one transaction: a
failed save or import leaves the stored program exactly as it was.
"""

from __future__ import annotations

import hashlib
import json
import re
import zipfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime, timedelta, tzinfo
from pathlib import Path
from typing import Any, BinaryIO

from sqlalchemy import Engine, delete, func, or_, select
from sqlalchemy.exc import SQLAlchemyError
from sqlalchemy.orm import Session, sessionmaker

from app.cnc import document
from app.cnc.blocks import Block, Hole, Program
from app.cnc.memo import ByObject, Recent
from app.cnc.numbers import NumberError, parse_int
from app.cnc.sizes import MAX_MOVES, TooLarge, check_block_count
from app.cnc.text import (
    NAME_LENGTH,
    NOTES_LENGTH,
    SETTING_LENGTH,
    SHORT_NAME_LENGTH,
    check_text,
    derived_name,
    search_terms,
)
from app.storage.db import migration_lock, open_engine, upgrade
from app.storage.models import DrawingRow, MachineRow, ProgramRow, RevisionRow, SettingRow
from app.storage.revisions import RevisionInfo, Versioned, stale_message

# Reading the library needs the document model and the rows; what only writing, comparing
# or checking a machine needs (the cost of a program's moves, the diff, the targets and
# their writers, the machine model with numpy, the serial settings) is imported where it
# is used, so a command that reads one program starts at once (issue 31).

SORTS = ("name", "part_number", "updated", "created")
DRAWING_KEEP = timedelta(days=1)
"""How long an uploaded drawing is kept for choosing from."""
DRAWINGS_PER_USER = 10
"""Drawings one user keeps: opening one more forgets that user's oldest."""
DRAWING_BYTES_IN_ALL = 64 * 1024 * 1024
"""Bytes of all users' drawings together: past it an upload is refused until the oldest
drawing's day is over (one user alone holds at most 10 × 2 MB)."""
DRAWING_KEY = re.compile(r"[0-9a-f]{64}")
BACKUP_FORMAT = "millblocks-backup"


PROGRAMS = Versioned(ProgramRow, RevisionRow, "program_id")
"""Programs and their revisions."""


class LibraryError(ValueError):
    """A library operation that cannot be done (the message says why)."""


class MachineSettingsError(LibraryError):
    """A machine profile's target, options, travel limits or serial settings the machines
    form would refuse. The message starts with the field (`serial, baud: …`, `options: …`,
    `limits: …`); `field` is that field."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(f"{field}: {message}")
        self.field = field
        self.detail = message


class NotFound(LibraryError):
    """No such program, revision or machine."""


class DrawingsFull(LibraryError):
    """The server keeps as many drawings as it may (DRAWING_BYTES_IN_ALL): the message says
    when room comes back."""


class StaleSave(LibraryError):
    """A save based on an older version: refused, with what changed meanwhile."""

    def __init__(self, message: str, current_version: int, changes: list[str]) -> None:
        super().__init__(message)
        self.current_version = current_version
        self.changes = changes


@dataclass(frozen=True)
class ProgramInfo:
    """A library entry without its document."""

    id: int
    name: str
    part_number: str
    notes: str
    units: str
    block_count: int
    version: int
    created_at: datetime
    updated_at: datetime
    updated_by: str
    deleted_at: datetime | None


@dataclass(frozen=True)
class StoredProgram:
    """A library entry with its program."""

    info: ProgramInfo
    program: Program


@dataclass(frozen=True)
class Machine:
    """A machine profile: the export target and its options, and serial settings."""

    name: str
    target: str
    options: dict[str, str]
    serial: dict[str, Any]
    notes: str = ""
    limits: dict[str, Any] = field(default_factory=dict)


def _now() -> datetime:
    return datetime.now(UTC).replace(tzinfo=None, microsecond=0)


def _info(row: ProgramRow) -> ProgramInfo:
    return ProgramInfo(
        id=row.id,
        name=row.name,
        part_number=row.part_number,
        notes=row.notes,
        units=row.units,
        block_count=row.block_count,
        version=row.version,
        created_at=row.created_at,
        updated_at=row.updated_at,
        updated_by=row.updated_by,
        deleted_at=row.deleted_at,
    )


def search_words(program: Program) -> str:
    """What a content search matches: tool numbers (T3), block types, hole operations."""
    words: set[str] = set()
    for block in program.blocks:
        words |= _block_words(block)
    words.update(f"T{tool.number}" for tool in program.block0.tools)
    return " ".join(sorted(words)).lower()


# Each block's words, by block object (a save writes a version that shares all but the
# edited block with the one before).
_WORDS: ByObject[frozenset[str]] = ByObject()


def _block_words(block: Block) -> frozenset[str]:
    found = _WORDS.get(block)
    if found is None:
        words = {block.kind, *block.title.split()}
        if isinstance(block, Hole):
            words.add(block.op.value)
        if block.tool_number is not None:
            words.add(f"T{block.tool_number}")
        found = frozenset(words)
        _WORDS.keep(block, found)
    return found


def _columns(program: Program) -> dict[str, Any]:
    """The row's columns for `program`. Raises LibraryError for a program past
    app.cnc.sizes.MAX_BLOCKS or MAX_MOVES (the server's, whatever a command line allows
    for files): the library keeps only programs it can open; TextError for a name or
    notes past the text rule (app.cnc.text), whatever the entry."""
    from app.cnc import cost

    try:
        check_block_count(len(program.blocks))
        cost.check(program, MAX_MOVES)
    except TooLarge as exc:
        raise LibraryError(f"not stored: {exc}") from None
    check_text(program.name, "program name", NAME_LENGTH)
    check_text(program.part_number, "part number", NAME_LENGTH)
    check_text(program.notes, "notes", NOTES_LENGTH)
    return {
        "name": program.name,
        "part_number": program.part_number[:8],
        "notes": program.notes,
        "units": program.units.value,
        "document": document.dumps(program),
        "search_text": search_words(program),
        "block_count": len(program.blocks),
    }


class Library:
    """The program library on one database."""

    def __init__(self, engine: Engine, zone: tzinfo = UTC) -> None:
        self.engine = engine
        self.zone = zone
        """The shop's time zone, for the times this library's messages state."""
        self.sessions = sessionmaker(engine, expire_on_commit=False)

    @contextmanager
    def session(self) -> Iterator[Session]:
        """One transaction: committed when the block ends, rolled back on any error."""
        with self.sessions.begin() as session:
            yield session

    # -- programs -------------------------------------------------------------------------

    def create(self, program: Program, author: str = "", summary_text: str = "") -> ProgramInfo:
        """Add a program; its first revision is version 1."""
        from app.cnc.diff import summary

        check_text(author, "author", SHORT_NAME_LENGTH)
        now = _now()
        with self.session() as s:
            row = ProgramRow(
                **_columns(program),
                version=1,
                created_at=now,
                updated_at=now,
                updated_by=author,
            )
            PROGRAMS.add_first(s, row, now, author, summary_text or summary(None, program))
            return _info(row)

    def get(self, program_id: int, include_trash: bool = False) -> StoredProgram:
        with self.session() as s:
            row = s.get(ProgramRow, program_id)
            if row is None or (row.deleted_at is not None and not include_trash):
                raise NotFound(f"no program {program_id} in the library")
            return StoredProgram(_info(row), _load(row))

    def find(self, reference: str) -> StoredProgram:
        """A program by id (digits) or by exact name (not in the trash)."""
        if reference.isascii() and reference.isdigit():  # `²` is a digit to isdigit
            try:
                return self.get(parse_int(reference))
            except NumberError:
                raise NotFound(f"no program {reference} in the library") from None
        with self.session() as s:
            rows = s.scalars(
                select(ProgramRow).where(
                    ProgramRow.name == reference, ProgramRow.deleted_at.is_(None)
                )
            ).all()
            if not rows:
                raise NotFound(f"no program named {reference!r} in the library")
            if len(rows) > 1:
                ids = ", ".join(str(r.id) for r in rows)
                raise LibraryError(f"{len(rows)} programs are named {reference!r} (ids {ids})")
            return StoredProgram(_info(rows[0]), _load(rows[0]))

    def programs(
        self, query: str = "", sort: str = "name", trash: bool = False
    ) -> list[ProgramInfo]:
        """Programs matching every word of `query` in name, part number, notes or content."""
        if sort not in SORTS:
            raise LibraryError(f"cannot sort by {sort!r}; sorts: {', '.join(SORTS)}")
        statement = select(ProgramRow).where(
            ProgramRow.deleted_at.is_not(None) if trash else ProgramRow.deleted_at.is_(None)
        )
        for word in search_terms(query):
            pattern = f"%{word}%"
            statement = statement.where(
                or_(
                    func.lower(ProgramRow.name).like(pattern),
                    func.lower(ProgramRow.part_number).like(pattern),
                    func.lower(ProgramRow.notes).like(pattern),
                    func.lower(ProgramRow.search_text).like(pattern),
                )
            )
        order = {
            "name": (func.lower(ProgramRow.name), ProgramRow.id),
            "part_number": (ProgramRow.part_number, ProgramRow.id),
            "updated": (ProgramRow.updated_at.desc(), ProgramRow.id.desc()),
            "created": (ProgramRow.created_at.desc(), ProgramRow.id.desc()),
        }[sort]
        with self.session() as s:
            return [_info(row) for row in s.scalars(statement.order_by(*order))]

    def save(
        self, program_id: int, program: Program, based_on: int, author: str = ""
    ) -> ProgramInfo:
        """Store a new version of a program, based on version `based_on`.

        Raises StaleSave (nothing written) when someone saved after `based_on`.
        """
        from app.cnc.diff import summary

        check_text(author, "author", SHORT_NAME_LENGTH)
        now = _now()
        with self.session() as s:
            row = s.get(ProgramRow, program_id)
            if row is None or row.deleted_at is not None:
                raise NotFound(f"no program {program_id} in the library")
            if row.version != based_on:
                raise self._stale(s, row, based_on, program)
            old = _parse(row.document)
            columns = _columns(program)
            if not PROGRAMS.write(
                s, program_id, based_on, columns, now, author, summary(old, program)
            ):
                s.rollback()
                with self.session() as again:
                    fresh = again.get(ProgramRow, program_id)
                    assert fresh is not None
                    raise self._stale(again, fresh, based_on, program)
            s.refresh(row)
            # The next read of this version (the editor's, right after) needs no parse.
            _remember(columns["document"], document.as_stored(program))
            return _info(row)

    def _stale(self, s: Session, row: ProgramRow, based_on: int, mine: Program) -> StaleSave:
        from app.cnc.diff import diff

        base = PROGRAMS.revision(s, row.id, based_on)
        changes = diff(document.loads(base.document), document.loads(row.document)) if base else []
        listed = changes[:6] or ["no change to the program itself"]
        del mine
        message = stale_message(f"program {row.id}", row, based_on, listed, self.zone)
        return StaleSave(message, row.version, changes)

    def rename(self, program_id: int, name: str, based_on: int, author: str = "") -> ProgramInfo:
        if not name.strip():
            raise LibraryError("a program needs a name")
        stored = self.get(program_id)
        return self.save(program_id, replace(stored.program, name=name), based_on, author)

    def duplicate(self, program_id: int, author: str = "", name: str | None = None) -> ProgramInfo:
        stored = self.get(program_id)
        copy = replace(stored.program, name=name or derived_name(stored.program.name, " (copy)"))
        return self.create(copy, author, f"duplicated from program {program_id}")

    def delete(self, program_id: int) -> None:
        """Move a program to the trash (its revisions are kept)."""
        with self.session() as s:
            row = s.get(ProgramRow, program_id)
            if row is None or row.deleted_at is not None:
                raise NotFound(f"no program {program_id} in the library")
            row.deleted_at = _now()

    def restore(self, program_id: int) -> None:
        """Take a program out of the trash."""
        with self.session() as s:
            row = s.get(ProgramRow, program_id)
            if row is None or row.deleted_at is None:
                raise NotFound(f"no program {program_id} in the trash")
            row.deleted_at = None

    def purge(self, program_id: int) -> None:
        """Delete a program from the trash for good, with its revisions."""
        with self.session() as s:
            row = s.get(ProgramRow, program_id)
            if row is None or row.deleted_at is None:
                raise NotFound(f"no program {program_id} in the trash")
            s.delete(row)

    # -- revisions --------------------------------------------------------------------------

    def revisions(self, program_id: int) -> list[RevisionInfo]:
        with self.session() as s:
            found = PROGRAMS.history(s, program_id)
            if not found:
                raise NotFound(f"no program {program_id} in the library")
            return found

    def revision(self, program_id: int, version: int) -> Program:
        with self.session() as s:
            row = PROGRAMS.revision(s, program_id, version)
            if row is None:
                raise NotFound(f"program {program_id} has no version {version}")
            return document.loads(row.document)

    def restore_revision(
        self, program_id: int, version: int, based_on: int, author: str = ""
    ) -> ProgramInfo:
        """Make an old version current again, as a new revision (history is kept)."""
        return self.save(program_id, self.revision(program_id, version), based_on, author)

    def diff(self, program_id: int, old: int, new: int) -> list[str]:
        """Block-level differences from version `old` to version `new`."""
        from app.cnc.diff import diff

        return diff(self.revision(program_id, old), self.revision(program_id, new))

    # -- machines -----------------------------------------------------------------------------

    def machines(self) -> list[Machine]:
        with self.session() as s:
            rows = s.scalars(select(MachineRow).order_by(MachineRow.name)).all()
            return [_machine(r) for r in rows]

    def machine(self, name: str) -> Machine:
        with self.session() as s:
            row = s.scalar(select(MachineRow).where(MachineRow.name == name))
            if row is None:
                raise NotFound(f"no machine named {name!r}")
            return _machine(row)

    def save_machine(self, machine: Machine) -> None:
        """Create or update a machine profile (by name)."""
        if not machine.name.strip():
            raise LibraryError("a machine needs a name")
        with self.session() as s:
            _store_machine(s, machine, _now())

    def delete_machine(self, name: str) -> None:
        with self.session() as s:
            if s.execute(delete(MachineRow).where(MachineRow.name == name)).rowcount == 0:  # type: ignore[attr-defined]
                raise NotFound(f"no machine named {name!r}")

    # -- settings, demo, backup -----------------------------------------------------------------

    def setting(self, key: str) -> str | None:
        with self.session() as s:
            row = s.get(SettingRow, key)
            return None if row is None else row.value

    def set_setting(self, key: str, value: str) -> None:
        with self.session() as s:
            row = s.get(SettingRow, key)
            if row is None:
                s.add(SettingRow(key=key, value=value))
            else:
                row.value = value

    # -- drawings being chosen from (DXF) ------------------------------------------------

    def put_drawing(self, name: str, data: bytes, author: str = "") -> str:
        """Keep an uploaded drawing; its key (the SHA-256 of `data`, hex). Drawings
        uploaded more than DRAWING_KEEP ago are removed first; a user keeps at most
        DRAWINGS_PER_USER (the oldest is forgotten to make room). Raises DrawingsFull,
        storing nothing, when all drawings together would pass DRAWING_BYTES_IN_ALL."""
        key = hashlib.sha256(data).hexdigest()
        # To the microsecond: which of a user's drawings is the oldest decides what goes.
        now = datetime.now(UTC).replace(tzinfo=None)
        with self.session() as s:
            s.execute(delete(DrawingRow).where(DrawingRow.uploaded_at < now - DRAWING_KEEP))
            row = s.get(DrawingRow, key)
            if row is None:
                mine = s.scalars(
                    select(DrawingRow.key)
                    .where(DrawingRow.author == author)
                    .order_by(DrawingRow.uploaded_at.desc(), DrawingRow.key)
                ).all()
                forget = list(mine[DRAWINGS_PER_USER - 1 :])
                if forget:
                    s.execute(delete(DrawingRow).where(DrawingRow.key.in_(forget)))
                self._room_for(s, len(data), now)
                s.add(
                    DrawingRow(
                        key=key, name=name[:NAME_LENGTH], data=data, uploaded_at=now, author=author
                    )
                )
            else:
                row.uploaded_at = now
                row.name = name[:NAME_LENGTH]
        return key

    def _room_for(self, s: Session, size: int, now: datetime) -> None:
        """Raise DrawingsFull when `size` more bytes would pass DRAWING_BYTES_IN_ALL."""
        kept = s.scalar(select(func.coalesce(func.sum(func.length(DrawingRow.data)), 0)))
        if int(kept or 0) + size <= DRAWING_BYTES_IN_ALL:
            return
        oldest = s.scalar(select(func.min(DrawingRow.uploaded_at)))
        when = f"{(oldest or now) + DRAWING_KEEP:%Y-%m-%d %H:%M} UTC"
        raise DrawingsFull(
            f"the server keeps at most {DRAWING_BYTES_IN_ALL // (1024 * 1024)} MB of uploaded "
            f"drawings and has {int(kept or 0) / (1024 * 1024):.1f} MB; each is kept a day, "
            f"so room comes back at {when}; open the drawing again then"
        )

    def drawing(self, key: str) -> tuple[str, bytes]:
        """(name, data) of the drawing `key`; NotFound when there is none (or it expired)."""
        with self.session() as s:
            row = s.get(DrawingRow, key) if DRAWING_KEY.fullmatch(key) else None
            if row is None:
                raise NotFound(
                    "no such drawing: it was never uploaded, or it is more than a day old; "
                    "upload it again"
                )
            return row.name, row.data

    def backup(self, out: BinaryIO) -> int:
        """Write the whole library as a zip of JSON documents (programs, machines and the
        crib's tools, each with every revision); returns the program count."""
        with self.session() as s:
            programs = s.scalars(select(ProgramRow).order_by(ProgramRow.id)).all()
            machines = s.scalars(select(MachineRow).order_by(MachineRow.name)).all()
            with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as archive:
                manifest: dict[str, Any] = {"format": BACKUP_FORMAT, "version": 1, "programs": []}
                for row in programs:
                    revisions: list[dict[str, Any]] = []
                    entry = {"id": row.id, "deleted": row.deleted_at is not None}
                    for rev in row.revisions:
                        name = f"programs/{row.id}/{rev.version}.json"
                        _write(archive, name, rev.document)
                        revisions.append(
                            {
                                "version": rev.version,
                                "file": name,
                                "author": rev.author,
                                "summary": rev.summary,
                                "created_at": rev.created_at.isoformat(),
                            }
                        )
                    manifest["programs"].append({**entry, "revisions": revisions})
                from app.storage.crib import backup_tools

                manifest["tools"] = backup_tools(s, lambda name, text: _write(archive, name, text))
                manifest["machines"] = [
                    {
                        "name": m.name,
                        "target": m.target,
                        "options": json.loads(m.options),
                        "serial": json.loads(m.serial),
                        "limits": json.loads(m.limits or "{}"),
                        "notes": m.notes,
                    }
                    for m in machines
                ]
                _write(archive, "manifest.json", json.dumps(manifest, indent=2, sort_keys=True))
            return len(programs)

    def restore_backup(self, source: BinaryIO | Path) -> int:
        """Add every program of a backup (with its revisions) as a new library entry,
        create or update its machines, and add its crib tools with their revisions (one
        whose number or name a tool in use has is added retired); returns the program
        count. All or nothing: the archive is read and checked whole first
        (app.storage.backup), then stored in one transaction, so a bad archive changes
        nothing (BackupError says what is wrong)."""
        from app.storage.backup import BackupError, read_backup

        backup = read_backup(source)
        now = _now()
        try:
            with self.session() as s:
                for entry in backup.programs:
                    first, last = entry.revisions[0], entry.revisions[-1]
                    row = ProgramRow(
                        **_columns(last.program),
                        version=last.version,
                        created_at=first.created_at,
                        updated_at=last.created_at,
                        updated_by=last.author,
                        deleted_at=now if entry.deleted else None,
                    )
                    PROGRAMS.add_restored(s, row, entry.revisions)
                for machine in backup.machines:
                    _store_machine(s, machine, now)
                from app.storage.crib import restore_tools

                restore_tools(s, backup.tools, now)
        except SQLAlchemyError as exc:
            raise BackupError(f"the backup could not be stored: {exc.__class__.__name__}") from None
        return len(backup.programs)


def _load(row: ProgramRow) -> Program:
    """A stored program's document. One the library can no longer open (stored before a
    limit existed) is a LibraryError naming the program, not a crash."""
    try:
        return _parse(row.document)
    except document.DocumentError as exc:
        raise LibraryError(f"program {row.id} ({row.name}) cannot be opened: {exc}") from None


# Parsed documents by their text, most recent last. A program is an immutable value, so the
# same text is the same Program: an edit reads the stored version (to edit it, and again for
# the revision summary) and then the version it saved, and parses none of them twice.
PARSED_DOCUMENTS = 16
_PARSED: Recent[Program] = Recent(PARSED_DOCUMENTS, lru=True)


def _parse(text: str) -> Program:
    """`document.loads(text)`, from the recent documents when it was read or written."""
    found = _PARSED.get(text)
    if found is None:
        found = document.loads(text)
        _PARSED.keep(text, found)
    return found


def _remember(text: str, program: Program) -> None:
    _PARSED.keep(text, program)


def _write(archive: zipfile.ZipFile, name: str, text: str) -> None:
    # A fixed date keeps the archive's bytes a function of its contents.
    info = zipfile.ZipInfo(name, date_time=(2000, 1, 1, 0, 0, 0))
    info.compress_type = zipfile.ZIP_DEFLATED
    archive.writestr(info, text)


def check_machine_text(machine: Machine) -> None:
    """Every string a machine profile stores meets the one text rule (app.cnc.text): its
    name (at most SHORT_NAME_LENGTH characters), notes (NOTES_LENGTH), target, and each
    name and text value of its options, serial settings and limits (SETTING_LENGTH each).
    The web form, the command line and a backup being restored store machines through
    this. Raises TextError naming the field (`serial, port`).

    The settings are kept as JSON, whose escapes (`\\u0000`) pass the database's own net
    (app.storage.db) and would come back as a NUL at the port or in the machines page."""
    check_text(machine.name, "machine name", SHORT_NAME_LENGTH)
    check_text(machine.notes, "notes", NOTES_LENGTH)
    check_text(machine.target, "target", SETTING_LENGTH)
    # A walk with a list, not recursion: limits may nest ([min, max]) as deep as JSON allows.
    pending: list[tuple[str, Any]] = [
        ("options", machine.options),
        ("serial", machine.serial),
        ("limits", machine.limits),
    ]
    while pending:
        field_name, value = pending.pop()
        if isinstance(value, str):
            check_text(value, field_name, SETTING_LENGTH)
        elif isinstance(value, dict):
            for key, item in value.items():
                check_text(str(key), f"{field_name}, a setting's name", SETTING_LENGTH)
                pending.append((f"{field_name}, {key}", item))
        elif isinstance(value, list):
            pending.extend((f"{field_name} [{n}]", item) for n, item in enumerate(value, start=1))


def check_machine(machine: Machine) -> None:
    """A machine profile as the machines form takes it: its text (check_machine_text), a
    target that exists, options that target takes, travel limits the machine model reads
    (app.cnc.machine.read_machine) and serial settings the line can use
    (`PortSettings.from_serial`, the rule a send reads them by). Saving a machine and
    restoring a backup go through this, so nothing is stored that only a later export or
    send would refuse.

    Raises TextError, or MachineSettingsError naming the field (`serial, baud`) and what
    is allowed."""
    from app.cnc.formats.targets import OptionError, targets
    from app.cnc.machine import MachineError, read_machine
    from app.dnc.settings import PortSettings, SettingsError

    check_machine_text(machine)
    target = targets().get(machine.target)
    if target is None:
        raise MachineSettingsError(
            "target", f"{machine.target!r} is not a target; targets: {', '.join(targets())}"
        )
    try:
        target.parse_options(machine.options)
    except OptionError as exc:
        raise MachineSettingsError("options", str(exc)) from None
    if machine.limits:
        try:
            read_machine(machine.limits)
        except MachineError as exc:
            raise MachineSettingsError("limits", str(exc)) from None
    try:
        PortSettings.from_serial(machine.serial, target=machine.target)
    except SettingsError as exc:
        # A fault of the machine's own target (a drawing) is the target field's, not serial's.
        own_target = exc.field == "target" and "target" not in machine.serial
        field = "target" if own_target else f"serial, {exc.field}" if exc.field else "serial"
        raise MachineSettingsError(field, str(exc)) from None


def _store_machine(s: Session, machine: Machine, now: datetime) -> None:
    """Create or update a machine profile by name, in transaction `s`. Raises TextError
    and MachineSettingsError (check_machine; the latter naming the machine)."""
    try:
        check_machine(machine)
    except MachineSettingsError as exc:
        raise MachineSettingsError(f"machine {machine.name!r}, {exc.field}", exc.detail) from None
    row = s.scalar(select(MachineRow).where(MachineRow.name == machine.name))
    if row is None:
        row = MachineRow(name=machine.name, created_at=now)
        s.add(row)
    row.target = machine.target
    row.options = json.dumps(machine.options, sort_keys=True)
    row.serial = json.dumps(machine.serial, sort_keys=True)
    row.limits = json.dumps(machine.limits, sort_keys=True)
    row.notes = machine.notes
    row.updated_at = now


def _machine(row: MachineRow) -> Machine:
    return Machine(
        row.name,
        row.target,
        json.loads(row.options),
        json.loads(row.serial),
        row.notes,
        json.loads(row.limits or "{}"),
    )


def open_library(url: str | None = None, seed_demo: bool = True, zone: tzinfo = UTC) -> Library:
    """The library at `url` (DATABASE_URL, else the SQLite default), migrated to head, with
    the demo programs added the first time it is opened (unless not `seed_demo`: then it
    never gets them); its messages state times in `zone`."""
    engine = open_engine(url)
    library = Library(engine, zone)
    # Workers starting together: one migrates and seeds, the others wait, then find both
    # done (migrating twice fails: "table alembic_version already exists").
    with migration_lock(engine):
        upgrade(engine)
        from app.storage.demo import decline, seed

        if seed_demo:
            seed(library)
        else:
            decline(library)
    return library
