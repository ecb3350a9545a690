"""Import formats: one registry, as the export targets have (app.cnc.formats.targets).

An `Importer` says what it reads (`name`, `label`, `description`, its `options`), how sure
it is that some content is its format (`sniff`), and reads it (`read`). A format package
(app.cnc.formats) registers its importer with `@register_importer` when imported;
`importers()` imports them all once. Detection asks every importer and takes the surest
answer; where two formats are equally likely, it refuses and asks for the format.
"""

from __future__ import annotations

import enum
import re
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, BinaryIO, ClassVar

from app.cnc.blocks import Program
from app.cnc.options import Option
from app.cnc.recognition.common import ImportFailure, ImportNote, text_of

_COMMENT = re.compile(r"\([^)]*\)?")
PLAIN_PART = 1 << 18  # characters of text blanked at a time (Content.plain)


def _after_break(text: str, start: int) -> int:
    """The index after the first line feed at or after `start`, or the text's length."""
    found = text.find("\n", start)
    return len(text) if found < 0 else found + 1


class Strength(enum.IntEnum):
    """How sure a sniff is, weakest first."""

    POSSIBLE = 1  # the content reads as this format and as others alike
    EVIDENCE = 2  # something in it only this format has (among those it could be)
    CONTENT = 3  # its content is of this format's kind (punch rows, events words)
    SIGNATURE = 4  # it opens with this format's own mark (a DXF sentinel, `{`)


@dataclass(frozen=True)
class Sniff:
    """An importer's answer to "is this yours?": how sure, and why (shown in a refusal)."""

    strength: Strength
    reason: str = ""


@dataclass
class Content:
    """A file's bytes as the sniffs look at them (text decoded once; derived views kept)."""

    data: bytes
    _memo: dict[str, Any] = field(default_factory=dict)

    @cached_property
    def text(self) -> str | None:
        """The content as text, or None when it is not text (NULs, control characters)."""
        text = text_of(self.data)
        return None if text is None else text.lstrip("\ufeff")

    def plain(self) -> Iterator[str]:
        """The text with parenthesised comments blanked (nothing when not text), in parts
        of about PLAIN_PART characters, each ending after a line break outside comments:
        joined, they are the whole text blanked, without a copy of it all (a sniff looks
        at one part at a time)."""
        text = self.text
        if text is None:
            return
        start, n = 0, len(text)
        while start < n:
            end = _after_break(text, start + PLAIN_PART)
            # A comment still open at the part's end goes on to its ")" (or the text's
            # end), as one blanking of the whole text reads it.
            while end < n and text.rfind("(", start, end) > text.rfind(")", start, end):
                close = text.find(")", end)
                end = n if close < 0 else _after_break(text, close)
            yield _COMMENT.sub(" ", text[start:end])
            start = end

    def plain_head(self, breaks: int) -> str:
        """The blanked text up to its `breaks`-th line break (CR or LF, each counted) or
        its end."""
        head: list[str] = []
        seen = 0
        for part in self.plain():
            head.append(part)
            seen += part.count("\n") + part.count("\r")
            if seen >= breaks:
                break
        return "".join(head)

    def memo(self, key: str, make: Callable[[], Any]) -> Any:
        """`make()` once per content (a view several sniffs share)."""
        if key not in self._memo:
            self._memo[key] = make()
        return self._memo[key]


class Importer(ABC):
    """An import format. Subclasses set the class attributes and implement both methods."""

    name: ClassVar[str]
    # How a sentence names the format ("a 1704 tape", "G-code").
    label: ClassVar[str]
    # How a menu lists it ("a Tektronix 1704 tape (listing or punch image)").
    description: ClassVar[str]
    # Place in lists (lower first).
    rank: ClassVar[int]
    # Reader options; values are read (and refused, naming the option) by `read`.
    options: ClassVar[tuple[Option, ...]] = ()
    # Whether a control sends it over a serial line (the transfers page offers it).
    from_machines: ClassVar[bool] = True

    @abstractmethod
    def sniff(self, content: Content) -> Sniff | None:
        """How sure this format is of `content`, or None when it cannot be this format."""

    @abstractmethod
    def read(
        self, data: bytes, name: str, options: Mapping[str, str]
    ) -> tuple[Program, list[ImportNote]]:
        """The program in `data` and its report. `name` names a program whose file gives no
        name. Raises ImportFailure naming line and column (or tape block and row)."""

    def read_file(
        self, file: BinaryIO, name: str, options: Mapping[str, str]
    ) -> tuple[Program, list[ImportNote]]:
        """`read` of the bytes of `file` (open, binary, at its start, seekable). A format
        that can read a long file a part at a time does so here (the G-code importer);
        the others read its bytes whole."""
        return self.read(file.read(), name, options)


_IMPORTERS: dict[str, Importer] = {}


def register_importer(cls: type[Importer]) -> type[Importer]:
    """Class decorator: make an import format available by its name."""
    if cls.name in _IMPORTERS:
        raise ValueError(f"two import formats named {cls.name}")
    _IMPORTERS[cls.name] = cls()
    return cls


def importers() -> dict[str, Importer]:
    """Every import format by name, in list order (`rank`)."""
    from app.cnc.formats import load_formats

    load_formats()
    return dict(sorted(_IMPORTERS.items(), key=lambda item: (item[1].rank, item[0])))


def get_importer(name: str) -> Importer:
    """The import format called `name`. Raises ImportFailure naming the formats there are."""
    found = importers().get(name)
    if found is None:
        raise ImportFailure("", f"no import format {name!r}; formats: {', '.join(importers())}")
    return found


def detect(data: bytes) -> Importer:
    """The import format of `data`, from its content: the surest sniff. Raises
    ImportFailure when the content is empty, or equally likely to be several formats (it
    names them and their evidence, and asks for the format)."""
    if not data.strip():
        raise ImportFailure("", "the file is empty")
    content = Content(data)
    answers = [
        (importer, sniff)
        for importer in importers().values()
        if (sniff := importer.sniff(content)) is not None
    ]
    if not answers:
        names = ", ".join(importers())
        raise ImportFailure("", f"no import format reads this; give the format ({names})")
    best = max(sniff.strength for _, sniff in answers)
    found = [(importer, sniff) for importer, sniff in answers if sniff.strength == best]
    if len(found) == 1:
        return found[0][0]
    found.sort(key=lambda pair: pair[0].label.lower())
    names = " or ".join(importer.name for importer, _ in found)
    if best is Strength.POSSIBLE:
        labels = " or ".join(importer.label for importer, _ in found)
        reasons = "; ".join(dict.fromkeys(sniff.reason for _, sniff in found if sniff.reason))
        because = f" ({reasons})" if reasons else ""
        raise ImportFailure(
            "",
            f"this could be {labels}: nothing in it is only one of them{because}; give the "
            f"format ({names})",
        )
    labels = " or ".join(f"{importer.label} ({sniff.reason})" for importer, sniff in found)
    raise ImportFailure("", f"this could be {labels}; give the format ({names})")
