"""Transfers over real ptys (socat pairs) against the simulated control — no mocks.

A pty has no baud rate and no parity: it carries 8-bit bytes as fast as they are written,
and this kernel refuses CS7 and PARENB on it. So the line rate is the simulator's (480
characters a second) and the sender's own pacing, and 7E1 goes as software framing (the
default `auto` falls back to it; the simulator checks bit 8 of every byte). Parity is
tested where it lives: the settings pyserial is given (test_dnc_serial's 8N1 and refused
7E1 cases) and the software check (these transfers, and a corrupted byte on receive).
"""

from __future__ import annotations

import importlib
import json
import math
import shutil
import threading
import time
from collections.abc import Iterator
from datetime import datetime
from pathlib import Path

import pytest

from app.cnc import document
from app.cnc.blocks import Program
from app.cnc.formats.targets import export
from app.dnc import jobs
from app.dnc.framing import EndReason, add_parity, outgoing
from app.dnc.record import Direction, TransferRecord
from app.dnc.service import (
    CaptureImportError,
    import_capture,
    program_from_capture,
    receive_program,
    send_program,
)
from app.dnc.settings import EndOfLine, Flow, Framing, Parity, PortSettings
from app.dnc.transfer import (
    Outcome,
    ReceiveError,
    ReceiveResult,
    SendError,
    open_port,
    receive,
    send,
)
from app.storage.demo import demo_programs
from app.storage.library import Library, Machine, open_library
from tests.simulated_control import SimulatedControl, SocatPair

WAIT = 30.0  # s: only a failing test waits this long (the simulator lags on a loaded box)
SEVEN_E_ONE = PortSettings()  # 4800 7E1: software framing on a pty
XON_XOFF = PortSettings(flow=Flow.XONXOFF)


@pytest.fixture
def pair() -> Iterator[SocatPair]:
    if shutil.which("socat") is None:
        pytest.fail("socat is not installed: add the Debian package socat (apt-get install socat)")
    with SocatPair() as joined:
        yield joined
    assert joined.process.returncode is not None, "socat was left running"


@pytest.fixture(scope="module")
def sample() -> Program:
    return demo_programs()[0]


@pytest.fixture(scope="module")
def events(sample: Program) -> bytes:
    """The ProtoTRAK Plus events for the sample part: 461 bytes, CR LF, `%` … `%`."""
    return export(sample, "events").data


@pytest.fixture
def library(tmp_path: Path) -> Library:
    return open_library(f"sqlite:///{tmp_path / 'library.db'}", seed_demo=False)


def _stripped(data: bytes) -> bytes:
    return bytes(b & 0x7F for b in data)


# -- sending ------------------------------------------------------------------------------


def test_send_is_exact_at_no_more_than_the_line_rate(pair: SocatPair, events: bytes) -> None:
    settings = PortSettings(leader=10, trailer=5)
    with SimulatedControl(pair.control, parity="E", buffer_size=4096) as control:
        seen: list[tuple[int, int | None]] = []
        result = send(events, settings, pair.host, progress=lambda d, t: seen.append((d, t)))
        assert control.wait_for(result.total, timeout=WAIT)
    assert result.outcome is Outcome.OK
    assert result.settings.framing is Framing.SOFTWARE  # the pty has no 7-bit mode
    assert result.sent == result.total == len(events) + 15
    assert bytes(control.memory) == bytes(10) + events + bytes(5)  # byte for byte
    assert control.parity_errors == 0
    assert seen[-1] == (result.total, result.total)
    assert [d for d, _ in seen] == sorted(d for d, _ in seen)
    assert result.seconds >= 0.95 * result.line_seconds  # never faster than 480 cps


def test_send_8n1_with_uart_framing(pair: SocatPair, sample: Program) -> None:
    gcode = export(sample, "gcode-linuxcnc").data
    settings = PortSettings(
        baud=9600,
        data_bits=8,
        parity=Parity.NONE,
        eol=EndOfLine.LF,
        target="gcode-linuxcnc",
        framing=Framing.UART,
    )
    with SimulatedControl(pair.control, cps=960, buffer_size=4096) as control:
        result = send(gcode, settings, pair.host)
        assert control.received(gcode, timeout=WAIT)
    assert result.settings.framing is Framing.UART


