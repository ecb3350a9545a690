"""The hostile-input corpus (issue 17): every case with its surface, input, expected status
and expected message. tests/test_hostile_corpus.py runs them; none may answer 500 or end
the CLI in a traceback, and every refusal names the field, line or limit.

The tables below are the corpus; `cases(surface)` expands them:

| surface  | what is sent                                                 | expected          |
|----------|--------------------------------------------------------------|-------------------|
| block    | each numeric field of each block form × HOSTILE_NUMBERS      | 422, LABEL: reason |
| db0      | each Data Block 0 field × HOSTILE_NUMBERS                    | 422, LABEL: reason |
| query    | editor/export/library URLs with hostile query arguments      | 200 or 404, never 500 |
| document | a golden document with one value replaced (DOCUMENT_VALUES)   | 422, where: reason |
| upload   | hostile files to the import form (UPLOADS)                   | 422, file: reason |
| cli      | hostile command-line arguments and files (CLI_CASES)         | exit 2, message   |
| cli      | programs read but refused (CLI_REFUSALS: past the moves limit) | exit 1, message |
| backup   | damaged backup archives (tests/test_backup_restore.py's DAMAGE, and more) | exit 2 |
| login    | hostile login forms                                          | 401 / 429         |
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass, field
from decimal import Decimal
from pathlib import Path
from typing import Any

from app.cnc import document
from app.cnc.blocks import (
    Block,
    DataBlock0,
    Direction,
    Hole,
    HoleOp,
    Island,
    Pocket,
    PocketArc,
    PocketArcEnd,
    PocketLine,
    Program,
    Tool,
)
from app.cnc.numbers import quoted
from app.cnc.sizes import MAX_IMPORT_LINES
from app.cnc.text import text_fault

# -- programs whose work multiplies (issue 30) ----------------------------------------------

GRID_OF_GRIDS = (
    Path(__file__).parent / "bad" / "loops-multiply-past-the-moves-limit" / "program.json"
).read_bytes()
"""Five blocks, two nested LOOP/REP of 99 x 99: 10^9 moves, refused naming block 2."""


def loop_of_holes(n: int, name: str = "HOLE GRID") -> Program:
    """The audit's program of issue 30 (five blocks): POS; POS INC LOOP; DRILL INC LOOP
    X 0.001; REP `n` x `n` at 0.01; REP `n` x `n` at 0.3 — (n + 1)^4 holes, each about 13
    moves. With n = 15, 65 536 holes and ~854 000 moves: the heaviest such program the
    moves limit allows (16 is refused), and before Verify's own limit, 14-60 s of Verify."""
    data = json.loads(GOLDEN_LOOP.read_text())
    pos: dict[str, Any] = {"type": "POS", "mode": "abs", "units": "inch", "loop": False}
    pos |= {"stop": False, "x": 0, "y": 0, "index": False, "tool": 1}
    drill: dict[str, Any] = {"type": "DRILL", "mode": "inc", "units": "inch", "loop": True}
    drill |= {"stop": False, "x": 0.001, "y": 0, "z_up": 0.1, "z_dn": -0.2, "feed_z": 5}
    drill |= {"pecks": 1, "tool": 1, "comp": "none"}

    def rep(step: float) -> dict[str, Any]:
        rep: dict[str, Any] = {"type": "REP", "mode": "inc", "units": "inch", "loop": False}
        return rep | {"stop": False, "x": step, "y": step, "nx": n, "ny": n}

    data |= {"name": name, "notes": ""}
    data["blocks"] = [pos, pos | {"mode": "inc", "loop": True}, drill, rep(0.01), rep(0.3)]
    return document.loads(json.dumps(data))


def verify_at_the_limit(name: str = "HELIX") -> Program:
    """A HELIX whose simulation is about as much work as the server's Verify accepts
    (sizes.MAX_VERIFY_WORK): tests/golden/helix-entry-mm down to Z DN -28 instead of -12
    (97 M cells of work). Arcs whose Z changes are the simulation's costliest cells: the
    heaviest Verify a page runs."""
    return _deeper_helix(name, -28)


def verify_past_the_limit(name: str = "HELIX") -> Program:
    """The same HELIX down to Z DN -40: 137 M cells, past the server's Verify limit."""
    return _deeper_helix(name, -40)


def _deeper_helix(name: str, z_dn: int) -> Program:
    data = json.loads((GOLDEN_LOOP.parent.parent / "helix-entry-mm" / "program.json").read_text())
    data["name"] = name
    data["blocks"][0]["z_dn"] = z_dn
    return document.loads(json.dumps(data))


GOLDEN_LOOP = Path(__file__).parent / "golden" / "loop-nested-3-deep" / "program.json"


