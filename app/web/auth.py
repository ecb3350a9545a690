"""Who may do what. Two modes (setting AUTH, MILLBLOCKS_AUTH):

- `local` (what `make run` uses): a single local user with every capability, for a
  server bound to 127.0.0.1; a request from any other address, or naming any host but
  localhost, 127.0.0.1 or [::1] (DNS rebinding), is refused, so serving the shop network
  requires accounts.
- `accounts`: everyone logs in; programmers edit, operators view, export and send, admins
  also manage users and machines.

Sessions (accounts mode) live on the server (app.storage.accounts): Flask's signed cookie
carries only a random session id, so logout, a password change, a role change or an
admin's "end sessions" end a session everywhere. A session ends after 30 minutes unused
or 12 hours after login (MILLBLOCKS_SESSION_IDLE_MINUTES, MILLBLOCKS_SESSION_HOURS).

The login rate limit counts failures per account and address (5 in 15 minutes, then that
account waits at that address) and per address (20, whatever the accounts). Behind a
reverse proxy every client has the proxy's address unless MILLBLOCKS_PROXY_HOPS trusts its
X-Forwarded-For (app.web.create_app installs werkzeug's ProxyFix).

Every endpoint needs a capability (`REQUIRED`, else `view` for reading and `edit` for
anything that changes state), checked in one place before the view runs.
"""

from __future__ import annotations

import ipaddress
from datetime import timedelta
from urllib.parse import urlsplit

from flask import (
    Blueprint,
    Flask,
    abort,
    current_app,
    g,
    redirect,
    render_template,
    request,
    session,
    url_for,
)
from werkzeug.wrappers import Response

from app.storage.accounts import ROLES, Accounts, User
from app.storage.library import LibraryError
from app.web.extensions import get_library

bp = Blueprint("auth", __name__)

LOCAL = User(0, "local", "admin")
WINDOW = timedelta(minutes=15)
MAX_FAILURES = 5
"""Failed logins for one account from one address within WINDOW before it must wait."""
MAX_ADDRESS_FAILURES = 20
"""Failed logins from one address, whatever the accounts, within WINDOW."""
OPEN = {"auth.login", "static"}
REQUIRED = {
    "machines.save": "admin",
    "machines.delete": "admin",
    "auth.users": "admin",
    "auth.create_user": "admin",
    "auth.set_role": "admin",
    "auth.end_sessions": "admin",
    "export.page": "export",
    "export.download": "export",
    "transfers.send": "send",
    "transfers.receive": "send",
    "transfers.cancel": "send",
    "auth.logout": "view",
    "auth.account": "view",
    "auth.change_password": "view",
}
LOOPBACK_NAMES = frozenset({"localhost"})
PUBLIC = {"health.check"}
"""Endpoints anyone may reach from anywhere, in either mode: the health check a proxy or
monitor asks (it says nothing but whether the database answers)."""


def accounts() -> Accounts:
    return Accounts(get_library())


def current_user() -> User:
    user: User = g.get("user", LOCAL)
    return user


def init_app(app: Flask) -> None:
    app.before_request(_authorise)
    app.context_processor(lambda: {"user": current_user(), "auth_mode": app.config["AUTH"]})


def _is_loopback(address: str | None) -> bool:
    try:
        return ipaddress.ip_address(address or "").is_loopback
    except ValueError:
        return False


def _host_name(host: str) -> str:
    """The name part of a Host header (`[::1]:5000` → `::1`, `localhost:5000` →
    `localhost`)."""
    host = host.strip().lower()
    if host.startswith("["):
        return host[1 : host.find("]")] if "]" in host else host
    return host.rsplit(":", 1)[0] if host.count(":") == 1 else host


def is_loopback_host(host: str) -> bool:
    """Whether a Host header names this computer's loopback: localhost, 127.x, ::1."""
    name = _host_name(host)
    return name in LOOPBACK_NAMES or _is_loopback(name)


def _timeouts() -> tuple[timedelta, timedelta]:
    """The idle and absolute session limits (settings SESSION_IDLE_MINUTES and
    SESSION_HOURS, read by app.settings)."""
    config = current_app.config
    return timedelta(minutes=config["SESSION_IDLE_MINUTES"]), timedelta(
        hours=config["SESSION_HOURS"]
    )


def _local_only(message: str) -> tuple[str, int]:
    return render_template("errors/error.html", title="Local only", message=message), 403


