"""The shop deployment as the README and docs/deploy.md give it, with real sockets: gunicorn
started with the README's command (listening on the loopback address only) behind nginx
with the documented configuration. Slow-header clients, more of them than there are
workers, wait in nginx while a normal request still answers (before, two such connections
held both sync workers of a two-worker server for gunicorn's 30 s timeout).

The README's command and the nginx block are read from the documents themselves, so the
test fails when either drifts from what it shows. Only the addresses change (free ports
of this computer) and the TLS lines go (no certificate here; tests/test_deploy.py runs the
same configuration with TLS).
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import ExitStack, closing
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NGINX = shutil.which("nginx") or "/usr/sbin/nginx"
WAIT = 30.0  # seconds a server may take to start
ANSWER = 10.0  # seconds a normal request may take with slow clients about: a third of the
# 30 s a held worker would make it wait


def readme_command() -> list[str]:
    """The gunicorn command of the README's "Serving a shop"."""
    section = (ROOT / "README.md").read_text().split("## Serving a shop", 1)[1]
    line = next(ln for ln in section.splitlines() if "bin/gunicorn " in ln)
    return shlex.split(line)


def nginx_block() -> str:
    """The nginx configuration of docs/deploy.md."""
    found = re.search(r"```nginx\n(.*?)```", (ROOT / "docs" / "deploy.md").read_text(), re.S)
    assert found, "docs/deploy.md has no nginx configuration"
    return found.group(1)


def free_port() -> int:
    with closing(socket.socket()) as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def wait_for(port: int, process: subprocess.Popen[bytes]) -> None:
    deadline = time.monotonic() + WAIT
    while time.monotonic() < deadline:
        assert process.poll() is None, f"the server on port {port} ended"
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            return
        except OSError:
            time.sleep(0.1)
    raise AssertionError(f"nothing answered on port {port} within {WAIT} s")


def stop(process: subprocess.Popen[bytes]) -> None:
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGTERM)
        try:
            process.wait(timeout=WAIT)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()


def listening_addresses(port: int) -> set[str]:
    """The local addresses of the TCP sockets listening on `port` (from /proc/net/tcp*)."""
    found = set()
    for table, width in (("/proc/net/tcp", 8), ("/proc/net/tcp6", 32)):
        if not Path(table).exists():
            continue
        for row in Path(table).read_text().splitlines()[1:]:
            local, state = row.split()[1], row.split()[3]
            address, _, hex_port = local.partition(":")
            if state == "0A" and int(hex_port, 16) == port:  # 0A: LISTEN
                if width == 8:
                    found.add(socket.inet_ntoa(bytes.fromhex(address)[::-1]))
                else:
                    words = bytes.fromhex(address)
                    raw = b"".join(words[i : i + 4][::-1] for i in range(0, 16, 4))
                    found.add(socket.inet_ntop(socket.AF_INET6, raw))
    return found


