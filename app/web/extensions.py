"""What the blueprints share with the factory: the CSRF extension and the library."""

from __future__ import annotations

from flask import current_app
from flask_wtf.csrf import CSRFProtect

from app.storage.library import Library

csrf = CSRFProtect()


def get_library() -> Library:
    """The library of the running app."""
    library: Library = current_app.extensions["millblocks.library"]
    return library
