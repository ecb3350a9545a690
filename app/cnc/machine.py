"""What a machine can do: travel limits, a collision zone, rapid and feed rates, times.

Seed 002 §2 gives the Kearney & Trecker Milwaukee-Matic models' limits and collision zones
(and §5's LIMIT word the way to change them); those are the presets here. A machine's
spindle range (app.cnc.spindle) decides the RPM an export to it takes. A tool path is
checked against a machine in machine coordinates: X and Y are part coordinates plus the
Data Block 0 offsets of part zero, Z is the tool's Z plus its calibration (TCAL; an
uncalibrated tool counts as 0). Every move that would leave the travel, or enter the
collision zone, is named with its block.

Collision zone (seed 002 §2): "the Y-Axis slide must be at a position greater than a while
the Z-Axis is less than b, or vice versa" — read, with LIMIT's YZ a/b "minimum values", as:
a move is in the zone where Y < a and Z < b at the same time.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from decimal import Decimal
from typing import Any

import numpy as np

from app.cnc.blocks import Program
from app.cnc.geometry import arc_sweep
from app.cnc.motions import motions
from app.cnc.numbers import NumberError, parse_decimal
from app.cnc.path import CompiledPath, Op, as_move
from app.cnc.spindle import CONTROL, Spindle, SpindleError, read_spindle, refusal
from app.cnc.toolpath import ArcFeed, Feed, Rapid
from app.cnc.units import Units, format_length, to_nm

AXES = ("x", "y", "z")


class MachineError(ValueError):
    """A machine description that cannot be read (the message names the field)."""


@dataclass(frozen=True)
class MachineModel:
    """A machine's limits and rates, in `units` (Decimal values as typed)."""

    name: str = ""
    units: Units = Units.INCH
    travel: dict[str, tuple[Decimal, Decimal]] = field(default_factory=dict)
    zone: tuple[Decimal, Decimal] | None = None  # (Y minimum, Z minimum)
    rapid: Decimal | None = None  # per minute, None: the data-block control's 250 ipm
    max_feed: Decimal | None = None  # per minute, linear motion
    tool_change_seconds: Decimal | None = None
    operator_seconds: Decimal | None = None  # OTIME: added once to the printed cycle time
    spindle: Spindle | None = None  # None: the profile gives none (the control's is assumed)

    def nm(self, value: Decimal) -> int:
        return to_nm(value, self.units)


_KT_INCH = Units.INCH
PRESETS: dict[str, MachineModel] = {
    "kt-180": MachineModel(
        "Kearney & Trecker Milwaukee-Matic 180",
        _KT_INCH,
        {
            "x": (Decimal(0), Decimal(20)),
            "y": (Decimal(0), Decimal(20)),
            "z": (Decimal(0), Decimal(20)),
        },
        (Decimal("2.88"), Decimal("6.50")),
        max_feed=Decimal(400),
        # "RPM range is from 4 to 4000 rpms" (the 200/600's depends on its headstock).
        spindle=Spindle(((4, 4000),), "the Kearney & Trecker Milwaukee-Matic 180"),
    ),
    "kt-200": MachineModel(
        "Kearney & Trecker Milwaukee-Matic 200/600",
        _KT_INCH,
        {
            "x": (Decimal(0), Decimal(24)),
            "y": (Decimal(0), Decimal(20)),
            "z": (Decimal(0), Decimal(20)),
        },
        (Decimal("5.90"), Decimal("8.50")),
        max_feed=Decimal(400),
    ),
    "kt-200-optional": MachineModel(
        "Kearney & Trecker Milwaukee-Matic 200/600, optional travel",
        _KT_INCH,
        {
            "x": (Decimal(0), Decimal(30)),
            "y": (Decimal(0), Decimal(20)),
            "z": (Decimal(0), Decimal(20)),
        },
        (Decimal("5.90"), Decimal("8.50")),
        max_feed=Decimal(400),
    ),
    "kt-800": MachineModel(
        "Kearney & Trecker Milwaukee-Matic 800",
        _KT_INCH,
        {
            "x": (Decimal(0), Decimal("43.1535")),
            "y": (Decimal(0), Decimal("35.4")),
            "z": (Decimal(5), Decimal("36.5")),
        },
        (Decimal("4.00"), Decimal("19.50")),
        rapid=Decimal(400),
        max_feed=Decimal(400),
    ),
}


KEYS = (
    "preset",
    "name",
    "units",
    *AXES,
    "zone",
    "rapid",
    "max_feed",
    "tool_change_seconds",
    "operator_seconds",
    "spindle",
)
"""What a machine's description may hold; any other key is an error, not ignored: a travel
limit typed `X=0 0.5` or `x_travel=…` would otherwise be saved and never checked."""


