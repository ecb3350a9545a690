"""A simulated control on one end of a socat pty pair, for the DNC tests and the bench.

`SocatPair` runs `socat -d -d pty,raw,echo=0 pty,raw,echo=0` and gives the two pty paths:
`host` (where MillBlocks opens its port) and `control` (where the simulator sits). Killing
socat makes the host's port vanish as an unplugged adapter does.

`SimulatedControl` behaves like a control's serial input: it takes characters off the line
at `cps` (480 a second: 4800 baud, 10 bits a character — the pty itself has no baud rate)
into a small receive buffer, stores them into its memory at `consume_cps`, sends XOFF (DC3)
when the buffer reaches `xoff_at` and XON (DC1) when it has drained to `xon_at`, and counts
the characters that arrive after each XOFF until its XON (those already waiting in its
input queue when the XOFF went out arrived before it and are not counted: a pty backlog
builds when the simulator's thread runs late, which is not the sender's doing). It can also
send a program back at `cps`, as the control's SEND does. With `parity` ("E" or "O") it
works as a 7-bit line on an 8-bit pty: it checks and strips bit 8 of what arrives and puts
parity in bit 8 of what it sends, so software framing is tested end to end.

It uses os, fcntl and termios only (not pyserial), so it shares no code with what it tests.
"""

from __future__ import annotations

import array
import contextlib
import fcntl
import os
import re
import select
import shutil
import signal
import subprocess
import tempfile
import termios
import threading
import time
import tty
from collections import deque
from pathlib import Path
from types import TracebackType

DC1, DC3 = 0x11, 0x13


def _parity_bit(value: int, parity: str) -> int:
    ones = (value & 0x7F).bit_count() & 1
    return ones if parity == "E" else ones ^ 1


