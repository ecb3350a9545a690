"""Sending a program to a control and receiving one back, over pyserial.

`send` writes in small chunks at no more than the line rate (or the drip-feed rate), and
between chunks reads what the control sent: with XON/XOFF a DC3 stops it within a chunk
(8 characters at 4800 baud) and a DC1 resumes it. Flow control is done here, not by the
driver (pyserial's `xonxoff` leaves it to the kernel, which cannot be bounded or timed
out), so the port is opened with `xonxoff=False`. Keeping the driver's transmit queue near
empty (`out_waiting`) is what makes the stop prompt on a real UART too.

`receive` waits for the first byte, captures until the program's end (see `framing`) or an
idle timeout, and refuses garbage. Neither function imports or stores anything: the caller
turns a capture into a program (`app.dnc.service`) and keeps the `TransferRecord`.

Both open the port exclusively (a second transfer on the same port is refused) and close it
before returning. A port is a device path (`/dev/ttyUSB0`) or any URL pyserial opens
(`serial.serial_for_url`): `socket://host:port`, a serial device server's raw TCP port,
whose line settings are the device server's (set on the box; nothing here can set or read
them), and `rfc2217://host:port`, whose settings are sent to the server and must be
acknowledged. Times are seconds; rates characters per second; datetimes are UTC without a
time zone, as the library stores them. POSIX only (the select on the port's descriptor).
"""

from __future__ import annotations

import contextlib
import enum
import errno
import os
import select
import termios
import threading
import time
import warnings
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime

import serial

from app.dnc.framing import Capture, EndReason, outgoing_pieces
from app.dnc.settings import DC1, DC3, Flow, Framing, Parity, PortSettings

Progress = Callable[[int, int | None], object]
"""Called as progress(bytes_done, bytes_total) — total None while receiving."""
Cancel = threading.Event | Callable[[], bool]
"""An Event that is set, or a function that returns True, to stop a transfer."""

POLL = 0.05
"""Longest wait between looks at `cancel` and the port (s)."""
LEAD = 0.002
"""How early a chunk is written before its time on the schedule (s), so a real UART has the
next chunk before it finishes the last; the schedule itself holds the rate."""

_PARITY = {Parity.NONE: serial.PARITY_NONE, Parity.EVEN: serial.PARITY_EVEN}
_PARITY[Parity.ODD] = serial.PARITY_ODD
_GONE = {errno.EIO, errno.ENXIO, errno.ENODEV, errno.EBADF}
# What an open port raises when it fails or vanishes: pyserial's own, the OS's, and termios'
# (tcflush and tcsetattr raise termios.error, which is not an OSError).
_PORT_ERRORS = (serial.SerialException, OSError, termios.error)


class Outcome(enum.Enum):
    OK = "ok"
    CANCELLED = "cancelled"
    FAILED = "failed"


class TransferError(Exception):
    """A transfer that failed: the port could not be opened or vanished, the control held
    us off too long, nothing came, or what came is not a program. The message is for the
    user; `result` holds what was done before the failure (for the transfer log)."""


class SendError(TransferError):
    def __init__(self, message: str, result: SendResult) -> None:
        super().__init__(message)
        self.result = result


class ReceiveError(TransferError):
    def __init__(self, message: str, result: ReceiveResult) -> None:
        super().__init__(message)
        self.result = result


def _now() -> datetime:
    return datetime.now(UTC).replace(tzinfo=None)


@dataclass(frozen=True)
class SendResult:
    """A send: `sent` of `total` wire bytes (leader and trailer included), the time it took,
    how often and how long the control held us with XOFF, and the outcome."""

    port: str
    settings: PortSettings
    total: int
    sent: int
    started: datetime
    finished: datetime
    seconds: float
    outcome: Outcome
    xoff_count: int = 0
    held_seconds: float = 0.0
    error: str = ""

    @property
    def line_seconds(self) -> float:
        """What `total` takes at the line rate (s): the floor any send can reach."""
        return self.total / self.settings.line_cps


