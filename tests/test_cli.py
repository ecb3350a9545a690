"""The `millblocks` command line, run as a user would (click's runner, real files)."""

from __future__ import annotations

import contextlib
import json
import os
import re
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from app.cli import main

ROOT = Path(__file__).resolve().parents[1]

GOLDEN = Path(__file__).parent / "golden"


def run(*args: str) -> tuple[int, str, str]:
    result = CliRunner().invoke(main, list(args))
    return result.exit_code, result.stdout, result.stderr


def test_check_valid_program() -> None:
    code, out, err = run("check", str(GOLDEN / "loop-rep-grid" / "program.json"))
    assert code == 0
    assert out.endswith("3 blocks, 0 errors, 0 warnings\n")
    assert err == ""


def test_export_canon_to_file_matches_golden(tmp_path: Path) -> None:
    out = tmp_path / "out.canon"
    code, _, _ = run(
        "export",
        str(GOLDEN / "bolt-circle-drill" / "program.json"),
        "--to",
        "canon",
        "-o",
        str(out),
    )
    assert code == 0
    assert out.read_text() == (GOLDEN / "bolt-circle-drill" / "expected.canon").read_text()


def test_export_json_carries_out_copy() -> None:
    code, out, _ = run("export", str(GOLDEN / "copy-offsets-abs" / "program.json"), "--to", "json")
    assert code == 0
    assert out == (GOLDEN / "copy-offsets-abs" / "expected.json").read_text()


def test_time_states_assumptions_and_total() -> None:
    code, out, _ = run("time", str(GOLDEN / "drill-single" / "program.json"))
    assert code == 0
    assert "rapids: straight lines at 250 ipm" in out
    assert out.endswith("Total 0:08.6\n")


def test_unreadable_file_exits_2(tmp_path: Path) -> None:
    code, _, err = run("check", str(tmp_path / "nope.json"))
    assert code == 2
    assert "nope.json: cannot read" in err


def test_bad_json_names_line_and_column(tmp_path: Path) -> None:
    path = tmp_path / "broken.json"
    path.write_text('{\n  "format": "millblocks-program",\n  "version": 1,,\n}\n')
    code, _, err = run("check", str(path))
    assert code == 2
    assert f"{path}: line 3, column 16: not valid JSON" in err


def test_errors_block_export(tmp_path: Path) -> None:
    program = (GOLDEN / "drill-single" / "program.json").read_text()
    path = tmp_path / "fast.json"
    path.write_text(program.replace('"feed_z": 5', '"feed_z": 300'))
    code, out, err = run("export", str(path), "--to", "canon")
    assert code == 1
    assert out == ""
    assert "block 1, FEEDR Z: 300 ipm is outside the allowed range 0.1 to 250 ipm" in err


def test_output_identical_across_processes(tmp_path: Path) -> None:
    """Same program, same options → byte-identical export for every target, in two
    processes with different hash seeds and time zones."""
    script = (
        "import sys; from pathlib import Path; from app.cnc import document; "
        "from app.cnc.formats.targets import export, targets; "
        "p = document.loads(Path(sys.argv[1]).read_text()); out = Path(sys.argv[2]); "
        "[(out / n).write_bytes(export(p, n).data) for n in targets()]"
    )
    program = GOLDEN / "coolant-and-messages" / "program.json"
    runs = []
    for seed, tz in (("1", "UTC"), ("12345", "America/Denver")):
        out = tmp_path / seed
        out.mkdir()
        env = {**os.environ, "PYTHONHASHSEED": seed, "TZ": tz}
        subprocess.run([sys.executable, "-c", script, str(program), str(out)], env=env, check=True)
        runs.append({f.name: f.read_bytes() for f in sorted(out.iterdir())})
    assert runs[0] == runs[1]
    assert len(runs[0]) >= 12 and all(runs[0].values())


