"""Restoring a backup is all or nothing (issue 17, defect 7): a damaged archive changes
nothing and is refused with a message (CLI: exit 2), never a traceback, and an archive is
never decompressed past stated limits."""

from __future__ import annotations

import io
import json
import zipfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from app.cli import main
from app.cnc import document
from app.storage.library import Library, LibraryError, Machine, open_library

GOLDEN = Path(__file__).parent / "golden"


@pytest.fixture
def library(database_url: str) -> Iterator[Library]:
    lib = open_library(database_url, seed_demo=False)
    yield lib
    lib.engine.dispose()


def good_backup() -> bytes:
    """A real backup: two programs (one with two revisions) and a machine."""
    source = open_library("sqlite://", seed_demo=False)
    first = document.loads((GOLDEN / "drill-single" / "program.json").read_text())
    info = source.create(first, author="ana")
    source.save(info.id, first, based_on=1, author="ana")
    source.create(document.loads((GOLDEN / "loop-rep-grid" / "program.json").read_text()))
    source.save_machine(Machine("Bridgeport", "gcode-linuxcnc", {}, {"port": ""}))
    out = io.BytesIO()
    source.backup(out)
    source.engine.dispose()
    return out.getvalue()


def rezip(archive: bytes, change: Callable[[dict[str, Any], dict[str, bytes]], None]) -> bytes:
    """The archive with its manifest (parsed) and members changed by `change`."""
    with zipfile.ZipFile(io.BytesIO(archive)) as source:
        members = {name: source.read(name) for name in source.namelist()}
    manifest = json.loads(members.pop("manifest.json"))
    change(manifest, members)
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as target:
        target.writestr("manifest.json", json.dumps(manifest))
        for name, data in members.items():
            target.writestr(name, data)
    return out.getvalue()


def state(library: Library) -> tuple[int, list[str]]:
    return len(library.programs(trash=False)), [m.name for m in library.machines()]


def bad_machine(manifest: dict[str, Any], _members: dict[str, bytes]) -> None:
    manifest["machines"].append({"name": "Broken"})  # no target, options, serial


def no_revisions(manifest: dict[str, Any], _members: dict[str, bytes]) -> None:
    manifest["programs"][1]["revisions"] = []


def not_utf8(manifest: dict[str, Any], members: dict[str, bytes]) -> None:
    members[manifest["programs"][1]["revisions"][0]["file"]] = b"\xff\xfe{"


def duplicate_version(manifest: dict[str, Any], _members: dict[str, bytes]) -> None:
    revisions = manifest["programs"][0]["revisions"]
    revisions[1]["version"] = revisions[0]["version"]


def bad_date(manifest: dict[str, Any], _members: dict[str, bytes]) -> None:
    manifest["programs"][0]["revisions"][0]["created_at"] = "yesterday"


def programs_not_a_list(manifest: dict[str, Any], _members: dict[str, bytes]) -> None:
    manifest["programs"] = {"0": 1}


def missing_file(manifest: dict[str, Any], members: dict[str, bytes]) -> None:
    del members[manifest["programs"][0]["revisions"][0]["file"]]


def bad_program(manifest: dict[str, Any], members: dict[str, bytes]) -> None:
    members[manifest["programs"][1]["revisions"][0]["file"]] = b'{"format": "x"}'


def machine_options_not_text(manifest: dict[str, Any], _members: dict[str, bytes]) -> None:
    manifest["machines"][0]["options"] = {"sequence-start": {"deep": [1]}}


def version_not_a_number(manifest: dict[str, Any], _members: dict[str, bytes]) -> None:
    manifest["programs"][0]["revisions"][0]["version"] = "1"


