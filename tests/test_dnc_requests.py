"""Requests from the control (issue 35): the operator sends a short file from the control's
keypad naming a program, and the transfer service answers with that program; an unknown
name answers nothing and is logged; a whole program sent from the control is received.
Over a socat pty pair against the simulated control — no mocks."""

from __future__ import annotations

import shutil
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from app.cnc.formats.targets import export
from app.dnc.daemon import TransferService
from app.dnc.requests import Request, read_request
from app.storage.library import Library, Machine, open_library
from app.storage.transfers import Transfer, TransferLog
from tests.simulated_control import SimulatedControl, SocatPair

WAIT = 30.0


def test_what_a_request_looks_like() -> None:
    assert read_request("%\r\nPN2262 G20;\r\n%\r\n") == Request("2262", "")
    assert read_request("%\nO1234 (BRACKET)\nM30\n%\n") == Request("1234", "BRACKET")
    assert read_request("%\n(FLANGE OP2)\n%\n") == Request("", "FLANGE OP2")
    assert read_request("%\nO1234\nG0 X1.\n%\n") is None  # a motion word: a program
    assert read_request("%\r\nPN2262 G20;\r\nN001 G104 XC0A YC0A HL05 T01;\r\n%") is None
    assert read_request("%\n%\n") is None  # names nothing
    assert read_request("\x00\x13garbage") is None


@pytest.fixture
def pair() -> Iterator[SocatPair]:
    if shutil.which("socat") is None:
        pytest.fail("socat is not installed: add the Debian package socat (apt-get install socat)")
    with SocatPair() as joined:
        yield joined


@pytest.fixture
def library(tmp_path: Path, pair: SocatPair) -> Library:
    lib = open_library(f"sqlite:///{tmp_path / 'shop.db'}")
    lib.save_machine(Machine("Plus", "events", {}, {"port": pair.host, "requests": "on"}))
    return lib


@pytest.fixture
def dnc(library: Library) -> Iterator[TransferService]:
    running = TransferService(library, poll=0.05)
    stop = threading.Event()
    thread = threading.Thread(target=running.run, args=(stop,), daemon=True)
    thread.start()
    yield running
    stop.set()
    thread.join(timeout=15)


def _rows(library: Library, count: int) -> list[Transfer]:
    """The `count` newest log rows once none of them waits or runs, oldest first."""
    log = TransferLog(library)
    deadline = time.monotonic() + WAIT
    while time.monotonic() < deadline:
        rows = log.recent(count)
        if len(rows) == count and all(r.outcome not in ("queued", "running") for r in rows):
            return rows[::-1]
        time.sleep(0.05)
    raise AssertionError(f"the log did not settle: {log.recent(count)}")


def test_a_request_from_the_control_is_answered_with_the_program_it_names(
    library: Library, pair: SocatPair, dnc: TransferService
) -> None:
    sample = next(p for p in library.programs() if p.part_number == "2262")
    expected = export(library.get(sample.id).program, "events").data
    with SimulatedControl(pair.control, parity="E", buffer_size=1 << 16) as control:
        time.sleep(0.3)  # the service opens the port to listen
        control.send_back(b"%\r\nPN2262 G20;\r\n%\r\n", delay=0.2)
        assert control.received(expected, timeout=WAIT)
        request, answer = _rows(library, 2)
    assert (request.direction, request.author) == ("receive", "request from Plus")
    assert "a request for part number 2262: ProtoTRAK Plus sample part queued" in request.report
    assert (answer.direction, answer.outcome, answer.program_id) == ("send", "ok", sample.id)
    assert answer.author == "request from Plus" and answer.checksum


def test_an_unknown_request_answers_nothing_and_is_logged(
    library: Library, pair: SocatPair, dnc: TransferService
) -> None:
    with SimulatedControl(pair.control, parity="E", buffer_size=1 << 16) as control:
        time.sleep(0.3)
        control.send_back(b"%\r\nPN9999 G20;\r\n%\r\n", delay=0.2)
        [request] = _rows(library, 1)
        time.sleep(1.0)  # nothing follows
        assert bytes(control.memory) == b""
    assert request.error == (
        "a request for part number 9999: no program with part number 9999 in the library; "
        "nothing was sent"
    )


def test_a_program_sent_from_the_control_is_received(
    library: Library, pair: SocatPair, dnc: TransferService
) -> None:
    sample = next(p for p in library.programs() if p.part_number == "2262")
    events = export(library.get(sample.id).program, "events").data
    before = {p.id for p in library.programs()}
    with SimulatedControl(pair.control, parity="E", buffer_size=1 << 16) as control:
        time.sleep(0.3)
        control.send_back(events, delay=0.2)
        [received] = _rows(library, 1)
    assert (received.direction, received.outcome) == ("receive", "ok")
    [new] = [p for p in library.programs() if p.id not in before]
    assert received.program_id == new.id
    assert received.report.startswith("Import report (events):")
