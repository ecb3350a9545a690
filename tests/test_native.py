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
from tests.test_import_dxf import bracket, bulge_part, metric_plate

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


SUFFIX = importlib.machinery.EXTENSION_SUFFIXES[0]
GROUP_LIBRARY = f"app/cnc/{native.GROUP}__mypyc{SUFFIX}"


def _tree(tmp_path: Path) -> Path:
    """A copy of the core's sources with a stand-in (empty) extension module for each
    compiled module and the group, and the record a build would have written: empty files
    that fail to load if anything imports them."""
    shutil.copytree(
        ROOT / "app",
        tmp_path / "app",
        ignore=shutil.ignore_patterns("*.so", "__pycache__", native.BUILD_RECORD.name),
    )
    for name in native.COMPILED:
        source = native.source_path(name, tmp_path)
        source.with_name(source.stem + SUFFIX).write_bytes(b"")
    (tmp_path / GROUP_LIBRARY).write_bytes(b"")
    record = {"sources": native.digests(tmp_path)}
    (tmp_path / "app" / "cnc" / native.BUILD_RECORD.name).write_text(json.dumps(record))
    return tmp_path


def _edit(path: Path) -> None:
    path.write_text(path.read_text() + "\n# edited\n")


def test_a_current_build_is_not_stale(tmp_path: Path) -> None:
    assert native.stale(_tree(tmp_path)) == []


def test_a_compiled_source_changed_after_the_build_is_found(tmp_path: Path) -> None:
    root = _tree(tmp_path)
    _edit(root / "app/cnc/imports/segment.py")
    assert native.stale(root) == ["app/cnc/imports/segment.py changed"]


def test_a_change_elsewhere_in_the_core_makes_the_build_stale(tmp_path: Path) -> None:
    """mypyc puts other modules' Final constants into the compiled code (NM_PER_INCH from
    units.py): a change there needs a new build as much as one in the group."""
    root = _tree(tmp_path)
    _edit(root / "app/cnc/units.py")
    (root / "app/cnc/new_module.py").write_text("")
    assert native.stale(root) == ["app/cnc/new_module.py changed", "app/cnc/units.py changed"]


def test_a_build_without_its_record_is_stale(tmp_path: Path) -> None:
    root = _tree(tmp_path)
    (root / "app" / "cnc" / native.BUILD_RECORD.name).unlink()
    assert native.stale(root) == ["the build record is missing"]


def test_an_incomplete_build_is_stale(tmp_path: Path) -> None:
    root = _tree(tmp_path)
    path = native.compiled_file("app.cnc.imports.steps", root)
    assert path is not None
    path.unlink()
    (root / GROUP_LIBRARY).unlink()
    assert native.stale(root) == [
        "no extension module for app.cnc.imports.steps",
        f"no extension module for app.cnc.{native.GROUP}__mypyc",
    ]


def test_a_module_built_but_no_longer_compiled_is_stale(tmp_path: Path) -> None:
    root = _tree(tmp_path)
    (root / f"app/cnc/imports/build{SUFFIX}").write_bytes(b"")
    assert native.stale(root) == ["app.cnc.imports.build is built but no longer compiled"]


def test_nothing_built_is_nothing_stale(tmp_path: Path) -> None:
    root = _tree(tmp_path)
    for path in native.extension_files(root).values():
        path.unlink()
    assert native.stale(root) == []


def test_a_stale_build_is_never_loaded(tmp_path: Path) -> None:
    """In a tree whose build is stale (units.py edited after it) every extension module —
    here empty files, which cannot load — is passed over for its source, an orphaned one
    too, and the import works and says why on stderr."""
    root = _tree(tmp_path)
    (root / f"app/cnc/imports/build{SUFFIX}").write_bytes(b"")
    (root / native.BUILD_RECORD.relative_to(ROOT)).write_text(
        json.dumps({"sources": native.digests(root)})
    )
    _edit(root / "app/cnc/units.py")
    script = (
        "from app.cnc import native\n"
        "from app.cnc.imports import read_program\n"
        "r = read_program(b'G21 G90\\nG0 X0 Y0 Z5\\nG1 Z-1 F100\\nG0 Z5\\nM30\\n', 'x')\n"
        "import app.cnc.imports.build as b\n"
        "print(len(r.program.blocks), b.__file__.endswith('.py'), native.status())\n"
    )
    env = {**os.environ, "PYTHONPATH": str(root)}
    env.pop(native.SWITCH, None)
    done = subprocess.run(
        [sys.executable, "-c", script], cwd=root, env=env, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    reasons = "app.cnc.imports.build is built but no longer compiled; app/cnc/units.py changed"
    assert f"does not match the code ({reasons})" in done.stderr
    blocks, from_source, status = done.stdout.split(" ", 2)
    assert int(blocks) >= 1 and from_source == "True"
    assert "compiled" not in status


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
    """Every G-code, tape, event and DXF file of the suite (the DXF reader builds on the
    compiled notes and recognition too): the goldens' exports of every block type, the
    seed samples, the drawings, the hostile uploads and a 20 000-line file of the benchmark's."""
    from bench.gcode_import import write_file

    exports = {".events", ".gcode-linuxcnc", ".gcode-fanuc", ".gcode-prototrak"}
    exports |= {".tape-ascii", ".tape-eia"}
    files = sorted(p for p in (HERE / "golden").glob("*/expected.*") if p.suffix in exports)
    samples = {".ngc", ".cnc", ".tape"}
    files += sorted(p for p in (HERE / "imports").iterdir() if p.suffix in samples)
    for drawing in (bracket, bulge_part, metric_plate):  # drawn with ezdxf by the DXF tests
        path = tmp_path / f"{drawing.__name__}.dxf"
        path.write_bytes(drawing())
        files.append(path)
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
