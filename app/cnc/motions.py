"""The motions of a compiled path with where each one starts and which tool makes it.

A chunk (app/cnc/path.py) holds each move's end point; a check that needs a move's start
(a crossing of the travel limits, a tool that moves down) or the tool in the spindle gets
them here, a chunk at a time, computed with numpy: the start of a motion is the end of the
motion before it, or the head's Z read with the new tool after a TOOL row.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from app.cnc.path import Chunk, CompiledPath, Op

Ints = npt.NDArray[np.int64]
MOTION_OPS = (Op.RAPID, Op.FEED, Op.ARC_CW, Op.ARC_CCW)


@dataclass(slots=True)
class Motions:
    """The motion rows of one chunk (`rows`, in order; `index` their places in the chunk),
    the point each starts from (`x0`, `y0`, `z0`, nm) and the tool in the spindle."""

    chunk: Chunk
    index: Ints
    x0: Ints
    y0: Ints
    z0: Ints
    tool: Ints

    @property
    def rows(self) -> npt.NDArray[np.void]:
        return self.chunk.rows[self.index]


def is_motion(ops: npt.NDArray[np.uint8]) -> npt.NDArray[np.bool_]:
    """Which rows move the tool (rapid, feed, arc)."""
    return ops <= Op.ARC_CCW


def motions(path: CompiledPath) -> Iterator[Motions]:
    """Every chunk's motions with their starts and tools, in order."""
    x, y, z = path.start
    tool = path.initial_tool
    for chunk in path.chunks():
        rows = chunk.rows
        ops = rows["op"]
        moving = is_motion(ops)
        changing = ops == Op.TOOL
        # Rows that set where the head is: motions (their end) and tool changes (Z read
        # with the new tool; X and Y stay).
        setting = np.flatnonzero(moving | changing)
        set_x = rows["x"][setting]
        set_y = rows["y"][setting]
        set_z = rows["z"][setting]
        at_change = changing[setting]
        if len(setting):
            # A tool change keeps X and Y: carry the motion before it.
            last_motion = np.where(~at_change, np.arange(len(setting)), -1)
            np.maximum.accumulate(last_motion, out=last_motion)
            set_x = np.where(last_motion >= 0, set_x[np.maximum(last_motion, 0)], x)
            set_y = np.where(last_motion >= 0, set_y[np.maximum(last_motion, 0)], y)
        start_x = np.concatenate(([x], set_x[:-1])) if len(setting) else set_x
        start_y = np.concatenate(([y], set_y[:-1])) if len(setting) else set_y
        start_z = np.concatenate(([z], set_z[:-1])) if len(setting) else set_z
        # The tool of each row: the last TOOL row's value before it, else the one carried.
        last_change = np.where(changing, np.arange(len(rows)), -1)
        np.maximum.accumulate(last_change, out=last_change)
        tools = np.where(last_change >= 0, rows["value"][np.maximum(last_change, 0)], tool)
        keep = ~at_change
        index = setting[keep]
        yield Motions(
            chunk,
            index,
            start_x[keep].astype(np.int64),
            start_y[keep].astype(np.int64),
            start_z[keep].astype(np.int64),
            tools[index].astype(np.int64),
        )
        if len(setting):
            x, y, z = int(set_x[-1]), int(set_y[-1]), int(set_z[-1])
        if len(rows):
            tool = int(tools[-1])
