"""LinuxCNC's O-word subroutines and control flow, Fanuc M98/M99 subprograms, parameters and
expressions (app/cnc/formats/gcode/ngc.py), held to what LinuxCNC's own rs274 reads.

Before issue 36 the G-code importer refused every `#`, `[`, O-word and M98/M99 ("parameters
and expressions are not supported", "O-word subroutines are not supported"), and `@`/`^`
(LinuxCNC's polar coordinates, hole-circle.ngc's `^60`) as unexpected characters: each test
here that imports such a file failed before.
"""

from __future__ import annotations

import math
import tempfile
from decimal import Decimal
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.cnc.blocks import BoltCircle, MillLine
from app.cnc.formats.gcode import ngc
from app.cnc.formats.reading import ImportFailure, read_program
from app.cnc.recognition.common import Notes
from app.cnc.sizes import MAX_EXPANDED_LINES
from tests.imports.support import fixture_text
from tests.referee import referee_import, rs274

CORPUS = "gcode-corpus/linuxcnc"


def expanded(text: str) -> list[str]:
    """The lines the front end gives the reader, `number: text`."""
    lines = ngc.expand(text.split("\n"), Notes())
    return [f"{line.number}: {line.text}" for line in lines if line.text.strip()]


def report(text: str) -> list[str]:
    return [str(n) for n in read_program(text.encode(), "t", "gcode").report]


def failure(text: str) -> str:
    with pytest.raises(ImportFailure) as caught:
        read_program(text.encode(), "t", "gcode")
    return str(caught.value)


def ours(expression: str) -> float:
    """Our value of a LinuxCNC expression (as the X of a move)."""
    (line,) = ngc.expand([f"G0 X{expression}"], Notes())
    return float(line.text.removeprefix("G0 X"))


def theirs(expressions: list[str], tmp_path: Path) -> list[float]:
    """rs274's values of `expressions` (as X of moves from X-99999 back, 4 decimals)."""
    path = tmp_path / "values.ngc"
    moves = "".join(f"G0 X-99999\nG0 X{e}\n" for e in expressions)
    path.write_text(f"G20\n{moves}M2\n")
    return [m.end[0] for m in rs274(path) if m.kind == "T" and m.end[0] != -99999]


# -- expressions --------------------------------------------------------------------------

# Each value as rs274 computes it (checked below against rs274 itself).
EXPRESSIONS = [
    ("[2**3**2]", 64.0),  # left to right: (2**3)**2
    ("[-2**2]", 4.0),  # the sign belongs to the number
    ("[-[2]**2]", 4.0),  # a unary minus binds tighter than **
    ("[1+2*3-4/2]", 5.0),
    ("[3 - 2 - 1]", 0.0),
    ("[12/2/3]", 2.0),
    ("[2 - - 3]", 5.0),
    ("[5 MOD -3]", 2.0),  # never negative
    ("[-5 MOD 3]", 1.0),
    ("[5.5 MOD 2]", 1.5),
    ("[1 LT 2 AND 3 GT 4]", 0.0),
    ("[1 OR 0 + 0]", 1.0),  # + before OR
    ("[1 XOR 1]", 0.0),
    ("[0 EQ 0.0000001]", 1.0),  # within 1e-6
    ("[1 NE 1.00001]", 1.0),  # (TOLERANCE rows: see below)
    ("[2 GE 2.0000005]", 1.0),
    ("[2 LE 1.9999995]", 1.0),
    ("[2 GT 2]", 0.0),
    ("[ROUND[-2.5]]", -3.0),  # half away from zero
    ("[ROUND[2.5]]", 3.0),
    ("[FIX[-2.5]]", -3.0),
    ("[FUP[-2.5]]", -2.0),
    ("[ATAN[1]/[-1]]", 135.0),
    ("[SIN[30]*2]", 1.0),
    ("[COS[60]]", 0.5),
    ("[TAN[45]]", 1.0),
    ("[ASIN[1]]", 90.0),
    ("[ACOS[0]]", 90.0),
    ("[SQRT[2]**2]", 2.0),
    ("[ABS[-1.25]]", 1.25),
    ("[LN[EXP[2]]]", 2.0),
    ("[2 ** 0.5]", math.sqrt(2)),
    ("[1 + [2 * [3 + 4]]]", 15.0),
    ("[EXISTS[#<nowhere>]]", 0.0),
    ("[EXISTS[#12]]", 1.0),
    ("-[1+1]", -2.0),
    ("+#3", 0.0),  # an unset numbered parameter is 0
    ("[ 1 + 2 ]", 3.0),  # blanks mean nothing
    ("[1 and 2]", 1.0),  # nor case
]


