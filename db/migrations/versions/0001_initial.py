"""The first schema: blocks, excitations, scenes, sweeps, runs, run summaries and series.

Revision ID: 0001
Revises:
"""
import sqlalchemy as sa
from alembic import op

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None

TZ = sa.DateTime(timezone=True)


def upgrade() -> None:
    op.create_table(
        "blocks",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("name", sa.String(100), nullable=False, unique=True),
        sa.Column("half_width", sa.Float, nullable=False),
        sa.Column("half_height", sa.Float, nullable=False),
        sa.Column("mass", sa.Float, nullable=False),
        sa.Column("material", sa.String(100)),
        sa.Column("restitution_law", sa.String(20), nullable=False),
        sa.Column("k", sa.Float),
        sa.Column("k_size_average", sa.Float),
        sa.Column("eta", sa.Float),
        sa.Column("correction", sa.Float, nullable=False),
        sa.Column("source", sa.Text),
    )
    op.create_table(
        "excitations",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("kind", sa.String(20), nullable=False),
        *[sa.Column(c, sa.Float) for c in ("amplitude", "frequency", "cycles", "start_time",
                                           "vertical_amplitude", "displacement")],
        sa.Column("series", sa.LargeBinary),
        sa.Column("series_dt", sa.Float),
    )
    op.create_table(
        "scenes",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("name", sa.String(200), nullable=False),
        sa.Column("n_blocks", sa.Integer, nullable=False),
        sa.Column("block1_id", sa.Integer, sa.ForeignKey("blocks.id")),
        sa.Column("block2_id", sa.Integer, sa.ForeignKey("blocks.id")),
        sa.Column("parameters", sa.JSON, nullable=False),
        sa.Column("source", sa.Text),
        sa.Column("created_at", TZ, nullable=False),
    )
    op.create_table(
        "sweeps",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("scene_id", sa.Integer, sa.ForeignKey("scenes.id"), nullable=False),
        sa.Column("grid", sa.JSON, nullable=False),
        sa.Column("total", sa.Integer, nullable=False),
        sa.Column("done", sa.Integer, nullable=False),
        sa.Column("status", sa.String(20), nullable=False),
        sa.Column("created_at", TZ, nullable=False),
    )
    op.create_table(
        "runs",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("scene_id", sa.Integer, sa.ForeignKey("scenes.id"), nullable=False),
        sa.Column("excitation_id", sa.Integer, sa.ForeignKey("excitations.id")),
        sa.Column("sweep_id", sa.Integer, sa.ForeignKey("sweeps.id")),
        sa.Column("grid_index", sa.Integer),
        sa.Column("model", sa.String(100), nullable=False),
        sa.Column("method", sa.String(50), nullable=False),
        sa.Column("rel_tol", sa.Float),
        sa.Column("abs_tol", sa.Float),
        sa.Column("stop_time", sa.Float, nullable=False),
        sa.Column("fmu_sha256", sa.String(64)),
        sa.Column("code_version", sa.String(40), nullable=False),
        sa.Column("wall_time", sa.Float),
        sa.Column("status", sa.String(10), nullable=False),
        sa.Column("error_message", sa.Text),
        sa.Column("created_at", TZ, nullable=False),
        sa.UniqueConstraint("sweep_id", "grid_index", name="one_run_per_grid_point"),
    )
    op.create_table(
        "run_summaries",
        sa.Column("run_id", sa.Integer, sa.ForeignKey("runs.id"), primary_key=True),
        sa.Column("peak1_over_alpha", sa.Float),
        sa.Column("peak2_over_alpha", sa.Float),
        sa.Column("overturned", sa.Boolean, nullable=False),
        sa.Column("overturned_blocks", sa.String(10)),
        sa.Column("overturn_time", sa.Float),
        sa.Column("impacts", sa.Integer),
        sa.Column("impacts_ground", sa.Integer),
        sa.Column("impacts_interface", sa.Integer),
        sa.Column("rest_time", sa.Float),
    )
    op.create_table(
        "run_series",
        sa.Column("run_id", sa.Integer, sa.ForeignKey("runs.id"), primary_key=True),
        sa.Column("names", sa.JSON, nullable=False),
        sa.Column("n_samples", sa.Integer, nullable=False),
        sa.Column("data", sa.LargeBinary, nullable=False),
    )


def downgrade() -> None:
    for table in ("run_series", "run_summaries", "runs", "sweeps", "scenes", "excitations", "blocks"):
        op.drop_table(table)
