"""Accounts for a shop server: users with roles, password hashes, server-side sessions,
failed-login counting.

Roles: `programmer` edits programs; `operator` views, exports and sends; `admin` does all
of that and manages users and machines. Passwords are stored only as scrypt hashes
(werkzeug.security), never in the clear.

Sessions live here, not in the cookie: a login stores the SHA-256 of a random 256-bit id
(the cookie carries the id itself), and a session is over when its row is gone: logout,
a password change, a role change, an admin's "end sessions", or its idle or absolute
timeout (checked on every request, `session_user`).
"""

from __future__ import annotations

import hashlib
import secrets
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta

from sqlalchemy import delete, func, select
from sqlalchemy.orm import Session
from werkzeug.security import check_password_hash, generate_password_hash

from app.cnc.text import SHORT_NAME_LENGTH, check_text
from app.storage.library import Library, LibraryError, NotFound
from app.storage.models import LoginAttemptRow, SessionRow, UserRow

ROLES = ("programmer", "operator", "admin")
CAPABILITIES = {
    "programmer": frozenset({"view", "edit", "export"}),
    "operator": frozenset({"view", "export", "send"}),
    "admin": frozenset({"view", "edit", "export", "send", "admin"}),
}
MIN_PASSWORD = 10
TOUCH_EVERY = timedelta(minutes=1)
"""How stale `last_seen` may get before a request writes it (not one write per request),
and at most a tenth of the idle limit: a session then ends between 90 % and 100 % of the
idle limit after its last request, never while its user works (with a 1-minute limit a
once-a-minute write let a session used every 10 s end at 60 s)."""


@dataclass(frozen=True)
class User:
    id: int
    username: str
    role: str

    def can(self, capability: str) -> bool:
        return capability in CAPABILITIES.get(self.role, frozenset())


def _now() -> datetime:
    return datetime.now(UTC).replace(tzinfo=None)


