"""Block kinds, each declared once: the vocabulary of the declarations and the registry.

A block kind is its dataclass in app/cnc/blocks.py. Each field is declared with `prompt()`:
the control's label, the kind of value (length, feed, angle, count, tool, flag, choice),
its limits, the editor's help, and what the value means to COPY and mirror (`Role`). The
class's `KIND` says the rest: the JSON document's `type` names, the editor's sub-types
(title, menu group and number, the field values each fixes, where it is offered), whether
X/Y is a position (ABS/INC), LOOP and STOP, the mill family and the planner of a mill
routine. The document, the editor's forms, validation's field checks, COPY and mirror read
these declarations through `REGISTRY`; none of them lists the kinds.

Adding a block kind:

1. In blocks.py, a frozen `kw_only` dataclass subclassing `Block` with `KIND = Kind(...)`
   and each field declared with `prompt(...)`; `type_name` if its title says more than
   its editor title. Declaring it registers it.
2. What it cuts. A mill routine names its planner: `Kind(mill=Mill.ROUTINE,
   planner="module:function")`, a function `(block, mill.RoutineStart) -> SequencePlan`;
   with `geometry=True` the `Mill.GEOMETRY` blocks after it are its contours
   (`RoutineStart.geometry`), as POCKET's PKT LINE / PKT ARC / ISLAND.
   Other motion is a node in structure.py and compiler.py.
3. Its own rules, if any, in validate.py, each with a case in tests/bad/.
4. A golden case (tests/golden/<name>/program.json, `make regen-golden`); its JSON `type`
   in docs/program-format.md.
"""

from __future__ import annotations

import dataclasses
import enum
import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from decimal import Decimal
from typing import TYPE_CHECKING, Any

from app.cnc.limits import FeedLimits
from app.cnc.units import Units

if TYPE_CHECKING:
    from app.cnc.blocks import Block


class Value(enum.Enum):
    """What a field holds, which says how it is typed in and checked."""

    LENGTH = "length"  # in the block's units (in or mm), to 0.001 in / 0.01 mm
    FEED = "feed"  # ipm or mm/min
    ANGLE = "angle"  # degrees, to 0.01°
    COUNT = "count"  # a whole number
    TOOL = "tool"  # a tool number, 1 to 24
    FLAG = "flag"  # on or off
    CHOICE = "choice"  # one member of an enum
    TEXT = "text"


class Role(enum.Enum):
    """What a length means geometrically, for COPY and mirror."""

    X = "x"  # the X of the point the block goes to (its centre if `Kind.xy_is_centre`),
    Y = "y"  # absolute or incremental by the block's ABS/INC
    STEP_X = "step_x"  # an increment whatever the mode (REP, COPY's XOF): mirrored by sign
    STEP_Y = "step_y"
    SIZE_X = "size_x"  # an extent from the point of the block before (FRAME XL, YW)
    SIZE_Y = "size_y"
    ANGLE = "angle"  # a direction, degrees clockwise from the lower vertical centre line


class Mill(enum.Enum):
    """The two families of mill blocks (seed 001 §3.4.5.2)."""

    CONTOUR = "contour"  # line and arc blocks: a path the tool follows
    ROUTINE = "routine"  # CIRCLE / FRAME / POCKET: a whole cut from one block
    GEOMETRY = "geometry"  # a POCKET's contour blocks: shapes its routine clears, not cut


@dataclass(frozen=True)
class Prompt:
    """One field's declaration (kept in the dataclass field's metadata).

    `low`/`high`: the allowed range of a count or tool (None: unchecked); for a length `low`
    is its minimum (None: ±the largest dimension) and `positive` asks for more than 0.
    `feed`: a feed's limits per unit. `blank`: the choice shown for no value (None).
    `only_when`: the field applies only while these other fields have these values; else
    it keeps its default (the editor does not ask for it). `changes`: on COPY, the field of
    the copied blocks this value replaces (or, for a STEP, adds to in absolute blocks).
    `prompted`: False for fields the entry form does not ask for one by one.
    `calculated`: the field may be left empty and the compile calculates it from the blocks
    around it (a contour's X/Y from the print, app.cnc.solve).
    """

    label: str
    value: Value
    low: Decimal | int | None = None
    high: int | None = None
    positive: bool = False
    feed: Mapping[Units, FeedLimits] | None = None
    role: Role | None = None
    help: str = ""
    blank: str = ""
    only_when: tuple[tuple[str, Any], ...] = ()
    changes: str = ""
    prompted: bool = True
    calculated: bool = False


