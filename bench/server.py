"""The production server for the editor and load benchmarks, and a small HTTP client.

`production_server()` does what `make run` does, on a free loopback port and a database of
the caller's choosing: `millblocks db upgrade`, then gunicorn with sync workers and the
access log (to a file), `app:create_app()`. It waits until every worker has booted and the
server answers, and stops the gunicorn master it started (by its process id) at the end.

`Client` speaks HTTP/1.1 to 127.0.0.1 only, one connection per request (gunicorn's sync
workers close each one anyway), keeps the session cookie (the CSRF token is bound to it)
and times each request from connect to the last byte.
"""

from __future__ import annotations

import http.client
import os
import re
import socket
import subprocess
import time
import urllib.parse
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from bench.common import ROOT, VENV_BIN

LOOPBACK = "127.0.0.1"
CSRF = re.compile(r'name="csrf_token" value="([^"]+)"')
VERSION = re.compile(r'name="version" value="(\d+)"')


class ServerError(RuntimeError):
    """The server did not start (the message quotes the end of its log)."""


@dataclass
class Server:
    host: str
    port: int
    process: subprocess.Popen[bytes]
    log: Path

    def log_tail(self, lines: int = 15) -> str:
        try:
            return "\n".join(self.log.read_text(errors="replace").splitlines()[-lines:])
        except OSError:
            return ""


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind((LOOPBACK, 0))
        port: int = sock.getsockname()[1]
        return port


@contextmanager
def production_server(
    database_url: str, workers: int, log_dir: Path, start_timeout: float = 90.0
) -> Iterator[Server]:
    """gunicorn serving the app on 127.0.0.1 with `database_url`, as `make run` starts it."""
    env = {**os.environ, "DATABASE_URL": database_url}
    subprocess.run(
        [str(VENV_BIN / "millblocks"), "db", "upgrade"],
        cwd=ROOT,
        env=env,
        check=True,
        capture_output=True,
        timeout=start_timeout,
    )
    port = free_port()
    log = log_dir / f"gunicorn-{port}.log"
    command = [
        str(VENV_BIN / "gunicorn"),
        "--bind",
        f"{LOOPBACK}:{port}",
        "--workers",
        str(workers),
        "--access-logfile",
        "-",
        "app:create_app()",
    ]
    with log.open("wb") as out:
        process = subprocess.Popen(command, cwd=ROOT, env=env, stdout=out, stderr=out)
    server = Server(LOOPBACK, port, process, log)
    try:
        _wait_ready(server, workers, start_timeout)
        yield server
    finally:
        process.terminate()  # gunicorn's master stops its workers gracefully on SIGTERM
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(timeout=10)


def _wait_ready(server: Server, workers: int, timeout: float) -> None:
    deadline = time.monotonic() + timeout
    client = Client(server.host, server.port)
    while time.monotonic() < deadline:
        if server.process.poll() is not None:
            raise ServerError(
                f"gunicorn exited ({server.process.returncode}):\n{server.log_tail()}"
            )
        booted = server.log.read_text(errors="replace").count("Booting worker")
        if booted >= workers:
            try:
                if client.get("/static/app.css").status == 200:
                    # Workers open the library (migrations, demo check) as they boot: give
                    # every one a request before anything is timed.
                    for _ in range(2 * workers):
                        client.get("/")
                    return
            except OSError:
                pass
        time.sleep(0.2)
    raise ServerError(f"gunicorn did not answer within {timeout:.0f} s:\n{server.log_tail()}")


@dataclass
class Response:
    status: int
    body: str
    headers: dict[str, str]
    seconds: float

    def csrf_token(self) -> str | None:
        found = CSRF.search(self.body)
        return found.group(1) if found else None

    def version(self) -> int | None:
        found = VERSION.search(self.body)
        return int(found.group(1)) if found else None


@dataclass
class Client:
    """One browser's worth of HTTP: a cookie jar and loopback requests."""

    host: str
    port: int
    timeout: float = 60.0
    cookies: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.host not in (LOOPBACK, "localhost", "::1"):
            raise ValueError("the benchmarks only talk to the loopback address")

    def request(
        self,
        method: str,
        path: str,
        form: Mapping[str, str | Sequence[str]] | None = None,
        headers: Mapping[str, str] | None = None,
    ) -> Response:
        sent = dict(headers or {})
        body = None
        if form is not None:
            # A list is a field sent once per value, as a form's same-named inputs are.
            body = urllib.parse.urlencode(form, doseq=True)
            sent["Content-Type"] = "application/x-www-form-urlencoded"
        if self.cookies:
            sent["Cookie"] = "; ".join(f"{k}={v}" for k, v in self.cookies.items())
        started = time.perf_counter()
        connection = http.client.HTTPConnection(self.host, self.port, timeout=self.timeout)
        try:
            connection.request(method, path, body=body, headers=sent)
            answer = connection.getresponse()
            data = answer.read()
        finally:
            connection.close()
        seconds = time.perf_counter() - started
        for name, value in answer.getheaders():
            if name.lower() == "set-cookie":
                key, _, rest = value.partition("=")
                self.cookies[key.strip()] = rest.split(";", 1)[0]
        return Response(
            answer.status,
            data.decode("utf-8", errors="replace"),
            {k.lower(): v for k, v in answer.getheaders()},
            seconds,
        )

    def get(self, path: str, headers: Mapping[str, str] | None = None) -> Response:
        return self.request("GET", path, headers=headers)

    def post(
        self,
        path: str,
        form: Mapping[str, str | Sequence[str]],
        headers: Mapping[str, str] | None = None,
    ) -> Response:
        return self.request("POST", path, form=form, headers=headers)
