"""The conversational block entry: types, sub-types, and each block's fields in the order
the control asks for them (seed 001 §3.4.5), parsed from form text into blocks.

A block form is identified by a `kind` (the type and sub-type the machinist chose, e.g.
`DRILL`, `BOLT_CIR_TAP`, `QCIR_CC`, `FRM_2P`) plus the LOOP and STOP qualifiers. Parsing
never raises: it returns the block, or the message for each field that could not be read
(what is wrong and what is allowed); range checks are validation's, shown beside the field.
"""

from __future__ import annotations

import enum
import functools
import typing
from collections.abc import Mapping
from dataclasses import dataclass
from decimal import Decimal
from typing import Any

from app.cnc import limits
from app.cnc.blocks import Block, Mode, Program, Rep, open_loops
from app.cnc.crib import feed_offers
from app.cnc.kinds import REGISTRY, Field, Role, SubKind, Value
from app.cnc.mirror import length_of, table_position
from app.cnc.numbers import NumberError, parse_decimal, parse_int
from app.cnc.structure import starts_mill_sequence
from app.cnc.units import Units

# The qualifiers and settings every block has; the form asks for them apart from the prompts.
COMMON = frozenset({"mode", "units", "loop", "stop", "message"})


@dataclass(frozen=True)
class FieldSpec:
    """One prompt of an entry form: form name, the control's label, how it is read."""

    name: str
    label: str
    kind: str  # length, feed, angle, count, tool, flag, choice
    required: bool = True
    choices: tuple[tuple[str, str], ...] = ()
    help: str = ""
    # Shown only while these prompts have these values ("placement=pocket entry=helix"):
    # the declaration's `only_when` on prompts the form asks for (static/app.js).
    shown_when: str = ""
    # Beside the Enter sequence, not in it: a field shown only sometimes, or one the control
    # never prompted for (the declaration's `beside`).
    beside: bool = False


@dataclass(frozen=True)
class EntryForm:
    """A block type and sub-type as the editor offers it, read from its declaration
    (app.cnc.kinds): the prompts in the control's order, and what the form builds."""

    key: str
    title: str
    group: str  # the first choice: POS, DRILL, BORE, TAP, MILL, REP, COPY
    fields: tuple[FieldSpec, ...]
    positioned: bool = False  # has X/Y, so the INC/ABS switch applies
    loopable: bool = False
    stoppable: bool = True
    menu: int = 0  # its number in the group's menu (0: not in a menu)
    extras: tuple[FieldSpec, ...] = ()  # beside the prompts (extra_fields)


def _enum_of(cls: type, name: str) -> type[enum.Enum] | None:
    """The enum a CHOICE field holds (from the dataclass's resolved annotations)."""
    hint = _hints(cls)[name]
    options = typing.get_args(hint) or (hint,)
    return next((o for o in options if isinstance(o, type) and issubclass(o, enum.Enum)), None)


@functools.cache
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def _shown(value: object) -> str:
    """A value as the form sends it (an enum's value)."""
    return str(value.value if isinstance(value, enum.Enum) else value)


def _spec(
    cls: type[Block], f: Field, name: str, label: str, sub: SubKind | None = None
) -> FieldSpec:
    shown = (
        ""
        if sub is None
        else " ".join(
            f"{n}={'|'.join(sorted(map(_shown, v))) if isinstance(v, frozenset) else _shown(v)}"
            for n, v in REGISTRY.shown_when(f, sub)
        )
    )
    choices: tuple[tuple[str, str], ...] = ()
    if f.prompt.value is Value.CHOICE:
        members = _enum_of(cls, f.name) or enum.Enum
        choices = tuple((m.value, m.name.replace("_", "/")) for m in members)
        if f.optional:
            choices = (("", f.prompt.blank), *choices)
    return FieldSpec(
        name,
        label,
        f.prompt.value.value,
        f.required,
        choices,
        f.prompt.help,
        shown,
        bool(shown) or f.prompt.beside,
    )


