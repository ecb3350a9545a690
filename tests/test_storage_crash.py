"""Crash safety: a writer killed with SIGKILL mid-save, many times, loses nothing it
acknowledged and leaves a database that passes its integrity check."""

from __future__ import annotations

import random
import signal
import subprocess
import sys
from pathlib import Path

from sqlalchemy import text

from app.cnc import document
from app.storage.library import open_library
from tests.test_storage import GOLDEN

ROOT = Path(__file__).parent.parent


def test_killed_writer_loses_no_acknowledged_save(database_url: str) -> None:
    library = open_library(database_url, seed_demo=False)
    program = document.loads((GOLDEN / "bolt-circle-drill" / "program.json").read_text())
    program_id = library.create(program).id
    acknowledged: set[int] = {1}
    chance = random.Random(1704)
    for _ in range(12):
        writer = subprocess.Popen(
            [sys.executable, "-m", "tests.crash_writer", database_url, str(program_id)],
            cwd=ROOT,
            stdout=subprocess.PIPE,
            text=True,
        )
        assert writer.stdout is not None
        wanted = chance.randint(1, 6)
        for line in writer.stdout:
            acknowledged.add(int(line.split()[1]))
            wanted -= 1
            if wanted == 0:
                break
        writer.send_signal(signal.SIGKILL)
        writer.wait()
        writer.stdout.close()
        stored = library.get(program_id)
        versions = {r.version for r in library.revisions(program_id)}
        assert acknowledged <= versions, f"lost {sorted(acknowledged - versions)}"
        assert stored.info.version == max(versions)
        assert versions == set(range(1, max(versions) + 1))
        assert stored.program == library.revision(program_id, stored.info.version)
    if database_url.startswith("sqlite"):
        with library.engine.connect() as conn:
            assert conn.execute(text("PRAGMA integrity_check")).scalar() == "ok"
    library.engine.dispose()