@pytest.mark.parametrize(("expression", "value"), EXPRESSIONS)
def test_expressions_as_linuxcnc_evaluates_them(expression: str, value: float) -> None:
    assert ours(expression) == pytest.approx(value, abs=1e-8)


# LinuxCNC 2.9.0 (commit 014777a816, June 2023) takes numbers within 1e-6 as equal for EQ,
# NE, GE and LE; before, within 1e-4 for EQ and NE, and GE and LE exactly. The rs274 the
# tests run (Debian 12's 2.9.0~pre1, February 2023) is the older: these rows follow the
# release.
TOLERANCE = {"[1 NE 1.00001]", "[2 GE 2.0000005]", "[2 LE 1.9999995]"}


def test_the_expression_table_is_rs274s(tmp_path: Path) -> None:
    """The table above is what LinuxCNC's interpreter computes, not our reading of it."""
    table = [(e, v) for e, v in EXPRESSIONS if e not in TOLERANCE]
    got = theirs([e for e, _ in table], tmp_path)
    assert got == pytest.approx([round(v, 4) for _, v in table], abs=1e-9)


ANGLES = ["0", "15", "30", "45", "60", "90", "120", "150", "180", "210", "270", "330", "360"]
ANGLES += ["37.3", "-45", "1000.5", "0.001", "89.99", "7.5", "[9.27 ** 32.84]", "[10 ** 300]"]
# A value's last bits, made small: times 2**60 (exact), MOD 1000 (exact).
LOW_BITS = "[[{}*1152921504606846976] MOD 1000]"


def test_angles_as_linuxcnc_on_a_pc_computes_them(tmp_path: Path) -> None:
    """LinuxCNC converts degrees with a long double pi and so calls sinl: SIN[30] is 0.5
    exactly and FIX[SIN[30]*2] 1 (in doubles 0.49999999999999994 and 0). Every bit of SIN,
    COS and TAN of these angles, and of ASIN, ACOS and ATAN, is rs274's. Before: FIX[SIN[30]
    *2], FIX[COS[60]*2], FIX[TAN[45]] and FIX[SIN[150]*2] were 0, LinuxCNC's 1."""
    probes = [LOW_BITS.format(f"{f}[{a}]") for a in ANGLES for f in ("SIN", "COS", "TAN")]
    probes += [
        LOW_BITS.format(f"{f}[{v}]") for v in ("0.5", "1", "-0.2", "0.3") for f in ("ASIN", "ACOS")
    ]
    probes += [LOW_BITS.format(f"ATAN[{y}]/[{x}]") for y, x in (("1", "-1"), ("-3", "4"))]
    probes += ["[FIX[SIN[30]*2]]", "[FIX[COS[60]*2]]", "[FIX[TAN[45]]]", "[FIX[SIN[150]*2]]"]
    assert theirs(probes, tmp_path)[-4:] == [1.0] * 4
    assert [round(ours(p), 4) for p in probes] == theirs(probes, tmp_path)


def test_a_computed_value_too_long_for_a_word_is_refused() -> None:
    """Before: 10**13 was written `1` (its trailing zeros taken for decimals), so
    `G0 X[10**13]` moved to X1."""
    assert "too many digits" in failure("G20\nG0 X[10**13]\n")
    assert ngc.number_text(10.0**13) == "10000000000000"


NUMBERS = st.decimals(min_value=-99, max_value=99, places=2).map(str)


def _tree(operations: list[str]) -> st.SearchStrategy[str]:
    """Expressions of numbers and `operations`, some bracketed (LinuxCNC's `[ ]`)."""
    return st.recursive(
        NUMBERS,
        lambda inner: st.one_of(
            st.tuples(inner, st.sampled_from(operations), inner).map(" ".join),
            inner.map(lambda e: f"[{e}]"),
        ),
        max_leaves=8,
    )


@given(_tree(["+", "-", "*", "/"]))
@settings(max_examples=300, deadline=None)
def test_arithmetic_is_pythons(expression: str) -> None:
    """+ - * / with LinuxCNC's precedence are Python's (doubles, left to right, * and /
    before + and -): the same text gives the same number, or both refuse a division by 0."""
    try:
        python = eval(
            expression.replace("[", "(").replace("]", ")")
        )  # (numbers and operators only)
    except ZeroDivisionError:
        with pytest.raises(ImportFailure, match="division by zero"):
            ours(f"[{expression}]")
        return
    assert ours(f"[{expression}]") == float(ngc.number_text(python))