class Accounts:
    """Users and login attempts, on the library's database."""

    def __init__(self, library: Library) -> None:
        self.library = library

    def create(self, username: str, password: str, role: str) -> User:
        username = check_text(username.strip(), "user name", SHORT_NAME_LENGTH)
        check_text(password, "password")
        if not username:
            raise LibraryError(f"a user name is 1 to {SHORT_NAME_LENGTH} characters")
        if role not in ROLES:
            raise LibraryError(f"role {role!r} is not one of {', '.join(ROLES)}")
        if len(password) < MIN_PASSWORD:
            raise LibraryError(f"a password has at least {MIN_PASSWORD} characters")
        with self.library.session() as s:
            if s.scalar(select(UserRow).where(UserRow.username == username)):
                raise LibraryError(f"user {username!r} exists already")
            row = UserRow(
                username=username,
                password_hash=generate_password_hash(password),
                role=role,
                created_at=_now(),
            )
            s.add(row)
            s.flush()
            return User(row.id, row.username, row.role)

    def users(self) -> list[User]:
        with self.library.session() as s:
            rows = s.scalars(select(UserRow).order_by(UserRow.username)).all()
            return [User(r.id, r.username, r.role) for r in rows]

    def get(self, user_id: int) -> User | None:
        with self.library.session() as s:
            row = s.get(UserRow, user_id)
            return None if row is None else User(row.id, row.username, row.role)

    def check(self, username: str, password: str) -> User | None:
        """The user, when the password is right; None otherwise (same time either way)."""
        check_text(password, "password")
        with self.library.session() as s:
            row = s.scalar(select(UserRow).where(UserRow.username == username))
            stored = row.password_hash if row else generate_password_hash("not a password")
            ok = check_password_hash(stored, password)
            return User(row.id, row.username, row.role) if row and ok else None

    def set_role(self, username: str, role: str) -> None:
        """Change a user's role; the user's sessions end (they log in again as the new
        role)."""
        if role not in ROLES:
            raise LibraryError(f"role {role!r} is not one of {', '.join(ROLES)}")
        with self.library.session() as s:
            row = _user(s, username)
            row.role = role
            _end_sessions(s, row.id)

    def set_password(self, username: str, password: str) -> None:
        """Change a user's password; every session of the user ends."""
        check_text(password, "password")
        if len(password) < MIN_PASSWORD:
            raise LibraryError(f"a password has at least {MIN_PASSWORD} characters")
        with self.library.session() as s:
            row = _user(s, username)
            row.password_hash = generate_password_hash(password)
            _end_sessions(s, row.id)

    # -- sessions ------------------------------------------------------------------------------

    def start_session(self, user: User, address: str) -> str:
        """A new session for `user`; returns the id the cookie carries (only its hash is
        stored)."""
        token = secrets.token_urlsafe(32)
        now = _now()
        with self.library.session() as s:
            s.add(
                SessionRow(
                    id=_digest(token),
                    user_id=user.id,
                    created_at=now,
                    last_seen=now,
                    address=address[:100],
                )
            )
        return token

    def session_user(self, token: str, idle: timedelta, absolute: timedelta) -> User | None:
        """The user of a live session, or None: no such session, or it has been idle for
        `idle` or lasted `absolute` (then it is deleted)."""
        now = _now()
        with self.library.session() as s:
            row = s.get(SessionRow, _digest(token))
            if row is None:
                return None
            if now - row.last_seen >= idle or now - row.created_at >= absolute:
                s.delete(row)
                return None
            if now - row.last_seen >= min(TOUCH_EVERY, idle / 10):
                row.last_seen = now
            user = s.get(UserRow, row.user_id)
            return None if user is None else User(user.id, user.username, user.role)

    def end_session(self, token: str) -> None:
        with self.library.session() as s:
            s.execute(delete(SessionRow).where(SessionRow.id == _digest(token)))

    def end_sessions(self, username: str) -> int:
        """End every session of a user; how many there were."""
        with self.library.session() as s:
            return _end_sessions(s, _user(s, username).id)

    def sessions_of(self) -> dict[str, int]:
        """Live-looking sessions per user name (for the users page)."""
        with self.library.session() as s:
            rows = s.execute(
                select(UserRow.username, func.count(SessionRow.id))
                .join(SessionRow, SessionRow.user_id == UserRow.id)
                .group_by(UserRow.username)
            ).all()
            return {name: int(count) for name, count in rows}

    def forget_expired(self, absolute: timedelta) -> None:
        """Delete sessions past the absolute timeout (they could no longer be used)."""
        with self.library.session() as s:
            s.execute(delete(SessionRow).where(SessionRow.created_at < _now() - absolute))

    # -- the login rate limit ----------------------------------------------------------------

    def failed(self, address: str, username: str) -> None:
        with self.library.session() as s:
            s.add(LoginAttemptRow(address=address[:100], username=username[:100], at=_now()))

    def recent_failures(self, address: str, window: timedelta, username: str | None = None) -> int:
        """Failed logins from `address` within `window` (for `username` only, when given)."""
        with self.library.session() as s:
            since = _now() - window
            statement = select(func.count(LoginAttemptRow.id)).where(
                LoginAttemptRow.address == address[:100], LoginAttemptRow.at >= since
            )
            if username is not None:
                statement = statement.where(LoginAttemptRow.username == username[:100])
            count = s.scalar(statement)
            s.execute(delete(LoginAttemptRow).where(LoginAttemptRow.at < _now() - 10 * window))
            return int(count or 0)

    def clear_failures(self, address: str, username: str) -> None:
        """Forget the failed logins of `username` from `address` (after it logged in there);
        guesses at other accounts from the same address still count."""
        with self.library.session() as s:
            s.execute(
                delete(LoginAttemptRow).where(
                    LoginAttemptRow.address == address[:100],
                    LoginAttemptRow.username == username[:100],
                )
            )


def _digest(token: str) -> str:
    return hashlib.sha256(token.encode()).hexdigest()


def _user(s: Session, username: str) -> UserRow:
    row = s.scalar(select(UserRow).where(UserRow.username == username))
    if row is None:
        raise NotFound(f"no user {username!r}")
    return row


def _end_sessions(s: Session, user_id: int) -> int:
    result = s.execute(delete(SessionRow).where(SessionRow.user_id == user_id))
    return int(getattr(result, "rowcount", 0) or 0)
