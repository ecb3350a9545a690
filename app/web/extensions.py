"""What the blueprints share with the factory: the CSRF extension, the library and the
limits of an upload."""

from __future__ import annotations

from flask import current_app
from flask_wtf.csrf import CSRFProtect

from app.cnc.sizes import ImportLimits
from app.storage.library import Library

csrf = CSRFProtect()


def get_library() -> Library:
    """The library of the running app."""
    library: Library = current_app.extensions["millblocks.library"]
    return library


def upload_limits() -> ImportLimits:
    """The bounds of a file uploaded to this server (MILLBLOCKS_MAX_UPLOAD_BYTES and
    MILLBLOCKS_MAX_IMPORT_LINES)."""
    config = current_app.config
    return ImportLimits(config["MAX_UPLOAD_BYTES"], config["MAX_IMPORT_LINES"])
