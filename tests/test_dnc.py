"""The DNC layer without a port: settings, the bytes on the wire, captures, the record."""

from __future__ import annotations

import ast
from datetime import datetime
from pathlib import Path
from typing import Any

import pytest

from app.cnc.formats.tape1704 import codes as tapecode
from app.dnc.framing import Capture, DataError, add_parity, check_parity, outgoing
from app.dnc.record import Direction, TransferRecord
from app.dnc.settings import (
    SERIAL_FIELDS,
    EndOfLine,
    Flow,
    Framing,
    Parity,
    PortSettings,
    SettingsError,
    port_of,
)
from app.dnc.transfer import Outcome, ReceiveResult, SendResult

ROOT = Path(__file__).parent.parent
# What the web's machine form stores today (app/web/machines.py SERIAL_DEFAULTS).
WEB_DEFAULTS = {
    "port": "/dev/ttyUSB0",
    "baud": "4800",
    "data_bits": "7",
    "parity": "E",
    "stop_bits": "1",
    "flow": "none",
}


# -- settings -------------------------------------------------------------------------------


def test_defaults_are_the_prototrak_plus_line() -> None:
    settings = PortSettings.from_serial(WEB_DEFAULTS, target="events")
    assert settings == PortSettings()
    assert (settings.baud, settings.frame, settings.flow) == (4800, "7E1", Flow.NONE)
    assert settings.bits_per_character == 10
    assert settings.line_cps == 480
    assert settings.describe() == "4800 7E1, no flow control, CR LF, events"
    assert port_of(WEB_DEFAULTS) == "/dev/ttyUSB0"


def test_every_field_is_read_from_text_and_written_back() -> None:
    serial = {
        "port": "/dev/ttyS1",
        "baud": "9600",
        "data_bits": "8",
        "parity": "none",
        "stop_bits": "2",
        "flow": "RTS/CTS",
        "eol": "lf",
        "leader": "40",
        "trailer": "20",
        "target": "gcode-fanuc",
        "cps": "300",
        "framing": "uart",
        "end": "M30",
    }
    settings = PortSettings.from_serial(serial, target="events")
    assert settings == PortSettings(
        baud=9600,
        data_bits=8,
        parity=Parity.NONE,
        stop_bits=2,
        flow=Flow.RTSCTS,
        eol=EndOfLine.LF,
        leader=40,
        trailer=20,
        target="gcode-fanuc",
        cps=300,
        framing=Framing.UART,
        end="M30",
    )
    assert settings.bits_per_character == 11
    stored = settings.to_serial("/dev/ttyS1")
    assert set(stored) == {"port", *SERIAL_FIELDS} - {"target"}
    assert PortSettings.from_serial(stored, target="gcode-fanuc") == settings
    assert PortSettings.from_serial(PortSettings().to_serial(), target="events") == PortSettings()


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"baud": "4801"}, "baud 4801 is not a standard rate; use one of 110, 150"),
        ({"baud": "fast"}, "baud 'fast' is not a whole number"),
        ({"data_bits": "6"}, "data bits 6: use 7 or 8"),
        ({"parity": "X"}, "parity 'X': use N, E or O (none, even, odd)"),
        ({"stop_bits": "3"}, "stop bits 3: use 1 or 2"),
        ({"flow": "dtr"}, "flow 'dtr': use none, xonxoff or rtscts"),
        ({"eol": "nl"}, "eol 'nl': use crlf, lf or cr"),
        ({"leader": "-1"}, "leader -1: use 0 to 10000 NUL characters"),
        ({"speed": "4800"}, "unknown serial setting 'speed'; the settings: port, baud,"),
        ({"target": "svg"}, "svg is a drawing, not something a control reads"),
        ({"target": "ptp"}, "no export target 'ptp'; targets:"),
        ({"cps": "500"}, "drip feed 500 characters per second: use 1 to the line's own rate, 480"),
        ({"framing": "software", "data_bits": "8", "parity": "N"}, "software parity is for 7"),
        ({"framing": "magic"}, "framing 'magic': use auto, uart or software"),
        ({"end": "two words"}, "end 'two words': use '%', 'idle', or up to 16 printable"),
    ],
)
def test_bad_settings_say_which_field_and_what_is_allowed(
    change: dict[str, str], message: str
) -> None:
    with pytest.raises(SettingsError) as caught:
        PortSettings.from_serial({**WEB_DEFAULTS, **change}, target="events")
    assert str(caught.value).startswith(message)


