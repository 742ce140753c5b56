"""Run summaries record the start of an overturning fall (the FMU's fallTime), so that a
sliding or lift-off during the fall is told from one that happened while the outcome was
open (docs/contact.md).

Revision ID: 0009
Revises: 0008
"""
import sqlalchemy as sa
from alembic import op

revision = "0009"
down_revision = "0008"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("run_summaries") as batch:
        batch.add_column(sa.Column("fall_time", sa.Float))


def downgrade() -> None:
    with op.batch_alter_table("run_summaries") as batch:
        batch.drop_column("fall_time")
