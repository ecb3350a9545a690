"""transfer log: which revision of the program was sent, its checksum, and the block a
restart began at

Revision ID: 0009
Revises: 0008
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0009"
down_revision = "0008"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("transfer_log", schema=None) as batch_op:
        batch_op.add_column(sa.Column("revision", sa.Integer(), nullable=True))
        batch_op.add_column(
            sa.Column("checksum", sa.String(length=64), nullable=False, server_default="")
        )
        batch_op.add_column(sa.Column("start_block", sa.Integer(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("transfer_log", schema=None) as batch_op:
        batch_op.drop_column("start_block")
        batch_op.drop_column("checksum")
        batch_op.drop_column("revision")
