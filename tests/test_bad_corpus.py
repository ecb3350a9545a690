"""The bad-input corpus: programs with one fault each, and malformed documents.

`tests/bad/<case>/program.json` is a readable program with (usually) exactly one fault;
`expected` holds the problems `validate` must report, one `str(problem)` per line, in the
order `validate` returns them; a case with a `target` file holds the problems an export to
that target is refused with (a need of the target, such as calibrated tools for a tape).
`tests/bad_documents/<case>/document.json` cannot be read at all; `expected` holds the
exact `DocumentError` message.

Every expected file was written from the rule and seed 001 before running the code. Where
the code disagrees with what a machinist expects, the case keeps the machinist's answer and
is listed in KNOWN_BUGS (a strict xfail: it fails loudly once the code is fixed, so the
entry can be removed).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from app.cli import main
from app.cnc.blocks import Program
from app.cnc.document import DocumentError, loads
from app.cnc.formats.targets import ExportError, export
from app.cnc.problems import Problem, Rule, Severity
from app.cnc.validate import validate

HERE = Path(__file__).parent
BAD = HERE / "bad"
BAD_DOCUMENTS = HERE / "bad_documents"

PROGRAM_CASES = sorted(p for p in BAD.iterdir() if (p / "program.json").is_file())
DOCUMENT_CASES = sorted(p for p in BAD_DOCUMENTS.iterdir() if (p / "document.json").is_file())

MIN_PROGRAM_CASES = 30

# Case name -> why the code does not (yet) give the expected answer.
KNOWN_BUGS: dict[str, str] = {}

# The CLI cases: one with an error (exit 1) and one with only a warning (exit 0).
CLI_CASES = {"feed-xy-above-100-ipm": 1, "arc-end-off-radius": 0}


def params(cases: list[Path]) -> list[pytest.ParameterSet]:
    """One pytest parameter per case folder, strict-xfail for the known bugs."""
    return [
        pytest.param(
            case,
            id=case.name,
            marks=(
                [pytest.mark.xfail(reason=KNOWN_BUGS[case.name], strict=True)]
                if case.name in KNOWN_BUGS
                else []
            ),
        )
        for case in cases
    ]


def expected_lines(case: Path) -> list[str]:
    return (case / "expected").read_text(encoding="utf-8").splitlines()


def load_case(case: Path) -> Program:
    return loads((case / "program.json").read_text(encoding="utf-8"))


def problems_of(case: Path) -> list[Problem]:
    """What `validate` reports; or, for a case with a `target` file (a need of that export
    target, not of the program), the problems the export is refused with."""
    program = load_case(case)
    if not (case / "target").is_file():
        return validate(program)
    target = (case / "target").read_text(encoding="utf-8").strip()
    try:
        export(program, target)
    except ExportError as exc:
        return exc.problems
    return []


@pytest.mark.parametrize("case", params(PROGRAM_CASES))
def test_bad_program(case: Path) -> None:
    assert [str(p) for p in problems_of(case)] == expected_lines(case)


@pytest.mark.parametrize("case", params(DOCUMENT_CASES))
def test_bad_document(case: Path) -> None:
    text = (case / "document.json").read_text(encoding="utf-8")
    expected = (case / "expected").read_text(encoding="utf-8").rstrip("\n")
    with pytest.raises(DocumentError) as info:
        loads(text)
    assert str(info.value) == expected


def test_corpus_has_enough_program_cases() -> None:
    assert len(PROGRAM_CASES) >= MIN_PROGRAM_CASES


def test_every_bad_program_expects_a_problem() -> None:
    empty = [case.name for case in PROGRAM_CASES if not expected_lines(case)]
    assert not empty, f"bad programs without an expected problem: {empty}"


def test_every_rule_has_a_bad_program() -> None:
    seen = {problem.rule for case in PROGRAM_CASES for problem in problems_of(case)}
    missing = sorted(rule.name for rule in set(Rule) - seen)
    assert seen == set(Rule), f"no bad program for rules: {', '.join(missing)}"


@pytest.mark.parametrize(("name", "exit_code"), sorted(CLI_CASES.items()))
def test_cli_check_reports_the_problems(name: str, exit_code: int) -> None:
    case = BAD / name
    expected = expected_lines(case)
    only_warnings = all(p.severity is Severity.WARNING for p in problems_of(case))
    assert only_warnings == (exit_code == 0), "the CLI case does not fit its exit code"
    path = case / "program.json"
    result = CliRunner().invoke(main, ["check", str(path)])
    assert result.exit_code == exit_code, result.output
    assert result.stderr.splitlines() == [f"{path}: {line}" for line in expected]