def test_xoff_is_honoured_within_a_few_characters(pair: SocatPair, events: bytes) -> None:
    """The control's buffer (64) fills at 480 cps and drains at 240: it sends XOFF at 48
    and XON at 16, and counts what still arrives after each XOFF."""
    control = SimulatedControl(
        pair.control, parity="E", buffer_size=64, xoff_at=48, xon_at=16, consume_cps=240
    )
    data = events + events[1:]  # ~920 bytes: about 4 s at 240 cps
    with control:
        result = send(data, XON_XOFF, pair.host)
        assert control.received(data, timeout=WAIT)
    assert control.overflowed == 0, (control.after_xoff, control.queued_at_xoff)
    assert result.outcome is Outcome.OK
    assert result.xoff_count >= 3
    assert result.held_seconds > 0.3
    assert control.after_xoff and max(control.after_xoff) <= 16, control.after_xoff
    assert bytes(control.memory) == data


def test_drip_feed_at_a_set_rate_needs_no_flow_control(pair: SocatPair, events: bytes) -> None:
    """A control without flow control: fed at 300 characters a second, it never overflows
    its 32-character buffer."""
    settings = PortSettings(cps=300)
    control = SimulatedControl(
        pair.control, parity="E", buffer_size=32, consume_cps=400, xon_xoff=False
    )
    with control:
        result = send(events, settings, pair.host)
        assert control.received(events, timeout=WAIT)
    assert control.overflowed == 0
    assert result.seconds >= 0.95 * len(events) / 300


def test_a_control_that_never_sends_xon_times_out(pair: SocatPair, events: bytes) -> None:
    control = SimulatedControl(pair.control, parity="E", hold_after=100)
    with control, pytest.raises(SendError) as caught:
        send(events, XON_XOFF, pair.host, xoff_timeout=0.5)
    message = str(caught.value)
    assert message.startswith("no XON for 0.5 s: the control sent XOFF after ")
    assert message.endswith(f"of {len(events)} bytes and did not resume")
    result = caught.value.result
    assert result.outcome is Outcome.FAILED and result.error == message
    assert 100 <= result.sent < result.total
    [after] = control.after_xoff  # counted until the simulator stopped
    assert after <= 16


@pytest.mark.parametrize("kind", ["event", "callable"])
def test_cancel_mid_transfer(pair: SocatPair, events: bytes, kind: str) -> None:
    stop = threading.Event()

    def progress(done: int, total: int | None) -> None:
        if done >= 120:
            stop.set()

    with SimulatedControl(pair.control, parity="E", buffer_size=4096) as control:
        result = send(
            events,
            SEVEN_E_ONE,
            pair.host,
            progress=progress,
            cancel=stop if kind == "event" else stop.is_set,
        )
        time.sleep(0.5)  # what was on its way arrives; nothing more comes
    assert result.outcome is Outcome.CANCELLED
    assert 120 <= result.sent <= 128 < result.total
    # What the driver still held when the send stopped is dropped, not sent (on a pty that
    # is what socat had not read yet): the control has a prefix, short by a chunk or two.
    got = bytes(control.memory)
    assert events.startswith(got) and result.sent - 16 <= len(got) <= result.sent


def test_a_vanished_port_is_a_clear_error(pair: SocatPair, events: bytes) -> None:
    def progress(done: int, total: int | None) -> None:
        if done >= 100 and pair.process.returncode is None:
            pair.kill()  # as if the USB adapter were pulled out

    with SimulatedControl(pair.control, parity="E"), pytest.raises(SendError) as caught:
        send(events, SEVEN_E_ONE, pair.host, progress=progress)
    assert str(caught.value).startswith(f"port {pair.host} vanished: ")
    result = caught.value.result
    assert result.outcome is Outcome.FAILED and 100 <= result.sent < result.total


def test_ports_that_cannot_be_used(pair: SocatPair, events: bytes) -> None:
    with pytest.raises(SendError, match="cannot open port /dev/no-such-port: "):
        send(events, SEVEN_E_ONE, "/dev/no-such-port")
    uart = PortSettings(framing=Framing.UART)
    with pytest.raises(SendError) as caught:
        send(events, uart, pair.host)
    # A pty takes no CS7 or PARENB: the driver keeps 8N (or, once it has, refuses: EINVAL).
    message = str(caught.value)
    assert message.startswith(f"port {pair.host} cannot do 7E1: the driver ")
    assert message.endswith(
        "; set framing to software (the same frames, parity made by MillBlocks)"
    )
    held, _ = open_port(SEVEN_E_ONE, pair.host, write_timeout=1)
    try:
        with pytest.raises(SendError, match=f"port {pair.host} is busy: another transfer has it"):
            send(events, SEVEN_E_ONE, pair.host)
    finally:
        held.close()


