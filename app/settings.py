"""A MillBlocks server's settings: each one a `MILLBLOCKS_*` environment variable.

The web app loads them with Flask's `app.config.from_prefixed_env("MILLBLOCKS")`
(`MILLBLOCKS_SESSION_HOURS` becomes the config key `SESSION_HOURS`), the command line with
the same call on a Config of its own (`environment()`); `apply()` then reads every setting of
`SETTINGS` into its value, or refuses it with a `SettingError` naming the variable, the value
and what is allowed. docs/deploy.md's table lists `SETTINGS` (tests/test_settings.py compares
the two). The instance folder is read by `app.resources.instance_dir()`, because Flask needs
it before any configuration exists.

Times: the library stores UTC; `shown()` writes one in the shop's zone (`TIME_ZONE`) with the
zone's abbreviation, so no time is ever shown without saying which clock it is.

Standard library only (the command line imports this at start).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Mapping, MutableMapping
from dataclasses import dataclass
from datetime import UTC, datetime, tzinfo
from pathlib import Path
from typing import Any
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

from app.cnc.numbers import NumberError, parse_decimal, parse_int
from app.cnc.sizes import MAX_IMPORT_BYTES, MAX_IMPORT_LINES

PREFIX = "MILLBLOCKS"

log = logging.getLogger("millblocks")


class SettingError(ValueError):
    """A setting whose value cannot be used; the message names the variable."""


@dataclass(frozen=True)
class Setting:
    """One setting: config `key`, read from `MILLBLOCKS_<key>`."""

    key: str
    default_text: str
    """The default as the docs table states it."""
    read: Callable[[Any], Any]
    """The value from what the environment (text) or a caller (a value) gave, None when
    unset; raises ValueError saying what is wrong and what is allowed."""
    meaning: str

    @property
    def variable(self) -> str:
        return f"{PREFIX}_{self.key}"


def _text(default: str | None) -> Callable[[Any], Any]:
    def read(raw: Any) -> str | None:
        return default if raw is None or raw == "" else str(raw)

    return read


SECRET_KEY_LEAST = 32
"""The shortest secret key taken (characters): `token_hex(32)` gives 64, and a short key
is one an attacker can guess to forge a session cookie."""


def _secret_key(raw: Any) -> str | None:
    if raw is None or raw == "":
        return None
    key = str(raw)
    if len(key) < SECRET_KEY_LEAST:
        raise ValueError(
            f"the key has {len(key)} characters, fewer than {SECRET_KEY_LEAST} (a short key "
            "can be guessed); give 64 hex digits: "
            "`python3 -c 'import secrets; print(secrets.token_hex(32))'`, or leave it unset "
            "for a key made once in the instance folder"
        )
    return key


def _whole(default: int, minimum: int) -> Callable[[Any], int]:
    def read(raw: Any) -> int:
        if raw is None or raw == "":
            return default
        if isinstance(raw, bool) or not isinstance(raw, int | str):
            raise ValueError(f"{raw!r} is not a whole number")
        try:
            value = raw if isinstance(raw, int) else parse_int(raw)
        except NumberError:
            raise ValueError(f"{raw!r} is not a whole number (digits 0-9, such as 12)") from None
        if value < minimum:
            raise ValueError(f"{value} is below {minimum}")
        return value

    return read


def _positive(default: float) -> Callable[[Any], float]:
    def read(raw: Any) -> float:
        if raw is None or raw == "":
            return default
        try:
            value = float(raw if isinstance(raw, int | float) else parse_decimal(str(raw)))
        except NumberError:
            raise ValueError(f"{raw!r} is not a number (such as 30 or 0.5)") from None
        if not value > 0:
            raise ValueError(f"{raw} is not above 0")
        return value

    return read


def _flag(default: bool) -> Callable[[Any], bool]:
    def read(raw: Any) -> bool:
        if raw is None or raw == "":
            return default
        if isinstance(raw, bool | int) and raw in (0, 1):
            return bool(raw)
        if str(raw).strip().lower() in ("1", "true", "yes", "on"):
            return True
        if str(raw).strip().lower() in ("0", "false", "no", "off"):
            return False
        raise ValueError(f"{raw!r} is not 0 or 1 (or true/false, yes/no, on/off)")

    return read


def _choice(default: str, *allowed: str) -> Callable[[Any], str]:
    def read(raw: Any) -> str:
        if raw is None or raw == "":
            return default
        if raw not in allowed:
            raise ValueError(f"{raw!r} is not one of {', '.join(allowed)}")
        return str(raw)

    return read


def _zone(raw: Any) -> tzinfo:
    if isinstance(raw, tzinfo):
        return raw
    if raw is None or raw == "":
        return server_zone()
    try:
        return ZoneInfo(str(raw))
    except (ZoneInfoNotFoundError, ValueError):
        raise ValueError(
            f"{raw!r} is not a time zone (an IANA name such as Europe/Berlin, "
            "America/Chicago or UTC; `timedatectl list-timezones` lists them)"
        ) from None


def server_zone() -> tzinfo:
    """The server's own time zone, as `date` shows it: TZ, else /etc/localtime, else UTC."""
    named = os.environ.get("TZ", "").lstrip(":")
    if named:
        try:
            return ZoneInfo(named)
        except (ZoneInfoNotFoundError, ValueError):
            pass
    local = Path("/etc/localtime")
    try:
        target = str(local.resolve())
        if "/zoneinfo/" in target:
            return ZoneInfo(target.split("/zoneinfo/", 1)[1])
        with local.open("rb") as data:
            return ZoneInfo.from_file(data, key="localtime")
    except (OSError, ZoneInfoNotFoundError, ValueError):
        return UTC


