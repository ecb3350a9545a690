"""The conversational block entry: types, sub-types, and each block's fields in the order
the control asks for them (seed 001 §3.4.5), parsed from form text into blocks.

A block form is identified by a `kind` (the type and sub-type the machinist chose, e.g.
`DRILL`, `BOLT_CIR_TAP`, `QCIR_CC`, `FRM_2P`) plus the LOOP and STOP qualifiers. Parsing
never raises: it returns the block, or the message for each field that could not be read
(what is wrong and what is allowed); range checks are validation's, shown beside the field.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from decimal import Decimal
from typing import Any

from app.cnc.blocks import (
    ArcEnd,
    Block,
    BoltCircle,
    Circle,
    Comp,
    Copy,
    CopyAction,
    Direction,
    Frame,
    Hole,
    HoleOp,
    MillArc,
    MillLine,
    MillQcir,
    Mode,
    Placement,
    Pos,
    Program,
    Rep,
)
from app.cnc.numbers import NumberError, parse_decimal, parse_int
from app.cnc.units import Units


@dataclass(frozen=True)
class FieldSpec:
    """One prompt: form name, the control's label, how it is read."""

    name: str
    label: str
    kind: str  # length, feed, angle, count, tool, flag, choice
    required: bool = True
    choices: tuple[tuple[str, str], ...] = ()
    help: str = ""


X = FieldSpec("x", "X", "length")
Y = FieldSpec("y", "Y", "length")
Z_UP = FieldSpec("z_up", "Z UP", "length", False, help="empty in a 2-axis program")
Z_DN = FieldSpec("z_dn", "Z DN", "length", False, help="empty in a 2-axis program")
FEED_Z = FieldSpec("feed_z", "FEEDR Z", "feed", False)
FEED_XY = FieldSpec("feed_xy", "FEEDR XY", "feed")
PECKS = FieldSpec("pecks", "# PECK", "count")
TOOL = FieldSpec("tool", "TOOL #", "tool")
MILL_Z = FieldSpec("z_dn", "Z DN", "length", False, help="empty keeps the depth")
PLACEMENT = FieldSpec(
    "placement",
    "PLACEMENT",
    "choice",
    choices=(
        ("inside", "INSIDE"),
        ("outside", "OUTSIDE"),
        ("in_tan", "IN/TAN"),
        ("out_tan", "OUT/TAN"),
        ("pocket", "POCKET"),
    ),
)
OPTIONAL_LENGTH = {"required": False}


@dataclass(frozen=True)
class Kind:
    """A block type and sub-type as the editor offers it."""

    key: str
    title: str
    group: str  # the first choice: POS, DRILL, BORE, TAP, MILL, REP, COPY
    fields: tuple[FieldSpec, ...]
    positioned: bool = False  # has X/Y, so the INC/ABS switch applies
    loopable: bool = False


