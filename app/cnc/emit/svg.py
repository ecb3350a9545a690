"""The tool path as an SVG drawing (svgwrite): the web preview and the `svg` export.

Seen from above in part coordinates (part zero marked), Y up. Rapids, feeds, plunges and
holes have their own classes (`rapid`, `feed`, `plunge`, `hole`) so a stylesheet can
restyle them; arcs stay arcs. Every drawn element sits in a `<g class="block"
data-block="N">` so the editor can link drawing and block. A LOOP/REP pattern is drawn
once as a `<symbol>` and placed with `<use>` for each repetition that is really the first
moved by its offset (checked move by move); nested LOOPs nest symbols, so the drawing grows
with NX + NY, not NX × NY.

Options: `swept` draws the width the tool sweeps along feed moves; `grid` draws a grid of
1 in (10 mm) squares. Output is deterministic: fixed decimals, no ids but the pattern
symbols' `p<block>-<n>`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import svgwrite

from app.cnc.blocks import Program
from app.cnc.emit.target import Option, OptionKind, Report, Target, register
from app.cnc.toolpath import ArcFeed, Dwell, Feed, Rapid, Repetition, ToolChange, Toolpath
from app.cnc.units import Units

STYLE = """
path:not(.swept), circle, line {{ fill: none; stroke-width: {w}; }}
path.swept {{ fill: none; }}
path.rapid {{ stroke: #8a8a8a; stroke-dasharray: {dash} {gap}; }}
path.feed {{ stroke: #0b5fbf; stroke-width: {wide}; }}
path.swept {{ stroke: #9cc3f0; stroke-linecap: round; stroke-linejoin: round; opacity: .45; }}
circle.plunge {{ stroke: #c2410c; }}
circle.hole {{ stroke: #15803d; fill: #bbf7d0; fill-opacity: .5; }}
g.zero line {{ stroke: #b91c1c; }}
g.grid line {{ stroke: #e5e7eb; stroke-width: {thin}; }}
"""


@register
class SvgTarget(Target):
    name = "svg"
    label = "Tool path picture (SVG)"
    description = "tool path drawing (SVG), as the web preview shows it"
    extension = "svg"
    media_type = "image/svg+xml"
    options = (
        Option("swept", OptionKind.BOOL, False, "draw the width the tool sweeps when feeding"),
        Option("grid", OptionKind.BOOL, False, "draw a 1 in / 10 mm grid"),
    )

    def emit(
        self, program: Program, toolpath: Toolpath, options: Mapping[str, Any], report: Report
    ) -> bytes:
        return draw(toolpath, swept=bool(options["swept"]), grid=bool(options["grid"])).encode(
            "utf-8"
        )


def draw(
    toolpath: Toolpath, swept: bool = False, grid: bool = False, embedded_style: bool = True
) -> str:
    """The SVG text of a tool path (see the module docstring).

    `embedded_style` False leaves the `<style>` out, for a page whose own stylesheet
    styles the classes (a Content-Security-Policy without inline styles forbids it there).
    """
    return _Drawing(toolpath, swept, grid, embedded_style).render()


@dataclass(frozen=True, slots=True)
class _Prim:
    """One drawn thing: a rapid/feed segment (line or arc), a hole, or a plunge mark.

    `move` is the index of the move it comes from; points are XY in nm.
    """

    move: int
    block: int
    kind: str  # rapid, feed, hole, plunge
    start: tuple[int, int]
    end: tuple[int, int]
    arc: tuple[int, int, bool] | None = None  # centre x, centre y, clockwise
    size: int = 0  # hole diameter, or the tool diameter for a swept feed

    def moved(self, dx: int, dy: int) -> _Prim:
        arc = None if self.arc is None else (self.arc[0] + dx, self.arc[1] + dy, self.arc[2])
        return _Prim(
            self.move,
            self.block,
            self.kind,
            (self.start[0] + dx, self.start[1] + dy),
            (self.end[0] + dx, self.end[1] + dy),
            arc,
            self.size,
        )

    def same_shape(self, other: _Prim, dx: int, dy: int) -> bool:
        """True when `other` is this primitive moved by (dx, dy)."""
        moved = self.moved(dx, dy)
        return (moved.block, moved.kind, moved.start, moved.end, moved.arc, moved.size) == (
            other.block,
            other.kind,
            other.start,
            other.end,
            other.arc,
            other.size,
        )


class _Drawing:
    def __init__(self, toolpath: Toolpath, swept: bool, grid: bool, embedded_style: bool) -> None:
        self.tp = toolpath
        self.embedded_style = embedded_style
        self.unit = toolpath.units.nm
        self.places = toolpath.units.dump_places
        self.swept = swept
        self.grid = grid
        self.prims = self.primitives()
        self.runs = _runs(toolpath.repetitions)

    def primitives(self) -> list[_Prim]:
        prims: list[_Prim] = []
        x, y, z = self.tp.start
        tool = self.tp.initial_tool
        for i, move in enumerate(self.tp.moves):
            if isinstance(move, ToolChange):
                tool, z = move.tool, move.z
                continue
            info = self.tp.tools.get(tool)
            diameter = info.diameter if info is not None and info.diameter else 0
            if isinstance(move, Dwell):
                prims.append(_Prim(i, move.block, "hole", (x, y), (x, y), size=diameter))
                continue
            if not isinstance(move, Rapid | Feed | ArcFeed):
                continue
            if (move.x, move.y) == (x, y) and not isinstance(move, ArcFeed):
                if isinstance(move, Feed) and move.z < z:
                    prims.append(_Prim(i, move.block, "plunge", (x, y), (x, y)))
            else:
                kind = "rapid" if isinstance(move, Rapid) else "feed"
                arc = (move.cx, move.cy, move.clockwise) if isinstance(move, ArcFeed) else None
                size = diameter if kind == "feed" else 0
                prims.append(_Prim(i, move.block, kind, (x, y), (move.x, move.y), arc, size))
            x, y, z = move.x, move.y, move.z
        return prims

    # -- numbers ----------------------------------------------------------------------------

    def n(self, nm: float) -> str:
        text = f"{nm / self.unit:.{self.places}f}".rstrip("0").rstrip(".")
        return "0" if text in ("-0", "") else text

    # -- the document ------------------------------------------------------------------------

    def render(self) -> str:
        x0, y0, x1, y1 = self.extent()
        pad = max((x1 - x0), (y1 - y0), self.unit // 4) * 0.05
        x0, y0, x1, y1 = x0 - pad, y0 - pad, x1 + pad, y1 + pad
        width, height = x1 - x0, y1 - y0
        drawing = svgwrite.Drawing(
            size=("100%", "100%"),
            viewBox=f"{self.n(x0)} {self.n(-y1)} {self.n(width)} {self.n(height)}",
            debug=False,
            profile="full",
        )
        drawing.attribs["class"] = "mb-path"
        drawing.attribs["data-units"] = self.tp.units.value
        # Line widths in drawing units, a fixed fraction of its size, so the drawing reads
        # the same in any viewer and at any part size.
        w = max(width, height) / 700
        if self.embedded_style:
            drawing.defs.add(
                drawing.style(
                    STYLE.format(
                        w=self.n(w),
                        wide=self.n(1.8 * w),
                        thin=self.n(0.5 * w),
                        dash=self.n(4 * w),
                        gap=self.n(3 * w),
                    )
                )
            )
        page = drawing.g(transform="scale(1,-1)")
        if self.grid:
            page.add(self.grid_lines(drawing, x0, y0, x1, y1))
        mark = self.unit * (0.1 if self.tp.units is Units.INCH else 2.5)
        zero = drawing.g(class_="zero")
        zero.add(drawing.line((self.n(-mark), 0), (self.n(mark), 0)))
        zero.add(drawing.line((0, self.n(-mark)), (0, self.n(mark))))
        page.add(zero)
        self.draw_range(drawing, page, 0, len(self.prims), 0)
        drawing.add(page)
        return str(drawing.tostring()) + "\n"

    def extent(self) -> tuple[float, float, float, float]:
        xs = [float(self.tp.start[0]), 0.0]
        ys = [float(self.tp.start[1]), 0.0]
        for p in self.prims:
            xs += [p.start[0], p.end[0]]
            ys += [p.start[1], p.end[1]]
            if p.arc is not None:
                radius = math.hypot(p.start[0] - p.arc[0], p.start[1] - p.arc[1])
                xs += [p.arc[0] - radius, p.arc[0] + radius]
                ys += [p.arc[1] - radius, p.arc[1] + radius]
        return min(xs), min(ys), max(xs), max(ys)

    def grid_lines(
        self, drawing: svgwrite.Drawing, x0: float, y0: float, x1: float, y1: float
    ) -> Any:
        step = self.unit * (1 if self.tp.units is Units.INCH else 10)
        group = drawing.g(class_="grid")
        for k in range(math.floor(x0 / step), math.ceil(x1 / step) + 1):
            group.add(drawing.line((self.n(k * step), self.n(y0)), (self.n(k * step), self.n(y1))))
        for k in range(math.floor(y0 / step), math.ceil(y1 / step) + 1):
            group.add(drawing.line((self.n(x0), self.n(k * step)), (self.n(x1), self.n(k * step))))
        return group

    # -- patterns ---------------------------------------------------------------------------

    def run_at(self, move: int, depth: int) -> list[Repetition] | None:
        """The LOOP run at `depth` whose moves include move index `move`."""
        for (first, run_depth), run in self.runs.items():
            if run_depth == depth and first <= move < run[-1].end:
                return run
        return None

    def draw_range(
        self, drawing: svgwrite.Drawing, parent: Any, lo: int, hi: int, depth: int
    ) -> None:
        """Draw prims[lo:hi], drawing each LOOP run at `depth + 1` once as a symbol."""
        i = lo
        pending: list[_Prim] = []
        while i < hi:
            run = self.run_at(self.prims[i].move, depth + 1)
            if run is None:
                pending.append(self.prims[i])
                i += 1
                continue
            self.flush(drawing, parent, pending)
            pending = []
            end = i
            while end < hi and self.prims[end].move < run[-1].end:
                end += 1
            self.draw_run(drawing, parent, run, i, end, depth + 1)
            i = end
        self.flush(drawing, parent, pending)

    def draw_run(
        self,
        drawing: svgwrite.Drawing,
        parent: Any,
        run: list[Repetition],
        lo: int,
        hi: int,
        depth: int,
    ) -> None:
        """One LOOP run: the first pattern as a symbol, the others as `<use>` where equal.

        Each pattern begins with the moves that bring the tool from where the last one
        ended; those are drawn as they are. The first pattern's entry is its first
        segment (if it starts with one); a later pattern's entry ends where its drawing
        starts to match the first pattern's body moved by the pattern's offset.
        """
        groups: list[tuple[Repetition, int, int]] = []
        k = lo
        for rep in run:
            start = k
            while k < hi and self.prims[k].move < rep.end:
                k += 1
            groups.append((rep, start, k))
        first, f_lo, f_hi = groups[0]
        entry = f_lo + 1 if f_lo < f_hi and self.prims[f_lo].kind in ("rapid", "feed") else f_lo
        self.flush(drawing, parent, self.prims[f_lo:entry])
        symbol_id = f"p{first.rep_block}-{first.start}"
        symbol = drawing.symbol(id=symbol_id)
        symbol.attribs["overflow"] = "visible"
        self.draw_range(drawing, symbol, entry, f_hi, depth)
        drawing.defs.add(symbol)
        parent.add(drawing.use(f"#{symbol_id}"))
        body = self.prims[entry:f_hi]
        for rep, r_lo, r_hi in groups[1:]:
            dx = rep.offset[0] - first.offset[0]
            dy = rep.offset[1] - first.offset[1]
            # This pattern's entry ends where the first pattern's body begins, moved.
            r_entry = r_lo
            while body and r_entry < r_hi and not body[0].same_shape(self.prims[r_entry], dx, dy):
                r_entry += 1
            other = self.prims[r_entry:r_hi]
            if len(other) == len(body) and all(
                a.same_shape(b, dx, dy) for a, b in zip(body, other, strict=True)
            ):
                self.flush(drawing, parent, self.prims[r_lo:r_entry])
                parent.add(drawing.use(f"#{symbol_id}", insert=(self.n(dx), self.n(dy))))
            else:
                self.draw_range(drawing, parent, r_lo, r_hi, depth)

    # -- primitives -------------------------------------------------------------------------

    def flush(self, drawing: svgwrite.Drawing, parent: Any, prims: list[_Prim]) -> None:
        """Draw primitives, grouped by block, joining neighbours of one kind in one path."""
        group: Any = None
        block: int | None = None
        path: list[str] = []
        kind = ""
        size = 0
        at: tuple[int, int] | None = None

        def close() -> None:
            nonlocal path, kind
            if path:
                group.add(drawing.path(d=" ".join(path), class_=kind))
                if kind == "feed" and self.swept and size:
                    sweep = drawing.path(d=" ".join(path), class_="swept")
                    # A presentation attribute, not a style: a page's Content-Security-
                    # Policy may forbid inline styles.
                    sweep.attribs["stroke-width"] = self.n(size)
                    group.add(sweep)
            path, kind = [], ""

        for p in prims:
            if p.block != block:
                close()
                block = p.block
                group = drawing.g(class_="block")
                group.attribs["data-block"] = str(block)
                parent.add(group)
            if p.kind == "hole":
                close()
                r = self.n(max(p.size / 2, self.unit * 0.01))
                group.add(
                    drawing.circle(
                        center=(self.n(p.start[0]), self.n(p.start[1])), r=r, class_="hole"
                    )
                )
                continue
            if p.kind == "plunge":
                close()
                r = self.n(self.unit * (0.02 if self.tp.units is Units.INCH else 0.5))
                group.add(
                    drawing.circle(
                        center=(self.n(p.start[0]), self.n(p.start[1])), r=r, class_="plunge"
                    )
                )
                continue
            if p.kind != kind or p.start != at or p.size != size:
                close()
                kind, size = p.kind, p.size
                path = [f"M{self.n(p.start[0])} {self.n(p.start[1])}"]
            path.append(self.segment(p))
            at = p.end
        close()

    def segment(self, p: _Prim) -> str:
        if p.arc is None:
            return f"L{self.n(p.end[0])} {self.n(p.end[1])}"
        cx, cy, clockwise = p.arc
        radius = math.hypot(p.start[0] - cx, p.start[1] - cy)
        r = self.n(radius)
        # Y is flipped by the page transform, so SVG's sweep flag 1 (positive angle) is
        # counter-clockwise as seen from above.
        sweep = "0" if clockwise else "1"
        if p.end == p.start:
            # A full circle: two half circles through the opposite point.
            ox, oy = 2 * cx - p.start[0], 2 * cy - p.start[1]
            return (
                f"A{r} {r} 0 0 {sweep} {self.n(ox)} {self.n(oy)} "
                f"A{r} {r} 0 0 {sweep} {self.n(p.end[0])} {self.n(p.end[1])}"
            )
        a0 = math.atan2(p.start[1] - cy, p.start[0] - cx)
        a1 = math.atan2(p.end[1] - cy, p.end[0] - cx)
        turn = ((a0 - a1) if clockwise else (a1 - a0)) % (2 * math.pi)
        large = "1" if turn > math.pi else "0"
        return f"A{r} {r} 0 {large} {sweep} {self.n(p.end[0])} {self.n(p.end[1])}"


def _runs(repetitions: list[Repetition]) -> dict[tuple[int, int], list[Repetition]]:
    """LOOP runs keyed by (first move index, depth): the repetitions of one LOOP, in order."""
    runs: dict[tuple[int, int], list[Repetition]] = {}
    current: list[Repetition] = []
    for rep in sorted(repetitions, key=lambda r: (r.depth, r.start)):
        if current and rep.number == 0:
            runs[(current[0].start, current[0].depth)] = current
            current = []
        current.append(rep)
    if current:
        runs[(current[0].start, current[0].depth)] = current
    return runs
