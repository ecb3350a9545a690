"""Time to send a 50 KB program over a 4800-baud line, against the line-rate limit.

    .venv/bin/python -m bench.serial_send                 # 50 000 bytes, 4800 7E1, XON/XOFF
    .venv/bin/python -m bench.serial_send --size 5000     # a quick look (about 10 s)
    .venv/bin/python -m bench.serial_send --consume-cps 300   # a control that stores slower

Not part of pytest: the full run takes about 105 s, which is the point. A socat pty pair
joins `app.dnc.transfer.send` to the simulated control of the tests, which takes characters
off the line at the line's rate (baud / 10 bits for 7E1 = 480 a second at 4800 baud) into a
256-character buffer with XOFF at 192 and XON at 64. The floor is the line: `size / 480`
seconds (104.2 s for 50 000 bytes); the ratio elapsed / floor says what the sender's
chunking, pacing and flow control cost. The received bytes are checked byte for byte.
"""

from __future__ import annotations

import argparse
import sys
import time

from app.cnc.formats.targets import export
from app.dnc.settings import EndOfLine, Flow, PortSettings
from app.dnc.transfer import send
from app.storage.demo import demo_programs
from tests.simulated_control import SimulatedControl, SocatPair


def program_text(size: int) -> bytes:
    """A G-code program of exactly `size` bytes: `%`, the sample part's moves repeated with
    sequence numbers, `%` (LF line endings)."""
    body = export(demo_programs()[0], "gcode-linuxcnc").data.decode("ascii").splitlines()
    moves = [line for line in body if line[:2] in ("G0", "G1", "G2", "G3")]
    lines, length, number = ["%"], 2, 0
    while True:
        number += 10
        line = f"N{number} {moves[number // 10 % len(moves)]}"
        if length + len(line) + 1 + 2 > size:
            break
        lines.append(line)
        length += len(line) + 1
    filler = size - length - 2
    if filler > 0:
        lines.append("(" + "-" * (filler - 3) + ")" if filler >= 3 else " " * (filler - 1))
    lines.append("%")
    data = ("\n".join(lines) + "\n").encode("ascii")
    assert len(data) == size, (len(data), size)
    return data


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=50_000, help="program bytes (50000)")
    parser.add_argument("--baud", type=int, default=4800, help="line rate (4800)")
    parser.add_argument(
        "--flow", choices=("xonxoff", "none"), default="xonxoff", help="flow control"
    )
    parser.add_argument(
        "--consume-cps",
        type=float,
        default=None,
        help="how fast the control stores characters (default: as fast as they come)",
    )
    args = parser.parse_args(argv)
    settings = PortSettings(
        baud=args.baud,
        flow=Flow.XONXOFF if args.flow == "xonxoff" else Flow.NONE,
        eol=EndOfLine.LF,
        target="gcode-linuxcnc",
    )
    data = program_text(args.size)
    line_cps = settings.line_cps
    floor = len(data) / line_cps
    print(
        f"sending {len(data)} bytes at {settings.describe()}; "
        f"line rate {line_cps:g} cps, floor {floor:.1f} s",
        flush=True,
    )
    with SocatPair() as pair:
        control = SimulatedControl(
            pair.control,
            cps=line_cps,
            parity="E",
            buffer_size=256,
            xoff_at=192,
            xon_at=64,
            consume_cps=args.consume_cps,
            xon_xoff=settings.flow is Flow.XONXOFF,
        )
        with control:
            last = [0.0]

            def progress(done: int, total: int | None) -> None:
                now = time.monotonic()
                if now - last[0] >= 10:
                    last[0] = now
                    print(f"  {done}/{total} bytes", flush=True)

            result = send(data, settings, pair.host, progress=progress)
            control.wait_for(len(data), timeout=30)
    exact = bytes(control.memory) == data
    ratio = result.seconds / floor
    print(
        f"sent {result.sent} bytes in {result.seconds:.1f} s: {result.sent / result.seconds:.1f} "
        f"cps, {ratio:.3f} x the line-rate floor ({floor:.1f} s); XOFF {result.xoff_count} "
        f"times, held {result.held_seconds:.1f} s; most characters after an XOFF "
        f"{max(control.after_xoff, default=0)} (already queued at most "
        f"{max(control.queued_at_xoff, default=0)}); overflowed {control.overflowed}; "
        f"parity errors {control.parity_errors}; byte for byte: {'yes' if exact else 'NO'}"
    )
    return 0 if exact and control.overflowed == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
