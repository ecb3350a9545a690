"""The `millblocks` command line.

    millblocks check FILE              list every problem; exit 1 when any is an error
    millblocks time FILE               cycle time per block, per tool and in total
    millblocks export FILE --to FMT    write the program in a target format (-o OUT)
    millblocks targets [--options]     list the export targets and their options
    millblocks send PROG --machine M   send over RS-232 in the machine's target (logged)
    millblocks receive --machine M     receive over RS-232 into the library (logged)
    millblocks import FILE             add a file to the library, with its import report
    millblocks verify FILE             simulate the cut; gouges, rest material, holes, crashes
    millblocks tools list|add|edit|…   the shop's tool crib; LinuxCNC tool tables in and out
    millblocks speeds --material 6061 --diameter 0.5 --flutes 3 --tool-material carbide
                                       the RPM and feeds offered, with how each was found

FILE is a MillBlocks JSON program, ProtoTRAK Plus events, G-code, a 1704 tape (listing or
punch image) or a DXF drawing, detected from its content; `--format` forces one. An import
prints its report (what became what, what was not carried) on stderr. A COPY block whose operator
chose EXEC or CANCEL is carried out as the file is read, as the control does on ENTER.
Exit codes: 0 success, 1 the program has errors, 2 the file cannot be read.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from app.cnc.limits import DEFAULT_TOOL_CHANGE_SECONDS
from app.cnc.sizes import MAX_MOVES, moves_allowed

if TYPE_CHECKING:
    from sqlalchemy import Engine

    from app.cnc.blocks import Program
    from app.cnc.machine import MachineModel
    from app.cnc.problems import Problem
    from app.storage.library import Library, Machine

# Each command imports what it needs when it runs: `millblocks --help` and a small export
# start in a fraction of a second, not after every format, ezdxf and SQLAlchemy are loaded.
# Only click and the standard library are imported here.


class Number(click.ParamType[Any, Any]):
    """A number argument read by app.cnc.numbers (click's own FLOAT takes `nan` and INT
    takes `١٢`): a float, or an int when `whole`, at least `minimum` (more than it when
    `above`)."""

    name = "number"

    def __init__(
        self, minimum: float | None = None, whole: bool = False, above: bool = False
    ) -> None:
        self.minimum = minimum
        self.whole = whole
        self.above = above  # more than `minimum`, not equal to it

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        from app.cnc.numbers import NumberError, parse_decimal, parse_int

        if isinstance(value, int | float) and not isinstance(value, bool):
            return value
        try:
            number = parse_int(str(value)) if self.whole else parse_decimal(str(value))
        except NumberError as exc:
            self.fail(str(exc), param, ctx)
        if self.minimum is not None and number < self.minimum:
            self.fail(f"{value!r} is below the allowed minimum {self.minimum:g}", param, ctx)
        if self.above and number == self.minimum:
            self.fail(
                f"{value!r} is not allowed; it must be more than {self.minimum:g}", param, ctx
            )
        return int(number) if self.whole else float(number)


class ProgramFileError(click.ClickException):
    """A file that cannot be read as a program (exit 2)."""

    exit_code = 2


_FORMAT_KEY = "millblocks.file_format"


class LazyChoice(click.Choice[str]):
    """A choice whose names are looked up when the option is used or its help shown (the
    import formats' registry imports every format's declaration: not at start-up)."""

    def __init__(self, names: Callable[[], list[str]]) -> None:
        # click.Choice's own __init__ would store the names now; they are a property here.
        self._names = names
        self.case_sensitive = True

    @property
    def choices(self) -> tuple[str, ...]:  # type: ignore[override]
        return tuple(self._names())


def _import_formats() -> list[str]:
    from app.cnc.formats.reading import importers

    return list(importers())


def _format_choice() -> click.Choice[str]:
    """The import formats of the registry, as a choice."""
    return LazyChoice(_import_formats)


def file_format_option(command: Callable[..., Any]) -> Callable[..., Any]:
    """`--format`: force what a program FILE is (default: detected from its content)."""
    return click.option(
        "--format",
        type=_format_choice(),
        default=None,
        expose_value=False,
        is_eager=True,
        callback=lambda ctx, _param, value: ctx.meta.__setitem__(_FORMAT_KEY, value),
        help="What FILE is (default: detected from its content).",
    )(command)


def read_file(
    path: Path, file_format: str | None = None, options: dict[str, str] | None = None
) -> tuple[Program, str]:
    """A program file of any format and the format read. A MillBlocks document has its
    executed or cancelled COPY blocks carried out; any other format is imported and its
    report printed on stderr. Raises ProgramFileError (exit 2) naming line and column.

    The file is not read whole unless its format needs it: the format is detected from
    its start and G-code is read a part at a time (a 10^6-line CAM file converts in flat
    memory, docs/imports.md "Streaming")."""
    from app.cnc.formats import reading

    try:
        with path.open("rb") as file:
            try:
                chosen = file_format or reading.detect_format(reading.file_head(file))
                if chosen == "json":
                    return _load_document(path, file.read()), chosen
                # The user's own file on their own machine: no line or block limit (the
                # library still keeps only programs of at most app.cnc.sizes.MAX_BLOCKS
                # blocks).
                result = reading.read_file(file, path.stem, chosen, options or {})
            except ValueError as exc:
                raise ProgramFileError(f"{path}: {exc}") from None
    except OSError as exc:
        raise ProgramFileError(f"{path}: cannot read: {exc}") from None
    for line in result.lines():
        click.echo(line, nl=False, err=True)
    return result.program, chosen


def _load_document(path: Path, data: bytes) -> Program:
    from app.cnc import document
    from app.cnc.copy import CopyError, resolve_copies

    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ProgramFileError(f"{path}: cannot read: {exc}") from None
    try:
        program = document.loads(text)
    except document.DocumentError as exc:
        raise ProgramFileError(f"{path}: {exc}") from None
    try:
        return resolve_copies(program)
    except CopyError as exc:
        click.echo(f"{path}: {exc}", err=True)
        sys.exit(1)


def load_program(path: Path) -> Program:
    """Read a program file in the format `--format` names, else the one detected."""
    context = click.get_current_context(silent=True)
    file_format = context.meta.get(_FORMAT_KEY) if context is not None else None
    return read_file(path, file_format)[0]


def resolve_program(reference: str) -> Program:
    """A program from a file path, or else from the library by id or exact name."""
    return resolve_reference(reference)[0]


def resolve_reference(reference: str, lib: Library | None = None) -> tuple[Program, int | None]:
    """A program from a file path (id None), or else from the library (`lib`, else the
    configured one) by id or exact name, with its library id."""
    path = Path(reference)
    if path.exists() or reference.endswith(".json"):
        return load_program(path), None
    from app.storage.library import LibraryError  # a file needs no database code

    try:
        stored = (lib or library()).find(reference)
    except LibraryError as exc:
        raise ProgramFileError(f"{reference}: not a file, and {exc}") from None
    return stored.program, stored.info.id


class ConfigurationError(click.ClickException):
    """A MILLBLOCKS_* setting or a database this MillBlocks cannot use (exit 2)."""

    exit_code = 2


class DatabaseUnavailableError(click.ClickException):
    """A database that does not answer now (not started yet, restarting): exit 1, on which
    the systemd unit tries again."""

    exit_code = 1


def settings() -> dict[str, Any]:
    """The MILLBLOCKS_* settings of the environment (app.settings), read."""
    from app.settings import SettingError, environment

    try:
        return environment()
    except SettingError as exc:
        raise ConfigurationError(str(exc)) from None


@contextlib.contextmanager
def opening_database() -> Iterator[None]:
    """Opening the database: a setting that cannot work (a URL, a password, the instance
    folder) or a newer schema is ConfigurationError (exit 2), a database that does not
    answer DatabaseUnavailableError (exit 1); each one line naming the variable."""
    from app.settings import SettingError
    from app.storage.db import DatabaseUnavailable, SchemaError

    try:
        yield
    except (SettingError, SchemaError) as exc:
        raise ConfigurationError(str(exc)) from None
    except DatabaseUnavailable as exc:
        raise DatabaseUnavailableError(str(exc)) from None


def library(config: dict[str, Any] | None = None) -> Library:
    """The library (MILLBLOCKS_DATABASE_URL or DATABASE_URL, else millblocks.db in the
    instance folder), migrated to the newest; its times in the shop's zone. `config`: the
    settings when the command has read them already."""
    from app.storage.library import open_library

    config = config or settings()
    with opening_database():
        return open_library(
            config["DATABASE_URL"], seed_demo=config["DEMO_PROGRAMS"], zone=config["TIME_ZONE"]
        )


def shop_time(lib: Library, moment: datetime, seconds: bool = False) -> str:
    """A stored time in the shop's zone, labelled (app.settings.shown)."""
    from app.settings import shown

    return shown(moment, lib.zone, seconds)