DAMAGE = {
    "a malformed machine after the programs": (bad_machine, "machine 2"),
    "a program without revisions": (no_revisions, "program 2"),
    "a revision that is not UTF-8": (not_utf8, "not UTF-8"),
    "two revisions with one version": (duplicate_version, "version"),
    "a date that is not a date": (bad_date, "created_at"),
    "programs that are not a list": (programs_not_a_list, "programs"),
    "a revision file missing": (missing_file, "missing"),
    "a revision that is no program": (bad_program, "format"),
    "machine options that are not text": (machine_options_not_text, "options"),
    "a version that is not a number": (version_not_a_number, "version"),
}


@pytest.mark.parametrize("damage", DAMAGE, ids=list(DAMAGE))
def test_a_damaged_backup_changes_nothing(library: Library, damage: str) -> None:
    change, named = DAMAGE[damage]
    library.save_machine(Machine("Existing", "events", {}, {}))
    before = state(library)
    with pytest.raises(LibraryError) as caught:
        library.restore_backup(io.BytesIO(rezip(good_backup(), change)))
    assert named in str(caught.value)
    assert state(library) == before


def test_a_good_backup_restores_programs_revisions_and_machines(library: Library) -> None:
    assert library.restore_backup(io.BytesIO(good_backup())) == 2
    programs = library.programs()
    assert len(programs) == 2
    assert [r.version for r in library.revisions(programs[0].id)] in ([1, 2], [1])
    assert [m.name for m in library.machines()] == ["Bridgeport"]


def bomb(manifest_bytes: int) -> bytes:
    """A small zip whose manifest decompresses to `manifest_bytes` of spaces."""
    out = io.BytesIO()
    chunk = b" " * (1 << 20)
    with (
        zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as archive,
        archive.open("manifest.json", "w", force_zip64=True) as member,
    ):
        for _ in range(manifest_bytes >> 20):
            member.write(chunk)
    return out.getvalue()


def test_a_manifest_that_decompresses_to_300_mb_is_refused_unread(tmp_path: Path) -> None:
    archive = bomb(300 << 20)
    assert len(archive) < 400_000
    library = open_library(f"sqlite:///{tmp_path / 'x.db'}", seed_demo=False)
    with pytest.raises(LibraryError) as caught:
        library.restore_backup(io.BytesIO(archive))
    assert "manifest.json" in str(caught.value) and "MB" in str(caught.value)
    library.engine.dispose()


def test_a_member_whose_size_lies_is_read_no_further_than_the_limit(tmp_path: Path) -> None:
    """The size a zip states is the archive's claim; the reader counts what it inflates."""
    archive = bytearray(bomb(40 << 20))
    # Patch the central directory's uncompressed size (and the zip64 extra) to 100 bytes.
    with zipfile.ZipFile(io.BytesIO(bytes(archive))) as z:
        info = z.getinfo("manifest.json")
        real = info.file_size
    archive = archive.replace(real.to_bytes(8, "little"), (100).to_bytes(8, "little"))
    library = open_library(f"sqlite:///{tmp_path / 'y.db'}", seed_demo=False)
    with pytest.raises(LibraryError):
        library.restore_backup(io.BytesIO(bytes(archive)))
    library.engine.dispose()


def test_a_zip_of_a_version_zipfile_cannot_read_is_refused(library: Library) -> None:
    """Found by the long fuzz run: ZipFile() itself raised NotImplementedError."""
    archive = bytearray(good_backup())
    end = archive.rfind(b"PK\x01\x02")  # the last central directory entry
    archive[end + 6 : end + 8] = (131).to_bytes(2, "little")  # version needed: 13.1
    with pytest.raises(LibraryError) as caught:
        library.restore_backup(io.BytesIO(bytes(archive)))
    assert "zip file version 13.1" in str(caught.value)
    assert library.programs() == []


def test_cli_restore_of_a_damaged_backup_exits_2_with_a_message(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'c.db'}")
    archive = tmp_path / "damaged.zip"
    archive.write_bytes(rezip(good_backup(), bad_machine))
    result = CliRunner().invoke(main, ["restore", str(archive)])
    assert result.exit_code == 2, result.output
    assert "damaged.zip: " in result.stderr and "machine 2" in result.stderr
    assert result.exception is None or isinstance(result.exception, SystemExit)
    archive.write_bytes(b"PK\x03\x04 not really a zip")
    result = CliRunner().invoke(main, ["restore", str(archive)])
    assert result.exit_code == 2 and "not a zip" in result.stderr.lower()


