"""(child) Import files and print what came of each, one JSON line per file.

Run by tests/test_wheel.py twice with the installed wheel's Python, once with the compiled
importer and once with MILLBLOCKS_NATIVE=0 (its sources): the two outputs must be
identical. Arguments: the files to read; each is read as it is and, for a text file, in
lower case (which takes the G-code reader's word-by-word path instead of its fast lane).
The last line says which modules ran compiled.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from app.cnc import document, native
from app.cnc.formats.reading import ImportFailure, read_program


def outcome(data: bytes, name: str) -> dict[str, object]:
    try:
        result = read_program(data, name)
    except ImportFailure as exc:
        return {"error": str(exc)}
    return {
        "format": result.format,
        "program": document.dumps(result.program),
        "report": [str(note) for note in result.report],
    }


def main(paths: list[str]) -> None:
    for path in paths:
        data = Path(path).read_bytes()
        print(json.dumps({"file": path, **outcome(data, Path(path).name)}, sort_keys=True))
        if data.isascii():
            lower = outcome(data.lower(), Path(path).name)
            print(json.dumps({"file": f"{path} (lower case)", **lower}, sort_keys=True))
    print(json.dumps({"native": native.status()}))  # last: every module is imported by now


if __name__ == "__main__":
    main(sys.argv[1:])