SETTINGS: tuple[Setting, ...] = (
    Setting(
        "DATABASE_URL",
        "SQLite `millblocks.db` in the instance folder",
        _text(None),
        "The library's database, e.g. `postgresql+psycopg://millblocks@/millblocks` "
        "(a local socket); `DATABASE_URL` is read too when this is unset.",
    ),
    Setting(
        "INSTANCE_PATH",
        "`instance/` in a checkout; installed, `var/millblocks-instance` in the environment",
        _text(None),
        "The folder of the SQLite library, the generated secret key and uploaded drawings.",
    ),
    Setting(
        "SECRET_KEY",
        "made once, kept in `secret_key` in the instance folder",
        _secret_key,
        "Signs the session cookies. Give every server of one shop the same key (64 hex "
        "digits: `python3 -c 'import secrets; print(secrets.token_hex(32))'`; fewer than "
        "32 characters is refused) so a login on one is good on all; a new key logs "
        "everyone out.",
    ),
    Setting(
        "AUTH",
        "`local`",
        _choice("local", "local", "accounts"),
        "`local`: one user, on 127.0.0.1 only; `accounts`: everyone logs in (a shop server).",
    ),
    Setting("USER", "`local`", _text("local"), "The local user's name in `local` mode."),
    Setting(
        "HTTPS",
        "`0`",
        _flag(False),
        "`1` behind HTTPS: the session cookie is `Secure` and named `__Host-millblocks`.",
    ),
    Setting(
        "PROXY_HOPS",
        "`0`",
        _whole(0, 0),
        "Reverse proxies in front whose `X-Forwarded-For`/`-Proto` are trusted (1 behind nginx).",
    ),
    Setting(
        "SESSION_IDLE_MINUTES",
        "`30`",
        _positive(30),
        "A session unused this long ends.",
    ),
    Setting(
        "SESSION_HOURS",
        "`12`",
        _positive(12),
        "A session ends this long after login, however active.",
    ),
    Setting(
        "DEMO_PROGRAMS",
        "`1`",
        _flag(True),
        "`0`: a new library starts empty instead of with the sample programs.",
    ),
    Setting(
        "MAX_UPLOAD_BYTES",
        f"`{MAX_IMPORT_BYTES}` (2 MiB)",
        _whole(MAX_IMPORT_BYTES, 1),
        "The largest request body, so the largest file uploaded to the web (nginx's "
        "`client_max_body_size` should match).",
    ),
    Setting(
        "MAX_IMPORT_LINES",
        f"`{MAX_IMPORT_LINES}`",
        _whole(MAX_IMPORT_LINES, 1),
        "Lines (or tape blocks) of a file imported on the web.",
    ),
    Setting(
        "REQUEST_SECONDS",
        "`20`",
        _positive(20),
        "The work one web request may do; past it the request is refused with a page saying "
        "so (503), well inside gunicorn's 30 s timeout (docs/security.md, Bounded work).",
    ),
    Setting(
        "TIME_ZONE",
        "the server's (`TZ`, else `/etc/localtime`)",
        _zone,
        "The zone times are shown in, e.g. `America/Chicago`; each time is labelled with it.",
    ),
    Setting(
        "LOG_LEVEL",
        "`INFO`",
        _choice("INFO", "DEBUG", "INFO", "WARNING", "ERROR"),
        "What goes to stderr (the journal): `INFO` a line per request, `WARNING` only "
        "warnings and errors.",
    ),
    Setting(
        "NATIVE",
        "`1`",
        _choice("1", "0", "1"),
        "`0`: the G-code importer runs from its Python sources where the wheel has it "
        "compiled (`make wheel-native`): the same results, slower (app/cnc/native.py reads it).",
    ),
)

