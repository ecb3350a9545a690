"""The MillBlocks program document: versioned JSON with a lossless round trip.

The format is described in docs/program-format.md. `dumps` writes a deterministic text
(fixed key order, two-space indent, trailing newline); `loads` reads it back and raises
DocumentError naming the block and field of anything malformed. Numbers are read as
`Decimal`, so what was typed is what is kept, and checked by app.cnc.numbers (no NaN or
Infinity, nothing beyond 1E+30); its text by app.cnc.text (no NUL or lone surrogate, the
name and notes within their lengths); a document nested deeper than JSON's own reader
goes, or with more than `MAX_BLOCKS` blocks, is refused whole.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import json
import typing
from dataclasses import dataclass, replace
from decimal import Decimal
from typing import Any

from app.cnc.blocks import Block, DataBlock0, Program, Stock, Tool, field_label
from app.cnc.cutting import Workpiece
from app.cnc.kinds import REGISTRY
from app.cnc.memo import ByObject, Recent
from app.cnc.numbers import NumberError, check_decimal, check_int, decimal_of
from app.cnc.sizes import MAX_BLOCKS
from app.cnc.text import NAME_LENGTH, NOTES_LENGTH, text_fault
from app.cnc.tools import Hand
from app.cnc.units import Units

FORMAT_NAME = "millblocks-program"
FORMAT_VERSION = 1


class DocumentError(ValueError):
    """A malformed document; `where` names the block and field (e.g. `block 3, FEEDR Z`)."""

    def __init__(self, where: str, message: str) -> None:
        super().__init__(f"{where}: {message}" if where else message)
        self.where = where
        self.message = message


# -- writing ------------------------------------------------------------------------------


def to_dict(program: Program) -> dict[str, Any]:
    """The document as plain JSON data."""
    db0 = program.block0
    data: dict[str, Any] = {
        "format": FORMAT_NAME,
        "version": FORMAT_VERSION,
        "name": program.name,
        "part_number": program.part_number,
        "units": program.units.value,
        "notes": program.notes,
    }
    # Written only when stated, so documents without a material read and write as before.
    if program.material is not None:
        data["material"] = _material_out(program.material)
    data |= {
        "data_block_0": {
            "x_offset": _out(db0.x_offset),
            "y_offset": _out(db0.y_offset),
            "current_tool": db0.current_tool,
            "milling": db0.milling.value,
            "z_retract": _out(db0.z_retract),
            "tools": [_tool_out(tool) for tool in db0.tools],
        },
        "blocks": [_block_out(block) for block in program.blocks],
    }
    # Written only when set, so documents without a stock read and write as before.
    if program.stock is not None:
        stock = _fields_out(program.stock)
        if not stock["clear"]:
            del stock["clear"]  # no room under the stock: documents read and write as before
        data["stock"] = stock
    return data


def dumps(program: Program) -> str:
    """The document as deterministic JSON text: `json.dumps(to_dict(program), indent=2)`.

    Made from each block's own text, kept per block object: a program is edited a block at
    a time and the other blocks are the same objects from one save to the next."""
    data = to_dict(_without_blocks(program))
    del data["blocks"]
    stock = data.pop("stock", None)
    head = _json(data).removesuffix("\n}")
    parts = [head, ',\n  "blocks": [']
    if program.blocks:
        parts += ["\n", ",\n".join("    " + _block_text(block) for block in program.blocks)]
        parts.append("\n  ]")
    else:
        parts.append("]")
    if stock is not None:
        parts += [',\n  "stock": ', _json(stock).replace("\n", "\n  ")]
    parts.append("\n}\n")
    return "".join(parts)


def _json(data: Any) -> str:
    return json.dumps(data, indent=2, ensure_ascii=False)


def _without_blocks(program: Program) -> Program:
    return Program(
        name=program.name,
        part_number=program.part_number,
        units=program.units,
        notes=program.notes,
        block0=program.block0,
        stock=program.stock,
        material=program.material,
    )


# Each block's text as it stands in the document (indented for its place), by the block
# object; the entry keeps the block alive, so its id is not reused while it is here.
BLOCK_MEMO = 1 << 16
_BLOCK_TEXT: ByObject[str] = ByObject(BLOCK_MEMO)


def _block_text(block: Block) -> str:
    text = _BLOCK_TEXT.get(block)
    if text is None:
        text = _json(_block_out(block)).replace("\n", "\n    ")
        _BLOCK_TEXT.keep(block, text)
    return text


def as_stored(program: Program) -> Program:
    """The program as its document reads back: `loads(dumps(program))`, which writes every
    number as the document does (1.50 is stored as 1.5). What reads back exactly as it is
    (blocks read from a document, and most typed ones) stays the same object, and so does
    the program when all of it does: what was worked out for it still applies."""
    blocks = tuple(_stored_block(block, n) for n, block in enumerate(program.blocks, 1))
    stock, material = program.stock, program.material
    if (
        not _READ.get(program.block0)
        or (stock is not None and not _READ.get(stock))
        or (material is not None and not _READ.get(material))
    ):
        rest = loads(dumps(_without_blocks(program)))
        if (
            repr(rest.block0) == repr(program.block0)
            and repr(rest.stock) == repr(stock)
            and repr(rest.material) == repr(material)
        ):
            for part in (program.block0, stock, material):
                if part is not None:
                    _was_read(part)
        else:
            return replace(rest, blocks=blocks)
    if all(a is b for a, b in zip(blocks, program.blocks, strict=True)):
        return program
    return replace(program, blocks=blocks)


def _stored_block(block: Block, number: int) -> Block:
    if _READ.get(block):
        return block
    data = json.loads(_json(_block_out(block)), parse_float=decimal_of, parse_int=_whole)
    again = _block_in(data, number)
    # The same values written the same way (repr shows each Decimal as typed): keep it.
    return _was_read(block if repr(again) == repr(block) else again)


# Blocks and Data Blocks 0 made by reading a document (by identity; kept alive while here).
_READ: ByObject[bool] = ByObject(BLOCK_MEMO)


def _was_read(value: _T) -> _T:
    _READ.keep(value, True)
    return value


def _block_out(block: Block) -> dict[str, Any]:
    # The JSON `type` names the kind and stands for the field values it fixes (DRILL: op).
    kind = REGISTRY.document_of(block)
    data: dict[str, Any] = {"type": kind.name}
    data.update(_fields_out(block))
    for name, _ in kind.fixed:
        del data[name]
    # Calculated geometry's fields (issue 33) only when set: documents without them read
    # and write as before.
    # (`is`: a BOLT CIR's angle 0 or a line's ANGLE 0 is a value, though 0 == False.)
    for name in _BLOCK_WHEN_SET:
        if name in data and (data[name] is None or data[name] is False):
            del data[name]
    return data


_BLOCK_WHEN_SET = ("angle", "radius", "tangent", "conrad", "chamfer", "entry", "ramp_angle")


# A tool's fields written only when set (its name, and the copy of the crib tool it was
# picked from): documents without them read and write as before.
_TOOL_WHEN_SET = ("name", "crib", "kind", "flutes", "tool_material", "length", "pitch")


def _tool_out(tool: Tool) -> dict[str, Any]:
    """A tool's fields; those of _TOOL_WHEN_SET only when set, its pitch unit only with a
    pitch and its hand only when left."""
    data = _fields_out(tool)
    for name in _TOOL_WHEN_SET:
        if data[name] in ("", None):
            del data[name]
    if tool.pitch is None:
        del data["pitch_unit"]
    if tool.hand is Hand.RIGHT:
        del data["hand"]
    return data


def _material_out(material: Workpiece) -> dict[str, Any]:
    """The stated material: its name, and a custom one's figures."""
    data = _fields_out(material)
    for name in ("surface_speed", "chip_load"):
        if data[name] is None:
            del data[name]
    return data