# (The comparisons are in the table above: which way a random one falls can depend on the
# tolerance, which changed in LinuxCNC 2.9.0.)
ALL_OPERATIONS = ["+", "-", "*", "/", "MOD", "**", "AND", "OR", "XOR"]
FUNCTIONS = ["ABS", "FIX", "FUP", "ROUND", "SIN", "COS", "ATAN"]


@given(
    cases=st.lists(
        st.tuples(_tree(ALL_OPERATIONS), st.sampled_from(["", *FUNCTIONS])),
        min_size=5,
        max_size=5,
    )
)
@settings(max_examples=15, deadline=None)
def test_every_operation_as_rs274_computes_it(
    cases: list[tuple[str, str]], tmp_path_factory: pytest.TempPathFactory
) -> None:
    """The operators and some functions, against rs274 itself: where we compute a value it
    computes the same (to its 4 printed decimals), and what we refuse it refuses."""
    tmp_path = tmp_path_factory.mktemp("ops")
    values: list[str] = []
    for tree, function in cases:
        expression = f"{function}[{tree}]" + ("/[3]" if function == "ATAN" else "")
        try:
            value = ours(f"[{expression}]")
        except ImportFailure:
            path = tmp_path / "refused.ngc"
            path.write_text(f"G20\nG0 X[{expression}]\nM2\n")
            with pytest.raises(AssertionError, match="rs274 refused"):
                rs274(path)
            continue
        if abs(value) < 1e6:  # (rs274 prints 4 decimals of any size; keep them exact)
            values.append(f"[{expression}]")
    expected = [round(ours(v), 4) for v in values]
    assert theirs(values, tmp_path) == pytest.approx(expected, abs=1.5e-4)


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("G0 X[1/0]", "line 1, column 7: division by zero"),
        ("G0 X[-8 ** 0.5]", "line 1, column 9: a negative number to a fractional power"),
        ("G0 X[SQRT[-1]]", "line 1, column 6: SQRT of -1: only of 0 or more"),
        ("G0 X[LN[0]]", "line 1, column 6: LN of 0"),
        ("G0 X[ACOS[2]]", "line 1, column 6: ACOS of 2: only -1 to 1"),
        ("G0 X[1 MOD 0]", "line 1, column 8: MOD 0"),
        ("G0 X[EXP[1000]]", "line 1, column 6: EXP does not give a finite number"),
        ("G0 X[1 + 2", "line 1, column 11: the expression is not closed"),
        ("G0 X[1 ? 2]", "line 1, column 8: '?' where an operation or ']' belongs"),
        ("G0 X[FOO[1]]", "line 1, column 6: 'FOO' where a value belongs"),
        ("G0 X[ATAN[1]]", "line 1, column 13: ATAN needs two arguments"),
        ("G0 X#<depth>", "line 1, column 5: #<depth> is read before it is set (LinuxCNC"),
        ("G0 X#<_depth>", "line 1, column 5: #<_depth> is read before it is set"),
        ("G0 X#5221", "line 1, column 5: #5221 holds the coordinate systems (G54-G59.3)"),
        ("#5420=1", "line 1, column 1: #5420 holds the current position"),
        ("G0 X#[1.5]", "line 1, column 6: 1.5: a whole number is needed here"),
        ("#<_value>=1", "line 1, column 1: #<_value> is LinuxCNC's, read-only"),
        ("#1 X5", "line 1, column 4: '=' missing"),
        ("G0 Y#1 X1.2.3", "line 1, column 9: '1.2.3' is not a number"),
    ],
)
def test_what_linuxcnc_refuses_is_refused_where_it_is(line: str, message: str) -> None:
    assert failure(f"{line}\n").startswith(message)


# -- parameters ---------------------------------------------------------------------------


def test_a_setting_takes_effect_after_its_line() -> None:
    """LinuxCNC sets a line's parameters after reading all of it: `#1=5 G0 X#1` moves to
    the old #1, and `#1=2 #2=#1` gives #2 the old #1 (rs274: X0, then X2 Y0)."""
    assert expanded("#1=5 G0 X#1\n#1=2 #2=#1\nG0 X#1 Y#2") == [
        "1: G0 X0",
        "3: G0 X2 Y5",
    ]