def print_problems(path: Path | str, problems: list[Problem]) -> None:
    for problem in problems:
        click.echo(f"{path}: {problem}", err=True)


def checked(path: str) -> Program:
    """Load and validate; exit 1 after listing the problems when there is an error."""
    from app.cnc.problems import has_errors
    from app.cnc.validate import validate

    program = resolve_program(path)
    problems = validate(program)
    print_problems(path, problems)
    if has_errors(problems):
        sys.exit(1)
    return program


class _Commands(click.Group):
    """The command group: text that the one text rule refuses (app.cnc.text: a NUL, a lone
    surrogate from arguments that are not UTF-8, a name or notes too long), wherever a
    command meets it, ends the command with exit 2 and the message naming the field."""

    def main(self, *args: Any, **kwargs: Any) -> Any:
        # numpy's OpenBLAS starts a thread per core when numpy is imported, 20-60 ms of CPU
        # on every command that loads numpy (issue 31.3, docs/benchmarks.md); nothing
        # MillBlocks runs multiplies matrices, so one thread does the same work.
        # Set before a command imports numpy; a setting of the user's own is kept, and a
        # process that calls `main` itself (the tests) has its environment back after.
        ours = "OPENBLAS_NUM_THREADS" not in os.environ
        if ours:
            os.environ["OPENBLAS_NUM_THREADS"] = "1"
        try:
            return super().main(*args, **kwargs)
        finally:
            if ours:
                os.environ.pop("OPENBLAS_NUM_THREADS", None)

    def invoke(self, ctx: click.Context) -> Any:
        from app.cnc.text import TextError

        try:
            return super().invoke(ctx)
        except TextError as exc:
            raise ProgramFileError(str(exc)) from None
        except Exception as exc:
            # A damaged SQLite file fails in whatever statement reads it first (migrating,
            # `db current`, a list): say so once here, naming the file, not a traceback.
            if type(exc).__module__.startswith("sqlalchemy"):
                _damaged_database(exc)
            raise


def _damaged_database(exc: Exception) -> None:
    """ConfigurationError naming the SQLite file and what to do when `exc` says the file
    is damaged (app.storage.db.damaged_file); nothing for any other error."""
    from app.storage.db import damaged_file

    said = damaged_file(exc, settings()["DATABASE_URL"])
    if said is not None:
        raise ConfigurationError(said) from None


@click.group(cls=_Commands)
@click.version_option(package_name="millblocks")
@click.option(
    "--max-moves",
    type=Number(minimum=1, whole=True),
    default=MAX_MOVES,
    show_default=True,
    help="The moves a program may expand to (LOOPs multiplied out). A shop server keeps "
    "the default; raise it for your own large files on your own computer.",
)
@click.pass_context
def main(ctx: click.Context, max_moves: int) -> None:
    """MillBlocks: conversational mill programs to tool paths, tape and G-code."""
    ctx.with_resource(moves_allowed(max_moves))


@main.command()
@click.argument("file", metavar="PROGRAM")
@file_format_option
def check(file: str) -> None:
    """List every problem in PROGRAM (a file, or a library id or name); exit 1 on errors."""
    from app.cnc.validate import validate

    program = resolve_program(file)
    problems = validate(program)
    print_problems(file, problems)
    errors = sum(1 for p in problems if p.severity.value == "error")
    warnings = len(problems) - errors
    click.echo(f"{file}: {len(program.blocks)} blocks, {errors} errors, {warnings} warnings")
    if errors:
        sys.exit(1)


@main.command()
@click.argument("file", metavar="PROGRAM")
@file_format_option
@click.option(
    "--tool-change-seconds",
    type=Number(minimum=0),
    default=None,
    help=f"Allowance for each manual tool change (default {DEFAULT_TOOL_CHANGE_SECONDS:g} s, "
    "or the machine's).",
)
@click.option("--machine", "machine_name", default=None, help="Use a library machine's rates.")
def time(file: str, tool_change_seconds: float | None, machine_name: str | None) -> None:
    """Estimate the cycle time of PROGRAM per block, per tool and in total."""
    from app.cnc.estimate import estimate, report
    from app.cnc.interpret import interpret

    program = checked(file)
    machine = None
    if machine_name:
        machine = _machine_model(_library_machine(machine_name).limits, machine_name)
    result = estimate(interpret(program), tool_change_seconds, machine)
    click.echo(report(result), nl=False)


