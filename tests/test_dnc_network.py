"""Network serial ports (issue 35): a serial device server's `socket://` port and an RFC 2217
server, each bridged to a pty where the simulated control listens — no mocks.

socat plays the device server's raw TCP port (bytes through, no frame of its own); the RFC
2217 server is pyserial's own `PortManager` over a pty, the protocol a Moxa or Digi box
speaks. Before: every URL failed with "No such file or directory" (the port was taken for
a device path).
"""

from __future__ import annotations

import shutil
import socket
import threading
from collections.abc import Iterator
from typing import Any, cast

import pytest
import serial
import serial.rfc2217

from app.cnc.formats.targets import export
from app.dnc.settings import EndOfLine, Parity, PortSettings
from app.dnc.transfer import Outcome, SendError, receive, send
from app.storage.demo import demo_programs
from tests.simulated_control import SimulatedControl, SocatPair, SocketBridge, free_port

WAIT = 30.0
EIGHT_N_ONE = PortSettings(baud=9600, data_bits=8, parity=Parity.NONE, eol=EndOfLine.LF)


@pytest.fixture(scope="module")
def events() -> bytes:
    return export(demo_programs()[0], "events").data


@pytest.fixture
def bridge() -> Iterator[SocketBridge]:
    if shutil.which("socat") is None:
        pytest.fail("socat is not installed: add the Debian package socat (apt-get install socat)")
    with SocketBridge() as joined:
        yield joined


def test_a_socket_port_receives_byte_for_byte_what_a_local_port_does(
    bridge: SocketBridge, events: bytes
) -> None:
    settings = PortSettings(leader=10, trailer=5)
    with SimulatedControl(bridge.control, buffer_size=4096) as control:
        result = send(events, settings, bridge.url)
        assert control.wait_for(result.total, timeout=WAIT)
    over_network = bytes(control.memory)
    with SocatPair() as pair, SimulatedControl(pair.control, buffer_size=4096) as local:
        sent = send(events, settings, pair.host)
        assert local.wait_for(sent.total, timeout=WAIT)
    assert result.outcome is Outcome.OK and result.port == bridge.url
    # The device server makes the frame: the data bytes go as they are (a local pty gets
    # MillBlocks' software parity on the same 7E1 settings, so compare the 7 data bits).
    assert over_network == bytes(10) + events + bytes(5)
    assert over_network == bytes(b & 0x7F for b in local.memory)
    assert result.seconds >= 0.95 * result.line_seconds  # paced at the line rate, too


def test_a_socket_port_receives_a_program(bridge: SocketBridge, events: bytes) -> None:
    with SimulatedControl(bridge.control, buffer_size=4096) as control:
        control.send_back(events, delay=0.5)
        got = receive(PortSettings(), bridge.url, first_byte_timeout=WAIT, idle_timeout=2.0)
    assert got.outcome is Outcome.OK
    assert got.data == events


def test_an_unreachable_network_port_says_so() -> None:
    """A device server that is off or a wrong port number: the URL and the reason."""
    url = f"socket://127.0.0.1:{free_port()}"
    with pytest.raises(SendError) as caught:
        send(b"%\r\nG100\r\n%\r\n", EIGHT_N_ONE, url)
    message = str(caught.value)
    assert message.startswith(f"cannot open port {url}: ")
    assert "No such file or directory" not in message
    assert "refused" in message.lower()


class _PtyAsUart(serial.Serial):
    """The server's port: a pty, which has no modem lines (its ioctls fail); a UART's
    lines are not what these tests are about, so they read as off and set as nothing."""

    def _update_rts_state(self) -> None:
        pass

    def _update_dtr_state(self) -> None:
        pass

    @property
    def cts(self) -> bool:
        return False

    @property
    def dsr(self) -> bool:
        return False

    @property
    def ri(self) -> bool:
        return False

    @property
    def cd(self) -> bool:
        return False


class _Connection:
    """What PortManager writes its answers to (it calls `write`)."""

    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock

    def write(self, data: bytes) -> None:
        self.sock.sendall(data)


class Rfc2217Server:
    """An RFC 2217 server (pyserial's PortManager) in front of the host end of a pty pair:
    what it negotiates is applied to its own port, which tests read back."""

    def __init__(self, device: str) -> None:
        self.port = _PtyAsUart(device, timeout=0.05)
        self.listener = socket.create_server(("127.0.0.1", free_port()))
        self.url = f"rfc2217://127.0.0.1:{self.listener.getsockname()[1]}"
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        self.listener.settimeout(0.1)
        while not self._stop.is_set():
            try:
                client, _ = self.listener.accept()
            except TimeoutError:
                continue
            client.settimeout(0.02)
            # The stubs type both as rfc2217.Serial; PortManager uses only a port's settings
            # and the connection's `write`.
            manager = serial.rfc2217.PortManager(
                cast(Any, self.port), cast(Any, _Connection(client))
            )
            while not self._stop.is_set():
                waiting = self.port.in_waiting
                if waiting:
                    client.sendall(b"".join(manager.escape(self.port.read(waiting))))
                try:
                    data = client.recv(4096)
                except TimeoutError:
                    continue
                except OSError:
                    break
                if not data:
                    break
                self.port.write(b"".join(manager.filter(data)))
            client.close()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        self.listener.close()
        self.port.close()


def test_an_rfc2217_port_sends_with_its_settings_applied_by_the_server(
    events: bytes,
) -> None:
    """The frame goes to the server, which sets its own port (9600 8N1 here: a pty refuses
    7-bit frames), and the bytes arrive as sent."""
    gcode = export(demo_programs()[0], "gcode-linuxcnc").data
    with SocatPair() as pair:
        server = Rfc2217Server(pair.host)
        try:
            with SimulatedControl(pair.control, cps=960, buffer_size=8192) as control:
                result = send(gcode, EIGHT_N_ONE, server.url)
                assert control.received(gcode, timeout=WAIT)
            assert server.port.baudrate == 9600
            assert server.port.bytesize == 8 and server.port.parity == serial.PARITY_NONE
        finally:
            server.close()
    assert result.outcome is Outcome.OK
