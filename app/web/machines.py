"""Machine profiles: export target with its options (the target's fields, as on the export
page), and serial port settings."""

from __future__ import annotations

import contextlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from flask import Blueprint, redirect, render_template, request, url_for
from jinja2_fragments.flask import render_block
from werkzeug.wrappers import Response

from app.cnc.formats.targets import OptionError, get_target, targets
from app.cnc.machine import PRESETS
from app.cnc.text import TextError
from app.dnc.service import available_ports
from app.storage.library import LibraryError, Machine, check_machine
from app.web.export import (
    DEFAULT_TARGET,
    form_values,
    option_groups,
    options_from,
    shown_targets,
)
from app.web.extensions import get_library

bp = Blueprint("machines", __name__)

SERIAL_DEFAULTS = {
    "port": "",
    "baud": "4800",
    "data_bits": "7",
    "parity": "E",
    "stop_bits": "1",
    "flow": "none",
    "eol": "crlf",
    "leader": "0",
    "trailer": "0",
    "cps": "",
    "hold": "30",
    "requests": "off",
    "end": "%",
}
"""The serial settings the form shows, with the defaults a new machine starts from (the
ProtoTRAK's 4800 7E1; app.dnc.settings says what each means)."""


@dataclass(frozen=True)
class ShopPreset:
    """A machine a shop has, as the form starts it: the target it takes, that target's
    options, the serial settings over SERIAL_DEFAULTS and the travel limits (app.cnc.machine
    presets). Only what the seeds say is filled in; the rest stays at its default."""

    label: str
    target: str
    options: Mapping[str, str] = field(default_factory=dict)
    serial: Mapping[str, str] = field(default_factory=dict)
    limits: Mapping[str, str] = field(default_factory=dict)


SHOP_PRESETS: dict[str, ShopPreset] = {
    "prototrak-plus": ShopPreset("ProtoTRAK Plus over RS-232 (4800 7E1)", "events"),
    "linuxcnc": ShopPreset("LinuxCNC mill (G-code file)", "gcode-linuxcnc"),
    "fanuc-6m": ShopPreset("Fanuc 6M mill", "gcode-fanuc"),
    "prototrak-gcode": ShopPreset("ProtoTRAK (modified Fanuc G-code)", "gcode-prototrak"),
    # The Kearney & Trecker machines with the Tektronix 1704 control read EIA tape.
    **{
        f"{key}-1704": ShopPreset(
            f"{model.name}, Tektronix 1704 (EIA tape)", "tape-eia", limits={"preset": key}
        )
        for key, model in PRESETS.items()
    },
}


def _options(target_name: str, options: Mapping[str, str]) -> dict[str, Any]:
    """What the options fieldset shows: the fields of target `target_name` (the default
    target when there is none by that name) holding `options` (its defaults where they do
    not parse)."""
    everything = targets()
    target = everything.get(target_name) or everything[DEFAULT_TARGET]
    try:
        effective = target.parse_options(options)
    except OptionError:
        effective = target.parse_options({})
    common, more = option_groups(target)
    return {
        "target": target,
        "chosen": target.name,
        "values": form_values(target, effective),
        "common_options": common,
        "more_options": more,
    }


def _page(
    machine: Machine | None,
    message: str = "",
    target_name: str = "",
    new: bool = False,
    preset: str = "",
) -> str:
    """The machines page: the list, and the form for `machine` (None: a new one, on
    `target_name` or LinuxCNC G-code), its serial port picked from the ports this computer
    has."""
    chosen = machine.target if machine else target_name or DEFAULT_TARGET
    everything = targets()
    # A machine kept on a target the menu leaves out (the canonical dump) still shows it.
    own = {chosen: everything[chosen]} if chosen in everything else {}
    return render_template(
        "machines/index.html",
        machines=get_library().machines(),
        targets=shown_targets() | own,
        **_options(chosen, machine.options if machine else {}),
        machine=machine,
        serial_defaults=SERIAL_DEFAULTS,
        ports=available_ports(),
        presets=PRESETS,
        shop_presets=SHOP_PRESETS,
        chosen_preset=preset,
        new=new,
        message=message,
    )


@bp.get("/machines")
def index() -> str:
    edit = request.args.get("edit", "")
    machine = None
    if edit:
        try:
            machine = get_library().machine(edit)
        except LibraryError:
            machine = None
    preset = SHOP_PRESETS.get(request.args.get("preset", ""))
    if machine is None and preset is not None:
        # A new machine started from a preset: the form filled in, nothing saved yet.
        return _page(
            Machine(
                "",
                preset.target,
                dict(preset.options),
                SERIAL_DEFAULTS | dict(preset.serial),
                limits=dict(preset.limits),
            ),
            new=True,
            preset=request.args.get("preset", ""),
        )
    return _page(machine, target_name=request.args.get("target", ""))


@bp.get("/machines/options")
def options() -> str:
    """The options fieldset for another target (the form swaps it in when the target
    changes)."""
    context = _options(request.args.get("target", ""), {})
    return render_block("machines/index.html", "options", **context)


def _chosen_options(form: Mapping[str, str], target_name: str) -> dict[str, str]:
    """The options set in the form's fields for `target_name` that differ from its
    defaults, as text (none when the fields shown were another target's). Raises
    OptionError for a value the option does not take."""
    if form.get("options_for") != target_name or target_name not in targets():
        return {}
    target = get_target(target_name)
    raw = options_from(form, target_name)
    chosen = target.parse_options(raw)
    defaults = target.parse_options({})
    return {name: text for name, text in raw.items() if chosen[name] != defaults[name]}


@bp.post("/machines")
def save() -> Response | tuple[str, int]:
    form = request.form
    name = form.get("name", "").strip()
    target = form.get("target", "")
    options: dict[str, str] = {}
    message = ""
    try:
        options = _chosen_options(form, target)
        get_target(target).parse_options(options)
    except OptionError as exc:
        message = f"Not saved: {exc}"
    serial = {key: form.get(key, default).strip() for key, default in SERIAL_DEFAULTS.items()}
    limits: dict[str, object] = {}
    for line in form.get("limits", "").splitlines():
        if not line.strip() or message:
            continue
        key, sep, value = line.partition("=")
        if not sep:
            message = f"Not saved: limits line {line!r} is not NAME=VALUE"
        else:
            limits[key.strip()] = value.strip()
    machine = Machine(name, target, options, serial, form.get("notes", ""), limits)
    if not message:
        try:
            # The one check saving and restoring a machine go through (text, options,
            # limits, serial settings); its message names the field (`serial, baud: …`).
            check_machine(machine)
            get_library().save_machine(machine)
        except (LibraryError, TextError) as exc:  # TextError: a setting too long (SETTING_LENGTH)
            message = f"Not saved: {exc}"
    if message:
        return _page(machine, message), 422
    return redirect(url_for("machines.index"))


@bp.post("/machines/<path:name>/delete")
def delete(name: str) -> Response:
    with contextlib.suppress(LibraryError):
        get_library().delete_machine(name)
    return redirect(url_for("machines.index"))
