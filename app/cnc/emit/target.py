"""Export targets: one registry, typed options, and the compatibility report.

In the manner of sqlglot's dialects: every target turns the same Toolpath (and, for the
structural ProtoTRAK Plus events, the Program) into its own bytes, declares its options,
and reports through one `Report` what it could not express — nothing is dropped silently.

A target module registers itself with `@register` when imported; `targets()` imports every
module of this package once, so a new target is a new file.
"""

from __future__ import annotations

import enum
import importlib
import pkgutil
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass, field
from decimal import Decimal
from typing import Any, ClassVar

from app.cnc.blocks import Program
from app.cnc.copy import resolve_copies
from app.cnc.interpret import interpret
from app.cnc.machine import MachineModel, check_travel
from app.cnc.needs import unmet
from app.cnc.numbers import NumberError, parse_decimal
from app.cnc.problems import Need, Problem, blocking
from app.cnc.toolpath import Toolpath
from app.cnc.validate import validate


class OptionKind(enum.Enum):
    """How an option's text value is read."""

    BOOL = "bool"
    INT = "int"
    DECIMAL = "decimal"
    CHOICE = "choice"
    TEXT = "text"


class OptionError(ValueError):
    """An option that does not exist for the target or whose value cannot be read."""


_TRUE = {"1", "true", "yes", "on"}
_FALSE = {"0", "false", "no", "off"}


@dataclass(frozen=True)
class Option:
    """One export option: its name (as on the command line), kind, default and meaning."""

    name: str
    kind: OptionKind
    default: Any
    help: str
    choices: tuple[str, ...] = ()
    minimum: Decimal | None = None
    maximum: Decimal | None = None

    def parse(self, raw: str) -> Any:
        """The value of `raw` for this option. Raises OptionError saying what is allowed."""
        text = raw.strip()
        if self.kind is OptionKind.BOOL:
            if text.lower() in _TRUE:
                return True
            if text.lower() in _FALSE:
                return False
            raise OptionError(f"option {self.name}: {raw!r} is not yes/no (true/false, 1/0)")
        if self.kind is OptionKind.CHOICE:
            if text not in self.choices:
                allowed = ", ".join(self.choices)
                raise OptionError(f"option {self.name}: {raw!r} is not one of {allowed}")
            return text
        if self.kind is OptionKind.TEXT:
            return raw
        try:
            number = parse_decimal(text)
        except NumberError as exc:
            raise OptionError(f"option {self.name}: {exc}") from None
        if self.kind is OptionKind.INT and number != number.to_integral_value():
            raise OptionError(f"option {self.name}: {raw!r} is not a whole number")
        low, high = self.minimum, self.maximum
        if (low is not None and number < low) or (high is not None and number > high):
            raise OptionError(
                f"option {self.name}: {raw} is outside the allowed range {low} to {high}"
            )
        return int(number) if self.kind is OptionKind.INT else number


class Severity(enum.Enum):
    """What a report entry means for the user."""

    ERROR = "error"  # the target cannot take the program: no output
    LOST = "lost"  # something the program says that the target does not carry
    REWRITTEN = "rewritten"  # expressed differently, with the same result on the part
    WARNING = "warning"  # output made, but worth the programmer's look
    NOTE = "note"  # how the output was made


@dataclass(frozen=True)
class Entry:
    """One line of a compatibility report. `block` is None for the whole program."""

    severity: Severity
    block: int | None
    message: str

    def __str__(self) -> str:
        where = "program" if self.block is None else f"block {self.block}"
        return f"{self.severity.value}: {where}: {self.message}"


@dataclass
class Report:
    """What a target did with a program: errors, losses, rewrites, warnings, notes."""

    target: str
    entries: list[Entry] = field(default_factory=list)

    def add(self, severity: Severity, block: int | None, message: str) -> None:
        entry = Entry(severity, block, message)
        if entry not in self.entries:
            self.entries.append(entry)

    def unsupported(self, block: int | None, message: str) -> None:
        """The one call for what the target cannot express (a loss, not an error)."""
        self.add(Severity.LOST, block, message)

    def error(self, block: int | None, message: str) -> None:
        self.add(Severity.ERROR, block, message)

    def rewritten(self, block: int | None, message: str) -> None:
        self.add(Severity.REWRITTEN, block, message)

    def warning(self, block: int | None, message: str) -> None:
        self.add(Severity.WARNING, block, message)

    def note(self, block: int | None, message: str) -> None:
        self.add(Severity.NOTE, block, message)

    @property
    def has_errors(self) -> bool:
        return any(e.severity is Severity.ERROR for e in self.entries)

    def text(self) -> str:
        """The report as lines, errors first, then in block order."""
        order = list(Severity)
        entries = sorted(
            self.entries,
            key=lambda e: (order.index(e.severity), -1 if e.block is None else e.block),
        )
        lines = [f"Compatibility report for {self.target}:"]
        lines += [f"  {e}" for e in entries] or ["  nothing lost or rewritten"]
        return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class Export:
    """An export's bytes, how to name and serve them, and its report."""

    target: str
    data: bytes
    extension: str
    media_type: str
    report: Report