@main.command()
@click.argument("file", metavar="PROGRAM")
@file_format_option
@click.option(
    "--to",
    "fmt",
    required=True,
    help="Target format; `millblocks targets` lists them.",
)
@click.option("-o", "--output", type=click.Path(path_type=Path, dir_okay=False), default=None)
@click.option(
    "-O",
    "--option",
    "option_pairs",
    multiple=True,
    metavar="NAME=VALUE",
    help="A target option (repeatable); `millblocks targets --options` lists them.",
)
@click.option(
    "--profile",
    type=click.Path(path_type=Path, dir_okay=False, exists=True),
    default=None,
    help='Machine profile: JSON {"options": {NAME: VALUE}, "limits": {...}}; -O overrides.',
)
@click.option(
    "--machine",
    "machine_name",
    default=None,
    help="A library machine: its options (-O overrides), travel limits and spindle range are used.",
)
def export(
    file: str,
    fmt: str,
    output: Path | None,
    option_pairs: tuple[str, ...],
    profile: Path | None,
    machine_name: str | None,
) -> None:
    """Write PROGRAM (a file, or a library id or name) in format FMT.

    The output goes to standard output unless -o is given; the compatibility report (what
    the target could not express) goes to standard error.
    """
    from app.cnc.formats.targets import ExportError, OptionError
    from app.cnc.formats.targets import export as run_export

    raw: dict[str, str] = {}
    machine = None
    if machine_name:
        stored_machine = _library_machine(machine_name)
        raw.update(stored_machine.options)
        machine = _machine_model(stored_machine.limits, machine_name)
    if profile:
        raw.update(_profile_options(profile))
        limits = _profile_limits(profile)
        if limits:
            machine = _machine_model(limits, str(profile))
    for pair in option_pairs:
        name, sep, value = pair.partition("=")
        if not sep:
            raise click.BadParameter(f"{pair!r} is not NAME=VALUE", param_hint="-O")
        raw[name.strip()] = value
    program = resolve_program(file)
    # Written as it is made: to a file beside OUT, renamed to OUT once the export is whole
    # (a failed export leaves OUT as it was), or to a spool that is then copied to stdout.
    partial = None
    if output is not None:
        partial = output.with_name(f".{output.name}.partial")
    try:
        with contextlib.ExitStack() as stack:
            sink = None if partial is None else stack.enter_context(partial.open("wb"))
            result = run_export(program, fmt, raw, machine, out=sink)
    except OptionError as exc:
        _remove(partial)
        raise click.UsageError(str(exc)) from None
    except ExportError as exc:
        _remove(partial)
        print_problems(file, [p for p in exc.problems if p.severity.value == "error"])
        if exc.report is not None:
            click.echo(exc.report.text(), err=True, nl=False)
        click.echo(f"{file}: {exc}", err=True)
        sys.exit(1)
    except BaseException:
        _remove(partial)
        raise
    click.echo(result.report.text(), err=True, nl=False)
    if partial is None:
        for chunk in result.chunks():
            sys.stdout.buffer.write(chunk)
        sys.stdout.flush()
        result.close()
    else:
        assert output is not None
        partial.replace(output)


def _remove(path: Path | None) -> None:
    if path is not None:
        path.unlink(missing_ok=True)


def _library_machine(name: str) -> Machine:
    from app.storage.library import LibraryError

    try:
        return library().machine(name)
    except LibraryError as exc:
        raise click.UsageError(str(exc)) from None


def _machine_model(limits: dict[str, Any], where: str) -> MachineModel | None:
    from app.cnc.machine import MachineError, read_machine

    if not limits:
        return None
    try:
        return read_machine(limits)
    except MachineError as exc:
        raise click.UsageError(f"{where}: limits: {exc}") from None


def _profile_limits(path: Path) -> dict[str, Any]:
    data = json.loads(path.read_text(encoding="utf-8"))
    limits = data.get("limits", {}) if isinstance(data, dict) else {}
    return limits if isinstance(limits, dict) else {}


def _profile_options(path: Path) -> dict[str, str]:
    """A machine profile's options as text (numbers and booleans written as JSON)."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise ProgramFileError(f"{path}: cannot read the profile: {exc}") from None
    options = data.get("options", {}) if isinstance(data, dict) else None
    if not isinstance(options, dict):
        raise ProgramFileError(f'{path}: a profile is {{"options": {{NAME: VALUE, ...}}}}')
    return {str(k): (json.dumps(v) if isinstance(v, bool) else str(v)) for k, v in options.items()}


@main.command("targets")
@click.option("--options", "show_options", is_flag=True, help="List each target's options.")
def list_targets(show_options: bool) -> None:
    """List the export targets (and their options)."""
    from app.cnc.formats.targets import targets

    for name, target in targets().items():
        click.echo(f"{name:<16} {target.description}")
        needs = target.needs_for(target.parse_options({}))
        if needs:
            listed = "; ".join(sorted(n.value for n in needs))
            click.echo(f"{'':<16} needs {listed}")
        if show_options:
            for option in target.options:
                choices = f" ({'/'.join(option.choices)})" if option.choices else ""
                default = option.default if option.default is not None else "-"
                click.echo(f"    {option.name}={default}{choices}  {option.help}")


@main.command("import")
@click.argument("file", type=click.Path(path_type=Path, dir_okay=False, exists=True))
@click.option(
    "--format",
    "format",
    type=_format_choice(),
    default=None,
    help="What the file is (default: detected from its content).",
)
@click.option(
    "--option",
    "options",
    multiple=True,
    metavar="NAME=VALUE",
    help="A reader option, e.g. units=metric or resolution=option1 for a tape.",
)
@click.option("--layer", default=None, help="DXF: only these layers (comma-separated).")
@click.option("--hole-diameter", default=None, help="DXF: circles this size or smaller are holes.")
@click.option("--tolerance", default=None, help="DXF: ends this close are chained.")
@click.option("--author", default="", help="Who is importing (kept with the revision).")
def import_program(
    file: Path,
    format: str | None,
    options: tuple[str, ...],
    layer: str | None,
    hole_diameter: str | None,
    tolerance: str | None,
    author: str,
) -> None:
    """Add a program file to the library: a MillBlocks JSON document, ProtoTRAK Plus
    events, G-code, a 1704 tape or a DXF drawing. Prints the import report on stderr and
    the new program's id. Exit 2, nothing saved, when the file cannot be read."""
    from app.cnc.validate import validate
    from app.storage.library import LibraryError

    reader_options: dict[str, str] = {}
    for option in options:
        key, sep, value = option.partition("=")
        if not sep:
            raise click.UsageError(f"--option {option!r}: not NAME=VALUE")
        reader_options[key.strip()] = value.strip()
    dxf = {"layer": layer, "hole-diameter": hole_diameter, "tolerance": tolerance}
    reader_options |= {key: given for key, given in dxf.items() if given is not None}
    program, chosen = read_file(file, format, reader_options)
    try:
        info = library().create(
            program, author=author, summary_text=f"imported from {file.name} ({chosen})"
        )
    except LibraryError as exc:
        raise ProgramFileError(f"{file}: {exc}") from None
    print_problems(file, validate(program))
    click.echo(info.id)


