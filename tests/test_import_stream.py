"""The G-code importer streams (issue 31 point 4; docs/imports.md, "Streaming").

`millblocks export big.ngc --to tape-eia` of a long CAM file must run in memory that does not
grow with the file: the lines are read as the segmenter asks for them, the steps it has
passed are let go, and operations are recognised a batch of `BATCH_OPS` at a time. What
streaming reads must be what the whole file reads: every file the suite has imports to the
same program and report either way, and one longer than a batch still cuts as rs274 reads it.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest
from hypothesis import given
from hypothesis import strategies as st

from app.cnc import document
from app.cnc.blocks import Program
from app.cnc.compiler import compile_program
from app.cnc.formats import reading
from app.cnc.formats.gcode.bossread import looks_segmented
from app.cnc.formats.gcode.reader import parse_gcode
from app.cnc.formats.importers import _COMMENT, PLAIN_PART, Content
from app.cnc.formats.reading import (
    DETECT_BYTES,
    ImportFailure,
    detect_format,
    file_head,
    read_program,
)
from app.cnc.path import Op
from app.cnc.recognition.common import (
    byte_lines,
    chunk_lines,
    decode_text,
    split_lines,
    text_lines,
)
from app.cnc.recognition.motion import program_from_motion
from app.cnc.recognition.segment import BATCH_OPS, segment
from bench.gcode_import import gcode_text

ROOT = Path(__file__).resolve().parents[1]
IMPORTS = Path(__file__).parent / "imports"
GCODE = sorted(
    p
    for p in IMPORTS.rglob("*")
    if p.suffix.lower() in (".ngc", ".nc", ".gcode", ".tap", ".cnc") and p.is_file()
)


# Runs the command and prints its peak RSS (KiB). A process's peak counts the memory of the
# process it was forked from (Linux keeps the high-water mark across exec), so the command
# is started from this small process, not from the test's: a test process larger than the
# command made both sizes read alike.
_LAUNCH = """
import os, subprocess, sys
child = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
error = child.stderr.read()
_, status, usage = os.wait4(child.pid, 0)
sys.stderr.buffer.write(error[-2000:])
print(usage.ru_maxrss)
sys.exit(os.waitstatus_to_exitcode(status))
"""


def _peak_rss(lines: int, tmp_path: Path, *command: str) -> int:
    """Peak resident size (bytes) of `millblocks check` (or `millblocks COMMAND`) reading
    a generated file, as a process of its own."""
    path = tmp_path / f"part-{lines}.ngc"
    path.write_text(gcode_text(lines))
    env = {k: v for k, v in os.environ.items() if not k.startswith("MILLBLOCKS_")}
    env["MILLBLOCKS_INSTANCE_PATH"] = str(tmp_path / "instance")
    cli = [sys.executable, "-m", "app.cli", *(command or ("check",)), str(path)]
    run = subprocess.run(
        [sys.executable, "-c", _LAUNCH, *cli], cwd=ROOT, env=env, capture_output=True
    )
    assert run.returncode == 0, run.stderr.decode()
    return int(run.stdout) * 1024


def test_a_ten_times_longer_file_takes_no_more_memory_than_its_own_text(tmp_path: Path) -> None:
    """2 x 10^4 and 2 x 10^5 lines of the bench's CAM-style file through the command line:
    the longer one may hold its bytes and text (detection and the reader each decode it
    once), and nothing per line beyond that. Before streaming every line, step and
    operation was held at once: 2 x 10^5 lines took 63 MB more than 2 x 10^4."""
    small, large = _peak_rss(20_000, tmp_path), _peak_rss(200_000, tmp_path)
    size = len(gcode_text(200_000)) - len(gcode_text(20_000))
    assert large - small < 8 * size, (
        f"{(large - small) / 1e6:.1f} MB more for 180 000 more lines ({size / 1e6:.1f} MB of text)"
    )


def test_a_conversion_to_tape_takes_flat_memory_once_a_batch_is_full(tmp_path: Path) -> None:
    """`millblocks export part.ngc --to tape-eia` of 5 x 10^4 and 2 x 10^5 lines of the
    bench's CAM-style file (both past one recognition batch, about 27 000 lines): the
    longer one may take less than 4 MB more, under its 2.6 MB of further text — the file
    is read a part at a time, not held as bytes and text (docs/imports.md, "Streaming").
    Before, 11 MB more: the file's bytes and detection's text, a report line per bolt
    circle, and validation's list of every hole (about 330 bytes each) to find none that
    needs a pilot."""
    out = str(tmp_path / "part.tape")
    convert = ("--max-moves", "10000000", "export", "--to", "tape-eia", "-o", out)
    small = _peak_rss(50_000, tmp_path, *convert)
    large = _peak_rss(200_000, tmp_path, *convert)
    assert large - small < 4_000_000, f"{(large - small) / 1e6:.1f} MB more for 4 x the lines"


def _whole(text: str) -> tuple[str, list[object]] | str:
    """The file read whole, the reference (`parse_gcode` then recognition): the program
    and report, or the refusal."""
    try:
        parsed = parse_gcode(text, "part")
        return document.dumps(program_from_motion(parsed)), list(parsed.notes.report())
    except ImportFailure as exc:
        return str(exc)


def _imported(data: bytes) -> tuple[str, list[object]] | str:
    try:
        result = read_program(data, "part", "gcode", limited=False)
        return document.dumps(result.program), list(result.report)
    except ImportFailure as exc:
        return str(exc)


@pytest.mark.parametrize("path", GCODE, ids=[str(p.relative_to(IMPORTS)) for p in GCODE])
def test_every_file_imports_as_the_whole_file_reads(path: Path) -> None:
    """The same program, report (in order) or refusal as reading the whole file, for
    every G-code file here, as written and in lower case (the word-by-word path)."""
    data = path.read_bytes()
    try:
        text = decode_text(data)
    except ImportFailure:
        pytest.skip("not text")
    for variant in (text, text.lower()):
        assert _imported(variant.encode()) == _whole(variant)


# Holes enough that the segmenter starts long before the file's end (the stream reads
# STREAM_LINES ahead): what comes after them is what the start could not say.
HOLES = "G0 X1 Y1\nG1 Z-0.1\nG0 Z0.1\nG0 X2 Y1\nG1 Z-0.1\nG0 Z0.1\n" * 100


@pytest.mark.parametrize(
    "text",
    [
        # The finest number comes late: the tolerance the start gave changes.
        "G20 G90\nT1 M6\nS1000 M3\nG0 X0 Y0 Z0.1\nG1 Z-0.1 F5\nG0 Z0.1\n"
        + HOLES
        + "G0 X1.00001 Y2\nG1 Z-0.1\nG0 Z0.1\nM30\n",
        # No tool named until a G43 H late in the file: that tool was in the spindle.
        "G20\nG0 X0 Y0 Z0.1\nS1000 M3\nG1 Z-0.1 F5\nG0 Z0.1\n"
        + HOLES
        + "G43 H2\nG0 X3 Y3\nG1 Z-0.1\nG0 Z0.1\nM30\n",
        # A tool past the control's 24.
        "G20\nG0 X0 Y0 Z0.1\nT32 M6\nS900 M3\nG1 Z-0.2 F4\nG0 Z0.1\n" + HOLES + "M30\n",
        # The unit comes after the first moves (inches assumed until then).
        "G0 X0 Y0 Z0.1\nT1 M6\nS900 M3\nG1 Z-0.2 F4\nG0 Z0.1\n" + HOLES + "G21\nM30\n",
        # A tool's diameter given after a compensated cut used it.
        "G20\nT1 M6\nS1000 M3\nG0 X0 Y0 Z0.1\nG1 Z-0.1 F5\nG41 D1 G1 X1 Y0 F10\nX1 Y1\n"
        "G40 G0 Z0.1\n" + HOLES + "G10 L1 P1 R0.125\nM30\n",
        # Refused late, after a segmenting error early: the reader's refusal is the one.
        "G20\nT1 M6\nG0 X0 Y0 Z0.1\nG1 X1 Y1 F5\nG0 Z1\n" + HOLES + "G1 X2 Y2 Z-1 Q\n",
    ],
    ids=[
        "late-decimals",
        "late-first-tool",
        "tool-32",
        "late-unit",
        "late-diameter",
        "late-refusal",
    ],
)
def test_what_the_start_of_a_file_cannot_say_is_read_from_the_whole_file(text: str) -> None:
    """Streaming starts with the set-up as the file's start gives it; where the rest of the
    file changes it, the import is the whole file's."""
    assert _imported(text.encode()) == _whole(text)