def helix_of_many_turns(name: str = "BIG HELIX") -> Program:
    """An audit's program of issue 30: one HELIX, DIA 99 in, Z UP 0 to Z DN -5 in at PITCH
    0.001 in (5 000 turns, a 0.5 in tool), every value within its limits and the compiled
    path small (a few arcs a turn). Where a helix is written as chords it is millions: the
    3D view's surface 18-28 s, the STL 28 s, the tape picture and punch image 19-30 s."""
    data = json.loads((GOLDEN_LOOP.parent.parent / "helix-entry-mm" / "program.json").read_text())
    data |= {"name": name, "units": "inch", "notes": ""}
    data["data_block_0"] |= {"x_offset": 0, "y_offset": 0, "current_tool": 2, "z_retract": 0.1}
    data["data_block_0"]["tools"] = [{"number": 2, "diameter": 0.5, "rpm": 800, "tcal": 0}]
    helix = {"type": "HELIX", "mode": "abs", "units": "inch", "loop": False, "stop": False}
    helix |= {"x": 0, "y": 0, "diameter": 99, "z_up": 0, "z_dn": -5, "pitch": 0.001}
    helix |= {"milling": None, "feed_xy": 10, "tool": 2}
    data["blocks"] = [helix]
    return document.loads(json.dumps(data))


def eight_island_pocket(
    size: Decimal = Decimal(10), tool: Decimal = Decimal("0.125"), name: str = "BASE PLATE"
) -> Program:
    """One POCKET with the most islands a POCKET takes (8), every value within its limits:
    a rounded `size` x 0.8 `size` in boundary (PKT LINE, PKT ARC), islands of lines with a
    notch and a bump (arcs), a small tool. Before issue 30 its like validated in 75 s and
    two requests for it held both of a shop server's workers."""
    w, h = size, size * Decimal("0.8")
    r = size / 10  # the boundary's corner radius

    def arc(cx: Decimal, cy: Decimal, ex: Decimal, ey: Decimal, turn: Direction) -> list[Block]:
        return [PocketArc(direction=turn, x=cx, y=cy), PocketArcEnd(x=ex, y=ey)]

    ccw, cw = Direction.CCW, Direction.CW
    zero = Decimal(0)
    blocks: list[Block] = [
        Hole(op=HoleOp.DRILL, x=r, y=zero, z_up=Decimal("0.1"), z_dn=Decimal("-0.25"),
             feed_z=Decimal(5), tool=1),
        Pocket(feed_xy=Decimal(12), tool=1),
        PocketLine(x=w - r, y=zero), *arc(w - r, r, w, r, ccw),
        PocketLine(x=w, y=h - r), *arc(w - r, h - r, w - r, h, ccw),
        PocketLine(x=r, y=h), *arc(r, h - r, zero, h - r, ccw),
        PocketLine(x=zero, y=r), *arc(r, r, r, zero, ccw),
    ]  # fmt: skip
    cell_w, cell_h = w / 4, h / 2
    for i in range(4):
        for j in range(2):
            x0, y0 = cell_w * i + cell_w * Decimal("0.35"), cell_h * j + cell_h / 4
            a, c = cell_w * Decimal("0.4"), cell_h / 2
            q = c / 8
            blocks += [
                Island(x=x0, y=y0), PocketLine(x=x0 + a, y=y0),
                PocketLine(x=x0 + a, y=y0 + c / 2 - q),
                *arc(x0 + a, y0 + c / 2, x0 + a, y0 + c / 2 + q, cw),
                PocketLine(x=x0 + a, y=y0 + c), PocketLine(x=x0, y=y0 + c),
                PocketLine(x=x0, y=y0 + c / 2 + q),
                *arc(x0, y0 + c / 2, x0, y0 + c / 2 - q, ccw), PocketLine(x=x0, y=y0),
            ]  # fmt: skip
    cutter = Tool(number=1, diameter=tool, rpm=2000, tcal=zero)
    block0 = DataBlock0(current_tool=1, z_retract=Decimal("0.1"), tools=(cutter,))
    return Program(name=name, block0=block0, blocks=tuple(blocks))


EIGHT_ISLANDS = document.dumps(eight_island_pocket()).encode()

# value typed into a number field → (reason for a decimal field, reason for a whole field)
HOSTILE_NUMBERS: dict[str, tuple[str, str]] = {
    "²": ("is not a number", "is not a whole number"),
    "--5": ("is not a number", "is not a whole number"),
    "１２": ("is not a number", "is not a whole number"),  # full-width
    "٣": ("is not a number", "is not a whole number"),  # Arabic-Indic
    "۵": ("is not a number", "is not a whole number"),  # extended Arabic-Indic
    "1_000": ("is not a number", "is not a whole number"),
    "NaN": ("is not a number", "is not a whole number"),
    "-Infinity": ("is not a number", "is not a whole number"),
    "1E+999999999": ("is too large", "is not a whole number"),
    "1e-999999999": ("has too many decimal places", "is not a whole number"),
    "11e99999999999999999999999": ("is out of range", "is not a whole number"),
    "0x10": ("is not a number", "is not a whole number"),
    "1,5": ("is not a number", "is not a whole number"),
    "<script>alert(1)</script>": ("is not a number", "is not a whole number"),
    "9" * 60: ("is not a number", "is not a whole number"),
    "1 2": ("is not a number", "is not a whole number"),
    "\u202e5": ("is not a number", "is not a whole number"),  # right-to-left override
    "5\x00": ("is not a number", "is not a whole number"),  # refused first by the text rule
}