def _form(cls: type[Block], sub: SubKind) -> EntryForm:
    kind = REGISTRY.kind(cls)
    parts = [(cls, "")] + ([(sub.then, "end_")] if sub.then is not None else [])
    specs = []
    extras = []
    for part, prefix in parts:
        suffix = f" ({REGISTRY.kind(part).part})" if sub.then is not None else ""
        follower = SubKind("", "", "") if prefix else sub
        for f in REGISTRY.prompted(part, follower):
            xy = f.prompt.role in (Role.X, Role.Y)
            label = f.label + (suffix if xy else "")
            specs.append(_spec(part, f, prefix + f.name, label, follower))
        for f in extra_fields(part, follower):
            extras.append(_spec(part, f, prefix + f.name, f.label + (suffix if prefix else "")))
    return EntryForm(
        sub.key,
        sub.title,
        sub.group,
        tuple(specs),
        kind.positioned,
        kind.loopable,
        kind.stoppable or sub.then is not None,
        sub.menu,
        tuple(extras),
    )


def extra_fields(cls: type[Block], sub: SubKind) -> tuple[Field, ...]:
    """The fields a block may carry beside its prompts (a contour's TANGENT, RAD, CONRAD
    and CHAMFER from the print, issue 33): shown after the prompts, outside the Enter
    sequence the control's prompts keep."""
    fixed = dict(sub.fixed)
    return tuple(
        f
        for f in REGISTRY.fields(cls)
        if not f.prompt.prompted
        and f.name not in COMMON
        and f.name not in fixed
        and f.prompt.value in (Value.LENGTH, Value.ANGLE, Value.FLAG)
    )


# The first menu's choices that are qualifiers of the next block, not kinds, at the
# control's numbers; the kinds declare the others (`Kind.choices`: POS 1 … POCKET 10, key 0).
QUALIFIERS = {6: "LOOP", 7: "STOP"}
_FORMS: tuple[int, dict[str, EntryForm], dict[str, tuple[str, ...]], tuple[str, ...]] = (
    -1,
    {},
    {},
    (),
)


def _tables() -> tuple[dict[str, EntryForm], dict[str, tuple[str, ...]], tuple[str, ...]]:
    """The entry forms, each group's menu and the first menu, read once from the registry
    (again only if a kind is declared later)."""
    global _FORMS
    if _FORMS[0] != REGISTRY.version:
        forms = {key: _form(cls, sub) for key, (cls, sub) in REGISTRY.sub_kinds().items()}
        groups = REGISTRY.first_menu(QUALIFIERS)
        menus = {
            group: tuple(
                form.key
                for form in sorted(forms.values(), key=lambda form: form.menu)
                if form.group == group and form.menu
            )
            for group in groups
            if group not in QUALIFIERS.values()
        }
        _FORMS = (REGISTRY.version, forms, menus, groups)
    return _FORMS[1], _FORMS[2], _FORMS[3]


def first_menu() -> tuple[str, ...]:
    """The first menu's choices (POS, DRILL, …, LOOP, STOP, …, POCKET), numbered from 1 in
    this order: the control's numbers."""
    return _tables()[2]


def entry_forms() -> dict[str, EntryForm]:
    """Editor key (e.g. `DRILL_CUT_RT`) → its entry form."""
    return _tables()[0]


def group_kinds() -> dict[str, tuple[str, ...]]:
    """First choice (POS, DRILL, …) → the keys of its sub-types, by menu number."""
    return _tables()[1]


def kind_of(block: Block) -> str:
    """The editor kind of an existing block."""
    return REGISTRY.sub_kind_of(block).key


# -- what may be offered where -------------------------------------------------------------


def refusal(program: Program, at: int, key: str) -> str:
    """Why sub-kind `key` cannot be entered as block `at` ("" when it can)."""
    cls, sub = REGISTRY.sub_kinds()[key]
    return REGISTRY.refusal(cls, sub, program.blocks, at)


@dataclass(frozen=True)
class Choice:
    """One line of a menu: its number (always the same for the same choice), what it
    chooses, its title, and why it cannot be chosen here ("" when it can)."""

    number: int
    key: str
    title: str
    reason: str = ""