def _moves(program: Program) -> npt.NDArray[np.void]:
    """The program's moves as compiled: kind, end, arc centre, feed (block numbers apart)."""
    path = compile_program(program).path
    rows = np.concatenate([chunk.rows for chunk in path.chunks()])
    return rows[["op", "x", "y", "z", "cx", "cy", "feed"]]


def test_a_file_longer_than_a_batch_cuts_where_the_whole_file_does() -> None:
    """40 000 lines: more operations than a batch of recognition, so bolt circles and LOOPs
    are found batch by batch (and LOOPs again across batches), and the blocks differ from
    the whole file's reading. The program makes the same moves in the same order, each
    within the programming resolution (0.001 in) of the whole reading's: a LOOP's body
    rounds its own increments, so where a pattern is cut apart differently a point may
    round the other way, as the report says."""
    text = gcode_text(40_000)
    assert len(segment(parse_gcode(text, "part")).ops) > BATCH_OPS
    streamed = read_program(text.encode(), "part", "gcode", limited=False).program
    whole = program_from_motion(parse_gcode(text, "part"))
    assert len(streamed.blocks) < 200  # (its bolt circles and LOOPs found)
    ours, theirs = _moves(streamed), _moves(whole)
    assert len(ours) == len(theirs) > 70_000
    assert (ours["op"] == theirs["op"]).all() and (ours["feed"] == theirs["feed"]).all()
    moving = ours["op"] <= Op.ARC_CCW
    arcs = (ours["op"] == Op.ARC_CW) | (ours["op"] == Op.ARC_CCW)
    resolution = 25_400  # nm
    for axis in ("x", "y", "z"):
        off = np.abs(ours[axis] - theirs[axis])
        assert off[moving].max() <= resolution, axis
    for axis in ("cx", "cy"):
        off = np.abs(ours[axis] - theirs[axis])
        assert off[arcs].max() <= resolution, axis