def test_import_prints_the_id_and_export_by_id_or_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'lib.db'}")
    code, out, _ = run("import", str(GOLDEN / "drill-single" / "program.json"))
    assert code == 0
    new_id = out.strip()
    assert new_id.isdigit()
    by_id = run("export", new_id, "--to", "canon")
    by_name = run("export", "drill-single", "--to", "canon")
    expected = (GOLDEN / "drill-single" / "expected.canon").read_text()
    assert by_id[1] == by_name[1] == expected
    code, out, _ = run("list", "drill")
    assert "drill-single" in out
    code, _, err = run("export", "no such program", "--to", "canon")
    assert code == 2 and "no program named 'no such program'" in err


def test_backup_and_restore_commands(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'a.db'}")
    archive = tmp_path / "library.zip"
    code, out, _ = run("backup", str(archive))
    assert code == 0 and out.endswith("programs\n")
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'b.db'}")
    code, out, _ = run("restore", str(archive))
    assert code == 0 and "programs restored" in out


def test_history_diff_restore_commands(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'h.db'}")
    code, out, _ = run("import", str(GOLDEN / "drill-single" / "program.json"))
    program_id = out.strip()
    edited = tmp_path / "edited.json"
    edited.write_text(
        (GOLDEN / "drill-single" / "program.json")
        .read_text()
        .replace('"z_dn": -0.5', '"z_dn": -0.6')
    )
    from app.cnc import document
    from app.storage.library import open_library

    lib = open_library(seed_demo=False)
    lib.save(int(program_id), document.loads(edited.read_text()), based_on=1, author="ben")
    lib.engine.dispose()
    code, out, _ = run("history", program_id)
    assert code == 0 and "v2" in out and "ben" in out
    code, out, _ = run("diff", program_id, "1", "2")
    assert out.strip() == "block 1 DRILL: Z DN -0.5 → -0.6"
    code, out, _ = run("restore-version", program_id, "1")
    assert code == 0 and out.strip() == f"program {program_id}: version 1 restored as v3"


def test_import_reads_events_gcode_and_tape_with_a_report(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'lib.db'}")
    seed = Path(__file__).parent / "imports" / "seed003-2.2.5.cnc"
    code, out, err = run("import", str(seed))
    assert code == 0, err
    assert out.strip().isdigit()
    assert err.startswith("Import report (events):\n")
    code, out, _ = run("history", out.strip())
    assert "imported from seed003-2.2.5.cnc (events)" in out
    # The same file forced as G-code is refused, naming where, and nothing is saved.
    before = run("list")[1]
    code, out, err = run("import", str(seed), "--format", "gcode")
    assert code == 2 and out == ""
    assert re.search(r"seed003-2\.2\.5\.cnc: line \d+, column \d+: ", err), err
    assert run("list")[1] == before
    code, _, err = run("import", str(seed), "--option", "units")
    assert code == 2 and "--option 'units': not NAME=VALUE" in err


def test_every_file_command_takes_every_format(tmp_path: Path) -> None:
    """check/time/export read events, G-code and tapes too, detected or forced."""
    code, out, err = run(
        "export", str(GOLDEN / "drill-single" / "program.json"), "--to", "gcode-linuxcnc"
    )
    assert code == 0, err
    ngc = tmp_path / "part.ngc"
    ngc.write_text(out)
    code, out, err = run("check", str(ngc))
    assert code == 0, err
    assert err.startswith("Import report (gcode):\n")
    code, out, err = run("export", str(ngc), "--to", "events")
    assert code == 0 and out.startswith("%"), err
    code, out, err = run("time", "--format", "gcode", str(ngc))
    assert code == 0 and "total" in out.lower(), err
    code, out, err = run("check", "--format", "events", str(ngc))
    assert code == 2 and out == ""
    assert err.startswith(f"Error: {ngc}: ")


def test_json_export_writes_a_program_with_errors(tmp_path: Path) -> None:
    """The JSON document is the program: it is written errors and all (issue 29 point 6),
    the problems on stderr as warnings; every other target still refuses the program."""
    from app.cnc import document

    program = (GOLDEN / "drill-single" / "program.json").read_text()
    path = tmp_path / "fast.json"
    path.write_text(program.replace('"feed_z": 5', '"feed_z": 300'))
    out = tmp_path / "out.json"
    code, _, err = run("export", str(path), "--to", "json", "-o", str(out))
    assert code == 0, err
    assert document.loads(out.read_text()) == document.loads(path.read_text())
    assert "warning: block 1: error, written as it is" in err
    assert "FEEDR Z: 300 ipm is outside the allowed range 0.1 to 250 ipm" in err
    code, _, _ = run("export", str(path), "--to", "gcode-linuxcnc", "-o", str(tmp_path / "g"))
    assert code == 1 and not (tmp_path / "g").exists()


