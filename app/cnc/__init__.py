"""The pure core: program model, validation, interpreter, tool path, emitters.

Nothing here imports Flask, a database or serial code (tests/test_layering.py checks).
The G-code importer's hot modules may be compiled (`native`); `native.guard()` runs first so
that a build older than its sources is never imported.
"""

from app.cnc import native

native.guard()
