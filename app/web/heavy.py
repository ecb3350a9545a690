"""One heavy request at a time in each server process: Verify, the set-up sheet, an export.

Each is bounded in work (sizes.MAX_MOVES, sizes.MAX_VERIFY_WORK) and in time
(REQUEST_SECONDS), but its work is Python and numpy under one interpreter lock: with
several in one process, a login in the same process waits its turn behind all of them
(five at once held a login 1.2 s here even with the bounds; issue 30). So a process runs
one at a time; another waits for it, at most HEAVY_WAIT seconds, and is then told the
server is busy (503, "try again") rather than queueing without end; more than one waiting
are told at once (HEAVY_ADMITTED). A login, a library
page, the editor never wait here (docs/security.md, "Heavy requests").
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable
from typing import ParamSpec, TypeVar

from flask import render_template

P = ParamSpec("P")
R = TypeVar("R")

HEAVY_WAIT = 10.0
"""Seconds a heavy request waits for the one before it: about five of the heaviest Verifys
(~2 s each), well inside REQUEST_SECONDS (20) and gunicorn's timeout (30)."""

HEAVY_ADMITTED = 2
"""Heavy requests a process holds at once, the one running and those waiting: a waiting
request holds one of the worker's threads (app/gunicorn_conf.py: 4), so past these a heavy
request is told at once that the server is busy, and two threads are always left for
logins and light pages (with every thread waiting, a login queued 2.2 s behind five)."""

# Per process: gunicorn's workers are processes, each with its own.
_RUNNING = threading.BoundedSemaphore(1)
_ADMITTED = threading.BoundedSemaphore(HEAVY_ADMITTED)

BUSY = (
    "The server is working on other large programs (Verifys, set-up sheets or exports); "
    "try this one again in a few seconds."
)


def heavy(view: Callable[P, R]) -> Callable[P, R | tuple[str, int, dict[str, str]]]:
    """Run the view when no other heavy request runs in this process, waiting at most
    HEAVY_WAIT seconds; past that, or when HEAVY_ADMITTED heavy requests are already here,
    a 503 page saying the server is busy."""

    @functools.wraps(view)
    def guarded(*args: P.args, **kwargs: P.kwargs) -> R | tuple[str, int, dict[str, str]]:
        if not _ADMITTED.acquire(blocking=False):
            return _busy()
        try:
            if not _RUNNING.acquire(timeout=HEAVY_WAIT):
                return _busy()
            try:
                return view(*args, **kwargs)
            finally:
                _RUNNING.release()
        finally:
            _ADMITTED.release()

    return guarded


def _busy() -> tuple[str, int, dict[str, str]]:
    page = render_template("errors/error.html", title="Busy", message=BUSY)
    return page, 503, {"Retry-After": "5"}
