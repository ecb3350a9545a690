"""The G-code importer's hot modules, compiled to C by mypyc where a build is present.

`make` (scripts/build-native) compiles the modules in `COMPILED` with mypyc into extension
modules beside their sources; Python then imports the `.so` before the `.py`. The sources
stay the reference: the compiled modules are the same code, typed by the same annotations,
and the test suite runs against them (tests/test_native.py compares their results with the
sources' on the import corpora).

A compiled module that no longer matches its source would run old code. The build writes
the SHA-256 of every source it compiled to `BUILD_RECORD`; `guard()` (run by
`app.cnc.__init__`, before any of these modules is imported) compares them, and when any
source differs, or the record is missing, the whole group is imported from the sources: the
compiled modules call each other directly, so one stale module makes all of them unsafe.
`MILLBLOCKS_NATIVE=0` in the environment asks for the sources too.

Standard library only: this runs at every start, before anything else in the core.
"""

from __future__ import annotations

import hashlib
import importlib.abc
import importlib.machinery
import importlib.util
import json
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType

# The G-code import pipeline, from the characters of a file to its operations (the
# bench's `read_as`): each is strictly typed (mypy --strict on app.cnc), which is what
# mypyc compiles from. Order does not matter; the group is built as one.
COMPILED = (
    "app.cnc.imports.common",
    "app.cnc.imports.steps",
    "app.cnc.formats.gcode.reader",
    "app.cnc.imports.segment",
    "app.cnc.imports.ops",
    "app.cnc.imports.recognise",
    "app.cnc.imports.motion",
)
ROOT = Path(__file__).resolve().parents[2]  # the directory holding `app`
BUILD_RECORD = ROOT / "app" / "cnc" / "native-build.json"
SWITCH = "MILLBLOCKS_NATIVE"


def source_path(module: str, root: Path = ROOT) -> Path:
    return root.joinpath(*module.split(".")).with_suffix(".py")


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def digests(modules: Sequence[str] = COMPILED, root: Path = ROOT) -> dict[str, str]:
    """Module name → SHA-256 of its source as it is now."""
    return {name: digest(source_path(name, root)) for name in modules}


def stale(modules: Sequence[str] = COMPILED, root: Path = ROOT) -> list[str]:
    """The modules whose source differs from the one their build was compiled from (all of
    them when the build record is missing or unreadable; none when nothing is compiled)."""
    record_path = root / "app" / "cnc" / BUILD_RECORD.name
    built = [name for name in modules if compiled_file(name, root) is not None]
    if not built:
        return []
    try:
        record = json.loads(record_path.read_text())
        sources = record["sources"]
    except (OSError, ValueError, KeyError, TypeError):
        return list(modules)
    now = digests(modules, root)
    return [name for name in modules if sources.get(name) != now[name]]


def compiled_file(module: str, root: Path = ROOT) -> Path | None:
    """The extension module built for `module` beside its source, if there is one."""
    source = source_path(module, root)
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        candidate = source.with_name(source.stem + suffix)
        if candidate.exists():
            return candidate
    return None


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


class _SourceFirst(importlib.abc.MetaPathFinder):
    """Finds the listed modules' `.py` files, so that their extension modules are not used."""

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
        return importlib.util.spec_from_file_location(fullname, source)


def guard() -> None:
    """Import the group from its sources when the compiled build is stale or switched off.

    Must run before any module of `COMPILED` is imported (app.cnc.__init__ calls it).
    A stale build is said on stderr once: the import still works, at the sources' speed.
    """
    if any(isinstance(finder, _SourceFirst) for finder in sys.meta_path):
        return
    off = os.environ.get(SWITCH, "") == "0"
    outdated = [] if off else stale()
    if not off and not outdated:
        return
    if outdated:
        print(
            "millblocks: the compiled G-code importer is older than its sources "
            f"({', '.join(outdated[:2])}{', …' if len(outdated) > 2 else ''}); importing "
            "the sources instead. `make native` rebuilds it.",
            file=sys.stderr,
        )
    sys.meta_path.insert(0, _SourceFirst(COMPILED, ROOT))
