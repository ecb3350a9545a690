"""Fuzzing: every reader raises nothing but `ImportFailure`, whatever it is given.

Each reader gets `MILLBLOCKS_FUZZ_EXAMPLES` inputs (1 000 in the normal run): real files
(our own exports of golden programs, seed samples) with bytes changed, inserted and
deleted; soups of the words the formats are made of; and plain random bytes. An input
either imports or fails with the documented error — any other exception is a bug.

The long run (docs/imports.md), at least 100 000 inputs per reader:

    MILLBLOCKS_FUZZ_EXAMPLES=100000 .venv/bin/pytest tests/test_import_fuzz.py

(or `.venv/bin/python bench/fuzz_imports.py 100000`). The examples are derandomized — the
same inputs every run — unless MILLBLOCKS_FUZZ_RANDOM=1.

DXF drawings (issue 30) are read by ezdxf, slower than our own readers: 300 of them
(`MILLBLOCKS_FUZZ_DXF_EXAMPLES`), the DXF test drawings damaged as `bench/fuzz_long.py`
damages them (tags changed, group codes swapped, cut short, written as binary DXF, bytes
flipped); its long run is `python -m bench.fuzz_long N --parsers dxf`.
"""

from __future__ import annotations

import contextlib
import os
import random
from functools import cache

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.cnc import document
from app.cnc.formats.reading import ImportFailure, read_program
from app.cnc.formats.targets import ExportError, export
from bench.fuzz_long import corpus as long_corpus
from bench.fuzz_long import generate, read_dxf
from tests.imports.support import GOLDEN, HERE, load