def write_fields(obj: Any) -> dict[str, Any]:
    """Any declared dataclass's fields as JSON data (numbers as typed, enums by value):
    the document's own writing, for the other documents of the library (a crib tool)."""
    return _fields_out(obj)


def read_fields(cls: type[_T], data: Any, where: str) -> _T:
    """A declared dataclass from JSON data, each field converted and checked as the
    document's own are. Raises DocumentError naming `where` and the field."""
    if not isinstance(data, dict):
        raise DocumentError(where, f"expected an object, got {_show(data)}")
    return _build(cls, data, where)


def _fields_out(obj: Any) -> dict[str, Any]:
    return {f.name: _out(getattr(obj, f.name)) for f in REGISTRY.fields(type(obj))}


def _out(value: Any) -> Any:
    if isinstance(value, Decimal):
        # Programs are typed to 0.001 in / 0.01 mm, far inside a float's 15 exact digits,
        # so a float writes the typed value exactly and reads back to the same Decimal.
        return int(value) if value == value.to_integral_value() else float(value)
    if isinstance(value, enum.Enum):
        return value.value
    return value


# -- reading ------------------------------------------------------------------------------


def loads(text: str) -> Program:
    """Read a document. Raises DocumentError (line and column for bad JSON)."""
    try:
        data = json.loads(
            text, parse_float=decimal_of, parse_int=_whole, parse_constant=_no_constant
        )
    except json.JSONDecodeError as exc:
        raise DocumentError(
            f"line {exc.lineno}, column {exc.colno}", f"not valid JSON: {exc.msg}"
        ) from None
    except NumberError as exc:
        raise DocumentError("", str(exc)) from None
    except RecursionError:
        # JSON's reader recurses once per level; a program document is 4 levels deep.
        raise DocumentError("", "not a program document: nested too deeply") from None
    return from_dict(data)


