"""The program document as an export target (the program itself, not its tool path)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from app.cnc import document
from app.cnc.blocks import Program
from app.cnc.emit.target import Report, Target, register
from app.cnc.toolpath import Toolpath


@register
class JsonTarget(Target):
    name = "json"
    description = "MillBlocks program document (docs/program-format.md)"
    extension = "json"
    media_type = "application/json"

    def emit(
        self, program: Program, toolpath: Toolpath, options: Mapping[str, Any], report: Report
    ) -> bytes:
        return document.dumps(program).encode("utf-8")
