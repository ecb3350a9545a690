"""Engines and migrations: where the library lives and how it is brought up to date.

The default database is an SQLite file, `instance/millblocks.db` under the project folder
(override with DATABASE_URL, e.g. `postgresql+psycopg://user@host/millblocks`). SQLite runs
with WAL, foreign keys on and synchronous FULL: an acknowledged save survives a crash.
`upgrade()` runs the committed Alembic migrations; every entry point calls it first,
inside `migration_lock()`, so any number of workers may start on an empty database: the
first migrates (and seeds), the others wait for it and then find nothing left to do.

Alembic (with Mako and Pygments under it, a quarter of a second) is imported only to run a
migration or to read the migrations' history: a database already at `HEAD` is told apart
by one query of its version table, so a command on an up-to-date library starts at once.
"""

from __future__ import annotations

import fcntl
import os
import re
import sqlite3
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

from sqlalchemy import Engine, create_engine, event, inspect, text
from sqlalchemy.exc import ArgumentError, DBAPIError, NoSuchModuleError

from app.cnc.text import check_text
from app.resources import data_dir
from app.settings import instance_folder

if TYPE_CHECKING:
    from alembic.config import Config

HEAD = "0010"
"""The newest schema revision this MillBlocks knows: the revision of the newest file in
migrations/versions/ (tests/test_storage_start.py holds it to Alembic's own head, so a new
migration fails the tests until this moves with it). Opening a library compares the
database's revision with it instead of loading Alembic's script directory."""

VERSION_TABLE = "alembic_version"
"""Where Alembic keeps the database's revision (its default; migrations/env.py keeps it)."""


class SchemaError(RuntimeError):
    """A database this MillBlocks cannot use as it is (the message says what to do)."""


class DatabaseSettingError(SchemaError):
    """The database setting names a database MillBlocks cannot open as it is: not a URL, a
    kind of database it has no driver for, a password or user or database the server
    refuses, a SQLite file that cannot be opened. The message names the variable and never
    holds the password; restarting does not help (the command line exits 2, the server 4)."""


class DatabaseUnavailable(RuntimeError):
    """The database does not answer (PostgreSQL not started yet, restarting, the network; a
    SQLite file another process holds locked past the busy timeout): it may later, so a
    restart helps (the command line exits 1, the server 3). The message
    names the variable and never holds the password."""


def database_url(url: str | None = None) -> str:
    """The URL to use: the argument, else MILLBLOCKS_DATABASE_URL, else DATABASE_URL, else
    `millblocks.db` in the instance folder."""
    given = url or os.environ.get("MILLBLOCKS_DATABASE_URL") or os.environ.get("DATABASE_URL")
    if given:
        # Heroku-style postgres:// URLs name the old driver; psycopg 3 is what we ship.
        for scheme in ("postgres://", "postgresql://"):
            if given.startswith(scheme):
                return "postgresql+psycopg://" + given[len(scheme) :]
        return given
    return f"sqlite:///{instance_folder() / 'millblocks.db'}"


def database_variable(url: str | None = None) -> str:
    """The setting that chose the database `database_url(url)` opens, to name in a message:
    MILLBLOCKS_DATABASE_URL (also when a caller gave the URL), DATABASE_URL, or
    MILLBLOCKS_INSTANCE_PATH for the default SQLite file."""
    if url or os.environ.get("MILLBLOCKS_DATABASE_URL"):
        return "MILLBLOCKS_DATABASE_URL"
    return "DATABASE_URL" if os.environ.get("DATABASE_URL") else "MILLBLOCKS_INSTANCE_PATH"


_PASSWORD = re.compile(r"(://[^:/@]*:).*@")


def without_password(url: str) -> str:
    """`url` with the password of its `user:password@` replaced by `***` (also in text
    SQLAlchemy could not parse), to be written in a message or a log."""
    return _PASSWORD.sub(r"\1***@", url)


_REFUSED = ("password", "authentication", "does not exist", "pg_hba.conf", "permission denied")
"""PostgreSQL's refusals at login that a setting causes (FATAL: password authentication
failed, role or database does not exist, no pg_hba.conf entry); anything else at connection
(refused, timed out, starting up, too many clients) may pass."""