def test_an_events_import_with_errors_converts_to_json(tmp_path: Path) -> None:
    """A ProtoTRAK Plus events file whose tools have no RPM and whose frame is too small
    for its tool: refused by G-code, converted to the JSON document to be fixed."""
    from app.cnc import document
    from app.cnc.formats.reading import read_program

    source = Path(__file__).parent / "imports" / "seed003-2.2.5.cnc"
    out = tmp_path / "part.json"
    code, _, err = run("export", str(source), "--to", "json", "-o", str(out))
    assert code == 0, err
    assert "warning: block 37: error, written as it is" in err
    imported = read_program(source.read_bytes(), source.stem).program
    assert document.loads(out.read_text()) == imported
    code, _, err = run("export", str(source), "--to", "gcode-linuxcnc")
    assert code == 1 and "fix them before exporting" in err


def _modules_after(args: list[str], tmp_path: Path) -> set[str]:
    """The modules a whole `millblocks ARGS` process has imported when it exits."""
    return _process_after(args)[0]


def _process_after(args: list[str]) -> tuple[set[str], int]:
    """The modules a whole `millblocks ARGS` process has imported when it exits, and how
    many threads it runs then (Linux's /proc/self/task)."""
    _, modules, threads = whole_process(args)
    return modules, threads


def whole_process(args: list[str], env: dict[str, str] | None = None) -> tuple[str, set[str], int]:
    """A whole `millblocks ARGS` process (`env` added to this one's environment): its
    standard output, the modules it had imported when it exited and its threads then."""
    report = (
        "print(json.dumps([sorted(sys.modules), len(os.listdir('/proc/self/task'))]), "
        "file=sys.stderr)"
    )
    script = (
        "import atexit, json, os, sys\n"
        f"atexit.register(lambda: {report})\n"
        "from app.cli import main\n"
        f"main({args!r})\n"
    )
    # The process's environment as a shell gives it: no thread setting inherited from this
    # test process.
    environment = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    done = subprocess.run(
        [sys.executable, "-c", script],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
        env=environment | (env or {}),
    )
    assert done.returncode == 0, done.stderr
    modules, threads = json.loads(done.stderr.strip().splitlines()[-1])
    return done.stdout, set(modules), threads


HEAVY = {"sqlalchemy", "alembic", "ezdxf", "flask", "numpy", "serial"}


def test_help_imports_nothing_it_does_not_need(tmp_path: Path) -> None:
    """Before: `millblocks --help` took 3-6 s and 94 MB, importing every format, ezdxf,
    SQLAlchemy and Alembic to print the help. Now it loads click and the command list."""
    loaded = _modules_after(["--help"], tmp_path)
    assert not HEAVY & {name.split(".")[0] for name in loaded}
    assert not [name for name in loaded if name.startswith(("app.cnc.formats", "app.storage"))]


def test_exporting_a_file_loads_no_database_or_drawing_code(tmp_path: Path) -> None:
    """A file's export needs the core and its target, not the library or ezdxf."""
    out = tmp_path / "out.ngc"
    program = ROOT / "app" / "demo" / "03-frame-pocket.json"
    loaded = _modules_after(
        ["export", str(program), "--to", "gcode-linuxcnc", "-o", str(out)], tmp_path
    )
    assert out.read_text().startswith("%")
    tops = {name.split(".")[0] for name in loaded}
    assert not {"sqlalchemy", "alembic", "ezdxf", "flask", "serial"} & tops
    assert "app.storage" not in loaded


