"""Stored series keep the run's events (impacts, uplift, rest, ...), so a recording
written later from the database shows them.

Revision ID: 0004
Revises: 0003
"""
import sqlalchemy as sa
from alembic import op

revision = "0004"
down_revision = "0003"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("run_series") as batch:
        batch.add_column(sa.Column("events", sa.JSON))


def downgrade() -> None:
    with op.batch_alter_table("run_series") as batch:
        batch.drop_column("events")