@dataclass(frozen=True)
class ReceiveResult:
    """A receive: the program `data` (leader and device-control characters removed, parity
    bit stripped) and its `text` (ASCII; empty for punch images), every byte as received in
    `raw`, and how it ended."""

    port: str
    settings: PortSettings
    raw: bytes
    data: bytes
    started: datetime
    finished: datetime
    seconds: float
    outcome: Outcome
    ended_by: EndReason | None = None
    error: str = ""
    text: str = field(default="")


def _cancelled(cancel: Cancel | None) -> bool:
    if cancel is None:
        return False
    if isinstance(cancel, threading.Event):
        return cancel.is_set()
    return bool(cancel())


def _vanished(port_path: str, exc: BaseException) -> str:
    return f"port {port_path} vanished: {exc}"


def is_network(port_path: str) -> bool:
    """Whether `port_path` is a pyserial URL (`socket://…`, `rfc2217://…`), not a device."""
    return "://" in port_path


def _io_error(port_path: str, exc: BaseException) -> str:
    """The message for an error on an open port: gone (unplugged, socat ended) or other."""
    code = getattr(exc, "errno", None)
    if isinstance(exc, termios.error) and exc.args:
        code = exc.args[0]
    text = str(exc)
    gone = (
        code in _GONE
        or "disconnected" in text
        or "Input/output error" in text
        or "connection lost" in text.lower()
        or (not is_network(port_path) and not os.path.exists(port_path))
    )
    return _vanished(port_path, exc) if gone else f"port {port_path} failed: {exc}"


def open_port(
    settings: PortSettings, port_path: str, write_timeout: float
) -> tuple[serial.Serial, PortSettings]:
    """The port opened exclusively, with non-blocking reads and `write_timeout` seconds for
    a write, and the settings in force: with Framing.AUTO, the UART's framing if the port
    took it (read back from the driver), else software parity (`settings.framing`
    SOFTWARE). Raises SettingsError (bad settings) or TransferError (missing, busy, no
    permission, or a port that cannot make the frame asked for)."""
    settings.check()
    if settings.framing is not Framing.SOFTWARE:
        try:
            return _open(settings, port_path, write_timeout, software=False), settings
        except _Refused as exc:
            if settings.framing is Framing.UART or not Framing.can_stand_in(
                settings.data_bits, settings.parity
            ):
                hint = (
                    "; set framing to software (the same frames, parity made by MillBlocks)"
                    if Framing.can_stand_in(settings.data_bits, settings.parity)
                    else ""
                )
                raise TransferError(
                    f"port {port_path} cannot do {settings.frame}: {exc}{hint}"
                ) from None
        settings = replace(settings, framing=Framing.SOFTWARE)
    return _open(settings, port_path, write_timeout, software=True), settings


class _Refused(Exception):
    """The port opened but would not take the data bits or parity."""


def _open(
    settings: PortSettings, port_path: str, write_timeout: float, *, software: bool
) -> serial.Serial:
    bytesize = serial.EIGHTBITS if software or settings.data_bits == 8 else serial.SEVENBITS
    parity = serial.PARITY_NONE if software else _PARITY[settings.parity]
    if is_network(port_path):
        return _open_url(settings, port_path, write_timeout, bytesize, parity)
    try:
        port = serial.Serial(
            port=port_path,
            baudrate=settings.baud,
            bytesize=bytesize,
            parity=parity,
            stopbits=serial.STOPBITS_TWO if settings.stop_bits == 2 else serial.STOPBITS_ONE,
            xonxoff=False,
            rtscts=settings.flow is Flow.RTSCTS,
            timeout=0,
            write_timeout=write_timeout,
            exclusive=True,
        )
    except termios.error as exc:
        # tcsetattr fails (EINVAL) when none of the changes asked for could be made.
        raise _Refused(f"the driver refused it ({exc})") from None
    except (serial.SerialException, OSError, ValueError) as exc:
        text = str(exc)
        if "exclusively lock" in text:
            raise TransferError(f"port {port_path} is busy: another transfer has it") from None
        raise TransferError(f"cannot open port {port_path}: {text}") from None
    # tcsetattr succeeds when any change could be made: read back what the driver kept.
    kept = termios.tcgetattr(port.fileno())[2]
    size = {termios.CS7: 7, termios.CS8: 8}.get(kept & termios.CSIZE, 0)
    want_parity = parity != serial.PARITY_NONE
    if size != bytesize or bool(kept & termios.PARENB) != want_parity:
        _close(port, drop=True)
        kept_frame = f"{size}{'E' if kept & termios.PARENB else 'N'}"
        raise _Refused(f"the driver kept {kept_frame}")
    return port


