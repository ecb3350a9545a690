"""The G-code importer's hot modules, compiled to C by mypyc where a build is present.

`make` (scripts/build-native) compiles the modules in `COMPILED` with mypyc into extension
modules beside their sources; Python then imports the `.so` before the `.py`. The sources
stay the reference: the compiled modules are the same code, typed by the same annotations,
and the test suite runs against them (tests/test_native.py compares their results with the
sources' on the import corpora).

A compiled module that no longer matches the code it was built from would run old code.
Compiled code depends on more than its own source — mypyc puts other modules' `Final`
constants into it and relies on their signatures — so the build records the SHA-256 of
every source of the core (`app/cnc`, about 90 files: 4 ms to hash). `guard()` (run by
`app.cnc.__init__`, before any of these modules is imported) compares them, and when
anything differs, the record is missing, or the build is incomplete, every module that has
an extension module is imported from its source: the compiled modules call each other
directly, so one stale module makes all of them unsafe. `MILLBLOCKS_NATIVE=0` in the
environment asks for the sources too.

The check runs once, when the process starts: a server whose sources are updated under it
keeps what it started with until it is restarted (gunicorn's workers run it again).

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
GROUP = "native_group"  # the group's shared library: app/cnc/native_group__mypyc.*.so
ROOT = Path(__file__).resolve().parents[2]  # the directory holding `app`
BUILD_RECORD = ROOT / "app" / "cnc" / "native-build.json"
SWITCH = "MILLBLOCKS_NATIVE"


def source_path(module: str, root: Path = ROOT) -> Path:
    return root.joinpath(*module.split(".")).with_suffix(".py")


def digests(root: Path = ROOT) -> dict[str, str]:
    """Path (from `root`) → SHA-256 of every source of the core as it is now."""
    core = root / "app" / "cnc"
    return {
        path.relative_to(root).as_posix(): hashlib.sha256(path.read_bytes()).hexdigest()
        for path in sorted(core.rglob("*.py"))
    }


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


def compiled_file(module: str, root: Path = ROOT) -> Path | None:
    """The extension module built for `module` beside its source, if there is one."""
    return extension_files(root).get(module)


def stale(root: Path = ROOT) -> list[str]:
    """Why the compiled build must not be used, in words (empty: it is current, or
    nothing is built)."""
    built = extension_files(root)
    if not built:
        return []
    expected = (*COMPILED, f"app.cnc.{GROUP}__mypyc")
    reasons = [f"no extension module for {name}" for name in expected if name not in built]
    reasons += [f"{name} is built but no longer compiled" for name in built if name not in expected]
    try:
        sources = json.loads((root / BUILD_RECORD.relative_to(ROOT)).read_text())["sources"]
    except (OSError, ValueError, KeyError, TypeError):
        return [*reasons, "the build record is missing"]
    now = digests(root)
    changed = sorted({*sources, *now} - {k for k in now if sources.get(k) == now[k]})
    return reasons + [f"{path} changed" for path in changed]


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
    """Finds the listed modules' `.py` files, so that their extension modules are not used
    (a module with no source left, such as the group's library, is not found at all)."""

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


def guard() -> None:
    """Import the compiled modules from their sources when the build is stale or switched
    off. Must run before any of them is imported (app.cnc.__init__ calls it). A stale build
    is said on stderr once: the import still works, at the sources' speed.
    """
    if any(isinstance(finder, _SourceFirst) for finder in sys.meta_path):
        return
    off = os.environ.get(SWITCH, "") == "0"
    reasons = [] if off else stale()
    if not off and not reasons:
        return
    if reasons:
        more = f" and {len(reasons) - 2} more" if len(reasons) > 2 else ""
        print(
            "millblocks: the compiled G-code importer does not match the code "
            f"({'; '.join(reasons[:2])}{more}); importing its sources instead. "
            "`make native` rebuilds it.",
            file=sys.stderr,
        )
    modules = sorted({*COMPILED, *extension_files()})
    sys.meta_path.insert(0, _SourceFirst(modules, ROOT))
