"""What the editor page shows, and what an edit answers with (issue 18, the editor's reply).

The page is three parts: the block list (one page of rows, the cycle time), the entry panel
and the preview. htmx requests get only the part that changes: a choice in the entry panel
answers with the panel; an edit answers with the panel and, out of band, the rows whose
title, values, problems or time changed (the whole list page when blocks moved or came or
went), the cycle time, the version the row buttons post, and what changed in the drawing
(`drawing_patch`; a request for the whole new drawing when the page shows another version's).

What a version of a program shows (its problems, its preview and times) is worked out once
and kept for the last few versions (`shown_of`): the GET after an edit, and the rows of the
version an edit starts from, cost nothing when this process showed it (else they are worked
out from the stored version, mostly from the compile's and the cycle time's kept nodes).
"""

from __future__ import annotations

import dataclasses
import enum
import hashlib
from dataclasses import dataclass
from decimal import Decimal
from typing import Any

from flask import render_template, request

from app.cnc.blocks import Block, Mode, Program, open_loops
from app.cnc.compiler import compile_program
from app.cnc.crib import feed_offers
from app.cnc.estimate import format_seconds
from app.cnc.kinds import REGISTRY
from app.cnc.memo import ByObject, Recent
from app.cnc.numbers import NumberError, parse_int
from app.cnc.problems import Problem, Severity
from app.cnc.validate import validate
from app.storage.library import StoredProgram
from app.web.forms import (
    Choice,
    EntryForm,
    entry_forms,
    extra_fields,
    group_kinds,
    group_menu,
    sub_menu,
)
from app.web.preview import Parts, Patch, Preview, parts, patch, preview, times
from app.web.preview import Shown as PreviewShown


@dataclass
class Entry:
    """What the entry panel shows: a choice of type, of sub-type, or a block's fields."""

    at: int  # the block number being entered (new) or edited
    editing: bool
    group: str = ""
    kind: str = ""
    loop: bool = False
    stop: bool = False
    values: dict[str, str] = dataclasses.field(default_factory=dict)
    errors: dict[str, str] = dataclasses.field(default_factory=dict)
    message: str = ""  # why what was entered was not saved
    refused: str = ""  # why the choice made cannot be made here
    notice: str = ""  # what was just done elsewhere (Data Block 0 saved)
    page: int = 0  # the block list's page asked for; 0: the page of block `at`


PAGE_SIZE = 100
"""Blocks per page of the block list: a page costs the same whatever the program's size."""


