"""Cycle-time estimate per block, per tool and in total.

Not a trajectory planner. What it assumes, stated with every estimate (`ASSUMPTIONS`):
- rapids are straight lines at the control's 250 ipm (XY and Z, seed 001 §3.4.5.2 POS/DRILL);
- feeds run at the programmed rate along the path (line or arc length); acceleration and
  deceleration are not modelled, so short moves are estimated slightly fast;
- hole dwells are 0.8 s; a tool change costs a fixed allowance (default 30 s, the operator
  changes tools by hand on this control);
- program stops, STOP blocks and manual quill moves wait for the operator: counted as 0 s
  and listed, since the operator's time cannot be known;
- rotary-table indexing is counted as 0 s and listed;
- a machine's operator time (seed 002 OTIME: "the additional operator time to be added to
  the printed cycle time") is added once to the total.
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass, field
from decimal import Decimal

from app.cnc.geometry import arc_sweep
from app.cnc.limits import RAPID_IPM
from app.cnc.machine import MachineModel
from app.cnc.toolpath import (
    ArcFeed,
    Dwell,
    Feed,
    IndexTable,
    ProgramStop,
    Rapid,
    ToolChange,
    Toolpath,
)
from app.cnc.units import NM_PER_INCH

DEFAULT_TOOL_CHANGE_SECONDS = 30.0
RAPID_NM_PER_MIN = int(RAPID_IPM) * NM_PER_INCH


def assumptions(tool_change_seconds: float, machine: MachineModel | None = None) -> list[str]:
    """The estimate's assumptions, in words, for printing beside it."""
    rapid = "250 ipm"
    feeds = "programmed rate along the path; acceleration not modelled"
    operator = "operator stops, STOP blocks, manual quill moves and indexing: 0 s (listed)"
    if machine is not None:
        unit = machine.units.feed_symbol
        if machine.rapid is not None:
            rapid = f"{machine.rapid} {unit} ({machine.name or 'the machine'})"
        if machine.max_feed is not None:
            feeds += f"; limited to the machine's {machine.max_feed} {unit}"
        if machine.operator_seconds is not None:
            operator = (
                f"operator time (OTIME): {machine.operator_seconds} s added once to the total; "
                "operator stops, STOP blocks, manual quill moves and indexing: 0 s (listed)"
            )
    return [
        f"rapids: straight lines at {rapid} (XY and Z)",
        f"feeds: {feeds}",
        "hole dwell: 0.8 s",
        f"tool change: {tool_change_seconds:g} s allowance each",
        operator,
    ]


@dataclass
class Estimate:
    """Seconds per block number, per tool number, in total; operator waits listed."""

    per_block: dict[int, float] = field(default_factory=dict)
    per_tool: dict[int, float] = field(default_factory=dict)
    total: float = 0.0
    rapid: float = 0.0
    cutting: float = 0.0
    dwell: float = 0.0
    tool_changes: int = 0
    operator: float = 0.0  # OTIME, in the total but no block's
    operator_waits: list[tuple[int, str]] = field(default_factory=list)
    assumptions: list[str] = field(default_factory=list)


