"""The long fuzz run (issue 17; docs/imports.md): N inputs per parser, none may crash.

    .venv/bin/python -m bench.fuzz_long [N] [--workers W] [--parsers gcode,events,...]
                                        [--seed S] [--out DIR]

Every parser that reads outside text gets N inputs (default 1 000 000): the golden exports
in tests/golden (expected.gcode-*, .events, .tape-*, .punch-*, .json, program.json) and
the seed samples in tests/imports, mutated (bytes changed, inserted, deleted, runs cut,
duplicated or swapped, numbers replaced by hostile ones), soups of each format's words,
and random bytes. An input must be read or refused with the parser's documented error
(ImportFailure, DocumentError, NumberError, LibraryError); anything else is a crash, and
so is an input that takes longer than --slow seconds (unbounded work). Crashing inputs are
written to --out. The inputs are a function of (--seed, parser, index), so a run repeats.

The normal `make test` run is tests/test_import_fuzz.py (hypothesis, 1 000 per reader).
"""

from __future__ import annotations

import argparse
import io
import logging
import multiprocessing
import random
import signal
import sys
import time
import traceback
import zipfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType

ROOT = Path(__file__).resolve().parent.parent
GOLDEN = ROOT / "tests" / "golden"
SAMPLES = ROOT / "tests" / "imports"

HOSTILE_NUMBERS = [
    b"1E+999999999", b"1e-999999999", b"NaN", b"-Infinity", b"\xc2\xb2", b"--5", b"1_000",
    b"\xef\xbc\x91\xef\xbc\x92", b"\xd9\xa3", b"9" * 400, b"-", b".", b"+-1", b"0x1F", b"1,5",
    b"00000000000000000000001", b"-0", b"1e", b"", b"\x00", b"99999999999999999999.9",
]  # fmt: skip

WORDS = {
    "gcode": "G0 G1 G2 G3 G4 G17 G20 G21 G28 G40 G41 G42 G43 G80 G81 G82 G83 G84 G85 G90 G91 "
    "G92 G98 G99 M0 M3 M4 M5 M6 M8 M9 M30 X Y Z I J K R F S T H P Q L N O 0 1 -1 0.5 1.125 "
    "99999 % ; ( ) / # [ ] \n \t .",
    "events": "G100 G101 G102 G103 G104 G105 G106 G107 G108 G109 G20 G21 G90 G91 PN1 X Y XB "
    "YB XE YE XC YC XD YD XO YO I J A R CR CR- F T TC D FE LE RE FC DR HL N 0 1 -1 1.2A 0I .5 "
    "+1234 ; % ( ) \n",
    "tape": "N001 G00 G01 G02 G03 G20 G30 G50 G04 G80 G81 G90 G91 G94 G98 G99 X Y Z I J K R F "
    "S T M00 M03 M06 M30 M50 M51 5000 -25000 100000 1.2345 ( ) % ; \t \n / &",
    "json": '{ } [ ] : , "format" "millblocks-program" "version" 1 "blocks" "type" "POS" "x" '
    '"y" "tool" "units" "inch" "mm" "data_block_0" "tools" 0.5 -1 true false null 1e30 "',
    "numbers": "0 1 2 9 . - + e E _ x , \u00b2 \uff11 \u0663 NaN inf 1e999999999",
}


def _files(pattern: str) -> list[bytes]:
    return [p.read_bytes() for p in sorted(GOLDEN.glob(pattern))]