class SocatPair:
    """Two ptys joined by socat. Use as a context manager; `close` always ends socat."""

    def __init__(self, timeout: float = 5.0) -> None:
        if shutil.which("socat") is None:
            raise RuntimeError("socat is not installed: apt-get install socat (Debian package)")
        self._log = tempfile.NamedTemporaryFile("w+", prefix="socat-", suffix=".log")  # noqa: SIM115
        self.process = subprocess.Popen(
            ["socat", "-d", "-d", "pty,raw,echo=0", "pty,raw,echo=0"],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=self._log,
        )
        paths: list[str] = []
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            text = Path(self._log.name).read_text(errors="replace")
            paths = re.findall(r"PTY is (\S+)", text)
            if len(paths) == 2 and "starting data transfer loop" in text:
                break
            if self.process.poll() is not None:
                break
            time.sleep(0.01)
        else:
            self.close()
            raise RuntimeError(f"socat did not open two ptys in {timeout} s")
        if len(paths) != 2:
            self.close()
            raise RuntimeError(f"socat failed: {Path(self._log.name).read_text()}")
        self.host, self.control = paths

    def kill(self) -> None:
        """End socat at once (SIGKILL): both ptys vanish."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGKILL)
        self.process.wait(timeout=5)

    def close(self) -> None:
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.kill()
        self._log.close()

    def __enter__(self) -> SocatPair:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()


class SimulatedControl:
    """A control's serial port on `path`, run by a thread between `start` and `stop`."""

    def __init__(
        self,
        path: str,
        *,
        cps: float = 480.0,
        buffer_size: int = 64,
        xoff_at: int = 48,
        xon_at: int = 16,
        consume_cps: float | None = None,
        xon_xoff: bool = True,
        parity: str | None = None,
        hold_after: int | None = None,
    ) -> None:
        """`consume_cps` None: memory takes characters as fast as they come. `hold_after`:
        send XOFF after that many characters and never XON (a control that hangs)."""
        self.path = path
        self.cps = cps
        self.buffer_size = buffer_size
        self.xoff_at = xoff_at
        self.xon_at = xon_at
        self.consume_cps = consume_cps
        self.xon_xoff = xon_xoff
        self.parity = parity
        self.hold_after = hold_after
        self.memory = bytearray()  # what the control stored, in order
        self.after_xoff: list[int] = []  # characters that came after each XOFF, until XON
        self.queued_at_xoff: list[int] = []  # characters already queued at each XOFF
        self.overflowed = 0  # characters lost to a full buffer
        self.parity_errors = 0
        self.line_bytes = 0  # characters taken off the line
        self.error: str = ""
        self._buffer: deque[int] = deque()
        self._outgoing: deque[int] = deque()
        self._send_at = 0.0
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._fd = -1

    # -- control ----------------------------------------------------------------------------

    def start(self) -> SimulatedControl:
        self._fd = os.open(self.path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        tty.setraw(self._fd)
        attrs = termios.tcgetattr(self._fd)
        attrs[0] &= ~(termios.IXON | termios.IXOFF | termios.ISTRIP)
        termios.tcsetattr(self._fd, termios.TCSANOW, attrs)
        self._thread = threading.Thread(target=self._run, name="simulated-control", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
        if self._fd >= 0:
            with contextlib.suppress(OSError):
                os.close(self._fd)
            self._fd = -1

    def __enter__(self) -> SimulatedControl:
        return self.start()

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.stop()

    def send_back(self, data: bytes, delay: float = 0.2) -> None:
        """Send `data` to the host at `cps` (as written: give it the control's leader),
        starting `delay` s from now — the operator presses SEND once the host listens (a
        receive discards what was waiting before it opened the port)."""
        if self.parity is not None:
            data = bytes(b | (_parity_bit(b, self.parity) << 7) for b in data)
        with self._lock:
            self._send_at = time.monotonic() + delay
            self._outgoing.extend(data)

    @property
    def sending(self) -> bool:
        with self._lock:
            return bool(self._outgoing)

    def wait_for(self, count: int, timeout: float) -> bool:
        """Wait until `count` characters are in memory."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if len(self.memory) >= count:
                return True
            time.sleep(0.01)
        return len(self.memory) >= count

    def received(self, data: bytes, timeout: float) -> bool:
        """Wait until as many characters as `data` has are in memory, then say whether they
        are `data`. Give the bytes as they travel (CR LF where the sender ends lines so): a
        count of other bytes stops the wait too early or too late."""
        self.wait_for(len(data), timeout)
        return bytes(self.memory) == data

    def wait_sent(self, timeout: float) -> bool:
        """Wait until everything given to `send_back` has gone."""
        deadline = time.monotonic() + timeout
        while self.sending and time.monotonic() < deadline:
            time.sleep(0.01)
        return not self.sending

    # -- the thread ---------------------------------------------------------------------------

    def _run(self) -> None:
        try:
            self._loop()
        except OSError as exc:  # the pty vanished (socat killed): stop, keep what came
            self.error = str(exc)

    def _loop(self) -> None:
        fd = self._fd
        last = time.monotonic()
        rx_tokens = tx_tokens = consume_tokens = 0.0
        burst = max(2.0, self.cps / 50)  # a UART's FIFO: at most 20 ms of line time at once
        holding = False  # XOFF sent, XON not yet
        after = 0
        while not self._stop.is_set():
            now = time.monotonic()
            elapsed, last = now - last, now
            rx_tokens = min(rx_tokens + elapsed * self.cps, burst)
            tx_tokens = min(tx_tokens + elapsed * self.cps, burst)
            if int(rx_tokens) > 0:
                try:
                    data = os.read(fd, int(rx_tokens))
                except BlockingIOError:
                    data = b""
                rx_tokens -= len(data)
                for byte in data:
                    self.line_bytes += 1
                    if holding:
                        after += 1
                    if self.parity is not None:
                        if (byte >> 7) != _parity_bit(byte, self.parity):
                            self.parity_errors += 1
                        byte &= 0x7F
                    if len(self._buffer) >= self.buffer_size:
                        self.overflowed += 1
                    else:
                        self._buffer.append(byte)
            if self.consume_cps is None:
                self.memory.extend(self._buffer)
                self._buffer.clear()
            else:
                # Storing is not the line: time this thread lost is made up (up to 0.1 s).
                store_burst = max(2.0, self.consume_cps / 10)
                consume_tokens = min(consume_tokens + elapsed * self.consume_cps, store_burst)
                while consume_tokens >= 1 and self._buffer:
                    self.memory.append(self._buffer.popleft())
                    consume_tokens -= 1
            if self.xon_xoff:
                hold = self.hold_after is not None and self.line_bytes >= self.hold_after
                # Characters waiting in the input queue have arrived (a real control's UART
                # would hold them): they fill the buffer too. They pile up when this thread
                # runs late on a loaded machine, which is not the sender's doing.
                queued = self._queued()
                fill = len(self._buffer) + queued
                if not holding and (fill >= self.xoff_at or hold):
                    # Those already queued came before the XOFF and do not count against
                    # the sender (read before the XOFF goes: one arriving in between does).
                    self.queued_at_xoff.append(queued)
                    after = -queued
                    self._signal(DC3)
                    holding = True
                elif holding and not hold and fill <= self.xon_at:
                    self._signal(DC1)
                    self.after_xoff.append(after)
                    holding = False
            with self._lock:
                ready = now >= self._send_at
                count = min(int(tx_tokens), len(self._outgoing)) if ready else 0
                chunk = bytes(self._outgoing.popleft() for _ in range(count))
            if chunk:
                self._write(chunk)
                tx_tokens -= len(chunk)
            if rx_tokens >= 1:
                select.select([fd], [], [], 0.002)  # wake when a character comes
            else:
                time.sleep(0.002)  # the line is busy: no character can come yet
        if holding:
            self.after_xoff.append(after)

    def _queued(self) -> int:
        """Characters in the input queue, not yet taken off the line (FIONREAD)."""
        count = array.array("i", [0])
        fcntl.ioctl(self._fd, termios.FIONREAD, count, True)
        return count[0]

    def _signal(self, code: int) -> None:
        """XON or XOFF, with its parity bit on a 7-bit line."""
        if self.parity is not None:
            code |= _parity_bit(code, self.parity) << 7
        self._write(bytes([code]))

    def _write(self, data: bytes) -> None:
        os.write(self._fd, data)


def free_port() -> int:
    """A TCP port on the loopback nobody listens on now."""
    import socket

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


class SocketBridge:
    """A serial device server's raw TCP port, played by socat: `url` (socket://127.0.0.1:N)
    on one side, a pty (`control`, where the simulated control listens) on the other.
    Like a device server, it carries bytes and makes no frame of its own."""

    def __init__(self, timeout: float = 5.0) -> None:
        if shutil.which("socat") is None:
            raise RuntimeError("socat is not installed: apt-get install socat (Debian package)")
        self._log = tempfile.NamedTemporaryFile("w+", prefix="socat-", suffix=".log")  # noqa: SIM115
        self.tcp = free_port()
        self.url = f"socket://127.0.0.1:{self.tcp}"
        # The pty first (it exists at once, for the control to open), then the listening
        # socket, which takes the one connection a transfer makes.
        link = str(Path(self._log.name).with_suffix(".pty"))
        self.process = subprocess.Popen(
            [
                "socat",
                "-d",
                "-d",
                f"pty,raw,echo=0,link={link}",
                f"TCP-LISTEN:{self.tcp},bind=127.0.0.1,reuseaddr",
            ],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=self._log,
        )
        self.control = link
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            text = Path(self._log.name).read_text(errors="replace")
            if "listening on" in text:
                break
            if self.process.poll() is not None:
                raise RuntimeError(f"socat failed: {text}")
            time.sleep(0.01)
        else:
            self.close()
            raise RuntimeError(f"socat did not listen on {self.tcp} in {timeout} s")

    def close(self) -> None:
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(timeout=5)
        self._log.close()

    def __enter__(self) -> SocketBridge:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()
