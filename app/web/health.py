"""`GET /healthz`: whether this server can serve, for a proxy, a load balancer or a monitor.

200 `{"status": "ok"}` when the database answers; 503 `{"status": "unavailable"}` when it
does not (the reason is logged, never sent: it may name hosts or users). No login, no
cookie, nothing else in it.
"""

from __future__ import annotations

import logging

from flask import Blueprint
from sqlalchemy import text
from sqlalchemy.exc import SQLAlchemyError

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
    return {"status": "ok"}, 200, headers
