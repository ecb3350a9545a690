"""The stock and the grid the simulation samples it on.

A height map, not dexels: every tool here is vertical (3-axis milling and drilling with end
mills, drill points, boring bars and taps), and a vertical tool removes everything above
its bottom surface in each column, so the material left in a column is always one interval
[stock bottom, top]. One height per cell is then exact at the cell's centre; dexels (a list
of intervals per column) would only pay for undercutting tools (T-slot, dovetail) or
tilted ones, which the data-block control does not have. One int64 per cell also carries
which move cut it last (see `KEY_SHIFT`), for "which block cut here".

Cells are squares of `resolution` nm; cell (i, j) is row i (Y) and column j (X), its centre
at (x0 + (j + ½)·res, y0 + (i + ½)·res). Arrays are (ny, nx), row-major.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from decimal import Decimal
from typing import TYPE_CHECKING

import numpy as np

from app.cnc.blocks import Stock as StockBlock
from app.cnc.simulate.segments import BOOL, Segments
from app.cnc.units import Units, format_length, to_nm

if TYPE_CHECKING:  # placements reads the stock's top from here
    from app.cnc.simulate.placements import Placed


class StockError(ValueError):
    """A stock that cannot be simulated (names the field and what is allowed); `field` is
    the stock's field at fault (x, y, z, xl, yw, zh), or "" for the grid."""

    def __init__(self, message: str, field: str = "") -> None:
        super().__init__(message)
        self.field = field


@dataclass(frozen=True)
class Stock:
    """The raw block in part coordinates, nm: X x0…x1, Y y0…y1, Z bottom…top.

    `given` is True when the program's own stock was used, False when it was sized from
    the program's extent. `clear` is the room under it (parallels): how far below `bottom`
    a cut may go.
    """

    x0: int
    y0: int
    x1: int
    y1: int
    bottom: int
    top: int
    given: bool = False
    clear: int = 0

    def describe(self, units: Units) -> str:
        def f(nm: int) -> str:
            return format_length(nm, units)

        how = "the program's stock" if self.given else "sized from the program's extent"
        return (
            f"X {f(self.x0)} to {f(self.x1)}, Y {f(self.y0)} to {f(self.y1)}, "
            f"Z {f(self.bottom)} to {f(self.top)} {units.symbol}"
            + (f", {f(self.clear)} {units.symbol} clear below" if self.clear else "")
            + f" ({how})"
        )


# Margins of a stock sized from the program (what a machinist would saw off the bar).
MARGIN = {Units.INCH: Decimal("0.1"), Units.MM: Decimal("2.5")}
BELOW = {Units.INCH: Decimal("0.25"), Units.MM: Decimal(6)}
ROUND_TO = {Units.INCH: Decimal("0.05"), Units.MM: Decimal(1)}


# The highest and lowest a stock's faces may be: the height map keeps heights in 36 bits of
# nanometres (sweep.py), ±34 m; a round figure well inside that.
HEIGHT_LIMIT = {Units.INCH: Decimal(1000), Units.MM: Decimal(25_400)}


def program_stock(stock: StockBlock, units: Units) -> Stock:
    """The program's own stock in nm. Raises StockError for a size that is not > 0, or a top
    or bottom face beyond ±HEIGHT_LIMIT."""
    for name, label in (("xl", "XL"), ("yw", "YW"), ("zh", "ZH")):
        if getattr(stock, name) <= 0:
            raise StockError(
                f"stock, {label}: must be more than 0, got {getattr(stock, name)}", name
            )
    limit = HEIGHT_LIMIT[units]
    if not 0 <= stock.clear <= limit:
        raise StockError(
            f"stock, CLEAR: the room under the stock must be 0 to {limit} {units.symbol}, "
            f"got {stock.clear}",
            "clear",
        )
    if abs(stock.z) > limit:
        raise StockError(
            f"stock, Z TOP: must be within ±{limit} {units.symbol}, got {stock.z}", "z"
        )
    if abs(stock.z - stock.zh) > limit:
        raise StockError(
            f"stock, ZH: the bottom (Z TOP − ZH) must be within ±{limit} {units.symbol}, "
            f"got {stock.z - stock.zh}",
            "zh",
        )
    return stock_box(stock, units)


def stock_box(stock: StockBlock, units: Units) -> Stock:
    """The program's own stock in nm as typed, unchecked: `program_stock` checks it first
    for the simulation; the drawing and the below-the-stock rule take it as it is."""
    x0, y0, top = (to_nm(v, units) for v in (stock.x, stock.y, stock.z))
    return Stock(
        x0=x0,
        y0=y0,
        x1=x0 + to_nm(stock.xl, units),
        y1=y0 + to_nm(stock.yw, units),
        bottom=top - to_nm(stock.zh, units),
        top=top,
        given=True,
        clear=to_nm(stock.clear, units),
    )