def test_xon_xoff_is_refused_for_eia_punch_images() -> None:
    serial = {**WEB_DEFAULTS, "data_bits": "8", "parity": "N", "flow": "xonxoff"}
    with pytest.raises(SettingsError, match=r"XON/XOFF cannot be used with punch-eia: .*digit 3"):
        PortSettings.from_serial(serial, target="punch-eia")
    # RTS/CTS, or none, is fine; an ASCII tape listing takes XON/XOFF.
    PortSettings.from_serial({**serial, "flow": "rtscts"}, target="punch-eia")
    PortSettings.from_serial({**WEB_DEFAULTS, "flow": "xonxoff"}, target="tape-ascii")


def test_punch_images_need_eight_data_bits() -> None:
    with pytest.raises(SettingsError, match=r"punch-ascii is an 8-bit image .* not 7E1"):
        PortSettings.from_serial(WEB_DEFAULTS, target="punch-ascii")


def test_a_machine_without_a_port_is_a_clear_error() -> None:
    with pytest.raises(SettingsError, match="the machine has no serial port"):
        port_of({**WEB_DEFAULTS, "port": " "})


# -- the bytes on the wire ----------------------------------------------------------------------


def test_outgoing_sets_line_endings_leader_and_trailer() -> None:
    data = b"%\r\nPN1 G20;\nN001 G100;\r%\n"
    crlf = PortSettings(leader=3, trailer=2)
    assert outgoing(data, crlf) == b"\0\0\0%\r\nPN1 G20;\r\nN001 G100;\r\n%\r\n\0\0"
    lf = PortSettings(eol=EndOfLine.LF)
    assert outgoing(data, lf) == b"%\nPN1 G20;\nN001 G100;\n%\n"
    cr = PortSettings(eol=EndOfLine.CR)
    assert outgoing(data, cr) == b"%\rPN1 G20;\rN001 G100;\r%\r"


def test_software_parity_matches_the_ascii_tape_code() -> None:
    """Even parity in bit 8 is the ISO 840 tape code the 1704 target punches."""
    for char, row in tapecode.ASCII_CODES.items():
        if char == "\n":
            continue  # a listing's newline is CR on the tape
        assert add_parity(char.encode("ascii"), Parity.EVEN)[0] == row, char
    assert add_parity(b"\r%\x7f", Parity.EVEN) == bytes(
        [tapecode.ASCII_END_OF_BLOCK, tapecode.ASCII_REWIND_STOP, tapecode.ASCII_DELETE]
    )
    assert add_parity(b"\x13", Parity.ODD) == b"\x13"  # three ones: odd already
    assert all(check_parity(b, Parity.ODD) for b in add_parity(bytes(range(128)), Parity.ODD))
    assert not check_parity(0x25, Parity.EVEN)  # `%` without its parity bit


def test_software_framing_puts_parity_on_every_wire_byte() -> None:
    settings = PortSettings(framing=Framing.SOFTWARE, leader=2)
    assert outgoing(b"%\n", settings) == b"\0\0\xa5\x8d\x0a"


def test_data_that_cannot_go_is_refused_before_the_port() -> None:
    with pytest.raises(DataError, match=r"byte 0xC2 at offset 7 \(line 2, column 2\) is not ASCII"):
        outgoing(b"G0 X1\n(\xc2\xb0)\n", PortSettings())
    with pytest.raises(DataError, match="control character 0x13 at offset 2"):
        outgoing(b"G0\x13\n", PortSettings())
    punch = PortSettings(data_bits=8, parity=Parity.NONE, target="punch-eia")
    assert outgoing(b"\x0b\x80\x13", punch) == b"\x0b\x80\x13"  # as it is: no EOL change


# -- captures -----------------------------------------------------------------------------


def _capture(settings: PortSettings, *chunks: bytes) -> Capture:
    capture = Capture(settings)
    for chunk in chunks:
        capture.feed(chunk)
    return capture


def test_a_program_ends_at_the_percent_that_closes_it() -> None:
    program = b"%\r\nPN1 G20;\r\nN001 G100 X1;\r\n%\r\n"
    capture = _capture(PortSettings(), b"\0\0\x7f", program[:5], program[5:], b"\0\0\0")
    assert capture.done
    assert bytes(capture.data) == program
    assert bytes(capture.raw) == b"\0\0\x7f" + program + b"\0\0\0"
    assert capture.problem() is None


def test_a_program_without_an_opening_percent_ends_at_its_first() -> None:
    capture = _capture(PortSettings(), b"\r\nG0 X1\nM30\n%\nmore")
    assert capture.done
    assert bytes(capture.data) == b"G0 X1\nM30\n%\n"


def test_the_end_can_be_a_word_or_only_the_idle_timeout() -> None:
    word = _capture(PortSettings(end="M30"), b"G0 X1\r\nM30 ;\r\nG0 X2")
    assert word.done
    assert bytes(word.data) == b"G0 X1\r\nM30 ;\r\n"
    idle = _capture(PortSettings(end="idle"), b"%\nG0\n%\n%\n")
    assert not idle.done and bytes(idle.data) == b"%\nG0\n%\n%\n"