# -- receiving ----------------------------------------------------------------------------


def test_receive_is_exact(pair: SocatPair, events: bytes) -> None:
    with SimulatedControl(pair.control, parity="E") as control:
        control.send_back(bytes(20) + events + bytes(20))
        result = receive(SEVEN_E_ONE, pair.host, first_byte_timeout=WAIT)
    assert result.outcome is Outcome.OK
    assert result.ended_by is EndReason.END_MARK
    assert result.data == events  # leader gone, parity stripped, up to the `%` and its CR LF
    assert result.text == events.decode("ascii")
    # Every byte as it came: the leader, the program, and any trailer read with its end.
    assert _stripped(result.raw).startswith(bytes(20) + events)
    assert set(result.raw[20 + len(events) :]) <= {0}


def test_receive_ends_at_a_word_or_when_the_line_goes_quiet(pair: SocatPair) -> None:
    with SimulatedControl(pair.control, parity="E") as control:
        control.send_back(b"G0 X1\r\nM30\r\nG0 X9\r\n")
        word = receive(PortSettings(end="M30"), pair.host, first_byte_timeout=WAIT)
        control.wait_sent(timeout=WAIT)
        control.send_back(b"G0 X1\r\nM2\r\n")
        quiet = receive(SEVEN_E_ONE, pair.host, first_byte_timeout=WAIT, idle_timeout=1.0)
    assert (word.data, word.ended_by) == (b"G0 X1\r\nM30\r\n", EndReason.END_MARK)
    assert (quiet.data, quiet.ended_by) == (b"G0 X1\r\nM2\r\n", EndReason.IDLE)


def test_garbage_on_receive_is_refused_and_nothing_is_saved(
    pair: SocatPair, library: Library
) -> None:
    """Wrong baud rate on the control: bytes whose parity is wrong."""
    garbage = bytes([0x00, 0x66, 0xE6, 0x9E, 0x78, 0x86, 0x1E, 0xF8, 0x60, 0xFE]) * 5
    machine = Machine("Plus", "events", {}, {"port": pair.host})
    log: list[TransferRecord] = []
    with SimulatedControl(pair.control) as control:  # the control's bytes go as they are
        control.send_back(garbage)
        with pytest.raises(ReceiveError) as caught:
            receive_program(
                machine, library, log=log.append, first_byte_timeout=WAIT, idle_timeout=1.0
            )
    message = str(caught.value)
    assert message.startswith("garbage from the control: byte 0xE6 at offset 2 is a parity error")
    assert message.endswith("(the machine is set to 4800 7E1); nothing was imported")
    assert library.programs() == []
    [record] = log
    assert (record.direction, record.outcome, record.error) == (
        Direction.RECEIVE,
        Outcome.FAILED,
        message,
    )
    assert record.raw == garbage


def test_a_program_cut_short_is_refused(pair: SocatPair, events: bytes) -> None:
    with SimulatedControl(pair.control, parity="E") as control:
        control.send_back(events[:200])
        with pytest.raises(ReceiveError) as caught:
            receive(SEVEN_E_ONE, pair.host, first_byte_timeout=WAIT, idle_timeout=1.0)
    assert str(caught.value) == (
        "the control stopped after 200 bytes without the closing % (nothing for 1 s): "
        "the program is incomplete; nothing was imported"
    )
    assert _stripped(caught.value.result.raw) == events[:200]


def test_nothing_from_the_control(pair: SocatPair) -> None:
    with SimulatedControl(pair.control, parity="E"), pytest.raises(ReceiveError) as caught:
        receive(SEVEN_E_ONE, pair.host, first_byte_timeout=0.3)
    assert str(caught.value) == (
        "nothing came from the control in 0.3 s: is it set to send, at 4800 7E1, and is the "
        "cable a null modem?"
    )


