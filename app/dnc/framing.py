"""The bytes on the wire, without a port: what `send` writes and how `receive` reads a capture.

Outgoing: the export's line endings become the machine's, the NUL leader and trailer are
added, and with software framing each character gets its parity in bit 8. Incoming: a
`Capture` is fed bytes as they arrive; it checks software parity, drops the tape leader
(NUL, DEL), finds where the program ends (the closing `%`, a word such as M30, or nothing
but the idle timeout) and says what is wrong with data that is not program text.

Offsets in messages count from 0 at the first byte received (or the first byte of the data
handed to `outgoing`).
"""

from __future__ import annotations

import enum
import re
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

from app.cnc.formats.targets import get_target
from app.dnc.settings import DC1, DC2, DC3, DC4, DEL, NUL, Framing, Parity, PortSettings

CR, LF, TAB = 0x0D, 0x0A, 0x09
_DEVICE_CONTROL = frozenset({DC1, DC2, DC3, DC4})
_SKIPPED_TEXT = frozenset({NUL, DEL}) | _DEVICE_CONTROL
_SKIPPED_BINARY = frozenset({0x00, 0x7F, 0xFF})  # blank tape; EIA delete; ASCII delete


class DataError(ValueError):
    """Data the line cannot carry as set (a byte that does not fit, not program text).
    Raised before the port is opened."""


def parity_bit(value: int, parity: Parity) -> int:
    """The bit that makes the count of ones in the 7-bit `value` even (EVEN) or odd (ODD)."""
    ones = (value & 0x7F).bit_count() & 1
    return ones if parity is Parity.EVEN else ones ^ 1


def add_parity(data: bytes, parity: Parity) -> bytes:
    """Each 7-bit character with its parity in bit 8 (software framing)."""
    return bytes(b | (parity_bit(b, parity) << 7) for b in data)


def check_parity(byte: int, parity: Parity) -> bool:
    """Whether an 8-bit `byte` holds the right parity for its low 7 bits in bit 8."""
    return (byte >> 7) == parity_bit(byte, parity)


_NOT_TEXT = re.compile(rb"[^\x09\x0a\x0d\x20-\x7f]")
_EIGHT_BIT = re.compile(rb"[\x80-\xff]")


def outgoing(data: bytes, settings: PortSettings) -> bytes:
    """The bytes `send` writes for an export's `data` (see `outgoing_pieces`)."""
    return b"".join(outgoing_pieces([data], settings))


def outgoing_pieces(pieces: Iterable[bytes], settings: PortSettings) -> Iterator[bytes]:
    """The bytes `send` writes for an export that comes in `pieces`, piece by piece: line
    endings made the machine's (text targets; punch images go as they are), NUL leader and
    trailer around them, and with software framing the parity in bit 8.

    Raises DataError (when the piece holding it is reached) for a byte that cannot go: a
    text target's byte that is not 7-bit ASCII program text, or any byte above 0x7F on a
    7-bit line; its offset counts from the export's first byte.
    """
    software = settings.framing is Framing.SOFTWARE

    def framed(data: bytes) -> bytes:
        return add_parity(data, settings.parity) if software else data

    yield framed(bytes(settings.leader))
    offset = 0  # of the piece's first byte in the whole export
    newlines = 0  # LFs before it, and where the last one was (for line and column)
    last_newline = -1
    carry = b""  # a CR at the end of a piece: a CR LF may be split between two
    for data in pieces:
        if settings.is_binary:
            if settings.data_bits == 7 and (bad := _EIGHT_BIT.search(data)) is not None:
                at = offset + bad.start()
                raise DataError(
                    f"byte 0x{data[bad.start()]:02X} at offset {at} does not fit in 7 data bits"
                )
            body = data
        else:
            found = _NOT_TEXT.search(data)
            if found is not None:
                k = found.start()
                before = data[:k]
                line = newlines + before.count(b"\n") + 1
                previous = before.rfind(b"\n")
                start = offset + previous if previous >= 0 else last_newline
                place = f"offset {offset + k} (line {line}, column {offset + k - start})"
                byte = data[k]
                what = (
                    f"byte 0x{byte:02X} at {place} is not ASCII: controls read 7-bit ASCII "
                    f"program text ({settings.target} export)"
                    if byte > 0x7F
                    else f"control character 0x{byte:02X} at {place} is not program text "
                    f"({settings.target} export)"
                )
                raise DataError(what)
            newlines += data.count(b"\n")
            last = data.rfind(b"\n")
            if last >= 0:
                last_newline = offset + last
            text = carry + data
            carry = b"\r" if text.endswith(b"\r") else b""
            if carry:
                text = text[:-1]
            body = _line_ends(text, settings)
        offset += len(data)
        yield framed(body)
    if carry:
        yield framed(_line_ends(carry, settings))
    yield framed(bytes(settings.trailer))


def _line_ends(text: bytes, settings: PortSettings) -> bytes:
    lines = text.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    return lines.replace(b"\n", settings.eol.bytes)


class EndReason(enum.Enum):
    """How a capture ended."""

    END_MARK = "end mark"  # the closing `%` (or the configured word's line)
    IDLE = "idle"  # nothing for the idle timeout after data


class _State(enum.Enum):
    LEADER = "leader"
    BODY = "body"
    LINE = "line"  # after the end word: up to the end of its line
    TAIL = "tail"  # after the end mark: only its CR/LF
    DONE = "done"


