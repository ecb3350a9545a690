"""RS-232 transfers from the web page and the command line, over real ptys (socat) against
the simulated control: what an operator does, and what the transfer log then shows."""

from __future__ import annotations

import json
import re
import shutil
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner
from flask import Flask
from flask.testing import FlaskClient

from app import create_app
from app.cli import main
from app.cnc import document
from app.cnc.formats.targets import export
from app.dnc.daemon import TransferService
from app.storage.demo import demo_programs
from app.storage.library import Library, Machine, open_library
from app.storage.transfers import Transfer, TransferLog
from app.web import get_library
from tests.simulated_control import SimulatedControl, SocatPair

WAIT = 30.0  # s: only a failing test waits this long


@pytest.fixture
def pair() -> Iterator[SocatPair]:
    if shutil.which("socat") is None:
        pytest.fail("socat is not installed: add the Debian package socat (apt-get install socat)")
    with SocatPair() as joined:
        yield joined


@pytest.fixture
def app(tmp_path: Path) -> Iterator[Flask]:
    app = create_app(
        {"DATABASE_URL": f"sqlite:///{tmp_path / 'web.db'}", "SECRET_KEY": "test" * 32}
    )
    yield app
    with app.app_context():
        get_library().engine.dispose()


@pytest.fixture
def client(app: Flask) -> FlaskClient:
    return app.test_client()


@pytest.fixture
def dnc(app: Flask) -> Iterator[TransferService]:
    """The transfer service that runs what the page queues (in a thread here; its own
    process in a shop: tests/test_dnc_service.py)."""
    running = TransferService(library_of(app), poll=0.05)
    stop = threading.Event()
    thread = threading.Thread(target=running.run, args=(stop,), daemon=True)
    thread.start()
    yield running
    stop.set()
    thread.join(timeout=10)


def library_of(app: Flask) -> Library:
    with app.app_context():
        return get_library()


def token(client: FlaskClient, url: str = "/transfers") -> str:
    found = re.search(r'name="csrf_token" value="([^"]+)"', client.get(url).get_data(as_text=True))
    assert found, "no CSRF token on the page"
    return found.group(1)


def settled(log: TransferLog) -> Transfer:
    """The newest transfer once it is no longer queued or running."""
    deadline = time.monotonic() + WAIT
    while time.monotonic() < deadline:
        newest = log.recent(1)[0]
        if newest.outcome not in ("queued", "running"):
            return newest
        time.sleep(0.05)
    raise AssertionError("the transfer did not end")


def sending(log: TransferLog) -> Transfer:
    """The newest transfer once its first bytes are on the wire: a cancel before them stops
    a send that sent nothing (a loaded machine can take that long to open the port)."""
    deadline = time.monotonic() + WAIT
    while time.monotonic() < deadline:
        newest = log.recent(1)[0]
        if newest.outcome != "queued" and newest.bytes_done > 0:
            return newest
        time.sleep(0.02)
    raise AssertionError("the service sent nothing")


def test_sending_from_the_page_puts_the_export_in_the_control(
    app: Flask, client: FlaskClient, pair: SocatPair, dnc: TransferService
) -> None:
    library = library_of(app)
    library.save_machine(Machine("Plus", "events", {}, {"port": pair.host}))
    stored = library.programs()[0]
    program = library.get(stored.id).program
    expected = export(program, "events").data
    with SimulatedControl(pair.control, parity="E", buffer_size=4096) as control:
        response = client.post(
            "/transfers/send",
            data={"csrf_token": token(client), "machine": "Plus", "program_id": stored.id},
        )
        assert response.status_code == 303
        done = settled(TransferLog(library))
        assert control.received(expected, timeout=WAIT)
    assert (done.outcome, done.direction, done.program_id) == ("ok", "send", stored.id)
    assert done.bytes_done == done.bytes_total == len(expected)
    assert done.settings.startswith("4800 7E1")
    page = client.get("/transfers").get_data(as_text=True)
    assert f"{len(expected)} / {len(expected)}" in page and "hx-trigger" not in page