BLOCK_KINDS: tuple[str, ...] = ("POS", "DRILL", "BOLT_CIR_DRILL", "MILL_STD", "ARC_C", "CIRCLE")
BLOCK_KINDS += ("FRAME", "REP", "COPY")
FULL_KIND = "DRILL"
"""The kind that gets every hostile number; the other kinds get FEW_NUMBERS (the fields
share one reader, so the rest adds time, not evidence)."""
FEW_NUMBERS = ("²", "--5", "１２", "1_000", "NaN", "1E+999999999")

DB0_FIELDS: dict[str, tuple[str, bool]] = {
    # form name → (label, whole number)
    "x_offset": ("X", False),
    "y_offset": ("Y", False),
    "z_retract": ("Z RET", False),
    "current_tool": ("CUR-TOOL", True),
    "dia_1": ("TOOL 1 DIA", False),
    "rpm_1": ("TOOL 1 RPM", True),
    "tcal_1": ("TOOL 1 TCAL", False),
    "dia_24": ("TOOL 24 DIA", False),
    "rpm_24": ("TOOL 24 RPM", True),
}

# (URL, allowed statuses). Query arguments the pages read with their own rules.
QUERIES: list[tuple[str, tuple[int, ...]]] = [
    *[(f"/programs/2?{arg}={value}", (200, 404)) for arg in ("edit", "at", "page")
      for value in ("²", "--5", "１", "1e999", "-1", "0", "99999999999999999999", "x")],
    # The one text rule (app.cnc.text) refuses a NUL or a lone surrogate in any argument.
    *[(f"/programs/2?{arg}=%00", (422,)) for arg in ("edit", "at", "page")],
    *[(f"/programs/2/entry?{arg}", (200, 404)) for arg in (
        "group=EVIL", "kind=EVIL", "kind=BOLT_CIR_DRILL&at=1", "group=REP", "group=COPY&at=1",
        "kind=ARC_C&at=%FF", "edit=1&page=-5")],
    ("/programs/2/entry?loop=%00", (422,)),
    *[(f"/programs/2/export?target={t}", (200, 422)) for t in (
        "../../etc/passwd", "%00", "gcode-linuxcnc&go=1&opt_sequence-start=NaN",
        "gcode-linuxcnc&go=1&opt_sequence-start=%EF%BC%91", "tape-eia&go=1&opt_leader=1e999999",
        "events&machine=%2F..%2F", "svg&go=1&opt_scale=--5")],
    *[(f"/programs/2/export/download?target={t}", (200, 422)) for t in (
        "gcode-linuxcnc&opt_sequence-start=1_000", "nonsense", "json&opt_x=%00",
        "tape-eia&opt_leader=%D9%A3")],
    *[(f"/?{q}", (200,)) for q in ("sort=evil", "q=%27%22<>")],
    # A search is at most 10 words of 100 characters, and no NUL (app.cnc.text).
    *[(f"/?{q}", (422,)) for q in ("q=%00", "q=" + "a" * 5000, "q=" + "+w" * 999)],
    *[(f"/programs/2/history?diff={v}", (200,)) for v in ("²", "-1", "1e9", "99999999999")],
    *[(u, (404,)) for u in ("/programs/99999999999999999999", "/programs/-1", "/machines/x/y")],
    # The verify pages read `upto` with the one number reader (`²` was a 500).
    *[(f"/programs/2/verify/{page}?upto={value}", (422,))
      for page in ("surface", "part.png", "part.stl")
      for value in ("²", "1E%2B999999999", "-1", "١", "99999999999999999999")],
    ("/programs/2/verify/surface?upto=3", (200,)),
    ("/programs/2/setup?target=%00", (200, 422)),
    ("/programs/2/setup?machine=nope", (200, 422)),
]  # fmt: skip