def test_a_named_parameter_exists_from_its_setting() -> None:
    """`#<a>=[#<a>+1]` with #<a> never set is 1: the name is made (at 0) as its setting is
    read, as rs274 reads it; on the same line a later #<b> reads that 0."""
    assert expanded("#<a>=[#<a>+1]\nG0 X#<a>\n#<b>=2 G0 Y#<b>\nG0 Y#<b>") == [
        "2: G0 X1",
        "3: G0 Y0",
        "4: G0 Y2",
    ]


def test_names_are_local_to_a_call_and_globals_shared() -> None:
    text = (
        "#<here>=1 #<_all>=2\n"
        "o<s> sub\n"
        "#<here>=#1\n"
        "#<_all>=[#<_all>+1]\n"
        "G0 X#<here> Y[EXISTS[#<gone>]]\n"
        "#<gone>=1\n"
        "o<s> endsub\n"
        "o<s> call [7]\n"
        "o<s> call [8]\n"
        "G0 X#<here> Y#<_all> Z[EXISTS[#<gone>]]\n"
        "M2"
    )
    assert expanded(text) == [
        "5: G0 X7 Y0",
        "5: G0 X8 Y0",
        "10: G0 X1 Y4 Z0",
        "11: M2",
    ]


def test_a_call_passes_its_arguments_as_1_to_30_and_restores_them() -> None:
    text = (
        "#1=10 #2=20 #3=30\n"
        "o100 sub\n"
        "G0 X#1 Y#2 Z#3\n"
        "#1=99\n"
        "o100 endsub\n"
        "o100 call [1] [2+3]\n"
        "G0 X#1 Y#2 Z#3\n"
    )
    assert expanded(text) == ["3: G0 X1 Y5 Z0", "7: G0 X10 Y20 Z30"]


def test_a_return_value_is_underscore_value() -> None:
    """retval.ngc's reading: endsub [4712] when no return ran, return [123*#1], a bare
    return 0 (and #<_value_returned> 0)."""
    text = fixture_text(f"{CORPUS}/retval.ngc").replace(
        "(debug,call with arg1=0 return #<_value>)", "G0 X#<_value> Y#<_value_returned>"
    )
    text = text.replace("(debug,call with arg1=2 return #<_value>)", "G0 X#<_value>")
    text = text.replace(
        "(debug,call with arg1=-1 return #<_value>)", "G0 X#<_value> Y#<_value_returned>"
    )
    moves = [line for line in expanded(text) if "G0" in line]
    assert moves == ["15: G0 X4712 Y1", "20: G0 X246", "25: G0 X0 Y0"]


# -- control flow -------------------------------------------------------------------------

FLOW = """G20
o1 repeat [2.5]
G0 X1
o1 endrepeat
#3=0
o2 while [#3 LT 5]
#3=[#3+1]
o3 if [#3 EQ 2]
o2 continue
o3 elseif [#3 EQ 4]
o2 break
o3 else
G0 Y#3
o3 endif
o2 endwhile
#4=10
o4 do
#4=[#4+1]
G0 Z#4
o4 while [#4 LT 13]
M2
"""


def test_control_flow_runs_as_rs274_runs_it(tmp_path: Path) -> None:
    """repeat [2.5] runs twice (rounded half even); while with continue and break; and a
    do loop that rs274 runs once although its condition is true: the break at line 11 left
    LinuxCNC's break flag set (interp_o_word.cc never clears it after a while loop) — so the
    import runs it once too, and says why."""
    path = tmp_path / "flow.ngc"
    path.write_text(FLOW)
    theirs_ = [m.end for m in rs274(path) if m.kind == "T"]
    lines = [line.split(": ")[1] for line in expanded(FLOW) if "G0" in line]
    assert lines == ["G0 X1", "G0 X1", "G0 Y1", "G0 Y3", "G0 Z11"]
    assert theirs_ == [(1.0, 0.0, 0.0), (1.0, 1.0, 0.0), (1.0, 3.0, 0.0), (1.0, 3.0, 11.0)]
    notes = report(FLOW)
    assert any(
        "line 20: o4 while: true, but LinuxCNC does not go round the loop again, because the "
        "break at line 11 (of another loop) left its flag set" in n
        for n in notes
    )
    assert any("line 6: o2 while (lines 6-15): run 4 times" in n for n in notes)


