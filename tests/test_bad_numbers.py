"""Numbers from hostile hands (issue 17, defects 5 and 9): one parser for the web forms,
the JSON document, machine limits and the CLI; a clear refusal naming the field, never a
500 or a traceback."""

from __future__ import annotations

import json
from collections.abc import Iterator
from decimal import Decimal
from pathlib import Path

import pytest
from click.testing import CliRunner
from flask import Flask
from flask.testing import FlaskClient

from app.cli import main
from app.cnc import document
from app.cnc.numbers import NumberError, parse_decimal, parse_int
from app.web.extensions import get_library
from tests.web_support import csrf, dispose, local_app

GOLDEN = Path(__file__).parent / "golden"


@pytest.fixture
def app(tmp_path: Path) -> Iterator[Flask]:
    app = local_app(tmp_path)
    yield app
    dispose(app)


@pytest.fixture
def client(app: Flask) -> FlaskClient:
    return app.test_client()


# -- the parser ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "value"),
    [("1", "1"), ("-1.5", "-1.5"), ("+.5", "0.5"), ("5.", "5"), (" 2 ", "2"), ("1e3", "1E+3")],
)
def test_numbers_as_typed(text: str, value: str) -> None:
    assert parse_decimal(text) == Decimal(value)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("²", "'²' is not a number"),
        ("--5", "'--5' is not a number"),
        ("１２", "'１２' is not a number"),  # full-width digits
        ("٣", "'٣' is not a number"),  # Arabic-Indic digit
        ("1_000", "'1_000' is not a number"),
        ("NaN", "'NaN' is not a number"),
        ("Infinity", "'Infinity' is not a number"),
        ("1E+999999999", "'1E+999999999' is too large; allowed: up to 1E+30"),
        ("1e-999999999", "'1e-999999999' has too many decimal places; allowed: at most 12"),
        ("0x10", "'0x10' is not a number"),
        ("1,5", "'1,5' is not a number"),
        ("", "no number given"),
    ],
)
def test_refused_numbers_say_what_is_allowed(text: str, message: str) -> None:
    with pytest.raises(NumberError) as caught:
        parse_decimal(text)
    assert str(caught.value).startswith(message)
    assert "allowed" in str(caught.value)


@pytest.mark.parametrize("text", ["²", "--5", "1.0", "１", "٣", "1_0", "99999999999999", "+"])
def test_whole_numbers_refused(text: str) -> None:
    with pytest.raises(NumberError):
        parse_int(text)


# -- web forms: integer fields (tool, pecks, holes, rpm, current tool) ----------------------


def post_block(client: FlaskClient, **fields: str) -> tuple[int, str]:
    data = {"csrf_token": csrf(client), "version": "1", "at": "4", "units": "inch"}
    data.update(fields)
    response = client.post("/programs/2/blocks", data=data)
    return response.status_code, response.get_data(as_text=True)


DRILL = {
    "kind": "DRILL",
    "x": "1",
    "y": "1",
    "z_up": "0.1",
    "z_dn": "-0.5",
    "feed_z": "5",
    "pecks": "1",
    "tool": "1",
}


@pytest.mark.parametrize("value", ["²", "--5", "１", "٣", "1_000"])
@pytest.mark.parametrize(("field", "label"), [("tool", "TOOL #"), ("pecks", "# PECK")])
def test_integer_fields_refuse_what_isdigit_accepts(
    client: FlaskClient, app: Flask, field: str, label: str, value: str
) -> None:
    status, page = post_block(client, **{**DRILL, field: value})
    assert status == 422
    assert f"{label}: " in page and "is not a whole number" in page
    with app.app_context():
        assert get_library().get(2).info.version == 1


def test_bolt_circle_holes_refuse_a_superscript(client: FlaskClient) -> None:
    status, page = post_block(client, kind="BOLT_CIR_DRILL", holes="²", angle="0", radius="1")
    assert status == 422 and "# HOLES: &#39;²&#39; is not a whole number" in page


@pytest.mark.parametrize(("field", "label"), [("x", "X"), ("z_dn", "Z DN"), ("feed_z", "FEEDR Z")])
def test_huge_lengths_and_feeds_are_refused_not_overflowed(
    client: FlaskClient, field: str, label: str
) -> None:
    status, page = post_block(client, **{**DRILL, field: "1E+999999999"})
    assert status == 422
    assert f"{label}: &#39;1E+999999999&#39; is too large" in page


@pytest.mark.parametrize("value", ["１", "٣", "1_000", "NaN", "--5"])
def test_lengths_refuse_other_digits_and_separators(client: FlaskClient, value: str) -> None:
    status, page = post_block(client, **{**DRILL, "x": value})
    assert status == 422 and "X: " in page and "is not a number" in page