def group_menu(program: Program, at: int, loop: bool = False, stop: bool = False) -> list[Choice]:
    """The first menu for block `at`: every choice, numbered as always (the control's order),
    those that do not fit here (given the LOOP and STOP already chosen) with the reason."""
    choices = []
    for number, group in enumerate(first_menu(), start=1):
        reason = ""
        if group == "LOOP":
            if loop:
                reason = "is chosen already"
            elif open_loops(program.blocks, at - 1) >= limits.MAX_LOOP_DEPTH:
                reason = "sequences nest at most 4 deep; close one with REP first"
        elif group == "STOP":
            reason = "is chosen already" if stop else ""
        elif (loop or stop) and group in ("REP", "COPY"):
            reason = "takes no LOOP or STOP qualifier"
        elif loop and group not in REGISTRY.loop_groups():
            reason = REGISTRY.loop_refusal()
        else:
            reasons = [refusal(program, at, key) for key in group_kinds().get(group, ())]
            if reasons and all(reasons):
                reason = reasons[0]
        choices.append(Choice(number, group, group, reason))
    return choices


def sub_menu(program: Program, at: int, group: str) -> list[Choice]:
    """The sub-types of `group` for block `at`, each with its own number (its declaration's)
    and, where it does not fit here, the reason."""
    forms = entry_forms()
    return [
        Choice(forms[key].menu, key, forms[key].title, refusal(program, at, key))
        for key in group_kinds().get(group, ())
    ]


# -- values --------------------------------------------------------------------------------


def field_values(block: Block, following: Block | None = None) -> dict[str, str]:
    """A block's values as form text (an ARC XY-CENT also shows its XY-END)."""
    values = {f.name: _text(getattr(block, f.name)) for f in REGISTRY.fields(type(block))}
    then = REGISTRY.sub_kind_of(block).then
    if then is not None and isinstance(following, then):
        extras = {f.name for f in extra_fields(then, SubKind("", "", ""))}
        for f in REGISTRY.fields(then):
            if f.prompt.prompted or f.name in extras:
                values["end_" + f.name] = _text(getattr(following, f.name))
    return values


