"""The tape drawn at full size like the manual's Fig. 1-4 (svgwrite): eight channels
(8 at the top), the feed-hole track, the punched title, each character named under its row.

Tape geometry in 0.01 in (EIA RS-227 / ECMA-10, 1-inch 8-track tape): tracks 0.1 in apart,
the feed-hole track between channels 3 and 4, code holes 0.072 in, feed holes 0.046 in.
A drawing shows at most `DRAWN_ROWS` rows (100 ft of tape; its text says how long the whole
tape is): the rows are drawn as they come, a few hundred at a time, so the drawing's memory
is bounded by what it shows.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import svgwrite

from app.cnc.formats.tape1704 import codes
from app.cnc.formats.tape1704.codes import TapeCode

PITCH = 10
TRACK_Y = {8: 10, 7: 20, 6: 30, 5: 40, 4: 50, 0: 60, 3: 70, 2: 80, 1: 90}  # 0: feed holes
DRAWN_ROWS = 100 * 12 * codes.ROWS_PER_INCH
_BATCH = 400  # rows drawn into one group at a time
_LEFT, _RIGHT, _TOP, _TAPE, _LEGEND = 40, 20, 45, 100, 30


def draw(
    pieces: Iterable[tuple[bytes, list[str]]],
    code: TapeCode,
    title: str,
    emit: Callable[[str], None],
) -> int:
    """Draw the tape whose rows and labels come in `pieces`; hand the SVG text to `emit`
    in pieces. Returns how many rows the tape has."""
    drawing = svgwrite.Drawing(debug=False)
    batches: list[str] = []
    rows: list[int] = []
    labels: list[str] = []
    total = 0

    def flush() -> None:
        if rows:
            batches.append(_batch(drawing, total - len(rows), rows, labels))
            rows.clear()
            labels.clear()

    for piece_rows, piece_labels in pieces:
        for row, label in zip(piece_rows, piece_labels, strict=True):
            if total < DRAWN_ROWS:
                rows.append(row)
                labels.append(label)
            total += 1
            if len(rows) == _BATCH:
                flush()
    flush()
    drawn = min(total, DRAWN_ROWS)
    emit('<?xml version="1.0" encoding="utf-8" ?>\n')
    head = _frame(drawn, total, code, title)
    emit(head[: -len("</svg>")])
    for batch in batches:
        emit(batch)
    emit("</svg>\n")
    return total


def _frame(drawn: int, total: int, code: TapeCode, title: str) -> str:
    """The drawing without its rows: title, legend, the tape, the channel names."""
    width = _LEFT + drawn * PITCH + _RIGHT
    height = _TOP + _TAPE + _LEGEND
    feet = total / codes.ROWS_PER_INCH / 12
    parity = "odd parity, EIA RS-244" if code is TapeCode.EIA else "even parity, ASCII"
    heading = title or "(no title)"
    info = (
        f"Tektronix 1704 tape, {code.value.upper()} ({parity}), {total} rows at "
        f"{codes.ROWS_PER_INCH} per inch, {feet:.1f} ft"
    )
    if drawn < total:
        info += f"; the first {drawn // codes.ROWS_PER_INCH // 12} ft drawn"
    d = svgwrite.Drawing(
        size=(f"{width / 100:.2f}in", f"{height / 100:.2f}in"),
        viewBox=f"0 0 {width} {height}",
        debug=False,
    )
    d.set_desc(title=heading)
    d.add(d.text(heading, insert=(_LEFT, 16), font_family="monospace", font_size=12))
    d.add(d.text(info, insert=(_LEFT, 32), font_family="monospace", font_size=8))
    d.add(
        d.rect(
            insert=(_LEFT, _TOP),
            size=(drawn * PITCH, _TAPE),
            fill="#f2e6c9",
            stroke="#8a7a5a",
            stroke_width=0.5,
        )
    )
    names = d.g(font_family="monospace", font_size=7, text_anchor="middle")
    for channel, offset in TRACK_Y.items():
        names.add(d.text(str(channel) if channel else "F", insert=(_LEFT - 10, _TOP + offset + 2)))
    d.add(names)
    text: str = d.tostring()
    return text


def _batch(d: svgwrite.Drawing, first: int, rows: list[int], labels: list[str]) -> str:
    """Rows `first`… of the tape: their feed holes, code holes and names, as SVG groups."""
    feed = d.g(fill="#6b6b6b")
    holes = d.g(fill="#1a1a1a")
    names = d.g(font_family="monospace", font_size=6)
    base = _TOP + _TAPE + 4
    for k, (row, label) in enumerate(zip(rows, labels, strict=True)):
        x = _LEFT + PITCH // 2 + (first + k) * PITCH
        feed.add(d.circle(center=(x, _TOP + TRACK_Y[0]), r=2.3))
        for channel in range(1, 9):
            if row & (1 << (channel - 1)):
                holes.add(d.circle(center=(x, _TOP + TRACK_Y[channel]), r=3.6))
        if label:
            names.add(d.text(label, transform=f"translate({x - 2} {base}) rotate(90)"))
    return "".join(str(group.tostring()) for group in (feed, holes, names))
