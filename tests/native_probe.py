"""(child) Import files and print what came of each, one JSON line per file; export
programs and print what each target wrote.

Run by tests/test_wheel.py twice with the installed wheel's Python, once with the compiled
modules and once with MILLBLOCKS_NATIVE=0 (their sources): the two outputs must be
identical. Arguments: the files to read; each is read as it is and, for a text file, in
lower case (which takes the G-code reader's word-by-word path instead of its fast lane),
and each program read is written as a 1704 tape (the compiled writer). After `--export`:
program documents (the goldens), each written to every target of EXPORTS. The last line
says which modules ran compiled.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from app.cnc import document, native
from app.cnc.blocks import Program
from app.cnc.formats.reading import ImportFailure, read_program
from app.cnc.formats.targets import ExportError, export

# The 1704 writer's targets (its columns, its one-by-one items, its punch image and its
# picture) and a G-code one (the compiled toolpath walk under every writer).
EXPORTS = ("tape-eia", "tape-ascii", "punch-eia", "tape-svg", "gcode-linuxcnc")


def exported(program: Program, target: str) -> dict[str, object]:
    """What `target` writes for `program` (bytes as Latin-1 text) and its report, or the
    export's error and report."""
    try:
        result = export(program, target)
    except ExportError as exc:
        return {"error": exc.explained(), "report": exc.report and exc.report.text()}
    try:
        return {"data": result.data.decode("latin-1"), "report": result.report.text()}
    finally:
        result.close()


def outcome(data: bytes, name: str) -> dict[str, object]:
    try:
        result = read_program(data, name)
    except ImportFailure as exc:
        return {"error": str(exc)}
    return {
        "format": result.format,
        "program": document.dumps(result.program),
        "report": [str(note) for note in result.report],
        "tape-eia": exported(result.program, "tape-eia"),
    }


def main(paths: list[str]) -> None:
    split = paths.index("--export") if "--export" in paths else len(paths)
    for path in paths[:split]:
        data = Path(path).read_bytes()
        print(json.dumps({"file": path, **outcome(data, Path(path).name)}, sort_keys=True))
        if data.isascii():
            lower = outcome(data.lower(), Path(path).name)
            print(json.dumps({"file": f"{path} (lower case)", **lower}, sort_keys=True))
    for path in paths[split + 1 :]:
        program = document.loads(Path(path).read_text(encoding="utf-8"))
        for target in EXPORTS:
            print(json.dumps({"file": path, target: exported(program, target)}, sort_keys=True))
    print(json.dumps({"native": native.status()}))  # last: every module is imported by now


if __name__ == "__main__":
    main(sys.argv[1:])