def _text(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "on" if value else ""
    if isinstance(value, Decimal):
        return f"{value:f}"
    if hasattr(value, "value"):
        return str(value.value)
    return str(value)


def entry_mode(blocks: tuple[Block, ...], at: int, loop: bool = False) -> Mode:
    """ABS or INC for a new block at `at` (seed 001 §3.4.5.1): the mode the machinist last
    chose with the INC key (that of the last positioned block outside LOOP sequences),
    carried to new blocks; INC for a LOOP block and inside a LOOP sequence, where the
    control programs every block in INC by itself."""
    if loop or open_loops(blocks, at - 1):
        return Mode.INC
    mode, depth = Mode.ABS, 0
    for block in blocks[: at - 1]:
        kind = REGISTRY.of(block)
        if block.loop and kind.loopable:
            depth += 1
        elif isinstance(block, Rep):
            depth = max(0, depth - 1)
        elif depth == 0 and kind.positioned:
            mode = block.mode
    return mode


def defaults_for(program: Program, at: int, kind: str, loop: bool = False) -> dict[str, str]:
    """Values offered for a new block `at` of sub-kind `kind`, from the sequence being cut.

    Each value comes from the nearest block before that has the field: first from the mill
    sequence the block continues (a MILL STD after an ARC's XY-END takes the contour's tool,
    Z DN and FEEDR XY), then from blocks of the same kind, then from any block; else the
    declared default. X and Y offer where the table is: in INC the step of the block before
    when it was an INC step too, else 0 (a LOOP DRILL after an ABS POS starts where it is);
    in ABS the position reached.
    """
    blocks = program.blocks[: at - 1]
    units = blocks[-1].units if blocks else program.units
    if kind == "COPY":
        return {"units": units.value, "from_block": "1", "to_block": str(at - 1)}
    cls, sub = REGISTRY.sub_kinds()[kind]
    mode = entry_mode(program.blocks, at, loop)
    values = {"units": units.value, "mode": mode.value}
    sequence, rest = _search_order(blocks, cls)
    order = [*sequence, *rest]
    from_sequence: set[str] = set()
    for f in REGISTRY.prompted(cls, sub):
        if f.prompt.role in (Role.X, Role.Y):
            continue
        found = next(
            (getattr(b, f.name) for b in order if getattr(b, f.name, None) is not None), None
        )
        if any(getattr(b, f.name, None) is not None for b in sequence):
            from_sequence.add(f.name)
        values[f.name] = _text(f.default if found is None else found)
    if "tool" in values and values["tool"] == "":
        block0 = program.block0
        values["tool"] = str(block0.current_tool or (block0.tools[0].number if block0.tools else 1))
    if "tool" in values and program.material is not None:
        # The feeds of the stated material for the block's tool (app.cnc.cutting), where
        # the sequence being cut does not give them (a contour keeps its feed).
        offered = feed_offers(program).for_tool(_whole_or_zero(values["tool"]))
        for name, value in offered.items():
            if name in values and name not in from_sequence:
                values[name] = value
    if "placement" in values and values["placement"] == "":
        values["placement"] = "inside"
    if REGISTRY.kind(cls).positioned:
        values.update(_position(blocks, mode, units))
    return values


def _whole_or_zero(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        return 0


def _search_order(blocks: tuple[Block, ...], cls: type[Block]) -> tuple[list[Block], list[Block]]:
    """The blocks a new block of kind `cls` takes its values from, in the order asked: the
    mill sequence it continues, then the others."""
    nearest = blocks[::-1]
    start = len(blocks)
    if REGISTRY.kind(cls).mill is not None:
        while start and REGISTRY.of(blocks[start - 1]).mill is not None:
            start -= 1
        if start < len(blocks) and start and starts_mill_sequence(blocks, start - 1):
            start -= 1
    sequence = list(blocks[start:][::-1])
    same = [b for b in nearest if isinstance(b, cls)]
    return sequence, [*same, *nearest]


def _position(blocks: tuple[Block, ...], mode: Mode, units: Units) -> dict[str, str]:
    """X and Y offered for a new positioned block (see `defaults_for`)."""
    kinds = [(b, REGISTRY.of(b)) for b in blocks]
    points = [b for b, kind in kinds if kind.positioned and not kind.xy_is_centre]
    last = points[-1] if points else None
    if mode is Mode.INC:
        if last is not None and last.mode is Mode.INC and not REGISTRY.of(last).part:
            return _xy(last)
        return {"x": "0", "y": "0"}
    if last is None:
        return {}
    if last is blocks[-1] and last.mode is Mode.ABS:
        return _xy(last)
    x, y = table_position(blocks)
    return {axis: _text(length_of(nm, units).normalize()) for axis, nm in (("x", x), ("y", y))}


def _xy(block: Block) -> dict[str, str]:
    """A positioned block's X and Y as form text (the fields declared as its point)."""
    found = {}
    for f in REGISTRY.fields(type(block)):
        if f.prompt.role in (Role.X, Role.Y):
            found["x" if f.prompt.role is Role.X else "y"] = _text(getattr(block, f.name))
    return found


@dataclass
class Parsed:
    """The result of reading a block form: blocks (1, or 2 for an ARC), or field errors."""

    blocks: list[Block]
    errors: dict[str, str]


def parse_block(kind_key: str, form: Mapping[str, str]) -> Parsed:
    """Read a submitted block form into blocks. Errors name the field and what is allowed."""
    entry = entry_forms().get(kind_key)
    if entry is None:
        return Parsed([], {"kind": f"unknown block type {kind_key!r}"})
    errors: dict[str, str] = {}
    values: dict[str, Any] = {}
    for spec in entry.fields:
        raw = form.get(spec.name, "").strip()
        value, error = _read(spec, raw)
        if error:
            errors[spec.name] = f"{spec.label}: {error}"
        values[spec.name] = value
    for spec in entry.extras:
        value, error = _read(spec, form.get(spec.name, "").strip())
        if error:
            errors[spec.name] = f"{spec.label}: {error}"
        values[spec.name] = value
    if errors:
        return Parsed([], errors)
    return Parsed(build(kind_key, values, form), {})


def build(kind_key: str, values: Mapping[str, Any], form: Mapping[str, str]) -> list[Block]:
    """The blocks of sub-kind `kind_key` from read values (`end_…` for the block the kind
    enters with it) and the form's qualifiers, as the declarations say (app.cnc.kinds)."""
    cls, sub = REGISTRY.sub_kinds()[kind_key]
    kind = REGISTRY.kind(cls)
    units = Units.MM if form.get("units") == "mm" else Units.INCH
    mode = Mode.INC if form.get("mode") == "inc" else Mode.ABS
    stop = form.get("stop") == "on"
    common: dict[str, Any] = {"units": units, "message": form.get("message", "").strip()}
    if kind.positioned:
        common["mode"] = mode
    if kind.loopable:
        common["loop"] = form.get("loop") == "on"
    if kind.stoppable:
        common["stop"] = stop
    blocks = [cls(**common, **dict(sub.fixed), **_own(cls, sub, values, form, ""))]
    if sub.then is not None:
        # The block the control adds itself (an ARC's XY-END) takes the kind's STOP.
        then = REGISTRY.kind(sub.then)
        extra: dict[str, Any] = {"units": units}
        if then.positioned:
            extra["mode"] = mode
        if then.stoppable and not kind.stoppable:
            extra["stop"] = stop
        follower = SubKind("", "", "")
        blocks.append(sub.then(**extra, **_own(sub.then, follower, values, form, "end_")))
    return blocks


def _own(
    cls: type[Block], sub: SubKind, values: Mapping[str, Any], form: Mapping[str, str], prefix: str
) -> dict[str, Any]:
    """The block's own field values: the prompted ones read, choices made members of their
    enum; a field the form does not prompt (COPY's EXEC/CANCEL) from its button."""
    own: dict[str, Any] = {}
    prompted = {f.name for f in REGISTRY.prompted(cls, sub)}
    prompted |= {f.name for f in extra_fields(cls, sub)}
    for f in REGISTRY.fields(cls):
        if f.name in COMMON or f.name in dict(sub.fixed):
            continue
        if f.name in prompted:
            value = values.get(prefix + f.name)
        elif not f.prompt.prompted and f.prompt.value is Value.CHOICE:
            value = form.get(prefix + f.name, "")
        else:
            continue
        members = _enum_of(cls, f.name) if f.prompt.value is Value.CHOICE else None
        if members is not None:
            known = {m.value: m for m in members}
            if f.name not in prompted and value not in known:
                continue
            value = known.get(value) if value not in (None, "") else None
        own[f.name] = value
    return own


def _read(spec: FieldSpec, raw: str) -> tuple[Any, str]:
    """(value, "") or (None, what is wrong)."""
    if spec.kind == "flag":
        return raw == "on", ""
    if raw == "":
        if spec.required:
            return None, "missing; enter a value"
        return None, ""
    if spec.kind == "text":
        return raw, ""  # what it may hold is validation's (ENGRAVE's font, a MESSAGE's)
    if spec.kind == "choice":
        allowed = [value for value, _ in spec.choices]
        if raw not in allowed:
            return None, f"{raw!r} is not one of {', '.join(a for a in allowed if a)}"
        return raw, ""
    if spec.kind in ("count", "tool"):
        return read_whole(raw)
    return read_number(raw)


def read_number(raw: str) -> tuple[Decimal | None, str]:
    """(number, "") or (None, what is wrong and what is allowed): app.cnc.numbers' rules."""
    try:
        return parse_decimal(raw), ""
    except NumberError as exc:
        return None, str(exc)


def read_whole(raw: str) -> tuple[int | None, str]:
    """(whole number, "") or (None, what is wrong and what is allowed)."""
    try:
        return parse_int(raw), ""
    except NumberError as exc:
        return None, str(exc)
