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


# -- the parsers ----------------------------------------------------------------------------


def _parser(kind: str) -> tuple[Callable[[bytes], object], tuple[type[BaseException], ...]]:
    """The function under test and the errors it may raise."""
    from app.cnc import document
    from app.cnc.imports import ImportFailure, read_program
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
    raise ValueError(kind)


PARSERS = ("gcode", "events", "tape", "punch", "json", "detect", "document", "numbers", "backup")


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
