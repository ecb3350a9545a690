"""Export targets: one registry, typed options, abilities, and the compatibility report.

In the manner of sqlglot's dialects: every target turns the same compiled program (its
moves in chunks, with the hole and mill spans kept; for the structural ProtoTRAK Plus
events, the Program too) into its own bytes, declares its options and what it can do, and
reports through one `Report` what it could not express — nothing is dropped silently.

A target writes as it goes (`Target.write` to a binary stream), so an export's memory does
not grow with the program: `export()` spools the bytes to a temporary file past 1 MB and
hands back an `Export` to read them from, whole (`data`) or in pieces (`chunks`).

A target registers itself with `@register` when its module is imported. Which module that
is, app.cnc.formats.TARGET_MODULES says: `get_target(name)` imports that module alone (an
export loads its own target, not every format), `targets()` imports them all —
app/cnc/formats/__init__.py has the checklist for a new target.
"""

from __future__ import annotations

import enum
import importlib
import weakref
from abc import ABC
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field, replace
from typing import Any, BinaryIO, ClassVar, Protocol

from app.cnc.blocks import Program
from app.cnc.compiler import compile_program
from app.cnc.copy import CopyError, resolve_copies
from app.cnc.machine import MachineModel, check_spindle, check_travel
from app.cnc.needs import unmet
from app.cnc.options import Option, OptionError, OptionKind
from app.cnc.path import CompiledPath
from app.cnc.places import Places, more_text
from app.cnc.problems import Need, Problem, blocking
from app.cnc.problems import Severity as ProblemSeverity
from app.cnc.sizes import OutputTooLarge
from app.cnc.toolpath import Toolpath
from app.cnc.validate import validate

__all__ = [
    "Entry",
    "Export",
    "ExportError",
    "Option",
    "OptionError",
    "OptionKind",
    "Report",
    "Severity",
    "Target",
    "export",
    "get_target",
    "register",
    "targets",
]

# An export's bytes stay in memory up to this size, then go to a temporary file.
SPOOL_BYTES = 1 << 20


class Out(Protocol):
    """Where a target writes its bytes (a binary file, a spool, a socket's writer)."""

    def write(self, data: bytes, /) -> int: ...


class Severity(enum.Enum):
    """What a report entry means for the user."""

    ERROR = "error"  # the target cannot take the program: no output
    LOST = "lost"  # something the program says that the target does not carry
    REWRITTEN = "rewritten"  # expressed differently, with the same result on the part
    WARNING = "warning"  # output made, but worth the programmer's look
    NOTE = "note"  # how the output was made


@dataclass(frozen=True)
class Entry:
    """One line of a compatibility report. `block` is None for the whole program.

    An entry that recurs (`same`: the text its places share, e.g. "arcs written as
    chords") is one entry: `message` is its first place's, `count` how many times it was
    reported, `places` the next few places by name and `more` how many further places are
    not named (app.cnc.places)."""

    severity: Severity
    block: int | None
    message: str
    same: str = ""
    count: int = 1
    places: tuple[str, ...] = ()
    more: int = 0

    def __str__(self) -> str:
        return f"{self.severity.value}: {self.reason}"

    @property
    def reason(self) -> str:
        """Where and what, without the severity: `program: 1203 events: line numbers run
        to 999 (seed 003 §2.2.4)`."""
        where = "program" if self.block is None else f"block {self.block}"
        return f"{where}: {self.message}{self.recurring}"

    @property
    def recurring(self) -> str:
        """` (… N in all; also at …)` for an entry reported at several places, else ""."""
        if self.count == 1:
            return ""
        also = f"; also at {', '.join(self.places)}" if self.places else ""
        return f" ({self.same}: {self.count} in all{also}{more_text(self.more)})"