def test_a_continue_in_a_do_loop_that_skips_to_a_break_leaves_the_loop(tmp_path: Path) -> None:
    """LinuxCNC skips from a continue to the next line with its label: in a do loop, a
    break there ends the loop (in rs274 as here), and the report says so."""
    text = (
        "G20\n#1=0\no1 do\n#1=[#1+1]\nG0 X#1\no2 if [#1 EQ 1]\no1 continue\no2 endif\n"
        "o1 break\no1 while [#1 LT 5]\nM2\n"
    )
    path = tmp_path / "do.ngc"
    path.write_text(text)
    assert [m.end[0] for m in rs274(path) if m.kind == "T"] == [1.0]
    assert [line for line in expanded(text) if "G0" in line] == ["5: G0 X1"]
    assert any(
        "line 9: o1 break: LinuxCNC reaches it as it skips to the end of the loop for the "
        "continue at line 7, and leaves the loop" in n
        for n in report(text)
    )


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("o1 if [1]\nG0 X1\n", "line 1, column 1: o1 if has no o1 endif"),
        ("o1 endif\n", "line 1, column 1: o1 endif without its o1 if"),
        (
            "o1 if [1]\no2 while [0]\no1 endif\no2 endwhile\n",
            "line 3, column 1: o1 endif before o2 while (line 2) is closed",
        ),
        (
            "o1 if [1]\no1 endif\no1 if [1]\no1 endif\n",
            "line 3, column 1: o1 is used already at line 1",
        ),
        ("o1 if [1]\no1 else\no1 else\no1 endif\n", "line 3, column 1: o1 else after o1 else"),
        (
            "o1 repeat [2]\no1 break\no1 endrepeat\n",
            "line 2, column 1: o1 break outside an o1 while or do loop",
        ),
        (
            "o<a> sub\no<b> sub\no<b> endsub\no<a> endsub\n",
            "line 2, column 1: o<b> sub inside o<a> sub (line 1)",
        ),
        ("o<a> sub\n", "line 1, column 1: o<a> sub has no o<a> endsub"),
        (
            "o<a> sub\no<a> endsub\no<a> sub\no<a> endsub\n",
            "line 3, column 1: o<a> sub is defined twice",
        ),
        ("o1 while [1] G0 X1\no1 endwhile\n", "line 1, column 14: unexpected 'g' after the O-word"),
        ("o1 while 1\no1 endwhile\n", "line 1, column 10: o1 while needs a [condition]"),
        (
            "o<a> call\n",
            "line 1, column 1: o<a> call: the file has no o<a> sub (LinuxCNC would look for a.ngc",
        ),
        ("o#1 call\n", "line 1, column 2: an O-word number from an expression is not supported"),
        (
            "G0 X1 O100\n",
            "line 1, column 7: an O-word (O number or subroutine) must begin its line",
        ),
    ],
)
def test_o_word_mistakes_name_line_and_column(text: str, message: str) -> None:
    assert failure(text).startswith(message)


# -- calls -------------------------------------------------------------------------------

SUBS = """G20
G0 X0 Y0 Z0.1
o<pocket> sub
G0 X#1 Y#2
G1 Z-0.1 F5
G1 X[#1+0.5]
G1 Y[#2+0.5]
G0 Z0.1
o<pocket> endsub
o<pocket> call [1] [1]
o10 repeat [3]
o<pocket> call [#<_x0>] [2]
#<_x0>=[#<_x0>+1]
o10 endrepeat
M2
"""


def test_calls_expand_into_moves_that_rs274_cuts(tmp_path: Path) -> None:
    text = "#<_x0>=2\n" + SUBS
    referee_import(text.encode(), tmp_path)
    notes = report(text)
    assert any(
        "line 11: o<pocket> call: o<pocket> sub (lines 4-10) expanded" in n for n in notes
    ), notes
    assert any(
        "line 13: o<pocket> call: o<pocket> sub (lines 4-10) expanded, 3 times" in n for n in notes
    )
    assert any("line 12: o10 repeat (lines 12-15): run 3 times" in n for n in notes)


def test_an_error_inside_a_subroutine_names_its_line_column_and_call() -> None:
    """Errors keep the file's line and column — the reader's too, on a line whose values
    were filled in — and say which call ran the line."""
    text = SUBS.replace("G1 Y[#2+0.5]", "G1 Y[#2+0.5] Y2").replace("#<_x0>", "3")
    assert failure(text) == (
        "line 7, column 14: Y given twice in one block (Y1.5 and Y2) (in o<pocket>, called at "
        "line 10)"
    )
    assert failure("G20\nG0 X[1+2] Y[2/0]\n") == "line 2, column 14: division by zero"
    assert failure("G20\nG0 X[1+2] X2\n").startswith("line 2, column 11: X given twice")
    assert failure("G20\nG0 X[20000*1] Y1\n").startswith("line 2, column 4: X20000 is out of range")


