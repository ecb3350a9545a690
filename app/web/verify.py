"""The finished part: the stock-removal simulation in 3D, verify's report per block, the
stock form, and the part as PNG (for the set-up sheet) and STL.

The page draws the part with three.js (static/verify.js) from `surface`: a small binary
file of the height map and of the block that cut each cell, simulated up to the block the
replay slider asks for.
"""

from __future__ import annotations

import dataclasses
import struct
from decimal import Decimal
from typing import Any

import numpy as np
from flask import Blueprint, Response, redirect, render_template, request, url_for
from markupsafe import escape
from werkzeug.wrappers import Response as BaseResponse

from app.cnc.blocks import Program, Stock
from app.cnc.numbers import NumberError, parse_decimal, parse_int
from app.cnc.problems import has_errors
from app.cnc.simulate.image import png_bytes, render
from app.cnc.simulate.mesh import stl_bytes
from app.cnc.simulate.stock import StockError, program_stock
from app.cnc.simulate.sweep import Simulation
from app.cnc.simulate.verify import Verification, VerifyTooLarge, run_simulation, verify
from app.cnc.units import Units
from app.cnc.validate import validate
from app.storage.library import StaleSave, StoredProgram
from app.web.downloads import attachment, file_name
from app.web.editor import _int, current_user, load
from app.web.extensions import get_library
from app.web.heavy import heavy

bp = Blueprint("verify", __name__)

VIEW_CELLS = 320  # along the stock's longer side in the browser: ~100 000 vertices
MAGIC = b"MBS1"
STOCK_FIELDS = (
    ("x", "X"),
    ("y", "Y"),
    ("z", "Z TOP"),
    ("xl", "XL"),
    ("yw", "YW"),
    ("zh", "ZH"),
    ("clear", "CLEAR"),
)


def _refusal(stored: StoredProgram) -> tuple[str, int] | None:
    """The page to show instead when the program cannot be simulated (it has errors)."""
    if has_errors(validate(stored.program)):
        message = "The program has errors; fix them before simulating the part."
        return render_template("errors/error.html", title="No simulation", message=message), 422
    return None


@bp.get("/programs/<int:program_id>/verify")
@heavy
def page(program_id: int) -> tuple[str, int]:
    stored = load(program_id)
    return _render(stored, {}, {}, "")


def _render(
    stored: StoredProgram, values: dict[str, str], errors: dict[str, str], message: str
) -> tuple[str, int]:
    refused = _refusal(stored)
    if refused is not None:
        return refused
    program = stored.program
    try:
        result = verify(program)
    except VerifyTooLarge as exc:
        return _too_large(exc), 422
    except StockError as exc:
        result = None
        errors = errors or {"stock": str(exc)}
    stock = program.stock
    shown = values or {
        name: ("" if stock is None else f"{getattr(stock, name):f}") for name, _ in STOCK_FIELDS
    }
    titles = {n: block.title for n, block in enumerate(program.blocks, start=1)}
    status = 422 if errors else 409 if message else 200
    return (
        render_template(
            "verify/page.html",
            stored=stored,
            program=program,
            result=result,
            report=result.text() if result else "",
            removed=_removed(result),
            titles=titles,
            stock_fields=STOCK_FIELDS,
            values=shown,
            errors=errors,
            message=message,
        ),
        status,
    )


@bp.get("/programs/<int:program_id>/verify/report")
@heavy
def report(program_id: int) -> tuple[str, int]:
    """Verify's findings per block, as a fragment for the editor's panel. It says which
    version of the program it verified (`data-version`): the panel shows it as out of date
    once the page shows another, since block numbers change with an edit."""
    stored = load(program_id)
    if has_errors(validate(stored.program)):
        return _verified(stored, '<p class="hint">Fix the program\'s errors first.</p>'), 200
    try:
        result = verify(stored.program)
    except (StockError, VerifyTooLarge) as exc:
        return _verified(stored, f'<p class="message error">{escape(str(exc))}</p>'), 200
    titles = {n: block.title for n, block in enumerate(stored.program.blocks, start=1)}
    html = render_template(
        "verify/report.html", stored=stored, result=result, titles=titles, removed=_removed(result)
    )
    return _verified(stored, html), 200


def _too_large(error: VerifyTooLarge) -> str:
    """The page instead of a simulation past the server's limit (sizes.MAX_VERIFY_WORK)."""
    return render_template("errors/error.html", title="Too much to simulate", message=str(error))


def _verified(stored: StoredProgram, html: str) -> str:
    """The report fragment, marked with the version it is about."""
    version = stored.info.version
    return f'<div class="verify-result" data-version="{version}">{html}</div>'


def _removed(result: Verification | None) -> str:
    if result is None:
        return ""
    u = result.units
    return f"{result.simulation.removed_volume() / u.nm**3:.4f} {u.symbol}³"