# A value written into a golden document's field: (field path, JSON text, expected part).
DOCUMENT_VALUES: list[tuple[str, str, str]] = (
    [
        (path, value, expected)
        for path in ("blocks.0.x", "blocks.0.z_dn", "blocks.0.feed_z", "data_block_0.z_retract")
        for value, expected in (
            ("1e99999999999999999999", "is out of range"),
            ("1E+999999999", "is too large"),
            ("NaN", "NaN is not a number"),
            ("Infinity", "Infinity is not a number"),
            ("9" * 5000, "is too large"),
            ('"1"', 'expected a number, got "1"'),
            ("true", "expected a number, got true"),
            ("[]", "expected a number, got []"),
            ("{}", "expected a number, got {}"),
            ('"١"', "expected a number"),
        )
    ]
    + [
        (path, value, expected)
        for path in ("blocks.0.tool", "blocks.0.pecks", "data_block_0.current_tool")
        for value, expected in (
            ("1.5", "expected a whole number, got 1.5"),
            ("9" * 20, "is too large"),
            ("-" + "9" * 40, "is too large"),
            ('"2"', 'expected a whole number, got "2"'),
            ("null", "expected a whole number, got null"),
            ("false", "expected a whole number, got false"),
        )
    ]
    + [
        ("blocks.0.type", '"EVIL"', "unknown block type 'EVIL'"),
        ("blocks.0.type", "null", "unknown block type None"),
        ("blocks.0.units", '"furlong"', "is not one of"),
        ("blocks.0.mode", "7", "is not one of"),
        ("blocks.0.evil", "1", "unknown field 'evil'"),
        ("data_block_0.tools", '"all"', "expected a list of tools"),
        ("data_block_0.tools.0", "5", "expected an object"),
        ("data_block_0", "[]", "expected an object"),
        ("blocks", "{}", "expected a list of data blocks"),
        ("blocks.0", '"POS"', "expected an object"),
        ("name", "5", "expected text, got 5"),
        ("notes", "[" * 3000 + "]" * 3000, "nested too deeply"),
        ("format", '"other"', 'expected "millblocks-program"'),
        ("version", "2", "version 2 is not supported"),
        ("units", "null", "is not one of"),
        # The one text rule (app.cnc.text): names and notes hold no NUL or lone surrogate
        # (a surrogate was a 500 on both databases), and have lengths.
        ("name", '"\\ud800"', "program, name: has a lone surrogate (U+D800)"),
        ("name", '"a\\udfffb"', "program, name: has a lone surrogate (U+DFFF) at character 2"),
        ("notes", '"\\udc80"', "program, notes: has a lone surrogate (U+DC80)"),
        ("name", '"a\\u0000"', "program, name: has a NUL character (U+0000)"),
        ("notes", '"\\u0000"', "program, notes: has a NUL character (U+0000)"),
        ("part_number", '"\\u0000"', "program, part_number: has a NUL character"),
        ("blocks.0.message", '"\\ud83d"', "block 1, MESSAGE: has a lone surrogate"),
        ("data_block_0.tools.0.name", '"\\u0000"',
         "Data Block 0, tool entry 1, NAME: has a NUL character"),
        ("name", '"' + "x" * 201 + '"', "program, name: 201 characters is too long; allowed: "
         "at most 200"),
        ("notes", '"' + "x" * 4001 + '"', "program, notes: 4,001 characters is too long; "
         "allowed: at most 4,000"),
    ]
)  # fmt: skip


def minimal_dxf(entities: list[str], units: int = 1, version: str = "") -> bytes:
    """A text DXF of a header ($ACADVER when `version` is given, else R12; $INSUNITS) and
    the ENTITIES section of `entities`, each the text of its tags ("0\\nLINE\\n8\\n0\\n…")."""
    header = f"9\n$ACADVER\n1\n{version}\n" if version else ""
    header += f"9\n$INSUNITS\n70\n{units}\n"
    text = f"0\nSECTION\n2\nHEADER\n{header}0\nENDSEC\n0\nSECTION\n2\nENTITIES\n"
    return (text + "".join(entities) + "0\nENDSEC\n0\nEOF\n").encode()


def zigzag(lines: int, gap: float = 0.0) -> list[str]:
    """`lines` LINE entities end to end, as a minimal DXF's entities (0.01 in steps), each
    starting `gap` in after the last one ends."""
    return [
        f"0\nLINE\n8\n0\n10\n{k / 100 + gap}\n20\n{k % 2 / 200}\n11\n{(k + 1) / 100}\n"
        f"21\n{(k + 1) % 2 / 200}\n"
        for k in range(lines)
    ]


def squares(count: int) -> list[str]:
    """`count` concentric squares about the origin, each of four LINE entities."""
    found = []
    for k in range(1, count + 1):
        a = k / 100
        corners = [(-a, -a), (a, -a), (a, a), (-a, a)]
        for (x0, y0), (x1, y1) in zip(corners, corners[1:] + corners[:1], strict=True):
            found.append(f"0\nLINE\n8\n0\n10\n{x0}\n20\n{y0}\n11\n{x1}\n21\n{y1}\n")
    return found


def binary_lines(count: int) -> bytes:
    """A binary DXF (R12: one-byte group codes) of `count` LINE entities, six tags each,
    0.01 in long end to end."""
    out = [b"AutoCAD Binary DXF\r\n\x1a\x00", b"\x00SECTION\x00\x02ENTITIES\x00"]
    for k in range(count):
        ends = ((10, k / 100), (20, 0.0), (11, (k + 1) / 100), (21, 0.0))
        out.append(b"\x00LINE\x00\x080\x00")
        out += [bytes([code]) + struct.pack("<d", value) for code, value in ends]
    out.append(b"\x00ENDSEC\x00\x00EOF\x00")
    return b"".join(out)


