"""Where the app's files are: templates, static files and migrations, and the instance folder.

In a checkout they sit beside `app/` (the layout the project was specified with:
`templates/`, `static/`, `migrations/` at the top). A built wheel maps them into the
package (`setup.py`: `app/templates`, `app/static`, `app/migrations`), so an installed
MillBlocks finds them through `importlib.resources` in site-packages. Standard library only:
the command line imports this at start-up.
"""

from __future__ import annotations

import os
import sys
from importlib import resources
from pathlib import Path

CHECKOUT = Path(__file__).resolve().parents[1]
"""The directory holding `app/` (a checkout's top level; site-packages when installed)."""

DATA = ("templates", "static", "migrations")
"""The top-level folders a wheel carries inside the package."""


def data_dir(name: str) -> Path:
    """The folder `name` (one of DATA): inside the installed package, else the checkout's."""
    if name not in DATA:
        raise ValueError(f"{name!r} is not one of the app's data folders {DATA}")
    packaged = Path(str(resources.files("app").joinpath(name)))
    return packaged if packaged.is_dir() else CHECKOUT / name


def installed() -> bool:
    """Whether this is an installed package (its data inside it), not a checkout."""
    return Path(str(resources.files("app").joinpath("templates"))).is_dir()


def instance_dir() -> Path:
    """The instance folder (the SQLite library, the secret key, uploaded drawings):
    MILLBLOCKS_INSTANCE_PATH when set; in a checkout its `instance/`; installed,
    `<prefix>/var/millblocks-instance` (Flask's convention for installed apps: beside the
    virtual environment, never inside site-packages)."""
    configured = os.environ.get("MILLBLOCKS_INSTANCE_PATH")
    if configured:
        return Path(configured).expanduser().resolve()
    if installed():
        return Path(sys.prefix) / "var" / "millblocks-instance"
    return CHECKOUT / "instance"