KINDS: dict[str, Kind] = {
    k.key: k
    for k in (
        Kind(
            "POS",
            "POS",
            "POS",
            (X, Y, FieldSpec("index", "INDEX", "flag", False), TOOL),
            True,
            True,
        ),
        Kind("DRILL", "DRILL", "DRILL", (X, Y, Z_UP, Z_DN, FEED_Z, PECKS, TOOL), True, True),
        Kind(
            "DRILL_CUT_RT",
            "DRILL CUT RT",
            "DRILL",
            (X, Y, Z_UP, Z_DN, FEED_Z, PECKS, TOOL),
            True,
            True,
        ),
        Kind(
            "DRILL_CUT_LT",
            "DRILL CUT LT",
            "DRILL",
            (X, Y, Z_UP, Z_DN, FEED_Z, PECKS, TOOL),
            True,
            True,
        ),
        Kind("BORE", "BORE", "BORE", (X, Y, Z_UP, Z_DN, FEED_Z, TOOL), True, True),
        Kind("TAP", "TAP", "TAP", (X, Y, Z_UP, Z_DN, FEED_Z, TOOL), True, True),
        *(
            Kind(
                f"BOLT_CIR_{op}",
                f"BOLT CIR {op}",
                op,
                (
                    FieldSpec("holes", "# HOLES", "count"),
                    FieldSpec("angle", "ANGLE", "angle", help="degrees clockwise from 6 o'clock"),
                    FieldSpec("radius", "RAD", "length"),
                ),
            )
            for op in ("DRILL", "BORE", "TAP")
        ),
        Kind("MILL_STD", "MILL STD", "MILL", (X, Y, MILL_Z, FEED_XY, TOOL), True),
        Kind("QCIR_C", "QCIR C", "MILL", (X, Y, MILL_Z, FEED_XY, TOOL), True),
        Kind("QCIR_CC", "QCIR CC", "MILL", (X, Y, MILL_Z, FEED_XY, TOOL), True),
        *(
            Kind(
                key,
                title,
                "MILL",
                (
                    FieldSpec("x", "X (XY-CENT)", "length"),
                    FieldSpec("y", "Y (XY-CENT)", "length"),
                    MILL_Z,
                    FEED_XY,
                    TOOL,
                    FieldSpec("end_x", "X (XY-END)", "length"),
                    FieldSpec("end_y", "Y (XY-END)", "length"),
                ),
                True,
            )
            for key, title in (("ARC_C", "ARC C"), ("ARC_CC", "ARC CC"))
        ),
        *(
            Kind(
                key, title, "MILL", (PLACEMENT, FieldSpec("radius", "RAD", "length"), FEED_XY, TOOL)
            )
            for key, title in (("CIRCLE", "CIRCLE"), ("CIR_2P", "CIR 2P"))
        ),
        *(
            Kind(
                key,
                title,
                "MILL",
                (
                    PLACEMENT,
                    FieldSpec("xl", "XL", "length"),
                    FieldSpec("yw", "YW", "length"),
                    FieldSpec("corner_radius", "CORNER RAD", "length"),
                    FEED_XY,
                    TOOL,
                ),
            )
            for key, title in (("FRAME", "FRAME"), ("FRM_2P", "FRM 2P"))
        ),
        Kind(
            "REP",
            "REP",
            "REP",
            (X, Y, FieldSpec("nx", "NX", "count"), FieldSpec("ny", "NY", "count")),
        ),
        Kind(
            "COPY",
            "COPY",
            "COPY",
            (
                FieldSpec("from_block", "FROM", "count"),
                FieldSpec("to_block", "TO", "count"),
                FieldSpec(
                    "op",
                    "OPERATION",
                    "choice",
                    False,
                    (("", "unchanged"), ("DRILL", "DRILL"), ("BORE", "BORE"), ("TAP", "TAP")),
                ),
                FieldSpec("pecks", "# PECK", "count", False),
                FieldSpec("xof", "XOF", "length", False),
                FieldSpec("yof", "YOF", "length", False),
                FieldSpec("z_up", "Z UP", "length", False),
                FieldSpec("z_dn", "Z DN", "length", False),
                FieldSpec("feed_z", "FEEDR Z", "feed", False),
                FieldSpec("feed_xy", "FEEDR XY", "feed", False),
                FieldSpec("tool", "TOOL #", "tool", False),
            ),
        ),
        Kind("ARC_END", "MILL ARC XY-END", "MILL", (X, Y), True),
    )
}

GROUPS = ("POS", "DRILL", "BORE", "TAP", "MILL", "LOOP", "STOP", "REP", "COPY")
GROUP_KINDS = {
    "POS": ("POS",),
    "DRILL": ("DRILL", "BOLT_CIR_DRILL", "DRILL_CUT_RT", "DRILL_CUT_LT"),
    "BORE": ("BORE", "BOLT_CIR_BORE"),
    "TAP": ("TAP", "BOLT_CIR_TAP"),
    "MILL": (
        "MILL_STD",
        "QCIR_C",
        "QCIR_CC",
        "ARC_C",
        "ARC_CC",
        "CIRCLE",
        "CIR_2P",
        "FRAME",
        "FRM_2P",
    ),
    "REP": ("REP",),
    "COPY": ("COPY",),
}


def kind_of(block: Block) -> str:
    """The editor kind of an existing block."""
    if isinstance(block, Pos):
        return "POS"
    if isinstance(block, Hole):
        if block.op is HoleOp.DRILL and block.comp is Comp.RIGHT:
            return "DRILL_CUT_RT"
        if block.op is HoleOp.DRILL and block.comp is Comp.LEFT:
            return "DRILL_CUT_LT"
        return block.op.value
    if isinstance(block, BoltCircle):
        return f"BOLT_CIR_{block.op.value}"
    if isinstance(block, MillLine):
        return "MILL_STD"
    if isinstance(block, MillQcir):
        return "QCIR_C" if block.direction is Direction.CW else "QCIR_CC"
    if isinstance(block, MillArc):
        return "ARC_C" if block.direction is Direction.CW else "ARC_CC"
    if isinstance(block, ArcEnd):
        return "ARC_END"
    if isinstance(block, Circle):
        return "CIR_2P" if block.two_pass else "CIRCLE"
    if isinstance(block, Frame):
        return "FRM_2P" if block.two_pass else "FRAME"
    if isinstance(block, Rep):
        return "REP"
    return "COPY"


# -- what may be offered where -------------------------------------------------------------


def open_loops(blocks: tuple[Block, ...], before: int) -> int:
    """How many LOOPs are open before position `before` (0-based insertion index)."""
    depth = 0
    for block in blocks[:before]:
        if block.loop and isinstance(block, Pos | Hole):
            depth += 1
        elif isinstance(block, Rep) and depth:
            depth -= 1
    return depth