def db0_form(client: FlaskClient, **fields: str) -> tuple[int, str]:
    data = {
        "csrf_token": csrf(client),
        "version": "1",
        "x_offset": "0",
        "y_offset": "0",
        "current_tool": "1",
        "milling": "climb",
        "z_retract": "0.1",
        "dia_1": "0.25",
        "rpm_1": "1500",
        "tcal_1": "0",
    }
    data.update(fields)
    response = client.post("/programs/2/db0", data=data)
    return response.status_code, response.get_data(as_text=True)


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("rpm_1", "²", "TOOL 1 RPM: &#39;²&#39; is not a whole number"),
        ("current_tool", "--5", "CUR-TOOL: &#39;--5&#39; is not a whole number"),
        ("z_retract", "1E+999999999", "Z RET: &#39;1E+999999999&#39; is too large"),
        ("dia_1", "٠.٢٥", "TOOL 1 DIA: &#39;٠.٢٥&#39; is not a number"),
    ],
)
def test_data_block_0_refuses_bad_numbers(
    client: FlaskClient, app: Flask, field: str, value: str, message: str
) -> None:
    status, page = db0_form(client, **{field: value})
    assert status == 422 and message in page
    with app.app_context():
        assert get_library().get(2).info.version == 1


# -- the JSON document -------------------------------------------------------------------


def sample() -> dict[str, object]:
    data: dict[str, object] = json.loads((GOLDEN / "drill-single" / "program.json").read_text())
    return data


def test_document_with_a_huge_number_is_refused_naming_the_field() -> None:
    text = (GOLDEN / "drill-single" / "program.json").read_text()
    data = sample()
    blocks = data["blocks"]
    assert isinstance(blocks, list)
    before = json.dumps(blocks[0]["x"])
    text = text.replace(f'"x": {before}', '"x": 1E+999999999', 1)
    with pytest.raises(document.DocumentError) as caught:
        document.loads(text)
    assert str(caught.value).startswith("block 1, X: '1E+999999999' is too large")


def test_document_nested_1000_deep_is_refused() -> None:
    with pytest.raises(document.DocumentError) as caught:
        document.loads("[" * 1000 + "]" * 1000)
    assert "nested" in str(caught.value)


@pytest.mark.parametrize("constant", ["NaN", "Infinity", "-Infinity"])
def test_document_refuses_json_constants(constant: str) -> None:
    text = (GOLDEN / "drill-single" / "program.json").read_text()
    text = text.replace('"z_retract": ', f'"z_retract": {constant}, "was": ', 1)
    with pytest.raises(document.DocumentError) as caught:
        document.loads(text)
    assert constant in str(caught.value)


def test_document_refuses_an_exponent_decimal_cannot_hold() -> None:
    """Found by the long fuzz run: Decimal('1e99999999999999999999') is InvalidOperation."""
    text = (GOLDEN / "drill-single" / "program.json").read_text()
    text = text.replace('"z_retract": ', '"z_retract": 1e99999999999999999999, "was": ', 1)
    with pytest.raises(document.DocumentError) as caught:
        document.loads(text)
    assert "is out of range" in str(caught.value)


def test_document_refuses_a_whole_number_of_5000_digits() -> None:
    text = (GOLDEN / "drill-single" / "program.json").read_text()
    text = text.replace('"current_tool": 1', '"current_tool": ' + "9" * 5000, 1)
    with pytest.raises(document.DocumentError) as caught:
        document.loads(text)
    assert "too large" in str(caught.value)


def test_upload_of_a_deeply_nested_document_is_refused(client: FlaskClient) -> None:
    import io

    response = client.post(
        "/programs/import",
        data={"csrf_token": csrf(client), "file": (io.BytesIO(b"{" + b'"a":[' * 1000), "x.json")},
    )
    assert response.status_code == 422
    assert "Not imported: x.json" in response.get_data(as_text=True)


# -- downloads of a program named in another script -------------------------------------


@pytest.mark.parametrize("name", ["Деталь 5", "部品", "قطعة", 'x"; filename=evil.sh'])
def test_download_of_a_program_named_in_any_script(
    client: FlaskClient, app: Flask, name: str
) -> None:
    with app.app_context():
        library = get_library()
        stored = library.get(2)
        from dataclasses import replace

        info = library.create(replace(stored.program, name=name))
    response = client.get(f"/programs/{info.id}/export/download?target=gcode-linuxcnc")
    assert response.status_code == 200
    disposition = response.headers["Content-Disposition"]
    assert disposition.startswith("attachment; filename=")
    assert "filename*=UTF-8''" in disposition
    disposition.encode("latin-1")  # a header must be latin-1
    assert 'evil.sh"' not in disposition


