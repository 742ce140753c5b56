"""Run summaries of rocking–sliding runs (contact.model = 1): the motion class
(rests, slides, rocks, slide-rocks, overturns; runners.engine.motion), the peak and residual
slip of block 1 (m) and the time it spent sliding (s). None for rigid-rocking runs.

Revision ID: 0010
Revises: 0009
"""
import sqlalchemy as sa
from alembic import op

revision = "0010"
down_revision = "0009"
branch_labels = None
depends_on = None

COLUMNS = [("motion", sa.String(12)), ("max_abs_slip", sa.Float), ("residual_slip", sa.Float),
           ("slide_duration", sa.Float)]


def upgrade() -> None:
    with op.batch_alter_table("run_summaries") as batch:
        for name, kind in COLUMNS:
            batch.add_column(sa.Column(name, kind))


def downgrade() -> None:
    with op.batch_alter_table("run_summaries") as batch:
        for name, _ in reversed(COLUMNS):
            batch.drop_column(name)