class ExportError(ValueError):
    """The program cannot be exported: validation errors, or the target's own errors."""

    def __init__(self, message: str, problems: list[Problem], report: Report | None) -> None:
        super().__init__(message)
        self.problems = problems
        self.report = report


class Target(ABC):
    """An output format. Subclasses set the class attributes and implement `emit`."""

    name: ClassVar[str]
    description: ClassVar[str]
    extension: ClassVar[str]
    media_type: ClassVar[str] = "text/plain; charset=us-ascii"
    options: ClassVar[tuple[Option, ...]] = ()
    # What the target needs from a program beyond what every consumer needs (a program
    # that lacks it is refused by this target alone, naming the blocks).
    needs: ClassVar[frozenset[Need]] = frozenset()

    def needs_for(self, options: Mapping[str, Any]) -> frozenset[Need]:
        """The needs with these (parsed) options; a target whose options change what it
        needs (a tape with spindle codes needs speeds) overrides this."""
        return self.needs

    def need_hint(self, need: Need) -> str:
        """What else the user may do when a program lacks `need` (an option), or ""."""
        return ""

    @abstractmethod
    def emit(
        self, program: Program, toolpath: Toolpath, options: Mapping[str, Any], report: Report
    ) -> bytes:
        """The output for a validated program. Report what cannot be expressed; errors
        (report.error) make the export fail. Must be a pure function of its arguments."""

    def parse_options(self, raw: Mapping[str, str]) -> dict[str, Any]:
        """Defaults overridden by `raw` (name → text). Raises OptionError for unknown names."""
        known = {option.name: option for option in self.options}
        values = {option.name: option.default for option in self.options}
        for given, text in raw.items():
            # sequence_numbers and sequence-numbers name the same option.
            name = given.replace("_", "-")
            name = name if name in known else given
            if name not in known:
                allowed = ", ".join(sorted(known)) or "none"
                raise OptionError(f"{self.name} has no option {name!r}; its options: {allowed}")
            values[name] = known[name].parse(text)
        return values


_REGISTRY: dict[str, Target] = {}
_LOADED = False


def register(cls: type[Target]) -> type[Target]:
    """Class decorator: make a target available by its name."""
    if cls.name in _REGISTRY:
        raise ValueError(f"two targets named {cls.name}")
    _REGISTRY[cls.name] = cls()
    return cls


def targets() -> dict[str, Target]:
    """Every target, by name (each module of this package is imported once)."""
    global _LOADED
    if not _LOADED:
        package = importlib.import_module("app.cnc.emit")
        for module in sorted(pkgutil.iter_modules(package.__path__), key=lambda m: m.name):
            importlib.import_module(f"app.cnc.emit.{module.name}")
        _LOADED = True
    return dict(sorted(_REGISTRY.items()))


def get_target(name: str) -> Target:
    """The target called `name`. Raises OptionError naming the targets there are."""
    found = targets().get(name)
    if found is None:
        raise OptionError(f"no export target {name!r}; targets: {', '.join(targets())}")
    return found


def export(
    program: Program,
    name: str,
    raw_options: Mapping[str, str] | None = None,
    machine: MachineModel | None = None,
) -> Export:
    """Export `program` (COPY blocks carried out) to target `name`.

    With a `machine`, every move is checked against its travel limits and collision zone,
    and a crossing is an error naming the block. Raises OptionError for bad options and
    ExportError when the program has validation errors or the target (or the machine)
    reports errors.
    """
    target = get_target(name)
    options = target.parse_options(raw_options or {})
    program = resolve_copies(program)
    needs = target.needs_for(options)
    # The control's needs are checked by validation; a target has its own (and may lack
    # some of the control's: events and JSON never need spindle speeds).
    problems = [p for p in validate(program) if p.need is None]
    toolpath = None if blocking(problems) else interpret(program)
    problems += unmet(program, needs, toolpath) if toolpath is not None else []
    stopping = blocking(problems, needs)
    if stopping:
        missing = sorted({p.need for p in stopping if p.need is not None}, key=lambda n: n.value)
        if missing and all(p.need is not None for p in stopping):
            hints = [h for h in (target.need_hint(n) for n in missing) if h]
            message = f"{target.name} needs {', '.join(n.value for n in missing)}" + "".join(
                f"; {h}" for h in hints
            )
        else:
            message = "the program has errors; fix them before exporting"
        raise ExportError(message, stopping, None)
    report = Report(target.name)
    assert toolpath is not None
    for need in sorted(needs, key=lambda n: n.value):
        report.note(None, f"this target needs {need.value}: the program has them")
    if machine is not None:
        for crossing in check_travel(toolpath, machine):
            report.error(crossing.block, crossing.message)
    data = target.emit(program, toolpath, options, report)
    if report.has_errors:
        raise ExportError(f"{target.name} cannot take this program", problems, report)
    return Export(target.name, data, target.extension, target.media_type, report)
