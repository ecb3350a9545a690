"""Serial port settings for one machine: the line (baud, framing, flow control) and what is
sent on it (the export target, line endings, NUL leader and trailer, drip-feed rate).

The defaults are the ProtoTRAK Plus's (seed 003 §1): 4800 baud, 7 data bits, even parity,
1 stop bit. A machine profile stores them as a dict of text values (`Machine.serial`, the
web form's fields); `PortSettings.from_serial` reads that dict and refuses, with a message
naming the field, anything the line cannot do. Nothing here opens a port.
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

from app.cnc.formats.targets import targets

BAUD_RATES = (110, 150, 300, 600, 1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200)
"""The standard rates a UART and the controls of the period offer (bits per second)."""

DEFAULT_TARGET = "events"
MAX_LEADER = 10_000
MAX_HOLD = 86_400  # s: the longest XOFF hold a machine may set (a day); 0 is no limit
"""Most NUL characters in a leader or trailer (10 000 is 21 s at 4800 baud)."""

DC1 = 0x11  # XON: the control asks us to go on
DC2 = 0x12  # tape punch on (some controls send it before a program)
DC3 = 0x13  # XOFF: the control asks us to stop
DC4 = 0x14  # tape punch off
NUL = 0x00
DEL = 0x7F


class SettingsError(ValueError):
    """Settings the line cannot use, or data they cannot carry. The message says which
    field is wrong and what is allowed; nothing has touched the port. `field` is the key of
    `Machine.serial` at fault (`baud`), "" when the fault is not one setting's."""

    def __init__(self, message: str, field: str = "") -> None:
        super().__init__(message)
        self.field = field


class Parity(enum.Enum):
    """Parity bit after the data bits (its letter is the one of `7E1`)."""

    NONE = "N"
    EVEN = "E"
    ODD = "O"


class Flow(enum.Enum):
    """Flow control: how the control tells us to stop sending."""

    NONE = "none"
    XONXOFF = "xonxoff"  # DC3 (XOFF) stops us, DC1 (XON) resumes; done by us, not the driver
    RTSCTS = "rtscts"  # the control drops CTS; done by the UART driver


class EndOfLine(enum.Enum):
    """The line ending put on the wire for text targets (punch images are sent as they are)."""

    CRLF = "crlf"
    LF = "lf"
    CR = "cr"

    @property
    def bytes(self) -> bytes:
        return {"crlf": b"\r\n", "lf": b"\n", "cr": b"\r"}[self.value]


class Framing(enum.Enum):
    """Who makes the parity bit of a 7-bit line.

    UART: pyserial is given the data bits and parity; the UART adds the bit and strips it.
    SOFTWARE (7 data bits with even or odd parity only): the UART runs 8 data bits without
    parity and we put the parity in bit 8 on the way out and check it on the way in. On the
    wire that is the same frame (start, 7 data bits, parity, stop bits), so it serves ports
    with no 7-bit mode (some USB adapters; a pty, which refuses CS7 and PARENB), and it is
    the only way parity errors reach us: pyserial opens ports with the kernel's parity check
    (INPCK) off. AUTO (the default): UART if the port takes the settings (read back after
    opening), else SOFTWARE where it can stand in, else a clear error.
    """

    AUTO = "auto"
    UART = "uart"
    SOFTWARE = "software"

    @staticmethod
    def can_stand_in(data_bits: int, parity: Parity) -> bool:
        """Whether software framing makes the same frames as the UART would."""
        return data_bits == 7 and parity is not Parity.NONE


_PARITY_WORDS = {
    "n": Parity.NONE,
    "none": Parity.NONE,
    "e": Parity.EVEN,
    "even": Parity.EVEN,
    "o": Parity.ODD,
    "odd": Parity.ODD,
}
_FLOW_WORDS = {
    "none": Flow.NONE,
    "off": Flow.NONE,
    "xonxoff": Flow.XONXOFF,
    "xon/xoff": Flow.XONXOFF,
    "xon-xoff": Flow.XONXOFF,
    "software": Flow.XONXOFF,
    "rtscts": Flow.RTSCTS,
    "rts/cts": Flow.RTSCTS,
    "rts-cts": Flow.RTSCTS,
    "hardware": Flow.RTSCTS,
}
_EOL_WORDS = {
    "crlf": EndOfLine.CRLF,
    "cr lf": EndOfLine.CRLF,
    "cr-lf": EndOfLine.CRLF,
    "lf": EndOfLine.LF,
    "cr": EndOfLine.CR,
}


