"""gunicorn's settings for MillBlocks (app/gunicorn_conf.py) that are code, not values."""

from __future__ import annotations

import gc

from app import gunicorn_conf


def test_a_worker_sets_aside_what_it_loaded_from_later_collections() -> None:
    """After the app is loaded, a worker freezes what exists (gunicorn calls
    `post_worker_init` then): full collections during a heavy request no longer read the
    app's own objects."""
    before = gc.get_freeze_count()
    try:
        gunicorn_conf.post_worker_init(None)
        assert gc.get_freeze_count() > before
        # What is created afterwards is still collected.
        cycle: list[object] = []
        cycle.append(cycle)
        del cycle
        assert gc.collect() >= 1
    finally:
        gc.unfreeze()
