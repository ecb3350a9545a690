"""Entry point of a measurement's child process: `python -m bench.child MODULE:FUNCTION ARGS`.

ARGS is a JSON object passed as keyword arguments; the function's result (a JSON-able dict)
is printed as the last line of standard output.
"""

from __future__ import annotations

import importlib
import json
import sys


def main(argv: list[str]) -> int:
    target, raw = argv
    module_name, function_name = target.split(":")
    function = getattr(importlib.import_module(module_name), function_name)
    result = function(**json.loads(raw))
    sys.stdout.write(json.dumps(result) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
