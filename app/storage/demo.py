"""The demo library: the seeds' sample parts, added the first time a library is opened.

The programs live as JSON documents in app/demo/. A setting records that they were added,
so a shop that deletes them does not get them back, or that the library was first opened
without them (MILLBLOCKS_DEMO_PROGRAMS=0), so a later command run without that setting
does not add them either.
"""

from __future__ import annotations

from importlib import resources
from typing import TYPE_CHECKING

from app.cnc import document
from app.cnc.blocks import Program

if TYPE_CHECKING:
    from app.storage.library import Library

SETTING = "demo_seeded"
DECLINED = "declined"  # SETTING's value when the library was first opened without them


def demo_programs() -> list[Program]:
    """The demo programs, in file-name order."""
    folder = resources.files("app") / "demo"
    files = sorted((f for f in folder.iterdir() if f.name.endswith(".json")), key=lambda f: f.name)
    return [document.loads(f.read_text(encoding="utf-8")) for f in files]


def seed(library: Library) -> int:
    """Add the demo programs unless this library already had them; returns how many."""
    if library.setting(SETTING):
        return 0
    programs = demo_programs()
    for program in programs:
        library.create(program, author="MillBlocks", summary_text="demo program")
    library.set_setting(SETTING, "1")
    return len(programs)


def decline(library: Library) -> None:
    """Record that this library was opened without the demo programs, unless it already has
    a decision: a library that started empty stays so, whoever opens it next."""
    if not library.setting(SETTING):
        library.set_setting(SETTING, DECLINED)
