"""Block kinds, each declared once: the vocabulary of the declarations and the registry.

A block kind is its dataclass in app/cnc/blocks.py. Each field is declared with `prompt()`:
the control's label, the kind of value (length, feed, angle, count, tool, flag, choice),
its limits, the editor's help, and what the value means to COPY and mirror (`Role`). The
class's `KIND` says the rest: the JSON document's `type` names, the editor's sub-types
(title, menu group and number, the field values each fixes, where it is offered), whether
X/Y is a position (ABS/INC), LOOP and STOP, the mill family and the planner of a mill
routine, its order rule (`Follows`: what may stand right before it) and which of its
findings are the compile's (`findings`). The document, the editor's forms and menus,
validation, structure, the preview, COPY and mirror read these declarations through
`REGISTRY`; none of them lists the kinds.

Adding a block kind (docs/adding-a-kind.md has the whole recipe, with what it touches):

1. In blocks.py, a frozen `kw_only` dataclass subclassing `Block` with `KIND = Kind(...)`
   and each field declared with `prompt(...)`; `type_name` if its title says more than
   its editor title. Declaring it registers it. Its order rule is `follows=Follows(...)`
   (the block before it: JSON types and mill families), which validation reports, structure
   groups by and the editor's menus grey: no other file changes for it.
2. What it cuts. A mill routine names its planner: `Kind(mill=Mill.ROUTINE,
   planner="module:function")`, a function `(block, mill.RoutineStart) -> SequencePlan`;
   with `geometry=True` the `Mill.GEOMETRY` blocks after it are its contours
   (`RoutineStart.geometry`), as POCKET's PKT LINE / PKT ARC / ISLAND. The rules its
   planner finds go in `findings` (the preview compiles a block with only those as it is).
   Other motion is a node in compiler.py. Its moves estimate, for the bound cost.py checks
   before any compile, is `cost="module:function"`; a first-menu choice of its own is
   `choices=((number, name),)`.
3. Its own rules beyond its order, if any, in validate.py, each with a case in tests/bad/.
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
from app.cnc.problems import Rule
from app.cnc.units import Units

if TYPE_CHECKING:
    from app.cnc.blocks import Block


def matches(value: Any, wanted: Any) -> bool:
    """True when `value` is what an `only_when` condition wants: the value, or any of a
    frozenset of values."""
    return value in wanted if isinstance(wanted, frozenset) else bool(value == wanted)


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
    """What a value means geometrically, for COPY and mirror."""

    X = "x"  # the X of the point the block goes to (its centre if `Kind.xy_is_centre`),
    Y = "y"  # absolute or incremental by the block's ABS/INC
    STEP_X = "step_x"  # an increment whatever the mode (REP, COPY's XOF): mirrored by sign
    STEP_Y = "step_y"
    SIZE_X = "size_x"  # an extent from the point of the block before (FRAME XL, YW)
    SIZE_Y = "size_y"
    ANGLE = "angle"  # a direction, degrees clockwise from the lower vertical centre line
    # CW or CCW seen from above. Mirror reverses it in a shape reflected as it stands
    # (Mill.GEOMETRY); a cut (Mill.CONTOUR) is run backwards instead and keeps it.
    TURN = "turn"


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
    `only_when`: the field applies only while these other fields have these values (a
    frozenset: any of its values); else it keeps its default (the editor does not ask for
    it). `changes`: on COPY, the field of the copied blocks this value replaces (or, for a
    STEP, adds to in absolute blocks).
    `prompted`: False for fields the entry form does not ask for one by one.
    `beside`: asked beside the control's own prompts, outside their Enter sequence (an
    option the control never prompted for: a POCKET's ENTRY), as a field with `only_when`
    is.
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
    beside: bool = False
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
class Follows:
    """A kind's order rule: what the block right before it must be. Validation checks it,
    structure groups by it (a block joins the node of the block it follows) and the editor
    greys the kind's menu lines where it fails; nothing else knows it.

    `after` names what may stand right before: JSON `type` names (`"DRILL"`: a DRILL of any
    cutter compensation) and mill families (`Mill.CONTOUR`: any of its kinds, those declared
    later too). `same`: fields the block before must have equal (a BOLT CIR's operation).
    `what` is what must come before, as messages say it after "must follow" (validation)
    and "follows" (the editor), formatted with the block's values (`{op.value}`);
    `message` validation's whole message, formatted with `{type_name}`, `{what}` and
    `{before}` ("block 1 is POS" or "it is first"); `rule` its code. `in_menu` False: the
    editor offers the kind anywhere and only validation says it is out of place (MILL,
    CIRCLE and FRAME, whose menus have always offered them so).
    """

    after: tuple[str | Mill, ...]
    what: str
    rule: Rule
    same: tuple[str, ...] = ()
    message: str = "{type_name} must follow {what}; {before}"
    in_menu: bool = True


@dataclass(frozen=True)
class Kind:
    """What a block kind is, beyond its fields (see the module docstring).

    `follows`: its order rule (None: it may stand anywhere). `findings`: the rules the
    compile finds in a block of this kind (its geometry, as its planner judges it): the
    preview compiles a block whose only errors are these as it stands and shows where its
    cut is left out; a block with any other error is left out of the drawing.
    """

    documents: tuple[Document, ...]
    editor: tuple[SubKind, ...] = ()
    positioned: bool = False  # X/Y is a position: ABS/INC applies (the INC key)
    loopable: bool = False  # may carry the LOOP qualifier
    stoppable: bool = True  # may carry the STOP qualifier
    xy_is_centre: bool = False  # X/Y is a centre: the table does not go there
    part: str = ""  # entered with another block: the suffix of its X/Y prompts
    mill: Mill | None = None
    planner: str = ""  # "module:function" planning a mill routine
    # "module:function" estimating, from its numbers before any of its work, the moves of
    # a block of this kind (cost.py, "Bounded work"): (program, block) -> int for a block
    # standing alone (HELIX); for a Mill.ROUTINE, (program, blocks, sequence) -> cost.Size
    # for its mill sequence, less the drill's rows. "": cost.py counts it by its node (a
    # hole, contour blocks a few elements each, anything else a move to X/Y).
    cost: str = ""
    # "module:function" cutting a block that stands alone (an operation: HELIX, THREAD MILL,
    # FACE, ENGRAVE) at its X/Y: (compiler, block number, block, (x, y) in nm) -> None,
    # emitting its moves through the compiler's motion methods. "": not an operation.
    cut: str = ""
    # The editor's first-menu choices this kind opens, (number, name): the control's
    # numbers (POCKET is 10, key 0); other kinds' sub-kinds may sit under them too.
    choices: tuple[tuple[int, str], ...] = ()
    geometry: bool = False  # a routine whose contour blocks (Mill.GEOMETRY) follow it
    follows: Follows | None = None
    findings: frozenset[Rule] = frozenset()


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
        self._functions: dict[tuple[type, str], Callable[..., Any]] = {}
        self._geometry_rules: frozenset[Rule] | None = None
        self._named: dict[int, dict[type, bool | None]] = {}
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
        self._geometry_rules = None
        self._named = {}

    @property
    def classes(self) -> tuple[type[Block], ...]:
        return tuple(self._classes)

    def kind(self, cls: type[Block]) -> Kind:
        declared: Kind = cls.KIND
        return declared

    def of(self, block: Block) -> Kind:
        declared: Kind = block.KIND
        return declared

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
        return all(matches(values.get(name), wanted) for name, wanted in field.prompt.only_when)

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
        """The fields the entry form of `sub` asks for, in the control's order. A field
        that applies only while another prompt has some value (`only_when` naming a field
        `sub` does not fix, as a pocket's ENTRY names PLACEMENT) is asked for, and the form
        shows it while that prompt has that value (`shown_when`)."""
        fixed = dict(sub.fixed)
        return tuple(
            f
            for f in self.fields(cls)
            if f.prompt.prompted
            and f.name not in fixed
            and all(matches(fixed[name], w) for name, w in f.prompt.only_when if name in fixed)
        )

    def shown_when(self, field: Field, sub: SubKind) -> tuple[tuple[str, Any], ...]:
        """The conditions of `field` the entry form of `sub` checks as its prompts change:
        those on fields `sub` does not fix."""
        fixed = dict(sub.fixed)
        return tuple((name, v) for name, v in field.prompt.only_when if name not in fixed)

    # -- order ---------------------------------------------------------------------------

    def joins(self, previous: Block | None, block: Block) -> bool:
        """True when `block` has an order rule and meets it right after `previous` (None:
        it is first): it belongs with that block (a BOLT CIR with its centre, a mill block
        with its sequence). False for a kind that may stand anywhere."""
        follows = block.KIND.follows
        return follows is not None and self._accepts(follows, previous, block.__dict__)

    def out_of_order(self, previous: Block | None, block: Block, number: int) -> str:
        """Validation's message when block `number` (1-based) breaks its kind's order rule
        right after `previous` (None: it is first), or "" when it does not."""
        follows = self.of(block).follows
        if follows is None or self._accepts(follows, previous, block.__dict__):
            return ""
        before = f"block {number - 1} is {previous.title}" if previous else "it is first"
        what = follows.what.format_map(block.__dict__)
        return follows.message.format(type_name=block.type_name, what=what, before=before)

    def refusal(self, cls: type[Block], sub: SubKind, blocks: tuple[Block, ...], at: int) -> str:
        """Why the editor cannot enter sub-kind `sub` as block `at` (1-based), or "": its
        kind's order rule (where `Follows.in_menu`), then the sub-kind's own `offered`."""
        follows = self.kind(cls).follows
        previous = blocks[at - 2] if at >= 2 else None
        fixed = dict(sub.fixed)
        if follows is not None and follows.in_menu and not self._accepts(follows, previous, fixed):
            return "follows " + follows.what.format_map(fixed)
        return sub.offered(blocks, at) if sub.offered else ""

    def _accepts(self, follows: Follows, previous: Block | None, values: Mapping[str, Any]) -> bool:
        if previous is None:
            return False
        # Whether the kind before is one `follows` names, once per pair of kinds (structure
        # asks for every block of a program); a kind with several JSON types (DRILL, BORE,
        # TAP) is asked block by block.
        table = self._named.get(id(follows))
        if table is None:
            table = self._named[id(follows)] = {}
        cls = type(previous)
        if cls in table:
            named = table[cls]
        else:
            kind = previous.KIND
            if kind.mill in follows.after or all(d.name in follows.after for d in kind.documents):
                named = True
            elif not any(d.name in follows.after for d in kind.documents):
                named = False
            else:
                named = None
            table[cls] = named
        if named is None:
            named = self.document_of(previous).name in follows.after
        return named and (
            not follows.same
            or all(getattr(previous, name, None) == values.get(name) for name in follows.same)
        )

    # -- qualifiers ------------------------------------------------------------------------

    def loop_groups(self) -> tuple[str, ...]:
        """The editor's first-menu choices whose blocks may carry LOOP (`Kind.loopable`), in
        declaration order: POS, DRILL, BORE, TAP."""
        groups = dict.fromkeys(
            sub.group
            for cls in self._classes
            if self.kind(cls).loopable
            for sub in self.kind(cls).editor
        )
        return tuple(groups)

    def loop_refusal(self) -> str:
        """Why a block of a kind that is not `loopable` cannot carry LOOP, as validation
        and the editor say it: "cannot carry LOOP; a LOOP is a POS, DRILL, BORE or TAP block"."""
        *most, last = self.loop_groups()
        names = f"{', '.join(most)} or {last}" if most else last
        return f"cannot carry LOOP; a LOOP is a {names} block"

    def first_menu(self, qualifiers: Mapping[int, str]) -> tuple[str, ...]:
        """The editor's first menu in the control's order: the choices the kinds declare
        (`Kind.choices`) and `qualifiers` (LOOP and STOP, which are not kinds), by number.
        Raises ValueError when two choices claim one number or a number is left out."""
        numbered: dict[int, str] = dict(qualifiers)
        for cls in self._classes:
            for number, name in self.kind(cls).choices:
                if numbered.setdefault(number, name) != name:
                    raise ValueError(
                        f"{cls.__name__}: first-menu choice {number} is {numbered[number]}, "
                        f"not {name}"
                    )
        if sorted(numbered) != list(range(1, len(numbered) + 1)):
            raise ValueError(f"the first menu's numbers are {sorted(numbered)}, not 1 to n")
        for cls in self._classes:
            for sub in self.kind(cls).editor:
                if sub.menu and sub.group not in numbered.values():
                    raise ValueError(
                        f"{cls.__name__}: {sub.title} sits under {sub.group}, which no kind "
                        "declares in its choices"
                    )
        return tuple(numbered[number] for number in sorted(numbered))

    # -- findings --------------------------------------------------------------------------

    def geometry_rules(self) -> frozenset[Rule]:
        """Every rule some kind's compile finds (`Kind.findings`)."""
        if self._geometry_rules is None:
            self._geometry_rules = frozenset().union(
                *(self.kind(cls).findings for cls in self._classes)
            )
        return self._geometry_rules

    # -- planners ------------------------------------------------------------------------

    def planner(self, cls: type[Block]) -> Callable[..., Any]:
        """The function planning a mill routine of kind `cls` (imported on first use).
        Raises LookupError when `cls` declares none."""
        found = self._function(cls, "planner")
        if found is None:
            raise LookupError(f"{cls.__name__} declares no planner")
        return found

    def estimator(self, cls: type[Block]) -> Callable[..., Any] | None:
        """The function estimating the moves of a block of kind `cls` (`Kind.cost`, imported
        on first use), or None when it declares none."""
        return self._function(cls, "cost")

    def cutter(self, cls: type[Block]) -> Callable[..., Any] | None:
        """The function cutting an operation of kind `cls` (`Kind.cut`, imported on first
        use), or None when it declares none."""
        return self._function(cls, "cut")

    def _function(self, cls: type[Block], attribute: str) -> Callable[..., Any] | None:
        """The "module:function" a kind declares as `attribute`, imported once."""
        found = self._functions.get((cls, attribute))
        if found is None:
            where: str = getattr(self.kind(cls), attribute)
            if not where:
                return None
            module, name = where.split(":")
            found = getattr(importlib.import_module(module), name)
            self._functions[(cls, attribute)] = found
        return found

    def mill_classes(self, family: Mill) -> tuple[type[Block], ...]:
        return tuple(cls for cls in self._classes if self.kind(cls).mill is family)


REGISTRY = Registry()
