"""SQLAlchemy 2 typed models of the library (the tables Alembic's migrations create)."""

from __future__ import annotations

from datetime import datetime

from sqlalchemy import (
    Boolean,
    ForeignKey,
    Index,
    Integer,
    LargeBinary,
    String,
    Text,
    UniqueConstraint,
    text,
)
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column, relationship


class Base(DeclarativeBase):
    """Declarative base; `Base.metadata` is what the migrations must match."""


class ProgramRow(Base):
    """A program in the library: its current document and bookkeeping.

    `version` counts saves; a save names the version it was based on (optimistic
    concurrency). `deleted_at` set means the program is in the trash. `search_text` holds
    the words a search matches beyond name, part number and notes (tools, block types).
    """

    __tablename__ = "programs"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(200))
    part_number: Mapped[str] = mapped_column(String(8), default="")
    notes: Mapped[str] = mapped_column(Text, default="")
    units: Mapped[str] = mapped_column(String(8))
    document: Mapped[str] = mapped_column(Text)
    search_text: Mapped[str] = mapped_column(Text, default="")
    block_count: Mapped[int] = mapped_column(Integer, default=0)
    version: Mapped[int] = mapped_column(Integer, default=1)
    created_at: Mapped[datetime]
    updated_at: Mapped[datetime]
    updated_by: Mapped[str] = mapped_column(String(100), default="")
    deleted_at: Mapped[datetime | None] = mapped_column(default=None)

    revisions: Mapped[list[RevisionRow]] = relationship(
        back_populates="program", cascade="all, delete-orphan", order_by="RevisionRow.version"
    )

    __table_args__ = (Index("ix_programs_name", "name"), Index("ix_programs_deleted", "deleted_at"))


class RevisionRow(Base):
    """Every save of a program: the whole document, when, by whom, what changed."""

    __tablename__ = "revisions"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    program_id: Mapped[int] = mapped_column(ForeignKey("programs.id", ondelete="CASCADE"))
    version: Mapped[int] = mapped_column(Integer)
    document: Mapped[str] = mapped_column(Text)
    created_at: Mapped[datetime]
    author: Mapped[str] = mapped_column(String(100), default="")
    summary: Mapped[str] = mapped_column(Text, default="")

    program: Mapped[ProgramRow] = relationship(back_populates="revisions")

    __table_args__ = (UniqueConstraint("program_id", "version", name="uq_revision_version"),)


class MachineRow(Base):
    """A machine profile: export target and options, serial port settings, and the
    machine itself (travel limits, collision zone, rates: app.cnc.machine.read_machine)."""

    __tablename__ = "machines"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(100), unique=True)
    target: Mapped[str] = mapped_column(String(40))
    options: Mapped[str] = mapped_column(Text, default="{}")
    serial: Mapped[str] = mapped_column(Text, default="{}")
    limits: Mapped[str] = mapped_column(Text, default="{}", server_default="{}")
    notes: Mapped[str] = mapped_column(Text, default="")
    created_at: Mapped[datetime]
    updated_at: Mapped[datetime]


class SettingRow(Base):
    """Library-wide facts, such as whether the demo programs were ever added."""

    __tablename__ = "settings"

    key: Mapped[str] = mapped_column(String(100), primary_key=True)
    value: Mapped[str] = mapped_column(Text, default="")


class UserRow(Base):
    """An account: programmer (edits), operator (views, exports, sends), admin (all, and
    users and machines). The password is kept only as a scrypt hash."""

    __tablename__ = "users"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    username: Mapped[str] = mapped_column(String(100), unique=True)
    password_hash: Mapped[str] = mapped_column(String(300))
    role: Mapped[str] = mapped_column(String(20))
    created_at: Mapped[datetime]


class SessionRow(Base):
    """A logged-in session. The browser's cookie holds a random id; only its SHA-256 is
    stored, so a copy of this table logs nobody in. Deleting the row ends the session:
    logout, a password or role change, an admin's "end sessions", the timeouts."""

    __tablename__ = "sessions"

    id: Mapped[str] = mapped_column(String(64), primary_key=True)
    user_id: Mapped[int] = mapped_column(ForeignKey("users.id", ondelete="CASCADE"))
    created_at: Mapped[datetime]
    last_seen: Mapped[datetime]
    address: Mapped[str] = mapped_column(String(100), default="")

    __table_args__ = (Index("ix_sessions_user", "user_id"),)


class LoginAttemptRow(Base):
    """A failed login, counted per account and address and per address for the login rate
    limit (shared by workers)."""

    __tablename__ = "login_attempts"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    address: Mapped[str] = mapped_column(String(100))
    username: Mapped[str] = mapped_column(String(100), default="")
    at: Mapped[datetime]

    __table_args__ = (Index("ix_login_attempts_address_at", "address", "at"),)