# Drawings that crashed the DXF importer (issue 30: 500s on the pages, tracebacks from the
# command line), found by the fuzzer (bench/fuzz_long.py, parser dxf) and cut down to what
# still crashed: (file name, bytes, expected message part). Each is refused, with a place.
DXF_UPLOADS: list[tuple[str, bytes, str]] = [
    # struct.error: a binary DXF that ends inside a tag's value.
    ("cut-short.dxf", b"AutoCAD Binary DXF\r\n\x1a\x00\t\x00$", "binary tag 2: not a DXF"),
    ("cut-short-int.dxf", b"AutoCAD Binary DXF\r\n\x1a\x00B", "binary tag 1: not a DXF"),
    # AssertionError inside ezdxf's layouts (an OBJECTS section of broken layouts).
    (
        "layouts.dxf",
        b"0\nSECTION\n2\nHEADER\n9\n$ACADVER\n1\nAC1027\n9\n$\n7\n\n9\n$\n1\n\n0\nSECTION\n"
        b"2\nOBJECTS\n0\nDICTIONARY\n0\n\n1\n\n0\nLAYOUT\n5\n\n330\nD\n0\n\n0\nENDSEC",
        "not a DXF drawing ezdxf can read: <class 'type'> (AssertionError in ezdxf.layouts",
    ),
    # KeyError 'MODEL': layouts without a model space.
    (
        "no-model-space.dxf",
        b"AutoCAD Binary DXF\r\n\x1a\x00\x00\x00SECTION\x00\x02\x00HEADER\x00\t\x00$ACADVER"
        b"\x00\x00AC7\x00\t\x00$\x002\x00\t\x00$\x01\x00xf\x00\x00\x00\x00\x14\x00\x00\x00"
        b"\x00\x00\x00\x00\xf8?*\x00\x00\x00\x00\x00\x00\x00\xf0\xbf\n\x00\x00\x00\x00\x00\x00"
        b"\x00\x04@\x14\x00\x00\x00\x00\x00\x00\x00\xf0?\n\x00\x00\x00\x00\x00\x00\x00\xf8?\x14"
        b"\x00\x00\x00\x00\x00\x00\x00\xf0?*\x00\x00\x00\x00\x00\x00\x00\xf0\xbf\x00\x00ENDSEC"
        b"\x00\x00\x00SECTION\x00\x02\x00OBJECTS\x00\x00\x00DICTIONARY\x00\x03\x00ACAD_LAYOUT\x00"
        b"^\x01D\x00\x00\x00DICTIONARY\x00\x05\x00D\x00\x03\x000\x00^\x011A\x00\x03\x001\x00^\x01"
        b"1E\x00\x01\x01\x00\x00\x00LAYOUT\x00\x05\x001A\x00\x01D\x00d\x00\x00\x06\x00\x00(\x00"
        b"\x00\x00\x00\x00\x00\x00\x1e@)\x00\x00\x00\x00\x00\x00\x004@*\x00\x00\x00\x00\x00\x00"
        b"\x00\x1e@+\x00\x00\x00\x00\x00\x00\x004@,\x00\x00\x00\x00\x00\x00@z@-\x00\x00\x00\x00"
        b"\x00\x00\x90r@.\x00\x00\x00\x00\x00\x00\x00\x00\x00/\x00\x00\x00\x00\x00\x00\x00\x00"
        b"\x000\x00\x00\x00\x00\x00\x00\x00\x00\x001\x00\x00\x00\x00\x00\x00\x00\x00J\x00\x05\x00"
        b"\x00\x10\x00L\x00\x00M\x00\x02\x00N\x00,\x01\x93\x00\x00\x00\x00\x00\x00\x00\xf0?\x94"
        b"\x00\x00\x00\x00\x00\x00\x00\x00\x00\x95\x00\x00\x00\x00\x00\x00\x00\x00\x00d\x00\x00"
        b"\x01\x00Model\x0017\x00\x00\x00LAYOUT\x00\x05\x001E\x0000\x00\x00\x00ENDSEC\x00\x00\x00"
        b"EOF\x00",
        "model space: ezdxf cannot read the drawing's model space: 'MODEL' (KeyError",
    ),
    # StopIteration: a table that ends before its first entry.
    (
        "empty-table.dxf",
        b"AutoCAD Binary DXF\r\n\x1a\x00\x00\x00SECTION\x00\x02\x00$ACADVERASE[\x00\x00\x00\x00"
        b"\x01\x00\x00\x01\x00\x00\x00\x00ENDSEC\x00\x00\x00SECTION\x00\x02\x00TABLES\x00\x00\x00"
        b"TABLE\x00\x02\x00VPORT\x00le\x00\x00\x00\x00\x00\x00ENDTAB\x00Te\x00F\x00\x00\x00\x00"
        b"\x00ENDTAB\x0000\x00\x00\x00ENDSEC\x00\x00\x00EOF\x00",
        "not a DXF drawing ezdxf can read: ",
    ),
    # AttributeError: a code page that is a number.
    (
        "codepage.dxf",
        b"0\nSECTION\n2\nHEADER\n9\n$DWGCODEPAGE\n72\n5\n9\n$\n7\n\n0\nENDSEC",
        "not a DXF drawing ezdxf can read: ",
    ),
    (
        "codepage-binary.dxf",
        b"AutoCAD Binary DXF\r\n\x1a\x00\x00\x00SECTION\x00\x02\x00HEADER\x00\t\x00$ACADVER"
        b"\x01\x00AC7\x00\t\x00$\x00\x00i\x00\t\x00$DWGCODEPAGE\x00\x18\x018\xd8\t\x00$\x00\xa0"
        b"\x00\x00\x00\x00\x00\x00\x00\x00\x00\t\x00$\x00\n\x00\x00\x00\x00\x00\x00\x00\x00\x00"
        b"\x14\x00\x01\x00\x00\t\x00$\x00\x01\x00\x00\x00\x00\x00ENDSEC\x00\x00\x00EOF\x00",
        "not a DXF drawing ezdxf can read: ",
    ),
    # A lone surrogate in ezdxf's message (a header variable named by an undecodable byte).
    (
        "surrogate.dxf",
        b"0\nSECTION\n2\nHEADER\n9\n$ACADVER\n1\nC\n9\n$\n7\n\n9\n$DWGCODEPAGE\n3\n\n9\n$\n2\n\n"
        b"9\n$\n2\n\n9\n\xfe\n0\n\n0\nENDSEC",
        'Invalid header variable name "\\xfe"',
    ),
    # TypeError, ValueError: units that are not a whole number.
    (
        "units-point.dxf",
        b"0\nSECTION\n2\nHEADER\n9\n$INSUNITS\n11\n1\n21\n0\n0\nSECTION",
        "header $INSUNITS: units code (1.0, 0.0) is not a whole number",
    ),
    (
        "units-word.dxf",
        b"0\nSECTION\n2\nHEADER\n9\n$INSUNITS\n1\ninch\n0\nENDSEC\n0\nEOF\n",
        "header $INSUNITS: units code 'inch' is not a whole number",
    ),
]