def open_engine(url: str | None = None) -> Engine:
    """`make_engine(url)` after one connection made and returned: raises
    DatabaseSettingError when the setting cannot work, DatabaseUnavailable when the
    database does not answer, each one line naming the variable, without the password."""
    variable = database_variable(url)
    shown = without_password(database_url(url))
    try:
        engine = make_engine(url)
        with engine.connect():
            pass
    except ArgumentError:
        raise DatabaseSettingError(
            f"{variable}: {shown!r} is not a database URL (such as "
            "postgresql+psycopg://USER:PASSWORD@HOST/DATABASE, or sqlite:////PATH/millblocks.db)"
        ) from None
    except (NoSuchModuleError, ImportError) as exc:
        raise DatabaseSettingError(
            f"{variable}: {shown}: MillBlocks cannot open this kind of database "
            f"({_first_line(exc)}); it uses PostgreSQL (postgresql+psycopg://…) or SQLite "
            "(sqlite:///…)"
        ) from None
    except DBAPIError as exc:
        if damage(exc) is not None:
            raise  # a damaged SQLite file: the command line says what to do (app.cli)
        said = _first_line(exc.orig or exc)
        if shown.startswith("sqlite") and "locked" in said:
            # Another process held it past the busy timeout: it may let go (as a server
            # that does not answer yet), and the folder is not at fault.
            raise DatabaseUnavailable(
                f"{variable}: {shown}: the database is busy: another process held it "
                f"locked for {SQLITE_BUSY_SECONDS} s ({said})"
            ) from None
        if shown.startswith("sqlite"):
            raise DatabaseSettingError(
                f"{variable}: {shown}: SQLite cannot open the file ({said}); its folder must "
                "exist and be writable by the user MillBlocks runs as"
            ) from None
        if "FATAL" in said and any(word in said for word in _REFUSED):
            raise DatabaseSettingError(f"{variable}: {shown}: the server refused: {said}") from None
        raise DatabaseUnavailable(
            f"{variable}: {shown}: the database does not answer: {said}"
        ) from None
    return engine


def _first_line(exc: BaseException) -> str:
    """An error's message on one line (psycopg's run over several)."""
    return " ".join(str(exc).split()) or type(exc).__name__


_DAMAGE = ("SQLITE_NOTADB", "SQLITE_CORRUPT")
"""SQLite's names for a file that is not a database or whose pages are damaged (the
extended codes, SQLITE_CORRUPT_INDEX and the like, begin the same)."""


def damage(exc: BaseException) -> str | None:
    """SQLite's own words ("file is not a database", "database disk image is malformed")
    when `exc` (a SQLAlchemy error) says the database file is damaged; None for any other
    error, which is not the file's fault (a lock, a full disk, PostgreSQL)."""
    original = getattr(exc, "orig", None)
    name = getattr(original, "sqlite_errorname", "")
    return str(original) if isinstance(name, str) and name.startswith(_DAMAGE) else None


def damaged_file(exc: BaseException, url: str | None = None) -> str | None:
    """What to say when `exc` says the SQLite file of `url` (see `database_url`) is damaged:
    the file, SQLite's words and what to do; None for any other error."""
    found = damage(exc)
    if found is None:
        return None
    from sqlalchemy.engine import make_url

    path = make_url(database_url(url)).database
    return (
        f"{path}: the database file is damaged (SQLite: {found}). Stop MillBlocks, move the "
        "file aside and restore from a backup: put back a copy of the file, or let "
        "MillBlocks create a new database and `millblocks restore ARCHIVE` an archive "
        "made with `millblocks backup` (docs/deploy.md, Backups)"
    )


SQLITE_BUSY_SECONDS = 30
"""How long a SQLite connection waits for another's lock (the busy timeout) before "database
is locked"."""