def test_the_port_vanishing_while_receiving(pair: SocatPair, events: bytes) -> None:
    def progress(done: int, total: int | None) -> None:
        if done >= 50 and pair.process.returncode is None:
            pair.kill()

    with SimulatedControl(pair.control, parity="E") as control:
        control.send_back(events)
        with pytest.raises(ReceiveError) as caught:
            receive(SEVEN_E_ONE, pair.host, first_byte_timeout=WAIT, progress=progress)
    assert str(caught.value).startswith(f"port {pair.host} vanished: ")
    assert len(caught.value.result.raw) >= 50


def test_cancel_while_waiting_for_the_control(pair: SocatPair) -> None:
    deadline = time.monotonic() + 0.2
    with SimulatedControl(pair.control, parity="E"):
        result = receive(SEVEN_E_ONE, pair.host, cancel=lambda: time.monotonic() > deadline)
    assert result.outcome is Outcome.CANCELLED and result.raw == b""
    assert result.seconds < 1


# -- the calls the CLI and the web make ---------------------------------------------------------


def test_send_program_exports_sends_and_logs(pair: SocatPair, sample: Program) -> None:
    machine = Machine("Plus", "events", {}, {"port": pair.host, "leader": "4"})
    log: list[TransferRecord] = []
    with SimulatedControl(pair.control, parity="E", buffer_size=4096) as control:
        sent = send_program(sample, machine, program_id=3, author="ann", log=log.append)
        assert control.wait_for(sent.result.total, timeout=WAIT)
    assert bytes(control.memory) == bytes(4) + sent.export.data
    assert log == [sent.record]
    assert sent.record.summary().startswith(
        f"send 'ProtoTRAK Plus sample part' events 465/465 bytes to Plus on {pair.host} in "
    )
    assert (sent.record.program_id, sent.record.author) == (3, "ann")


def test_receive_program_saves_a_whole_program(pair: SocatPair, library: Library) -> None:
    # The same document with \u escapes: a 7-bit line carries ASCII only ("§" is in it).
    small = min(demo_programs(), key=lambda p: len(document.dumps(p)))
    text = json.dumps(json.loads(document.dumps(small)), indent=1).encode("ascii")
    serial = {"port": pair.host, "baud": "9600", "end": "idle"}
    machine = Machine("Plus", "json", {}, serial)
    log: list[TransferRecord] = []
    with SimulatedControl(pair.control, cps=960, parity="E") as control:
        control.send_back(text)
        got = receive_program(
            machine,
            library,
            log=log.append,
            author="ann",
            first_byte_timeout=WAIT,
            idle_timeout=1.0,
        )
    assert got.program == small
    [entry] = library.programs()
    assert entry.name == small.name and got.stored.id == entry.id
    assert library.revisions(entry.id)[0].summary == f"received from Plus on {pair.host}"
    assert [r.program_id for r in log] == [entry.id]
    assert log[0].outcome is Outcome.OK and log[0].raw is not None


def test_receive_program_saves_nothing_that_does_not_import(
    pair: SocatPair, events: bytes, library: Library
) -> None:
    machine = Machine("Plus", "json", {}, {"port": pair.host})
    log: list[TransferRecord] = []
    with SimulatedControl(pair.control, parity="E") as control:
        control.send_back(events)  # a good capture, but not a MillBlocks document
        with pytest.raises(CaptureImportError, match="what came is not a MillBlocks program"):
            receive_program(machine, library, log=log.append, first_byte_timeout=WAIT)
    assert library.programs() == []
    assert log[0].outcome is Outcome.FAILED and log[0].raw is not None


def test_events_capture_imports_through_the_import_package(events: bytes) -> None:
    """Through app.cnc.formats.reading.read_program once it exists; until then a clear error."""
    now = datetime(2025, 3, 1)
    result = ReceiveResult(
        port="/dev/ttyS0",
        settings=SEVEN_E_ONE,
        raw=events,
        data=events,
        started=now,
        finished=now,
        seconds=0.0,
        outcome=Outcome.OK,
        text=events.decode("ascii"),
    )
    try:
        available = hasattr(importlib.import_module("app.cnc.formats.reading"), "read_program")
    except ImportError:
        available = False
    if not available:
        with pytest.raises(CaptureImportError, match="importing events is not available yet"):
            program_from_capture(result, "events")
    else:
        program = program_from_capture(result, "events", "received")
        assert len(program.blocks) > 0