# A binary DXF past the line limit (issue 30: its tags were not counted).
LINES_DXF = ("lines.dxf", binary_lines(1_700), f"at most {MAX_IMPORT_LINES:,} lines")

# Drawings whose entities ezdxf half understands (it could not give their layer): read, each
# such entity named and left out. (file name, bytes, expected note part)
DXF_READ: list[tuple[str, bytes, str]] = [
    (
        "no-layer.dxf",
        b"AutoCAD Binary DXF\r\n\x1a\x00\x00SECTION\x00\x02ENTITIES\x00NE\x00\x14\x00\x00\x00"
        b"\x00\x00\x00\xf0\xbf\x00\x00\x00ENDSEC\x00\x00EOF\x00",
        "is not read",
    ),
]

# Uploads to the import form: (file name, bytes, expected message part); a part of None
# means the file is a program after all (201).
UPLOADS: list[tuple[str, bytes, str | None]] = [
    ("empty.ngc", b"", ""),
    ("bom.cnc", b"\xef\xbb\xbf", ""),
    ("nul.ngc", b"G1 X1\x00 Y2\n", ""),
    ("latin1.ngc", b"G1 X1 (caf\xe9)\n", "no End of Block"),
    ("utf16.ngc", "G1 X1\n".encode("utf-16"), ""),
    ("binary.tape", bytes(range(256)) * 4, ""),
    ("damaged.cnc", b"PN2 G20;\nN001 G106 XB1.0A YB1.0A XD2.0A YD2.0A DR1 TC2 CR- FC0;\n", "CR"),
    ("fullwidth.ngc", "G20 G90\nG0 X１ Y0\nM30\n".encode(), "line 2"),
    ("arabic.ngc", "G20 G90\nG0 X٣ Y0\nM30\n".encode(), "line 2"),
    ("under.ngc", b"G20 G90\nG0 X1_000 Y0\nM30\n", "line 2"),
    ("hugeexp.ngc", b"G20 G90\nG1 X1E+999999999 F10\nM30\n", "line 2"),
    ("longdigits.ngc", b"G20 G90\nG1 X" + b"9" * 5000 + b" F10\nM30\n", "line 2"),
    ("longline.ngc", b"G20 G90\n(" + b"x" * 200_000 + b")\nG0 X1 Y1\nM30\n", None),
    ("lines.ngc", b"G20\n" * (MAX_IMPORT_LINES + 1), f"at most {MAX_IMPORT_LINES:,} lines"),
    ("crlines.tape", b"%\r" + b"N001 G00 X1000\r" * (MAX_IMPORT_LINES + 1), "lines"),
    ("deep.json", b"{" + b'"a":[' * 1000, ""),
    ("nan.json", b'{"format": "millblocks-program", "version": 1, "notes": NaN}', "NaN"),
    ("bigint.json", b'{"format": "millblocks-program", "version": ' + b"9" * 5000 + b"}", ""),
    ("events-nan.cnc", b"PN2 G20;\nN001 G100 XNaN Y1 T01;\n", "line 2"),
    ("events-sup.cnc", "PN2 G20;\nN001 G100 X1.0A Y²A T01;\n".encode(), "line 2"),
    # An angle of 13 decimals once implied: refused by the number reader at its word.
    (
        "events-angle.cnc",
        b"PN2 G20;\nN001 G104 XC1.0 YC1.0 HL4 R1.0 A.0000000000001 T01;\n",
        "line 2, column 32: A.0000000000001: '.0000000000001' has too many decimal places",
    ),
    ("tape-junk.tape", b"%\rN001 G00 X\xff\xfe\r", ""),
    ("ambiguous.txt", b"N001 G00 X1000 Y2000\nM30\n", ""),
    # Issue 30: work that multiplies. Refused naming the block and the figure; the 8-island
    # POCKET is legal and is taken (it planned for minutes).
    ("grid-of-grids.json", GRID_OF_GRIDS, "block 2: the program would make about 1,300,130,007"),
    ("eight-islands.json", EIGHT_ISLANDS, None),  # a document: it opens in the editor (302)
    # Issue 30: drawings past the line limit as binary, and those ezdxf crashed on.
    LINES_DXF,
    *DXF_UPLOADS,
]

