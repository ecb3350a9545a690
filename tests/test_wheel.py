"""The package a shop installs: the wheel, in a fresh virtual environment outside the
checkout, serves the app; and its compiled G-code importer reads every file as the sources do.

The wheel is built once per run the way `make wheel-native` builds it (setup.py with
MILLBLOCKS_MYPYC=1: the importer compiled by mypyc, ~2 min of gcc) and installed with its
dependencies (constraints.txt) into a new virtual environment in a temporary directory.
Every command runs from another temporary directory, so nothing of the checkout is on its
path: what answers is what site-packages holds.
"""

from __future__ import annotations

import importlib.machinery
import json
import os
import shutil
import socket
import subprocess
import sys
import time
import urllib.request
import zipfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from app.cnc import native
from app.resources import DATA
from tests.hostile_corpus import UPLOADS
from tests.test_import_dxf import bracket, bulge_part, metric_plate

ROOT = Path(__file__).resolve().parents[1]
HERE = Path(__file__).parent


@dataclass(frozen=True)
class Installed:
    """A fresh virtual environment with the wheel installed, and a directory to run in."""

    venv: Path
    wheel: Path
    workdir: Path

    def command(self, name: str) -> str:
        return str(self.venv / "bin" / name)

    def env(self, **extra: str) -> dict[str, str]:
        env = {k: v for k, v in os.environ.items() if not k.startswith(("MILLBLOCKS_", "PYTHON"))}
        env.pop("DATABASE_URL", None)
        env["MILLBLOCKS_INSTANCE_PATH"] = str(self.workdir / "instance")
        return {**env, **extra}

    def run(self, *args: str, **extra: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            args,
            cwd=self.workdir,
            env=self.env(**extra),
            capture_output=True,
            text=True,
            timeout=600,
            check=False,
        )


def _build_wheel(out: Path, compiled: bool, source: Path = ROOT) -> Path:
    env = {**os.environ, "MILLBLOCKS_MYPYC": "1" if compiled else "0"}
    command = [sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "-w", str(out)]
    if compiled:
        command.append("--no-build-isolation")  # mypy (mypyc) from the project's environment
    done = subprocess.run(
        [*command, str(source)], env=env, capture_output=True, text=True, timeout=1200, check=False
    )
    assert done.returncode == 0, done.stdout + done.stderr
    (wheel,) = out.glob("millblocks-*.whl")
    return wheel


