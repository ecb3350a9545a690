"""The transfer service (issue 35): transfers run by `millblocks dnc`, a process of its own,
so the web server can restart under a send; several machines at once; a service restart
says which transfers it interrupted. Real processes (gunicorn, the service), socat pty
pairs and the simulated control — no mocks.

Before: a transfer ran as a thread inside the web worker that took the request; killing or
restarting that worker cut the program off (an operator's second heavy page stopped a send
at 9 296 of 224 025 bytes).
"""

from __future__ import annotations

import contextlib
import http.cookiejar
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.parse
import urllib.request
from collections.abc import Iterator
from contextlib import ExitStack
from pathlib import Path

import pytest

from app.cnc.formats.targets import export
from app.dnc.daemon import INTERRUPTED_BY_CRASH, INTERRUPTED_BY_STOP, TransferService
from app.storage.library import Library, Machine, open_library
from app.storage.transfers import Transfer, TransferLog
from tests.simulated_control import SimulatedControl, SocatPair

ROOT = Path(__file__).resolve().parents[1]
WAIT = 60.0  # s: only a failing test waits this long


@pytest.fixture
def pair() -> Iterator[SocatPair]:
    if shutil.which("socat") is None:
        pytest.fail("socat is not installed: add the Debian package socat (apt-get install socat)")
    with SocatPair() as joined:
        yield joined


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _env(database: str) -> dict[str, str]:
    return {**os.environ, "DATABASE_URL": database, "MILLBLOCKS_AUTH": "local"}


def _until(what: str, check: object, timeout: float = WAIT) -> None:
    deadline = time.monotonic() + timeout
    while not check():  # type: ignore[operator]
        assert time.monotonic() < deadline, f"waited {timeout:.0f} s for {what}"
        time.sleep(0.05)


class Web:
    """A gunicorn of the app on the library `database`, and a browser-like client."""

    def __init__(self, database: str, log: Path) -> None:
        self.port = _free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.database = database
        self.log = log
        self.jar = http.cookiejar.CookieJar()
        self.opener = urllib.request.build_opener(urllib.request.HTTPCookieProcessor(self.jar))
        self.process: subprocess.Popen[bytes] | None = None

    def start(self) -> Web:
        with self.log.open("a") as errors:
            self.process = subprocess.Popen(
                [
                    *(sys.executable, "-m", "gunicorn", "--bind", f"127.0.0.1:{self.port}"),
                    *("--workers", "1", "app:create_app()"),
                ],
                cwd=ROOT,
                env=_env(self.database),
                stdout=subprocess.DEVNULL,
                stderr=errors,
            )
        _until("the web server", self._answers, 60)
        return self

    def _answers(self) -> bool:
        assert self.process is not None and self.process.poll() is None, self.log.read_text()
        try:
            self.opener.open(self.url + "/login", timeout=5).close()
        except OSError:
            return False
        return True

    def kill(self) -> None:
        """The whole web server gone at once (a crash, or a restart's stop)."""
        if self.process is not None and self.process.poll() is None:
            os.kill(self.process.pid, signal.SIGKILL)
            self.process.wait(timeout=10)
        # gunicorn's worker outlives a SIGKILLed master for a moment; wait for the port.
        _until("the old server's port to close", self._closed, 30)

    def _closed(self) -> bool:
        with socket.socket() as probe:
            return probe.connect_ex(("127.0.0.1", self.port)) != 0

    def post_send(self, machine: str, program_id: int) -> None:
        page = self.opener.open(self.url + "/transfers", timeout=30).read().decode()
        found = re.search(r'name="csrf_token" value="([^"]+)"', page)
        assert found, "no CSRF token on the transfers page"
        form = {"csrf_token": found.group(1), "machine": machine, "program_id": program_id}
        data = urllib.parse.urlencode(form).encode()
        self.opener.open(self.url + "/transfers/send", data=data, timeout=30).close()

    def page(self) -> str:
        return str(self.opener.open(self.url + "/transfers", timeout=30).read().decode())


class Service:
    """`millblocks dnc` as its own process."""

    def __init__(self, database: str, log: Path) -> None:
        self.database = database
        self.log = log
        self.process: subprocess.Popen[bytes] | None = None

    def start(self) -> Service:
        with self.log.open("a") as errors:
            self.process = subprocess.Popen(
                [sys.executable, "-m", "app.cli", "dnc", "--poll", "0.1"],
                cwd=ROOT,
                env=_env(self.database),
                stdout=subprocess.DEVNULL,
                stderr=errors,
            )
        _until("the service to start", lambda: "transfer service running" in self.log.read_text())
        return self

    def stop(self) -> str:
        if self.process is not None and self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            self.process.wait(timeout=30)
        return self.log.read_text()