# Uploads the command line reads (a program document) and then refuses to work on (exit 1,
# CLI_REFUSALS), where the web refuses to import them (422).
READ_BUT_REFUSED = frozenset({"grid-of-grids.json"})

# CLI arguments: (argv, expected message part). Files named @name are written from UPLOADS.
CLI_CASES: list[tuple[list[str], str]] = [
    *[(["export", "@golden", "--to", "gcode-linuxcnc", "-O", f"sequence-start={v}"],
       "option sequence-start") for v in ("NaN", "１", "1_0", "1E+999999999", "--5", "²", "")],
    *[(["export", "@golden", "--to", "tape-eia", "-O", f"leader={v}"], "option leader")
      for v in ("NaN", "Infinity", "٣", "0x10")],
    (["export", "@golden", "--to", "no-such-target"], "no-such-target"),
    (["export", "@golden", "--to", "gcode-linuxcnc", "-O", "no-equals"], "NAME=VALUE"),
    *[(["time", "@golden", "--tool-change-seconds", v], "--tool-change-seconds")
      for v in ("nan", "inf", "-1", "١", "1_0")],
    # (Not lines.dxf either: the command line reads the user's own files whole, without the
    # line limit, and this drawing is one long open contour.)
    *[(["check", f"@{name}"], "") for name, _data, part in UPLOADS
      if part is not None and name not in READ_BUT_REFUSED and name != LINES_DXF[0]],
    *[(["import", f"@{name}"], part) for name, _data, part in DXF_UPLOADS],
    (["check", "/nonexistent/file.json"], "/nonexistent/file.json"),
    (["diff", "1", "²", "1"], "²"),
    (["restore-version", "1", "--5"], "--5"),
    (["transfers", "--limit", "١٠"], "١٠"),
    # The one number reader for verify's options (inf, nan, 1e300 were tracebacks).
    *[(["verify", "@golden", "--resolution", v], "--resolution")
      for v in ("inf", "nan", "1e300", "NaN", "0", "-1", "²")],
    (["verify", "@golden", "--tolerance", "inf"], "--tolerance"),
    # The one text rule: a lone surrogate is what a command line of non-UTF-8 bytes gives.
    (["list", " ".join(["w"] * 999)], "search: 999 words is too many; allowed: at most 10"),
    (["list", "caf\udce9"], "search: has a lone surrogate (U+DCE9) at character 4"),
    (["check", "no such \udcff"], "has a lone surrogate (U+DCFF)"),
    (["history", "\udcff"], "has a lone surrogate (U+DCFF)"),
    (["user", "add", "a\udcffb", "--role", "admin", "--password", "a long password"],
     "user name: has a lone surrogate (U+DCFF) at character 2"),
    (["user", "password", "ada\udcff", "--password", "a long password"],
     "has a lone surrogate (U+DCFF)"),
    (["--max-moves", "NaN", "check", "@golden"], "--max-moves"),
    (["--max-moves", "0", "check", "@golden"], "--max-moves"),
]  # fmt: skip

# Programs a command reads whole but refuses to work on (exit 1, the problem on stderr).
CLI_REFUSALS: list[tuple[list[str], str]] = [
    ([command, "@grid-of-grids.json", *rest], "block 2, LOOP: the program would make about")
    for command, rest in (("check", []), ("time", []), ("verify", []), ("setup-sheet", []),
                          ("export", ["--to", "gcode-linuxcnc"]))
]  # fmt: skip

