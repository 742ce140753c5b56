"""Columns of 3 to 8 blocks (nBlocks 3 to 8): each block's outcome in a new table run_blocks (one
row per run and block: peak |theta| in rad and over its alpha, peak and residual slip on what it
stands on in m, overturned, fell off, final contact mode), and the column's outcome in four new
columns of run_summaries (collapsed, the lowest block that fell, the largest residual slip of a
standing block in m and its block). Only adds: every stored row stays as it was, None in the new
columns (runs of one and two blocks keep their outcomes where they were).

Revision ID: 0014
Revises: 0013
"""
import sqlalchemy as sa
from alembic import op

revision = "0014"
down_revision = "0013"
branch_labels = None
depends_on = None

COLUMNS = [("collapsed", sa.Boolean), ("lowest_fallen", sa.Integer), ("max_residual_slip", sa.Float),
           ("max_residual_slip_block", sa.Integer)]


def upgrade() -> None:
    with op.batch_alter_table("run_summaries") as batch:
        for name, kind in COLUMNS:
            batch.add_column(sa.Column(name, kind))
    op.create_table(
        "run_blocks",
        sa.Column("run_id", sa.Integer, sa.ForeignKey("runs.id"), primary_key=True),
        sa.Column("block", sa.Integer, primary_key=True),
        sa.Column("max_abs_theta", sa.Float, nullable=False),
        sa.Column("peak_over_alpha", sa.Float),
        sa.Column("max_abs_slip", sa.Float),
        sa.Column("residual_slip", sa.Float),
        sa.Column("overturned", sa.Boolean, nullable=False),
        sa.Column("fell_off", sa.Boolean, nullable=False),
        sa.Column("final_mode", sa.String(12)),
    )


def downgrade() -> None:
    op.drop_table("run_blocks")
    with op.batch_alter_table("run_summaries") as batch:
        for name, _ in reversed(COLUMNS):
            batch.drop_column(name)