@dataclass(frozen=True)
class PortSettings:
    """One machine's line and what goes on it. Build with `from_serial`, or directly and
    then `check()` (the transfer functions check again).

    baud: bits per second. data_bits: 7 or 8. stop_bits: 1 or 2. leader/trailer: NUL
    characters sent before/after the program. cps: drip-feed limit in characters per second
    (None: the line rate). end: how a received program ends: "%" (the `%` that closes a
    program that began with `%`, else the first `%`), "idle" (only the idle timeout), or a
    word such as "M30" (the end of the line holding it). target: the export target sent.
    hold: seconds the control may hold a send with XOFF before it fails; 0 for no limit — a
    drip feed, where the control runs the program as it reads it and holds the line for as
    long as a cut takes (the operator can still cancel). requests: the transfer service
    listens on the port while it is idle and answers a request sent from the control with
    the program it names (app.dnc.requests); anything else it sends is received.
    """

    baud: int = 4800
    data_bits: int = 7
    parity: Parity = Parity.EVEN
    stop_bits: int = 1
    flow: Flow = Flow.NONE
    eol: EndOfLine = EndOfLine.CRLF
    leader: int = 0
    trailer: int = 0
    target: str = DEFAULT_TARGET
    cps: int | None = None
    framing: Framing = Framing.AUTO
    end: str = "%"
    hold: int = 30
    requests: bool = False

    # -- reading and writing the machine's dict ----------------------------------------------

    @classmethod
    def from_serial(cls, serial: Mapping[str, Any], target: str | None = None) -> PortSettings:
        """Settings from a machine's `serial` dict (text or numbers; `port` is ignored, see
        `port_of`). `target` is the machine's export target, used when the dict names none.
        Missing fields take the defaults (4800 7E1, no flow control, CR LF).

        Raises SettingsError naming the first field that cannot be read or used.
        """
        unknown = sorted(set(serial) - set(SERIAL_FIELDS) - {"port"})
        if unknown:
            known = ", ".join(("port", *SERIAL_FIELDS))
            raise SettingsError(
                f"unknown serial setting {unknown[0]!r}; the settings: {known}", unknown[0]
            )
        values: dict[str, Any] = {}
        for name, reader in _READERS.items():
            raw = serial.get(name)
            if raw is None or (isinstance(raw, str) and not raw.strip()):
                continue
            values[name] = reader(name, raw)
        if "target" not in values and target:
            values["target"] = target
        settings = cls(**values)
        settings.check()
        return settings

    def to_serial(self, port: str = "") -> dict[str, str]:
        """The dict to store in `Machine.serial` (text values, as the web form keeps them).
        The target is left out: the machine's own target is the one (`from_serial` takes a
        `target` key only as a deliberate override)."""
        out = {"port": port}
        for f in fields(self):
            if f.name == "target":
                continue
            value = getattr(self, f.name)
            if isinstance(value, enum.Enum):
                out[f.name] = str(value.value)
            elif isinstance(value, bool):
                out[f.name] = "on" if value else "off"
            elif value is None:
                out[f.name] = ""
            else:
                out[f.name] = str(value)
        return out

    # -- what the line does ---------------------------------------------------------------------

    @property
    def bits_per_character(self) -> int:
        """Start bit, data bits, parity bit and stop bits: 10 for 7E1 and for 8N1."""
        return 1 + self.data_bits + (0 if self.parity is Parity.NONE else 1) + self.stop_bits

    @property
    def line_cps(self) -> float:
        """The line's own rate in characters per second (480 at 4800 baud 7E1)."""
        return self.baud / self.bits_per_character

    @property
    def send_cps(self) -> float:
        """The rate `send` holds to: the drip-feed limit, else the line rate."""
        return float(self.cps) if self.cps is not None else self.line_cps

    @property
    def is_binary(self) -> bool:
        """A binary target (a punch image: 8-bit rows, channel 8 in bit 8) is sent as it is."""
        target = targets().get(self.target)
        return target is not None and target.binary

    @property
    def frame(self) -> str:
        """`7E1`, `8N1`, …"""
        return f"{self.data_bits}{self.parity.value}{self.stop_bits}"

    def describe(self) -> str:
        """One line for logs and pages: `4800 7E1, XON/XOFF, CR LF, events`."""
        flow = {Flow.NONE: "no flow control", Flow.XONXOFF: "XON/XOFF", Flow.RTSCTS: "RTS/CTS"}
        parts = [f"{self.baud} {self.frame}", flow[self.flow]]
        if self.framing is Framing.SOFTWARE:
            parts.append("parity by software (8N1 on the UART)")
        if not self.is_binary:
            parts.append({"crlf": "CR LF", "lf": "LF", "cr": "CR"}[self.eol.value])
        if self.leader or self.trailer:
            parts.append(f"leader {self.leader}, trailer {self.trailer} NUL")
        if self.cps is not None:
            parts.append(f"drip feed {self.cps} cps")
        if self.hold == 0 and self.flow is Flow.XONXOFF:
            parts.append("XOFF held without limit")
        if self.requests:
            parts.append("answers requests")
        parts.append(self.target)
        return ", ".join(parts)

    def check(self) -> None:
        """Raise SettingsError if the line cannot be used so; the message says what to change."""
        if self.baud not in BAUD_RATES:
            rates = ", ".join(map(str, BAUD_RATES))
            raise SettingsError(
                f"baud {self.baud} is not a standard rate; use one of {rates}", "baud"
            )
        if self.data_bits not in (7, 8):
            raise SettingsError(f"data bits {self.data_bits}: use 7 or 8", "data_bits")
        if self.stop_bits not in (1, 2):
            raise SettingsError(f"stop bits {self.stop_bits}: use 1 or 2", "stop_bits")
        for name in ("leader", "trailer"):
            count = getattr(self, name)
            if not 0 <= count <= MAX_LEADER:
                raise SettingsError(f"{name} {count}: use 0 to {MAX_LEADER} NUL characters", name)
        found = targets().get(self.target)
        if found is None:
            raise SettingsError(
                f"no export target {self.target!r}; targets: {', '.join(targets())}", "target"
            )
        if found.media_type.startswith("image/"):
            raise SettingsError(
                f"{self.target} is a drawing, not something a control reads", "target"
            )
        if self.cps is not None and not 1 <= self.cps <= self.line_cps:
            raise SettingsError(
                f"drip feed {self.cps} characters per second: use 1 to the line's own rate, "
                f"{self.line_cps:g} at {self.baud} baud {self.frame}",
                "cps",
            )
        if not 0 <= self.hold <= MAX_HOLD:
            raise SettingsError(
                f"hold {self.hold} s: use 1 to {MAX_HOLD} seconds, or 0 for no limit (drip feed)",
                "hold",
            )
        if self.framing is Framing.SOFTWARE and not Framing.can_stand_in(
            self.data_bits, self.parity
        ):
            raise SettingsError(
                f"software parity is for 7 data bits with even or odd parity (sent as 8N1 "
                f"with the parity in bit 8), not {self.frame}",
                "framing",
            )
        if self.is_binary and self.data_bits != 8:
            raise SettingsError(
                f"{self.target} is an 8-bit image (a byte per tape row, channel 8 in bit 8): "
                f"use 8 data bits (8N1), not {self.frame}",
                "data_bits",
            )
        target = targets().get(self.target)
        if self.flow is Flow.XONXOFF and target is not None and target.flow_codes_in_data:
            raise SettingsError(
                f"XON/XOFF cannot be used with {self.target}: its bytes can be the XON and "
                "XOFF codes (in EIA RS-244 the row 0x13, DC3 or XOFF, is the digit 3 and 0x11, "
                "DC1 or XON, can be data too), so flow control and data collide; use "
                "RTS/CTS, or none with a drip-feed rate",
                "flow",
            )
        end = self.end
        if not end or len(end) > 16 or not all(32 < ord(c) < 127 for c in end):
            raise SettingsError(
                f"end {end!r}: use '%', 'idle', or up to 16 printable characters such as M30",
                "end",
            )


