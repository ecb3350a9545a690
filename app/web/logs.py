"""What the server says on stderr (the journal, under systemd): one line per request with a
level, and every unexpected error with a reference the user can quote.

A line is `LEVEL logger: message`. When stderr is the journal (systemd sets JOURNAL_STREAM
to its device and inode) each line starts with the syslog priority, `<6>` for INFO, `<3>`
for ERROR, which journald takes as the entry's priority (`journalctl -p err` finds the
errors) and strips; elsewhere the line starts with the time instead. A request line is
`GET /programs/3 200 12 ms 10.0.0.7 ana`: the path without its query, the status, the time
the app took, the client (X-Forwarded-For when the proxy is trusted) and the user, at INFO
(ERROR for a 5xx).

An unexpected error is logged once, with its traceback and a reference (8 hex digits), and
the user gets the 500 page naming that reference (`templates/errors/500.html`).
"""

from __future__ import annotations

import logging
import os
import secrets
import sys
import time
from typing import Any

from flask import Flask, g, render_template, request
from werkzeug.exceptions import InternalServerError
from werkzeug.wrappers import Response

log = logging.getLogger("millblocks")
request_log = logging.getLogger("millblocks.request")

SYSLOG_PRIORITY = {
    logging.DEBUG: 7,
    logging.INFO: 6,
    logging.WARNING: 4,
    logging.ERROR: 3,
    logging.CRITICAL: 2,
}


class Lines(logging.Formatter):
    """`LEVEL logger: message`, after the syslog priority when stderr is the journal, else
    after the time."""

    def __init__(self, journal: bool) -> None:
        super().__init__("%(levelname)s %(name)s: %(message)s")
        self.journal = journal

    def format(self, record: logging.LogRecord) -> str:
        line = super().format(record)
        if self.journal:
            return f"<{SYSLOG_PRIORITY.get(record.levelno, 6)}>{line}"
        return f"{self.formatTime(record, '%Y-%m-%d %H:%M:%S')} {line}"


def stderr_is_journal() -> bool:
    """Whether stderr is the journal's stream (systemd's JOURNAL_STREAM is `device:inode`)."""
    device, _, inode = os.environ.get("JOURNAL_STREAM", "").partition(":")
    try:
        status = os.fstat(sys.stderr.fileno())
    except (OSError, ValueError, AttributeError):
        return False
    return f"{status.st_dev}:{status.st_ino}" == f"{device}:{inode}"


class Stderr(logging.StreamHandler[Any]):
    """A handler writing to whatever sys.stderr is when a line is written (as logging's own
    last resort does), not the stream of the moment it was made: a test runner or a
    command runner that swaps stderr gets the lines, and no stale stream is kept open."""

    def __init__(self) -> None:
        super().__init__(sys.stderr)

    @property
    def stream(self) -> Any:
        return sys.stderr

    @stream.setter
    def stream(self, _value: Any) -> None:
        pass


def setup(level: str) -> None:
    """Send MillBlocks' logs (`millblocks.*`, and the package's own `app.*`) to stderr at
    `level`; once per process, however many apps it makes."""
    handler = next((h for h in log.handlers if isinstance(h, Stderr)), None)
    if handler is None:
        handler = Stderr()
        handler.setFormatter(Lines(stderr_is_journal()))
        for logger in (log, logging.getLogger("app")):
            logger.addHandler(handler)
    for logger in (log, logging.getLogger("app")):
        logger.setLevel(level)


class MillBlocks(Flask):
    """The Flask app, logging an unexpected error with a reference the 500 page shows."""

    def log_exception(self, exc_info: Any) -> None:
        g.error_reference = secrets.token_hex(4).upper()
        log.error(
            "error %s on %s %s",
            g.error_reference,
            request.method,
            request.path,
            exc_info=exc_info,
        )


def init_app(app: Flask) -> None:
    setup(app.config["LOG_LEVEL"])
    app.before_request(_started)
    app.after_request(_log_request)
    app.register_error_handler(InternalServerError, _server_error)


def _started() -> None:
    g.request_started = time.perf_counter()


def _log_request(response: Response) -> Response:
    started = g.get("request_started")
    took = "-" if started is None else f"{(time.perf_counter() - started) * 1000:.0f} ms"
    user = g.get("user")
    reference = g.get("error_reference")
    request_log.log(
        logging.ERROR if response.status_code >= 500 else logging.INFO,
        "%s %s %d %s %s %s%s",
        request.method,
        request.path,
        response.status_code,
        took,
        request.remote_addr or "-",
        getattr(user, "username", "-"),
        f" error {reference}" if reference else "",
    )
    return response


def _server_error(error: InternalServerError) -> tuple[str, int]:
    """The 500 page, in the app's style, naming the logged reference."""
    reference = g.get("error_reference")
    if reference is None:  # a 500 raised on purpose, not an exception: log it too
        g.error_reference = reference = secrets.token_hex(4).upper()
        log.error("error %s on %s %s: %s", reference, request.method, request.path, error)
    try:
        return render_template("errors/500.html", reference=reference), 500
    except Exception:  # the page itself failed (a broken template): say it plainly
        log.exception("error %s: the 500 page could not be shown", reference)
        return (
            "<!doctype html><title>Error</title><h1>Something went wrong</h1>"
            f"<p>Reference {reference}. <a href='/'>Back to the library</a></p>",
            500,
        )
