"""MillBlocks: conversational mill programming.

`app.cnc` is the pure core; `app.storage` the library; `app.web` the Flask app, whose
factory is re-exported here so that `flask --app app run` finds it.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager
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
    from app.web import create_app as factory

    with _start_refused((test_config or {}).get("DATABASE_URL")):
        return factory(test_config)


def check_start() -> None:
    """What create_app refuses that no worker can mend — the settings, the instance folder,
    the database's answer, a schema newer than this code, a damaged SQLite file — checked
    once, refused the same way (one line, exit 4 or 3). gunicorn's master runs it before
    any worker starts (app/gunicorn_conf.py, on_starting): when two workers each fail to
    load, gunicorn reaps the second while it halts for the first and ends with a traceback
    and status 1, which the unit restarts on."""
    from app.settings import environment, instance_folder
    from app.storage.db import check_known, open_engine

    with _start_refused(None):
        settings = environment()
        instance_folder()
        engine = open_engine(settings["DATABASE_URL"])
        try:
            check_known(engine)
        finally:
            engine.dispose()  # no connection of the master's is inherited by a worker


@contextmanager
def _start_refused(url: str | None) -> Iterator[None]:
    """Exit as create_app's docstring says for what the body raises; `url` is the database
    URL given, if any (else the environment's)."""
    from sqlalchemy.exc import SQLAlchemyError

    from app.settings import SettingError, environment
    from app.storage.db import DatabaseUnavailable, SchemaError, damaged_file

    try:
        yield
    except (SettingError, SchemaError) as exc:
        print(f"MillBlocks cannot start: {exc}", file=sys.stderr, flush=True)
        raise SystemExit(4) from None
    except SQLAlchemyError as exc:
        # A damaged SQLite file: restarting cannot mend it (as a setting it cannot use).
        said = damaged_file(exc, url or environment()["DATABASE_URL"])
        if said is None:
            raise
        print(f"MillBlocks cannot start: {said}", file=sys.stderr, flush=True)
        raise SystemExit(4) from None
    except DatabaseUnavailable as exc:
        # 3: gunicorn's "worker failed to boot"; it stops, and the unit tries again later.
        print(f"MillBlocks cannot start yet: {exc}", file=sys.stderr, flush=True)
        raise SystemExit(3) from None