def test_a_cancel_from_the_page_stops_a_send(
    app: Flask, client: FlaskClient, pair: SocatPair, dnc: TransferService
) -> None:
    library = library_of(app)
    # A control that takes 40 characters a second keeps the send running for seconds.
    library.save_machine(Machine("Plus", "events", {}, {"port": pair.host, "flow": "xonxoff"}))
    stored = max(library.programs(), key=lambda p: p.block_count)
    with SimulatedControl(pair.control, parity="E", buffer_size=64, consume_cps=40):
        csrf = token(client)
        client.post(
            "/transfers/send", data={"csrf_token": csrf, "machine": "Plus", "program_id": stored.id}
        )
        log = TransferLog(library)
        running = sending(log)
        assert running.outcome == "running"
        assert 'hx-trigger="every 1s"' in client.get("/transfers").get_data(as_text=True)
        response = client.post(f"/transfers/{running.id}/cancel", data={"csrf_token": csrf})
        assert response.status_code == 303
        done = settled(log)
    assert done.outcome == "cancelled"
    assert done.bytes_total is not None and 0 < done.bytes_done < done.bytes_total


def test_receiving_from_the_page_adds_the_program(
    app: Flask, client: FlaskClient, pair: SocatPair, dnc: TransferService
) -> None:
    library = library_of(app)
    small = min(demo_programs(), key=lambda p: len(document.dumps(p)))
    text = json.dumps(json.loads(document.dumps(small)), indent=1).encode("ascii")
    library.save_machine(Machine("Plus", "json", {}, {"port": pair.host, "end": "idle"}))
    before = {p.id for p in library.programs()}
    with SimulatedControl(pair.control, cps=960, parity="E") as control:
        control.send_back(text, delay=0.5)
        response = client.post(
            "/transfers/receive",
            data={"csrf_token": token(client), "machine": "Plus", "name": "From the Plus"},
        )
        assert response.status_code == 303
        done = settled(TransferLog(library))
    assert done.outcome == "ok", done.error
    [new] = [p for p in library.programs() if p.id not in before]
    assert new.id == done.program_id
    assert library.get(new.id).program.blocks == small.blocks
    raw = client.get(f"/transfers/{done.id}/raw")
    assert raw.status_code == 200 and raw.data.startswith(b"{")


def test_a_transfer_needs_a_configured_machine(app: Flask, client: FlaskClient) -> None:
    library_of(app).save_machine(Machine("Bench", "events", {}, {"port": ""}))
    csrf = token(client, "/machines")
    page = client.post(
        "/transfers/send", data={"csrf_token": csrf, "machine": "Bench", "program_id": "1"}
    )
    assert page.status_code == 422
    assert "Not sent: machine Bench: " in page.get_data(as_text=True)
    page = client.post("/transfers/receive", data={"csrf_token": csrf, "machine": "Mill 9"})
    assert page.status_code == 422
    assert "Not started: no machine named &#39;Mill 9&#39;" in page.get_data(as_text=True)
    assert TransferLog(library_of(app)).recent() == []


def test_a_machine_with_unusable_serial_settings_is_not_saved(
    app: Flask, client: FlaskClient
) -> None:
    csrf = token(client, "/machines")
    form = {"csrf_token": csrf, "name": "Plus", "target": "events", "port": "/dev/ttyS0"}
    page = client.post("/machines", data={**form, "baud": "4801", "limits": "x=-10/10"})
    assert page.status_code == 422
    assert "Not saved: serial, baud: baud 4801 is not a standard rate; use one of 110, 150," in (
        page.get_data(as_text=True)
    )
    assert all(m.name != "Plus" for m in library_of(app).machines())
    response = client.post("/machines", data={**form, "baud": "9600", "limits": "x=-10/10"})
    assert response.status_code == 302
    saved = library_of(app).machine("Plus")
    assert saved.serial["baud"] == "9600" and saved.limits == {"x": "-10/10"}