@dataclass(frozen=True)
class Fault:
    """The first thing wrong in a capture, and how many bytes were wrong."""

    offset: int
    byte: int
    what: str
    count: int


class Capture:
    """A program arriving byte by byte. `feed` what comes in; `done` turns true at the end
    mark (with its line ending); `data` is the program (leader, NUL/DEL and device-control
    characters removed, parity bit stripped), `raw` every byte as received.

    `fault` is the first parity error or byte that is not program text (text targets only;
    punch images are not checked), with the count of such bytes.
    """

    def __init__(self, settings: PortSettings) -> None:
        self.settings = settings
        self.raw = bytearray()
        self.data = bytearray()
        self.skipped = 0
        self.parity_fault: Fault | None = None
        self.text_fault: Fault | None = None
        self._state = _State.LEADER
        self._opened_with_mark = False
        if settings.is_binary:
            # The target's own end mark: a punch image's rewind stop, not the ASCII `%`.
            self._mark = get_target(settings.target).end_mark
        else:
            self._mark = b"%" if settings.end in ("%", "idle") else settings.end.encode("ascii")

    @property
    def done(self) -> bool:
        return self._state is _State.DONE

    @property
    def started(self) -> bool:
        """Whether anything past the leader has come."""
        return bool(self.data)

    @property
    def awaiting_close(self) -> bool:
        """Whether the program opened with `%` and its closing `%` has not come."""
        return self._opened_with_mark and self._state is _State.BODY

    @property
    def in_tail(self) -> bool:
        """The end mark has come; only its line ending may follow."""
        return self._state in (_State.LINE, _State.TAIL)

    def finish_tail(self) -> None:
        """Take the capture as ended at its end mark (no more of its line ending came)."""
        if self.in_tail:
            self._state = _State.DONE

    def feed(self, chunk: bytes) -> int:
        """Take bytes as received; returns how many were used (the rest come after the end
        and are kept in `raw` only)."""
        for index, byte in enumerate(chunk):
            if self._state is _State.DONE:
                self.raw += chunk[index:]
                return index
            offset = len(self.raw)
            self.raw.append(byte)
            self._take(offset, self._strip(offset, byte))
        return len(chunk)

    # -- one byte ---------------------------------------------------------------------------

    def _strip(self, offset: int, byte: int) -> int:
        settings = self.settings
        if settings.framing is not Framing.SOFTWARE:
            return byte
        if not check_parity(byte, settings.parity):
            self.parity_fault = _count(self.parity_fault, offset, byte, "parity error")
        return byte & 0x7F

    def _take(self, offset: int, byte: int) -> None:
        if self.settings.is_binary:
            self._take_binary(byte)
            return
        state = self._state
        if state in (_State.TAIL, _State.LINE) and byte in (CR, LF):
            self.data.append(byte)
            if byte == LF:
                self._state = _State.DONE
            elif state is _State.LINE:
                self._state = _State.TAIL  # a CR ends the line; an LF may follow
            return
        if state is _State.TAIL:
            self._state = _State.DONE  # the trailer or the next thing: not the program's
            return
        if byte in _SKIPPED_TEXT:
            self.skipped += 1
            return
        if state is _State.LEADER:
            if byte in (CR, LF, 0x20, TAB):
                self.skipped += 1
                return
            self._state = state = _State.BODY
            self._opened_with_mark = self.settings.end == "%" and byte == ord("%")
            self.data.append(byte)
            self._check_text(offset, byte)
            return
        self.data.append(byte)
        self._check_text(offset, byte)
        if state is _State.BODY and self.settings.end != "idle" and self._at_mark():
            self._state = _State.TAIL if self.settings.end == "%" else _State.LINE

    def _take_binary(self, byte: int) -> None:
        if self._state is _State.LEADER:
            if byte in _SKIPPED_BINARY:
                self.skipped += 1
                return
            self._state = _State.BODY
            self._opened_with_mark = byte == self._mark[0]
            self.data.append(byte)
            return
        self.data.append(byte)
        if self.settings.end != "idle" and self._at_mark():
            self._state = _State.DONE

    def _at_mark(self) -> bool:
        if not self.data.endswith(self._mark):
            return False
        # The `%` that opened the program is not its end.
        return not (self._opened_with_mark and len(self.data) == len(self._mark))

    def _check_text(self, offset: int, byte: int) -> None:
        if byte > 0x7F:
            what = "not 7-bit ASCII"
        elif byte < 0x20 and byte not in (CR, LF, TAB):
            what = "a control character, not program text"
        else:
            return
        self.text_fault = _count(self.text_fault, offset, byte, what)

    # -- the verdict ------------------------------------------------------------------------

    def problem(self) -> str | None:
        """Why this capture is not a program, or None. Parity errors come first (they mean
        a wrong line setting or noise), then bytes that are not program text."""
        line = f"the machine is set to {self.settings.baud} {self.settings.frame}"
        for fault in (self.parity_fault, self.text_fault):
            if fault is not None:
                more = f" ({fault.count} bytes in all)" if fault.count > 1 else ""
                return (
                    f"garbage from the control: byte 0x{fault.byte:02X} at offset "
                    f"{fault.offset} is {'a ' if fault.what == 'parity error' else ''}"
                    f"{fault.what}{more}; check the baud rate, data bits and parity ({line})"
                )
        return None


def _count(previous: Fault | None, offset: int, byte: int, what: str) -> Fault:
    if previous is None:
        return Fault(offset, byte, what, 1)
    return Fault(previous.offset, previous.byte, previous.what, previous.count + 1)
