"""The library on a real SQLite file and a real PostgreSQL (pg_virtualenv in `make test`).

Every test runs on both databases (the `database_url` fixture in conftest.py).
"""

from __future__ import annotations

import io
from collections.abc import Iterator
from dataclasses import replace
from decimal import Decimal as D
from pathlib import Path

import pytest
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import Engine, inspect, text

from app.cnc import document
from app.cnc.blocks import Hole, Program, Stock
from app.storage.db import downgrade, make_engine, upgrade
from app.storage.demo import demo_programs
from app.storage.library import Library, LibraryError, Machine, NotFound, StaleSave, open_library
from app.storage.models import Base

GOLDEN = Path(__file__).parent / "golden"


@pytest.fixture
def library(database_url: str) -> Iterator[Library]:
    lib = open_library(database_url, seed_demo=False)
    yield lib
    lib.engine.dispose()


def program(name: str = "bolt-circle-drill") -> Program:
    return document.loads((GOLDEN / name / "program.json").read_text())


# -- migrations -----------------------------------------------------------------------------


def tables(engine: Engine) -> set[str]:
    return set(inspect(engine).get_table_names()) - {"alembic_version"}


def test_upgrade_head_on_an_empty_database(database_url: str) -> None:
    engine = make_engine(database_url)
    upgrade(engine)
    assert tables(engine) == {
        "programs",
        "revisions",
        "machines",
        "settings",
        "users",
        "login_attempts",
        "transfer_log",
        "sessions",
        "drawings",
        "crib_tools",
        "crib_revisions",
    }
    engine.dispose()


def test_downgrade_and_upgrade_round_trip(database_url: str) -> None:
    engine = make_engine(database_url)
    upgrade(engine)
    downgrade(engine, "base")
    assert tables(engine) == set()
    upgrade(engine)
    assert tables(engine) == {
        "programs",
        "revisions",
        "machines",
        "settings",
        "users",
        "login_attempts",
        "transfer_log",
        "sessions",
        "drawings",
        "crib_tools",
        "crib_revisions",
    }
    engine.dispose()


def test_models_and_migrations_agree(database_url: str) -> None:
    """Autogenerate finds no difference between the migrated database and the models."""
    engine = make_engine(database_url)
    upgrade(engine)
    with engine.connect() as conn:
        differences = compare_metadata(MigrationContext.configure(conn), Base.metadata)
    assert differences == []
    engine.dispose()


def test_every_entry_point_migrates_by_itself(database_url: str) -> None:
    lib = open_library(database_url)
    assert len(lib.programs()) == len(demo_programs()) >= 3
    lib.engine.dispose()
    again = open_library(database_url)  # no second demo set
    assert len(again.programs()) == len(demo_programs())
    again.engine.dispose()


def test_a_library_started_without_the_demo_programs_never_gets_them(database_url: str) -> None:
    """MILLBLOCKS_DEMO_PROGRAMS=0: "a new library starts empty". Failed before: the next
    command run without the setting (an admin's `millblocks user list`) added the six demo
    programs to the shop's library, and so did opening a restored dump of it."""
    lib = open_library(database_url, seed_demo=False)
    assert lib.programs() == []
    lib.engine.dispose()
    again = open_library(database_url)  # the default: demo programs on
    assert again.programs() == []
    again.engine.dispose()


def test_sqlite_runs_wal_with_foreign_keys_and_full_sync(tmp_path: Path) -> None:
    engine = make_engine(f"sqlite:///{tmp_path / 'x.db'}")
    with engine.connect() as conn:
        assert conn.execute(text("PRAGMA journal_mode")).scalar() == "wal"
        assert conn.execute(text("PRAGMA foreign_keys")).scalar() == 1
        assert conn.execute(text("PRAGMA synchronous")).scalar() == 2  # FULL
    engine.dispose()


# -- programs -------------------------------------------------------------------------------


def test_create_get_and_revisions(library: Library) -> None:
    info = library.create(program(), author="ana")
    stored = library.get(info.id)
    assert stored.program == program()
    assert stored.info.version == 1
    assert [(r.version, r.author) for r in library.revisions(info.id)] == [(1, "ana")]


def test_save_records_a_revision_with_a_summary(library: Library) -> None:
    info = library.create(program(), author="ana")
    changed = replace(program(), blocks=program().blocks[:1])
    saved = library.save(info.id, changed, based_on=1, author="ben")
    assert saved.version == 2
    revisions = library.revisions(info.id)
    assert [r.version for r in revisions] == [1, 2]
    assert revisions[1].author == "ben"
    assert revisions[1].summary == "block 2 BOLT CIR DRILL deleted (old numbering)"


def test_a_change_of_stock_alone_is_described_in_the_history(library: Library) -> None:
    """Saving a new stock (the Verify page's form, or `stock` in the document) was recorded as
    "saved without changes"."""
    info = library.create(program())
    four = Stock(x=D("0.5"), y=D("0.5"), xl=D(4), yw=D(3), zh=D(1))
    library.save(info.id, replace(program(), stock=four), based_on=1)
    library.save(info.id, replace(program(), stock=replace(four, zh=D("0.750"))), based_on=2)
    library.save(info.id, replace(program(), notes="face first"), based_on=3)
    assert [r.summary for r in library.revisions(info.id)][1:] == [
        "stock: none (sized from the program's extent) → 4 × 3 × 1 in at X 0.5, Y 0.5, Z TOP 0",
        "stock: 4 × 3 × 1 in at X 0.5, Y 0.5, Z TOP 0 → 4 × 3 × 0.75 in at X 0.5, Y 0.5, Z TOP 0",
        "notes: '' → 'face first'; "
        "stock: 4 × 3 × 0.75 in at X 0.5, Y 0.5, Z TOP 0 → none (sized from the program's extent)",
    ]


