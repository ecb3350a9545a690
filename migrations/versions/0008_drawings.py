"""drawings being chosen from (DXF, issue 22)

Revision ID: 0008
Revises: 0007
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0008"
down_revision = "0007"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "drawings",
        sa.Column("key", sa.String(length=64), nullable=False),
        sa.Column("name", sa.String(length=200), nullable=False),
        sa.Column("data", sa.LargeBinary(), nullable=False),
        sa.Column("uploaded_at", sa.DateTime(), nullable=False),
        sa.Column("author", sa.String(length=100), nullable=False),
        sa.PrimaryKeyConstraint("key"),
    )
    with op.batch_alter_table("drawings", schema=None) as batch_op:
        batch_op.create_index("ix_drawings_uploaded", ["uploaded_at"], unique=False)


def downgrade() -> None:
    with op.batch_alter_table("drawings", schema=None) as batch_op:
        batch_op.drop_index("ix_drawings_uploaded")
    op.drop_table("drawings")
