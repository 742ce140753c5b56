"""Measured series (peak tables, rotation histories, table records, ground motions)
with their blocks, excitation and provenance.

Revision ID: 0005
Revises: 0004
"""
import sqlalchemy as sa
from alembic import op

revision = "0005"
down_revision = "0004"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "measurements",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("name", sa.String(200), nullable=False),
        sa.Column("kind", sa.String(30), nullable=False),
        sa.Column("block1_id", sa.Integer, sa.ForeignKey("blocks.id")),
        sa.Column("block2_id", sa.Integer, sa.ForeignKey("blocks.id")),
        sa.Column("excitation_id", sa.Integer, sa.ForeignKey("excitations.id")),
        sa.Column("source", sa.Text),
        sa.Column("instrument", sa.String(200)),
        sa.Column("sampling_rate", sa.Float),
        sa.Column("uncertainty_angle", sa.Float),
        sa.Column("uncertainty_time", sa.Float),
        sa.Column("uncertainty_value", sa.Float),
        sa.Column("units", sa.JSON, nullable=False),
        sa.Column("sign", sa.String(40), nullable=False),
        sa.Column("file_name", sa.Text),
        sa.Column("file_sha256", sa.String(64)),
        sa.Column("names", sa.JSON, nullable=False),
        sa.Column("n_samples", sa.Integer, nullable=False),
        sa.Column("data", sa.LargeBinary, nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
    )


def downgrade() -> None:
    op.drop_table("measurements")
