"""The one text rule: what a stored string may hold, and how long it may be.

Every entry that takes text — each web form field, query argument, file name and URL part
(one check before any route runs, app/web/__init__.py), the JSON program document's
strings (app.cnc.document), a backup being restored (app.storage.backup), what the library
stores or looks up (app.storage) and the command line (app/cli.py) — checks it here, so
they all refuse the same things:

- NUL (U+0000): PostgreSQL's text cannot hold it (the statement fails), and a C string,
  a log line or a control's tape ends at it;
- a lone surrogate (U+D800-U+DFFF): half of a UTF-16 pair, which JSON's `\\ud800` escape
  or a command line of bytes that are not UTF-8 can produce, but which no UTF-8 database
  or file can store;
- more characters than the field holds: `NAME_LENGTH` for a program's name,
  `SHORT_NAME_LENGTH` for a machine's or a user's, `NOTES_LENGTH` for notes,
  `SETTING_LENGTH` for each of a machine's settings (its serial port, options, limits).

A search is at most `SEARCH_WORDS` words of `SEARCH_WORD_LENGTH` characters (every word
is one more condition on every row).

Errors are `TextError` (a ValueError) whose message names the field, says what is wrong
and what is allowed. Pure: no Flask, database or serial code.
"""

from __future__ import annotations

import re

NAME_LENGTH = 200
"""Characters of a program's name (the library's column; a drawing's name too)."""

SHORT_NAME_LENGTH = 100
"""Characters of a machine's name, a user's name and an author (their columns)."""

NOTES_LENGTH = 4000
"""Characters of a program's or a machine's notes: a page of set-up notes."""

SETTING_LENGTH = 500
"""Characters of one of a machine's settings, its name or its value: the serial port (a
device path under /dev/serial/by-path/ or a network port's URL with a host name of up to
253 characters fits), an option of its target, a travel limit."""

SEARCH_WORDS = 10
"""Words in one library search."""

SEARCH_WORD_LENGTH = 100
"""Characters of one word of a search."""

ALLOWED = "any characters but NUL (U+0000) and lone surrogates (U+D800-U+DFFF)"

_REFUSED = re.compile("[\x00\ud800-\udfff]")


class TextError(ValueError):
    """Text that may not be stored; the message names the field and says what is allowed."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(f"{field}: {message}")
        self.field = field


def text_fault(text: str, limit: int | None = None) -> str:
    """What is wrong with `text` ("" when nothing): a NUL, a lone surrogate, or more than
    `limit` characters."""
    # Most text is plain ASCII: two scans in C instead of the pattern's.
    found = None if text.isascii() and "\x00" not in text else _REFUSED.search(text)
    if found is not None:
        char = found.group()
        what = "a NUL character" if char == "\x00" else "a lone surrogate"
        return (
            f"has {what} (U+{ord(char):04X}) at character {found.start() + 1}; allowed: {ALLOWED}"
        )
    if limit is not None and len(text) > limit:
        return f"{len(text):,} characters is too long; allowed: at most {limit:,}"
    return ""


def check_text(text: str, field: str, limit: int | None = None) -> str:
    """`text` if it may be stored in `field`; TextError naming `field` otherwise."""
    fault = text_fault(text, limit)
    if fault:
        raise TextError(field, fault)
    return text


def derived_name(name: str, suffix: str) -> str:
    """`name` + `suffix` ("Bracket (copy)"), the name cut short so that the whole is at
    most NAME_LENGTH characters: a copy of a program with the longest name can be stored."""
    return name[: max(0, NAME_LENGTH - len(suffix))] + suffix


def search_terms(query: str) -> list[str]:
    """The words of a library search (lower case), each a condition every match meets.

    Raises TextError for text that may not be stored (it is looked up in the database) and
    for more than SEARCH_WORDS words or a word of more than SEARCH_WORD_LENGTH characters.
    """
    check_text(query, "search")
    words = query.lower().split()
    if len(words) > SEARCH_WORDS:
        raise TextError(
            "search", f"{len(words):,} words is too many; allowed: at most {SEARCH_WORDS}"
        )
    for word in words:
        if len(word) > SEARCH_WORD_LENGTH:
            raise TextError(
                "search",
                f"a word of {len(word):,} characters is too long; allowed: at most "
                f"{SEARCH_WORD_LENGTH} characters a word",
            )
    return words