def _open_url(
    settings: PortSettings, url: str, write_timeout: float, bytesize: int, parity: str
) -> serial.Serial:
    """A network port (any URL pyserial opens). `rfc2217://` sends the frame to the server,
    which must acknowledge each setting (pyserial raises when it does not); `socket://`
    carries the bytes as they are, in the frame the device server was set to."""
    try:
        port = serial.serial_for_url(
            url,
            do_not_open=True,
            baudrate=settings.baud,
            bytesize=bytesize,
            parity=parity,
            stopbits=serial.STOPBITS_TWO if settings.stop_bits == 2 else serial.STOPBITS_ONE,
            xonxoff=False,
            rtscts=settings.flow is Flow.RTSCTS,
            timeout=0,
        )
        # A write that blocks this long fails the send. pyserial's rfc2217 client has no
        # such timeout (it refuses to open with one): its writes go to a socket buffer, and a
        # control that holds off is seen by the flow control.
        if not url.lower().startswith("rfc2217:"):
            port.write_timeout = write_timeout
        with warnings.catch_warnings():
            # pyserial 3.5's rfc2217 client names its reader with Thread.setDaemon/setName.
            warnings.filterwarnings("ignore", "set(Daemon|Name)", DeprecationWarning)
            port.open()
    except (serial.SerialException, OSError, ValueError) as exc:
        text = str(exc)
        if "does not accept parameter change" in text:
            raise _Refused(f"the server refused the settings ({text})") from None
        raise TransferError(f"cannot open port {url}: {text}") from None
    return port


def _wait_input(port: serial.Serial, seconds: float) -> None:
    """Sleep up to `seconds`, waking as soon as the control sends something (a port with
    no descriptor to wait on, such as rfc2217://, is looked at every 10 ms)."""
    if seconds <= 0:
        return
    try:
        fd = port.fileno()
    except (AttributeError, NotImplementedError, OSError, serial.SerialException):
        deadline = time.monotonic() + seconds
        while port.in_waiting == 0 and time.monotonic() < deadline:
            time.sleep(min(0.01, max(0.0, deadline - time.monotonic())))
        return
    select.select([fd], [], [], seconds)


def _read_available(port: serial.Serial) -> bytes:
    waiting = port.in_waiting
    return port.read(waiting) if waiting else b""


def _out_waiting(port: serial.Serial) -> int:
    """Bytes in the driver's transmit queue (0 where the driver cannot tell, e.g. a pty)."""
    try:
        return port.out_waiting
    except (AttributeError, NotImplementedError):  # a network port keeps no count
        return 0
    except OSError as exc:
        if exc.errno in _GONE:
            raise
        return 0