@main.command("setup-sheet")
@click.argument("program", metavar="PROGRAM")
@file_format_option
@click.option("--to", "target", default=None, help="Include this target's report (tape length).")
@click.option("--machine", "machine_name", default=None, help="A library machine (rates, target).")
def setup_sheet_command(program: str, target: str | None, machine_name: str | None) -> None:
    """Print the set-up sheet of PROGRAM: part zero, tools, times, the export's report."""
    from app.cnc.formats.targets import ExportError, OptionError
    from app.cnc.formats.targets import export as run_export
    from app.cnc.setup import render_text, setup_sheet

    loaded = checked(program)
    machine = None
    raw: dict[str, str] = {}
    if machine_name:
        stored_machine = _library_machine(machine_name)
        machine = _machine_model(stored_machine.limits, machine_name)
        raw = dict(stored_machine.options)
        target = target or stored_machine.target
    found = None
    if target:
        try:
            found = run_export(loaded, target, raw, machine).report
        except OptionError as exc:
            raise click.ClickException(str(exc)) from None
        except ExportError as exc:
            raise click.ClickException(exc.explained()) from None
    click.echo(render_text(setup_sheet(loaded, found, machine)), nl=False)


@main.command("verify")
@click.argument("program", metavar="PROGRAM")
@file_format_option
@click.option(
    "--resolution",
    type=Number(minimum=0, above=True),
    default=None,
    help="Cell size in the program's units (default: about 800 cells along the stock).",
)
@click.option(
    "--tolerance",
    type=Number(minimum=0),
    default=None,
    help="What counts, in the program's units (default 0.001 in or 0.02 mm).",
)
@click.option("--png", type=click.Path(path_type=Path, dir_okay=False), default=None)
@click.option("--stl", type=click.Path(path_type=Path, dir_okay=False), default=None)
def verify_command(
    program: str,
    resolution: float | None,
    tolerance: float | None,
    png: Path | None,
    stl: Path | None,
) -> None:
    """Simulate cutting PROGRAM from its stock and check the part against the blocks.

    Prints the stock, the volume each tool removes and every finding (gouge, rest material,
    hole depth, crash) by block; exit 1 when anything is found or the program has errors.
    --png writes a picture of the part, --stl the part as an STL solid (millimetres).
    """
    from decimal import Decimal

    from app.cnc.simulate.image import png_bytes, render
    from app.cnc.simulate.mesh import stl_bytes
    from app.cnc.simulate.stock import StockError
    from app.cnc.simulate.verify import verify
    from app.cnc.units import to_nm

    loaded = checked(program)
    units = loaded.units
    try:
        result = verify(
            loaded,
            None if resolution is None else max(1, to_nm(Decimal(str(resolution)), units)),
            None if tolerance is None else to_nm(Decimal(str(tolerance)), units),
        )
    except StockError as exc:
        click.echo(f"{program}: {exc}", err=True)
        sys.exit(1)
    click.echo(result.text(), nl=False)
    sim = result.simulation
    if png is not None:
        png.write_bytes(png_bytes(render(sim.grid, sim.heights())))
    if stl is not None:
        stl.write_bytes(stl_bytes(sim.grid, sim.heights()))
    if result.findings:
        sys.exit(1)


@main.command("mirror")
@click.argument("program", metavar="PROGRAM")
@file_format_option
@click.option("--axis", type=click.Choice(["x", "y", "xy"]), required=True)
@click.option(
    "-o",
    "--output",
    type=click.Path(path_type=Path, dir_okay=False),
    default=None,
    help="Write the mirrored program to this JSON file instead of the library.",
)
def mirror_program(program: str, axis: str, output: Path | None) -> None:
    """Make the mirror-image (left-hand) program of PROGRAM, keeping each cut's direction."""
    from app.cnc import document
    from app.cnc.mirror import Axis, mirror

    result = mirror(resolve_program(program), Axis(axis))
    for note in result.notes:
        click.echo(f"note: {note}", err=True)
    if output is not None:
        output.write_text(document.dumps(result.program), encoding="utf-8")
        return
    info = library().create(result.program, summary_text=f"mirror {axis.upper()} of {program}")
    click.echo(info.id)


@main.command("history")
@click.argument("program", metavar="PROGRAM")
def history(program: str) -> None:
    """List the saved versions of a library PROGRAM (id or name)."""
    from app.storage.library import LibraryError

    lib = library()
    try:
        stored = lib.find(program)
    except LibraryError as exc:
        raise click.ClickException(str(exc)) from None
    for revision in lib.revisions(stored.info.id):
        click.echo(
            f"v{revision.version:<4} {shop_time(lib, revision.created_at)}  "
            f"{revision.author or '-':<12} {revision.summary}"
        )


@main.command("diff")
@click.argument("program", metavar="PROGRAM")
@click.argument("old", type=Number(whole=True))
@click.argument("new", type=Number(whole=True))
def diff_versions(program: str, old: int, new: int) -> None:
    """Block-level differences between two versions of a library PROGRAM."""
    from app.storage.library import LibraryError

    lib = library()
    try:
        stored = lib.find(program)
        changes = lib.diff(stored.info.id, old, new)
    except LibraryError as exc:
        raise click.ClickException(str(exc)) from None
    for line in changes or ["no differences"]:
        click.echo(line)


@main.command("restore-version")
@click.argument("program", metavar="PROGRAM")
@click.argument("version", type=Number(whole=True))
def restore_version(program: str, version: int) -> None:
    """Make an old VERSION of a library PROGRAM current again (as a new version)."""
    from app.storage.library import LibraryError

    lib = library()
    try:
        stored = lib.find(program)
        info = lib.restore_revision(stored.info.id, version, based_on=stored.info.version)
    except LibraryError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(f"program {info.id}: version {version} restored as v{info.version}")


@main.command("list")
@click.argument("query", required=False, default="")
@click.option("--sort", type=click.Choice(["name", "part_number", "updated", "created"]))
@click.option("--trash", is_flag=True, help="List the trash instead.")
def list_programs(query: str, sort: str | None, trash: bool) -> None:
    """List library programs matching QUERY (name, part number, notes, tools, block types)."""
    lib = library()
    for info in lib.programs(query, sort or "name", trash):
        click.echo(
            f"{info.id:>5}  {info.name:<40} {info.part_number:<8} {info.block_count:>4} blocks"
            f"  v{info.version}  {shop_time(lib, info.updated_at)}"
        )


@main.command()
@click.argument("archive", type=click.Path(path_type=Path, dir_okay=False))
def backup(archive: Path) -> None:
    """Write the whole library to ARCHIVE (a zip of JSON documents)."""
    with archive.open("wb") as out:
        count = library().backup(out)
    click.echo(f"{archive}: {count} programs")


@main.command()
@click.argument("archive", type=click.Path(path_type=Path, dir_okay=False, exists=True))
def restore(archive: Path) -> None:
    """Add every program of a backup ARCHIVE to the library (nothing is replaced)."""
    from app.storage.library import LibraryError

    try:
        count = library().restore_backup(archive)
    except LibraryError as exc:
        raise ProgramFileError(f"{archive}: {exc}") from None
    click.echo(f"{archive}: {count} programs restored")