@bp.post("/programs/<int:program_id>/verify/stock")
def save_stock(program_id: int) -> BaseResponse | tuple[str, int]:
    """Save the stock with the program (a new revision), or clear it ("use the extent")."""
    stored = load(program_id)
    form = request.form
    stock: Stock | None = None
    errors: dict[str, str] = {}
    if form.get("action") != "clear":
        stock, errors = parse_stock(form, stored.program.units)
    values = {name: form.get(name, "") for name, _ in STOCK_FIELDS}
    if errors:
        return _render(stored, values, errors, "")
    program: Program = dataclasses.replace(stored.program, stock=stock)
    try:
        get_library().save(
            program_id,
            program,
            based_on=_int(form.get("version"), stored.info.version),
            author=current_user(),
        )
    except StaleSave as exc:
        return _render(get_library().get(program_id), values, {}, str(exc))
    return redirect(url_for("verify.page", program_id=program_id))


def parse_stock(form: Any, units: Units) -> tuple[Stock | None, dict[str, str]]:
    """The stock from its form; errors by field name, saying what is allowed (what the
    simulation cannot take too: `program_stock`'s refusals)."""
    values: dict[str, Decimal] = {}
    errors: dict[str, str] = {}
    for name, label in STOCK_FIELDS:
        raw = form.get(name, "").strip()
        if raw == "" and name in ("z", "clear"):
            raw = "0"
        try:
            value = parse_decimal(raw)
        except NumberError as exc:
            errors[name] = f"{label}: {exc}"
            continue
        if name in ("xl", "yw", "zh") and value <= 0:
            errors[name] = f"{label}: must be more than 0"
            continue
        if name == "clear" and value < 0:
            errors[name] = f"{label}: the room under the stock cannot be negative; 0 or more"
            continue
        if abs(value) >= 10_000:
            errors[name] = f"{label}: {raw} is out of range; allowed less than 10000"
            continue
        values[name] = value
    if errors:
        return None, errors
    stock = Stock(**values)
    try:
        program_stock(stock, units)
    except StockError as exc:
        return None, {exc.field: str(exc).removeprefix("stock, ")}
    return stock, {}


def _simulated(program_id: int, cells: int = VIEW_CELLS) -> tuple[Program, Simulation] | Response:
    stored = load(program_id)
    if has_errors(validate(stored.program)):
        return Response("The program has errors.", 422, mimetype="text/plain")
    upto_raw = request.args.get("upto", "")
    try:
        upto = parse_int(upto_raw) if upto_raw.strip() else None
    except NumberError as exc:
        return Response(f"upto: {exc}", 422, mimetype="text/plain")
    if upto is not None and upto < 0:
        return Response(
            f"upto: {upto} is below 0; allowed: a block number", 422, mimetype="text/plain"
        )
    try:
        return stored.program, run_simulation(stored.program, upto=upto, cells=cells)
    except (StockError, VerifyTooLarge) as exc:
        return Response(str(exc), 422, mimetype="text/plain")


@bp.get("/programs/<int:program_id>/verify/surface")
@heavy
def surface(program_id: int) -> Response:
    """The height map for the 3D view (program units; little-endian):

    `MBS1`, nx, ny (uint32); x0, y0, cell size, stock top, stock bottom (float64); the last
    block simulated, the number of blocks (uint32); heights (float32, nx·ny, row by row from
    the lowest Y); the block that cut each cell (int32, 0 where none did).
    """
    found = _simulated(program_id)
    if isinstance(found, Response):
        return found
    program, sim = found
    grid, unit = sim.grid, float(program.units.nm)
    stock = grid.stock
    last = len(program.blocks) if sim.upto is None else min(sim.upto, len(program.blocks))
    head = MAGIC + struct.pack(
        "<II5dII",
        grid.nx,
        grid.ny,
        grid.x0 / unit,
        grid.y0 / unit,
        grid.resolution / unit,
        stock.top / unit,
        stock.bottom / unit,
        last,
        len(program.blocks),
    )
    heights = (sim.heights() / unit).astype("<f4")
    owners = sim.owner_blocks().astype("<i4")
    body = head + heights.tobytes() + np.ascontiguousarray(owners).tobytes()
    return Response(body, mimetype="application/octet-stream")


@bp.get("/programs/<int:program_id>/verify/part.png")
@heavy
def part_png(program_id: int) -> Response:
    found = _simulated(program_id, cells=800)
    if isinstance(found, Response):
        return found
    _, sim = found
    return Response(png_bytes(render(sim.grid, sim.heights())), mimetype="image/png")


@bp.get("/programs/<int:program_id>/verify/part.stl")
@heavy
def part_stl(program_id: int) -> Response:
    found = _simulated(program_id, cells=400)
    if isinstance(found, Response):
        return found
    program, sim = found
    return Response(
        stl_bytes(sim.grid, sim.heights()),
        mimetype="model/stl",
        headers={"Content-Disposition": attachment(file_name(program.name, "stl", "part"))},
    )