def make_engine(url: str | None = None) -> Engine:
    """An engine for `url` (see `database_url`), with SQLite's safety pragmas."""
    resolved = database_url(url)
    if resolved.startswith("sqlite"):
        engine = create_engine(resolved, connect_args={"timeout": SQLITE_BUSY_SECONDS})
        event.listen(engine, "connect", _sqlite_pragmas)
    else:
        engine = create_engine(resolved, pool_pre_ping=True)
    event.listen(engine, "before_cursor_execute", _text_rule)
    return engine


_BIND_NUMBER = re.compile(r"_\d+$")


def _text_rule(
    _conn: Any,
    _cursor: Any,
    _statement: str,
    parameters: Any,
    context: Any,
    _executemany: bool,
) -> None:
    """Every string a statement sends to the database, stored or looked up, meets the one
    text rule (app.cnc.text): a NUL or a lone surrogate is a TextError naming the column,
    not PostgreSQL's `ValueError` or an encoding error from the driver (a 500). The
    entries check their fields with their limits first; this is the net under them."""
    compiled = getattr(context, "compiled_parameters", None)
    rows = compiled if compiled else [parameters]
    for row in rows:
        items = row.items() if isinstance(row, dict) else enumerate(row or ())
        for key, value in items:
            if isinstance(value, str):
                check_text(value, _BIND_NUMBER.sub("", str(key)))


def _sqlite_pragmas(dbapi_connection: Any, _record: Any) -> None:
    cursor = dbapi_connection.cursor()
    _wal(cursor)
    cursor.execute("PRAGMA foreign_keys=ON")
    cursor.execute("PRAGMA synchronous=FULL")
    cursor.execute(f"PRAGMA busy_timeout={SQLITE_BUSY_SECONDS * 1000}")
    cursor.close()


def _wal(cursor: Any) -> None:
    """Put the database in WAL mode, waiting for other connections' locks as long as any
    statement does. SQLite answers this pragma with "database is locked" at once, without
    its busy timeout, while another connection converts or writes the same new file: one of
    four processes opening a new library together (gunicorn's workers, two commands) failed
    to start about one time in four (tests/test_migrate_lock.py)."""
    deadline = time.monotonic() + SQLITE_BUSY_SECONDS
    while True:
        try:
            cursor.execute("PRAGMA journal_mode=WAL")
            return
        except sqlite3.OperationalError as exc:
            if "locked" not in str(exc) or time.monotonic() > deadline:
                raise
            time.sleep(0.01)


MIGRATION_LOCK_KEY = 0x4D696C6C  # "Mill": the PostgreSQL advisory lock of migrations


@contextmanager
def migration_lock(engine: Engine) -> Iterator[None]:
    """Hold the database's migration lock while the block runs (blocking until it is free).

    PostgreSQL: a session-level advisory lock on a connection of its own (released when the
    block ends, or by the server if the process dies). SQLite: an exclusive `flock` on a
    file beside the database (released by the kernel if the process dies); an in-memory
    database is one process's own and needs none.
    """
    if engine.dialect.name == "postgresql":
        with engine.connect() as connection:
            connection.execute(text("SELECT pg_advisory_lock(:key)"), {"key": MIGRATION_LOCK_KEY})
            connection.commit()
            try:
                yield
            finally:
                connection.execute(
                    text("SELECT pg_advisory_unlock(:key)"), {"key": MIGRATION_LOCK_KEY}
                )
                connection.commit()
        return
    database = engine.url.database
    if engine.dialect.name != "sqlite" or not database or database == ":memory:":
        yield
        return
    with open(f"{database}.migrate-lock", "a+b") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def alembic_config(engine: Engine) -> Config:
    """An Alembic configuration for the project's migrations on `engine`."""
    from alembic.config import Config

    config = Config()
    # Alembic keeps its options in a ConfigParser, which reads % as interpolation: a
    # percent-encoded password (s3cr%40t) or a folder with a % in its name would stop every
    # `db` command with "invalid interpolation syntax". %% is a literal %.
    for option, value in (
        ("script_location", str(data_dir("migrations"))),
        ("sqlalchemy.url", engine.url.render_as_string(hide_password=False)),
    ):
        config.set_main_option(option, value.replace("%", "%%"))
    return config