@main.group()
def user() -> None:
    """Accounts for serving MillBlocks on a network (MILLBLOCKS_AUTH=accounts)."""


@user.command("add")
@click.argument("username")
@click.option("--role", type=click.Choice(["programmer", "operator", "admin"]), required=True)
@click.password_option(help="The password (asked for when not given; 10 characters or more).")
def user_add(username: str, role: str, password: str) -> None:
    """Create an account."""
    from app.storage.accounts import Accounts
    from app.storage.library import LibraryError

    try:
        Accounts(library()).create(username, password, role)
    except LibraryError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(f"user {username} ({role}) created")


@user.command("password")
@click.argument("username")
@click.password_option(help="The new password (asked for when not given; 10 characters or more).")
def user_password(username: str, password: str) -> None:
    """Set a user's password; every session of the user ends."""
    from app.storage.accounts import Accounts
    from app.storage.library import LibraryError

    try:
        Accounts(library()).set_password(username, password)
    except LibraryError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(f"password of {username} changed; every session of {username} ended")


@user.command("end-sessions")
@click.argument("username")
def user_end_sessions(username: str) -> None:
    """Log a user out everywhere (a lost badge, a shared terminal)."""
    from app.storage.accounts import Accounts
    from app.storage.library import LibraryError

    try:
        count = Accounts(library()).end_sessions(username)
    except LibraryError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(f"{count} sessions of {username} ended")


@user.command("list")
def user_list() -> None:
    """List the accounts."""
    from app.storage.accounts import Accounts

    for account in Accounts(library()).users():
        click.echo(f"{account.username:<20} {account.role}")


@main.group()
def db() -> None:
    """Database maintenance."""


@db.command("upgrade")
def db_upgrade() -> None:
    """Bring the database up to this MillBlocks' schema, and say what was done (every
    command does this by itself too)."""
    from app.storage.db import current

    config = settings()
    engine = _database(config)
    before = _known_revision(engine)
    after = current(library(config).engine)
    where = engine.url.render_as_string(hide_password=True)
    if before is None:
        click.echo(f"created the database at {after} ({where})")
    elif before == after:
        click.echo(f"already at {after} ({where})")
    else:
        click.echo(f"upgraded from {before} to {after} ({where})")


@db.command("current")
def db_current() -> None:
    """Say which schema revision the database is at, and the newest this MillBlocks knows
    (exit 1 when the database is newer than this MillBlocks)."""
    from app.storage.db import current, head, revisions

    engine = _database()
    found, newest = current(engine), head()
    where = engine.url.render_as_string(hide_password=True)
    if found is None:
        click.echo(
            f"empty: no schema yet ({where}); `millblocks db upgrade` creates it at {newest}"
        )
    elif found == newest:
        click.echo(f"at {found}, the newest this MillBlocks knows ({where})")
    elif found in revisions():
        click.echo(
            f"at {found}; this MillBlocks knows up to {newest}: "
            f"`millblocks db upgrade` brings it up ({where})"
        )
    else:
        click.echo(f"at {found}, newer than this MillBlocks (it knows up to {newest}) ({where})")
        sys.exit(1)


@db.command("downgrade")
@click.argument("revision", required=False)
@click.option("--yes", is_flag=True, help="Do not ask before dropping data.")
def db_downgrade(revision: str | None, yes: bool) -> None:
    """Take the database down to REVISION (default: one step; `base` empties it), to run an
    older MillBlocks on it. What each undone migration added is dropped with its data:
    back up first (docs/deploy.md)."""
    from app.storage.db import SchemaError, current, downgrade, revisions, undone

    engine = _database()
    found = _known_revision(engine)
    if found is None:
        raise ConfigurationError("the database is empty: nothing to downgrade")
    if revision is None:
        known = revisions()
        revision = known[known.index(found) - 1] if known.index(found) else "base"
    try:
        steps = undone(found, revision)
    except SchemaError as exc:
        raise ConfigurationError(str(exc)) from None
    if not steps:
        click.echo(f"already at {found}")
        return
    for step, what in steps:
        click.echo(f"undo {step}: {what}", err=True)
    if not yes:
        click.confirm("The data of what these added is dropped. Go on?", abort=True, err=True)
    downgrade(engine, revision)
    click.echo(f"downgraded from {found} to {current(engine) or 'base (empty)'}")


def _database(config: dict[str, Any] | None = None) -> Engine:
    """An engine on the configured database, without migrating it (a database that cannot
    be opened: `opening_database`)."""
    from app.storage.db import open_engine

    with opening_database():
        return open_engine((config or settings())["DATABASE_URL"])


def _known_revision(engine: Engine) -> str | None:
    """The database's revision; exit 2 with what to do when it is newer than this code."""
    from app.storage.db import SchemaError, check_known

    try:
        return check_known(engine)
    except SchemaError as exc:
        raise ConfigurationError(str(exc)) from None


@main.command("serve")
@click.option("--host", default="127.0.0.1", show_default=True, help="The address to listen on.")
@click.option("--port", default=5000, show_default=True, type=Number(minimum=1, whole=True))
@click.option(
    "--workers",
    default=2,
    show_default=True,
    type=Number(minimum=1, whole=True),
    help="gunicorn worker processes.",
)
@click.option(
    "--dnc/--no-dnc",
    default=True,
    show_default=True,
    help="Also start the transfer service (`millblocks dnc`); --no-dnc where it runs as its "
    "own systemd unit.",
)
def serve(host: str, port: int, workers: int, dnc: bool) -> None:
    """Serve the web app with gunicorn (Linux), after bringing the database up to date.

    Listens on 127.0.0.1 unless told otherwise: on a shop network put the reverse proxy
    of docs/deploy.md in front, which reaches it there. Settings come from the
    environment (MILLBLOCKS_*, DATABASE_URL).
    """
    library()  # migrated (and given its demo programs) once, before the workers start
    if dnc:
        # A process of its own, in this process group (Ctrl-C stops both); gunicorn
        # restarting its workers does not touch a transfer. This process becomes gunicorn's
        # master (exec keeps the PID): the service stops when it is gone, however it ended.
        import subprocess

        subprocess.Popen([sys.executable, "-m", "app.cli", "dnc", "--stop-with", str(os.getpid())])
    command = [sys.executable, "-m", "gunicorn", "-c", "python:app.gunicorn_conf"]
    command += ["--bind", f"{host}:{port}"]
    # No gunicorn access log: the app writes one line per request with its level
    # (app/web/logs.py), so the journal would have each request twice.
    command += ["--workers", str(workers), "app:create_app()"]
    click.echo(f"serving MillBlocks on http://{host}:{port}/ ({workers} workers)", err=True)
    sys.stderr.flush()
    os.execv(sys.executable, command)


# -- the tool crib, feeds and speeds (issue 34) ---------------------------------------------


def _tool_types() -> list[str]:
    from app.cnc.tools import ToolType

    return [kind.value for kind in ToolType]


