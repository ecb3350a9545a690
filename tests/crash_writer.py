"""A writer for the crash test: saves new versions of one program in a loop.

`python -m tests.crash_writer URL PROGRAM_ID` prints `ack N` after each save of version N
is committed, and never stops by itself: the test kills it with SIGKILL mid-save.
"""

from __future__ import annotations

import sys
from dataclasses import replace

from app.storage.library import open_library


def main() -> None:
    url, program_id = sys.argv[1], int(sys.argv[2])
    library = open_library(url, seed_demo=False)
    while True:
        stored = library.get(program_id)
        version = stored.info.version
        changed = replace(stored.program, notes=f"save {version + 1}")
        info = library.save(program_id, changed, based_on=version, author="crash")
        print(f"ack {info.version}", flush=True)


if __name__ == "__main__":
    main()
