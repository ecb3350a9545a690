"""The places a recurring report line applies to, kept in bounded memory.

A long file repeats itself: a CAM program's bolt-circle grid is one import note per
circle (28 606 of them in a 10^6-line file), a helical ramp one tape warning per chord. The
import report (app.cnc.recognition.common.Notes) and the export's compatibility report
(app.cnc.formats.targets.Report) keep such a line once, with `Places`: how many places
exactly, and the first few after the first by name (`PLACES` of them), as
`lines 47, 83 … and 2 766 more` says them. Pure core, standard library only.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Final, Generic, TypeVar

# How many places after the first a recurring line names (the count stays exact).
PLACES: Final = 8

T = TypeVar("T")


@dataclass
class Places(Generic[T]):
    """A recurring line's places as they are reported: `count` reports in all, the first
    place, the next distinct ones by name (at most PLACES: `named`) and how many further
    distinct places are not named (`more`). A place equal to the first or to the one
    named last is counted, not named again (a note on each hole of one line)."""

    first: T
    count: int = 1
    named: list[T] = field(default_factory=list)
    more: int = 0
    last: T | None = None

    def add(self, place: T) -> None:
        """One more report of the line, at `place`."""
        self.count += 1
        self.name(place)

    def name(self, place: T) -> None:
        if (
            place is None
            or place == self.first
            or place == (self.first if self.last is None else self.last)
        ):
            return
        self.last = place
        if len(self.named) < PLACES:
            self.named.append(place)
        else:
            self.more += 1

    def join(self, other: Places[T]) -> None:
        """`other`'s reports after these, as if each had been made here (what `other` did
        not name is counted in `more`)."""
        for place in (other.first, *other.named):
            self.name(place)
        self.count += other.count
        self.more += other.more
        if other.last is not None:
            self.last = other.last

    def copy(self) -> Places[T]:
        return Places(self.first, self.count, self.named[:], self.more, self.last)


def more_text(more: int) -> str:
    """` and N more` for places not named, else ""."""
    return f" and {more} more" if more else ""