def corpus(kind: str) -> list[bytes]:
    """The real files each parser starts from: golden exports and seed samples."""
    if kind == "gcode":
        return _files("*/expected.gcode-*") + [p.read_bytes() for p in SAMPLES.glob("*.ngc")]
    if kind == "events":
        return _files("*/expected.events") + [p.read_bytes() for p in SAMPLES.glob("*.cnc")]
    if kind == "tape":
        files = _files("*/expected.tape-ascii") + _files("*/expected.tape-eia")
        return files + [p.read_bytes() for p in SAMPLES.glob("*.tape")]
    if kind == "punch":
        return _files("*/expected.punch-*")
    if kind in ("json", "document"):
        return _files("*/program.json") + _files("*/expected.json")
    if kind == "detect":
        return corpus("gcode") + corpus("events") + corpus("tape") + corpus("punch")[:2]
    if kind == "numbers":
        return [b"1", b"-1.25", b"0.001", b"+.5", b"12", b"1e3", b"99.999", b"2539.99"]
    if kind == "backup":
        return [_backup_archive()]
    if kind == "dxf":
        return dxf_corpus()
    raise ValueError(kind)


def _backup_archive() -> bytes:
    """A real backup of two golden programs, as Library.backup writes it."""
    import tempfile

    from app.storage.library import open_library

    with tempfile.TemporaryDirectory() as folder:
        library = open_library(f"sqlite:///{folder}/fuzz.db")
        from app.cnc import document

        for name in ("drill-single", "loop-rep-grid"):
            library.create(document.loads((GOLDEN / name / "program.json").read_text()))
        out = io.BytesIO()
        library.backup(out)
        library.engine.dispose()
        return out.getvalue()


def mutate(rng: random.Random, data: bytes, binary: bool) -> bytes:
    """A few edits: bytes changed, inserted or deleted, runs cut, copied or swapped, a
    number replaced by a hostile one."""
    out = bytearray(data)
    for _ in range(rng.randint(1, 8)):
        at = rng.randrange(len(out) + 1)
        action = rng.randrange(7)
        if action == 0 and out:
            out[min(at, len(out) - 1)] = rng.randrange(256) if binary else rng.randrange(32, 127)
        elif action == 1:
            out[at:at] = bytes([rng.randrange(256)])
        elif action == 2 and out:
            del out[min(at, len(out) - 1)]
        elif action == 3:
            del out[at : at + rng.randint(1, 60)]
        elif action == 4:
            start = rng.randrange(len(out) + 1)
            out[at:at] = out[start : start + rng.randint(1, 80)]
        elif action == 5:
            out[at : at + rng.randint(0, 6)] = rng.choice(HOSTILE_NUMBERS)
        else:
            start = rng.randrange(len(out) + 1)
            a, b = out[at : at + 20], out[start : start + 20]
            out[at : at + 20], out[start : start + 20] = b, a
    return bytes(out)


def soup(rng: random.Random, kind: str) -> bytes:
    words = WORDS.get(kind, WORDS["gcode"]).split(" ")
    parts = [rng.choice(words) for _ in range(rng.randint(0, 60))]
    return "".join(p if p in ("\n", "\t") else p + " " for p in parts).encode()


def generate(rng: random.Random, kind: str, files: list[bytes]) -> bytes:
    roll = rng.random()
    if kind == "dxf":
        return mutate_dxf(rng, rng.choice(files)) if roll < 0.95 else rng.randbytes(300)
    if kind == "backup":
        return _mutate_archive(rng, files[0]) if roll < 0.9 else mutate(rng, files[0], True)
    if roll < 0.7:
        return mutate(rng, rng.choice(files), kind in ("punch", "backup"))
    if roll < 0.9:
        return soup(rng, kind)
    return rng.randbytes(rng.randint(0, 300))


def _mutate_archive(rng: random.Random, archive: bytes) -> bytes:
    """A backup whose members (the manifest above all) are mutated and re-zipped."""
    with zipfile.ZipFile(io.BytesIO(archive)) as source:
        members = {name: source.read(name) for name in source.namelist()}
    names = list(members)
    for _ in range(rng.randint(1, 3)):
        name = "manifest.json" if rng.random() < 0.6 else rng.choice(names)
        members[name] = mutate(rng, members[name], False)
    if rng.random() < 0.1:
        del members[rng.choice(names)]
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as target:
        for name, data in members.items():
            target.writestr(name, data)
    return out.getvalue()


# -- DXF drawings (issue 30) ----------------------------------------------------------------