def estimate(
    toolpath: Toolpath,
    tool_change_seconds: float | None = None,
    machine: MachineModel | None = None,
) -> Estimate:
    """Estimate the run time of `toolpath` (see the module docstring for the model).

    A `machine` sets the rapid rate, caps feeds at its maximum, and supplies its tool-change
    and operator times (OTIME); `tool_change_seconds` overrides the tool-change time.
    """
    if tool_change_seconds is None:
        known = machine.tool_change_seconds if machine is not None else None
        tool_change_seconds = float(known) if known is not None else DEFAULT_TOOL_CHANGE_SECONDS
    rapid_rate = RAPID_NM_PER_MIN
    max_feed = None
    operator = 0.0
    if machine is not None:
        if machine.rapid is not None:
            rapid_rate = machine.nm(machine.rapid)
        if machine.max_feed is not None:
            max_feed = machine.nm(machine.max_feed)
        if machine.operator_seconds is not None:
            operator = float(machine.operator_seconds)
    per_block: dict[int, float] = defaultdict(float)
    per_tool: dict[int, float] = defaultdict(float)
    result = Estimate(assumptions=assumptions(tool_change_seconds, machine))
    x, y, z = toolpath.start
    tool = toolpath.initial_tool
    for move in toolpath.moves:
        seconds = 0.0
        if isinstance(move, Rapid | Feed):
            length = math.sqrt((move.x - x) ** 2 + (move.y - y) ** 2 + (move.z - z) ** 2)
            rate = rapid_rate if isinstance(move, Rapid) else move.feed
            if max_feed is not None and not isinstance(move, Rapid):
                rate = min(rate, max_feed)
            seconds = 60.0 * length / rate
            if isinstance(move, Rapid):
                result.rapid += seconds
            else:
                result.cutting += seconds
            x, y, z = move.x, move.y, move.z
        elif isinstance(move, ArcFeed):
            radius = math.hypot(x - move.cx, y - move.cy)
            sweep = arc_sweep((x, y), (move.x, move.y), (move.cx, move.cy), move.clockwise)
            rate = move.feed if max_feed is None else min(move.feed, max_feed)
            seconds = 60.0 * radius * sweep / rate
            result.cutting += seconds
            x, y = move.x, move.y
        elif isinstance(move, Dwell):
            seconds = float(move.seconds)
            result.dwell += seconds
        elif isinstance(move, ToolChange):
            seconds = tool_change_seconds
            result.tool_changes += 1
            tool = move.tool
            z = move.z  # the head stays; its Z reads differently with the new tool
        elif isinstance(move, ProgramStop):
            result.operator_waits.append((move.block, move.reason))
        elif isinstance(move, IndexTable):
            result.operator_waits.append((move.block, "index the rotary table"))
        per_block[move.block] += seconds
        per_tool[tool] += seconds
    result.per_block = dict(sorted(per_block.items()))
    result.per_tool = dict(sorted(per_tool.items()))
    result.operator = operator
    result.total = sum(per_block.values()) + operator
    return result


def format_seconds(seconds: float) -> str:
    """`1:02:03.4` style: hours only when needed, tenths of a second."""
    tenths = round(Decimal(repr(seconds)) * 10)
    whole, tenth = divmod(int(tenths), 10)
    minutes, secs = divmod(whole, 60)
    hours, minutes = divmod(minutes, 60)
    if hours:
        return f"{hours}:{minutes:02d}:{secs:02d}.{tenth}"
    return f"{minutes}:{secs:02d}.{tenth}"


def report(result: Estimate) -> str:
    """The estimate as text: assumptions first, then per block, per tool, total."""
    lines = ["Cycle time estimate", "Assumptions:"]
    lines += [f"  - {a}" for a in result.assumptions]
    lines.append("Per block:")
    for block, seconds in result.per_block.items():
        name = "set-up" if block == 0 else f"block {block}"
        lines.append(f"  {name:<10} {format_seconds(seconds):>10}")
    lines.append("Per tool:")
    for tool, seconds in result.per_tool.items():
        name = "no tool" if tool == 0 else f"tool {tool}"
        lines.append(f"  {name:<10} {format_seconds(seconds):>10}")
    lines.append(
        f"Rapid {format_seconds(result.rapid)}, cutting {format_seconds(result.cutting)}, "
        f"dwell {format_seconds(result.dwell)}, tool changes {result.tool_changes}"
    )
    for block, reason in result.operator_waits:
        lines.append(f"Operator wait (not timed): block {block}: {reason}")
    if result.operator:
        lines.append(f"Operator time (OTIME) {format_seconds(result.operator)}")
    lines.append(f"Total {format_seconds(result.total)}")
    return "\n".join(lines) + "\n"
