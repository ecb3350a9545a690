"""The transfer service and a database that goes away (issue 31, an audit of the installed
wheel): a fast PostgreSQL restart left a bare traceback and no `dnc` process, while the web
server kept serving and /healthz said ok. Now the service logs the outage with time and
level, tries again with a growing wait and carries on when the database is back; one that
dies anyway makes /healthz say unavailable.

Real processes (`millblocks dnc`), the suite's real PostgreSQL cluster (pg_virtualenv),
stopped and started with Debian's pg_ctlcluster, a socat pty pair and the simulated control.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import uuid
from collections.abc import Iterator
from datetime import datetime, timedelta
from pathlib import Path

import pytest
from sqlalchemy import create_engine, text

from app.cnc.formats.targets import export
from app.dnc.daemon import HEARTBEAT_KEY
from app.storage.library import Library, Machine, open_library
from app.storage.transfers import TransferLog
from app.web import create_app
from tests.conftest import postgres_admin_url
from tests.simulated_control import SimulatedControl, SocatPair
from tests.test_dnc_service import WAIT, Service, _until, pair
from tests.web_support import dispose

__all__ = ["pair"]  # the fixture, used by name

LINE = re.compile(
    r"^\d{4}-\d\d-\d\d \d\d:\d\d:\d\d ERROR app\.dnc\.daemon: the database does not answer "
    r"\(.+\); trying again in 1 s$",
    re.MULTILINE,
)
"""The service's line for the outage: the time, the level, the logger (docs/deploy.md, Logs)."""


def cluster(action: str) -> None:
    """`pg_ctlcluster VERSION NAME action -m fast` on the suite's cluster (the one PGPORT
    names)."""
    listed = subprocess.run(
        ["pg_lsclusters", "--no-header"], capture_output=True, text=True, check=True
    ).stdout
    port = os.environ.get("PGPORT", "5432")
    (version, name) = next(
        line.split()[:2] for line in listed.splitlines() if line.split()[2] == port
    )
    subprocess.run(["pg_ctlcluster", version, name, action, "-m", "fast"], check=True)


@pytest.fixture
def postgres_database() -> Iterator[str]:
    """A database of its own on the suite's cluster; the cluster running again after."""
    admin_url = postgres_admin_url()
    admin = create_engine(admin_url, isolation_level="AUTOCOMMIT")
    name = f"mb_{uuid.uuid4().hex[:12]}"
    with admin.connect() as conn:
        conn.execute(text(f'CREATE DATABASE "{name}"'))
    yield admin.url.set(database=name).render_as_string(hide_password=False)
    status = subprocess.run(["pg_lsclusters", "--no-header"], capture_output=True, text=True)
    if "online" not in status.stdout:
        cluster("start")
    admin.dispose()
    admin = create_engine(admin_url, isolation_level="AUTOCOMMIT")
    with admin.connect() as conn:
        conn.execute(text(f'DROP DATABASE "{name}" WITH (FORCE)'))
    admin.dispose()


def test_the_transfer_service_outlives_a_postgresql_restart(
    tmp_path: Path, pair: SocatPair, postgres_database: str
) -> None:
    library = open_library(postgres_database)
    library.save_machine(Machine("Plus", "events", {}, {"port": pair.host}))
    stored = min(library.programs(), key=lambda p: p.block_count)
    expected = export(library.get(stored.id).program, "events").data
    log = tmp_path / "dnc.log"
    with SimulatedControl(pair.control, parity="E", buffer_size=1 << 16) as control:
        service = Service(postgres_database, log).start()
        try:
            cluster("stop")
            _until("the service to meet the outage", lambda: "does not answer" in log.read_text())
            cluster("start")
            _until("the service to carry on", lambda: "answers again" in log.read_text())
            assert service.process is not None and service.process.poll() is None
            # A send queued now (as the web page does) is sent.
            transfers = TransferLog(library)
            row = transfers.begin(
                "send", "Plus", pair.host, "events", "ann", stored.id, stored.name, queued=True
            )
            assert control.received(expected, timeout=WAIT)
            _until("the log to say ok", lambda: transfers.get(row).outcome == "ok")
        finally:
            said = service.stop()
    assert LINE.search(said), said
    assert re.search(r"^\S+ \S+ WARNING app\.dnc\.daemon: the database answers again", said, re.M)
    assert "Traceback" not in said
    library.engine.dispose()


def age_heartbeat(library: Library) -> None:
    """The heartbeat as a minute from now would find it (no test waits for a clock)."""
    name, _, stamp = (library.setting(HEARTBEAT_KEY) or "").rpartition(" at ")
    earlier = datetime.fromisoformat(stamp) - timedelta(minutes=1)
    library.set_setting(HEARTBEAT_KEY, f"{name} at {earlier.isoformat()}")


def test_health_says_when_the_transfer_service_died(tmp_path: Path) -> None:
    """/healthz: ok with no service ever run and with one running; unavailable once the
    service is gone without being stopped (killed); ok again when one runs, and after one
    is stopped as asked."""
    database = f"sqlite:///{tmp_path / 'shop.db'}"
    app = create_app({"DATABASE_URL": database, "SECRET_KEY": "h" * 32})
    client = app.test_client()
    library = open_library(database)
    assert client.get("/healthz").status_code == 200
    service = Service(database, tmp_path / "dnc.log").start()
    _until("the first heartbeat", lambda: library.setting(HEARTBEAT_KEY))
    assert client.get("/healthz").status_code == 200
    assert service.process is not None
    os.kill(service.process.pid, signal.SIGKILL)
    service.process.wait(timeout=30)
    age_heartbeat(library)
    answer = client.get("/healthz")
    assert (answer.status_code, answer.get_json()) == (503, {"status": "unavailable"})
    service = Service(database, tmp_path / "again.log").start()
    _until("a heartbeat", lambda: client.get("/healthz").status_code == 200)
    service.stop()
    age_heartbeat(library)
    assert client.get("/healthz").status_code == 200
    library.engine.dispose()
    dispose(app)