# The one text rule (app.cnc.text) at every entry, on SQLite and on PostgreSQL (whose text
# cannot hold a NUL: each of these was a 500 there). (method, URL, form, the field named in
# the refusal); the NUL is in that field. Run logged in as an admin; programs 1 and 2 exist.
NUL = "\x00"
TEXT_ENTRIES: list[tuple[str, str, dict[str, str], str]] = [
    ("POST", "/login", {"username": f"ana{NUL}", "password": "x"}, "username"),
    ("POST", "/programs", {"name": f"a{NUL}b", "units": "inch"}, "name"),
    ("POST", "/programs/1/header", {"name": f"a{NUL}", "version": "1"}, "name"),
    ("POST", "/programs/1/header", {"name": "a", "notes": NUL, "version": "1"}, "notes"),
    ("POST", "/programs/1/header", {"name": "a", "part_number": NUL, "version": "1"},
     "part_number"),
    ("POST", "/programs/1/blocks", {"kind": "POS", "x": "1", "y": "1", "message": f"A{NUL}",
                                    "version": "1"}, "message"),
    ("POST", "/programs/1/db0", {"name_1": f"DRILL{NUL}", "version": "1"}, "name_1"),
    ("POST", "/programs/1/mirror", {"axis": NUL}, "axis"),
    ("POST", "/programs/1/verify/stock", {"x": NUL, "version": "1"}, "x"),
    ("POST", "/machines", {"name": f"m{NUL}", "target": "gcode-linuxcnc"}, "name"),
    ("POST", "/machines", {"name": "m", "target": "gcode-linuxcnc", "notes": NUL}, "notes"),
    ("POST", "/machines", {"name": "m", "target": "gcode-linuxcnc", "limits": f"x=0 {NUL}"},
     "limits"),
    ("POST", "/machines/m%00/delete", {}, "name"),
    ("GET", "/machines/options?target=%00", {}, "target"),
    ("POST", "/users", {"username": f"u{NUL}", "password": "a long password", "role": "operator"},
     "username"),
    ("POST", "/users/u%00/role", {"role": "admin"}, "username"),
    ("POST", "/users/u%00/sessions/end", {}, "username"),
    ("POST", "/account/password", {"current": NUL, "new": "a long password"}, "current"),
    ("GET", "/?q=%00", {}, "q"),
    ("GET", "/programs/1/export?machine=%00", {}, "machine"),
    ("GET", "/programs/1/export/download?machine=%00", {}, "machine"),
    ("GET", "/programs/1/setup?machine=%00", {}, "machine"),
    ("GET", "/programs/1/verify/surface?upto=%00", {}, "upto"),
    ("POST", "/transfers/send", {"machine": NUL, "program_id": "1"}, "machine"),
    ("POST", "/transfers/receive", {"machine": "m", "name": NUL}, "name"),
]  # fmt: skip

LOGINS: list[tuple[dict[str, str], int]] = [
    ({"username": "ana", "password": "x" * 100_000}, 401),
    ({"username": "a" * 10_000, "password": "x"}, 401),
    ({"username": "\x00", "password": "\x00"}, 422),  # the one text rule: no NUL
    ({"username": "ana'; DROP TABLE users; --", "password": "x"}, 401),
    ({"username": "ana\u202e", "password": "x"}, 401),
    ({"username": "", "password": ""}, 401),
    ({}, 401),
]


@dataclass(frozen=True)
class Case:
    """One hostile input and what must come back."""

    surface: str
    id: str
    data: dict[str, Any] = field(default_factory=dict)
    status: tuple[int, ...] = (422,)
    message: str = ""


def refused_text(field: str, value: str) -> str:
    """The text rule's refusal of `value` in form field `field` ("" when it has none): a
    NUL or lone surrogate is refused before the field is read as a number."""
    fault = text_fault(value)
    return f"{field}: {fault}" if fault else ""


def block_cases() -> list[Case]:
    from app.web.forms import entry_forms

    found = []
    for key in BLOCK_KINDS:
        for spec in entry_forms()[key].fields:
            if spec.kind in ("flag", "choice"):
                continue
            whole = spec.kind in ("count", "tool")
            for value, reasons in HOSTILE_NUMBERS.items():
                if key != FULL_KIND and value not in FEW_NUMBERS:
                    continue
                reason = reasons[1] if whole else reasons[0]
                found.append(
                    Case(
                        "block",
                        f"{key}-{spec.name}-{value[:12]!r}",
                        {"kind": key, "field": spec.name, "value": value},
                        (422,),
                        refused_text(spec.name, value)
                        or f"{spec.label}: {quoted(value.strip())} {reason}",
                    )
                )
    return found


def db0_cases() -> list[Case]:
    found = []
    for name, (label, whole) in DB0_FIELDS.items():
        for value, reasons in HOSTILE_NUMBERS.items():
            reason = reasons[1] if whole else reasons[0]
            found.append(
                Case(
                    "db0",
                    f"{name}-{value[:12]!r}",
                    {"field": name, "value": value},
                    (422,),
                    refused_text(name, value) or f"{label}: {quoted(value.strip())} {reason}",
                )
            )
    return found


def cases(surface: str) -> list[Case]:
    """Every case of one surface."""
    if surface == "block":
        return block_cases()
    if surface == "db0":
        return db0_cases()
    if surface == "query":
        return [Case("query", url, {"url": url}, statuses) for url, statuses in QUERIES]
    if surface == "document":
        return [
            Case("document", f"{path}={value[:16]}", {"path": path, "value": value}, (422,), part)
            for path, value, part in DOCUMENT_VALUES
        ]
    if surface == "upload":
        return [
            Case(
                "upload",
                name,
                {"name": name, "bytes": data},
                (422,) if part is not None else (302,) if name.endswith(".json") else (201,),
                part if part is not None else "" if name.endswith(".json") else "Import report",
            )
            for name, data, part in UPLOADS
        ]
    if surface == "cli":
        return [
            Case("cli", " ".join(argv)[:60], {"argv": argv}, (2,), part) for argv, part in CLI_CASES
        ] + [
            Case("cli", " ".join(argv)[:60], {"argv": argv}, (1,), part)
            for argv, part in CLI_REFUSALS
        ]
    if surface == "login":
        return [
            Case("login", repr(form)[:40], {"form": form}, (status,), "") for form, status in LOGINS
        ]
    raise ValueError(surface)


SURFACES = ("block", "db0", "query", "document", "upload", "cli", "login")