# Every format's reader and writer module, and the libraries only some of them need.
FORMAT_MODULES = {
    "app.cnc.formats.canon",
    "app.cnc.formats.svg",
    "app.cnc.formats.document.writer",
    "app.cnc.formats.dxf.blocks",
    "app.cnc.formats.dxf.reader",
    "app.cnc.formats.events.reader",
    "app.cnc.formats.events.writer",
    "app.cnc.formats.gcode.boss",
    "app.cnc.formats.gcode.reader",
    "app.cnc.formats.gcode.writer",
    "app.cnc.formats.tape1704.picture",
    "app.cnc.formats.tape1704.reader",
    "app.cnc.formats.tape1704.targets",
}
FORMAT_LIBRARIES = {"ezdxf", "svgwrite", "sqlalchemy", "alembic", "flask", "serial"}


def test_a_small_export_loads_its_own_format_alone(tmp_path: Path) -> None:
    """Before: the export of one small program imported every format's reader and writer
    (and svgwrite), 0.35 s of CPU before the first byte, 561 ms over a bare Python start as
    an installed command (issue 31). Now a program file read as JSON and written as
    LinuxCNC G-code loads that one writer; detection still asks every format's sniff. Its
    FRAME pocket is no irregular POCKET: the pocket engine and pyclipper stay unloaded."""
    out = tmp_path / "out.ngc"
    program = ROOT / "app" / "demo" / "03-frame-pocket.json"
    loaded = _modules_after(
        ["export", str(program), "--to", "gcode-linuxcnc", "-o", str(out)], tmp_path
    )
    assert out.read_text().startswith("%")
    assert FORMAT_MODULES & loaded == {"app.cnc.formats.gcode.writer"}
    assert not FORMAT_LIBRARIES & {name.split(".")[0] for name in loaded}
    assert "pyclipper" not in loaded and "app.cnc.pocketing.plan" not in loaded


def test_a_small_export_starts_nothing_it_does_not_use(tmp_path: Path) -> None:
    """Before: the export of a small program cost 0.28-0.31 s of CPU over a bare Python
    start (issue 31.3). Of that, about 60 ms were OpenBLAS starting a thread per core
    that no command line work uses (nothing in MillBlocks multiplies matrices), about
    20 ms numpy.ma, which `np.unique` imports to ask whether its argument is masked (and
    numpy.ma then reads the signatures of numpy's functions), 6 ms the ENGRAVE font
    package, and the simulation's stock and segments and the THREAD MILL and ENGRAVE
    modules, all loaded by validation for a program without STOCK, THREAD MILL or
    ENGRAVE; tempfile, for a spool an export to OUT does not use. The export now runs
    in one thread and loads none of them."""
    out = tmp_path / "out.ngc"
    program = ROOT / "app" / "demo" / "03-frame-pocket.json"
    loaded, threads = _process_after(
        ["export", str(program), "--to", "gcode-linuxcnc", "-o", str(out)]
    )
    assert out.read_text().startswith("%")
    assert threads == 1
    assert "numpy" in loaded
    assert not {"numpy.ma", "HersheyFonts", "tempfile"} & loaded
    assert not [name for name in loaded if name.startswith(OPERATION_MODULES)]


# What a program without STOCK, THREAD MILL or ENGRAVE does not use: the simulation's
# stock and segments, and the operations' own modules (the kinds name them as text).
OPERATION_MODULES = ("app.cnc.simulate", "app.cnc.operations")


def test_converting_gcode_to_a_tape_loads_the_two_formats_alone(tmp_path: Path) -> None:
    """A G-code file made into a 1704 tape: the G-code reader and the tape writer, not the
    tape's picture (svgwrite), the DXF, events or other G-code writers."""
    source = tmp_path / "part.ngc"
    code, _, err = run(
        "export",
        str(ROOT / "app" / "demo" / "03-frame-pocket.json"),
        "--to",
        "gcode-linuxcnc",
        "-o",
        str(source),
    )
    assert code == 0, err
    tape = tmp_path / "part.tape"
    loaded = _modules_after(["export", str(source), "--to", "tape-eia", "-o", str(tape)], tmp_path)
    assert tape.read_bytes().startswith(b"%")
    assert FORMAT_MODULES & loaded == {
        "app.cnc.formats.gcode.reader",
        "app.cnc.formats.tape1704.targets",
    }
    assert not FORMAT_LIBRARIES & {name.split(".")[0] for name in loaded}


