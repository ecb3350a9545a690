"""The tape image: how a 1704 tape's blocks are laid out on tape (seed 000 §1, §2).

Leader (blank tape, with the title punched as letters after the first 2 in when `ident`),
the rewind stop and an End of Block, the header comment blocks, one block per line (a blank
stretch after a tool change's block when asked), then trailer. A listing is the same as
text: `%` for the rewind stop, one block per line. Both are made line by line from the
blocks as they come, and `rows` counts the tape's length as they pass.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass

from app.cnc.formats.tape1704 import codes
from app.cnc.formats.tape1704.codes import TapeCode
from app.cnc.formats.tape1704.words import Line, LineRun


@dataclass
class TapeImage:
    """What surrounds a tape's blocks: its code, title, header comments, leader and
    trailer (rows), and whether the title is punched in the leader."""

    code: TapeCode
    title: str
    header: list[str]
    leader_rows: int
    trailer_rows: int
    ident: bool

    def leader(self) -> bytes:
        """Blank tape, with the title punched as letters after the first 2 in when `ident`."""
        title = codes.title_rows(self.title) if self.ident and self.title else b""
        if not title:
            return bytes(self.leader_rows)
        margin = 2 * codes.ROWS_PER_INCH
        after = max(margin, self.leader_rows - margin - len(title))
        return bytes(margin) + title + bytes(after)

    def fixed_rows(self) -> int:
        """The rows of the tape that are not its blocks: leader, rewind stop and its End of
        Block, header comments, trailer (a block takes `len(text) + 1 + leader_after`)."""
        header = sum(len(text) + 1 for text in self.header)
        return len(self.leader()) + 2 + header + self.trailer_rows

    def listing(self, lines: Iterable[Line | LineRun]) -> Iterator[list[str]]:
        """The listing, a few lines at a time: rewind stop, header comments, one block per
        line."""
        yield [codes.REWIND_STOP_CHAR, *self.header]
        for line in lines:
            yield line.texts if isinstance(line, LineRun) else [line.text]

    def punched(self, lines: Iterable[Line | LineRun]) -> Iterator[tuple[bytes, list[str]]]:
        """The punch image in pieces (one row per byte, channel n in bit n-1), each with
        what its rows are (`` for blank tape): the leader, each block with its End of
        Block, the trailer."""
        leader = self.leader()
        yield leader, [""] * len(leader)
        names = {
            codes.EOB_CHAR: "EOB",
            "\t": "TAB",
            " ": "SP",
            codes.REWIND_STOP_CHAR: "ER" if self.code is TapeCode.EIA else "%",
        }

        def piece(text: str, blank_after: int = 0) -> tuple[bytes, list[str]]:
            rows = codes.encode(text, self.code) + bytes(blank_after)
            labels = [names.get(ch, ch) for ch in text] + [""] * blank_after
            return rows, labels

        yield piece(codes.REWIND_STOP_CHAR + codes.EOB_CHAR)
        for text in self.header:
            yield piece(text + codes.EOB_CHAR)
        for line in lines:
            if isinstance(line, LineRun):
                for text in line.texts:
                    yield piece(text + codes.EOB_CHAR)
            else:
                yield piece(line.text + codes.EOB_CHAR, line.leader_after)
        yield bytes(self.trailer_rows), [""] * self.trailer_rows