@pytest.fixture(scope="session")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Installed:
    base = tmp_path_factory.mktemp("wheel")
    wheel = _build_wheel(base / "dist", compiled=True)
    venv = base / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=300)
    pip = [str(venv / "bin" / "python"), "-m", "pip", "install", "--quiet"]
    done = subprocess.run(
        [*pip, "-c", str(ROOT / "constraints.txt"), str(wheel)],
        capture_output=True,
        text=True,
        timeout=900,
        check=False,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    workdir = base / "elsewhere"
    workdir.mkdir()
    return Installed(venv, wheel, workdir)


def _data_files() -> set[str]:
    """Every file of the app's data folders, as the wheel names it (app/<folder>/...)."""
    found = set()
    for name in DATA:
        for path in (ROOT / name).rglob("*"):
            if path.is_file() and "__pycache__" not in path.parts:
                found.add(f"app/{path.relative_to(ROOT).as_posix()}")
    return found


def test_the_pure_wheel_carries_templates_static_and_migrations(tmp_path: Path) -> None:
    """Before: `pip wheel .` gave a wheel without templates/, static/ or migrations/, so an
    installed MillBlocks failed at `db upgrade` (alembic: Path doesn't exist). The default
    wheel (no switch) is pure Python: no compiled module in it."""
    wheel = _build_wheel(tmp_path, compiled=False)
    names = set(zipfile.ZipFile(wheel).namelist())
    assert _data_files() <= names
    assert "app/demo/01-prototrak-plus-sample.json" in names
    assert any(n.endswith("licenses/LICENSE") for n in names)
    assert not [n for n in names if n.endswith(".so") or "__pycache__" in n]


def test_the_native_wheel_compiles_the_importer(installed: Installed) -> None:
    names = set(zipfile.ZipFile(installed.wheel).namelist())
    assert _data_files() <= names
    for module in native.COMPILED:
        stem = module.replace(".", "/")
        assert any(n.startswith(stem + ".") and n.endswith(".so") for n in names), module


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture()
def served(installed: Installed) -> Iterator[str]:
    """`millblocks db upgrade` then `millblocks serve` from the installed wheel."""
    upgraded = installed.run(installed.command("millblocks"), "db", "upgrade")
    assert upgraded.returncode == 0, upgraded.stderr
    port = _free_port()
    log = installed.workdir / "serve.log"
    with log.open("w") as errors:
        server = subprocess.Popen(
            [installed.command("millblocks"), "serve", "--port", str(port), "--workers", "1"],
            cwd=installed.workdir,
            env=installed.env(),
            stdout=subprocess.DEVNULL,
            stderr=errors,
        )
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                urllib.request.urlopen(url + "/", timeout=5).close()
                break
            except OSError:
                assert server.poll() is None, log.read_text()
                assert time.monotonic() < deadline, "the installed server did not answer"
                time.sleep(0.2)
        yield url
    finally:
        server.terminate()
        server.wait(timeout=30)


def test_an_installed_wheel_serves_the_app(served: str, installed: Installed) -> None:
    """From site-packages alone: the library page with the demo programs, a static file,
    an editor page (templates, static files and the migrated database all found)."""
    with urllib.request.urlopen(served + "/", timeout=30) as page:
        html = page.read().decode()
    assert "<title>Library · MillBlocks" in html
    assert "PROTOTRAK PLUS SAMPLE" in html.upper()
    with urllib.request.urlopen(served + "/static/app.js", timeout=30) as script:
        assert script.status == 200 and b"htmx" in script.read()
    with urllib.request.urlopen(served + "/programs/1", timeout=30) as editor:
        assert editor.status == 200 and "Data Block 0" in editor.read().decode()
    assert (installed.workdir / "instance" / "millblocks.db").is_file()
    assert not list(installed.venv.glob("lib/python*/site-packages/instance"))


def _version(wheel: Path) -> str:
    return wheel.name.split("-")[1]


def test_the_installed_command_line_says_its_wheels_version(installed: Installed) -> None:
    shown = installed.run(installed.command("millblocks"), "--version")
    assert shown.returncode == 0, shown.stderr
    assert shown.stdout.split()[-1] == _version(installed.wheel)


def test_a_later_commits_wheel_upgrades_and_the_earlier_rolls_back(tmp_path: Path) -> None:
    """docs/deploy.md's upgrade is `pip install millblocks-NEW.whl`, its rollback `pip
    install millblocks-OLD.whl`. Failed before: every wheel was 0.1.0, so pip said "already
    installed with the same version" and kept the old code (the new database schema then met
    old code, or a rollback left the new code in place). The version now comes from git."""
    from packaging.version import Version

    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "--quiet", str(ROOT), str(clone)], check=True, timeout=300)
    older = _build_wheel(tmp_path / "older", compiled=False, source=clone)
    who = ["-c", "user.name=MillBlocks tests", "-c", "user.email=tests@millblocks.invalid"]
    subprocess.run(
        ["git", *who, "commit", "--quiet", "--allow-empty", "-m", "a later change"],
        cwd=clone,
        check=True,
        timeout=60,
    )
    newer = _build_wheel(tmp_path / "newer", compiled=False, source=clone)
    assert Version(_version(newer)) > Version(_version(older)) > Version("0.1.0")

    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=300)
    python = str(venv / "bin" / "python")

    def install(wheel: Path) -> str:
        # --no-deps: what is at stake is whether pip replaces the package, not its deps.
        subprocess.run(
            [python, "-m", "pip", "install", "--quiet", "--no-deps", str(wheel)],
            check=True,
            timeout=300,
        )
        ask = "import importlib.metadata as m; print(m.version('millblocks'))"
        # Asked from outside the checkout, whose editable install's metadata is in it.
        return subprocess.run(
            [python, "-c", ask], cwd=venv, capture_output=True, text=True, check=True, timeout=60
        ).stdout.strip()

    assert install(older) == _version(older)
    assert install(newer) == _version(newer)  # the upgrade
    assert install(older) == _version(older)  # the rollback


def test_the_installed_command_line_exports_as_the_checkout_does(installed: Installed) -> None:
    """The same bytes from the installed (compiled) package as from the checkout's sources."""
    program = ROOT / "app" / "demo" / "03-frame-pocket.json"
    for target in ("gcode-linuxcnc", "tape-eia", "events"):
        ours = installed.run(
            installed.command("millblocks"), "export", str(program), "--to", target
        )
        assert ours.returncode == 0, ours.stderr
        checkout = subprocess.run(
            [sys.executable, "-m", "app.cli", "export", str(program), "--to", target],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        )
        assert ours.stdout == checkout.stdout, target


def _import_files(tmp_path: Path) -> list[Path]:
    """Every G-code, tape, event and DXF file of the suite (the DXF reader builds on the
    compiled notes and recognition too): the goldens' exports of every block type, the
    seed samples, the G-code corpus, the drawings, the hostile uploads and a 20 000-line
    file of the bench's."""
    from bench.gcode_import import write_file

    exports = {".events", ".gcode-linuxcnc", ".gcode-fanuc", ".gcode-prototrak"}
    exports |= {".tape-ascii", ".tape-eia"}
    files = sorted(p for p in (HERE / "golden").glob("*/expected.*") if p.suffix in exports)
    samples = {".ngc", ".cnc", ".tape"}
    files += sorted(p for p in (HERE / "imports").iterdir() if p.suffix in samples)
    # the G-code corpus: post output, and LinuxCNC's subroutines, loops and expressions
    # (the compiled reader hands those to the front end, app/cnc/formats/gcode/ngc.py)
    corpus = (HERE / "imports" / "gcode-corpus").rglob("*")
    files += sorted(p for p in corpus if p.suffix in (".ngc", ".nc", ".gcode"))
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