@dataclass
class Report:
    """What a target did with a program: errors, losses, rewrites, warnings, notes (each
    entry once, in the order first reported; an entry that recurs with its own details at
    each place is one entry counting them, `Entry`)."""

    target: str
    _entries: list[Entry] = field(default_factory=list, repr=False)
    _index: dict[tuple[object, ...], int] = field(default_factory=dict, repr=False)
    _places: dict[int, Places[str]] = field(default_factory=dict, repr=False)

    @property
    def entries(self) -> list[Entry]:
        """The entries, in the order first reported, each with its count and places."""
        out = self._entries[:]
        for k, seen in self._places.items():
            out[k] = replace(out[k], count=seen.count, places=tuple(seen.named), more=seen.more)
        return out

    def add(
        self,
        severity: Severity,
        block: int | None,
        message: str,
        same: str = "",
        at: str = "",
    ) -> None:
        """Report `message` at `block`. Without `same`, the same message at the same block
        is reported once. With `same` (the text every place shares; `message` is this
        place's own), every place of that severity is one entry: the first place's message,
        how many places, and the next few by name (`at`, by default `block N`)."""
        key: tuple[object, ...] = (severity, same) if same else (severity, block, message)
        index = self._index.get(key)
        name = at or ("program" if block is None else f"block {block}")
        if index is None:
            self._index[key] = len(self._entries)
            self._entries.append(Entry(severity, block, message, same))
            if same:
                self._places[len(self._entries) - 1] = Places(name)
            return
        seen = self._places.get(index)
        if seen is not None:
            seen.add(name)

    def merge(self, other: Report) -> None:
        """`other`'s entries after this report's, as if each place had been reported here
        (a stage's report into the export's)."""
        for k, entry in enumerate(other._entries):
            seen = other._places.get(k)
            if seen is None:
                self.add(entry.severity, entry.block, entry.message, entry.same)
                continue
            key = (entry.severity, entry.same)
            index = self._index.get(key)
            if index is None:
                self._index[key] = len(self._entries)
                self._entries.append(entry)
                self._places[len(self._entries) - 1] = seen.copy()
            else:
                # The same kind of place from two stages: counted on, places named as kept.
                self._places[index].join(seen)

    def unsupported(self, block: int | None, message: str) -> None:
        """The one call for what the target cannot express (a loss, not an error)."""
        self.add(Severity.LOST, block, message)

    def error(self, block: int | None, message: str) -> None:
        self.add(Severity.ERROR, block, message)

    def rewritten(self, block: int | None, message: str, same: str = "", at: str = "") -> None:
        self.add(Severity.REWRITTEN, block, message, same, at)

    def warning(self, block: int | None, message: str, same: str = "", at: str = "") -> None:
        self.add(Severity.WARNING, block, message, same, at)

    def note(self, block: int | None, message: str) -> None:
        self.add(Severity.NOTE, block, message)

    @property
    def has_errors(self) -> bool:
        return any(e.severity is Severity.ERROR for e in self._entries)

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


@dataclass
class Export:
    """An export: its bytes (`size` of them, in `file` from its start), how to name and
    serve them, and its report. Read them with `data` (all at once) or `chunks`. A spool
    `export()` made itself is closed with the Export (or by `close`)."""

    target: str
    file: BinaryIO
    size: int
    extension: str
    media_type: str
    report: Report
    owned: bool = False

    def __post_init__(self) -> None:
        if self.owned:
            weakref.finalize(self, self.file.close)

    def close(self) -> None:
        """Let go of the spooled bytes (an export made to a caller's stream keeps it open)."""
        if self.owned:
            self.file.close()

    @property
    def data(self) -> bytes:
        """Every byte of the output (for small programs; large ones read `chunks`)."""
        self.file.seek(0)
        return self.file.read(self.size)

    def chunks(self, size: int = 1 << 16) -> Iterator[bytes]:
        """The output in pieces of at most `size` bytes, in order."""
        self.file.seek(0)
        left = self.size
        while left > 0:
            piece = self.file.read(min(size, left))
            if not piece:
                return
            left -= len(piece)
            yield piece

    def head(self, size: int) -> bytes:
        """The first `size` bytes (a preview)."""
        self.file.seek(0)
        return self.file.read(min(size, self.size))