class TransferRow(Base):
    """One RS-232 transfer: what went over which port, when, how it ended.

    A running transfer's progress and a cancel asked for by another worker live here, so
    every web worker sees them. A receive keeps its raw capture (garbage included)."""

    __tablename__ = "transfer_log"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    direction: Mapped[str] = mapped_column(String(8))
    machine: Mapped[str] = mapped_column(String(200))
    port: Mapped[str] = mapped_column(String(200), default="")
    target: Mapped[str] = mapped_column(String(40), default="")
    settings: Mapped[str] = mapped_column(String(200), default="")
    bytes_done: Mapped[int] = mapped_column(Integer, default=0)
    bytes_total: Mapped[int | None] = mapped_column(Integer, default=None)
    started_at: Mapped[datetime]
    finished_at: Mapped[datetime | None] = mapped_column(default=None)
    # The last sign of life from the process running it: a row left "running" whose process
    # died (a restarted server) is shown as interrupted instead of polling forever.
    updated_at: Mapped[datetime | None] = mapped_column(default=None)
    outcome: Mapped[str] = mapped_column(String(12), default="running")
    error: Mapped[str] = mapped_column(Text, default="")
    report: Mapped[str] = mapped_column(Text, default="", server_default="")
    program_id: Mapped[int | None] = mapped_column(
        ForeignKey("programs.id", ondelete="SET NULL"), default=None
    )
    program_name: Mapped[str] = mapped_column(String(200), default="")
    author: Mapped[str] = mapped_column(String(100), default="")
    raw: Mapped[bytes | None] = mapped_column(LargeBinary, default=None)
    cancel_requested: Mapped[bool] = mapped_column(Boolean, default=False)
    # A send: the program's version, and the SHA-256 of the export (the program as the
    # control gets it, before the line's framing), so the shop can say what ran where.
    revision: Mapped[int | None] = mapped_column(Integer, default=None)
    checksum: Mapped[str] = mapped_column(String(64), default="", server_default="")
    # A restart: the data block the send began at (None: the whole program).
    start_block: Mapped[int | None] = mapped_column(Integer, default=None)

    __table_args__ = (Index("ix_transfer_log_started", "started_at"),)


class DrawingRow(Base):
    """A DXF drawing uploaded to choose blocks from (issue 22), kept while it is being
    chosen from: by content (`key`, the SHA-256 of `data`), so every web worker finds it
    and uploading the same file twice stores it once. Not part of backups; drawings older
    than a day are removed when another is uploaded."""

    __tablename__ = "drawings"

    key: Mapped[str] = mapped_column(String(64), primary_key=True)
    name: Mapped[str] = mapped_column(String(200))
    data: Mapped[bytes] = mapped_column(LargeBinary)
    uploaded_at: Mapped[datetime]
    author: Mapped[str] = mapped_column(String(100), default="")

    __table_args__ = (Index("ix_drawings_uploaded", "uploaded_at"),)


class CribToolRow(Base):
    """A tool of the shop's crib (app.cnc.tools.CribTool): its document (the tool's fields
    as JSON) and bookkeeping, as a program's. `number` and `name` are columns for lookups;
    among the tools in use (not retired) each number is one tool (a partial unique index)
    and each name one tool (checked on save, whatever the case). `version` counts saves; a
    save names the version it was based on. `deleted_at` set: retired (kept, with its
    revisions, for the programs that picked it)."""

    __tablename__ = "crib_tools"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    number: Mapped[int] = mapped_column(Integer)
    name: Mapped[str] = mapped_column(String(100))
    kind: Mapped[str] = mapped_column(String(20))
    document: Mapped[str] = mapped_column(Text)
    version: Mapped[int] = mapped_column(Integer, default=1)
    created_at: Mapped[datetime]
    updated_at: Mapped[datetime]
    updated_by: Mapped[str] = mapped_column(String(100), default="")
    deleted_at: Mapped[datetime | None] = mapped_column(default=None)

    revisions: Mapped[list[CribRevisionRow]] = relationship(
        back_populates="tool", cascade="all, delete-orphan", order_by="CribRevisionRow.version"
    )

    __table_args__ = (
        Index(
            "uq_crib_tools_number_in_use",
            "number",
            unique=True,
            sqlite_where=text("deleted_at IS NULL"),
            postgresql_where=text("deleted_at IS NULL"),
        ),
        Index("ix_crib_tools_name", "name"),
    )


class CribRevisionRow(Base):
    """Every save of a crib tool: the whole tool, when, by whom, what changed."""

    __tablename__ = "crib_revisions"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    tool_id: Mapped[int] = mapped_column(ForeignKey("crib_tools.id", ondelete="CASCADE"))
    version: Mapped[int] = mapped_column(Integer)
    document: Mapped[str] = mapped_column(Text)
    created_at: Mapped[datetime]
    author: Mapped[str] = mapped_column(String(100), default="")
    summary: Mapped[str] = mapped_column(Text, default="")

    tool: Mapped[CribToolRow] = relationship(back_populates="revisions")

    __table_args__ = (UniqueConstraint("tool_id", "version", name="uq_crib_revision_version"),)
