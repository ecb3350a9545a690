"""Any number of workers can start on an empty database (issue 17, defect 8).

gunicorn's workers each open the library, so each migrates and seeds the demo set. Four
processes released together on an empty database must all start, and leave one schema at
head and one demo set. Real processes, a real SQLite file and a real PostgreSQL.
"""

from __future__ import annotations

import multiprocessing
import traceback
from pathlib import Path

from sqlalchemy import text

from app.storage.db import make_engine
from app.storage.demo import demo_programs

WORKERS = 4
TRIALS = 40


def _start(url: str, barrier: multiprocessing.synchronize.Barrier, results: object) -> None:
    from app.storage.library import open_library

    barrier.wait(timeout=60)
    try:
        library = open_library(url)
        library.engine.dispose()
        results.put("ok")  # type: ignore[attr-defined]
    except Exception:
        results.put(traceback.format_exc(limit=3))  # type: ignore[attr-defined]


def test_workers_started_together_on_an_empty_database_all_start(database_url: str) -> None:
    context = multiprocessing.get_context("spawn")
    barrier = context.Barrier(WORKERS)
    results = context.Queue()
    workers = [
        context.Process(target=_start, args=(database_url, barrier, results))
        for _ in range(WORKERS)
    ]
    for worker in workers:
        worker.start()
    outcomes = [results.get(timeout=120) for _ in workers]
    for worker in workers:
        worker.join(timeout=60)
    assert outcomes == ["ok"] * WORKERS, "\n".join(o for o in outcomes if o != "ok")
    engine = make_engine(database_url)
    with engine.connect() as conn:
        assert conn.execute(text("select count(*) from alembic_version")).scalar() == 1
        programs = conn.execute(text("select count(*) from programs")).scalar()
    engine.dispose()
    assert programs == len(demo_programs())


def _connect(url: str, barrier: multiprocessing.synchronize.Barrier, results: object) -> None:
    barrier.wait(timeout=60)
    try:
        engine = make_engine(url)
        with engine.begin() as connection:  # and writes, as the first to open it migrates
            connection.execute(text("CREATE TABLE IF NOT EXISTS opened (at INTEGER)"))
            connection.execute(text("INSERT INTO opened VALUES (1)"))
        engine.dispose()
        results.put("ok")  # type: ignore[attr-defined]
    except Exception as exc:
        results.put(" ".join(str(exc).splitlines()[:2]))  # type: ignore[attr-defined]


def test_connections_opened_together_on_a_new_sqlite_file_all_open(tmp_path: Path) -> None:
    """SQLite answers `PRAGMA journal_mode=WAL` with "database is locked" at once, without
    its busy timeout, while another connection converts the same new file: one of four
    processes opening a new library together (and writing, as the first to open it
    migrates) failed about one time in four (CI: a worker of the test above, "SQLite cannot
    open the file (database is locked)"). Forked processes, so that each trial costs
    little; a new file each trial."""
    context = multiprocessing.get_context("fork")
    failures = []
    for trial in range(TRIALS):
        url = f"sqlite:///{tmp_path / f'library-{trial}.db'}"
        barrier = context.Barrier(WORKERS)
        results = context.Queue()
        workers = [
            context.Process(target=_connect, args=(url, barrier, results)) for _ in range(WORKERS)
        ]
        for worker in workers:
            worker.start()
        outcomes = [results.get(timeout=120) for _ in workers]
        for worker in workers:
            worker.join(timeout=60)
        failures += [f"trial {trial}: {o}" for o in outcomes if o != "ok"]
    assert not failures, "\n".join(failures)