def _authorise() -> Response | tuple[str, int] | None:
    endpoint = request.endpoint or ""
    if endpoint in PUBLIC:
        return None
    if current_app.config["AUTH"] == "local":
        if not _is_loopback(request.remote_addr):
            return _local_only(
                "This MillBlocks serves its local user only. To serve the shop network, "
                "start it with accounts (MILLBLOCKS_AUTH=accounts; see the README)."
            )
        if not is_loopback_host(request.host):
            return _local_only(
                "This MillBlocks serves its local user only and answers only to localhost, "
                "127.0.0.1 or [::1]; open it by one of those names."
            )
        g.user = User(0, current_app.config["USER"], "admin")
        return None
    user = None
    token = session.get("sid")
    if isinstance(token, str):
        user = accounts().session_user(token, *_timeouts())
        if user is None:
            session.clear()  # ended on the server, or timed out
    if user is None:
        if endpoint in OPEN:
            return None
        return redirect(url_for("auth.login", next=request.full_path))
    g.user = user
    needed = REQUIRED.get(endpoint, "view" if request.method in ("GET", "HEAD") else "edit")
    if not user.can(needed):
        abort(403, f"{user.username} ({user.role}) may not do this: it needs the {needed} right.")
    return None


def safe_next(target: str) -> str:
    """`target` when it is a path on this site, else `/` (ASVS 5.1.5).

    Browsers drop tabs and newlines from a URL and read `\\` as `/`, so `/\t/evil` and
    `/\\evil` are other sites to them; anything with a control character, a space or a
    backslash is refused, as is anything naming a scheme or host.
    """
    if not target.startswith("/") or target.startswith("//"):
        return "/"
    if any(ord(c) <= 0x20 or c in "\\\x7f" for c in target):
        return "/"
    parts = urlsplit(target)
    if parts.scheme or parts.netloc:
        return "/"
    return target


def _refusal(book: Accounts, address: str, username: str) -> str:
    """Why a login from `address` as `username` must wait, or "" when it may go on."""
    if book.recent_failures(address, WINDOW) >= MAX_ADDRESS_FAILURES:
        return "Too many failed logins from this address; wait 15 minutes and try again."
    if book.recent_failures(address, WINDOW, username) >= MAX_FAILURES:
        return (
            f"Too many failed logins for {username} from this address; wait 15 minutes "
            "and try again."
        )
    return ""


@bp.route("/login", methods=["GET", "POST"])
def login() -> Response | tuple[str, int]:
    if current_app.config["AUTH"] == "local":
        return redirect(url_for("library.index"))
    message = ""
    status = 200
    if request.method == "POST":
        address = request.remote_addr or "?"
        username = request.form.get("username", "")
        book = accounts()
        message = _refusal(book, address, username)
        if message:
            return render_template("auth/login.html", message=message), 429
        user = book.check(username, request.form.get("password", ""))
        if user is None:
            book.failed(address, username)
            message, status = "Wrong user name or password.", 401
        else:
            book.clear_failures(address, username)
            _start_session(book, user)
            return redirect(safe_next(request.args.get("next", "")))
    return render_template("auth/login.html", message=message), status


def _start_session(book: Accounts, user: User) -> None:
    """A new session id for this browser (never one it brought: no session fixation)."""
    session.clear()
    session["sid"] = book.start_session(user, request.remote_addr or "?")
    book.forget_expired(_timeouts()[1])


@bp.post("/logout")
def logout() -> Response:
    token = session.get("sid")
    if isinstance(token, str):
        accounts().end_session(token)
    session.clear()
    return redirect(url_for("auth.login"))


@bp.get("/account")
def account() -> str:
    return render_template("auth/account.html", message="")


@bp.post("/account/password")
def change_password() -> Response | tuple[str, int]:
    """Change one's own password: every other session of the user ends, this one is
    renewed."""
    user = current_user()
    book = accounts()
    form = request.form
    if book.check(user.username, form.get("current", "")) is None:
        return render_template("auth/account.html", message="The current password is wrong."), 403
    try:
        book.set_password(user.username, form.get("new", ""))
    except LibraryError as exc:
        return render_template("auth/account.html", message=f"Not changed: {exc}"), 422
    _start_session(book, user)
    return redirect(url_for("auth.account", changed=1))


@bp.get("/users")
def users() -> str:
    return _users_page("")


def _users_page(message: str) -> str:
    book = accounts()
    return render_template(
        "auth/users.html",
        users=book.users(),
        roles=ROLES,
        sessions=book.sessions_of(),
        message=message,
    )


@bp.post("/users")
def create_user() -> Response | tuple[str, int]:
    form = request.form
    try:
        accounts().create(form.get("username", ""), form.get("password", ""), form.get("role", ""))
    except LibraryError as exc:
        return _users_page(f"Not created: {exc}"), 422
    return redirect(url_for("auth.users"))


@bp.post("/users/<path:username>/role")
def set_role(username: str) -> Response | tuple[str, int]:
    """A new role; the user's sessions end (a role is read at login)."""
    try:
        accounts().set_role(username, request.form.get("role", ""))
    except LibraryError as exc:
        return _users_page(f"Not changed: {exc}"), 422
    return redirect(url_for("auth.users"))


@bp.post("/users/<path:username>/sessions/end")
def end_sessions(username: str) -> Response | tuple[str, int]:
    """Log a user out everywhere (a lost badge, a shared terminal)."""
    try:
        accounts().end_sessions(username)
    except LibraryError as exc:
        return _users_page(f"Not done: {exc}"), 422
    return redirect(url_for("auth.users"))
