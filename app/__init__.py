"""MillBlocks: conversational mill programming.

`app.cnc` is the pure core; `app.storage` the library; `app.web` the Flask app, whose
factory is re-exported here so that `flask --app app run` finds it.
"""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from flask import Flask


def create_app(test_config: dict[str, Any] | None = None) -> Flask:
    """The Flask application (see app.web.create_app), for a server to start: a setting it
    cannot use (a database URL, password or instance folder among them) or a database newer
    than this code is said in one line on stderr (the journal), and the process exits with
    status 4, which gunicorn reads as "the app failed to load" and stops on, instead of
    restarting workers that cannot start (the unit file does not restart on it either); so
    is a damaged SQLite file, which no restart mends. A
    database that does not answer is one line too, and status 3 ("worker failed to boot"):
    gunicorn stops, and the unit starts it again after RestartSec."""
    from sqlalchemy.exc import SQLAlchemyError

    from app.settings import SettingError, environment
    from app.storage.db import DatabaseUnavailable, SchemaError, damaged_file
    from app.web import create_app as factory

    try:
        return factory(test_config)
    except (SettingError, SchemaError) as exc:
        print(f"MillBlocks cannot start: {exc}", file=sys.stderr, flush=True)
        raise SystemExit(4) from None
    except SQLAlchemyError as exc:
        # A damaged SQLite file: restarting cannot mend it (as a setting it cannot use).
        url = (test_config or {}).get("DATABASE_URL") or environment()["DATABASE_URL"]
        said = damaged_file(exc, url)
        if said is None:
            raise
        print(f"MillBlocks cannot start: {said}", file=sys.stderr, flush=True)
        raise SystemExit(4) from None
    except DatabaseUnavailable as exc:
        # 3: gunicorn's "worker failed to boot"; it stops, and the unit tries again later.
        print(f"MillBlocks cannot start yet: {exc}", file=sys.stderr, flush=True)
        raise SystemExit(3) from None