# Values a damaged or hostile drawing puts where a number, a name or a structure word goes.
DXF_VALUES = [
    b"", b"0", b"-1", b"1e308", b"-1e308", b"nan", b"inf", b"-inf", b"1E+999999999", b"1e-320",
    b"32768", b"-32769", b"4294967296", b"9" * 40, b"\xff\xfe", b"\xed\xa0\x80", b"\xc3",
    b"x" * 300, b"SECTION", b"ENDSEC", b"EOF", b"HEADER", b"CLASSES", b"TABLES", b"BLOCKS",
    b"ENTITIES", b"OBJECTS", b"TABLE", b"ENDTAB", b"LAYER", b"BLOCK_RECORD", b"BLOCK", b"ENDBLK",
    b"*Model_Space", b"*Paper_Space", b"LINE", b"ARC", b"CIRCLE", b"LWPOLYLINE", b"POLYLINE",
    b"VERTEX", b"SEQEND", b"INSERT", b"LAYOUT", b"DICTIONARY", b"ACAD_GROUP", b"$ACADVER",
    b"AC1009", b"AC1015", b"AC1032", b"AC9999", b"$INSUNITS", b"$DWGCODEPAGE", b"ANSI_1252",
    b"ANSI_9999", b"FFFF", b"0", b"1F", b"\\U+D800", b"\\M+5D800", b"%%u", b"{\\fArial|b1;",
]  # fmt: skip
DXF_CODES = [
    0, 1, 2, 3, 5, 6, 8, 9, 10, 11, 20, 21, 30, 31, 39, 40, 42, 43, 50, 51, 62, 66, 70, 71, 72,
    90, 100, 102, 105, 210, 220, 230, 290, 310, 330, 340, 360, 370, 999, 1000, 1001, 1002, 1004,
    1010, 1020, 1040, 1071, -1, -2, 4, 255, 256, 1072, 5000,
]  # fmt: skip


def dxf_corpus() -> list[bytes]:
    """The DXF test drawings (text, as ezdxf writes them) and small hand-written ones that
    reach the entities quickly: every kind the reader takes, and some it leaves out."""
    from tests.test_drawings_side import outline_and_slot
    from tests.test_import_dxf import CASES

    drawings = [make() for make, _options in CASES.values()] + [outline_and_slot()]
    return drawings + [
        _small_dxf(units, version) for units in (1, 4, 0) for version in ("", "AC1015")
    ]


def _small_dxf(units: int, version: str) -> bytes:
    """A drawing of a few hundred bytes: a header, then one entity of each kind (R12 when
    `version` is empty)."""
    header = f"9\n$INSUNITS\n70\n{units}\n"
    if version:
        header = f"9\n$ACADVER\n1\n{version}\n" + header
    entities = (
        "0\nLINE\n5\n2A\n8\n0\n10\n0\n20\n0\n30\n0\n11\n1\n21\n0\n31\n0\n"
        "0\nARC\n5\n2B\n8\nA\n10\n1\n20\n1\n40\n1\n50\n270\n51\n90\n"
        "0\nARC\n8\nA\n10\n3\n20\n1\n40\n0.5\n50\n0\n51\n180\n230\n-1\n"
        "0\nCIRCLE\n8\n0\n10\n0.5\n20\n0.5\n40\n0.125\n"
        "0\nPOLYLINE\n8\n0\n66\n1\n70\n1\n10\n0\n20\n0\n30\n0\n"
        "0\nVERTEX\n8\n0\n10\n5\n20\n5\n0\nVERTEX\n8\n0\n10\n6\n20\n5\n42\n1\n"
        "0\nVERTEX\n8\n0\n10\n6\n20\n6\n0\nSEQEND\n8\n0\n"
        "0\nTEXT\n8\nNOTES\n10\n0\n20\n-1\n40\n0.2\n1\nPART\n"
        "0\nINSERT\n8\n0\n2\nB\n10\n0\n20\n0\n"
    )
    if version:  # a light polyline is not an R12 entity
        entities += (
            "0\nLWPOLYLINE\n100\nAcDbEntity\n8\n0\n100\nAcDbPolyline\n90\n4\n70\n1\n"
            "10\n2\n20\n2\n42\n0.4142\n10\n3\n20\n2\n10\n3\n20\n3\n42\n-1\n10\n2\n20\n3\n"
        )
    text = f"0\nSECTION\n2\nHEADER\n{header}0\nENDSEC\n0\nSECTION\n2\nENTITIES\n{entities}"
    return (text + "0\nENDSEC\n0\nEOF\n").encode()