def test_an_error_the_reader_raises_a_line_later_keeps_its_own_column() -> None:
    """A `G0 X Y` right after a canned cycle is decided by the move after it: its error,
    raised while the next line is read, is at its own line's column (3 blanks in), not
    the next line's."""
    text = "G20\n#1=2\nG0 X0 Y0 Z1\nG81 X1 Y1 R0.1 Z-0.5 F5\n   G0 X[#1] Y[#1+1]\nG1 X[#1*3]\n"
    assert failure(text).startswith("line 5, column 4: G0 right after a canned cycle")


def test_fanuc_subprograms_m98_m99(tmp_path: Path) -> None:
    """M98 P<n> L<count> runs O<n> to its M99 count times with the caller's #1-#30; the
    main program's O number and an M99 after M30 are not cuts."""
    text = (
        "%\nO1000 (MAIN)\nG20 G90\nG0 X0 Y0 Z0.1\nG1 Z-0.1 F5\n#1=0.25\nM98 P2000 L3\n"
        "G0 Z0.1\nM30\nO2000\nG91 G1 X#1\nG90\nM99\n%\n"
    )
    referee_import(text.encode(), tmp_path)
    notes = report(text)
    assert any("line 7: M98 P2000: O2000 (lines 10-13) expanded, 3 times" in n for n in notes)
    assert any("line 2: program number O1000: not carried" in n for n in notes)
    assert failure("G20\nM98 P20002\nM30\nO2\nM99\n").startswith(
        "line 2, column 1: M98 P20002: the file has no O20002 (a Fanuc P of more than four "
        "digits may hold a repeat count: for P2 0002 write M98 P2 L2)"
    )
    assert failure("G20\nM98 P2 L0\nM30\nO2\nM99\n").startswith(
        "line 2, column 1: M98 P2 L0: LinuxCNC skips the call but stays a call deeper"
    )
    assert failure("G20\no2 call\nM30\nO2\nM99\n").startswith(
        "line 2, column 1: o2 call: O2 is a Fanuc subprogram, called with M98 P2"
    )


def test_m99_in_the_main_program_ends_it(tmp_path: Path) -> None:
    """A Haas-style pallet loop: rs274 reads M99 in the main program as its end (a control
    runs it again). Before: refused ("M99: a subprogram return is not supported")."""
    text = "G20\nG0 X0 Y0 Z0.1\nG1 Z-0.1 F5\nG1 X1\nG0 Z0.1\nM99\n"
    referee_import(text.encode(), tmp_path)
    assert any("line 6: M99 in the main program: its end" in n for n in report(text))


# -- programs against rs274 ---------------------------------------------------------------


@st.composite
def _programs(draw: st.DrawFn) -> str:
    """Small LinuxCNC programs of settings, moves, if/else, while (with breaks), do,
    repeat and calls of a subroutine, every loop bounded, each block its own label."""
    labels = iter(range(100, 1000))
    variables = [31, 32, 33]

    def expression() -> str:
        a, b = draw(st.sampled_from(variables)), draw(st.sampled_from(variables))
        n = draw(st.integers(-3, 3))
        form = draw(st.sampled_from(["#{a} + {n}", "#{a} * 0.5 - #{b}", "[#{a} MOD 3] + {n}"]))
        return "[" + form.format(a=a, b=b, n=n) + "]"

    def block(depth: int, loop: int | None) -> list[str]:
        lines: list[str] = []
        for _ in range(draw(st.integers(1, 3))):
            kinds = ["set", "move", "call"] + (["if", "while", "do", "repeat"] if depth else [])
            kinds += ["break"] if loop is not None else []
            kind = draw(st.sampled_from(kinds))
            v = draw(st.sampled_from(variables))
            n = draw(st.integers(1, 3))
            if kind == "set":
                lines.append(f"#{v}={expression()}")
            elif kind == "move":
                lines.append(f"G0 X#{v} Y{expression()}")
            elif kind == "call":
                lines.append(f"o<s> call [#{v}] [{n}]")
            elif kind == "break":
                label = next(labels)
                lines += [f"o{label} if [#{v} GT {n}]", f"o{loop} break", f"o{label} endif"]
            elif kind == "if":
                label = next(labels)
                lines += [f"o{label} if [#{v} GT {n}]", *block(depth - 1, loop)]
                if draw(st.booleans()):
                    lines += [f"o{label} else", *block(depth - 1, loop)]
                lines.append(f"o{label} endif")
            elif kind == "repeat":
                label = next(labels)
                lines += [f"o{label} repeat [{n}]", *block(depth - 1, None), f"o{label} endrepeat"]
            else:
                label = next(labels)
                counter = 40 + label % 50
                step = f"#{counter}=[#{counter}+1]"
                test = f"[#{counter} LT {n}]"
                if kind == "while":
                    body = [step, *block(depth - 1, label)]
                    lines += [f"#{counter}=0", f"o{label} while {test}", *body]
                    lines.append(f"o{label} endwhile")
                else:
                    body = [step, *block(depth - 1, label)]
                    lines += [f"#{counter}=0", f"o{label} do", *body, f"o{label} while {test}"]
        return lines

    sub = ["o<s> sub", "#34=[#1 * 2 + #2]", "G0 X#1 Y#34", "o<s> endsub"]
    start = [f"#{v}={draw(st.integers(-2, 2))}" for v in variables]
    return "\n".join(["G20", *sub, *start, *block(2, None), "M2", ""])