def test_the_end_marks_line_ending_may_come_late_or_not_at_all() -> None:
    capture = _capture(PortSettings(), b"%\nG0\n%")
    assert capture.in_tail and not capture.done
    capture.finish_tail()
    assert capture.done and bytes(capture.data) == b"%\nG0\n%"


def test_a_percent_that_never_closes_is_awaited() -> None:
    capture = _capture(PortSettings(), b"%\r\nPN1 G20;\r\n")
    assert capture.awaiting_close and not capture.done


def test_device_control_characters_and_tape_feed_are_dropped() -> None:
    capture = _capture(PortSettings(), b"\x12%\nG0\x00 X1\x7f\n\x11%\n\x14")
    assert bytes(capture.data) == b"%\nG0 X1\n%\n"
    assert capture.skipped == 4


def test_garbage_is_named_with_its_offset() -> None:
    capture = _capture(PortSettings(), b"\0\0G0\x85\x86\x05 X1\n")
    assert capture.problem() == (
        "garbage from the control: byte 0x85 at offset 4 is not 7-bit ASCII (3 bytes in all); "
        "check the baud rate, data bits and parity (the machine is set to 4800 7E1)"
    )


def test_software_parity_errors_come_first() -> None:
    settings = PortSettings(framing=Framing.SOFTWARE)
    good = add_parity(b"%\nG0 X1\n%\n", Parity.EVEN)
    assert _capture(settings, good).problem() is None
    assert bytes(_capture(settings, good).data) == b"%\nG0 X1\n%\n"
    bad = good[:4] + bytes([good[4] ^ 0x80]) + good[5:]
    problem = _capture(settings, bad).problem()
    assert problem is not None
    # The byte as it came: the space (0x20) needs bit 8 for even parity, and lost it.
    assert problem.startswith("garbage from the control: byte 0x20 at offset 4 is a parity error")


def test_a_punch_image_ends_at_its_rewind_stop() -> None:
    settings = PortSettings(data_bits=8, parity=Parity.NONE, target="punch-eia")
    capture = _capture(settings, b"\0\0\x0b\x80\x01\x13\x80\x0b\0\0")
    assert capture.done
    assert bytes(capture.data) == b"\x0b\x80\x01\x13\x80\x0b"
    assert capture.problem() is None  # images are not checked as text


# -- the record ---------------------------------------------------------------------------


def _when(second: int) -> datetime:
    return datetime(2025, 3, 1, 10, 0, second)


def test_a_send_record_carries_the_columns_of_the_log() -> None:
    result = SendResult(
        port="/dev/ttyUSB0",
        settings=PortSettings(),
        total=471,
        sent=200,
        started=_when(0),
        finished=_when(2),
        seconds=2.0,
        outcome=Outcome.FAILED,
        error="port /dev/ttyUSB0 vanished: write failed",
    )
    record = TransferRecord.of_send(result, machine="Plus", program_id=7, program_name="BRKT")
    row: dict[str, Any] = record.as_row()
    assert row == {
        "direction": "send",
        "machine": "Plus",
        "port": "/dev/ttyUSB0",
        "target": "events",
        "settings": "4800 7E1, no flow control, CR LF, events",
        "bytes_done": 200,
        "bytes_total": 471,
        "started_at": _when(0),
        "finished_at": _when(2),
        "outcome": "failed",
        "error": "port /dev/ttyUSB0 vanished: write failed",
        "program_id": 7,
        "program_name": "BRKT",
        "author": "",
        "raw": None,
    }
    assert record.summary() == (
        "send 'BRKT' events 200/471 bytes to Plus on /dev/ttyUSB0 in 2.0 s: failed: "
        "port /dev/ttyUSB0 vanished: write failed"
    )


def test_a_receive_record_keeps_the_raw_capture_and_an_import_error() -> None:
    result = ReceiveResult(
        port="/dev/ttyS0",
        settings=PortSettings(),
        raw=b"\0\0%\nnonsense\n%\n",
        data=b"%\nnonsense\n%\n",
        started=_when(0),
        finished=_when(1),
        seconds=1.0,
        outcome=Outcome.OK,
    )
    record = TransferRecord.of_receive(result, machine="Plus", error="not an events program")
    assert record.direction is Direction.RECEIVE
    assert (record.outcome, record.error) == (Outcome.FAILED, "not an events program")
    assert record.raw == b"\0\0%\nnonsense\n%\n"
    assert (record.bytes_done, record.bytes_total) == (15, None)


def test_the_core_does_not_import_the_serial_adapter() -> None:
    for path in sorted((ROOT / "app" / "cnc").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module:
                assert not node.module.startswith("app.dnc"), path
            if isinstance(node, ast.Import):
                assert not any(a.name.startswith("app.dnc") for a in node.names), path