def dxf_tags(data: bytes) -> list[tuple[bytes, bytes]]:
    """A text DXF as (group code, value) line pairs (an odd last line kept as a code)."""
    lines = data.split(b"\n")
    if lines and not lines[-1]:
        lines.pop()
    if len(lines) % 2:
        lines.append(b"")
    return [(lines[k].strip(), lines[k + 1].rstrip(b"\r")) for k in range(0, len(lines), 2)]


def dxf_text(tags: list[tuple[bytes, bytes]]) -> bytes:
    return b"".join(code + b"\n" + value + b"\n" for code, value in tags)


def dxf_binary(rng: random.Random, tags: list[tuple[bytes, bytes]]) -> bytes:
    """The tags as a binary DXF: group codes of one byte (R12, no $ACADVER after AC1009) or
    two, each value in its code's type; a value that is not one is random bytes of the
    type's size (what a damaged file holds)."""
    import struct

    from ezdxf.lldxf.types import BINARY_DATA, BYTES, DOUBLE, INT16, INT32, INT64

    versions = [v for c, v in tags[:40] if c == b"1" and v.startswith(b"AC")]
    r12 = not versions or versions[0] <= b"AC1009"
    out = bytearray(b"AutoCAD Binary DXF\r\n\x1a\x00")
    for text_code, value in tags:
        try:
            code = int(text_code)
        except ValueError:
            code = rng.randrange(1100)
        code &= 0xFFFF
        if r12:
            out += bytes([code]) if code < 255 else bytes([255]) + struct.pack("<H", code)
        else:
            out += struct.pack("<H", code)
        formats = ((INT16, "<h"), (INT32, "<i"), (INT64, "<q"), (DOUBLE, "<d"), (BYTES, "<B"))
        fmt = next((f for kinds, f in formats if code in kinds), None)
        if code in BINARY_DATA:
            try:
                chunk = bytes.fromhex(value.decode("ascii"))[:255]
            except ValueError:
                chunk = value[:255]
            out += bytes([len(chunk)]) + chunk
        elif fmt is None:
            out += value.replace(b"\x00", b"") + b"\x00"
        else:
            try:
                number = float(value)
                out += struct.pack(fmt, number if fmt == "<d" else int(number))
            except (ValueError, OverflowError, struct.error):
                out += rng.randbytes(struct.calcsize(fmt))
    return bytes(out)


def mutate_dxf(rng: random.Random, data: bytes) -> bytes:
    """A DXF drawing damaged as files are: its tags changed (a group code or a value
    replaced, codes swapped, tags deleted, copied, moved, the list cut short), written as
    text or as binary DXF, then sometimes bytes flipped, inserted or cut off."""
    tags = dxf_tags(data)
    for _ in range(rng.randint(1, 5)):
        if not tags:
            break
        at = rng.randrange(len(tags))
        action = rng.randrange(9)
        code, value = tags[at]
        if action == 0:
            tags[at] = (str(rng.choice(DXF_CODES)).encode(), value)
        elif action == 1:
            tags[at] = (code, rng.choice(DXF_VALUES))
        elif action == 2:
            number = rng.choice([-1.0, 0.0, 1e-9, 2.0, 1e9, -1e15, 3.14159])
            tags[at] = (code, repr(number).encode())
        elif action == 3:
            other = rng.randrange(len(tags))
            tags[at], tags[other] = (tags[other][0], value), (code, tags[other][1])
        elif action == 4:
            del tags[at : at + rng.randint(1, 12)]
        elif action == 5:
            start = rng.randrange(len(tags))
            tags[at:at] = tags[start : start + rng.randint(1, 12)]
        elif action == 6:
            other = rng.randrange(len(tags))
            tags[at], tags[other] = tags[other], tags[at]
        elif action == 7:
            del tags[rng.randrange(len(tags) + 1) :]
        else:
            run = tags[at : at + rng.randint(1, 20)]
            del tags[at : at + len(run)]
            where = rng.randrange(len(tags) + 1)
            tags[where:where] = run
    out = dxf_binary(rng, tags) if rng.random() < 0.4 else dxf_text(tags)
    roll = rng.random()
    if roll < 0.2:
        out = mutate(rng, out, out.startswith(b"AutoCAD Binary"))
    elif roll < 0.3:
        out = out[: rng.randrange(len(out) + 1)]
    return out


