"""Downloads: the Content-Disposition header for a file name in any script (RFC 6266)."""

from __future__ import annotations

import unicodedata
from urllib.parse import quote


def file_name(name: str, extension: str, default: str) -> str:
    """The file a program named `name` downloads as: letters (of any script), digits, `-`
    and `_` kept, anything else `-` (`Деталь 5` → `Деталь-5.stl`); `default` for a name
    with nothing left."""
    stem = "".join(c if c.isalnum() or c in "-_" else "-" for c in name) or default
    return f"{stem}.{extension}"


def attachment(filename: str) -> str:
    """`attachment; filename="…"; filename*=UTF-8''…` for `filename`.

    HTTP headers are latin-1, so a program named `Деталь 5` cannot go into `filename`
    as it is: that parameter gets an ASCII stand-in (accents dropped, anything else `_`)
    for old clients, and `filename*` the real name, percent-encoded UTF-8 (RFC 5987), which
    every current browser prefers. Quotes, backslashes and control characters never reach
    the header, so a name cannot add parameters of its own.
    """
    name = "".join(c for c in filename if c.isprintable() and c not in '"\\/') or "download"
    folded = unicodedata.normalize("NFKD", name).encode("ascii", "ignore").decode()
    fallback = "".join(c if c.isalnum() or c in "-_." else "_" for c in folded)
    stem, dot, extension = fallback.rpartition(".")
    if dot and not stem.strip("_-."):
        fallback = f"download.{extension}"
    elif not fallback.strip("_-."):
        fallback = "download"
    return f"attachment; filename=\"{fallback}\"; filename*=UTF-8''{quote(name, safe='')}"