def test_a_serial_port_of_100_000_characters_is_not_saved(app: Flask, client: FlaskClient) -> None:
    """The audit of issue 31: the form stored it (only a send refused it, and the machines
    page grew to 110 kB); the form and a restored backup now share one check."""
    csrf = token(client, "/machines")
    form = {"csrf_token": csrf, "name": "Plus", "target": "events"}
    page = client.post("/machines", data={**form, "port": "/dev/" + "x" * 100_000})
    assert page.status_code == 422
    assert "Not saved: serial, port: 100,005 characters is too long; allowed: at most 500" in (
        page.get_data(as_text=True)
    )
    assert all(m.name != "Plus" for m in library_of(app).machines())


def test_send_and_receive_from_the_command_line(
    tmp_path: Path, pair: SocatPair, monkeypatch: pytest.MonkeyPatch
) -> None:
    url = f"sqlite:///{tmp_path / 'cli.db'}"
    monkeypatch.setenv("DATABASE_URL", url)
    library = open_library(url)
    library.save_machine(Machine("Plus", "events", {}, {"port": pair.host}))
    stored = library.programs()[0]
    expected = export(library.get(stored.id).program, "events").data
    runner = CliRunner()
    with SimulatedControl(pair.control, parity="E", buffer_size=4096) as control:
        result = runner.invoke(main, ["send", str(stored.id), "--machine", "Plus"])
        assert control.received(expected, timeout=WAIT)
    assert result.exit_code == 0, result.output
    assert f"{len(expected)}/{len(expected)} bytes to Plus on {pair.host}" in result.output
    listed = runner.invoke(main, ["transfers"])
    assert listed.exit_code == 0 and " send " in listed.output and " ok" in listed.output

    with SimulatedControl(pair.control, parity="E") as control:
        control.send_back(b"%\r\nnot a program\r\n%\r\n", delay=0.5)
        result = runner.invoke(main, ["receive", "--machine", "Plus", "--wait", "10"])
    assert result.exit_code == 1
    assert "nothing was saved" in result.output
    assert [p.id for p in library.programs()] == [p.id for p in open_library(url).programs()]


def test_unknown_machine_on_the_command_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'cli.db'}")
    result = CliRunner().invoke(main, ["send", "1", "--machine", "Nowhere"])
    assert result.exit_code == 2
    assert "no machine named 'Nowhere'" in result.output


def test_send_to_a_bare_port_at_the_plus_defaults(
    tmp_path: Path, pair: SocatPair, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'cli.db'}")
    program = demo_programs()[0]
    path = tmp_path / "part.json"
    path.write_text(document.dumps(program), encoding="utf-8")
    expected = export(program, "gcode-linuxcnc").data
    with SimulatedControl(pair.control, parity="E", buffer_size=1 << 16) as control:
        result = CliRunner().invoke(
            main, ["send", str(path), "--port", pair.host, "--to", "gcode-linuxcnc"]
        )
        # The port ends lines with CR LF (the ProtoTRAK Plus default): wait for those bytes.
        assert control.received(expected.replace(b"\n", b"\r\n"), timeout=WAIT)
    assert result.exit_code == 0, result.output
    assert "4800 7E1" in CliRunner().invoke(main, ["transfers"]).output
    result = CliRunner().invoke(main, ["send", str(path)])
    assert result.exit_code == 2
    assert "give --machine NAME (a library machine) or --port PATH" in result.output


def test_a_received_events_program_is_imported_with_its_report(
    app: Flask, client: FlaskClient, pair: SocatPair, dnc: TransferService
) -> None:
    library = library_of(app)
    sample = demo_programs()[0]
    events = export(sample, "events").data
    library.save_machine(Machine("Plus", "events", {}, {"port": pair.host}))
    with SimulatedControl(pair.control, parity="E") as control:
        control.send_back(events, delay=0.5)
        client.post(
            "/transfers/receive",
            data={"csrf_token": token(client), "machine": "Plus", "name": "From the floor"},
        )
        done = settled(TransferLog(library))
    assert done.outcome == "ok", done.error
    assert done.report.startswith("Import report (events):\n")
    received = library.get(done.program_id or 0)
    assert received.info.name == "From the floor"
    # Events carry no spindle speeds: the report says what the programmer must supply.
    assert len(received.program.blocks) >= len(sample.blocks) // 2
    assert "needs" in done.report
    page = client.get("/transfers").get_data(as_text=True)
    assert "<summary>import report</summary>" in page