def read_machine(data: Mapping[str, Any]) -> MachineModel:
    """A machine from its stored description: `{"preset": "kt-180"}` and/or explicit
    `units`, `x`/`y`/`z` ([min, max]), `zone` ([Y min, Z min]), `rapid`, `max_feed`,
    `tool_change_seconds`, `operator_seconds`, `spindle` (`100-24000`, or gear ranges
    `60-500, 500-4000`). Raises MachineError naming the field, and for a key not in KEYS
    naming it and the allowed keys."""
    unknown = sorted(key for key in data if key not in KEYS)
    if unknown:
        key = str(unknown[0])
        hint = f" (did you mean {key.lower()!r}?)" if key.lower() in KEYS else ""
        raise MachineError(f"unknown key {key!r}{hint}; allowed: {', '.join(KEYS)}")
    base = MachineModel()
    preset = data.get("preset")
    if preset:
        if preset not in PRESETS:
            raise MachineError(f"preset {preset!r} is not one of {', '.join(PRESETS)}")
        base = PRESETS[preset]
    units = base.units
    if "units" in data:
        if data["units"] not in ("inch", "mm"):
            raise MachineError(f"units {data['units']!r} is not inch or mm")
        units = Units(data["units"])
    travel = dict(base.travel)
    for axis in AXES:
        if axis in data and data[axis] not in (None, ""):
            low, high = _pair(data[axis], axis)
            if low >= high:
                raise MachineError(f"{axis}: the minimum {low} is not below the maximum {high}")
            travel[axis] = (low, high)
    zone = base.zone
    if "zone" in data:
        zone = None if data["zone"] in (None, "", []) else _pair(data["zone"], "zone")
    name = str(data.get("name", base.name))
    spindle = base.spindle
    if data.get("spindle") not in (None, ""):
        try:
            spindle = read_spindle(data["spindle"], name or "the machine chosen")
        except SpindleError as exc:
            raise MachineError(f"spindle: {exc}") from None
    return MachineModel(
        name=name,
        units=units,
        travel=travel,
        zone=zone,
        rapid=_number(data, "rapid", base.rapid),
        max_feed=_number(data, "max_feed", base.max_feed),
        tool_change_seconds=_number(data, "tool_change_seconds", base.tool_change_seconds),
        operator_seconds=_number(data, "operator_seconds", base.operator_seconds),
        spindle=spindle,
    )


def _pair(raw: Any, name: str) -> tuple[Decimal, Decimal]:
    if isinstance(raw, str):
        raw = raw.replace("/", " ").replace(",", " ").split()
    if not isinstance(raw, list | tuple) or len(raw) != 2:
        raise MachineError(f"{name}: expected two numbers (minimum and maximum), got {raw!r}")
    try:
        return parse_decimal(str(raw[0])), parse_decimal(str(raw[1]))
    except NumberError as exc:
        raise MachineError(f"{name}: {exc}") from None


def _number(data: Mapping[str, Any], name: str, default: Decimal | None) -> Decimal | None:
    if name not in data or data[name] in (None, ""):
        return default
    try:
        value = parse_decimal(str(data[name]))
    except NumberError as exc:
        raise MachineError(f"{name}: {exc}") from None
    if value <= 0:
        raise MachineError(f"{name}: {value} must be more than 0")
    return value


def check_spindle(program: Program, spindle: Spindle | None) -> list[str]:
    """Each tool of Data Block 0 whose RPM the spindle does not run (None: no machine with a
    spindle range chosen, so the control's), one message per tool."""
    return [
        refusal(tool.number, tool.rpm, spindle)
        for tool in program.block0.tools
        if tool.rpm is not None and not (spindle or CONTROL).runs(tool.rpm)
    ]


@dataclass(frozen=True)
class Crossing:
    """A move that leaves the travel or enters the collision zone."""

    block: int
    message: str


def check_travel(path: CompiledPath, machine: MachineModel) -> list[Crossing]:
    """Every block whose moves cross the machine's travel limits or collision zone (one
    message per block and limit, at the first such move).

    Each chunk's motions are screened with numpy (end points and each arc's whole circle,
    which bounds its bulge); only the moves that may cross are checked exactly."""
    ox, oy = path.origin
    tcal = {n: t.tcal or 0 for n, t in path.tools.items()}
    found: dict[tuple[int, str], Crossing] = {}
    limits = {axis: (machine.nm(lo), machine.nm(hi)) for axis, (lo, hi) in machine.travel.items()}
    zone = (
        None if machine.zone is None else (machine.nm(machine.zone[0]), machine.nm(machine.zone[1]))
    )
    u = path.units

    def show(nm: float) -> str:
        return f"{format_length(round(nm), u)} {u.symbol}"

    for m in motions(path):
        rows = m.rows
        if not len(rows):
            continue
        tools, where = np.unique(m.tool, return_inverse=True)
        lift = np.array([tcal.get(int(t), 0) for t in tools], dtype=np.int64)[where]
        ex, ey = rows["x"] + ox, rows["y"] + oy
        sx, sy = m.x0 + ox, m.y0 + oy
        sz, ez = m.z0 + lift, rows["z"] + lift
        arc = rows["op"] >= Op.ARC_CW
        # Every point of an arc is within its radius of its centre.
        radius = np.where(arc, np.hypot(sx - (rows["cx"] + ox), sy - (rows["cy"] + oy)), 0.0)
        cx, cy = rows["cx"] + ox, rows["cy"] + oy
        low = {
            "x": np.where(arc, cx - radius, np.minimum(sx, ex)),
            "y": np.where(arc, cy - radius, np.minimum(sy, ey)),
            "z": np.minimum(sz, ez),
        }
        high = {
            "x": np.where(arc, cx + radius, np.maximum(sx, ex)),
            "y": np.where(arc, cy + radius, np.maximum(sy, ey)),
            "z": np.maximum(sz, ez),
        }
        maybe = np.zeros(len(rows), dtype=bool)
        for axis, (lo, hi) in limits.items():
            maybe |= (low[axis] < lo - 0.5) | (high[axis] > hi + 0.5)
        if zone is not None:
            maybe |= (low["y"] < zone[0]) & (low["z"] < zone[1])
        strings = m.chunk.strings
        for k in np.flatnonzero(maybe).tolist():
            move = as_move(rows[k].tolist(), strings)
            assert isinstance(move, Rapid | Feed | ArcFeed)
            start = (int(sx[k]), int(sy[k]), int(sz[k]))
            end = (int(ex[k]), int(ey[k]), int(ez[k]))
            _check_move(move, start, end, (ox, oy), limits, zone, machine, show, found)
    return sorted(found.values(), key=lambda c: c.block)