@pytest.fixture(scope="module")
def shop(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[int, int, int]]:
    """(nginx port, gunicorn port, workers): both started as the documents say."""
    tmp_path = tmp_path_factory.mktemp("shop")
    if not Path(NGINX).exists():
        pytest.fail("no nginx: scripts/install-system-deps installs it (debian-packages.txt)")
    app_port, proxy_port = free_port(), free_port()
    command = readme_command()
    host, _, _ = command[command.index("--bind") + 1].rpartition(":")
    command[command.index("--bind") + 1] = f"{host}:{app_port}"  # the README's address
    command[0] = str(Path(sys.executable).parent / "gunicorn")
    workers = int(command[command.index("--workers") + 1])
    env = {
        **os.environ,
        "DATABASE_URL": f"sqlite:///{tmp_path / 'shop.db'}",
        "MILLBLOCKS_AUTH": "accounts",
        "MILLBLOCKS_PROXY_HOPS": "1",
    }
    block = nginx_block().replace("127.0.0.1:8000", f"127.0.0.1:{app_port}")
    block = re.sub(r"\n\s*listen \[::\]:[^\n]*", "", block)  # IPv6 may be absent here
    block = block.replace("listen 80;", f"listen 127.0.0.1:{free_port()};")
    block = re.sub(r"listen 443 ssl;", f"listen 127.0.0.1:{proxy_port};", block)
    block = re.sub(r"\n\s*ssl_certificate(_key)?\s[^\n]*", "", block)
    temp = tmp_path / "nginx"
    temp.mkdir()
    (temp / "nginx.conf").write_text(
        f"""daemon off;
user root;
worker_processes 1;
pid {temp}/nginx.pid;
error_log {temp}/error.log;
events {{ worker_connections 256; }}
http {{
    access_log off;
    client_body_temp_path {temp}/body;
    proxy_temp_path {temp}/proxy;
    fastcgi_temp_path {temp}/fastcgi;
    uwsgi_temp_path {temp}/uwsgi;
    scgi_temp_path {temp}/scgi;
{block}
}}
"""
    )
    with ExitStack() as stack:
        server = subprocess.Popen(
            command, cwd=ROOT, env=env, start_new_session=True, stderr=subprocess.DEVNULL
        )
        stack.callback(stop, server)
        wait_for(app_port, server)
        proxy = subprocess.Popen(
            [NGINX, "-p", str(temp), "-c", str(temp / "nginx.conf")],
            start_new_session=True,
            stderr=subprocess.DEVNULL,
        )
        stack.callback(stop, proxy)
        wait_for(proxy_port, proxy)
        yield proxy_port, app_port, workers


def get(port: int, path: str, timeout: float = ANSWER) -> tuple[int, bytes]:
    """A plain HTTP/1.1 GET through a real socket; (status, body) or a timeout error."""
    with socket.create_connection(("127.0.0.1", port), timeout=timeout) as conn:
        conn.sendall(f"GET {path} HTTP/1.1\r\nHost: mill\r\nConnection: close\r\n\r\n".encode())
        reply = b""
        while chunk := conn.recv(65536):
            reply += chunk
    head, _, body = reply.partition(b"\r\n\r\n")
    return int(head.split()[1]), body


def test_slow_header_clients_leave_the_shop_server_answering(
    shop: tuple[int, int, int],
) -> None:
    proxy_port, app_port, workers = shop
    assert get(proxy_port, "/login", WAIT)[0] == 200  # the workers have started
    with ExitStack() as stack:
        slow = []
        for _ in range(2 * workers + 2):
            conn = stack.enter_context(socket.create_connection(("127.0.0.1", proxy_port)))
            conn.sendall(b"GET /login HTTP/1.1\r\nHost: mill\r\nX-Slow: ")
            slow.append(conn)
        for conn in slow:  # one more byte each, as a slow client sends them
            conn.sendall(b"a")
        status, body = get(proxy_port, "/login")
        assert status == 200 and b'name="username"' in body
        for conn in slow:  # still open, still unanswered: they wait in nginx
            conn.setblocking(False)
            with pytest.raises(BlockingIOError):
                conn.recv(1)
    # gunicorn is reached from this computer only.
    assert listening_addresses(app_port) == {"127.0.0.1"}


def test_an_upload_past_the_limit_is_refused_by_the_proxy(shop: tuple[int, int, int]) -> None:
    """client_max_body_size is the app's own limit: a larger body never reaches a worker."""
    proxy_port, _, _ = shop
    with socket.create_connection(("127.0.0.1", proxy_port), timeout=ANSWER) as conn:
        size = 2 * 1024 * 1024 + 1
        conn.sendall(
            f"POST /programs/import HTTP/1.1\r\nHost: mill\r\nContent-Length: {size}\r\n"
            "Content-Type: application/octet-stream\r\nConnection: close\r\n\r\n".encode()
        )
        reply = conn.recv(65536)
    assert reply.split()[1] == b"413"