@given(_programs())
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_programs_run_as_rs274_runs_them(text: str) -> None:
    """Random programs of LinuxCNC's control flow, settings and calls: every move where
    rs274 makes it, in its order (its breaks' stale flags included)."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "flow.ngc"
        path.write_text(text)
        theirs_ = [m.end[:2] for m in rs274(path) if m.kind == "T"]
    ours_: list[tuple[float, float]] = []
    here = (0.0, 0.0)
    for line in ngc.expand(text.split("\n"), Notes()):
        if line.text.startswith("G0 "):
            words = {w[0]: float(w[1:]) for w in line.text.split()[1:]}
            point = (round(words.get("X", here[0]), 4), round(words.get("Y", here[1]), 4))
            if point != here:  # (rs274 leaves out a move to where the tool is)
                ours_.append(point)
            here = point
    assert len(ours_) == len(theirs_), text
    assert [c for p in ours_ for c in p] == pytest.approx(
        [c for p in theirs_ for c in p], abs=1.1e-4
    ), text


# -- bounds -------------------------------------------------------------------------------


def test_a_loop_that_never_ends_is_refused_naming_it() -> None:
    """issue 30: no request may take the server down. Before: refused as an O-word; a
    front end without a bound would run it for ever."""
    assert failure("G20\n#1=0\no7 while [#1 LT 1]\nG0 X1\no7 endwhile\nM2\n").startswith(
        f"line 3, column 1: o7 while has run {MAX_EXPANDED_LINES // 3:,} times and the "
        f"program {MAX_EXPANDED_LINES:,} lines: a loop that does not end?"
    )
    assert failure("G20\no7 do\no7 while [1]\nM2\n").startswith("line 2, column 1: o7 do has run")


def test_too_many_lines_in_all_is_refused() -> None:
    """A finite loop past the bound (each line each time counted): refused, not run."""
    assert "a loop that does not end?" in failure(
        f"G20\no1 repeat [{MAX_EXPANDED_LINES}]\nG0 X1\no1 endrepeat\nM2\n"
    )


def test_an_m98_repeated_past_the_bound_is_refused_naming_it() -> None:
    assert failure("G20\nM98 P1 L1000000\nM30\nO1\nG0 X1\nM99\n").startswith(
        "line 2, column 1: M98 has run 25,000 times and the program 50,000 lines"
    )


def test_a_subroutine_that_calls_itself_for_ever_is_refused() -> None:
    assert failure("G20\no<r> sub\no<r> call\no<r> endsub\no<r> call\nM2\n").startswith(
        "line 3, column 1: o<r> call: more than 9 calls deep (LinuxCNC's limit)"
    )


# -- the fast path ------------------------------------------------------------------------


def test_a_parameter_on_the_last_line_reads_the_whole_file_once_more() -> None:
    """A file is read straight until a line needs the front end, then again from the start
    with it: the report is that of one reading (its notes once each), and the moves are
    those of the whole file."""
    text = "G20\nG0 X0 Y0 Z0.1\nG1 Z-0.1 F5\nG1 X1\nG1 X[1+1]\nG0 Z0.1\nM2\n"
    notes = report(text)
    assert sum("G20: the program and every block are inch" in n for n in notes) == 1
    program = read_program(text.encode(), "t", "gcode").program
    assert [b.x for b in program.blocks if isinstance(b, MillLine)] == [
        Decimal("1.000"),
        Decimal("2.000"),
    ]


# -- LinuxCNC's own examples (tests/imports/gcode-corpus, SOURCES.md) ---------------------


def test_hole_circle_drills_a_bolt_circle(tmp_path: Path) -> None:
    """hole-circle.ngc: `G91 G81 R.1 Z-.5 ^60 L6`, six holes 60° apart about program zero
    (LinuxCNC's polar coordinates: ^ turns the tool's position about program zero). The
    holes are rs274's (MillBlocks drills them clockwise: the order differs)."""
    text = fixture_text(f"{CORPUS}/hole-circle.ngc")
    referee_import(text.encode(), tmp_path, any_order=True)
    program = read_program(text.encode(), "hole-circle.ngc", "gcode").program
    bolt = next(b for b in program.blocks if isinstance(b, BoltCircle))
    assert (bolt.holes, bolt.radius) == (6, Decimal("1.500"))


