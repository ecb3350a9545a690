"""A library command starts at once (issue 31): opening a library that is already at this
MillBlocks' schema loads no Alembic, and the library loads what an operation needs when it
runs. Real processes on a real SQLite file and a real PostgreSQL.

Before: `millblocks export "Rectangular pocket" --to gcode-linuxcnc` imported Alembic (and
through it Mako and Pygments) and ran an Alembic upgrade that had nothing to do, on every
command: about 1.1 s of CPU where a file's export takes 0.3 s.
"""

from __future__ import annotations

from pathlib import Path

from alembic.script import ScriptDirectory

from app.resources import data_dir
from app.storage.db import current, head, make_engine, upgrade
from app.storage.library import open_library
from tests.test_cli import whole_process

MIGRATION_ONLY = {"alembic", "mako", "pygments"}
"""What only a migration (or a schema history) needs."""


def _run(args: list[str], database_url: str, tmp_path: Path) -> tuple[str, set[str]]:
    """A whole `millblocks ARGS` process on `database_url`: its standard output and the
    modules it had imported when it exited."""
    env = {
        "MILLBLOCKS_DATABASE_URL": database_url,
        "MILLBLOCKS_INSTANCE_PATH": str(tmp_path / "instance"),
    }
    out, modules, _ = whole_process(args, env)
    return out, modules


def _tops(modules: set[str]) -> set[str]:
    return {name.split(".")[0] for name in modules}


def test_a_library_export_loads_no_migration_code(database_url: str, tmp_path: Path) -> None:
    """The README's example, on a library already at head: the G-code comes out, and
    neither Alembic nor Mako was imported to check the schema."""
    open_library(database_url).engine.dispose()  # migrated and seeded, as `db upgrade` does
    out, loaded = _run(
        ["export", "Rectangular pocket", "--to", "gcode-linuxcnc"], database_url, tmp_path
    )
    assert out.startswith("%\n(RECTANGULAR POCKET")
    assert MIGRATION_ONLY & _tops(loaded) == set()


def test_listing_the_library_loads_no_export_diff_or_transfer_code(
    database_url: str, tmp_path: Path
) -> None:
    """`millblocks list` reads rows: no migration, no target's writer, no diff, no DNC."""
    open_library(database_url).engine.dispose()
    out, loaded = _run(["list"], database_url, tmp_path)
    assert "Rectangular pocket" in out
    assert (MIGRATION_ONLY | {"ezdxf", "serial"}) & _tops(loaded) == set()
    assert [
        name for name in loaded if name.startswith(("app.cnc.formats", "app.cnc.diff", "app.dnc"))
    ] == []


def test_an_older_database_is_still_migrated_when_opened(database_url: str) -> None:
    """Skipping Alembic at head must not skip it below head: a database a step behind is
    brought up by the next command, as before."""
    engine = make_engine(database_url)
    upgrade(engine, "0009")
    assert current(engine) == "0009"
    engine.dispose()
    library = open_library(database_url, seed_demo=False)
    assert current(library.engine) == head()
    library.engine.dispose()


def test_the_head_constant_is_alembics_head() -> None:
    """HEAD, which the start-up check compares with, is the newest migration Alembic finds
    (a new migration without HEAD moved on fails here, not in a shop)."""
    from app.storage.db import HEAD

    assert HEAD == head() == ScriptDirectory(str(data_dir("migrations"))).get_current_head()