def _materials() -> list[str]:
    from app.cnc.cutting import MaterialName

    return [name.value for name in MaterialName]


def _tool_materials() -> list[str]:
    from app.cnc.tools import ToolMaterial

    return [material.value for material in ToolMaterial]


UNITS = click.Choice(["inch", "mm"])


def _crib() -> Any:
    from app.storage.crib import Crib

    return Crib(library())


def _crib_tool(reference: str) -> Any:
    """A crib tool in use by number (12, T12) or name; a usage error naming it otherwise."""
    from app.storage.library import LibraryError

    try:
        return _crib().find(reference)
    except LibraryError as exc:
        raise click.UsageError(str(exc)) from None


@main.group()
def tools() -> None:
    """The shop's tool crib: list, add, edit, retire, history; LinuxCNC tool tables."""


@tools.command("list")
@click.argument("query", required=False, default="")
@click.option("--retired", is_flag=True, help="List the retired tools instead.")
def tools_list(query: str, retired: bool) -> None:
    """List the crib's tools matching QUERY (number, name or type), by number."""
    for stored in _crib().tools(query, retired):
        click.echo(f"{stored.tool.describe()}  v{stored.version}")


@tools.command("show")
@click.argument("reference", metavar="TOOL")
def tools_show(reference: str) -> None:
    """Show a crib tool (TOOL: its number, 12 or T12, or its name) and its history."""
    stored = _crib_tool(reference)
    click.echo(stored.tool.describe())
    tool = stored.tool
    if tool.tcal is not None:
        click.echo(f"TCAL {tool.tcal} {tool.units.symbol}")
    if tool.notes:
        click.echo(f"notes: {tool.notes}")
    for rev in _crib().revisions(stored.id):
        click.echo(
            f"  v{rev.version}  {rev.created_at:%Y-%m-%d %H:%M}  {rev.author or '-'}  {rev.summary}"
        )


def tool_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """The fields of a crib tool as options (none required: `tools add` checks)."""
    options = [
        click.option("--number", type=Number(whole=True), default=None, help="T number."),
        click.option("--name", default=None, help='What the shop calls it ("#7 DRILL").'),
        click.option("--type", "kind", type=LazyChoice(_tool_types), default=None),
        click.option("--units", type=UNITS, default=None, help="Of its sizes (inch)."),
        click.option("--diameter", default=None, help="Cutting diameter."),
        click.option("--flutes", type=Number(whole=True), default=None),
        click.option("--material", type=LazyChoice(_tool_materials), default=None),
        click.option("--length", default=None, help="Length out of the holder."),
        click.option("--tcal", default=None, help="Measured length offset (tool table Z)."),
        click.option("--pitch", default=None, help="A tap's pitch: TPI (20) or mm (1)."),
        click.option("--pitch-unit", type=click.Choice(["tpi", "mm"]), default=None),
        click.option("--hand", type=click.Choice(["right", "left"]), default=None),
        click.option("--notes", default=None),
        click.option("--author", default="", help="Who (kept with the revision)."),
    ]
    for option in reversed(options):
        command = option(command)
    return command


def _tool_from(base: Any, values: dict[str, Any]) -> Any:
    """A crib tool: `base` (None: a new one) with the options given, each read and checked
    as the web form reads it. A usage error names the option."""
    from dataclasses import replace
    from decimal import Decimal

    from app.cnc.numbers import NumberError, parse_decimal
    from app.cnc.tools import CribTool, Hand, PitchUnit, ToolMaterial, ToolType
    from app.cnc.units import Units

    fields: dict[str, Any] = {}
    for name in ("diameter", "length", "tcal", "pitch"):
        raw = values.get(name)
        if raw is None:
            continue
        try:
            fields[name] = None if raw == "" else parse_decimal(raw, exponent=False)
        except NumberError as exc:
            raise click.UsageError(f"--{name}: {exc}") from None
    for name in ("number", "name", "flutes", "notes"):
        if values.get(name) is not None:
            fields[name] = values[name]
    enums = {
        "kind": ToolType,
        "units": Units,
        "material": ToolMaterial,
        "pitch_unit": PitchUnit,
        "hand": Hand,
    }
    for name, cls in enums.items():
        if values.get(name) is not None:
            fields[name] = cls(values[name])
    if base is not None:
        return replace(base, **fields)
    missing = [
        f"--{n}"
        for n in ("number", "name", "type", "diameter")
        if values.get("kind" if n == "type" else n) is None
    ]
    if missing:
        raise click.UsageError(f"a new tool needs {', '.join(missing)}")
    fields.setdefault("diameter", Decimal(0))
    return CribTool(**fields)


@tools.command("add")
@tool_options
def tools_add(author: str, **values: Any) -> None:
    """Add a tool to the crib (--number, --name, --type and --diameter at least)."""
    from app.storage.library import LibraryError

    try:
        stored = _crib().create(_tool_from(None, values), author)
    except LibraryError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(f"added {stored.tool.describe()}")


@tools.command("edit")
@click.argument("reference", metavar="TOOL")
@tool_options
def tools_edit(reference: str, author: str, **values: Any) -> None:
    """Change a crib tool (a new revision); options not given stay as they are."""
    from app.storage.library import LibraryError

    stored = _crib_tool(reference)
    try:
        saved = _crib().save(stored.id, _tool_from(stored.tool, values), stored.version, author)
    except LibraryError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(f"saved v{saved.version}: {saved.tool.describe()}")


@tools.command("retire")
@click.argument("reference", metavar="TOOL")
def tools_retire(reference: str) -> None:
    """Take a tool out of use (kept with its history for the programs that picked it)."""
    stored = _crib_tool(reference)
    _crib().retire(stored.id)
    click.echo(f"retired {stored.tool.title}")


@tools.command("import")
@click.argument("file", type=click.Path(path_type=Path, dir_okay=False, exists=True))
@click.option("--units", type=UNITS, default="inch", show_default=True, help="The table's units.")
@click.option("--author", default="", help="Who (kept with the revisions).")
def tools_import(file: Path, units: str, author: str) -> None:
    """Read a LinuxCNC tool table (.tbl) into the crib: known numbers get its diameter,
    length and name, new numbers become tools. All or nothing; what was assumed or not
    carried is listed."""
    from app.cnc.units import Units
    from app.storage.library import LibraryError

    try:
        text = file.read_text(encoding="utf-8", errors="strict")
    except (OSError, UnicodeDecodeError) as exc:
        raise ProgramFileError(f"{file}: cannot read: {exc}") from None
    try:
        done = _crib().import_table(text, Units(units), author)
    except LibraryError as exc:
        raise ProgramFileError(f"{file}: {exc}") from None
    click.echo(done.text(), nl=False)


