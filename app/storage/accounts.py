"""Accounts for a shop server: users with roles, password hashes, failed-login counting.

Roles: `programmer` edits programs; `operator` views, exports and sends; `admin` does all
of that and manages users and machines. Passwords are stored only as scrypt hashes
(werkzeug.security), never in the clear.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import UTC, datetime, timedelta

from sqlalchemy import delete, func, select
from werkzeug.security import check_password_hash, generate_password_hash

from app.storage.library import Library, LibraryError, NotFound
from app.storage.models import LoginAttemptRow, UserRow

ROLES = ("programmer", "operator", "admin")
CAPABILITIES = {
    "programmer": frozenset({"view", "edit", "export"}),
    "operator": frozenset({"view", "export", "send"}),
    "admin": frozenset({"view", "edit", "export", "send", "admin"}),
}
MIN_PASSWORD = 10


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
        username = username.strip()
        if not username or len(username) > 100:
            raise LibraryError("a user name is 1 to 100 characters")
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
        with self.library.session() as s:
            row = s.scalar(select(UserRow).where(UserRow.username == username))
            stored = row.password_hash if row else generate_password_hash("not a password")
            ok = check_password_hash(stored, password)
            return User(row.id, row.username, row.role) if row and ok else None

    def set_role(self, username: str, role: str) -> None:
        if role not in ROLES:
            raise LibraryError(f"role {role!r} is not one of {', '.join(ROLES)}")
        with self.library.session() as s:
            row = s.scalar(select(UserRow).where(UserRow.username == username))
            if row is None:
                raise NotFound(f"no user {username!r}")
            row.role = role

    def set_password(self, username: str, password: str) -> None:
        if len(password) < MIN_PASSWORD:
            raise LibraryError(f"a password has at least {MIN_PASSWORD} characters")
        with self.library.session() as s:
            row = s.scalar(select(UserRow).where(UserRow.username == username))
            if row is None:
                raise NotFound(f"no user {username!r}")
            row.password_hash = generate_password_hash(password)

    # -- the login rate limit ----------------------------------------------------------------

    def failed(self, address: str, username: str) -> None:
        with self.library.session() as s:
            s.add(LoginAttemptRow(address=address, username=username[:100], at=_now()))

    def recent_failures(self, address: str, window: timedelta) -> int:
        with self.library.session() as s:
            since = _now() - window
            count = s.scalar(
                select(func.count(LoginAttemptRow.id)).where(
                    LoginAttemptRow.address == address, LoginAttemptRow.at >= since
                )
            )
            s.execute(delete(LoginAttemptRow).where(LoginAttemptRow.at < _now() - 10 * window))
            return int(count or 0)

    def clear_failures(self, address: str) -> None:
        with self.library.session() as s:
            s.execute(delete(LoginAttemptRow).where(LoginAttemptRow.address == address))