def prompt(label: str, value: Value, default: Any = dataclasses.MISSING, **details: Any) -> Any:
    """A dataclass field declared with the control's prompt `label` (see `Prompt`)."""
    return dataclasses.field(default=default, metadata={"prompt": Prompt(label, value, **details)})


@dataclass(frozen=True)
class Document:
    """A JSON `type` name of a kind, and the field values that name stands for."""

    name: str
    fixed: tuple[tuple[str, Any], ...] = ()


@dataclass(frozen=True)
class SubKind:
    """A type and sub-type as the editor offers it (e.g. `DRILL_CUT_RT`).

    `group` is the first choice it sits under and `menu` its number there (0: not in a menu);
    `fixed` the field values it sets; `then` a block kind the editor enters with it (an
    ARC's XY-END); `offered(blocks, at)` says why it cannot be entered as block `at`
    (1-based), or "" when it can.
    """

    key: str
    title: str
    group: str
    menu: int = 0
    fixed: tuple[tuple[str, Any], ...] = ()
    then: type[Block] | None = None
    offered: Callable[[tuple[Block, ...], int], str] | None = None


@dataclass(frozen=True)
class Kind:
    """What a block kind is, beyond its fields (see the module docstring)."""

    documents: tuple[Document, ...]
    editor: tuple[SubKind, ...] = ()
    positioned: bool = False  # X/Y is a position: ABS/INC applies (the INC key)
    loopable: bool = False  # may carry the LOOP qualifier
    stoppable: bool = True  # may carry the STOP qualifier
    xy_is_centre: bool = False  # X/Y is a centre: the table does not go there
    part: str = ""  # entered with another block: the suffix of its X/Y prompts
    mill: Mill | None = None
    planner: str = ""  # "module:function" planning a mill routine
    geometry: bool = False  # a routine whose contour blocks (Mill.GEOMETRY) follow it


@dataclass(frozen=True)
class Field:
    """A declared field as the registry hands it out."""

    name: str
    prompt: Prompt
    default: Any
    optional: bool  # None is allowed (the default is None)

    @property
    def label(self) -> str:
        return self.prompt.label

    @property
    def required(self) -> bool:
        """The entry form asks for a value (a field whose default is None may stay empty,
        and one the compile calculates)."""
        return (
            not self.optional and self.prompt.value is not Value.FLAG and not self.prompt.calculated
        )


def _fields_of(cls: type) -> tuple[Field, ...]:
    found = []
    for f in dataclasses.fields(cls):
        declared = f.metadata.get("prompt")
        if declared is None:
            declared = Prompt(f.name.upper(), Value.TEXT, prompted=False)
        default = f.default if f.default is not dataclasses.MISSING else None
        found.append(Field(f.name, declared, default, f.default is None))
    return tuple(found)