# -- the parsers ----------------------------------------------------------------------------


def _parser(kind: str) -> tuple[Callable[[bytes], object], tuple[type[BaseException], ...]]:
    """The function under test and the errors it may raise."""
    from app.cnc import document
    from app.cnc.formats.reading import ImportFailure, read_program
    from app.cnc.numbers import NumberError, parse_decimal, parse_int

    if kind in ("gcode", "events", "json"):
        return (lambda data: read_program(data, "fuzz", kind)), (ImportFailure,)
    if kind in ("tape", "punch"):
        return (lambda data: read_program(data, "fuzz", "tape")), (ImportFailure,)
    if kind == "detect":
        return (lambda data: read_program(data, "fuzz", None)), (ImportFailure,)
    if kind == "document":

        def load(data: bytes) -> object:
            return document.loads(data.decode("utf-8", "replace"))

        return load, (document.DocumentError,)
    if kind == "numbers":

        def numbers(data: bytes) -> object:
            text = data.decode("utf-8", "replace")
            try:
                return parse_decimal(text)
            except NumberError:
                return parse_int(text)

        return numbers, (NumberError,)
    if kind == "backup":
        from app.storage.backup import BackupError, read_backup

        return (lambda data: read_backup(io.BytesIO(data))), (BackupError,)
    if kind == "dxf":
        # ezdxf warns of each repair it makes; a damaged file makes many (not crashes).
        logging.getLogger("ezdxf").setLevel(logging.ERROR)
        return read_dxf, (ImportFailure,)
    raise ValueError(kind)


def read_dxf(data: bytes) -> object:
    """A drawing as `millblocks import` and the choosing page read it: imported (detected,
    or as a DXF), then shown, its sides found and every contour and hole chosen. A third of
    the inputs are read as unitless drawings in inches, so that more reach the entities."""
    from app.cnc.formats.dxf.blocks import cut_sides
    from app.cnc.formats.dxf.choice import ContourChoice, HoleChoice, chosen_blocks, drawing_svg
    from app.cnc.formats.dxf.reader import parse_options, read_drawing
    from app.cnc.formats.reading import ImportFailure, read_program

    options = {"drawing-units": "inch", "hole-diameter": "0.3"} if len(data) % 3 else {}
    try:
        result = read_program(data, "fuzz", "dxf" if len(data) % 2 else None, options)
    except ImportFailure as exc:
        # A refusal the page and the terminal can show: no lone surrogates.
        str(exc).encode("utf-8")
        raise
    result.text().encode("utf-8")  # the report too
    drawing = read_drawing(data, "fuzz", parse_options(options))
    drawing_svg(drawing).encode("utf-8")
    cut_sides(drawing)
    choices = [ContourChoice(k) for k in range(len(drawing.contours))]
    chosen_blocks(drawing, [*choices, HoleChoice(tuple(range(len(drawing.holes))))])
    return result


PARSERS = (
    "gcode",
    "events",
    "tape",
    "punch",
    "json",
    "detect",
    "document",
    "numbers",
    "backup",
    "dxf",
)


