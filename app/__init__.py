"""MillBlocks: conversational mill programming.

`app.cnc` is the pure core; `app.storage` the library; `app.web` the Flask app, whose
factory is re-exported here so that `flask --app app run` finds it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from flask import Flask


def create_app(test_config: dict[str, Any] | None = None) -> Flask:
    """The Flask application (see app.web.create_app)."""
    from app.web import create_app as factory

    return factory(test_config)
