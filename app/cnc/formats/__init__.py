"""File formats: one package per format, holding its model, its reader and its writers.

    events/     ProtoTRAK Plus events G100-G109 (seed 003 §2.2): model, reader, writer
    gcode/      RS274/NGC, Fanuc 6M, ProtoTRAK modified Fanuc, Bridgeport BOSS: dialects,
                reader, writer
    tape1704/   Tektronix 1704 tape (seed 000): codes, profile, plan, words, tape image,
                picture, reader
    document/   the MillBlocks program document (JSON; app/cnc/document.py is its model)
    dxf/        DXF drawings (import only)

A format package registers what it offers when it is imported: its export targets with
`app.cnc.emit.target.register` (name, options, abilities: `binary`, `picture`,
`reads_back`, `needs`) and its importer with `app.cnc.imports.registry.register_importer`
(name, options, `sniff`, `read`). Everything that lists formats — the command line's
choices, the web forms, the transfers page, the RS-232 receive path — asks the two
registries (`targets()`, `importers()`), never a list of names, and a target's abilities
are its attributes, never read from its name.

Adding a format or a target:

1. A new package here (or a module in an existing one) with the model, the reader and
   the writer side by side; import them from the package's `__init__`.
2. A target: subclass `Target` (or an existing family: `GcodeTarget` with a `Dialect`,
   `TapeTarget`), set `name`, `label`, `description`, `extension`, `options` (and
   `common`), the abilities, and implement `write(program, path, options, report, out)`:
   walk `path.chunks()` (arrays of moves with their hole and mill spans), write as you go,
   report what cannot be expressed through `report.unsupported`; never re-derive holes
   from moves — read the spans.
3. An importer: subclass `Importer`, set `name`, `label`, `description`, `rank`,
   `options`, implement `sniff(content)` (how sure the content is this format) and
   `read(data, name, options)` (a Program and its report; `ImportFailure` naming line and
   column for anything unreadable).
4. Tests: a golden file per case (`tests/golden/<case>/expected.<target>`, written by
   `make regen-golden` and reviewed), a round trip through the importer that reads it back
   (tests/test_import_roundtrip.py picks up `reads_back`), and the referee where one exists
   (LinuxCNC's rs274 for G-code).
"""

from __future__ import annotations

import importlib
import pkgutil

_LOADED = False


def load_formats() -> None:
    """Import every format package once (each registers its targets and importer)."""
    global _LOADED
    if _LOADED:
        return
    _LOADED = True
    for module in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if module.ispkg:
            importlib.import_module(f"{__name__}.{module.name}")
