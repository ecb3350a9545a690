"""Entry point of a measurement's child process: `python -m bench.child MODULE:FUNCTION ARGS`.

ARGS is a JSON object passed as keyword arguments; the function's result (a JSON-able dict)
is printed as the last line of standard output. The benchmarks measure programs of up to
10^6 moves and more, past what a shop server allows one program (app.cnc.sizes.MAX_MOVES
is about the estimate, which counts more than the path): they run with the limit lifted,
as the command line's `--max-moves` lifts it.
"""

from __future__ import annotations

import importlib
import json
import sys

from app.cnc.sizes import moves_allowed

BENCH_MOVES = 10**9


def main(argv: list[str]) -> int:
    target, raw = argv
    module_name, function_name = target.split(":")
    function = getattr(importlib.import_module(module_name), function_name)
    with moves_allowed(BENCH_MOVES):
        result = function(**json.loads(raw))
    sys.stdout.write(json.dumps(result) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
