"""gunicorn's settings for MillBlocks: `millblocks serve` passes them (`-c
python:app.gunicorn_conf`), and the checkout's gunicorn.conf.py, which gunicorn reads from
the folder it starts in (`make run`, the README's shop command, the benchmarks' server),
is these. The command line's --bind and --workers still choose where and how many.

Threads (gthread workers): a request that works for seconds (a large pocket planned for
the first time, Verify of a large program) holds one thread, not a whole worker, so the
other requests of the shop — a login, a library page — are answered meanwhile
(tests/test_server_load.py). Every request's work is bounded in size (app/cnc/sizes.py,
app/cnc/cost.py) and in time (MILLBLOCKS_REQUEST_SECONDS, 20 s: a clear refusal), well
inside `timeout`, so no worker is killed for a slow request. Within a process the heavy
requests (Verify, the set-up sheet, exports) run one at a time (app/web/heavy.py), so the
interpreter lock is shared with the light ones by at most one of them.

The control socket (gunicorn 25 and later, for `gunicornc`) is `gunicorn.ctl` in the instance
folder: gunicorn's default, `$XDG_RUNTIME_DIR` or `~/.gunicorn`, is one for every gunicorn of
a user, so a second `millblocks serve` took over the first one's socket (and removed it on
stopping). An older gunicorn ignores the setting.
"""

import gc
from typing import Any

from app.resources import instance_dir

worker_class = "gthread"
threads = 4
timeout = 30
control_socket = str(instance_dir() / "gunicorn.ctl")


def on_starting(server: Any) -> None:
    """Before gunicorn's master starts a worker: a setting or database no worker can use is
    said once and gunicorn exits 4 (or 3 for a database that does not answer yet) as the
    unit expects (app.check_start says why the workers alone cannot be trusted to)."""
    from app import check_start

    check_start()


def post_worker_init(worker: Any) -> None:
    """Once a worker has loaded the app: what exists then (modules, the app, its tables)
    lives as long as the worker, so it is collected once and set aside (`gc.freeze`) rather
    than read again by every full collection. A heavy request makes several (the 8-island
    POCKET's plan about 7, a seventh of its time, most of it reading those objects)."""
    gc.collect()
    gc.freeze()