def _probe(installed: Installed, files: list[Path], switch: str | None) -> list[dict[str, object]]:
    extra = {} if switch is None else {native.SWITCH: switch}
    done = installed.run(
        installed.command("python"), str(HERE / "native_probe.py"), *map(str, files), **extra
    )
    assert done.returncode == 0, done.stderr
    return [json.loads(line) for line in done.stdout.splitlines()]


def test_compiled_and_sources_import_alike(installed: Installed, tmp_path: Path) -> None:
    """The installed wheel runs its importer and 1704 writer compiled, and gives the same
    programs, reports, tapes and errors as the same wheel's sources (MILLBLOCKS_NATIVE=0),
    file by file: every imported program written as a tape, every golden program written
    to each tape target and LinuxCNC G-code. The build changes the speed, nothing a user
    sees."""
    files = _import_files(tmp_path)
    assert len(files) > 80
    programs = sorted((HERE / "golden").glob("*/program.json"))
    assert len(programs) > 60
    arguments = [*files, Path("--export"), *programs]
    compiled = _probe(installed, arguments, None)
    sources = _probe(installed, arguments, "0")
    assert compiled[-1] == {"native": dict.fromkeys(native.COMPILED, "compiled")}
    assert sources[-1] == {"native": dict.fromkeys(native.COMPILED, "source")}
    assert len(compiled) == len(sources) > len(files) + 5 * len(programs)
    for ours, theirs in zip(compiled[:-1], sources[:-1], strict=True):
        assert ours == theirs, ours["file"]
    assert sum("program" in outcome for outcome in compiled) > 80
    tapes = [o["tape-eia"] for o in compiled if "tape-eia" in o]
    assert sum("data" in tape for tape in tapes) > 100  # type: ignore[operator]


def test_a_checkout_never_loads_extension_modules(tmp_path: Path) -> None:
    """Nothing is compiled into a checkout; an extension module left there by an older
    build (here empty files, which cannot load) is passed over for its source."""
    shutil.copytree(
        ROOT / "app", tmp_path / "app", ignore=shutil.ignore_patterns("*.so", "__pycache__")
    )
    (tmp_path / "templates").mkdir()
    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
    stale = ("app.cnc.formats.gcode.ngc", f"app.cnc.{native.GROUP}__mypyc")  # not in COMPILED
    for name in (*native.COMPILED, *stale):
        source = native.source_path(name, tmp_path)
        source.with_name(source.stem + suffix).write_bytes(b"")
    script = (
        "from app.cnc import native\n"
        "from app.cnc.formats.reading import read_program\n"
        "r = read_program(b'G21 G90\\nG0 X0 Y0 Z5\\nG1 Z-1 F100\\nG0 Z5\\nM30\\n', 'x')\n"
        "import app.cnc.formats.gcode.ngc as b\n"
        "print(len(r.program.blocks), b.__file__.endswith('.py'), native.status())\n"
    )
    env = {k: v for k, v in os.environ.items() if k != native.SWITCH}
    env["PYTHONPATH"] = str(tmp_path)
    done = subprocess.run(
        [sys.executable, "-c", script], cwd=tmp_path, env=env, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    blocks, from_source, status = done.stdout.split(" ", 2)
    assert int(blocks) >= 1 and from_source == "True"
    assert "compiled" not in status


def test_the_compiled_modules_written_inits_take_their_fields() -> None:
    """A dataclass of a compiled module that writes its `__init__` out (so that mypyc
    compiles it: app.cnc.recognition.steps) takes the fields the generated one would, in
    their order with their defaults, and sets each from its parameter; a field made by a
    default factory starts as a new one. A field added to the class and not to its
    `__init__` fails here, not as a missing attribute in a compiled import."""
    import dataclasses
    import importlib
    import inspect

    written = []
    for name in native.COMPILED:
        module = importlib.import_module(name)
        for cls in vars(module).values():
            if not (
                isinstance(cls, type)
                and cls.__module__ == name
                and dataclasses.is_dataclass(cls)
                and not cls.__dataclass_params__.init  # type: ignore[attr-defined]
            ):
                continue
            written.append(cls.__qualname__)
            fields = dataclasses.fields(cls)
            taken = [f for f in fields if f.default_factory is dataclasses.MISSING]
            parameters = list(inspect.signature(cls.__init__).parameters.values())[1:]
            assert [p.name for p in parameters] == [f.name for f in taken], cls
            for parameter, field in zip(parameters, taken, strict=True):
                default = (
                    inspect.Parameter.empty
                    if field.default is dataclasses.MISSING
                    else field.default
                )
                assert parameter.default == default, (cls, field.name)
            given = {f.name: object() for f in taken}
            made = cls(**given)
            for field in fields:
                factory = field.default_factory
                expected = factory() if callable(factory) else given[field.name]
                assert getattr(made, field.name) == expected, (cls, field.name)
    assert {"Rapid", "Feed", "Arc", "Cycle", "Element", "HoleOpR", "MillOp", "Block"} <= set(
        written
    )
