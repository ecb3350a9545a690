"""The hot modules of the G-code importer and the 1704 tape writer, compiled to C by
mypyc in a wheel built for it.

`MILLBLOCKS_MYPYC=1` when the wheel is built (setup.py, `make wheel-native`) compiles the
modules in `COMPILED` into extension modules that sit beside their sources in the
installed package; Python then imports the `.so` before the `.py`. The sources stay the
reference: the compiled modules are the same code, typed by the same annotations, and
tests/test_native.py installs such a wheel and compares its results with the sources' on
the import corpora.

A wheel's extension modules were built from the sources beside them, so they cannot be
older than their code. Nothing is compiled into a checkout; an extension module found in
one (left by an older build of this project) is never loaded: `guard()` (run by
`app.cnc.__init__`, before any of these modules is imported) imports the sources there.
`MILLBLOCKS_NATIVE=0` in the environment asks for the sources anywhere.

Standard library only: this runs at every start, before anything else in the core.
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType

# The G-code import pipeline, from the characters of a file to its operations (the
# bench's `read_as`), the helpers it calls for every operation (units, geometry, routines,
# the program's build), and the 1704 writer's planner, rounder and words with the compiled
# path they walk (`millblocks export big.ngc --to tape-eia`, issue 31). Each is strictly
# typed (mypy --strict on app.cnc), which is what mypyc compiles from. Not app.cnc.places:
# a generic dataclass compiled by mypyc fails at import ("attribute '__dict__' of 'type'
# objects is not writable"). Order does not matter; the group is built as one.
COMPILED = (
    "app.cnc.recognition.common",
    "app.cnc.recognition.steps",
    "app.cnc.formats.gcode.reader",
    "app.cnc.recognition.segment",
    "app.cnc.recognition.ops",
    "app.cnc.recognition.recognise",
    "app.cnc.recognition.motion",
    "app.cnc.formats.tape1704.plan",
    "app.cnc.formats.tape1704.words",
    "app.cnc.formats.tape1704.image",
    "app.cnc.units",
    "app.cnc.geometry",
    "app.cnc.routines",
    "app.cnc.recognition.build",
    "app.cnc.path",
)
GROUP = "native_group"  # the group's shared library: app/cnc/native_group__mypyc.*.so
ROOT = Path(__file__).resolve().parents[2]  # the directory holding `app`
SWITCH = "MILLBLOCKS_NATIVE"


def source_path(module: str, root: Path = ROOT) -> Path:
    return root.joinpath(*module.split(".")).with_suffix(".py")


def extension_files(root: Path = ROOT) -> dict[str, Path]:
    """Module name → extension module file, for every one under `root`/app (those of
    `COMPILED`, the group's library, and any left from an older list)."""
    suffixes = sorted(importlib.machinery.EXTENSION_SUFFIXES, key=len, reverse=True)
    found: dict[str, Path] = {}
    for path in (root / "app").rglob("*"):
        suffix = next((s for s in suffixes if path.name.endswith(s)), None)
        if suffix is not None:
            parts = path.relative_to(root).with_name(path.name[: -len(suffix)]).parts
            found[".".join(parts)] = path
    return dict(sorted(found.items()))


def status() -> dict[str, str]:
    """Module name → "compiled" (its extension module is loaded), "source" or "not loaded"."""
    result: dict[str, str] = {}
    for name in COMPILED:
        module = sys.modules.get(name)
        if module is None:
            result[name] = "not loaded"
        else:
            origin = getattr(module, "__file__", None) or ""
            result[name] = "source" if origin.endswith(".py") else "compiled"
    return result


class _SourceFirst:
    """Finds the listed modules' `.py` files, so that their extension modules are not used
    (a module with no source left, such as the group's library, is not found at all).

    A meta path finder is anything with `find_spec`: importlib.abc.MetaPathFinder as the
    base would import importlib.resources at every start (2 ms, issue 31.3)."""

    def __init__(self, modules: Sequence[str], root: Path) -> None:
        self.paths = {name: source_path(name, root) for name in modules}

    def find_spec(
        self,
        fullname: str,
        path: Sequence[str] | None = None,
        target: ModuleType | None = None,
    ) -> importlib.machinery.ModuleSpec | None:
        source = self.paths.get(fullname)
        if source is None:
            return None
        if not source.exists():
            raise ModuleNotFoundError(f"{fullname}: only a stale compiled build is left")
        return importlib.util.spec_from_file_location(fullname, source)


def in_checkout(root: Path = ROOT) -> bool:
    """Whether `root` is a source checkout (its top level has the app's `templates/` beside
    `app/`), not an installed package."""
    return (root / "templates").is_dir() and (root / "app").is_dir()


def guard() -> None:
    """Import the compiled modules from their sources in a checkout, or when switched off.
    Must run before any of them is imported (app.cnc.__init__ calls it)."""
    if any(isinstance(finder, _SourceFirst) for finder in sys.meta_path):
        return
    if os.environ.get(SWITCH, "") != "0" and not in_checkout():
        return
    modules = sorted({*COMPILED, *extension_files()})
    sys.meta_path.insert(0, _SourceFirst(modules, ROOT))
