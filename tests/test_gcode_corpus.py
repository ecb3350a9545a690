"""G-code nobody here wrote, refereed by LinuxCNC's rs274 (issue 36).

The corpus (tests/imports/gcode-corpus, where each file came from in SOURCES.md) is real
post output — Fusion 360's posts, FreeCAD's, KiCad drill files through drl2gcode, a Fanuc
beginners' example — and LinuxCNC's own examples and interpreter tests, kept as their authors
wrote them. MANIFEST.toml says what each does on import:

- **cuts**: it imports, and rs274 reading the file and rs274 reading our LinuxCNC export of
  the imported program agree on the cut path (`tests.referee.referee_import`: every feed
  move in order, its ends, arc centre and direction within 0.001 in / 0.01 mm, its feed
  within 0.1 ipm / 2 mm/min — what the blocks hold; how rapids get there may differ);
- **refused**: the import stops at the line the manifest gives with exactly its message,
  one a machinist can act on (what is wrong, where, what to do) — never an unexpected
  character or a traceback.
- **imports**: it imports where rs274's cut cannot be the measure — a compensated contour
  whose diameter the file leaves to the tool table, pecks the control spaces evenly where
  G83 does not: the report says how it was read and what to supply (the manifest's
  `report`), and the program's only errors are what the file leaves to the user (`errors`).
  tests/test_import_compensation.py and tests/test_import_freecad.py hold these readings to
  rs274 (with the diameters filled in, and hole by hole).

A file rs274 refuses for lines the import reports as not carried (Centroid's M25, a G49
with an H) names them in `rs274_without`: rs274 referees the file without those lines. A
bolt circle the file drills counter-clockwise is one MillBlocks drills clockwise: `any_order`
compares its holes as a set.

A file marked `pending` is refused today for something other work is adding (O-word
subroutines and expressions); when that lands, its entry here changes to what it then does.

Generated programs in the posts' styles (`strategies.post_programs`: a Fusion/Haas header
with G28 G91 Z0., the safety line G0 G17 G40 G80 G90 G94 G98, T M6, G43 H, G54, S M3, M8,
drilling cycles G81/G83 with G98/G99 and R, contours of G1/G2/G3 with I/J and feed words,
G0 Z retracts, M9 M5, M30, %) are refereed the same way.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings

from app.cnc.formats.reading import ImportFailure, NoteKind, read_program
from app.cnc.problems import Severity
from app.cnc.validate import validate
from tests.referee import referee_import, rs274_reads
from tests.strategies import post_programs

CORPUS = Path(__file__).parent / "imports" / "gcode-corpus"
MANIFEST: list[dict[str, Any]] = tomllib.loads((CORPUS / "MANIFEST.toml").read_text())["file"]
BOM = b"\xef\xbb\xbf"
# What a message a machinist cannot act on looks like.
UNHELPFUL = ("unexpected", "Traceback", "Error", "None", "cannot take this program")


def test_the_manifest_and_the_sources_name_every_file() -> None:
    on_disk = sorted(
        str(p.relative_to(CORPUS))
        for p in CORPUS.rglob("*")
        if p.is_file() and p.name not in ("MANIFEST.toml", "SOURCES.md")
    )
    assert sorted(entry["path"] for entry in MANIFEST) == on_disk
    sources = (CORPUS / "SOURCES.md").read_text(encoding="utf-8")
    assert all(f"`{path}`" in sources for path in on_disk)
    assert 20 <= len(on_disk) <= 40
    assert {entry["outcome"] for entry in MANIFEST} == {"cuts", "refused", "imports"}


@pytest.mark.parametrize("entry", MANIFEST, ids=[e["path"] for e in MANIFEST])
def test_each_file_imports_and_cuts_as_rs274_reads_it_or_is_refused_as_the_manifest_says(
    entry: dict[str, Any], tmp_path: Path
) -> None:
    data = (CORPUS / entry["path"]).read_bytes()
    # rs274's own verdict on the file (it refuses a byte-order mark, which the importer reads
    # past: the G-code after it is what is judged).
    original = tmp_path / "as-written.ngc"
    original.write_bytes(data.removeprefix(BOM))
    assert rs274_reads(original) == (entry["rs274"] == "reads")
    if entry["outcome"] == "cuts":
        # Lines rs274 refuses that the import reports as not carried (another control's M
        # code, a word no code uses): rs274 referees the file without them.
        dropped = entry.get("rs274_without", [])
        lines = data.split(b"\n")
        gone = [n for n, line in enumerate(lines, 1) if line.strip().decode() in dropped]
        kept = [line for n, line in enumerate(lines, 1) if n not in gone]
        result = referee_import(
            data, tmp_path, as_rs274_reads=b"\n".join(kept), any_order=entry.get("any_order", False)
        )
        ignored = {n.line for n in result.report if n.kind is NoteKind.IGNORED}
        assert len(gone) == len(dropped) and set(gone) <= ignored, (gone, ignored)
        return
    if entry["outcome"] == "imports":
        result = read_program(data, Path(entry["path"]).stem, "gcode")
        report = "\n".join(str(note) for note in result.report)
        assert all(text in report for text in entry["report"]), report
        errors = [str(p) for p in validate(result.program) if p.severity is Severity.ERROR]
        assert all(any(named in e for named in entry["errors"]) for e in errors), errors
        return
    with pytest.raises(ImportFailure) as caught:
        read_program(data, Path(entry["path"]).stem, "gcode")
    message = str(caught.value)
    assert caught.value.line == entry["line"]
    assert message == entry["message"]
    assert message.startswith(f"line {entry['line']}")
    assert not any(word in message for word in UNHELPFUL), message


@settings(
    max_examples=50,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(text=post_programs())
def test_programs_in_the_posts_styles_cut_as_rs274_reads_them(text: str, tmp_path: Path) -> None:
    """Every generated program imports, and its cut path is rs274's."""
    referee_import(text.encode(), tmp_path, "post")
