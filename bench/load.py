"""Load test (GitHub issue 9): many editors at once against the production server.

    .venv/bin/python -m bench.load                          # SQLite, 60 s
    pg_virtualenv .venv/bin/python -m bench.load --database postgresql

20 clients each edit their own program and 5 clients edit the same one, for `--duration`
seconds (default 60), against gunicorn with `--workers` sync workers (default 4) on
127.0.0.1, on a throwaway database: a temporary SQLite file, or a new database in the
PostgreSQL cluster that the PG* variables name (Debian's `pg_virtualenv` sets them;
`--database-url` names another; the database is dropped afterwards).

Each client does what the editor's htmx form does, as fast as the server answers (no
think time, so the latencies include queueing): POST /programs/<id>/blocks editing one
DRILL block to a new X that no other edit uses, with the version it was last shown.
Answers are counted: 200 (saved, the editor fragment), 409 (a stale save refused: correct,
the client carries on from the version the answer shows), 5xx, anything else, and
connection errors. Afterwards every stored revision is read back: an acknowledged edit (a
200 or 302 answer to a save) that no revision holds is a lost edit. Revisions that no
client saw acknowledged are reported too. The figures go into docs/load.md, with the
command used.

Bounded: loopback only, `--duration` seconds plus the requests in flight (each at most
60 s), at most `--max-requests` per client.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import sys
import tempfile
import threading
import time
import urllib.parse
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from decimal import Decimal
from pathlib import Path

from bench.common import (
    ROOT,
    fmt_seconds,
    machine_lines,
    percentile,
    replace_between,
    table,
)
from bench.programs import EDITABLE_STRIDE, drill_form, editor_program
from bench.server import Client, production_server

DOC = ROOT / "docs" / "load.md"
HTMX = {"HX-Request": "true"}
REQUEST_TIMEOUT = 60.0
PREAMBLE = """# Load test (issue 9)