def port_of(serial: Mapping[str, Any]) -> str:
    """The machine's port: a device path (`/dev/ttyUSB0`, `/dev/serial/by-id/…`) or a
    network port's URL (`socket://host:port` for a serial device server's raw TCP port,
    `rfc2217://host:port`). Raises SettingsError when the machine has none."""
    port = str(serial.get("port") or "").strip()
    if not port:
        raise SettingsError(
            "the machine has no serial port: set its port (e.g. /dev/ttyUSB0 or socket://10.0.0.5:4001)",
            "port",
        )
    return port


# -- reading one field --------------------------------------------------------------------


def _int(name: str, raw: Any) -> int:
    if isinstance(raw, bool):
        raise SettingsError(f"{name} {raw!r} is not a whole number", name)
    if isinstance(raw, int):
        return raw
    text = str(raw).strip()
    try:
        return int(text)
    except ValueError:
        raise SettingsError(f"{name} {raw!r} is not a whole number", name) from None


def _optional_int(name: str, raw: Any) -> int | None:
    if isinstance(raw, str) and raw.strip().lower() in ("", "none", "line"):
        return None
    return _int(name, raw)


def _word(table: Mapping[str, Any], allowed: str) -> Any:
    def read(name: str, raw: Any) -> Any:
        found = table.get(str(raw).strip().lower())
        if found is None:
            raise SettingsError(f"{name} {raw!r}: use {allowed}", name)
        return found

    return read


def _text(name: str, raw: Any) -> str:
    return str(raw).strip()


_READERS = {
    "baud": _int,
    "data_bits": _int,
    "parity": _word(_PARITY_WORDS, "N, E or O (none, even, odd)"),
    "stop_bits": _int,
    "flow": _word(_FLOW_WORDS, "none, xonxoff or rtscts"),
    "eol": _word(_EOL_WORDS, "crlf, lf or cr"),
    "leader": _int,
    "trailer": _int,
    "target": _text,
    "cps": _optional_int,
    "framing": _word({f.value: f for f in Framing}, "auto, uart or software"),
    "end": _text,
    "hold": _int,
    "requests": _word({"on": True, "off": False, "yes": True, "no": False}, "on or off"),
}

SERIAL_FIELDS = tuple(_READERS)
"""The keys of `Machine.serial` these settings read, besides `port`."""