def offered_kinds(program: Program, at: int, group: str) -> list[str]:
    """The sub-types of `group` the control offers for a new block at position `at` (1-based).

    BOLT CIR only right after a standard block of the same operation; REP only with an
    unmatched LOOP open; COPY only as a new block at the end (not inserted).
    """
    blocks = program.blocks
    previous = blocks[at - 2] if at >= 2 else None
    kinds = []
    for key in GROUP_KINDS.get(group, ()):
        if key.startswith("BOLT_CIR_"):
            op = key.removeprefix("BOLT_CIR_")
            if not (isinstance(previous, Hole) and previous.op.value == op):
                continue
        if key == "REP" and open_loops(blocks, at - 1) == 0:
            continue
        if key == "COPY" and at != len(blocks) + 1:
            continue
        kinds.append(key)
    return kinds


def offered_groups(program: Program, at: int) -> list[str]:
    """The first choices offered for a new block at position `at`."""
    groups = []
    for group in GROUPS:
        if group in ("LOOP", "STOP") or offered_kinds(program, at, group):
            groups.append(group)
    return groups


# -- values --------------------------------------------------------------------------------


def field_values(block: Block, following: Block | None = None) -> dict[str, str]:
    """A block's values as form text (an ARC XY-CENT also shows its XY-END)."""
    values: dict[str, str] = {}
    for f in dataclasses.fields(block):
        value = getattr(block, f.name)
        values[f.name] = _text(value)
    if isinstance(block, MillArc) and isinstance(following, ArcEnd):
        values["end_x"] = _text(following.x)
        values["end_y"] = _text(following.y)
    if isinstance(block, Hole | BoltCircle):
        values["op"] = block.op.value
    return values


