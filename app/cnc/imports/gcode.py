"""The G-code reader's old address: it lives in app/cnc/formats/gcode/reader.py."""

from app.cnc.formats.gcode.reader import parse_gcode

__all__ = ["parse_gcode"]