# -- the CLI ---------------------------------------------------------------------------------


def run(*args: str) -> tuple[int, str, str]:
    result = CliRunner().invoke(main, list(args))
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(
        result.exception
    )
    return result.exit_code, result.stdout, result.stderr


def test_a_damaged_events_line_is_exit_2_with_a_message(tmp_path: Path) -> None:
    path = tmp_path / "damaged.cnc"
    path.write_text("PN2 G20;\nN001 G106 XB1.0A YB1.0A XD2.0A YD2.0A DR1 TC2 CR- FC0;\n")
    code, _, err = run("check", str(path))
    assert code == 2
    assert "line 2" in err and "CR" in err
    assert "Traceback" not in err


@pytest.mark.parametrize("value", ["１", "1_000", "٣"])
def test_gcode_words_with_other_digits_are_refused(tmp_path: Path, value: str) -> None:
    path = tmp_path / "part.ngc"
    path.write_text(f"G20 G90\nG0 X{value} Y0\nM30\n", encoding="utf-8")
    code, _, err = run("check", "--format", "gcode", str(path))
    assert code == 2 and "line 2" in err


@pytest.mark.parametrize("value", ["NaN", "１０", "1_0", "1E+999999999"])
def test_an_export_option_that_is_no_number_is_a_usage_error(value: str) -> None:
    program = str(GOLDEN / "drill-single" / "program.json")
    option = f"sequence-start={value}"
    code, _, err = run("export", program, "--to", "gcode-linuxcnc", "-O", option)
    assert code == 2 and f"option sequence-start: {value!r}" in err


# -- defect 9: small holes ---------------------------------------------------------------


def test_a_save_without_a_version_is_refused(client: FlaskClient, app: Flask) -> None:
    data = {"csrf_token": csrf(client), "at": "4", "units": "inch", **DRILL}
    response = client.post("/programs/2/blocks", data=data)
    assert response.status_code == 422
    assert "version" in response.get_data(as_text=True)
    with app.app_context():
        assert get_library().get(2).info.version == 1


@pytest.mark.parametrize(
    ("url", "data"),
    [
        ("/programs/2/header", {"name": "Renamed", "units": "inch"}),
        ("/programs/2/db0", {"x_offset": "0", "y_offset": "0", "z_retract": "0.1"}),
        ("/programs/2/blocks/1/delete", {}),
        ("/programs/2/blocks/1/move", {"direction": "down"}),
        ("/programs/2/history/1/restore", {}),
    ],
)
def test_every_save_needs_the_version_it_is_based_on(
    client: FlaskClient, app: Flask, url: str, data: dict[str, str]
) -> None:
    response = client.post(url, data={"csrf_token": csrf(client), **data})
    assert response.status_code == 422, url
    with app.app_context():
        assert get_library().get(2).info.version == 1


def test_a_machine_named_with_a_slash_can_be_deleted(client: FlaskClient, app: Flask) -> None:
    from app.storage.library import Machine

    with app.app_context():
        get_library().save_machine(Machine("a/b", "gcode-linuxcnc", {}, {}))
    response = client.post("/machines/a/b/delete", data={"csrf_token": csrf(client)})
    assert response.status_code == 302
    with app.app_context():
        assert [m.name for m in get_library().machines()] == []


@pytest.mark.parametrize("limits", ["x=NaN 10", "x=0 NaN", "rapid=NaN", "x=0 ١٠", "max_feed=1_000"])
def test_machine_limits_refuse_nan_and_other_digits(
    client: FlaskClient, app: Flask, limits: str
) -> None:
    response = client.post(
        "/machines",
        data={
            "csrf_token": csrf(client),
            "name": "mill",
            "target": "gcode-linuxcnc",
            "limits": limits,
        },
    )
    assert response.status_code == 422
    assert "Not saved: limits: " in response.get_data(as_text=True)
    with app.app_context():
        assert get_library().machines() == []


def test_a_gcode_line_of_long_digit_runs_is_refused_without_backtracking(tmp_path: Path) -> None:
    """Found by the long fuzz run: `C999…A999…b999…` made G-code's whole-line pattern try
    every split of every digit run (17 s for 466 bytes, doubling with each word). In a
    subprocess with a watchdog: before the fix this line of 40 words never finished."""
    import subprocess
    import sys

    path = tmp_path / "runs.ngc"
    path.write_text("C" + "A".join(["9" * 30] * 40) + "b!\n")
    result = subprocess.run(
        [sys.executable, "-m", "app.cli", "check", "--format", "gcode", str(path)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 2 and "line 1" in result.stderr
