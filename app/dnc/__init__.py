"""RS-232 transfer (DNC): send programs to controls and receive them back (issue 8).

An adapter around the core, like app/storage and app/web: it uses pyserial, and nothing in
app/cnc imports it (tests/test_layering.py). The layers:

- `settings`: `PortSettings` from a machine's serial dict (4800 7E1 by default), checked.
- `framing`: the bytes on the wire, with no port: line endings, leader, software parity,
  and the `Capture` that finds a received program's end and refuses garbage.
- `transfer`: `send` and `receive` over pyserial, with XON/XOFF done here (prompt to a few
  characters), drip-feed pacing, cancel, timeouts, and clear errors for a vanished port.
- `record`: the `TransferRecord` the caller keeps in its transfer log.
- `service`: export-and-send, receive-import-and-save, each logged — what the CLI and the
  web call. `jobs`: the same in a background thread for the web.

docs/rs232.md says how to set a machine up and what was measured.
"""

from app.dnc.framing import DataError, EndReason
from app.dnc.record import Direction, TransferRecord
from app.dnc.settings import (
    EndOfLine,
    Flow,
    Framing,
    Parity,
    PortSettings,
    SettingsError,
    port_of,
)
from app.dnc.transfer import (
    Outcome,
    ReceiveError,
    ReceiveResult,
    SendError,
    SendResult,
    TransferError,
    receive,
    send,
)

__all__ = [
    "DataError",
    "Direction",
    "EndOfLine",
    "EndReason",
    "Flow",
    "Framing",
    "Outcome",
    "Parity",
    "PortSettings",
    "ReceiveError",
    "ReceiveResult",
    "SendError",
    "SendResult",
    "SettingsError",
    "TransferError",
    "TransferRecord",
    "port_of",
    "receive",
    "send",
]