@dataclass
class Tally:
    parser: str
    inputs: int = 0
    refused: int = 0
    crashes: list[str] = field(default_factory=list)
    slow: list[str] = field(default_factory=list)
    seconds: float = 0.0


class _Slow(Exception):
    pass


def _alarm(_signum: int, _frame: FrameType | None) -> None:
    raise _Slow


def run_chunk(job: tuple[str, int, int, int, float, str]) -> Tally:
    """Inputs [start, stop) of one parser (each from its own seeded generator)."""
    kind, start, stop, seed, slow_seconds, out = job
    files = corpus(kind)
    parse, allowed = _parser(kind)
    tally = Tally(kind)
    signal.signal(signal.SIGALRM, _alarm)
    began = time.monotonic()
    for index in range(start, stop):
        rng = random.Random(f"{seed}:{kind}:{index}")
        data = generate(rng, kind, files)
        signal.setitimer(signal.ITIMER_REAL, slow_seconds)
        try:
            parse(data)
        except allowed:
            tally.refused += 1
        except _Slow:
            tally.slow.append(_keep(out, kind, index, data, "slow"))
        except Exception:
            tally.crashes.append(_keep(out, kind, index, data, traceback.format_exc(limit=4)))
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
        tally.inputs += 1
    tally.seconds = time.monotonic() - began
    return tally


def _keep(out: str, kind: str, index: int, data: bytes, why: str) -> str:
    # A crash's message may hold lone surrogates (text ezdxf decoded with surrogateescape).
    why = why.encode("utf-8", "backslashreplace").decode("utf-8")
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{kind}-{index}.bin").write_bytes(data)
    (folder / f"{kind}-{index}.txt").write_text(why)
    return f"{kind}-{index}: {why.strip().splitlines()[-1]}"


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("count", nargs="?", type=int, default=1_000_000)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--parsers", default=",".join(PARSERS))
    parser.add_argument("--seed", type=int, default=17)
    parser.add_argument("--slow", type=float, default=10.0, help="seconds per input at most")
    parser.add_argument("--chunk", type=int, default=20_000)
    parser.add_argument("--out", default=str(ROOT / "instance" / "fuzz-crashes"))
    args = parser.parse_args(argv)
    kinds = [k for k in args.parsers.split(",") if k]
    jobs = [
        (kind, start, min(start + args.chunk, args.count), args.seed, args.slow, args.out)
        for kind in kinds
        for start in range(0, args.count, args.chunk)
    ]
    totals = {kind: Tally(kind) for kind in kinds}
    began = time.monotonic()
    with multiprocessing.get_context("fork").Pool(args.workers, maxtasksperchild=1) as pool:
        for tally in pool.imap_unordered(run_chunk, jobs):
            total = totals[tally.parser]
            total.inputs += tally.inputs
            total.refused += tally.refused
            total.crashes += tally.crashes
            total.slow += tally.slow
            total.seconds += tally.seconds
            done = sum(t.inputs for t in totals.values())
            print(
                f"{time.monotonic() - began:8.0f} s  {done:>9} inputs  {tally.parser}: "
                f"{total.inputs} done, {len(total.crashes)} crashes, {len(total.slow)} slow",
                flush=True,
            )
    print(f"\n{args.count} inputs per parser, seed {args.seed}, {args.workers} workers")
    print(f"{'parser':<10} {'inputs':>9} {'refused':>9} {'crashes':>8} {'slow':>5} {'cpu s':>8}")
    for t in totals.values():
        print(
            f"{t.parser:<10} {t.inputs:>9} {t.refused:>9} {len(t.crashes):>8} "
            f"{len(t.slow):>5} {t.seconds:>8.0f}"
        )
        for line in (t.crashes + t.slow)[:10]:
            print(f"    {line}")
    minutes = (time.monotonic() - began) / 60
    print(f"wall time {minutes:.1f} min")
    return 1 if any(t.crashes or t.slow for t in totals.values()) else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
