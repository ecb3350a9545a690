"""gunicorn reads this file from the folder it starts in: MillBlocks' settings, kept in the
package (app/gunicorn_conf.py) so that `millblocks serve` of an installed wheel has them.

Every name of that module, not a list of them: gunicorn takes the names that are its
settings and hooks and ignores the rest, and a list here had already lost a hook
(`post_worker_init`) that `millblocks serve` had and `make run` did not."""

from app.gunicorn_conf import *  # noqa: F403 - gunicorn reads this module's names
