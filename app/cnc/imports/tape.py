"""The 1704 tape reader's old address: it lives in app/cnc/formats/tape1704/reader.py."""

from app.cnc.formats.tape1704.reader import parse_tape

__all__ = ["parse_tape"]
