"""The transfer service sending to 8 machines at once, each against its line rate; and a
`socket://` port against a local one (issue 35).

    .venv/bin/python -m bench.serial_service              # 8 machines, ~20 KB each (~45 s)
    .venv/bin/python -m bench.serial_service --machines 2 --blocks 40   # a quick look

Not part of pytest. Each machine is a socat pty pair with the tests' simulated control at
4800 7E1 (480 characters a second off the line); one `TransferService` (as `millblocks dnc`
runs it) claims the 8 queued sends and runs them together. Each send's time is set against
its floor, bytes / 480 s; the goal is every machine at ≥ 98 % of its line rate. Then the
same program goes once through a local pty and once through a `socket://` port (socat
between a TCP port and a pty, as a serial device server), and the two controls' memories
are compared byte for byte. The control, the service and socat share the machine's cores:
the figures are what this box gives, stated with its load.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import threading
import time
from contextlib import ExitStack
from pathlib import Path

from app.cnc.formats.targets import export
from app.dnc.daemon import TransferService
from app.dnc.settings import Flow, PortSettings
from app.dnc.transfer import send
from app.storage.library import Machine, open_library
from app.storage.transfers import TransferLog
from bench.programs import editor_program
from tests.simulated_control import SimulatedControl, SocatPair, SocketBridge

GOAL = 0.98


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--machines", type=int, default=8)
    parser.add_argument("--blocks", type=int, default=120, help="blocks of the program sent")
    args = parser.parse_args(argv)
    load = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp, ExitStack() as stack:
        library = open_library(f"sqlite:///{Path(tmp) / 'shop.db'}", seed_demo=False)
        program = editor_program(args.blocks, name="bench service")
        info = library.create(program)
        data = export(program, "gcode-linuxcnc").data
        wire = data.replace(b"\n", b"\r\n")
        settings = PortSettings(flow=Flow.XONXOFF, target="gcode-linuxcnc")
        floor = len(wire) / settings.line_cps
        print(
            f"{args.machines} machines, {len(wire)} bytes each at {settings.describe()}; "
            f"floor {floor:.1f} s; load before {load[0]:.2f}",
            flush=True,
        )
        controls = []
        rows = []
        log = TransferLog(library)
        for n in range(args.machines):
            pair = stack.enter_context(SocatPair())
            controls.append(
                stack.enter_context(
                    SimulatedControl(
                        pair.control, parity="E", buffer_size=256, xoff_at=192, xon_at=64
                    )
                )
            )
            serial = {"port": pair.host, "flow": "xonxoff"}
            library.save_machine(Machine(f"Mill {n}", "gcode-linuxcnc", {}, serial))
            rows.append(
                log.begin(
                    "send", f"Mill {n}", pair.host, "gcode-linuxcnc", "", info.id, queued=True
                )
            )
        service = TransferService(library, poll=0.05)
        stop = threading.Event()
        thread = threading.Thread(target=service.run, args=(stop,), daemon=True)
        started = time.monotonic()
        thread.start()
        while not all(log.get(r).outcome not in ("queued", "running") for r in rows):
            time.sleep(0.1)
            if time.monotonic() - started > 10 * floor + 60:
                break
        stop.set()
        thread.join(timeout=30)
        worst = 1.0
        exact = 0
        for n, (row, control) in enumerate(zip(rows, controls, strict=True)):
            done = log.get(row)
            control.wait_for(len(wire), timeout=10)
            seconds = (
                (done.finished_at - done.started_at).total_seconds() if done.finished_at else 0
            )
            rate = floor / seconds if seconds else 0.0
            worst = min(worst, rate)
            same = bytes(control.memory) == wire
            exact += same
            print(
                f"  Mill {n}: {done.outcome}, {seconds:.1f} s ({rate * 100:.1f} % of the line "
                f"rate), byte for byte: {'yes' if same else 'NO'}"
            )
        # The socket:// port against a local one, the same bytes.
        with SocatPair() as pair, SimulatedControl(pair.control, buffer_size=1 << 16) as local:
            send(data, settings, pair.host)
            local.wait_for(len(wire), timeout=60)
        with (
            SocketBridge() as bridge,
            SimulatedControl(bridge.control, buffer_size=1 << 16) as remote,
        ):
            send(data, settings, bridge.url)
            remote.wait_for(len(wire), timeout=60)
        alike = bytes(remote.memory) == bytes(b & 0x7F for b in local.memory)
    print(
        f"{exact}/{args.machines} byte for byte; slowest at {worst * 100:.1f} % of its line rate "
        f"(goal ≥ {GOAL * 100:.0f} %); socket:// receives what a local port does: "
        f"{'yes' if alike else 'NO'}; load after {os.getloadavg()[0]:.2f}"
    )
    return 0 if exact == args.machines and alike else 1


if __name__ == "__main__":
    sys.exit(main())