@tools.command("table")
@click.option("--program", "reference", default=None, help="A program's tools instead.")
@click.option("--units", type=UNITS, default=None, help="The table's units (inch).")
@click.option("-o", "--output", type=click.Path(path_type=Path, dir_okay=False), default=None)
def tools_table(reference: str | None, units: str | None, output: Path | None) -> None:
    """Write a LinuxCNC tool table: the crib's tools by number (Z: each one's measured
    length, TCAL, where known), or with --program a program's Data Block 0 tools by the
    numbers its G-code calls (D: DIA, Z: TCAL), in the program's units."""
    from app.cnc.tooltable import crib_table, program_table, write_table
    from app.cnc.units import Units

    if reference:
        program = resolve_program(reference)
        if units and Units(units) is not program.units:
            raise click.UsageError(
                f"--units {units}: a program's table is in its own units ({program.units.value})"
            )
        text = write_table(program_table(program), program.units)
    else:
        chosen = Units(units or "inch")
        text = write_table(crib_table([t.tool for t in _crib().tools()], chosen), chosen)
    if output is None:
        click.echo(text, nl=False)
    else:
        output.write_text(text, encoding="utf-8")


@main.command("speeds")
@click.option("--material", type=LazyChoice(_materials), required=True)
@click.option("--diameter", required=True, help="The tool's cutting diameter.")
@click.option("--flutes", type=Number(minimum=1, whole=True), default=None)
@click.option("--tool-material", type=LazyChoice(_tool_materials), default="hss", show_default=True)
@click.option(
    "--type",
    "kind",
    type=LazyChoice(_tool_types),
    default=None,
    help="The tool's type (end_mill; tap with --tap-pitch).",
)
@click.option("--units", type=UNITS, default="inch", show_default=True)
@click.option("--machine", "machine_name", default=None, help="A library machine's spindle.")
@click.option("--tap-pitch", default=None, help="A tap's pitch: TPI in inch, mm in mm.")
@click.option("--hand", type=click.Choice(["right", "left"]), default="right", show_default=True)
@click.option("--rpm", type=Number(whole=True), default=None, help="Feeds for this RPM instead.")
@click.option("--surface-speed", default=None, help="custom: sfm (inch) or m/min (mm).")
@click.option("--chip-load", default=None, help="custom: in or mm per tooth.")
def speeds(
    material: str,
    diameter: str,
    flutes: int | None,
    tool_material: str,
    kind: str | None,
    units: str,
    machine_name: str | None,
    tap_pitch: str | None,
    hand: str,
    rpm: int | None,
    surface_speed: str | None,
    chip_load: str | None,
) -> None:
    """The RPM and feeds offered for a tool in a material, as the editor offers them, with
    how each was found (the tables are cited in docs/tools.md)."""
    from fractions import Fraction

    from app.cnc.crib import machine_limits
    from app.cnc.cutting import Cutter, MaterialName, Workpiece, offer, workpiece_faults
    from app.cnc.numbers import NumberError, parse_decimal
    from app.cnc.tools import Hand, PitchUnit, ToolMaterial, ToolType, thread_faults
    from app.cnc.units import Units

    chosen = Units(units)

    def number(option: str, raw: str | None) -> Any:
        if raw is None:
            return None
        try:
            return parse_decimal(raw, exponent=False)
        except NumberError as exc:
            raise click.UsageError(f"{option}: {exc}") from None

    def workpiece_of() -> Workpiece:
        return Workpiece(
            name=MaterialName(material),
            surface_speed=number("--surface-speed", surface_speed),
            chip_load=number("--chip-load", chip_load),
        )

    workpiece = workpiece_of()
    dia = number("--diameter", diameter)
    if dia <= 0:
        raise click.UsageError(f"--diameter: {diameter} must be more than 0")
    pitch = number("--tap-pitch", tap_pitch)
    tool_kind = ToolType(kind) if kind else ToolType.TAP if pitch is not None else ToolType.END_MILL
    pitch_unit = PitchUnit.TPI if chosen is Units.INCH else PitchUnit.MM
    faults = [message for _, message in thread_faults(tool_kind, pitch, pitch_unit, Hand(hand))]
    faults += workpiece_faults(workpiece, chosen)
    if faults:
        raise click.UsageError("; ".join(faults))
    spindle = max_feed = None
    where = "the control's spindle (60-500 low gear, 500-4000 high gear)"
    if machine_name:
        model = _machine_model(_library_machine(machine_name).limits, machine_name)
        spindle, max_feed = machine_limits(model, chosen)
        if spindle is not None:
            where = f"{machine_name}'s spindle ({spindle.text()} rpm)"
    inches = Fraction(dia) if chosen is Units.INCH else Fraction(dia) / Fraction(254, 10)
    cutter = Cutter(
        tool_kind, inches, flutes, ToolMaterial(tool_material), pitch, pitch_unit, Hand(hand)
    )
    figures = offer(workpiece, cutter, chosen, spindle, rpm, max_feed)
    click.echo(
        f"{workpiece.label(chosen)}: {dia} {chosen.symbol} {cutter.material.label} "
        f"{tool_kind.label}" + (f", {flutes} flutes" if flutes else "") + f"; {where}"
    )
    for line in figures.lines:
        click.echo(f"  {line}")
    click.echo(f"offered: {figures.summary()}")


# -- RS-232 transfers (issue 8) -------------------------------------------------------------


def _interruptible() -> tuple[threading.Event, Callable[[], bool]]:
    """Ctrl-C asks the transfer to stop (it stops within 50 ms) instead of killing it."""
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    return stop, stop.is_set


def _progress_printer(label: str) -> Callable[[int, int | None], None]:
    """Progress on stderr, at most every 10 % (sends) or 1 KiB (receives)."""
    shown = {"mark": -1}

    def progress(done: int, total: int | None) -> None:
        mark = done * 10 // total if total else done // 1024
        if mark != shown["mark"]:
            shown["mark"] = mark
            of = f"/{total} bytes ({done * 100 // total}%)" if total else " bytes"
            click.echo(f"{label}: {done}{of}", err=True)

    return progress


def _transfer_machine(name: str | None, port: str | None, target: str) -> Machine:
    """The library machine `name`, or else a bare line on `port`: 4800 7E1, no flow
    control, sending `target` (the ProtoTRAK Plus defaults)."""
    from app.cnc.formats.targets import targets
    from app.storage.library import Machine

    if name:
        return _library_machine(name)
    if not port:
        raise click.UsageError("give --machine NAME (a library machine) or --port PATH")
    if target not in targets():
        raise click.UsageError(f"--to {target}: not a target; see `millblocks targets`")
    return Machine(f"port {port}", target, {}, {"port": port})