class Registry:
    """Every declared block kind, and the tables read from the declarations (built once,
    on first use: nothing scans `dataclasses.fields` per call)."""

    def __init__(self) -> None:
        self._classes: list[type[Block]] = []
        self._fields: dict[type, tuple[Field, ...]] = {}
        self._labels: dict[type, dict[str, str]] = {}
        self._names: dict[type, dict[str, str]] = {}
        self._documents: dict[str, tuple[type[Block], dict[str, Any]]] | None = None
        self._sub_kinds: dict[str, tuple[type[Block], SubKind]] | None = None
        self._planners: dict[type, Callable[..., Any]] = {}
        self.version = 0  # counts changes, for tables read from the registry elsewhere

    def add(self, cls: type[Block]) -> None:
        """Register a block kind (Block subclasses with a `KIND` do this themselves)."""
        self._classes.append(cls)
        self._changed()

    def remove(self, cls: type[Block]) -> None:
        """Forget a kind (one declared for a test)."""
        self._classes.remove(cls)
        self._changed()

    def _changed(self) -> None:
        self.version += 1
        self._documents = None
        self._sub_kinds = None

    @property
    def classes(self) -> tuple[type[Block], ...]:
        return tuple(self._classes)

    def kind(self, cls: type[Block]) -> Kind:
        declared: Kind = cls.KIND
        return declared

    def of(self, block: Block) -> Kind:
        return self.kind(type(block))

    # -- fields --------------------------------------------------------------------------

    def fields(self, cls: type) -> tuple[Field, ...]:
        """The declared fields of a dataclass (a block kind, Data Block 0, a tool), in order."""
        found = self._fields.get(cls)
        if found is None:
            found = self._fields[cls] = _fields_of(cls)
        return found

    def label(self, cls: type, name: str) -> str:
        """The control's prompt for field `name`. Raises KeyError for an unknown field."""
        labels = self._labels.get(cls)
        if labels is None:
            labels = self._labels[cls] = {f.name: f.label for f in self.fields(cls)}
        return labels[name]

    def name_of(self, cls: type, label: str) -> str | None:
        """The field whose prompt is `label` (the first such), or None."""
        names = self._names.get(cls)
        if names is None:
            names = {}
            for f in self.fields(cls):
                names.setdefault(f.label, f.name)
            self._names[cls] = names
        return names.get(label)

    def applies(self, cls: type, field: Field, values: Mapping[str, Any]) -> bool:
        """True when `field` applies with these values of the other fields (`only_when`)."""
        return all(values.get(name) == wanted for name, wanted in field.prompt.only_when)

    # -- the JSON document ---------------------------------------------------------------

    def documents(self) -> dict[str, tuple[type[Block], dict[str, Any]]]:
        """JSON `type` → (class, the field values that name fixes)."""
        if self._documents is None:
            self._documents = {
                document.name: (cls, dict(document.fixed))
                for cls in self._classes
                for document in self.kind(cls).documents
            }
        return self._documents

    def document_of(self, block: Block) -> Document:
        """The JSON `type` of a block and the fields it stands for."""
        for document in self.of(block).documents:
            if all(getattr(block, name) == value for name, value in document.fixed):
                return document
        raise ValueError(f"{type(block).__name__} has no document type for {block!r}")

    # -- the editor ------------------------------------------------------------------------

    def sub_kinds(self) -> dict[str, tuple[type[Block], SubKind]]:
        """Editor key → (class, sub-kind), in declaration order."""
        if self._sub_kinds is None:
            self._sub_kinds = {
                sub.key: (cls, sub) for cls in self._classes for sub in self.kind(cls).editor
            }
        return self._sub_kinds

    def sub_kind_of(self, block: Block) -> SubKind:
        """The editor sub-kind of a block: the first whose fixed values it has."""
        for sub in self.of(block).editor:
            if all(getattr(block, name) == value for name, value in sub.fixed):
                return sub
        raise ValueError(f"{type(block).__name__} has no editor sub-kind for {block!r}")

    def prompted(self, cls: type[Block], sub: SubKind) -> tuple[Field, ...]:
        """The fields the entry form of `sub` asks for, in the control's order."""
        fixed = dict(sub.fixed)
        values = {f.name: fixed.get(f.name, f.default) for f in self.fields(cls)}
        return tuple(
            f
            for f in self.fields(cls)
            if f.prompt.prompted and f.name not in fixed and self.applies(cls, f, values)
        )

    # -- planners ------------------------------------------------------------------------

    def planner(self, cls: type[Block]) -> Callable[..., Any]:
        """The function planning a mill routine of kind `cls` (imported on first use)."""
        found = self._planners.get(cls)
        if found is None:
            where = self.kind(cls).planner
            if not where:
                raise LookupError(f"{cls.__name__} declares no planner")
            module, name = where.split(":")
            found = self._planners[cls] = getattr(importlib.import_module(module), name)
        return found

    def mill_classes(self, family: Mill) -> tuple[type[Block], ...]:
        return tuple(cls for cls in self._classes if self.kind(cls).mill is family)


REGISTRY = Registry()
