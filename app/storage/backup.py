"""Reading a backup archive (the zip `Library.backup` writes), whole and checked, before
anything is stored.

`read_backup` validates the manifest field by field (naming the program, tool, revision or
machine and the field at fault), reads every revision as a program document (a crib
tool's as a tool the crib can keep), and inflates
no member past `MAX_MEMBER_BYTES` nor the archive past `MAX_TOTAL_BYTES`, counting the
bytes it actually inflates (a zip's stated sizes are only the archive's claim). Anything
wrong raises `BackupError`; `Library.restore_backup` then stores everything in one
transaction, so a bad archive changes nothing.
"""

from __future__ import annotations

import json
import zipfile
import zlib
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any, BinaryIO

from app.cnc import document
from app.cnc.blocks import Program
from app.cnc.document import DocumentError
from app.cnc.text import NOTES_LENGTH, SHORT_NAME_LENGTH, TextError, text_fault
from app.cnc.tools import CribTool, tool_faults
from app.storage.crib import tool_from_document
from app.storage.library import (
    BACKUP_FORMAT,
    LibraryError,
    Machine,
    MachineSettingsError,
    check_machine,
)

MAX_MEMBER_BYTES = 16 * 1024 * 1024
"""One member (the manifest, one revision) inflated: far above any real document."""
MAX_TOTAL_BYTES = 512 * 1024 * 1024
"""All members inflated together."""
MAX_MEMBERS = 200_000
MB = 1024 * 1024


class BackupError(LibraryError):
    """An archive that is not a readable MillBlocks backup (the message says where)."""


@dataclass(frozen=True)
class Revision:
    version: int
    text: str
    program: Program
    author: str
    summary: str
    created_at: datetime


@dataclass(frozen=True)
class ProgramEntry:
    deleted: bool
    revisions: tuple[Revision, ...]


@dataclass(frozen=True)
class ToolRevision:
    """One saved version of a crib tool, as its document and read."""

    version: int
    text: str
    tool: CribTool
    author: str
    summary: str
    created_at: datetime


@dataclass(frozen=True)
class ToolEntry:
    """A crib tool of the backup with its revisions (retired or in use)."""

    retired: bool
    revisions: tuple[ToolRevision, ...]


@dataclass(frozen=True)
class Backup:
    programs: tuple[ProgramEntry, ...]
    machines: tuple[Machine, ...]
    tools: tuple[ToolEntry, ...] = ()


class _Reader:
    """Members of one archive, inflated under the limits."""

    def __init__(self, archive: zipfile.ZipFile) -> None:
        self.archive = archive
        self.total = 0
        if len(archive.infolist()) > MAX_MEMBERS:
            raise BackupError(f"the archive has more than {MAX_MEMBERS:,} files")

    def read(self, name: str) -> bytes:
        try:
            info = self.archive.getinfo(name)
        except KeyError:
            raise BackupError(f"{name} is missing from the archive") from None
        limit = min(MAX_MEMBER_BYTES, MAX_TOTAL_BYTES - self.total)
        if info.file_size > limit:
            raise BackupError(_too_big(name, info.file_size))
        try:
            with self.archive.open(info) as member:
                data = member.read(limit + 1)
        except (
            zipfile.BadZipFile,
            zlib.error,
            NotImplementedError,
            RuntimeError,
            OSError,
            EOFError,
        ) as exc:
            # A damaged or encrypted member, or one in a compression we do not read.
            raise BackupError(f"{name} cannot be read: {exc}") from None
        if len(data) > limit:
            raise BackupError(_too_big(name, len(data)))
        self.total += len(data)
        return data

    def text(self, name: str) -> str:
        try:
            return self.read(name).decode("utf-8")
        except UnicodeDecodeError as exc:
            raise BackupError(f"{name} is not UTF-8 text (byte {exc.start})") from None