@main.command("send")
@click.argument("program", metavar="PROGRAM")
@file_format_option
@click.option("--machine", "machine_name", default=None, help="A library machine (port, target).")
@click.option("--port", default=None, help="Another port than the machine's (e.g. /dev/ttyUSB1).")
@click.option(
    "--to", "target", default="events", show_default=True, help="What to send with --port alone."
)
@click.option("--author", default="", help="Who is sending (kept in the transfer log).")
@click.option(
    "--from-block",
    "start_block",
    default=None,
    type=Number(minimum=1, whole=True),
    help="Restart: send the program from this data block on (the start of a hole, bolt "
    "circle, mill sequence or LOOP).",
)
def send_command(
    program: str,
    machine_name: str | None,
    port: str | None,
    target: str,
    author: str,
    start_block: int | None,
) -> None:
    """Send a program over RS-232: to a library machine (its port, target and line
    settings), or to --port PATH at 4800 7E1.

    PROGRAM is a library id or name, or a JSON file. The transfer is logged in the library.
    Ctrl-C stops it (the control has a partial program). Exit 1 when it is cancelled.
    """
    from app.cnc.formats.targets import ExportError, OptionError
    from app.dnc import TransferError, service
    from app.storage.transfers import TransferLog

    machine = _transfer_machine(machine_name, port, target)
    lib = library()
    chosen, program_id = resolve_reference(program, lib)
    revision = None if program_id is None else lib.get(program_id).info.version
    stop, cancelled = _interruptible()
    try:
        sent = service.send_program(
            chosen,
            machine,
            port=port,
            program_id=program_id,
            revision=revision,
            start_block=start_block,
            author=author,
            log=TransferLog(lib).log,
            progress=_progress_printer(f"send {chosen.name}"),
            cancel=cancelled,
        )
    except ExportError as exc:
        raise click.ClickException(exc.explained()) from None
    except (TransferError, OptionError, ValueError) as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(sent.record.summary())
    if stop.is_set():
        sys.exit(1)


@main.command("receive")
@click.option("--machine", "machine_name", default=None, help="A library machine (port, target).")
@click.option("--port", default=None, help="Another port than the machine's.")
@click.option(
    "--format", "format", default=None, help="What the control sends (default: its target)."
)
@click.option("--name", default="", help="The new program's name.")
@click.option(
    "--wait",
    "first_byte_timeout",
    default=120.0,
    show_default=True,
    type=Number(minimum=0),
    help="Seconds to wait for the control to start sending.",
)
@click.option("--author", default="", help="Who is receiving (kept with the revision).")
def receive_command(
    machine_name: str | None,
    port: str | None,
    format: str | None,
    name: str,
    first_byte_timeout: float,
    author: str,
) -> None:
    """Receive a program from a machine over RS-232 and add it to the library.

    Start this, then start the send on the control. Prints the new program's id. A capture
    that is not a whole program is refused (nothing saved; the raw bytes are in the
    transfer log). Exit 1 when nothing was saved.
    """
    from app.cnc.validate import validate
    from app.dnc import TransferError, service
    from app.storage.transfers import TransferLog

    machine = _transfer_machine(machine_name, port, "events")
    lib = library()
    _, cancelled = _interruptible()
    try:
        got = service.receive_program(
            machine,
            lib,
            port=port,
            format=format,
            name=name,
            author=author,
            log=TransferLog(lib).log,
            progress=_progress_printer("receive"),
            cancel=cancelled,
            first_byte_timeout=first_byte_timeout,
            compare=TransferLog(lib).compare_with_last_send,
        )
    except (TransferError, ValueError) as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(got.record.summary(), err=True)
    if got.report:
        click.echo(got.report, nl=False, err=True)
    if got.stored is None or got.program is None:
        sys.exit(1)
    click.echo(got.stored.id)
    print_problems(got.program.name, validate(got.program))


def _stop_with_parent(stop: threading.Event, parent: int, poll: float) -> None:
    """Set `stop` once the process `parent` (the `millblocks serve` that started this
    service) is gone — stopped by a signal only it received, or killed — so that no transfer
    service is left holding the machines' ports without its web server."""

    def watch() -> None:
        while not stop.wait(poll):
            if os.getppid() != parent:
                click.echo("the web server this service was started with is gone", err=True)
                stop.set()

    threading.Thread(target=watch, name="stop-with-serve", daemon=True).start()


@main.command("dnc")
@click.option(
    "--poll",
    default=0.5,
    show_default=True,
    type=Number(minimum=0.05),
    help="Seconds between looks at the queue.",
)
@click.option(
    "--stop-with",
    type=int,
    default=None,
    hidden=True,
    help="Stop when this process (the `millblocks serve` that started the service) is gone.",
)
def dnc_service(poll: float, stop_with: int | None) -> None:
    """Run the transfer service: every transfer queued by the web page, one at a time per
    machine, any number of machines at once, until SIGTERM or Ctrl-C (which interrupt the
    transfers running then, naming them). Run one per library, beside the web server."""
    from app.dnc.daemon import TransferService
    from app.web.logs import setup

    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    if stop_with is not None:
        _stop_with_parent(stop, stop_with, poll)
    config = settings()
    # The service's log lines (a database that stopped answering, a transfer that failed)
    # as the web server's: time or journal priority, level, logger (docs/deploy.md, Logs).
    setup(config["LOG_LEVEL"])
    running = TransferService(library(config), poll=poll)
    for transfer in running.recover():
        click.echo(
            f"transfer {transfer.id} ({transfer.direction} {transfer.program_name or '-'} on "
            f"{transfer.machine}) was interrupted when the service last stopped",
            err=True,
        )
    click.echo(f"transfer service running ({running.name})", err=True)

    def started(transfer: Any) -> None:
        click.echo(
            f"transfer {transfer.id}: {transfer.direction} {transfer.program_name or '-'} "
            f"on {transfer.machine} ({transfer.port})",
            err=True,
        )

    for transfer in running.run(stop, on_start=started):
        click.echo(
            f"transfer {transfer.id} on {transfer.machine} interrupted by the stop", err=True
        )
    click.echo("transfer service stopped", err=True)


@main.command("ports")
def list_ports() -> None:
    """List this computer's serial ports."""
    from app.dnc import service

    for device, description in service.available_ports():
        click.echo(f"{device:<24} {description}")


@main.command("transfers")
@click.option("--limit", default=20, show_default=True, type=Number(minimum=1, whole=True))
def list_transfers(limit: int) -> None:
    """The newest RS-232 transfers in the log."""
    from app.storage.transfers import TransferLog

    lib = library()
    for t in TransferLog(lib).recent(limit):
        total = f"/{t.bytes_total}" if t.bytes_total is not None else ""
        error = f"  {t.error}" if t.error else ""
        version = f" v{t.revision}" if t.revision is not None else ""
        digest = f" sha256 {t.checksum[:12]}" if t.checksum else ""
        click.echo(
            f"{t.id:>5} {shop_time(lib, t.started_at)} {t.direction:<7} {t.machine:<16} "
            f"{(t.program_name or '-') + version:<24} {t.target} {t.settings}  "
            f"{t.bytes_done}{total} bytes  {t.outcome}{error}{digest}  {t.author or '-'}"
        )


if __name__ == "__main__":  # pragma: no cover
    main()
