"""The BOSS tape's segmenting at its old address: it lives in app/cnc/formats/gcode/boss.py."""

from app.cnc.formats.gcode.boss import segments

__all__ = ["segments"]