def _too_big(name: str, size: int) -> str:
    return (
        f"{name} inflates to more than {MAX_MEMBER_BYTES // MB} MB (at least {size // MB} MB); "
        f"a backup member is at most {MAX_MEMBER_BYTES // MB} MB and a backup at most "
        f"{MAX_TOTAL_BYTES // MB} MB"
    )


def read_backup(source: BinaryIO | Path) -> Backup:
    """The whole backup, checked. Raises BackupError naming what is wrong (`cannot read
    the backup: manifest, program 2, revision 1, version: …`)."""
    try:
        return _read(source)
    except BackupError as exc:
        raise BackupError(f"cannot read the backup: {exc}") from None


def _read(source: BinaryIO | Path) -> Backup:
    try:
        with zipfile.ZipFile(source) as archive:
            reader = _Reader(archive)
            try:
                manifest = json.loads(reader.text("manifest.json"))
            except (json.JSONDecodeError, RecursionError) as exc:
                raise BackupError(f"manifest.json is not valid JSON: {exc}") from None
            return _backup(reader, manifest)
    except zipfile.BadZipFile as exc:
        raise BackupError(f"not a zip archive: {exc}") from None
    except NotImplementedError as exc:  # a zip "version needed" or method we do not read
        raise BackupError(f"a zip archive MillBlocks cannot read: {exc}") from None
    except (OSError, EOFError, ValueError) as exc:
        if isinstance(exc, BackupError):
            raise
        raise BackupError(f"cannot read the archive: {exc}") from None


def _backup(reader: _Reader, manifest: Any) -> Backup:
    if not isinstance(manifest, dict) or manifest.get("format") != BACKUP_FORMAT:
        raise BackupError(f'not a MillBlocks backup (manifest "format" is not {BACKUP_FORMAT})')
    if manifest.get("version") != 1:
        raise BackupError(f"backup version {manifest.get('version')!r} is not 1")
    programs = _list(manifest, "programs", "manifest")
    machines = _list(manifest, "machines", "manifest", required=False)
    tools = _list(manifest, "tools", "manifest", required=False)  # backups before the crib
    return Backup(
        tuple(_program(reader, entry, n) for n, entry in enumerate(programs, start=1)),
        tuple(_machine(entry, n) for n, entry in enumerate(machines, start=1)),
        tuple(_tool(reader, entry, n) for n, entry in enumerate(tools, start=1)),
    )


def _tool(reader: _Reader, entry: Any, number: int) -> ToolEntry:
    """A crib tool's entry: each revision a tool the crib can keep."""
    where = f"manifest, tool {number}"
    if not isinstance(entry, dict):
        raise BackupError(f"{where}: expected an object")
    retired = entry.get("retired", False)
    if not isinstance(retired, bool):
        raise BackupError(f"{where}, retired: expected true or false")
    revisions = _list(entry, "revisions", where)
    if not revisions:
        raise BackupError(f"{where}: no revisions; every tool has at least one")
    read = []
    for k, rev in enumerate(revisions, start=1):
        at = f"{where}, revision {k}"
        version, file, created, author, summary = _revision_fields(rev, at)
        text = reader.text(file)
        try:
            tool = tool_from_document(text, f"{at} ({file})")
        except (DocumentError, json.JSONDecodeError, RecursionError) as exc:
            raise BackupError(f"{at} ({file}): {exc}") from None
        faults = tool_faults(tool)
        if faults:
            label, message = faults[0]
            raise BackupError(f"{at} ({file}), {label}: {message}")
        read.append(ToolRevision(version, text, tool, author, summary, created))
    versions = [r.version for r in read]
    if versions != sorted(set(versions)):
        raise BackupError(f"{where}: revision versions {versions} are not increasing and unique")
    return ToolEntry(retired, tuple(read))


