"""Run summaries record whether the rigid-rocking assumptions held (docs/contact.md):
the first sliding and lift-off times and the extremes of the contact monitors.

Revision ID: 0008
Revises: 0007
"""
import sqlalchemy as sa
from alembic import op

revision = "0008"
down_revision = "0007"
branch_labels = None
depends_on = None

COLUMNS = [("assumptions_held", sa.Boolean), ("slide_time", sa.Float), ("lift_time", sa.Float),
           ("friction_demand_max", sa.Float), ("normal_min", sa.Float), ("friction_demand_max_interface", sa.Float),
           ("normal_min_interface", sa.Float), ("impulse_demand_max", sa.Float)]


def upgrade() -> None:
    with op.batch_alter_table("run_summaries") as batch:
        for name, kind in COLUMNS:
            batch.add_column(sa.Column(name, kind))


def downgrade() -> None:
    with op.batch_alter_table("run_summaries") as batch:
        for name, _ in reversed(COLUMNS):
            batch.drop_column(name)