@dataclass(frozen=True)
class Remedy:
    """An option value that takes a need away, offered when a program lacks the need:
    export with `option`=`value` to `does` (the shop's words: "touch off each tool at its
    change")."""

    option: str
    value: str
    does: str

    @property
    def hint(self) -> str:
        return f"or export with {self.option}={self.value} to {self.does}"


EXPLAINED = 5
"""Errors an ExportError's one-line explanation names (the rest are counted)."""


class ExportError(ValueError):
    """The program cannot be exported: validation errors, or the target's own errors.
    `remedies`: option values that would take away every need the program lacks (empty
    when other errors stop it too)."""

    def __init__(
        self,
        message: str,
        problems: list[Problem],
        report: Report | None,
        remedies: tuple[Remedy, ...] = (),
    ) -> None:
        super().__init__(message)
        self.problems = problems
        self.report = report
        self.remedies = remedies

    @property
    def errors(self) -> list[str]:
        """Each error that stops the export, one line each: the program's (`block 3, ARC:
        …`) and the target's or the machine's (`program: 1203 events: line numbers run to
        999 (seed 003 §2.2.4)`)."""
        found = [str(p) for p in self.problems if p.severity is ProblemSeverity.ERROR]
        if self.report is not None:
            found += [e.reason for e in self.report.entries if e.severity is Severity.ERROR]
        return found

    def explained(self) -> str:
        """The message with the errors behind it, for a place that shows one message (a
        download refused, a send that failed): `events cannot take this program: program:
        1203 events: line numbers run to 999 (seed 003 §2.2.4)`. At most EXPLAINED errors
        are named, the rest counted: a program off the table in every block is one line."""
        errors = self.errors
        shown = "; ".join(errors[:EXPLAINED])
        if len(errors) > EXPLAINED:
            shown += f"; and {len(errors) - EXPLAINED:,} more errors"
        return f"{self} ({shown})" if shown else str(self)


class Target(ABC):
    """An output format. Subclasses set the class attributes and implement `write` (or,
    for a target that makes its bytes in one piece from the whole Toolpath, `emit`)."""

    name: ClassVar[str]
    # The shop's name for it, as a menu shows it ("LinuxCNC G-code"); "" for none.
    label: ClassVar[str] = ""
    description: ClassVar[str]
    extension: ClassVar[str]
    media_type: ClassVar[str] = "text/plain; charset=us-ascii"
    options: ClassVar[tuple[Option, ...]] = ()
    # The options a shop sets most often: a form shows them first and folds the rest.
    common: ClassVar[tuple[str, ...]] = ()
    # What the target needs from a program beyond what every consumer needs (a program
    # that lacks it is refused by this target alone, naming the blocks).
    needs: ClassVar[frozenset[Need]] = frozenset()
    # Bytes that are not lines of text (a punch image: a byte per tape row): sent on a
    # serial line as they are, never shown as text.
    binary: ClassVar[bool] = False
    # The target that draws this output ("" for none; a drawing names itself).
    picture: ClassVar[str] = ""
    # The import format that reads the output back (None: nothing reads it).
    reads_back: ClassVar[str | None] = None
    # The bytes that end the program (a receive stops after them): the rewind stop.
    end_mark: ClassVar[bytes] = b"%"
    # Whether data bytes can be the XON/XOFF codes (then software flow control cannot run).
    flow_codes_in_data: ClassVar[bool] = False
    # The program document itself, not a tool path: it writes any program, errors and all
    # (a program is fixed by writing it, loading it and editing it), with every problem in
    # the report as a warning. Such a target implements `write_program`.
    document: ClassVar[bool] = False

    def needs_for(self, options: Mapping[str, Any]) -> frozenset[Need]:
        """The needs with these (parsed) options; a target whose options change what it
        needs (a tape with spindle codes needs speeds) overrides this."""
        return self.needs

    def need_remedy(self, need: Need) -> Remedy | None:
        """The option value that takes `need` away, if this target has one."""
        return None

    @property
    def shown_name(self) -> str:
        """How a menu names the target: its label, else its description."""
        return self.label or self.description

    def picture_target(self) -> str:
        """The target that draws this output: `picture`, or the target itself when its
        output is an image; "" for none."""
        return self.picture or (self.name if self.media_type.startswith("image/") else "")

    def picture_options(self, options: Mapping[str, str]) -> dict[str, str]:
        """The options (text) of the picture target that draw this output as made with
        `options` (text)."""
        return dict(options)

    def write(
        self,
        program: Program,
        path: CompiledPath,
        options: Mapping[str, Any],
        report: Report,
        out: Out,
    ) -> None:
        """Write the output for a validated program to `out` as it is made. Report what
        cannot be expressed; errors (report.error) make the export fail (the caller then
        discards what was written). Must be a pure function of its arguments.

        By default the whole Toolpath is made and handed to `emit`."""
        out.write(self.emit(program, path.toolpath(), options, report))

    def write_program(
        self, program: Program, options: Mapping[str, Any], report: Report, out: Out
    ) -> None:
        """A `document` target's output: the program as it is, valid or not."""
        raise NotImplementedError(f"{self.name} is not a document target")

    def emit(
        self, program: Program, toolpath: Toolpath, options: Mapping[str, Any], report: Report
    ) -> bytes:
        """The output in one piece, from the whole Toolpath (targets that do not stream)."""
        raise NotImplementedError(f"{self.name} implements neither write nor emit")

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


