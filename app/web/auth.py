"""Who may do what. Two modes (config MILLBLOCKS_AUTH):

- `local` (what `make run` uses): a single local user with every capability, for a
  server bound to 127.0.0.1; a request from any other address is refused, so serving the
  shop network requires accounts.
- `accounts`: everyone logs in; programmers edit, operators view, export and send, admins
  also manage users and machines. Failed logins are counted per address: the sixth within
  15 minutes is answered 429. A login starts a new session.

Every endpoint needs a capability (`REQUIRED`, else `view` for reading and `edit` for
anything that changes state), checked in one place before the view runs.
"""

from __future__ import annotations

import ipaddress
from datetime import timedelta

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
OPEN = {"auth.login", "static"}
REQUIRED = {
    "machines.save": "admin",
    "machines.delete": "admin",
    "auth.users": "admin",
    "auth.create_user": "admin",
    "auth.set_role": "admin",
    "export.page": "export",
    "export.download": "export",
    "transfers.send": "send",
    "transfers.receive": "send",
    "transfers.cancel": "send",
    "auth.logout": "view",
}


def accounts() -> Accounts:
    return Accounts(get_library())


def current_user() -> User:
    user: User = g.get("user", LOCAL)
    return user


def init_app(app: Flask) -> None:
    app.config.setdefault("MILLBLOCKS_AUTH", "local")
    app.before_request(_authorise)
    app.context_processor(
        lambda: {"user": current_user(), "auth_mode": app.config["MILLBLOCKS_AUTH"]}
    )


def _is_loopback(address: str | None) -> bool:
    try:
        return ipaddress.ip_address(address or "").is_loopback
    except ValueError:
        return False


def _authorise() -> Response | tuple[str, int] | None:
    endpoint = request.endpoint or ""
    if current_app.config["MILLBLOCKS_AUTH"] == "local":
        if not _is_loopback(request.remote_addr):
            message = (
                "This MillBlocks serves its local user only. To serve the shop network, "
                "start it with accounts (MILLBLOCKS_AUTH=accounts; see the README)."
            )
            return render_template("errors/error.html", title="Local only", message=message), 403
        g.user = User(0, str(current_app.config.get("MILLBLOCKS_USER", "local")), "admin")
        return None
    user = None
    if "user_id" in session:
        user = accounts().get(int(session["user_id"]))
    if user is None:
        if endpoint in OPEN:
            return None
        return redirect(url_for("auth.login", next=request.full_path))
    g.user = user
    needed = REQUIRED.get(endpoint, "view" if request.method in ("GET", "HEAD") else "edit")
    if not user.can(needed):
        abort(403, f"{user.username} ({user.role}) may not do this: it needs the {needed} right.")
    return None


@bp.route("/login", methods=["GET", "POST"])
def login() -> Response | tuple[str, int]:
    if current_app.config["MILLBLOCKS_AUTH"] == "local":
        return redirect(url_for("library.index"))
    message = ""
    status = 200
    if request.method == "POST":
        address = request.remote_addr or "?"
        book = accounts()
        if book.recent_failures(address, WINDOW) >= MAX_FAILURES:
            message = "Too many failed logins from this address; wait 15 minutes and try again."
            return render_template("auth/login.html", message=message), 429
        user = book.check(request.form.get("username", ""), request.form.get("password", ""))
        if user is None:
            book.failed(address, request.form.get("username", ""))
            message, status = "Wrong user name or password.", 401
        else:
            book.clear_failures(address)
            session.clear()  # a new session on login
            session["user_id"] = user.id
            target = request.args.get("next", "")
            return redirect(
                target if target.startswith("/") and not target.startswith("//") else "/"
            )
    return render_template("auth/login.html", message=message), status


@bp.post("/logout")
def logout() -> Response:
    session.clear()
    return redirect(url_for("auth.login"))


@bp.get("/users")
def users() -> str:
    return render_template("auth/users.html", users=accounts().users(), roles=ROLES, message="")


@bp.post("/users")
def create_user() -> Response | tuple[str, int]:
    form = request.form
    try:
        accounts().create(form.get("username", ""), form.get("password", ""), form.get("role", ""))
    except LibraryError as exc:
        page = render_template(
            "auth/users.html", users=accounts().users(), roles=ROLES, message=f"Not created: {exc}"
        )
        return page, 422
    return redirect(url_for("auth.users"))


@bp.post("/users/<username>/role")
def set_role(username: str) -> Response:
    try:
        accounts().set_role(username, request.form.get("role", ""))
    except LibraryError as exc:
        abort(422, str(exc))
    return redirect(url_for("auth.users"))