def page_of(number: int) -> int:
    """The page (from 1) of the block list that shows block `number`."""
    return max(1, (number - 1) // PAGE_SIZE + 1)


def is_htmx() -> bool:
    return request.headers.get("HX-Request") == "true"


def block_summary(block: Block) -> str:
    """The block's values in one line, the way the control's block list reads: what its
    entry form asks for (its type and sub-type are in its title). Kept per block object
    (most blocks of one version are the blocks of the version before)."""
    found = _SUMMARIES.get(block)
    if found is None:
        found = _summary(block)
        _SUMMARIES.keep(block, found)
    return found


_SUMMARIES: ByObject[str] = ByObject()


def _summary(block: Block) -> str:
    parts = []
    sub = REGISTRY.sub_kind_of(block)
    for f in (*REGISTRY.prompted(type(block), sub), *extra_fields(type(block), sub)):
        value = getattr(block, f.name)
        if value is None or value is False:
            continue
        label = f.label
        if value is True:
            parts.append(label)
        elif isinstance(value, Decimal):
            parts.append(f"{label} {value:f}")
        elif isinstance(value, enum.Enum):
            parts.append(f"{label} {str(value.value).upper()}")
        else:
            parts.append(f"{label} {value}")
    if REGISTRY.of(block).positioned and block.mode is Mode.INC:
        parts.insert(0, "INC")
    return "  ".join(parts)


# -- one version of a program, as the editor shows it -----------------------------------------


@dataclass
class Shown:
    """A program's problems and times (what validation and the cycle time made of it), and
    its drawing, made when first asked for: an edit's reply sends rows and times, and the
    page fetches the drawing after it (`drawing()`, cached here)."""

    program: Program
    problems: list[Problem]
    by_block: dict[int, list[Problem]]
    per_block: dict[int, float]
    total: float
    _drawing: Preview | None = None
    _parts: Parts | None = None

    def drawing(self) -> Preview:
        """The preview: the SVG and what it holds (blocks with errors, not drawn)."""
        if self._drawing is None:
            self._drawing = preview(self.program, self.problems, timed=(self.per_block, self.total))
        return self._drawing

    def parts(self) -> Parts | None:
        """The drawing split for comparing with another version's (preview.parts); None
        when there is none to compare (nothing drawn, or painted on a canvas)."""
        drawing = self.drawing()
        if not drawing.svg or drawing.shown.large:
            return None
        if self._parts is None:
            self._parts = parts(drawing.svg)
        return self._parts

    @property
    def drawn(self) -> PreviewShown | None:
        """What the drawing holds, if it was made already (the cycle-time line says which
        blocks it leaves out only then)."""
        return self._drawing.shown if self._drawing is not None else None


SHOWN_VERSIONS = 4
_SHOWN: Recent[Shown] = Recent(SHOWN_VERSIONS, lru=True)  # by id; each keeps its program


def shown_of(program: Program) -> Shown:
    """What the editor shows of `program`, worked out once per Program object (the library
    hands out the same object for the same stored text)."""
    found = _SHOWN.get(id(program))
    if found is not None and found.program is program:
        return found
    problems = validate(program)
    per_block, total = times(program, problems)
    by_block: dict[int, list[Problem]] = {}
    for problem in problems:
        if problem.block is not None:
            by_block.setdefault(problem.block, []).append(problem)
    found = Shown(program, problems, by_block, per_block, total)
    _SHOWN.keep(id(program), found)
    return found


@dataclass(frozen=True)
class Row:
    """One row of the block list."""

    number: int
    title: str
    summary: str
    seconds: str
    problems: tuple[Problem, ...]
    has_error: bool
    current: bool = False

    @property
    def digest(self) -> str:
        """What the row shows (title, values, time, problems), as 16 hex digits: the page
        keeps it beside the row and an edit sends it back (the same text in every worker)."""
        shown = [self.title, self.summary, self.seconds]
        shown += [f"{p.severity.value}\x1e{p.field or ''}\x1e{p.message}" for p in self.problems]
        return hashlib.blake2b("\x1f".join(shown).encode(), digest_size=8).hexdigest()


def row(shown: Shown, number: int, current: bool = False) -> Row:
    block = shown.program.blocks[number - 1]
    problems = tuple(shown.by_block.get(number, ()))
    seconds = shown.per_block.get(number)
    return Row(
        number,
        block.title,
        block_summary(block),
        "" if seconds is None else format_seconds(seconds),
        problems,
        any(p.severity is Severity.ERROR for p in problems),
        current,
    )


def shown_digests() -> dict[int, str]:
    """The rows the page shows, as the edit's form sent them (`shown`: "number:digest");
    empty when it sent none (a page without them, a client of its own)."""
    found = {}
    for value in request.form.getlist("shown"):
        number, _, digest = value.partition(":")
        if not digest:
            continue
        try:
            found[parse_int(number)] = digest
        except NumberError:  # not a row this page sent
            continue
    return found


def changed_rows(old: Shown, new: Shown, first: int, last: int) -> list[Row]:
    """The rows `first`…`last` of `new` that do not read as they did in `old` (same blocks
    count: an edit in place). A row is made of its block, problems and time: where all
    three are the same as before (most rows of an edit: the same block object, the same
    figures), the row is the same and is not made again."""
    changed = []
    for number in range(first, last + 1):
        if (
            old.program.blocks[number - 1] is new.program.blocks[number - 1]
            and old.per_block.get(number) == new.per_block.get(number)
            and old.by_block.get(number) == new.by_block.get(number)
        ):
            continue
        fresh = row(new, number)
        if fresh != row(old, number):
            changed.append(fresh)
    return changed


def drawing_patch(before: Program, before_version: int, after: Shown) -> Patch | None:
    """What the page's drawing needs to become `after`'s, when the edit's form says the page
    shows the drawing of the version the edit started from (`drawn`: static/preview.js sends
    it; it is `before`, version `before_version`); None when it shows another or none, or
    either drawing is painted on a canvas: the page then asks for the whole drawing."""
    if request.form.get("drawn") != str(before_version):
        return None
    new = after.parts()
    old = shown_of(before).parts() if new is not None else None
    if new is None or old is None:
        return None
    return patch(old, new)


# -- contexts and rendering ---------------------------------------------------------------------


def list_context(
    stored: StoredProgram, shown: Shown, entry: Entry, focus: int, rows: bool = True
) -> dict[str, Any]:
    """The block list's page: the page of `focus` unless the entry asks for another.
    `rows` False: its bounds (`first`, `last`) without the rows (an edit's reply that sends
    only the rows that changed)."""
    count = len(stored.program.blocks)
    pages = page_of(max(count, 1))  # "new block…" ends the last page
    page = min(entry.page or page_of(focus), pages)
    first = (page - 1) * PAGE_SIZE + 1
    last = min(count, first + PAGE_SIZE - 1)
    current = entry.at if entry.editing else 0
    return {
        "rows": [row(shown, n, n == current) for n in range(first, last + 1)] if rows else [],
        "last": last,
        "block_count": count,
        "page": page,
        "pages": pages,
        "first": first,
        "focus": focus,
        "total": format_seconds(shown.total),
        "shown": shown.drawn,
    }


def entry_context(stored: StoredProgram, entry: Entry, problems: list[Problem]) -> dict[str, Any]:
    """The entry panel: the menus offered at `entry.at`, or the prompts with their problems."""
    program = stored.program
    kind = entry_forms().get(entry.kind)
    field_problems: dict[str, list[Problem]] = {}
    if entry.editing and kind is not None:
        field_problems["message"] = [
            p for p in problems if p.block == entry.at and p.field == "MESSAGE"
        ]
        for spec in kind.fields:
            number, name = entry.at, spec.name
            if name.startswith("end_"):
                number, name = entry.at + 1, name.removeprefix("end_")
            label = REGISTRY.label(type(program.blocks[number - 1]), name)
            field_problems[spec.name] = [
                p for p in problems if p.block == number and p.field == label
            ]
    groups = group_menu(program, entry.at, entry.loop, entry.stop)
    calculated = calculated_values(program, entry.at, kind) if entry.editing else {}
    menus: dict[str, list[Choice]] = {}
    if not entry.editing and not entry.kind and not entry.group:
        # The sub-type menus go with the type menu: the page shows them without a request.
        kinds = group_kinds()
        for choice in groups:
            if not choice.reason and len(kinds.get(choice.key, ())) > 1:
                menus[choice.key] = sub_menu(program, entry.at, choice.key)
    return {
        "problems": problems,
        "errors": [p for p in problems if p.severity is Severity.ERROR],
        "entry": entry,
        "menus": menus,
        "kind": kind,
        "field_problems": field_problems,
        "groups": groups,
        "sub_kinds": sub_menu(program, entry.at, entry.group) if entry.group else [],
        "kinds": entry_forms(),
        "offered": not entry.editing and not entry.errors and not entry.message,
        "in_loop": open_loops(program.blocks, entry.at - 1) > 0,
        "feed_offers": _feed_offers(program, kind),
        "calculated": calculated,
    }


def calculated_values(program: Program, at: int, kind: EntryForm | None) -> dict[str, str]:
    """The values of block `at` (and of its XY-END) the compile calculated from the print
    (app.cnc.solve), by form field, to 0.0001 in / 0.001 mm: the form shows them where
    nothing is typed."""
    if kind is None or not 1 <= at <= len(program.blocks):
        return {}
    found = {}
    names = {spec.name for spec in kind.fields}
    for number, name, value in compile_program(program).calculated:
        field = name if number == at else "end_" + name if number == at + 1 else ""
        if field in names:
            units = program.blocks[number - 1].units
            found[field] = f"{value.quantize(Decimal(1).scaleb(-units.dump_places)):f}"
    return found


def _feed_offers(program: Program, kind: EntryForm | None) -> dict[str, dict[str, str]]:
    """The feeds offered with each tool (app.cnc.crib), for a form that asks for a feed and
    a tool in a program that states its material: changing TOOL # offers that tool's feed
    where the feed was not typed (static/app.js)."""
    if kind is None or program.material is None:
        return {}
    names = {spec.name for spec in kind.fields}
    if "tool" not in names or not names & {"feed_xy", "feed_z"}:
        return {}
    return {str(number): values for number, values in feed_offers(program).by_tool.items()}


def _common(stored: StoredProgram) -> dict[str, Any]:
    return {"stored": stored, "program": stored.program, "program_id": stored.info.id}


def render_page(
    stored: StoredProgram, entry: Entry, status: int = 200, crib_notes: list[str] | None = None
) -> tuple[str, int]:
    """The whole editor page (`crib_notes`: where Data Block 0's tools differ from the
    crib's, said above the editor)."""
    shown = shown_of(stored.program)
    drawing = shown.drawing()
    return render_template(
        "editor/program.html",
        **_common(stored),
        **list_context(stored, shown, entry, entry.at),
        **entry_context(stored, entry, shown.problems),
        svg=drawing.svg,
        crib_notes=crib_notes or [],
    ), status


def render_drawing(stored: StoredProgram) -> tuple[str, int]:
    """The drawing of the stored program, and the cycle-time line out of band (what an
    edit's reply asks for after it)."""
    shown = shown_of(stored.program)
    drawing = shown.drawing()
    return render_template(
        "editor/_drawing_reply.html",
        **_common(stored),
        svg=drawing.svg,
        shown=drawing.shown,
        total=format_seconds(shown.total),
    ), 200


def render_entry(stored: StoredProgram, entry: Entry, status: int = 200) -> tuple[str, int]:
    """The entry panel alone (htmx), or the page."""
    if not is_htmx():
        return render_page(stored, entry, status)
    problems = validate(stored.program)
    return render_template(
        "editor/_entry.html", **_common(stored), **entry_context(stored, entry, problems)
    ), status


def render_list(stored: StoredProgram, entry: Entry) -> tuple[str, int]:
    """The block list alone (htmx: another page of it)."""
    shown = shown_of(stored.program)
    return render_template(
        "editor/_blocks.html",
        **_common(stored),
        **list_context(stored, shown, entry, entry.at),
        entry=entry,
    ), 200


def render_reply(
    before: Program,
    before_version: int,
    saved: StoredProgram,
    entry: Entry,
    focus: int,
    in_place: bool,
) -> tuple[str, int]:
    """The answer to an edit (htmx): the entry panel, and out of band what changed.

    `focus` is the block the list stays at (the edited one). `in_place`: the edit kept
    every block where it was, so the rows can be compared one for one with the version the
    edit started from; those are the digests the page sent with the edit (`shown_digests`:
    what the browser shows, whichever worker showed it), else that version's rows (worked
    out here when this process did not show it: under gunicorn the other worker may have).
    When blocks moved, the whole list page is sent.

    The drawing: when the page shows `before`'s (version `before_version`), what changed
    in it (`drawing_patch`, applied by static/preview.js) and the blocks it leaves out;
    else a request for the whole new drawing, which follows."""
    shown = shown_of(saved.program)
    redrawn = drawing_patch(before, before_version, shown)
    drawing = {
        "redrawn": redrawn,
        "drawn_from": before_version,
        "drawn_shown": shown.drawn if redrawn is not None else None,
    }
    if not in_place:
        return render_template(
            "editor/_reply.html",
            **_common(saved),
            **list_context(saved, shown, entry, focus),
            **entry_context(saved, entry, shown.problems),
            **drawing,
            changed=None,
        ), 200
    listing = list_context(saved, shown, entry, focus, rows=False)
    first, last = listing["first"], listing["last"]
    seen = shown_digests()
    if all(n in seen for n in range(first, last + 1)):
        # What the browser shows: no need for the version the edit started from.
        changed = [r for n in range(first, last + 1) if (r := row(shown, n)).digest != seen[n]]
    else:
        changed = changed_rows(shown_of(before), shown, first, last)
    return render_template(
        "editor/_reply.html",
        **_common(saved),
        **listing,
        **entry_context(saved, entry, shown.problems),
        **drawing,
        changed=changed,
    ), 200