def register(cls: type[Target]) -> type[Target]:
    """Class decorator: make a target available by its name. Raises ValueError for a name
    taken, or one app.cnc.formats.TARGET_MODULES does not give this class's module (the
    registry would not find it without importing everything)."""
    from app.cnc.formats import TARGET_MODULES

    if cls.name in _REGISTRY:
        raise ValueError(f"two targets named {cls.name}")
    declared = TARGET_MODULES.get(cls.name)
    if declared != cls.__module__:
        raise ValueError(
            f"target {cls.name} is defined in {cls.__module__}, but app.cnc.formats."
            f"TARGET_MODULES gives {declared or 'no module'} for it"
        )
    _REGISTRY[cls.name] = cls()
    return cls


def targets() -> dict[str, Target]:
    """Every target, by name (their modules are imported once)."""
    from app.cnc.formats import TARGET_MODULES

    for name in TARGET_MODULES:
        _load(name)
    return dict(sorted(_REGISTRY.items()))


def get_target(name: str) -> Target:
    """The target called `name` (only its module is imported). Raises OptionError naming
    the targets there are."""
    from app.cnc.formats import TARGET_MODULES

    if name not in TARGET_MODULES:
        raise OptionError(
            f"no export target {name!r}; targets: {', '.join(sorted(TARGET_MODULES))}"
        )
    return _load(name)


def _load(name: str) -> Target:
    """The registered target `name` of app.cnc.formats.TARGET_MODULES, its module imported
    when it is not yet."""
    found = _REGISTRY.get(name)
    if found is None:
        from app.cnc.formats import TARGET_MODULES

        importlib.import_module(TARGET_MODULES[name])
        found = _REGISTRY.get(name)
        if found is None:
            raise LookupError(f"{TARGET_MODULES[name]} does not register the target {name}")
    return found


class _Counted:
    """A binary stream that counts what is written through it."""

    def __init__(self, out: Out) -> None:
        self.out = out
        self.size = 0

    def write(self, data: bytes) -> int:
        self.size += len(data)
        return self.out.write(data)