def _text(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "on" if value else ""
    if isinstance(value, Decimal):
        return f"{value:f}"
    if hasattr(value, "value"):
        return str(value.value)
    return str(value)


def defaults_for(program: Program, at: int, kind: str, loop: bool = False) -> dict[str, str]:
    """Values offered for a new block: the previous block's where it has the same field.

    Blocks of a LOOP sequence (the LOOP block included) are offered in INC.
    """
    values: dict[str, str] = {
        "units": program.units.value,
        "mode": "abs",
        "tool": str(
            program.block0.current_tool
            or (program.block0.tools[0].number if program.block0.tools else 1)
        ),
        "pecks": "1",
        "angle": "0",
        "corner_radius": "0",
        "nx": "0",
        "ny": "0",
        "placement": "inside",
    }
    previous = program.blocks[at - 2] if at >= 2 else None
    if previous is not None:
        values.update({k: v for k, v in field_values(previous).items() if v != ""})
        values.pop("index", None)
        values.pop("stop", None)
        values.pop("loop", None)
    if loop or open_loops(program.blocks, at - 1) or kind == "REP":
        values["mode"] = "inc"
    elif (
        previous is not None and previous.loop is False and open_loops(program.blocks, at - 1) == 0
    ):
        values["mode"] = "abs"
    if kind == "COPY":
        values = {"units": values["units"], "from_block": "1", "to_block": str(at - 1)}
    return values


@dataclass
class Parsed:
    """The result of reading a block form: blocks (1, or 2 for an ARC), or field errors."""

    blocks: list[Block]
    errors: dict[str, str]


def parse_block(kind_key: str, form: Mapping[str, str]) -> Parsed:
    """Read a submitted block form into blocks. Errors name the field and what is allowed."""
    kind = KINDS.get(kind_key)
    if kind is None:
        return Parsed([], {"kind": f"unknown block type {kind_key!r}"})
    errors: dict[str, str] = {}
    values: dict[str, Any] = {}
    for spec in kind.fields:
        raw = form.get(spec.name, "").strip()
        value, error = _read(spec, raw)
        if error:
            errors[spec.name] = f"{spec.label}: {error}"
        values[spec.name] = value
    units = Units.MM if form.get("units") == "mm" else Units.INCH
    mode = Mode.INC if form.get("mode") == "inc" else Mode.ABS
    loop = form.get("loop") == "on" and kind.loopable
    stop = form.get("stop") == "on" and kind_key not in ("REP", "COPY")
    if errors:
        return Parsed([], errors)
    message = form.get("message", "").strip()
    common: dict[str, Any] = {
        "units": units,
        "mode": mode,
        "loop": loop,
        "stop": stop,
        "message": message,
    }
    return Parsed(_build(kind_key, values, common, form), {})


def _read(spec: FieldSpec, raw: str) -> tuple[Any, str]:
    """(value, "") or (None, what is wrong)."""
    if spec.kind == "flag":
        return raw == "on", ""
    if raw == "":
        if spec.required:
            return None, "missing; enter a value"
        return None, ""
    if spec.kind == "choice":
        allowed = [value for value, _ in spec.choices]
        if raw not in allowed:
            return None, f"{raw!r} is not one of {', '.join(a for a in allowed if a)}"
        return raw, ""
    if spec.kind in ("count", "tool"):
        return read_whole(raw)
    return read_number(raw)


def read_number(raw: str) -> tuple[Decimal | None, str]:
    """(number, "") or (None, what is wrong and what is allowed): app.cnc.numbers' rules."""
    try:
        return parse_decimal(raw), ""
    except NumberError as exc:
        return None, str(exc)


def read_whole(raw: str) -> tuple[int | None, str]:
    """(whole number, "") or (None, what is wrong and what is allowed)."""
    try:
        return parse_int(raw), ""
    except NumberError as exc:
        return None, str(exc)


def _build(
    kind: str, v: dict[str, Any], common: dict[str, Any], form: Mapping[str, str]
) -> list[Block]:
    if kind == "POS":
        return [Pos(**common, x=v["x"], y=v["y"], index=v["index"], tool=v["tool"])]
    if kind in ("DRILL", "DRILL_CUT_RT", "DRILL_CUT_LT", "BORE", "TAP"):
        op = HoleOp(kind.split("_")[0])
        comp = {"DRILL_CUT_RT": Comp.RIGHT, "DRILL_CUT_LT": Comp.LEFT}.get(kind, Comp.NONE)
        return [
            Hole(
                **common,
                op=op,
                x=v["x"],
                y=v["y"],
                z_up=v["z_up"],
                z_dn=v["z_dn"],
                feed_z=v["feed_z"],
                pecks=v.get("pecks") or 1,
                tool=v["tool"],
                comp=comp,
            )
        ]
    if kind.startswith("BOLT_CIR_"):
        common = {**common, "loop": False}
        op = HoleOp(kind.removeprefix("BOLT_CIR_"))
        return [BoltCircle(**common, op=op, holes=v["holes"], angle=v["angle"], radius=v["radius"])]
    if kind == "MILL_STD":
        return [
            MillLine(
                **common, x=v["x"], y=v["y"], z_dn=v["z_dn"], feed_xy=v["feed_xy"], tool=v["tool"]
            )
        ]
    if kind in ("QCIR_C", "QCIR_CC"):
        direction = Direction.CW if kind == "QCIR_C" else Direction.CCW
        return [
            MillQcir(
                **common,
                direction=direction,
                x=v["x"],
                y=v["y"],
                z_dn=v["z_dn"],
                feed_xy=v["feed_xy"],
                tool=v["tool"],
            )
        ]
    if kind in ("ARC_C", "ARC_CC"):
        direction = Direction.CW if kind == "ARC_C" else Direction.CCW
        centre = MillArc(
            **common,
            direction=direction,
            x=v["x"],
            y=v["y"],
            z_dn=v["z_dn"],
            feed_xy=v["feed_xy"],
            tool=v["tool"],
        )
        end = ArcEnd(units=common["units"], mode=common["mode"], x=v["end_x"], y=v["end_y"])
        return [centre, end]
    if kind == "ARC_END":
        return [ArcEnd(**common, x=v["x"], y=v["y"])]
    if kind in ("CIRCLE", "CIR_2P"):
        return [
            Circle(
                **common,
                placement=Placement(v["placement"]),
                two_pass=kind == "CIR_2P",
                radius=v["radius"],
                feed_xy=v["feed_xy"],
                tool=v["tool"],
            )
        ]
    if kind in ("FRAME", "FRM_2P"):
        return [
            Frame(
                **common,
                placement=Placement(v["placement"]),
                two_pass=kind == "FRM_2P",
                xl=v["xl"],
                yw=v["yw"],
                corner_radius=v["corner_radius"],
                feed_xy=v["feed_xy"],
                tool=v["tool"],
            )
        ]
    if kind == "REP":
        return [
            Rep(
                units=common["units"],
                message=common["message"],
                x=v["x"],
                y=v["y"],
                nx=v["nx"],
                ny=v["ny"],
            )
        ]
    action = {"exec": CopyAction.EXEC, "cancel": CopyAction.CANCEL}.get(form.get("action", ""))
    return [
        Copy(
            units=common["units"],
            from_block=v["from_block"],
            to_block=v["to_block"],
            op=HoleOp(v["op"]) if v.get("op") else None,
            pecks=v["pecks"],
            xof=v["xof"],
            yof=v["yof"],
            z_up=v["z_up"],
            z_dn=v["z_dn"],
            feed_z=v["feed_z"],
            feed_xy=v["feed_xy"],
            tool=v["tool"],
            action=action,
        )
    ]