`bench/load.py` runs many editors at once against the production server (gunicorn on
127.0.0.1) and checks that no edit is lost. The sections between the markers are
rewritten by each run; see the end of this file for what the figures mean.
"""


@dataclass
class Ack:
    """An edit the server acknowledged: it must be in some stored revision."""

    program_id: int
    block: int
    x: Decimal
    shown_version: int | None


@dataclass
class ClientLog:
    group: str  # "own" (one client per program) or "shared"
    latencies: list[float] = field(default_factory=list)
    statuses: Counter[str] = field(default_factory=Counter)
    acks: list[Ack] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)


def edit_loop(
    log: ClientLog,
    host: str,
    port: int,
    program_id: int,
    blocks: list[int],
    client_number: int,
    deadline: float,
    max_requests: int,
) -> None:
    """One client: edit `blocks` of `program_id` in turn until the deadline."""
    client = Client(host, port, timeout=REQUEST_TIMEOUT)
    try:
        page = client.get(f"/programs/{program_id}")
    except OSError as exc:
        log.errors.append(f"GET editor page: {exc!r}")
        return
    csrf, version = page.csrf_token(), page.version()
    if csrf is None or version is None:
        log.errors.append(f"editor page answered {page.status} without a form")
        return
    for seq in range(max_requests):
        if time.monotonic() >= deadline:
            break
        block = blocks[seq % len(blocks)]
        unit = (block - 1) // EDITABLE_STRIDE
        # Unique per client and edit: 10 + client/100 + seq/100000 would overflow the
        # control's resolution, so the client is in Y and the edit count in X.
        x = Decimal(10) + Decimal(seq) / 1000
        y = Decimal(unit % 10) + Decimal("0.5") + Decimal(client_number % 50) / 100
        form = {
            "csrf_token": csrf,
            "version": str(version),
            "edit": str(block),
            **drill_form(x, y),
        }
        try:
            answer = client.post(f"/programs/{program_id}/blocks", form, HTMX)
        except OSError as exc:
            log.errors.append(f"{type(exc).__name__}: {exc}")
            log.statuses["connection error"] += 1
            continue
        log.latencies.append(answer.seconds)
        log.statuses[str(answer.status)] += 1
        shown = answer.version()
        if answer.status in (200, 302):
            log.acks.append(Ack(program_id, block, x, shown))
        if shown is not None:
            version = shown
        elif answer.status in (200, 302):
            version += 1
        elif answer.status >= 500:
            log.errors.append(f"{answer.status}: {answer.body[:200]!r}")
            refreshed = client.get(f"/programs/{program_id}")
            version = refreshed.version() or version


def stored_edits(url: str) -> tuple[dict[int, set[tuple[int, Decimal]]], Counter[int]]:
    """Per program, every (block, X) some revision holds, and the revision counts."""
    from sqlalchemy import select

    from app.storage.library import open_library
    from app.storage.models import RevisionRow

    library = open_library(url, seed_demo=False)
    held: dict[int, set[tuple[int, Decimal]]] = {}
    counts: Counter[int] = Counter()
    try:
        with library.session() as s:
            rows = s.execute(select(RevisionRow.program_id, RevisionRow.document))
            for program_id, text in rows:
                counts[program_id] += 1
                doc = json.loads(text, parse_float=Decimal)
                found = held.setdefault(program_id, set())
                for number, block in enumerate(doc["blocks"], start=1):
                    if "x" in block:
                        found.add((number, Decimal(block["x"])))
    finally:
        library.engine.dispose()
    return held, counts


@contextmanager
def database(kind: str, url: str | None) -> Iterator[str]:
    """A throwaway database URL: a temporary SQLite file, or a new PostgreSQL database."""
    if kind == "sqlite":
        with tempfile.TemporaryDirectory() as tmp:
            yield url or f"sqlite:///{Path(tmp) / 'load.db'}"
        return
    if url:
        yield url
        return
    if not os.environ.get("PGHOST") and not os.environ.get("PGPORT"):
        raise SystemExit(
            "no PostgreSQL: run under pg_virtualenv (it sets PG*) or give --database-url"
        )
    import psycopg

    name = f"millblocks_load_{os.getpid()}"
    with psycopg.connect(dbname="postgres", autocommit=True) as admin:
        admin.execute(f'CREATE DATABASE "{name}"')
    host = os.environ.get("PGHOST", "127.0.0.1")
    user = urllib.parse.quote(os.environ.get("PGUSER", "postgres"))
    password = urllib.parse.quote(os.environ.get("PGPASSWORD", ""))
    port = os.environ.get("PGPORT", "5432")
    if host.startswith("/"):
        built = f"postgresql+psycopg://{user}:{password}@/{name}?host={host}&port={port}"
    else:
        built = f"postgresql+psycopg://{user}:{password}@{host}:{port}/{name}"
    try:
        yield built
    finally:
        with psycopg.connect(dbname="postgres", autocommit=True) as admin:
            admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')


@dataclass
class Outcome:
    logs: list[ClientLog]
    lost: list[Ack]
    unacknowledged: int
    stored: int
    seconds: float
    log_tail: str


def run_load(args: argparse.Namespace, url: str) -> Outcome:
    from app.storage.library import open_library

    library = open_library(url)
    program = editor_program(args.blocks)
    own = [
        library.create(editor_program(args.blocks, f"load own {k + 1}")).id for k in range(args.own)
    ]
    shared = library.create(editor_program(args.blocks, "load shared")).id
    library.engine.dispose()
    units = max(1, len(program.blocks) // EDITABLE_STRIDE)
    all_blocks = [k * EDITABLE_STRIDE + 1 for k in range(units)]
    with (
        tempfile.TemporaryDirectory() as tmp,
        production_server(url, args.workers, Path(tmp)) as server,
    ):
        started = time.monotonic()
        deadline = started + args.duration
        logs: list[ClientLog] = []
        threads: list[threading.Thread] = []
        plan: list[tuple[str, int, list[int]]] = [("own", pid, all_blocks) for pid in own]
        plan += [("shared", shared, [all_blocks[k % len(all_blocks)]]) for k in range(args.shared)]
        for number, (group, program_id, blocks) in enumerate(plan):
            log = ClientLog(group)
            logs.append(log)
            thread = threading.Thread(
                target=edit_loop,
                args=(log, server.host, server.port, program_id, blocks, number, deadline),
                kwargs={"max_requests": args.max_requests},
                daemon=True,
            )
            threads.append(thread)
            thread.start()
        for thread in threads:
            thread.join(timeout=max(0.0, deadline - time.monotonic()) + 2 * REQUEST_TIMEOUT)
        seconds = time.monotonic() - started
        tail = server.log_tail(5)
    held, counts = stored_edits(url)
    acks = [ack for log in logs for ack in log.acks]
    lost = [a for a in acks if (a.block, a.x) not in held.get(a.program_id, set())]
    # Every revision after the first is a save; a save nobody saw acknowledged is reported.
    saves = sum(counts[pid] - 1 for pid in [*own, shared])
    return Outcome(logs, lost, saves - len(acks), saves, seconds, tail)


def report(args: argparse.Namespace, outcome: Outcome, command: str) -> str:
    rows = []
    for group, title in (
        ("own", f"{args.own} clients, one program each"),
        ("shared", f"{args.shared} clients, one shared program"),
        ("all", "all clients"),
    ):
        logs = [log for log in outcome.logs if group in ("all", log.group)]
        latencies = [t for log in logs for t in log.latencies]
        statuses: Counter[str] = Counter()
        for log in logs:
            statuses.update(log.statuses)
        acks = sum(len(log.acks) for log in logs)
        server_errors = sum(n for s, n in statuses.items() if s.isdigit() and int(s) >= 500)
        other = sum(
            n for s, n in statuses.items() if s not in ("200", "302", "409") and s.isdigit()
        )
        lost = sum(
            1 for ack in outcome.lost if group == "all" or any(ack in log.acks for log in logs)
        )
        rows.append(
            [
                title,
                str(sum(statuses.values())),
                str(acks),
                str(statuses.get("409", 0)),
                str(server_errors),
                str(other - server_errors + statuses.get("connection error", 0)),
                f"**{lost}**",
                fmt_seconds(percentile(latencies, 50)),
                fmt_seconds(percentile(latencies, 95)),
                fmt_seconds(max(latencies, default=float("nan"))),
                f"{acks / outcome.seconds:.1f}/s",
            ]
        )
    errors = [e for log in outcome.logs for e in log.errors]
    lines = [
        f"### {args.database}: {args.own} + {args.shared} clients, {args.duration:g} s, "
        f"{args.workers} workers",
        "",
        f"Command: `{command}`",
        "",
        *machine_lines(),
        f"- Load average at the end: {' / '.join(f'{x:.2f}' for x in os.getloadavg())}",
        f"- Programs: {args.blocks} blocks each (bench/programs.py `editor_program`); "
        "each edit moves one DRILL, the server answers with the editor fragment and preview",
        "",
        *table(
            [
                "clients",
                "requests",
                "saved (200)",
                "refused stale (409)",
                "5xx",
                "other errors",
                "lost edits",
                "p50",
                "p95",
                "max",
                "saves/s",
            ],
            rows,
        ),
        "",
        f"Stored revisions after the first: {outcome.stored}; acknowledged saves: "
        f"{outcome.stored - outcome.unacknowledged}; saves no client saw acknowledged: "
        f"{outcome.unacknowledged}. Ran {outcome.seconds:.1f} s including the requests in "
        "flight at the deadline.",
    ]
    if errors:
        lines += ["", f"First errors ({len(errors)} in all):", ""]
        lines += [f"- `{e[:160]}`" for e in errors[:5]]
    if outcome.lost:
        lines += ["", "Lost edits (first 5):", ""]
        lines += [
            f"- program {a.program_id} block {a.block} X {a.x} (answer showed version "
            f"{a.shown_version})"
            for a in outcome.lost[:5]
        ]
    return "\n".join(lines)


def parse_args(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="python -m bench.load", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--database", choices=("sqlite", "postgresql"), default="sqlite")
    parser.add_argument("--database-url", help="use this database instead of a throwaway one")
    parser.add_argument("--duration", type=float, default=60.0, help="seconds (default 60)")
    parser.add_argument("--workers", type=int, default=4, help="gunicorn workers (default 4)")
    parser.add_argument("--own", type=int, default=20, help="clients with a program each")
    parser.add_argument("--shared", type=int, default=5, help="clients sharing one program")
    parser.add_argument("--blocks", type=int, default=50, help="blocks per program (≥ 50)")
    parser.add_argument("--max-requests", type=int, default=5000, help="per client")
    parser.add_argument("--output", type=Path, default=DOC, help="Markdown file to update")
    parser.add_argument("--no-write", action="store_true", help="print only")
    args = parser.parse_args(argv)
    if args.duration <= 0 or args.duration > 3600:
        parser.error("--duration is between 0 and 3600 seconds")
    if args.blocks < 5 * EDITABLE_STRIDE:
        parser.error("--blocks must be at least 50 (each shared client edits its own DRILL)")
    return args


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    args = parse_args(argv)
    prefix = "pg_virtualenv " if args.database == "postgresql" and not args.database_url else ""
    shown = ["<url>" if "://" in a else a for a in argv]  # no passwords in the docs
    command = prefix + shlex.join([".venv/bin/python", "-m", "bench.load", *shown])
    with database(args.database, args.database_url) as url:
        outcome = run_load(args, url)
    text = report(args, outcome, command)
    print(text)
    if not args.no_write:
        replace_between(args.output, f"load:{args.database}", text, PREAMBLE)
        print(f"\nwritten to {args.output}")
    failed = outcome.lost or any(
        s.isdigit() and int(s) >= 500 for log in outcome.logs for s in log.statuses
    )
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