def export(
    program: Program,
    name: str,
    raw_options: Mapping[str, str] | None = None,
    machine: MachineModel | None = None,
    out: BinaryIO | None = None,
) -> Export:
    """Export `program` (COPY blocks carried out) to target `name`.

    The output is written to `out` (a binary stream at its start) as it is made, or by
    default to a temporary file that stays in memory up to SPOOL_BYTES; the returned
    `Export` reads it. With a `machine`, every move is checked against its travel limits
    and collision zone, and a crossing is an error naming the block. Raises OptionError for
    bad options and ExportError when the program has validation errors or the target (or
    the machine) reports errors; what was written to `out` by then is not an export.

    A `document` target (the JSON program) is the exception: it writes any program, and
    its report lists the program's problems as warnings (see `_export_document`).
    """
    target = get_target(name)
    options = target.parse_options(raw_options or {})
    if target.document:
        return _export_document(program, target, options, out)
    program = resolve_copies(program)
    needs = target.needs_for(options)
    # The control's needs are checked by validation; a target has its own (and may lack
    # some of the control's: events and JSON never need spindle speeds).
    problems = [p for p in validate(program) if p.need is None]
    path = None if blocking(problems) else compile_program(program).path
    problems += unmet(program, needs, path) if path is not None else []
    stopping = blocking(problems, needs)
    if stopping:
        missing = sorted({p.need for p in stopping if p.need is not None}, key=lambda n: n.value)
        remedies: tuple[Remedy, ...] = ()
        if missing and all(p.need is not None for p in stopping):
            found = [target.need_remedy(n) for n in missing]
            remedies = tuple(r for r in found if r is not None)
            message = f"{target.name} needs {', '.join(n.value for n in missing)}" + "".join(
                f"; {r.hint}" for r in remedies
            )
        else:
            message = "the program has errors; fix them before exporting"
        raise ExportError(message, stopping, None, remedies)
    report = Report(target.name)
    assert path is not None
    for need in sorted(needs, key=lambda n: n.value):
        report.note(None, f"this target needs {need.value}: the program has them")
    if machine is not None:
        for crossing in check_travel(path, machine):
            report.error(crossing.block, crossing.message)
    if Need.SPINDLE_SPEEDS in needs:
        # The speeds written must be ones the machine's spindle runs.
        for message in check_spindle(program, None if machine is None else machine.spindle):
            report.error(None, message)
    try:
        result = _written(
            target, report, out, lambda sink: target.write(program, path, options, report, sink)
        )
    except OutputTooLarge as exc:
        report.error(exc.block, str(exc))
        raise ExportError(f"{target.name} cannot take this program", problems, report) from None
    if report.has_errors:
        result.close()
        raise ExportError(f"{target.name} cannot take this program", problems, report)
    return result


def _written(
    target: Target, report: Report, out: BinaryIO | None, write: Callable[[Out], None]
) -> Export:
    """What `write` writes into `out` (or into a spool, closed again if writing fails), as
    the Export of `target` with `report`."""
    sink: BinaryIO = out if out is not None else _spool()
    counted = _Counted(sink)
    try:
        write(counted)
    except BaseException:
        if out is None:
            sink.close()
        raise
    return Export(
        target.name,
        sink,
        counted.size,
        target.extension,
        target.media_type,
        report,
        owned=out is None,
    )


def _export_document(
    program: Program, target: Target, options: Mapping[str, Any], out: BinaryIO | None
) -> Export:
    """Write the program document, errors and all: it is how a program that does not run
    yet (an import whose tools have no diameters) is kept to be fixed. Every validation
    problem goes in the report as a warning naming its block and field; a COPY that cannot
    be carried out is left in the document as the operator's choice."""
    report = Report(target.name)
    try:
        program = resolve_copies(program)
    except CopyError as exc:
        report.warning(exc.block, f"COPY not carried out, written as it is: {exc.message}")
    for problem in validate(program):
        where = f"{problem.field}: " if problem.field else ""
        if problem.severity.value == "error":
            where = f"error, written as it is (fix it before the program runs): {where}"
        report.warning(problem.block, f"{where}{problem.message}")
    return _written(
        target, report, out, lambda sink: target.write_program(program, options, report, sink)
    )


def _spool() -> BinaryIO:
    # tempfile (with shutil and random, 4 ms) loads for an export kept in memory or sent
    # on, not for one written to the caller's file (the command line's -o, issue 31.3).
    import tempfile

    return tempfile.SpooledTemporaryFile(max_size=SPOOL_BYTES)  # type: ignore[return-value]
