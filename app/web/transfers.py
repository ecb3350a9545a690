"""Transfers: sending to and receiving from controls over RS-232 (the page is a shell
until the serial transfer work lands; it lists the machines that have a port)."""

from __future__ import annotations

from flask import Blueprint, render_template

from app.web.extensions import get_library

bp = Blueprint("transfers", __name__)


@bp.get("/transfers")
def index() -> str:
    machines = [m for m in get_library().machines() if m.serial.get("port")]
    return render_template("transfers/index.html", machines=machines)
