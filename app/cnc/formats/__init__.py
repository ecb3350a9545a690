"""File formats: one package per format, holding its model, its reader and its writers.

    events/     ProtoTRAK Plus events G100-G109 (seed 003 §2.2): model, reader, writer
    gcode/      RS274/NGC, Fanuc 6M, ProtoTRAK modified Fanuc, Bridgeport BOSS: dialects,
                reader, writer
    tape1704/   Tektronix 1704 tape (seed 000): codes, profile, plan, words, tape image,
                picture, reader
    document/   the MillBlocks program document (JSON; app/cnc/document.py is its model)
    dxf/        DXF drawings (import only)

A format is known by a light declaration, and its reader or writer is imported only when it
is used, so a command that exports one program loads that target alone (issue 31):

- a format package's `__init__` declares its importer (`app.cnc.formats.importers.Importer`:
  name, label, options, `sniff`) and imports nothing heavy; its `read` imports the
  package's reader when it runs. `importers()` imports every package's `__init__` (detection
  asks every sniff), never a reader.
- `TARGET_MODULES` below says which module defines each export target; `get_target(name)`
  imports that one module, `targets()` (a list of them all) imports every one. The module
  registers the target with `app.cnc.formats.targets.register`, which refuses a target this
  table does not name, so the table cannot fall behind.

Everything that lists formats - the command line's choices, the web forms, the transfers
page, the RS-232 receive path - asks the two registries (`targets()`, `importers()`, or
`get_target`/`get_importer` for one), never a list of names, and a target's abilities
(`binary`, `picture`, `reads_back`, `needs`) are its attributes, never read from its name.

Adding a format or a target:

1. A new package here (or a module in an existing one) with the model, the reader and
   the writer side by side; its `__init__` holds the importer's declaration only.
2. A target: add its name and module to `TARGET_MODULES`; subclass `Target` (or an
   existing family: `GcodeTarget` with a `Dialect`, `TapeTarget`), set `name`, `label`,
   `description`, `extension`, `options` (and `common`), the abilities, and implement
   `write(program, path, options, report, out)`: walk `path.chunks()` (arrays of moves
   with their hole and mill spans), write as you go, report what cannot be expressed
   through `report.unsupported`; never re-derive holes from moves — read the spans.
3. An importer: in the package's `__init__`, subclass `Importer`, set `name`, `label`,
   `description`, `rank`, `options`, implement `sniff(content)` (how sure the content is
   this format; it runs for every file detected, so it stays light) and
   `read(data, name, options)` (it imports the reader; a Program and its report,
   `ImportFailure` naming line and column for anything unreadable).
4. Tests: a golden file per case (`tests/golden/<case>/expected.<target>`, written by
   `make regen-golden` and reviewed), a round trip through the importer that reads it back
   (tests/test_import_roundtrip.py picks up `reads_back`), and the referee where one exists
   (LinuxCNC's rs274 for G-code).
"""

from __future__ import annotations

import importlib
import pkgutil

# Each export target's name and the module that defines it (and registers it).
TARGET_MODULES: dict[str, str] = {
    "canon": "app.cnc.formats.canon",
    "events": "app.cnc.formats.events.writer",
    "gcode-fanuc": "app.cnc.formats.gcode.writer",
    "gcode-linuxcnc": "app.cnc.formats.gcode.writer",
    "gcode-prototrak": "app.cnc.formats.gcode.writer",
    "json": "app.cnc.formats.document.writer",
    "punch-ascii": "app.cnc.formats.tape1704.targets",
    "punch-eia": "app.cnc.formats.tape1704.targets",
    "svg": "app.cnc.formats.svg",
    "tape-ascii": "app.cnc.formats.tape1704.targets",
    "tape-boss": "app.cnc.formats.gcode.boss",
    "tape-eia": "app.cnc.formats.tape1704.targets",
    "tape-svg": "app.cnc.formats.tape1704.targets",
}

_LOADED = False


def load_formats() -> None:
    """Import every format package's declaration once (each registers its importer; no
    reader or writer is imported)."""
    global _LOADED
    if _LOADED:
        return
    _LOADED = True
    for module in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if module.ispkg:
            importlib.import_module(f"{__name__}.{module.name}")