def test_a_boss_machine_capture_is_read_as_a_boss_tape(sample: Program) -> None:
    """What reads a target's output back is the target's `reads_back`, not a guess from
    its name: a BOSS machine's capture (`tape-boss`, no 1704 tape) is read by the BOSS
    reader, its segments joined (issue 29 #8; before, nothing read it back)."""
    data = export(sample, "tape-boss", {"segment": "300"}).data
    assert data.count(b"#0") > 1
    now = datetime(2025, 3, 1)
    result = ReceiveResult(
        port="/dev/ttyS0",
        settings=SEVEN_E_ONE,
        raw=data,
        data=data,
        started=now,
        finished=now,
        seconds=0.0,
        outcome=Outcome.OK,
        text=data.decode("ascii"),
    )
    program, report = import_capture(result, "tape-boss", "received")
    assert program.units is sample.units
    assert len(program.blocks) > 0
    assert report.startswith("Import report (boss):")
    assert "segments (#0 … $) joined into one program" in report


def test_a_background_job_reports_progress_and_can_be_cancelled(
    pair: SocatPair, sample: Program
) -> None:
    machine = Machine("Plus", "events", {}, {"port": pair.host})
    states: list[tuple[str, int]] = []
    with SimulatedControl(pair.control, parity="E", buffer_size=4096):
        job = jobs.start(
            lambda progress, cancel: (
                send_program(sample, machine, progress=progress, cancel=cancel).record
            ),
            direction=Direction.SEND,
            machine="Plus",
            port=pair.host,
            label=sample.name,
            on_change=lambda j: states.append((j.state.value, j.done)),
            interval=0.1,
        )
        while job.done < 100:
            time.sleep(0.01)
        job.cancel()
        assert job.wait(timeout=WAIT)
    assert job.state is jobs.JobState.CANCELLED
    assert job.record is not None and job.record.outcome is Outcome.CANCELLED
    assert job.percent is not None and 20 <= job.percent < 100
    assert states[0] == ("running", 0) and states[-1][0] == "cancelled"
    assert len(states) >= 3


def test_software_parity_frames_on_the_wire(pair: SocatPair) -> None:
    """What the simulator gets is 8-bit: the 7-bit characters with even parity in bit 8."""
    with SimulatedControl(pair.control, buffer_size=4096) as raw_line:
        result = send(b"%\nG0 X1\n%\n", PortSettings(eol=EndOfLine.LF), pair.host)
        assert raw_line.wait_for(result.total, timeout=WAIT)
    assert bytes(raw_line.memory) == add_parity(b"%\nG0 X1\n%\n", Parity.EVEN)
    assert bytes(raw_line.memory) == outgoing(b"%\nG0 X1\n%\n", result.settings)


def test_a_drip_feed_waits_out_xoff_holds_that_fail_an_ordinary_send(pair: SocatPair) -> None:
    """`hold` (issue 35): how long the control may hold us with XOFF. A control that runs
    the program as it reads it (a drip feed, for programs longer than its memory) holds the
    line for as long as a cut takes: with `hold` 1 s its 1.6 s holds fail the send; with
    `hold` 0 (no limit) the same control gets the whole program."""
    data = b"%\r\n" + b"".join(b"N%03d G01 X1.0 Y2.0\r\n" % n for n in range(6)) + b"%\r\n"
    machine = Machine("Plus", "events", {}, {"port": pair.host, "flow": "xonxoff", "hold": "1"})
    # XOFF at 48 characters buffered, XON at 16, emptied at 20 characters a second.
    with (
        SimulatedControl(pair.control, parity="E", buffer_size=64, consume_cps=20),
        pytest.raises(SendError) as caught,
    ):
        send_program(demo_programs()[0], machine)
    assert "no XON for 1 s" in str(caught.value)
    drip = PortSettings.from_serial({"flow": "xonxoff", "hold": "0"}, target="events")
    assert drip.hold == 0 and "XOFF held without limit" in drip.describe()
    with SimulatedControl(pair.control, parity="E", buffer_size=64, consume_cps=20) as control:
        result = send(data, drip, pair.host, xoff_timeout=math.inf)
        assert control.received(data, timeout=WAIT)
    assert result.outcome is Outcome.OK and result.xoff_count >= 1 and result.held_seconds > 1.0