def _check_move(
    move: Rapid | Feed | ArcFeed,
    start: tuple[int, int, int],
    end: tuple[int, int, int],
    origin: tuple[int, int],
    limits: dict[str, tuple[int, int]],
    zone: tuple[int, int] | None,
    machine: MachineModel,
    show: Callable[[float], str],
    found: dict[tuple[int, str], Crossing],
) -> None:
    """Add to `found` the limits one move (in machine coordinates) crosses."""
    ox, oy = origin
    low, high = _extent(move, start, end, ox, oy)
    for i, axis in enumerate(AXES):
        if axis not in limits:
            continue
        lo, hi = limits[axis]
        if low[i] < lo - 0.5 or high[i] > hi + 0.5:
            key = (move.block, axis)
            if key not in found:
                beyond = low[i] if low[i] < lo - 0.5 else high[i]
                found[key] = Crossing(
                    move.block,
                    f"{axis.upper()} reaches {show(beyond)} in machine coordinates; the "
                    f"{machine.name or 'machine'} travels {show(lo)} to {show(hi)}",
                )
    if zone is not None and _enters_zone(start, end, move, zone, ox, oy):
        key = (move.block, "zone")
        if key not in found:
            found[key] = Crossing(
                move.block,
                f"the move enters the collision zone (Y below {show(zone[0])} while Z is "
                f"below {show(zone[1])}): the spindle head can hit the table",
            )


def _extent(
    move: Rapid | Feed | ArcFeed,
    start: tuple[int, int, int],
    end: tuple[int, int, int],
    ox: int,
    oy: int,
) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """The lowest and highest X, Y, Z a move reaches (an arc's bulge included)."""
    xs: list[float] = [start[0], end[0]]
    ys: list[float] = [start[1], end[1]]
    if isinstance(move, ArcFeed):
        cx, cy = move.cx + ox, move.cy + oy
        radius = math.dist(start[:2], (cx, cy))
        a0 = math.atan2(start[1] - cy, start[0] - cx)
        sweep = arc_sweep(start[:2], end[:2], (cx, cy), move.clockwise)
        for k in range(4):
            a = k * math.pi / 2
            along = ((a0 - a) if move.clockwise else (a - a0)) % (2 * math.pi)
            if along <= sweep:
                xs.append(cx + radius * math.cos(a))
                ys.append(cy + radius * math.sin(a))
    zs: list[float] = [start[2], end[2]]
    return (min(xs), min(ys), min(zs)), (max(xs), max(ys), max(zs))


def _enters_zone(
    start: tuple[int, int, int],
    end: tuple[int, int, int],
    move: Rapid | Feed | ArcFeed,
    zone: tuple[int, int],
    ox: int,
    oy: int,
) -> bool:
    """True when some point of the move has Y below zone[0] and Z below zone[1]."""
    if isinstance(move, ArcFeed):
        # An arc is in the zone if its lowest Y is and its lowest Z is (a helical arc's Z
        # changes: taking its lowest may report one that passes under the zone's Y at a
        # higher Z, never miss one).
        low, _ = _extent(move, start, end, ox, oy)
        return low[2] < zone[1] and low[1] < zone[0]

    def below(a: float, b: float, limit: float) -> tuple[float, float] | None:
        """The part of t in [0, 1] where a + (b - a) t < limit."""
        if a < limit and b < limit:
            return (0.0, 1.0)
        if a >= limit and b >= limit:
            return None
        t = (limit - a) / (b - a)
        return (0.0, t) if a < limit else (t, 1.0)

    in_y = below(start[1], end[1], zone[0])
    in_z = below(start[2], end[2], zone[1])
    if in_y is None or in_z is None:
        return False
    return max(in_y[0], in_z[0]) < min(in_y[1], in_z[1])
