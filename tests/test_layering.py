"""The core (app/cnc) imports no web, database or serial code."""

from __future__ import annotations

import ast
from pathlib import Path

CORE = Path(__file__).parent.parent / "app" / "cnc"
FORBIDDEN = {"flask", "sqlalchemy", "alembic", "serial", "click", "werkzeug", "jinja2"}


def test_core_imports_only_the_standard_library_and_itself() -> None:
    offenders = []
    for path in sorted(CORE.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            names: list[str] = []
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                names = [node.module]
            for name in names:
                if name.split(".")[0] in FORBIDDEN:
                    offenders.append(f"{path.relative_to(CORE.parent.parent)}: {name}")
    assert offenders == []