def _newest(library: Library) -> Transfer:
    return TransferLog(library).recent(1)[0]


def test_the_web_server_restarts_during_a_send_and_the_send_goes_on(
    tmp_path: Path, pair: SocatPair
) -> None:
    database = f"sqlite:///{tmp_path / 'shop.db'}"
    library = open_library(database)
    library.save_machine(Machine("Plus", "events", {}, {"port": pair.host}))
    stored = max(library.programs(), key=lambda p: p.block_count)
    expected = export(library.get(stored.id).program, "events").data
    with ExitStack() as stack:
        # A control that takes 120 characters a second: the send lasts several seconds.
        control = stack.enter_context(
            SimulatedControl(pair.control, parity="E", buffer_size=1 << 16, cps=120)
        )
        service = Service(database, tmp_path / "dnc.log").start()
        stack.callback(service.stop)
        web = Web(database, tmp_path / "web.log").start()
        stack.callback(web.kill)
        web.post_send("Plus", stored.id)
        _until("the send to start", lambda: len(control.memory) > 0)
        web.kill()
        assert len(control.memory) < len(expected), "the send ended before the restart"
        web.start()
        assert control.received(expected, timeout=WAIT)
        _until("the log to say ok", lambda: _newest(library).outcome == "ok")
        page = web.page()
    done = _newest(library)
    assert done.bytes_done == done.bytes_total == len(expected)
    assert f"{len(expected)} / {len(expected)}" in page


def test_a_service_stopped_during_a_send_says_which_it_interrupted(
    tmp_path: Path, pair: SocatPair
) -> None:
    database = f"sqlite:///{tmp_path / 'shop.db'}"
    library = open_library(database)
    library.save_machine(Machine("Plus", "events", {}, {"port": pair.host}))
    stored = max(library.programs(), key=lambda p: p.block_count)
    log = TransferLog(library)
    with SimulatedControl(pair.control, parity="E", buffer_size=1 << 16, cps=60) as control:
        service = Service(database, tmp_path / "dnc.log").start()
        row = log.begin("send", "Plus", pair.host, "events", "ann", stored.id, "part", queued=True)
        _until("the send to start", lambda: len(control.memory) > 0)
        said = service.stop()
    assert f"transfer {row} on Plus interrupted by the stop" in said
    done = log.get(row)
    assert (done.outcome, done.error) == ("interrupted", INTERRUPTED_BY_STOP)


def test_a_service_started_after_a_crash_names_what_was_left_running(tmp_path: Path) -> None:
    database = f"sqlite:///{tmp_path / 'shop.db'}"
    library = open_library(database, seed_demo=False)
    log = TransferLog(library)
    row = log.begin("send", "Plus", "/dev/ttyUSB0", "events", "ann", None, "bracket")
    said = Service(database, tmp_path / "dnc.log").start().stop()
    assert f"transfer {row} (send bracket on Plus) was interrupted" in said
    assert (log.get(row).outcome, log.get(row).error) == ("interrupted", INTERRUPTED_BY_CRASH)


def test_several_machines_send_at_once_and_one_machine_one_at_a_time(tmp_path: Path) -> None:
    """Eight machines, nine queued sends (two to one machine): the eight machines run
    together; the second send to the busy machine waits for the first."""
    library = open_library(f"sqlite:///{tmp_path / 'shop.db'}")
    stored = max(library.programs(), key=lambda p: p.block_count)
    expected = export(library.get(stored.id).program, "events").data
    log = TransferLog(library)
    with ExitStack() as stack:
        pairs = [stack.enter_context(SocatPair()) for _ in range(8)]
        controls = [
            stack.enter_context(
                SimulatedControl(p.control, parity="E", buffer_size=1 << 16, cps=240)
            )
            for p in pairs
        ]
        rows = []
        for n, joined in enumerate(pairs):
            library.save_machine(Machine(f"Mill {n}", "events", {}, {"port": joined.host}))
            rows.append(
                log.begin("send", f"Mill {n}", joined.host, "events", "", stored.id, queued=True)
            )
        rows.append(
            log.begin("send", "Mill 0", pairs[0].host, "events", "", stored.id, queued=True)
        )
        running = TransferService(library, poll=0.05)
        stop = threading.Event()
        thread = threading.Thread(target=running.run, args=(stop,), daemon=True)
        thread.start()
        stack.callback(thread.join, 10)
        stack.callback(stop.set)
        _until("all nine sends", lambda: all(log.get(r).outcome == "ok" for r in rows), 180)
        assert controls[0].received(expected + expected, timeout=WAIT)
        assert all(c.received(expected, timeout=WAIT) for c in controls[1:])
    done = [log.get(r) for r in rows]
    first_end = min(d.finished_at for d in done[:8] if d.finished_at)
    assert all(d.started_at < first_end for d in done[:8])  # the eight machines overlapped
    assert done[0].finished_at is not None and done[8].started_at >= done[0].finished_at