def test_detection_reads_past_the_first_part_of_a_long_file() -> None:
    """Detection blanks comments a part of the text at a time: a comment open across a
    part's end is blanked to its ')' as in the whole text, and a BOSS segment mark far down
    the file is found, on the line the whole text gives it — not the `$` in the comment."""
    head = "G0 X1.0 Y1.0\n" * (PLAIN_PART // 13 - 2)
    comment = "(A COMMENT THAT RUNS ON\n$\nPAST THE PART)\n"
    text = head + comment + "G1 X2.0 Y2.0 F10.0\n" * 30_000 + "$\n"
    content = Content(text.encode())
    assert len(list(content.plain())) > 2
    whole = _COMMENT.sub(" ", text)
    assert "".join(content.plain()) == whole
    mark = whole.split("\n").index("$") + 1
    assert looks_segmented(content.plain()) == f"line {mark}: $, a BOSS tape's segment mark"
    assert detect_format(text.encode()) == "boss"


@given(
    st.lists(st.sampled_from(["a", "é", "\r", "\n", "\r\n", "\ufeff", " "]), max_size=30).map(
        "".join
    )
)
def test_lines_read_one_at_a_time_are_the_lines_of_the_whole_text(text: str) -> None:
    """CR LF, CR and LF each end a line, from the text or (decoded line by line) from its
    bytes, as splitting the whole text does."""
    assert list(text_lines(text)) == split_lines(text)
    assert list(byte_lines(text.encode())) == split_lines(text.lstrip("\ufeff"))


@given(
    st.lists(st.sampled_from(["a", "é", "\r", "\n", "\r\n", "\ufeff", " "]), max_size=30).map(
        "".join
    ),
    st.lists(st.integers(0, 60), max_size=6),
)
def test_lines_of_a_file_read_a_part_at_a_time_are_the_lines_of_its_bytes(
    text: str, cuts: list[int]
) -> None:
    """A file read in parts (`chunk_lines`, the command line's G-code import) has the
    lines of its bytes whole, wherever the parts end: inside a CR LF, a UTF-8 character or
    a byte order mark."""
    data = text.encode()
    ends = sorted({min(cut, len(data)) for cut in cuts})
    parts = [data[a:b] for a, b in zip([0, *ends], [*ends, len(data)], strict=True)]
    assert list(chunk_lines(parts)) == list(byte_lines(data))


def _lines_until_refused(lines: Iterator[str]) -> tuple[list[str], bool]:
    """The lines read before a refusal, and whether there was one."""
    read: list[str] = []
    try:
        read.extend(lines)
    except ImportFailure:
        return read, True
    return read, False


@given(
    st.lists(
        st.sampled_from([b"a", b"\xc3\xa9", b"\n", b"\r\n", b"\xff", b"G1 X1\n", b"(" * 70_000]),
        max_size=12,
    ).map(b"".join),
    st.lists(st.integers(0, 1_000_000), max_size=4),
)
def test_a_file_read_in_parts_gives_its_lines_up_to_a_byte_that_is_not_text(
    data: bytes, cuts: list[int]
) -> None:
    """A file read in parts has, line for line, the lines of its bytes read whole — lines
    longer than a part, and those before a byte that is not UTF-8 — and is refused at
    that byte (the parts are decoded many lines at a time where they can be)."""
    ends = sorted({min(cut, len(data)) for cut in cuts})
    parts = [data[a:b] for a, b in zip([0, *ends], [*ends, len(data)], strict=True)]
    assert _lines_until_refused(chunk_lines(parts)) == _lines_until_refused(byte_lines(data))


def test_the_command_line_reads_a_long_file_as_its_bytes_read(tmp_path: Path) -> None:
    """A file longer than detection's DETECT_BYTES, read from disk a part at a time
    (`reading.read_file`, as `millblocks` reads a file): detected from its start as
    G-code, the same program and report as its bytes read whole; and a punch image
    (bytes that are not text) still detected as a tape from its start."""
    text = gcode_text(70_000)
    assert len(text) > DETECT_BYTES
    path = tmp_path / "part.ngc"
    path.write_text(text)
    with path.open("rb") as file:
        head = file_head(file)
        assert len(head) <= DETECT_BYTES and head.endswith(b"\n")
        result = reading.read_file(file, "part")
    whole = read_program(text.encode(), "part", limited=False)
    assert result.format == whole.format == "gcode"
    assert document.dumps(result.program) == document.dumps(whole.program)
    assert result.report == whole.report
    punched = tmp_path / "part.tape"
    punched.write_bytes(bytes([0x80, 0x00, 0x2B]) * (DETECT_BYTES // 2))
    with punched.open("rb") as file:
        assert detect_format(file_head(file)) == "tape"