def test_a_target_missing_from_the_table_is_refused() -> None:
    """`get_target` finds a target through app.cnc.formats.TARGET_MODULES alone, so a
    target that the table does not name (it would be missing from an export's choices
    until something imported every format) is refused when it is defined."""
    from app.cnc.formats.targets import Target, register, targets

    class Unlisted(Target):
        name = "unlisted"
        description = "a target no table names"
        extension = "txt"

    with pytest.raises(ValueError, match=r"target unlisted is defined in tests\.test_cli"):
        register(Unlisted)
    assert "unlisted" not in targets()


def test_the_benchmark_files_stay_inside_the_travel_at_any_size() -> None:
    """Before: bench/cli.py's 10^6-line G-code file ran to Y 890 in (its grid of cells only
    grew), past the ±99.999 in an import allows, so that row timed a refusal. Its grid now
    repeats: every X and Y, with the file's G54 offset (X1 Y1), stays inside."""
    from bench.gcode_import import gcode_text

    text = gcode_text(1_000_000)
    assert len(text.splitlines()) == 1_000_000
    assert "G10 L2 P1 X1.0000 Y1.0000 Z0" in text
    largest = max(float(value) for value in re.findall(r"[XY](-?\d+\.\d+)", text))
    assert 1.0 + largest <= 99.999


def _damaged(path: Path, how: str) -> None:
    """A library file damaged `how`: "header" (not a database at all) or "pages" (its
    header is whole, its first page is not: SQLite's "disk image is malformed")."""
    if how == "header":
        path.write_bytes(bytes(range(256)) * 32)
        return
    with contextlib.closing(sqlite3.connect(path)) as database, database:
        database.execute("CREATE TABLE notes (text TEXT)")
        database.executemany("INSERT INTO notes VALUES (?)", [("x" * 500,)] * 100)
    data = bytearray(path.read_bytes())
    data[100:4096] = b"\xa5" * 3996  # the schema table's page, after the 100-byte header
    path.write_bytes(bytes(data))


@pytest.mark.parametrize(
    ("how", "said"),
    [("header", "file is not a database"), ("pages", "database disk image is malformed")],
)
@pytest.mark.parametrize("command", [["db", "upgrade"], ["db", "current"], ["list"]])
def test_a_damaged_sqlite_file_is_named_with_what_to_do(
    command: list[str], how: str, said: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The audit of issue 31: `db upgrade` and `db current` ended in a traceback from the
    driver. Now exit 2, naming the file, SQLite's words and the way back (a backup)."""
    path = tmp_path / "library.db"
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{path}")
    _damaged(path, how)
    result = CliRunner().invoke(main, command)
    assert result.exit_code == 2, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit)
    assert result.stderr.startswith(
        f"Error: {path}: the database file is damaged (SQLite: {said}). Stop MillBlocks, "
        "move the file aside and restore from a backup"
    )
    assert "millblocks restore ARCHIVE" in result.stderr


def test_a_send_the_target_refuses_says_why(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The audit of issue 31: `millblocks send` said only "events cannot take this
    program"; now the reason (the Plus's line numbers run to 999), before any port."""
    from decimal import Decimal

    from app.cnc.blocks import Rep
    from app.storage.library import Machine, open_library
    from tests.test_events import loop

    url = f"sqlite:///{tmp_path / 'send.db'}"
    monkeypatch.setenv("DATABASE_URL", url)
    library = open_library(url, seed_demo=False)
    program = library.create(loop(Rep(x=Decimal(5), y=Decimal("0.15"), nx=1, ny=600)))
    library.save_machine(Machine("Plus", "events", {}, {"port": str(tmp_path / "no-port")}))
    library.engine.dispose()
    result = CliRunner().invoke(main, ["send", str(program.id), "--machine", "Plus"])
    assert result.exit_code == 1, result.output
    assert result.stderr == (
        "Error: events cannot take this program (program: 1203 events: line numbers run to "
        "999 (seed 003 §2.2.4))\n"
    )