def _whole(text: str) -> int | Decimal:
    """A JSON integer; one beyond Decimal's bounds is refused before `int()` reads it
    (Python refuses over 4 300 digits with a ValueError of its own)."""
    if len(text.lstrip("-")) > 31:
        raise NumberError(f"{text[:40]}… is too large; allowed: up to 1E+30 in size")
    return int(text)


def _no_constant(text: str) -> Any:
    raise NumberError(f"{text} is not a number; JSON numbers are digits, such as -1.25")


def from_dict(data: Any) -> Program:
    """Build a Program from JSON data. Raises DocumentError naming what is wrong."""
    if not isinstance(data, dict):
        raise DocumentError("", "a program document is a JSON object")
    if "format" not in data:
        raise DocumentError("format", f'missing; a program document has "format": "{FORMAT_NAME}"')
    if data["format"] != FORMAT_NAME:
        raise DocumentError("format", f'expected "{FORMAT_NAME}", got {_show(data["format"])}')
    if data.get("version") != FORMAT_VERSION:
        raise DocumentError(
            "version",
            f"version {data.get('version')!r} is not supported; this MillBlocks reads version "
            f"{FORMAT_VERSION}",
        )
    known = {"format", "version", "name", "part_number", "units", "notes", "material"}
    known |= {"data_block_0", "blocks", "stock"}
    _no_unknown("program", data, known)
    units = _enum(Units, data.get("units", "inch"), "program, units")
    db0_data = data.get("data_block_0", {})
    if not isinstance(db0_data, dict):
        raise DocumentError("Data Block 0", "expected an object")
    tools_data = db0_data.get("tools", [])
    if not isinstance(tools_data, list):
        raise DocumentError("Data Block 0, tools", "expected a list of tools")
    tools = tuple(_tool_in(item, n) for n, item in enumerate(tools_data, start=1))
    db0_fields = {k: v for k, v in db0_data.items() if k != "tools"}
    block0 = _was_read(_build(DataBlock0, db0_fields, "Data Block 0", tools=tools))
    blocks_data = data.get("blocks", [])
    if not isinstance(blocks_data, list):
        raise DocumentError("blocks", "expected a list of data blocks")
    if len(blocks_data) > MAX_BLOCKS:
        raise DocumentError(
            "blocks",
            f"{len(blocks_data)} data blocks; a program has at most {MAX_BLOCKS} (the limit of "
            "one program in MillBlocks)",
        )
    blocks = tuple(_was_read(_block_in(item, n)) for n, item in enumerate(blocks_data, start=1))
    stock_data = data.get("stock")
    if stock_data is not None and not isinstance(stock_data, dict):
        raise DocumentError("stock", 'expected an object like {"x": 0, "y": 0, "xl": 4, ...}')
    material_data = data.get("material")
    if material_data is not None and not isinstance(material_data, dict):
        raise DocumentError("material", 'expected an object like {"name": "6061"}')
    return Program(
        name=_text(data.get("name", ""), "program, name", NAME_LENGTH),
        part_number=_text(data.get("part_number", ""), "program, part_number", NAME_LENGTH),
        units=units,
        notes=_text(data.get("notes", ""), "program, notes", NOTES_LENGTH),
        block0=block0,
        blocks=blocks,
        stock=None if stock_data is None else _was_read(_build(Stock, stock_data, "stock")),
        material=(
            None
            if material_data is None
            else _was_read(_build(Workpiece, material_data, "material"))
        ),
    )


def _tool_in(item: Any, number: int) -> Tool:
    where = f"Data Block 0, tool entry {number}"
    if not isinstance(item, dict):
        raise DocumentError(
            where, f'expected an object like {{"number": 1, ...}}, got {_show(item)}'
        )
    return _build(Tool, item, where)


# Blocks already read, by their JSON fields exactly as written: the next version of a
# program is the same document but for the edited block, and reads it from here.
_BLOCKS_READ: Recent[Block] = Recent(BLOCK_MEMO)


def _block_in(item: Any, number: int) -> Block:
    where = f"block {number}"
    if not isinstance(item, dict):
        raise DocumentError(where, "expected an object")
    try:
        key: tuple[Any, ...] | None = tuple((k, _written(v)) for k, v in item.items())
        known = _BLOCKS_READ.get(key)
    except TypeError:  # a list or an object where a value belongs: read it for its error
        key = known = None
    if known is not None:
        return known
    block = _read_block(item, where)
    if key is not None:
        _BLOCKS_READ.keep(key, block)
    return block


def _written(value: Any) -> Any:
    """A JSON value as written: 1.5 and 1.50 read as equal Decimals but are kept apart."""
    return (type(value), str(value)) if isinstance(value, Decimal) else (type(value), value)