# A manifest's machine with settings the machines form refuses (issue 30.4 / 31.6): each was
# restored, and only a later send (serial) or export (options, limits) refused it.
REFUSED_SETTINGS = {
    "a baud that is not a number": (
        {"serial": {"port": "", "baud": "abc"}},
        "serial, baud: baud 'abc' is not a whole number",
    ),
    "a baud no UART runs": (
        {"serial": {"port": "", "baud": 4801}},
        "serial, baud: baud 4801 is not a standard rate; use one of 110, 150,",
    ),
    "a parity not allowed": (
        {"serial": {"port": "", "parity": "X"}},
        "serial, parity: parity 'X': use N, E or O",
    ),
    "three stop bits": (
        {"serial": {"port": "", "stop_bits": "3"}},
        "serial, stop_bits: stop bits 3: use 1 or 2",
    ),
    "a negative hold": (
        {"serial": {"port": "", "hold": "-5"}},
        "serial, hold: hold -5 s: use 1 to 86400 seconds, or 0 for no limit",
    ),
    "a setting no line has": (
        {"serial": {"port": "", "speed": "fast"}},
        "serial, speed: unknown serial setting 'speed'; the settings: port, baud,",
    ),
    "an option the target has not": (
        {"options": {"nope": "1"}},
        "options: gcode-linuxcnc has no option 'nope'; its options: ",
    ),
    "travel limits the machine model cannot read": (
        {"limits": {"spindle": "fast"}},
        "limits: spindle: 'fast' is not a range of speeds",
    ),
}


@pytest.mark.parametrize("case", REFUSED_SETTINGS, ids=list(REFUSED_SETTINGS))
def test_a_machine_the_form_refuses_is_not_restored(library: Library, case: str) -> None:
    settings, message = REFUSED_SETTINGS[case]

    def change(manifest: dict[str, Any], _members: dict[str, bytes]) -> None:
        manifest["machines"][0].update(settings)

    kept = Machine("Bridgeport", "gcode-linuxcnc", {}, {"port": "/dev/ttyUSB0", "baud": "9600"})
    library.save_machine(kept)
    with pytest.raises(LibraryError) as caught:
        library.restore_backup(io.BytesIO(rezip(good_backup(), change)))
    assert f"cannot read the backup: manifest, machine 1 (Bridgeport), {message}" in str(
        caught.value
    )
    # Nothing stored: the machine keeps its settings, no program came in.
    assert library.machines() == [kept]
    assert library.programs(trash=True) == []


def test_saving_a_machine_checks_its_serial_settings_as_the_form_does(library: Library) -> None:
    with pytest.raises(LibraryError) as caught:
        library.save_machine(Machine("m12", "events", {}, {"port": "", "baud": "abc"}))
    assert str(caught.value) == "machine 'm12', serial, baud: baud 'abc' is not a whole number"
    with pytest.raises(LibraryError, match=r"^machine 'm12', target: 'nope' is not a target"):
        library.save_machine(Machine("m12", "nope", {}, {}))
    assert library.machines() == []


def test_cli_restore_names_the_serial_setting_it_refuses(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'c.db'}")

    def change(manifest: dict[str, Any], _members: dict[str, bytes]) -> None:
        manifest["machines"][0]["serial"] = {"port": "/dev/ttyS0", "parity": "mark"}

    archive = tmp_path / "serial.zip"
    archive.write_bytes(rezip(good_backup(), change))
    result = CliRunner().invoke(main, ["restore", str(archive)])
    assert result.exit_code == 2, result.output
    assert (
        "manifest, machine 1 (Bridgeport), serial, parity: parity 'mark': use N, E or O "
        "(none, even, odd)" in result.stderr
    )