EXAMPLES = int(os.environ.get("MILLBLOCKS_FUZZ_EXAMPLES", "1000"))
FUZZ = settings(
    max_examples=EXAMPLES,
    deadline=None,
    derandomize=os.environ.get("MILLBLOCKS_FUZZ_RANDOM") != "1",
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
# Small golden programs: their files are short, so many mutants run in the time.
CASES = [
    "bolt-circle-drill",
    "bore",
    "circle-inside",
    "contour-cut-right",
    "coolant-and-messages",
    "drill-12-pecks",
    "frame-in-tan",
    "loop-rep-grid",
    "mill-contour-uncompensated",
    "mixed-units",
    "stop-and-tool-changes",
    "tap-metric",
    "two-axis",
]
SEEDS = {
    "gcode": ["seed003-2.2.6.1.ngc", "seed003-2.2.6.2.ngc"],
    "events": ["seed003-2.2.5.cnc", "seed003-2.2.6.3.cnc"],
    "tape": ["seed000-table-3-1.tape", "seed000-table-4-1.tape", "seed000-table-4-2.tape"],
}
TARGETS = {
    "gcode": ["gcode-linuxcnc", "gcode-fanuc", "gcode-prototrak"],
    "events": ["events"],
    "tape": ["tape-ascii", "tape-eia"],
    "punch": ["punch-eia", "punch-ascii"],
    "json": ["json"],
    "boss": ["tape-boss"],
}
WORDS = {
    "gcode": "G0 G1 G2 G3 G4 G17 G18 G20 G21 G28 G40 G41 G42 G43 G45 G80 G81 G82 G83 G84 G85 "
    "G89 G90 G91 G92 G98 G99 M0 M3 M4 M5 M6 M8 M9 M30 X Y Z I J K R F S T H P Q L N O "
    "0 1 -1 0.5 -0.25 1.125 2.7 0.0001 99999 % ; ( ) / # [ \n \n \t .",
    "events": "G100 G101 G102 G103 G104 G105 G106 G107 G108 G109 G20 G21 G90 G91 PN1 X Y "
    "XB YB XE YE XC YC XD YD XO YO I J A R CR CR- F T TC D FE LE RE FC DR HL N 0 1 -1 1.2A "
    "0I .5 +1234 A 1 ; % ( ) \n",
    "boss": "%#0 #0 $ %#1 #1 T1/ G00 G01 G02 G03 G04 G70 G71 G90 G91 X Y Z I J F S T M02 M03 M06 "
    "X0.8 1. -2.5 25.4 0 % $ # ( ) / \r \n",
    "tape": "N001 G00 G01 G02 G03 G20 G30 G50 G04 G80 G81 G90 G91 G94 G98 G99 X Y Z I J K R "
    "F S T M00 M03 M06 M30 M50 M51 5000 -25000 100000 1.2345 ( ) % ; \t \n / &",
}
ALPHABET = b"GXYZIJKRFSTMNPQHDLOABCE0123456789.-+ ;%()\n\t/#&"


@cache
def corpus(kind: str) -> tuple[bytes, ...]:
    """Real files of one kind: exports of small golden programs, and the seed samples."""
    files: list[bytes] = []
    for name in CASES:
        program = load(GOLDEN / name)
        for target in TARGETS[kind]:
            try:
                files.append(export(program, target).data)
            except ExportError:
                continue
    for name in SEEDS.get(kind, []):
        files.append((HERE / name).read_bytes())
    if kind == "json":
        files.append(document.dumps(load(GOLDEN / "copy-offsets-abs")).encode())
    return tuple(files)


@st.composite
def mutants(draw: st.DrawFn, kind: str) -> bytes:
    """A real file with a few bytes changed, inserted or deleted (whole lines too)."""
    data = bytearray(draw(st.sampled_from(corpus(kind))))
    binary = kind == "punch"
    for _ in range(draw(st.integers(1, 8))):
        at = draw(st.integers(0, max(len(data) - 1, 0)))
        byte = draw(st.integers(0, 255)) if binary else draw(st.sampled_from(ALPHABET))
        action = draw(st.sampled_from(("change", "insert", "delete", "cut")))
        if action == "change" and data:
            data[at] = byte
        elif action == "insert":
            data[at:at] = bytes([byte])
        elif action == "delete" and data:
            del data[at]
        elif data:
            del data[at : at + draw(st.integers(1, 40))]
    return bytes(data)


def soup(kind: str) -> st.SearchStrategy[bytes]:
    """Words of the format in any order, joined with or without spaces."""
    words = WORDS.get(kind, WORDS["gcode"]).split(" ")
    return st.lists(st.sampled_from(words), max_size=60).map(
        lambda parts: "".join(p if p in ("\n", "\t") else p + " " for p in parts).encode()
    )


def inputs(kind: str) -> st.SearchStrategy[bytes]:
    return st.one_of(mutants(kind), soup(kind), st.binary(max_size=300))


def survives(data: bytes, fmt: str | None) -> None:
    with contextlib.suppress(ImportFailure):
        read_program(data, "fuzz", fmt)


@FUZZ
@given(inputs("gcode"))
def test_gcode_reader_raises_only_import_failures(data: bytes) -> None:
    survives(data, "gcode")


@FUZZ
@given(inputs("boss"))
def test_boss_reader_raises_only_import_failures(data: bytes) -> None:
    survives(data, "boss")


@FUZZ
@given(inputs("events"))
def test_events_reader_raises_only_import_failures(data: bytes) -> None:
    survives(data, "events")


@FUZZ
@given(inputs("tape"))
def test_tape_listing_reader_raises_only_import_failures(data: bytes) -> None:
    survives(data, "tape")


@FUZZ
@given(st.one_of(mutants("punch"), st.binary(max_size=400)))
def test_punch_image_reader_raises_only_import_failures(data: bytes) -> None:
    survives(data, "tape")


@FUZZ
@given(st.one_of(mutants("json"), st.binary(max_size=200)))
def test_json_reader_raises_only_import_failures(data: bytes) -> None:
    survives(data, "json")


@FUZZ
@given(st.one_of(inputs("gcode"), inputs("events"), inputs("tape"), mutants("punch")))
def test_detection_raises_only_import_failures(data: bytes) -> None:
    survives(data, None)


DXF_FUZZ = settings(FUZZ, max_examples=int(os.environ.get("MILLBLOCKS_FUZZ_DXF_EXAMPLES", "300")))


@cache
def dxf_drawings() -> list[bytes]:
    return long_corpus("dxf")


@DXF_FUZZ
@given(st.randoms(use_true_random=False))
def test_dxf_reader_and_choosing_page_raise_only_import_failures(rng: random.Random) -> None:
    """Import, then the choosing page's work (shown, sides, every contour and hole chosen);
    a refusal's message and the report hold no lone surrogate."""
    with contextlib.suppress(ImportFailure):
        read_dxf(generate(rng, "dxf", dxf_drawings()))