def head() -> str:
    """The newest schema revision this MillBlocks knows (`HEAD`)."""
    return HEAD


def history() -> list[tuple[str, str]]:
    """Every schema revision this MillBlocks knows with what it does, oldest first (read
    from the migrations by Alembic)."""
    from alembic.script import ScriptDirectory

    walked = ScriptDirectory(str(data_dir("migrations"))).walk_revisions()
    return [(r.revision, (r.doc or "").splitlines()[0]) for r in reversed(list(walked))]


def revisions() -> list[str]:
    """Every schema revision this MillBlocks knows, oldest first."""
    return [revision for revision, _ in history()]


def current(engine: Engine) -> str | None:
    """The database's schema revision; None for an empty database (no version table, or
    one emptied by a downgrade to base). Raises SchemaError for a version table holding
    more than one revision (branched migrations: not this MillBlocks' schema)."""
    # What Alembic's MigrationContext.get_current_revision reads, without importing it.
    with engine.connect() as connection:
        if not inspect(connection).has_table(VERSION_TABLE):
            return None
        found = connection.execute(text(f"SELECT version_num FROM {VERSION_TABLE}")).scalars()
        rows = list(found)
    if len(rows) > 1:
        raise SchemaError(
            f"the database's {VERSION_TABLE} table holds {len(rows)} revisions "
            f"({', '.join(sorted(rows))}); MillBlocks' schema has one line of revisions"
        )
    return rows[0] if rows else None


def check_known(engine: Engine) -> str | None:
    """The database's revision, after refusing one this MillBlocks does not know: a newer
    MillBlocks migrated it (rolling the code back without the database), and Alembic would
    only say "Can't locate revision"."""
    found = current(engine)
    if found is not None and found != HEAD and found not in revisions():
        newest = head()
        raise SchemaError(
            f"the database's schema is at revision {found}, newer than this MillBlocks "
            f"(it knows up to {newest}): a newer MillBlocks upgraded it. Run this version "
            f"against a copy restored from before that upgrade, or run the newer version's "
            f"`millblocks db downgrade {newest}` first, then this one (docs/deploy.md, "
            '"Upgrade and roll back")'
        )
    return found


def upgrade(engine: Engine, revision: str = "head") -> None:
    """Bring the database up to `revision` (an empty or older database included). Raises
    SchemaError when the database is newer than this code."""
    found = check_known(engine)
    if found == HEAD and revision in ("head", HEAD):
        return  # nothing to do: Alembic would load every migration to find that out
    from alembic import command

    config = alembic_config(engine)
    with engine.begin() as connection:
        config.attributes["connection"] = connection
        command.upgrade(config, revision)


def undone(found: str | None, revision: str) -> list[tuple[str, str]]:
    """The migrations a downgrade from `found` to `revision` (an id, or `base`: empty)
    undoes, newest first. Raises SchemaError for a revision this MillBlocks does not know
    or one above `found`."""
    known = history()
    ids = [r for r, _ in known]
    if revision != "base" and revision not in ids:
        raise SchemaError(
            f"no schema revision {revision!r}; this MillBlocks knows {', '.join(ids)} "
            "(and base, an empty database)"
        )
    top = -1 if found is None else ids.index(found)
    bottom = -1 if revision == "base" else ids.index(revision)
    if bottom > top:
        raise SchemaError(
            f"the database is at {found or 'base (empty)'}, below {revision}: "
            "`millblocks db upgrade` goes up"
        )
    return list(reversed(known[bottom + 1 : top + 1]))


def downgrade(engine: Engine, revision: str) -> None:
    """Take the database down to `revision` (an id, or `base`: empty). What each undone
    migration created is dropped with its data. Raises SchemaError for a database newer than
    this code or a revision it does not know (see `undone`)."""
    undone(check_known(engine), revision)
    from alembic import command

    config = alembic_config(engine)
    with engine.begin() as connection:
        config.attributes["connection"] = connection
        command.downgrade(config, revision)
