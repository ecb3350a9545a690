"""The compiled G-code importer (app.cnc.native): in use, current, and the same as its
sources.

`make test` builds it first (scripts/build-native), so these tests run against the code a
user runs: they fail when the build is missing or older than the sources, and compare its
results with the sources' on every import file the suite has.
"""

from __future__ import annotations

import importlib.machinery
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from app.cnc import native
from tests.hostile_corpus import UPLOADS

ROOT = Path(__file__).resolve().parents[1]
HERE = Path(__file__).parent


def test_the_importer_runs_compiled() -> None:
    """Every module of the group is its extension module, built from the sources as they
    are now (otherwise: `make native`)."""
    if os.environ.get(native.SWITCH) == "0":
        pytest.skip("MILLBLOCKS_NATIVE=0: the sources were asked for")
    for name in native.COMPILED:
        __import__(name)
    assert native.stale() == []
    assert native.status() == dict.fromkeys(native.COMPILED, "compiled")


def _tree(tmp_path: Path) -> Path:
    """A copy of the group's sources with a stand-in extension module for each."""
    for name in native.COMPILED:
        source = native.source_path(name, tmp_path)
        source.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(native.source_path(name), source)
        suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
        source.with_name(source.stem + suffix).write_bytes(b"")
    record = {"sources": native.digests(native.COMPILED, tmp_path)}
    (tmp_path / "app" / "cnc" / native.BUILD_RECORD.name).write_text(json.dumps(record))
    return tmp_path


def test_a_source_changed_after_the_build_is_found(tmp_path: Path) -> None:
    root = _tree(tmp_path)
    assert native.stale(native.COMPILED, root) == []
    changed = native.source_path("app.cnc.imports.segment", root)
    changed.write_text(changed.read_text() + "\n# edited\n")
    assert native.stale(native.COMPILED, root) == ["app.cnc.imports.segment"]


def test_a_build_without_its_record_is_stale_throughout(tmp_path: Path) -> None:
    root = _tree(tmp_path)
    (root / "app" / "cnc" / native.BUILD_RECORD.name).unlink()
    assert native.stale(native.COMPILED, root) == list(native.COMPILED)


def test_nothing_built_is_nothing_stale(tmp_path: Path) -> None:
    root = _tree(tmp_path)
    for name in native.COMPILED:
        path = native.compiled_file(name, root)
        assert path is not None
        path.unlink()
    assert native.stale(native.COMPILED, root) == []


def _probe(files: list[Path], switch: str | None) -> list[dict[str, object]]:
    env = {k: v for k, v in os.environ.items() if k != native.SWITCH}
    if switch is not None:
        env[native.SWITCH] = switch
    done = subprocess.run(
        [sys.executable, "-m", "tests.native_probe", *map(str, files)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
        check=True,
    )
    assert "older than its sources" not in done.stderr
    return [json.loads(line) for line in done.stdout.splitlines()]


def _import_files(tmp_path: Path) -> list[Path]:
    """Every G-code and tape file of the suite: the goldens' exports of every block type,
    the seed samples, the hostile uploads and a 20 000-line file of the benchmark's."""
    from bench.gcode_import import write_file

    exports = {".events", ".gcode-linuxcnc", ".gcode-fanuc", ".gcode-prototrak"}
    exports |= {".tape-ascii", ".tape-eia"}
    files = sorted(p for p in (HERE / "golden").glob("*/expected.*") if p.suffix in exports)
    samples = {".ngc", ".cnc", ".tape"}
    files += sorted(p for p in (HERE / "imports").iterdir() if p.suffix in samples)
    files.append(write_file(tmp_path, 20_000))
    for name, data, _message in UPLOADS:  # hostile files: the same errors, too
        if name.endswith((".ngc", ".cnc", ".tape")):
            (tmp_path / name).write_bytes(data)
            files.append(tmp_path / name)
    return files


def test_compiled_and_sources_import_alike(tmp_path: Path) -> None:
    """The same programs, reports and errors from the compiled importer as from its
    sources, file by file: the build changes the speed, nothing a user sees."""
    files = _import_files(tmp_path)
    assert len(files) > 80
    compiled = _probe(files, None)
    sources = _probe(files, "0")
    assert sources[-1] == {"native": dict.fromkeys(native.COMPILED, "source")}
    if os.environ.get(native.SWITCH) != "0":
        assert compiled[-1] == {"native": dict.fromkeys(native.COMPILED, "compiled")}
    assert len(compiled) == len(sources) > len(files)
    for ours, theirs in zip(compiled[:-1], sources[:-1], strict=True):
        assert ours == theirs, ours["file"]
    assert sum("program" in outcome for outcome in compiled) > 80