BY_KEY = {setting.key: setting for setting in SETTINGS}

DEVELOPMENT = frozenset(
    {"MYPYC", "FUZZ_EXAMPLES", "FUZZ_DXF_EXAMPLES", "FUZZ_RANDOM", "REGEN_GOLDEN"}
)
"""MILLBLOCKS_* variables of building, the test suite and benchmarks, not of a server
(tests/test_settings.py finds every one they read here)."""

_warned: set[tuple[str, str]] = set()
"""The not-a-setting variables already named (with their values): once a process."""


def apply(config: MutableMapping[str, Any], environment: Mapping[str, str]) -> None:
    """Read every setting in `config` into its value (the default when absent). Names in
    `environment` (the variables `config` was loaded from) that are no setting are
    reported. Raises SettingError naming the variable."""
    for name in sorted(environment):
        key = name.removeprefix(f"{PREFIX}_")
        if name.startswith(f"{PREFIX}_") and key not in BY_KEY and key not in DEVELOPMENT:
            if (name, environment[name]) not in _warned:
                _warned.add((name, environment[name]))
                log.warning(
                    "%s is not a MillBlocks setting (docs/deploy.md lists them); ignored", name
                )
            config.pop(key, None)
    for setting in SETTINGS:
        raw = config.get(setting.key)
        try:
            config[setting.key] = setting.read(raw)
        except ValueError as exc:
            raise SettingError(f"{setting.variable}: {exc}") from None


def instance_folder(folder: Path | None = None) -> Path:
    """The instance folder (`folder`, else app.resources.instance_dir()), made if missing.
    Raises SettingError naming MILLBLOCKS_INSTANCE_PATH when it cannot be made or is not
    writable by this user (a path under /proc, a file, another user's folder)."""
    from app.resources import instance_dir

    path = folder or instance_dir()
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SettingError(
            f"{PREFIX}_INSTANCE_PATH: cannot make the folder {path}: {exc.strerror}; give a "
            "folder the user MillBlocks runs as may write (docs/deploy.md: /var/lib/millblocks)"
        ) from None
    if not os.access(path, os.W_OK | os.X_OK):
        raise SettingError(
            f"{PREFIX}_INSTANCE_PATH: the folder {path} is not writable by this user; give a "
            "folder the user MillBlocks runs as may write (docs/deploy.md: /var/lib/millblocks)"
        )
    return path


def environment() -> dict[str, Any]:
    """The settings from this process's environment (for the command line), read."""
    from flask.config import Config

    from app.resources import CHECKOUT

    config = Config(str(CHECKOUT))
    config.from_prefixed_env(PREFIX, loads=str)
    settings: dict[str, Any] = dict(config)
    apply(settings, os.environ)
    return settings


def shown(moment: datetime, zone: tzinfo, seconds: bool = False) -> str:
    """A stored time (naive UTC, as the library keeps them) in `zone`, labelled:
    `2024-07-01 07:00 CDT`."""
    local = moment.replace(tzinfo=UTC).astimezone(zone)
    return local.strftime("%Y-%m-%d %H:%M:%S %Z" if seconds else "%Y-%m-%d %H:%M %Z")