def _program(reader: _Reader, entry: Any, number: int) -> ProgramEntry:
    where = f"manifest, program {number}"
    if not isinstance(entry, dict):
        raise BackupError(f"{where}: expected an object")
    deleted = entry.get("deleted", False)
    if not isinstance(deleted, bool):
        raise BackupError(f"{where}, deleted: expected true or false")
    revisions = _list(entry, "revisions", where)
    if not revisions:
        raise BackupError(f"{where}: no revisions; every program has at least one")
    read = tuple(
        _revision(reader, rev, f"{where}, revision {k}") for k, rev in enumerate(revisions, start=1)
    )
    versions = [r.version for r in read]
    if versions != sorted(set(versions)):
        raise BackupError(f"{where}: revision versions {versions} are not increasing and unique")
    return ProgramEntry(deleted, read)


def _revision_fields(rev: Any, where: str) -> tuple[int, str, datetime, str, str]:
    """A revision's version, file, time, author and summary from the manifest."""
    if not isinstance(rev, dict):
        raise BackupError(f"{where}: expected an object")
    version = rev.get("version")
    if isinstance(version, bool) or not isinstance(version, int) or not 1 <= version < 2**31:
        raise BackupError(f"{where}, version: expected a whole number from 1, got {version!r}")
    file = _string(rev, "file", where)
    try:
        created = datetime.fromisoformat(_string(rev, "created_at", where))
    except ValueError:
        raise BackupError(f"{where}, created_at: not a date and time") from None
    author = _string(rev, "author", where, "")[:SHORT_NAME_LENGTH]
    return version, file, created.replace(tzinfo=None), author, _string(rev, "summary", where, "")


def _revision(reader: _Reader, rev: Any, where: str) -> Revision:
    version, file, created, author, summary = _revision_fields(rev, where)
    text = reader.text(file)
    try:
        program = document.loads(text)
    except document.DocumentError as exc:
        raise BackupError(f"{where} ({file}): {exc}") from None
    return Revision(version, text, program, author, summary, created)


def _machine(entry: Any, number: int) -> Machine:
    where = f"manifest, machine {number}"
    if not isinstance(entry, dict):
        raise BackupError(f"{where}: expected an object")
    name = _string(entry, "name", where, limit=SHORT_NAME_LENGTH).strip()
    if not name:
        raise BackupError(f"{where}, name: 1 to {SHORT_NAME_LENGTH} characters")
    options = _mapping(entry, "options", where)
    if not all(isinstance(v, str) for v in options.values()):
        raise BackupError(f"{where}, options: every value is text")
    machine = Machine(
        name,
        _string(entry, "target", where),
        options,
        _mapping(entry, "serial", where),
        _string(entry, "notes", where, "", limit=NOTES_LENGTH),
        _mapping(entry, "limits", where, required=False),
    )
    try:
        # The one check saving a machine goes through: a serial port with a NUL, or a baud
        # of "abc", was restored, and only a send refused it.
        check_machine(machine)
    except (TextError, MachineSettingsError) as exc:
        raise BackupError(f"{where} ({name}), {exc}") from None
    return machine


def _list(data: dict[str, Any], key: str, where: str, required: bool = True) -> list[Any]:
    value = data.get(key, None if required else [])
    if not isinstance(value, list):
        raise BackupError(f"{where}, {key}: expected a list")
    return value


def _mapping(data: dict[str, Any], key: str, where: str, required: bool = True) -> dict[str, Any]:
    value = data.get(key, None if required else {})
    if not isinstance(value, dict) or not all(isinstance(k, str) for k in value):
        raise BackupError(f"{where}, {key}: expected an object")
    return value


def _string(
    data: dict[str, Any], key: str, where: str, default: str | None = None, limit: int | None = None
) -> str:
    """Text that meets the one text rule (app.cnc.text), at most `limit` characters."""
    value = data.get(key, default)
    if not isinstance(value, str):
        raise BackupError(f"{where}, {key}: expected text")
    fault = text_fault(value, limit)
    if fault:
        raise BackupError(f"{where}, {key}: {fault}")
    return value