def send(
    data: bytes | Callable[[], Iterable[bytes]],
    settings: PortSettings,
    port_path: str,
    *,
    progress: Progress | None = None,
    cancel: Cancel | None = None,
    xoff_timeout: float = 30.0,
    write_timeout: float = 10.0,
    chunk: int | None = None,
) -> SendResult:
    """Send an export's `data` to the control on `port_path`: its bytes, or a function
    giving them in pieces each time it is called (`Export.chunks`: the export is read
    twice, to check and count it, then to send it, and never held whole in memory).

    The wire bytes are `framing.outgoing_pieces(data, settings)`. They go `chunk` characters at a
    time (default: 1/60 s of line time, 8 at 4800 baud, at most 16), never faster than
    `settings.send_cps`. With XON/XOFF a DC3 from the control holds us until DC1;
    `xoff_timeout` seconds without XON fail the send. With RTS/CTS the driver holds the
    data; a write blocked `write_timeout` seconds, or a transmit queue that does not drain
    for that long, fails the send. `progress(sent, total)` is called after each chunk (from
    this thread); `cancel` is looked at before each chunk and at least every 50 ms.

    Returns the result (outcome OK or CANCELLED; a cancelled send drops what the driver still
    holds, and leaves a partial program in the control). Raises SettingsError or DataError
    before the port is touched, and
    SendError (with the partial result) when the port cannot be opened, vanishes, or the
    control holds us off too long.
    """
    settings.check()
    if chunk is not None and chunk < 1:
        raise ValueError(f"chunk {chunk}: send at least 1 character at a time")
    pieces = (lambda: [data]) if isinstance(data, bytes) else data
    # DataError before the port is touched.
    total = sum(len(piece) for piece in outgoing_pieces(pieces(), settings))
    rate = settings.send_cps
    size = chunk or max(1, min(16, int(rate // 60)))
    started, clock = _now(), time.monotonic()
    state = _SendState()
    used = settings

    def result(outcome: Outcome, error: str = "") -> SendResult:
        return SendResult(
            port=port_path,
            settings=used,
            total=total,
            sent=state.sent,
            started=started,
            finished=_now(),
            seconds=time.monotonic() - clock,
            outcome=outcome,
            xoff_count=state.xoffs,
            held_seconds=state.held,
            error=error,
        )

    try:
        port, used = open_port(settings, port_path, write_timeout)
    except TransferError as exc:
        raise SendError(str(exc), result(Outcome.FAILED, str(exc))) from None
    outcome = Outcome.FAILED
    try:
        wire = _Wire(outgoing_pieces(pieces(), used), total)
        outcome = _send_loop(
            port, wire, used, size, state, progress, cancel, xoff_timeout, write_timeout
        )
        if outcome is Outcome.CANCELLED:
            state.sent -= _out_waiting(port)  # still in the driver: dropped, never sent
    except _Failure as exc:
        raise SendError(exc.message, result(Outcome.FAILED, exc.message)) from None
    except _PORT_ERRORS as exc:
        message = _io_error(port_path, exc)
        raise SendError(message, result(Outcome.FAILED, message)) from None
    finally:
        _close(port, drop=outcome is not Outcome.OK)
    return result(outcome)


@dataclass
class _SendState:
    sent: int = 0
    xoffs: int = 0
    held: float = 0.0


class _Failure(Exception):
    def __init__(self, message: str) -> None:
        super().__init__(message)
        self.message = message


class _Wire:
    """The bytes to send (`total` of them), taken a few at a time from their pieces."""

    def __init__(self, pieces: Iterator[bytes], total: int) -> None:
        self.pieces = pieces
        self.total = total
        self.buffer = b""
        self.at = 0  # in `buffer`

    def take(self, size: int) -> bytes:
        """The next `size` bytes (fewer at the end). Raises _Failure when the pieces end
        before `total`."""
        while len(self.buffer) - self.at < size:
            piece = next(self.pieces, None)
            if piece is None:
                break
            self.buffer = self.buffer[self.at :] + piece
            self.at = 0
        taken = self.buffer[self.at : self.at + size]
        self.at += len(taken)
        if not taken:
            raise _Failure("the export ended before all its bytes were sent")
        return taken


def _send_loop(
    port: serial.Serial,
    wire: _Wire,
    settings: PortSettings,
    size: int,
    state: _SendState,
    progress: Progress | None,
    cancel: Cancel | None,
    xoff_timeout: float,
    write_timeout: float,
) -> Outcome:
    rate = settings.send_cps
    total = wire.total
    software_flow = settings.flow is Flow.XONXOFF
    held_since: float | None = None
    stalled_since: float | None = None
    due = time.monotonic()
    sent = 0
    while sent < total:
        if _cancelled(cancel):
            return Outcome.CANCELLED
        now = time.monotonic()
        if software_flow:
            for byte in _read_available(port):
                code = byte & 0x7F
                if code == DC3 and held_since is None:
                    held_since = now
                    state.xoffs += 1
                elif code == DC1 and held_since is not None:
                    state.held += now - held_since
                    held_since = None
                    due = max(due, now)
            if held_since is not None:
                if now - held_since > xoff_timeout:
                    raise _Failure(
                        f"no XON for {xoff_timeout:g} s: the control sent XOFF after "
                        f"{sent} of {total} bytes and did not resume"
                    )
                _wait_input(port, POLL)
                continue
        if now < due - LEAD:
            _wait_input(port, min(due - LEAD - now, POLL))
            continue
        if _out_waiting(port) > size:
            # The driver has not sent the last chunks: RTS/CTS holding, or a slow adapter.
            stalled_since = stalled_since or now
            if now - stalled_since > write_timeout:
                raise _Failure(
                    f"the port's output did not drain for {write_timeout:g} s after {sent} of "
                    f"{total} bytes (RTS/CTS: the control holds Clear To Send off?)"
                )
            _wait_input(port, min(size / rate, POLL))
            continue
        stalled_since = None
        piece = wire.take(size)
        try:
            port.write(piece)
        except serial.SerialTimeoutException:
            raise _Failure(
                f"a write blocked for {write_timeout:g} s after {sent} of {total} bytes "
                "(RTS/CTS: the control holds Clear To Send off?)"
            ) from None
        sent += len(piece)
        state.sent = sent
        # A fixed schedule at `rate`: a late wake-up is made up (by one chunk at most, so
        # never a burst), so the line is not left idle for the wake-up latency of each chunk.
        due = max(due, now - size / rate) + len(piece) / rate
        if progress is not None:
            progress(sent, total)
    _drain(port, due, write_timeout, total)
    return Outcome.OK


def _drain(port: serial.Serial, due: float, write_timeout: float, total: int) -> None:
    """Wait until the last character has left: the driver's queue is empty and the line
    time of the last chunk has passed. Raises _Failure if the queue does not empty within
    `write_timeout` s (what is left would be dropped when the port closes)."""
    deadline = time.monotonic() + write_timeout
    while (left := _out_waiting(port)) and time.monotonic() < deadline:
        time.sleep(0.01)
    if left:
        raise _Failure(
            f"the port's output did not drain for {write_timeout:g} s: the last {left} of "
            f"{total} bytes did not go (RTS/CTS: the control holds Clear To Send off?)"
        )
    rest = due - time.monotonic()
    if rest > 0:
        time.sleep(rest)


def _close(port: serial.Serial, *, drop: bool) -> None:
    """Close the port. `drop`: first discard what the driver still holds to send (after a
    cancel or a failure it must not go, and Linux's close would wait up to 30 s for it while
    CTS is held off). Otherwise wait for it to leave (tcdrain): discarding then would cut
    the end off a good send, from the UART's FIFO or, on a pty, what the other end has not
    read yet."""
    with contextlib.suppress(*_PORT_ERRORS):  # vanished: nothing to drop or drain
        if drop:
            port.reset_output_buffer()
        else:
            port.flush()
    with contextlib.suppress(*_PORT_ERRORS):
        port.close()


def receive(
    settings: PortSettings,
    port_path: str,
    *,
    idle_timeout: float = 5.0,
    first_byte_timeout: float = 120.0,
    max_bytes: int = 1_000_000,
    progress: Progress | None = None,
    cancel: Cancel | None = None,
) -> ReceiveResult:
    """Receive one program from the control on `port_path` (the operator presses SEND on
    the control after this starts listening; input already waiting is discarded).

    Waits up to `first_byte_timeout` s for the first byte, then captures until the program's
    end (`settings.end`: the closing `%` with its line ending, a word's line, or "idle")
    or until nothing came for `idle_timeout` s. `progress(received, None)` is called as
    bytes arrive; `cancel` is looked at every 50 ms.

    Returns the result (outcome OK, or CANCELLED with what came so far). Raises SettingsError
    for bad settings, and ReceiveError (its result holds the raw capture for the log; nothing
    is imported) when the port cannot be opened or vanishes, nothing came, only leader came,
    more than `max_bytes` came, a program opened with `%` stopped before its closing `%`, or
    the capture has parity errors or bytes that are not program text.
    """
    settings.check()
    capture = Capture(settings)
    started, clock = _now(), time.monotonic()
    used = settings

    def result(outcome: Outcome, error: str = "", ended: EndReason | None = None) -> ReceiveResult:
        data = bytes(capture.data)
        text = "" if settings.is_binary else data.decode("ascii", errors="replace")
        return ReceiveResult(
            port=port_path,
            settings=used,
            raw=bytes(capture.raw),
            data=data,
            started=started,
            finished=_now(),
            seconds=time.monotonic() - clock,
            outcome=outcome,
            ended_by=ended,
            error=error,
            text=text,
        )

    def fail(message: str) -> ReceiveError:
        return ReceiveError(message, result(Outcome.FAILED, message))

    try:
        port, used = open_port(settings, port_path, write_timeout=1.0)
    except TransferError as exc:
        raise fail(str(exc)) from None
    capture = Capture(used)
    try:
        port.reset_input_buffer()
        ended = _receive_loop(
            port, capture, idle_timeout, first_byte_timeout, max_bytes, progress, cancel
        )
    except _Failure as exc:
        problem = capture.problem()  # garbage explains a missing end better than the end
        raise fail(f"{problem}; nothing was imported" if problem else exc.message) from None
    except _PORT_ERRORS as exc:
        raise fail(_io_error(port_path, exc)) from None
    finally:
        _close(port, drop=True)  # nothing of ours to send
    if ended is None:
        return result(Outcome.CANCELLED)
    problem = capture.problem()
    if problem is not None:
        raise fail(f"{problem}; nothing was imported")
    if not capture.started:
        raise fail(
            f"only leader came ({len(capture.raw)} bytes of NUL, DEL or blanks), no program; "
            "nothing was imported"
        )
    return result(Outcome.OK, ended=ended)


def _receive_loop(
    port: serial.Serial,
    capture: Capture,
    idle_timeout: float,
    first_byte_timeout: float,
    max_bytes: int,
    progress: Progress | None,
    cancel: Cancel | None,
) -> EndReason | None:
    """Capture until the end; None when cancelled."""
    start = time.monotonic()
    last: float | None = None  # when the last byte came
    tail_grace = min(idle_timeout, 0.5)
    while True:
        if _cancelled(cancel):
            return None
        now = time.monotonic()
        chunk = _read_available(port)
        if chunk:
            last = now
            capture.feed(chunk)
            if progress is not None:
                progress(len(capture.raw), None)
            if len(capture.raw) > max_bytes:
                raise _Failure(
                    f"more than {max_bytes} bytes came without the program's end "
                    f"({capture.settings.end!r}); nothing was imported"
                )
            if capture.done:
                return EndReason.END_MARK
            continue
        if last is None:
            if now - start > first_byte_timeout:
                line = f"{capture.settings.baud} {capture.settings.frame}"
                raise _Failure(
                    f"nothing came from the control in {first_byte_timeout:g} s: is it set to "
                    f"send, at {line}, and is the cable a null modem?"
                )
        elif capture.in_tail and now - last > tail_grace:
            capture.finish_tail()
            return EndReason.END_MARK
        elif now - last > idle_timeout:
            if capture.awaiting_close:
                raise _Failure(
                    f"the control stopped after {len(capture.raw)} bytes without the closing "
                    f"% (nothing for {idle_timeout:g} s): the program is incomplete; nothing "
                    "was imported"
                )
            return EndReason.IDLE
        _wait_input(port, POLL)