def test_a_transfer_whose_process_died_is_shown_as_interrupted(
    app: Flask, client: FlaskClient
) -> None:
    from datetime import timedelta

    from app.storage.models import TransferRow

    library = library_of(app)
    log = TransferLog(library)
    alive = log.begin("send", "Plus", "/dev/ttyUSB0", "events", "ann")
    dead = log.begin("send", "Plus", "/dev/ttyUSB0", "events", "ann")
    with library.session() as s:
        row = s.get(TransferRow, dead)
        assert row is not None and row.updated_at is not None
        row.updated_at -= timedelta(minutes=5)
    assert log.heartbeat(alive) is False
    page = client.get("/transfers").get_data(as_text=True)
    by_id = {t.id: t for t in log.recent()}
    assert by_id[dead].outcome == "interrupted"
    assert "server process running this transfer stopped" in by_id[dead].error
    assert by_id[alive].outcome == "running"
    assert "interrupted" in page and 'hx-trigger="every 1s"' in page
    log.cancel(alive)
    assert log.heartbeat(alive) is True


def test_the_transfers_page_names_a_machines_target_in_the_shops_words(
    app: Flask, client: FlaskClient
) -> None:
    """The machine menu says what the machine takes ("ProtoTRAK Plus (events over RS-232)"),
    as the export and machines pages do, not the registry's name ("events")."""
    library_of(app).save_machine(Machine("Plus", "events", {}, {"port": "/dev/ttyS0"}))
    page = client.get("/transfers").get_data(as_text=True)
    assert "Plus — ProtoTRAK Plus (events over RS-232) on /dev/ttyS0" in page
    assert "— events on" not in page


def test_a_send_is_logged_with_its_revision_and_checksum_and_a_receive_compared_with_it(
    app: Flask, client: FlaskClient, pair: SocatPair, dnc: TransferService
) -> None:
    """Traceability (issue 35): what went to which machine, by whom, which revision and its
    SHA-256; what comes back is compared with it, block by block (an edit at the control)."""
    import dataclasses
    import hashlib
    from decimal import Decimal

    from app.cnc.blocks import Hole

    library = library_of(app)
    library.save_machine(Machine("Plus", "json", {}, {"port": pair.host, "end": "idle"}))
    small = min(demo_programs(), key=lambda p: len(document.dumps(p)))
    info = library.create(small, author="ann")
    edited = library.save(info.id, small, based_on=1, author="ann")  # version 2
    sent_bytes = export(small, "json").data
    with SimulatedControl(pair.control, cps=960, parity="E", buffer_size=1 << 16) as control:
        client.post(
            "/transfers/send",
            data={"csrf_token": token(client), "machine": "Plus", "program_id": info.id},
        )
        done = settled(TransferLog(library))
        # The line ends lines with CR LF (the Plus's default); the checksum is the export's.
        assert control.received(sent_bytes.replace(b"\n", b"\r\n"), timeout=WAIT)
    assert done.outcome == "ok", done.error
    assert done.revision == edited.version == 2
    assert done.checksum == hashlib.sha256(sent_bytes).hexdigest()
    page = client.get("/transfers").get_data(as_text=True)
    assert f"sha256 {done.checksum[:12]}" in page and " v2" in page
    # The operator changes a depth at the control and sends the program back.
    first = small.blocks[0]  # the pocket's DRILL: its Z DN
    assert isinstance(first, Hole)
    changed = dataclasses.replace(
        small, blocks=(dataclasses.replace(first, z_dn=Decimal("-0.777")), *small.blocks[1:])
    )
    back = json.dumps(json.loads(document.dumps(changed)), indent=1).encode("ascii")
    with SimulatedControl(pair.control, cps=960, parity="E") as control:
        control.send_back(back, delay=0.5)
        client.post(
            "/transfers/receive",
            data={"csrf_token": token(client), "machine": "Plus", "name": "Back from the Plus"},
        )
        received = settled(TransferLog(library))
    assert received.outcome == "ok", received.error
    assert f"compared with what was last sent to Plus: {small.name} v2" in received.report
    assert "UTC: 1 difference\n    block 1 DRILL: Z DN -0.3 → -0.777" in received.report
