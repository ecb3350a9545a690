"""The `json` target: the program document itself (not its tool path) - any program, errors
and all, its problems reported as warnings (a `document` target)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from app.cnc import document
from app.cnc.blocks import Program
from app.cnc.formats.targets import Out, Report, Target, register
from app.cnc.path import CompiledPath


@register
class JsonTarget(Target):
    name = "json"
    label = "MillBlocks program (JSON)"
    description = "MillBlocks program document (docs/program-format.md)"
    extension = "json"
    media_type = "application/json"
    reads_back = "json"
    document = True

    def write_program(
        self, program: Program, options: Mapping[str, Any], report: Report, out: Out
    ) -> None:
        out.write(document.dumps(program).encode("utf-8"))

    def write(
        self,
        program: Program,
        path: CompiledPath,
        options: Mapping[str, Any],
        report: Report,
        out: Out,
    ) -> None:
        self.write_program(program, options, report, out)