def test_spiral_is_800_polar_steps(tmp_path: Path) -> None:
    """spiral.ngc: `o100 repeat [800]` of `G91 G1 @-.0025 ^4.5` (each step 4.5° on and
    0.0025 in in): 800 feed moves where rs274 cuts them, within the 0.001 in the blocks
    hold (0.0005 rounding; the report's rounding note lists the first few, then a count)."""
    text = fixture_text(f"{CORPUS}/spiral.ngc")
    referee_import(text.encode(), tmp_path)
    program = read_program(text.encode(), "spiral.ngc", "gcode").program
    assert sum(isinstance(b, MillLine) for b in program.blocks) == 800
    rounded = [n for n in report(text) if n.startswith("rounded: line 9")]
    assert rounded and rounded[0].endswith(" and 1552 more") and len(rounded[0]) < 400


def test_useful_subroutines_is_refused_in_the_call_that_reaches_its_first_problem() -> None:
    """useful-subroutines.ngc mills holes with G41 and helical arcs: refused where its
    subroutine first does what MillBlocks cannot (a rapid across with compensation on), at
    the subroutine's line and column, saying which call reached it. Without that rapid's
    G41 the hole's helical arcs read as a HELIX (issue 33), and the refusal moves on to the
    slot subroutine's own rapid with compensation on."""
    text = fixture_text(f"{CORPUS}/useful-subroutines.ngc")
    assert failure(text).startswith(
        "line 24, column 1: a rapid move in X/Y with cutter compensation on"
    ) and failure(text).endswith("(in o100, called at line 79)")
    without_comp = text.replace("g41 g0 x#1", "g0 x#1")
    assert failure(without_comp).startswith(
        "line 51, column 1: a rapid move in X/Y with cutter compensation on"
    ) and failure(without_comp).endswith("(in o200, called at line 88)")


def test_retval_reports_its_calls_and_debug_messages() -> None:
    """retval.ngc: three calls of o1000 (no moves), each named; its (debug, …) messages
    are LinuxCNC's screen output, said not carried."""
    notes = report(fixture_text(f"{CORPUS}/retval.ngc"))
    calls = [n for n in notes if "o1000 call: o1000 sub (lines 3-12) expanded" in n]
    assert calls == [
        "became: line 14: o1000 call: o1000 sub (lines 3-12) expanded (also lines 19, 24)"
    ]
    assert any(
        n.startswith("ignored: line 15: (DEBUG, …): a message on LinuxCNC's screen; not carried")
        for n in notes
    )


def test_a_comment_beside_a_setting_does_not_name_the_program() -> None:
    """`#1=0.5 (DEPTH)` is a setting with a comment, not a title line (the first comment
    alone on a line names the program)."""
    program = read_program(b"#1=0.5 (DEPTH)\nG20\nG0 X0 Y0 Z0.1\nM2\n", "part.ngc", "gcode")
    assert program.program.name != "DEPTH"


def test_factorial_defines_and_never_calls() -> None:
    """factorial.ngc defines a recursive subroutine and ends: nothing to cut, said so."""
    notes = report(fixture_text(f"{CORPUS}/factorial.ngc"))
    assert any(
        "line 3: o<factorial> sub (lines 3-10) is never run: not imported" in n for n in notes
    )


def test_g5_splines_are_refused_not_cut_as_lines() -> None:
    """Before: G5.1 (a quadratic spline, LinuxCNC's systems.ngc writes its letters so) was
    "not a code MillBlocks knows" and its X/Y were then cut as straight G1 moves."""
    assert failure("G20\nG0 X0 Y0 Z0.1\nG1 Z-0.1 F5\nG5.1 X1 Y1 I0.5 J0\n").startswith(
        "line 4, column 1: G5.1: a quadratic spline is not supported"
    )