def _read_block(item: dict[str, Any], where: str) -> Block:
    kind = item.get("type")
    types = REGISTRY.documents()
    found = types.get(kind) if isinstance(kind, str) else None
    if found is None:
        allowed = ", ".join(sorted(types))
        raise DocumentError(f"{where}, type", f"unknown block type {kind!r}; allowed: {allowed}")
    cls, fixed = found
    fields = {k: v for k, v in item.items() if k != "type"}
    return _build(cls, fields, where, **fixed)


_T = typing.TypeVar("_T")


@dataclass(frozen=True)
class _Shape:
    """What reading a dataclass from JSON needs, worked out once per class: its resolved
    type hints (slow to resolve), its field names and those that have no default."""

    hints: dict[str, Any]
    names: frozenset[str]
    required: tuple[str, ...]


@functools.cache
def _shape(cls: type) -> _Shape:
    fields = dataclasses.fields(cls)
    return _Shape(
        typing.get_type_hints(cls),
        frozenset(f.name for f in fields),
        tuple(
            f.name
            for f in fields
            if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
        ),
    )


def _build(cls: type[_T], data: dict[str, Any], where: str, **fixed: Any) -> _T:
    """Construct dataclass `cls` from JSON fields, converting and checking each one."""
    shape = _shape(typing.cast(type, cls))  # (mypy: a type[_T] is hashable too)
    _no_unknown(where, data, set(shape.names - set(fixed)))
    values: dict[str, Any] = dict(fixed)
    for name, raw in data.items():
        label = field_label(cls, name)  # type: ignore[arg-type]
        values[name] = _convert(raw, shape.hints[name], f"{where}, {label}")
    missing = [field_label(cls, name) for name in shape.required if name not in values]  # type: ignore[arg-type]
    if missing:
        raise DocumentError(f"{where}, {missing[0]}", "missing; this field has no default")
    return cls(**values)


def _convert(raw: Any, hint: Any, where: str) -> Any:
    options = typing.get_args(hint) if typing.get_origin(hint) in (typing.Union, _UnionType) else ()
    if options:
        if raw is None and type(None) in options:
            return None
        hint = next(o for o in options if o is not type(None))
    if hint is bool:
        if not isinstance(raw, bool):
            raise DocumentError(where, f"expected true or false, got {_show(raw)}")
        return raw
    if hint is int:
        if isinstance(raw, bool) or not isinstance(raw, int):
            raise DocumentError(where, f"expected a whole number, got {_show(raw)}")
        try:
            return check_int(raw)
        except NumberError as exc:
            raise DocumentError(where, str(exc)) from None
    if hint is Decimal:
        if isinstance(raw, bool) or not isinstance(raw, int | Decimal):
            raise DocumentError(where, f"expected a number, got {_show(raw)}")
        try:
            return check_decimal(Decimal(raw))
        except NumberError as exc:
            raise DocumentError(where, str(exc)) from None
    if isinstance(hint, type) and issubclass(hint, enum.Enum):
        return _enum(hint, raw, where)
    if hint is str:  # a block's message, a tool's name: their rules are validation's
        return _text(raw, where, NAME_LENGTH)
    raise TypeError(f"no JSON conversion for {hint!r}")


_UnionType = type(int | None)
_E = typing.TypeVar("_E", bound=enum.Enum)


def _enum(cls: type[_E], raw: Any, where: str) -> _E:
    for member in cls:
        if member.value == raw:
            return member
    allowed = ", ".join(repr(m.value) for m in cls)
    raise DocumentError(where, f"{_show(raw)} is not one of {allowed}")


def _text(raw: Any, where: str, limit: int) -> str:
    """A JSON string that meets the one text rule (app.cnc.text): no NUL, no lone
    surrogate (`"\\ud800"`), at most `limit` characters."""
    if not isinstance(raw, str):
        raise DocumentError(where, f"expected text, got {_show(raw)}")
    fault = text_fault(raw, limit)
    if fault:
        raise DocumentError(where, fault)
    return raw


def _no_unknown(where: str, data: dict[str, Any], known: set[str]) -> None:
    unknown = sorted(set(data) - known)
    if unknown:
        raise DocumentError(
            where, f"unknown field {unknown[0]!r}; allowed: {', '.join(sorted(known))}"
        )


def _show(raw: Any) -> str:
    """A JSON value as it was written: numbers bare, text quoted (cut short)."""
    if isinstance(raw, Decimal):
        return str(raw)
    try:
        text = json.dumps(
            raw, default=lambda value: float(value) if isinstance(value, Decimal) else str(value)
        )
    except (RecursionError, ValueError):
        return "a value nested too deeply"
    return text if len(text) <= 60 else text[:60] + "…"
