"""The wheel's build: the package, the app's data folders mapped into it, and (behind a
switch) the hot modules of the G-code importer and the 1704 writer compiled with mypyc.

The repository keeps `templates/`, `static/` and `migrations/` at its top level; the wheel
carries them inside the package as `app/templates`, `app/static`, `app/migrations`, where
an installed MillBlocks finds them (`app.resources`).

`MILLBLOCKS_MYPYC=1` compiles the modules of `app.cnc.native.COMPILED` into C extension
modules of the wheel, as black and mypy ship theirs. It needs mypy and a C compiler in the
build environment, so build without isolation from the project's environment:

    MILLBLOCKS_MYPYC=1 .venv/bin/pip wheel --no-build-isolation --no-deps -w dist .

(`make wheel-native`). Without the switch the wheel is pure Python: the same code,
interpreted. Nothing is ever compiled into the working tree, and a build leaves nothing in it.
"""

from __future__ import annotations

import atexit
import importlib.util
import os
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Any

from setuptools import find_packages, setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent
# Everything a build writes (setuptools' build/ and mypyc's C sources) goes to a directory
# of its own, removed afterwards: nothing of a build is left in the checkout, and no file of
# an earlier build can find its way into a wheel.
BUILD = Path(tempfile.mkdtemp(prefix="millblocks-build-"))
atexit.register(shutil.rmtree, BUILD, True)
DATA = ("templates", "static", "migrations")  # app.resources.DATA


class BuildWithData(build_py):  # type: ignore[misc]
    """The package, then the app's data folders copied into it (data, not subpackages)."""

    def run(self) -> None:
        super().run()
        for name in DATA:
            shutil.copytree(
                HERE / name,
                Path(self.build_lib) / "app" / name,
                ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.so"),
                dirs_exist_ok=True,
            )


def compiled_modules() -> list[Any]:
    """The mypyc extension modules when MILLBLOCKS_MYPYC=1, else none."""
    if os.environ.get("MILLBLOCKS_MYPYC", "") != "1":
        return []
    try:
        from mypyc.build import mypycify
    except ImportError:
        sys.exit(
            "MILLBLOCKS_MYPYC=1 needs mypy in the build environment: build with "
            "`pip wheel --no-build-isolation` from an environment that has it (make wheel-native)"
        )
    # The module list, read from app/cnc/native.py without importing the package.
    spec = importlib.util.spec_from_file_location("_millblocks_native", HERE / "app/cnc/native.py")
    assert spec is not None and spec.loader is not None
    native = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(native)
    config = BUILD / "mypyc.ini"
    # mypyc type-checks what it compiles; the project's own mypy settings are for the checker.
    config.write_text("[mypy]\npython_version = 3.11\nignore_missing_imports = True\n")
    sources = [
        native.source_path(name, HERE).relative_to(HERE).as_posix() for name in native.COMPILED
    ]
    return list(
        mypycify(
            [f"--config-file={config}", *sources],
            opt_level="3",
            target_dir=str(BUILD / "mypyc"),
            group_name=f"app.cnc.{native.GROUP}",
        )
    )


setup(
    # app/demo holds the demo library's documents: data, a package so setuptools keeps it.
    packages=[*find_packages(include=["app", "app.*"]), "app.demo"],
    package_data={"app.demo": ["*.json"]},
    cmdclass={"build_py": BuildWithData},
    ext_modules=compiled_modules(),
    options={"build": {"build_base": str(BUILD)}},
)
