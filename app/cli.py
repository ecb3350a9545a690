"""The `millblocks` command line.

    millblocks check FILE              list every problem; exit 1 when any is an error
    millblocks time FILE               cycle time per block, per tool and in total
    millblocks export FILE --to FMT    write the program as canon or json (-o OUT)

FILE is a MillBlocks JSON program. A COPY block whose operator chose EXEC or CANCEL is
carried out as the file is read, as the control does on ENTER. Exit codes: 0 success,
1 the program has errors, 2 the file cannot be read.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click

from app.cnc import document
from app.cnc.blocks import Program
from app.cnc.copy import CopyError, resolve_copies
from app.cnc.emit import canon
from app.cnc.estimate import DEFAULT_TOOL_CHANGE_SECONDS, estimate, report
from app.cnc.interpret import interpret
from app.cnc.problems import Problem, has_errors
from app.cnc.validate import validate

EXPORT_FORMATS = ("canon", "json")


class ProgramFileError(click.ClickException):
    """A file that cannot be read as a program (exit 2)."""

    exit_code = 2


def load_program(path: Path) -> Program:
    """Read a program file, carrying out executed or cancelled COPY blocks."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
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


def print_problems(path: Path, problems: list[Problem]) -> None:
    for problem in problems:
        click.echo(f"{path}: {problem}", err=True)


def checked(path: Path) -> Program:
    """Load and validate; exit 1 after listing the problems when there is an error."""
    program = load_program(path)
    problems = validate(program)
    print_problems(path, problems)
    if has_errors(problems):
        sys.exit(1)
    return program


@click.group()
@click.version_option(package_name="millblocks")
def main() -> None:
    """MillBlocks: conversational mill programs to tool paths, tape and G-code."""


@main.command()
@click.argument("file", type=click.Path(path_type=Path, dir_okay=False))
def check(file: Path) -> None:
    """List every problem in FILE; exit 1 when any is an error."""
    program = load_program(file)
    problems = validate(program)
    print_problems(file, problems)
    errors = sum(1 for p in problems if p.severity.value == "error")
    warnings = len(problems) - errors
    click.echo(f"{file}: {len(program.blocks)} blocks, {errors} errors, {warnings} warnings")
    if errors:
        sys.exit(1)


@main.command()
@click.argument("file", type=click.Path(path_type=Path, dir_okay=False))
@click.option(
    "--tool-change-seconds",
    type=click.FloatRange(min=0),
    default=DEFAULT_TOOL_CHANGE_SECONDS,
    show_default=True,
    help="Allowance for each manual tool change.",
)
def time(file: Path, tool_change_seconds: float) -> None:
    """Estimate the cycle time of FILE per block, per tool and in total."""
    program = checked(file)
    click.echo(report(estimate(interpret(program), tool_change_seconds)), nl=False)


@main.command()
@click.argument("file", type=click.Path(path_type=Path, dir_okay=False))
@click.option("--to", "fmt", type=click.Choice(EXPORT_FORMATS), required=True)
@click.option("-o", "--output", type=click.Path(path_type=Path, dir_okay=False), default=None)
def export(file: Path, fmt: str, output: Path | None) -> None:
    """Write FILE as another format (to standard output unless -o is given)."""
    if fmt == "json":
        text = document.dumps(load_program(file))
    else:
        text = canon.dump(interpret(checked(file)))
    if output is None:
        click.echo(text, nl=False)
    else:
        output.write_text(text, encoding="utf-8")


if __name__ == "__main__":  # pragma: no cover
    main()
