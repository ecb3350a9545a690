"""The canonical text dump: one canonical call per line, in the manner of LinuxCNC's saicanon.

Every line starts with the block number the call came from (0 for set-up). Lengths are in
the program's units with fixed decimals (0.0001 in, 0.001 mm), feeds in units per minute
with the same decimals, dwells in seconds to 0.01 s. A tag, when a move has one, follows
after `;`. The dump is a pure function of the tool path: same program, same bytes; the
target writes it as the compiled path's moves come, a chunk at a time.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping
from typing import Any

from app.cnc.blocks import Program
from app.cnc.formats.targets import Out, Report, Target, register
from app.cnc.formats.text import Lengths
from app.cnc.path import CompiledPath
from app.cnc.toolpath import (
    ArcFeed,
    CoolantOff,
    CoolantOn,
    Dwell,
    Feed,
    IndexTable,
    Message,
    Move,
    ProgramEnd,
    ProgramStop,
    Rapid,
    SpindleOff,
    SpindleOn,
    ToolChange,
    Toolpath,
)

HEADER = "# MillBlocks canonical dump v1"


def dump(toolpath: Toolpath) -> str:
    """The whole tool path as canonical text (ends with a newline)."""
    return "".join(iter_lines(toolpath))


def iter_lines(toolpath: Toolpath) -> Iterator[str]:
    """The dump line by line, so large tool paths can be streamed."""
    return _lines(toolpath, toolpath.moves)


def _lines(toolpath: Toolpath | CompiledPath, moves: Iterable[Move]) -> Iterator[str]:
    """The dump of `moves`, which start as `toolpath` says (its units, origin, start and
    tools)."""
    u = toolpath.units
    length = Lengths(u).one

    yield f"{HEADER}, units {u.value}\n"
    x, y, z = toolpath.start
    yield f"{0:>5} SET_ORIGIN_OFFSETS({length(toolpath.origin[0])}, {length(toolpath.origin[1])})\n"
    yield f"{0:>5} START_POSITION({length(x)}, {length(y)}, {length(z)})\n"
    yield f"{0:>5} CURRENT_TOOL({toolpath.initial_tool})\n"
    if toolpath.initial_tool:
        yield f"{0:>5} {_tool_data(toolpath, toolpath.initial_tool, length)}\n"
    for move in moves:
        yield f"{move.block:>5} {_call(move, length)}\n"
        if isinstance(move, ToolChange):
            # As LinuxCNC's USE_TOOL_LENGTH_OFFSET: Z after this line is measured from this
            # tool's calibrated zero (TCAL), which the dump states so every target can use it.
            yield f"{move.block:>5} {_tool_data(toolpath, move.tool, length)}\n"


def _tool_data(toolpath: Toolpath | CompiledPath, tool: int, length: Callable[[int], str]) -> str:
    info = toolpath.tools.get(tool)
    dia = "none" if info is None or info.diameter is None else length(info.diameter)
    tcal = "uncalibrated" if info is None or info.tcal is None else length(info.tcal)
    return f"TOOL_DATA({tool}, DIA {dia}, TCAL {tcal})"


def _call(move: Move, length: Callable[[int], str]) -> str:
    if isinstance(move, Rapid):
        text = f"STRAIGHT_TRAVERSE({length(move.x)}, {length(move.y)}, {length(move.z)})"
    elif isinstance(move, Feed):
        text = (
            f"STRAIGHT_FEED({length(move.x)}, {length(move.y)}, {length(move.z)}, "
            f"F {length(move.feed)})"
        )
    elif isinstance(move, ArcFeed):
        text = (
            f"ARC_FEED({length(move.x)}, {length(move.y)}, {length(move.z)}, "
            f"C {length(move.cx)}, {length(move.cy)}, {'CW' if move.clockwise else 'CCW'}, "
            f"F {length(move.feed)})"
        )
    elif isinstance(move, Dwell):
        return f"DWELL({move.seconds:.2f})"
    elif isinstance(move, SpindleOn):
        speed = "NO RPM" if move.rpm is None else move.rpm
        return f"SPINDLE_{'CW' if move.clockwise else 'CCW'}({speed})"
    elif isinstance(move, SpindleOff):
        return "SPINDLE_STOP()"
    elif isinstance(move, ToolChange):
        return f"TOOL_CHANGE({move.tool}, Z {length(move.z)})"
    elif isinstance(move, ProgramStop):
        return f"PROGRAM_STOP({move.reason})"
    elif isinstance(move, IndexTable):
        return "INDEX_TABLE()"
    elif isinstance(move, CoolantOn):
        return f"COOLANT_{move.mode.upper()}()"
    elif isinstance(move, CoolantOff):
        return "COOLANT_OFF()"
    elif isinstance(move, Message):
        return f"MESSAGE({move.text})"
    else:
        assert isinstance(move, ProgramEnd)
        return "PROGRAM_END()"
    return f"{text}  ; {move.tag}" if move.tag else text


@register
class CanonTarget(Target):
    """The canonical dump as an export target."""

    name = "canon"
    label = "Canonical moves (the test dump)"
    description = "canonical move dump (one call per line, the golden-test format)"
    extension = "canon"

    def write(
        self,
        program: Program,
        path: CompiledPath,
        options: Mapping[str, Any],
        report: Report,
        out: Out,
    ) -> None:
        pending: list[str] = []
        for line in _lines(path, path.moves()):
            pending.append(line)
            if len(pending) == 4096:
                out.write("".join(pending).encode("utf-8"))
                pending = []
        out.write("".join(pending).encode("utf-8"))
