"""gunicorn reads this file from the folder it starts in: MillBlocks' settings, kept in the
package (app/gunicorn_conf.py) so that `millblocks serve` of an installed wheel has them."""

from app.gunicorn_conf import (
    control_socket,
    on_starting,
    post_worker_init,
    threads,
    timeout,
    worker_class,
)

__all__ = [
    "control_socket",
    "on_starting",
    "post_worker_init",
    "threads",
    "timeout",
    "worker_class",
]