def test_stale_save_is_refused_and_nothing_is_lost(library: Library) -> None:
    """Two people open version 1; the second save is refused with what changed."""
    info = library.create(program(), author="ana")
    first = library.get(info.id)
    second = library.get(info.id)
    hole = first.program.blocks[0]
    assert isinstance(hole, Hole)
    ana = replace(first.program, blocks=(replace(hole, z_dn=D("-0.4")), *first.program.blocks[1:]))
    library.save(info.id, ana, based_on=first.info.version, author="ana")
    ben = replace(second.program, name="Ben's name")
    with pytest.raises(StaleSave) as refused:
        library.save(info.id, ben, based_on=second.info.version, author="ben")
    message = str(refused.value)
    assert message.startswith(f"not saved: ana saved program {info.id} at ")
    assert "(version 2) after the version 1 you started from" in message
    assert "block 1 DRILL: Z DN -0.3 → -0.4" in message
    assert "nothing was overwritten" in message
    stored = library.get(info.id)
    assert stored.program == ana and stored.info.version == 2
    assert [r.version for r in library.revisions(info.id)] == [1, 2]


def test_rename_duplicate_trash_restore_purge(library: Library) -> None:
    info = library.create(program())
    library.rename(info.id, "Flange", based_on=1)
    copy = library.duplicate(info.id, name="Flange B")
    assert {p.name for p in library.programs()} == {"Flange", "Flange B"}
    library.delete(info.id)
    assert [p.name for p in library.programs()] == ["Flange B"]
    assert [p.name for p in library.programs(trash=True)] == ["Flange"]
    with pytest.raises(NotFound):
        library.get(info.id)
    library.restore(info.id)
    assert library.get(info.id).program.name == "Flange"
    library.delete(copy.id)
    library.purge(copy.id)
    with pytest.raises(NotFound):
        library.get(copy.id, include_trash=True)
    with pytest.raises(LibraryError, match="a program needs a name"):
        library.rename(info.id, "  ", based_on=2)


def test_search_by_name_part_notes_and_content(library: Library) -> None:
    library.create(replace(program("bolt-circle-drill"), name="Flange", notes="customer A"))
    library.create(replace(program("frame-pocket"), name="Pocket plate", part_number="7"))
    library.create(replace(program("tap-inch"), name="Tapped block"))
    assert [p.name for p in library.programs("flange")] == ["Flange"]
    assert [p.name for p in library.programs("customer")] == ["Flange"]
    assert [p.name for p in library.programs("frame")] == ["Pocket plate"]
    assert [p.name for p in library.programs("tap t3")] == ["Tapped block"]
    assert [p.name for p in library.programs("bolt_cir")] == ["Flange"]
    assert [p.name for p in library.programs("", sort="name")] == [
        "Flange",
        "Pocket plate",
        "Tapped block",
    ]
    with pytest.raises(LibraryError, match="cannot sort by 'size'"):
        library.programs(sort="size")


def test_restore_revision_and_diff(library: Library) -> None:
    info = library.create(program())
    two = replace(program(), name="two")
    library.save(info.id, two, based_on=1)
    library.restore_revision(info.id, 1, based_on=2)
    assert library.get(info.id).program == program()
    assert [r.version for r in library.revisions(info.id)] == [1, 2, 3]
    assert library.diff(info.id, 1, 2) == ["name: 'bolt-circle-drill' → 'two'"]


def test_find_by_id_or_name(library: Library) -> None:
    info = library.create(replace(program(), name="Flange"))
    assert library.find(str(info.id)).info.id == info.id
    assert library.find("Flange").info.id == info.id
    library.create(replace(program(), name="Flange"))
    with pytest.raises(LibraryError, match="2 programs are named 'Flange'"):
        library.find("Flange")


def test_machines(library: Library) -> None:
    mill = Machine("Bridgeport 1704", "tape-eia", {"sequence": "yes"}, {"baud": 4800})
    library.save_machine(mill)
    library.save_machine(replace(mill, notes="bay 3"))
    assert library.machines() == [replace(mill, notes="bay 3")]
    library.delete_machine("Bridgeport 1704")
    assert library.machines() == []


def test_backup_and_restore(library: Library, tmp_path: Path) -> None:
    info = library.create(program(), author="ana")
    library.save(info.id, replace(program(), name="v2"), based_on=1, author="ben")
    library.save_machine(Machine("Plus", "events", {}, {"baud": 4800}))
    archive = io.BytesIO()
    assert library.backup(archive) == 1
    archive.seek(0)
    other = open_library(f"sqlite:///{tmp_path / 'other.db'}", seed_demo=False)
    assert other.restore_backup(archive) == 1
    [restored] = other.programs()
    assert other.get(restored.id).program == replace(program(), name="v2")
    assert [(r.version, r.author) for r in other.revisions(restored.id)] == [(1, "ana"), (2, "ben")]
    assert [m.name for m in other.machines()] == ["Plus"]
    other.engine.dispose()


def test_bad_backup_changes_nothing(library: Library) -> None:
    library.create(program())
    with pytest.raises(LibraryError, match="cannot read the backup"):
        library.restore_backup(io.BytesIO(b"not a zip"))
    assert len(library.programs()) == 1