def test_a_queued_transfer_cancelled_before_it_starts_never_runs(tmp_path: Path) -> None:
    library = open_library(f"sqlite:///{tmp_path / 'shop.db'}", seed_demo=False)
    log = TransferLog(library)
    row = log.begin("send", "Plus", "/dev/ttyUSB0", "events", "", queued=True)
    log.cancel(row)
    assert (log.get(row).outcome, log.get(row).error) == (
        "cancelled",
        "withdrawn before it started",
    )
    assert TransferService(library).step() == []


def _children(pid: int) -> list[int]:
    """The processes `pid` started (Linux's /proc)."""
    found: list[int] = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        found += [int(c) for c in (task / "children").read_text().split()]
    return found


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except FileNotFoundError:
        return False
    return state != "Z"


@pytest.mark.parametrize("how", [signal.SIGTERM, signal.SIGKILL])
def test_the_transfer_service_serve_started_stops_with_it(tmp_path: Path, how: int) -> None:
    """`millblocks serve` starts the transfer service beside gunicorn; stopped by a signal
    only it receives (a supervisor's TERM, or KILL), it must not leave the service running,
    holding the machines' ports with no web server (it did: only Ctrl-C, which reaches the
    whole process group, stopped both)."""
    port = _free_port()
    env = {**_env(f"sqlite:///{tmp_path / 'shop.db'}"), "MILLBLOCKS_INSTANCE_PATH": str(tmp_path)}
    with (tmp_path / "serve.log").open("w") as log:
        serve = subprocess.Popen(
            [sys.executable, "-m", "app.cli", "serve", "--port", str(port), "--workers", "1"],
            env=env,
            stderr=log,
            stdout=log,
            start_new_session=True,
        )
    try:

        def service() -> int | None:
            for child in _children(serve.pid):
                command = Path(f"/proc/{child}/cmdline").read_bytes().split(b"\0")
                if b"dnc" in command:
                    return child
            return None

        _until("the transfer service", lambda: service() is not None)
        dnc = service()
        assert dnc is not None
        _until("the web server", lambda: _answers(f"http://127.0.0.1:{port}/healthz"))
        os.kill(serve.pid, how)
        serve.wait(timeout=WAIT)
        _until("the transfer service to stop", lambda: not _alive(dnc), 15)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(serve.pid, signal.SIGKILL)
        serve.wait(timeout=WAIT)


def _answers(url: str) -> bool:
    try:
        with urllib.request.urlopen(url, timeout=2) as reply:
            return bool(reply.status == 200)
    except OSError:
        return False


def test_a_queued_send_the_target_refuses_says_why(tmp_path: Path) -> None:
    """The audit of issue 31: the transfers page said only "events cannot take this
    program"; the send's row now keeps the export's reason (1 203 events: the Plus's line
    numbers run to 999). Nothing reaches the port: the export fails first."""
    from decimal import Decimal

    from app.cnc.blocks import Rep
    from tests.test_events import loop

    library = open_library(f"sqlite:///{tmp_path / 'shop.db'}", seed_demo=False)
    program = library.create(loop(Rep(x=Decimal(5), y=Decimal("0.15"), nx=1, ny=600)))
    library.save_machine(Machine("Plus", "events", {}, {"port": str(tmp_path / "no-port")}))
    log = TransferLog(library)
    row = log.begin("send", "Plus", "", "events", "", program.id, queued=True)
    service = TransferService(library)
    assert [t.id for t in service.step()] == [row]
    assert service.running["Plus"].job.wait(WAIT)
    assert (log.get(row).outcome, log.get(row).error) == (
        "failed",
        "events cannot take this program (program: 1203 events: line numbers run to 999 "
        "(seed 003 §2.2.4))",
    )