def extent_stock(placed: Placed, units: Units) -> Stock:
    """A stock that holds every cut: the feed moves' reach (tool radius included) plus a
    margin, rounded outward; its top is part Z0 and its bottom a little below the deepest
    cut. With no cut below Z0, the reach of every move, 0.25 in (6 mm) deep."""
    step = to_nm(ROUND_TO[units], units)

    def cutting(s: Segments) -> BOOL:
        return ~s.rapid & (np.minimum(s.z0, s.z1) < 0)

    any_cut = any(cutting(g.segments).any() for g in placed.groups)
    lows: list[float] = []
    highs: list[float] = []
    deepest = math.inf
    for group in placed.groups:
        s = group.segments
        if any_cut:
            s = s.select(cutting(s))
        elif group.loose:
            # Its first segment starts where the first placement was entered from, which
            # is not where the others were: every start but that one is another's end.
            s = s.select(np.arange(1, len(s)))
        if not len(s):
            continue
        r = s.radius
        xs = np.concatenate([s.x0 - r, s.x1 - r, s.x0 + r, s.x1 + r])
        ys = np.concatenate([s.y0 - r, s.y1 - r, s.y0 + r, s.y1 + r])
        # Arc pieces bulge past their ends by at most (1 − cos 45°)·radius: take the circle.
        if s.arc.any():
            a = s.arc
            ra = np.hypot(s.x0[a] - s.cx[a], s.y0[a] - s.cy[a]) + r[a]
            xs = np.concatenate([xs, s.cx[a] - ra, s.cx[a] + ra])
            ys = np.concatenate([ys, s.cy[a] - ra, s.cy[a] + ra])
        low, high = group.offsets.min(axis=0), group.offsets.max(axis=0)
        lows += [float(xs.min()) + float(low[0]), float(ys.min()) + float(low[1])]
        highs += [float(xs.max()) + float(high[0]), float(ys.max()) + float(high[1])]
        deepest = min(deepest, float(np.minimum(s.z0, s.z1).min()))
    if not lows:
        size = to_nm(BELOW[units], units)
        return Stock(-size, -size, size, size, -size, 0)

    below = to_nm(BELOW[units], units)
    bottom = math.floor((deepest - below) / step) * step if any_cut else -below
    x0, y0 = min(lows[0::2]), min(lows[1::2])
    x1, y1 = max(highs[0::2]), max(highs[1::2])
    return Stock(*rounded_out(x0, y0, x1, y1, units), bottom, 0)


def rounded_out(
    x0: float, y0: float, x1: float, y1: float, units: Units
) -> tuple[int, int, int, int]:
    """The box (nm) grown by MARGIN on every side and rounded outward to ROUND_TO: a stock
    sized from the reach of the cuts, in XY (the simulation's, and the drawing's outline)."""
    margin = to_nm(MARGIN[units], units)
    step = to_nm(ROUND_TO[units], units)

    def down(v: float) -> int:
        return math.floor((v - margin) / step) * step

    def up(v: float) -> int:
        return math.ceil((v + margin) / step) * step

    return down(x0), down(y0), up(x1), up(y1)


@dataclass(frozen=True)
class Grid:
    """The sampling grid over a stock: `nx` × `ny` cells of `resolution` nm."""

    stock: Stock
    resolution: float
    nx: int
    ny: int

    @property
    def x0(self) -> float:
        return float(self.stock.x0)

    @property
    def y0(self) -> float:
        return float(self.stock.y0)

    @property
    def cells(self) -> int:
        return self.nx * self.ny

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """The X (nx) and Y (ny) coordinates of the cell centres, nm."""
        res = self.resolution
        xs = self.x0 + (np.arange(self.nx) + 0.5) * res
        ys = self.y0 + (np.arange(self.ny) + 0.5) * res
        return xs, ys

    def cell_of(self, x: float, y: float) -> tuple[int, int] | None:
        """(row, column) of the cell holding point (x, y), or None outside the grid."""
        j = math.floor((x - self.x0) / self.resolution)
        i = math.floor((y - self.y0) / self.resolution)
        if 0 <= i < self.ny and 0 <= j < self.nx:
            return i, j
        return None


MAX_CELLS = 25_000_000


def make_grid(stock: Stock, resolution: int) -> Grid:
    """The grid of `resolution` nm cells covering `stock` (whole cells; the last row and
    column may reach past the stock by less than a cell). Raises StockError when the
    resolution is not positive or the grid would be unreasonably large."""
    if resolution <= 0:
        raise StockError("the resolution must be more than 0")
    if resolution > max(stock.x1 - stock.x0, stock.y1 - stock.y0):
        # One cell would hold the whole stock, and its size need not fit the grid's integers.
        raise StockError(
            "the resolution is larger than the stock; choose a cell smaller than its longer side"
        )
    nx = max(1, math.ceil((stock.x1 - stock.x0) / resolution))
    ny = max(1, math.ceil((stock.y1 - stock.y0) / resolution))
    if nx * ny > MAX_CELLS:
        raise StockError(
            f"{nx} × {ny} cells is more than the {MAX_CELLS:,} this simulation takes; "
            "choose a coarser resolution"
        )
    return Grid(stock, float(resolution), nx, ny)


def auto_resolution(stock: Stock, units: Units, cells_along: int = 800) -> int:
    """A resolution (nm) giving about `cells_along` cells along the stock's longer side,
    rounded up to 0.0005 in (0.01 mm) and never finer than that."""
    quantum = to_nm(Decimal("0.0005") if units is Units.INCH else Decimal("0.01"), units)
    longest = max(stock.x1 - stock.x0, stock.y1 - stock.y0)
    return max(quantum, math.ceil(longest / cells_along / quantum) * quantum)
