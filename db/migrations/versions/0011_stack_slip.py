"""Run summaries of rocking–sliding stacks (nBlocks = 2, contact.model = 1): block 2's contact
with block 1 (its motion class, peak and residual slip along block 1's top in m, the time it spent
sliding and its first slide in s) and whether and when it fell off block 1 (s). The existing
motion and slip columns are block 1's on the ground. None for one block and for rigid rocking.

Revision ID: 0011
Revises: 0010
"""
import sqlalchemy as sa
from alembic import op

revision = "0011"
down_revision = "0010"
branch_labels = None
depends_on = None

COLUMNS = [("block2_motion", sa.String(12)), ("block2_max_abs_slip", sa.Float), ("block2_residual_slip", sa.Float),
           ("block2_slide_duration", sa.Float), ("block2_slide_time", sa.Float), ("block2_fell_off", sa.Boolean),
           ("block2_fell_off_time", sa.Float)]


def upgrade() -> None:
    with op.batch_alter_table("run_summaries") as batch:
        for name, kind in COLUMNS:
            batch.add_column(sa.Column(name, kind))


def downgrade() -> None:
    with op.batch_alter_table("run_summaries") as batch:
        for name, _ in reversed(COLUMNS):
            batch.drop_column(name)
