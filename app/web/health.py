"""`GET /healthz`: whether this server can serve, for a proxy, a load balancer or a monitor.

200 `{"status": "ok"}` when the database answers; 503 `{"status": "unavailable"}` when it
does not, or when the library's transfer service went silent without being stopped (killed,
crashed: queued RS-232 transfers wait for nobody). The reason is logged, never sent: it
may name hosts or users. No login, no cookie, nothing else in it.
"""

from __future__ import annotations

import logging

from flask import Blueprint
from sqlalchemy import text
from sqlalchemy.exc import SQLAlchemyError

from app.dnc.daemon import service_died
from app.web.extensions import get_library

bp = Blueprint("health", __name__)
log = logging.getLogger("millblocks.health")


@bp.get("/healthz")
def check() -> tuple[dict[str, str], int, dict[str, str]]:
    headers = {"Cache-Control": "no-store"}
    try:
        with get_library().engine.connect() as connection:
            connection.execute(text("SELECT 1"))
    except SQLAlchemyError as exc:
        first = (str(exc).splitlines() or [exc.__class__.__name__])[0]
        log.warning("health check: the database does not answer: %s", first)
        return {"status": "unavailable"}, 503, headers
    try:
        gone = service_died(get_library())
    except SQLAlchemyError:
        # The database answers but has no library's tables (emptied, a restore under way):
        # no service's heartbeat to judge; the database's answer is the health.
        gone = None
    if gone is not None:
        log.warning(
            "health check: the transfer service (%s UTC, its last heartbeat) stopped without "
            "being stopped; queued transfers wait until it runs again",
            gone,
        )
        return {"status": "unavailable"}, 503, headers
    return {"status": "ok"}, 200, headers
