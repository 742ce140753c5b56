"""Co-simulated runs (runners cosim): the system that ran (its file's text and sha256, the
building, the blocks' floor, the blocks' and the building's parameters as run, the base record,
its scale and the sha256 of the file the building read), the engine, the coupling, the
communication step and stop time (s), the run's summary, the FMUs' sha256, the code version and
wall time (s); and their series, every output at every communication point, packed as
run_series packs a simulated run's. The runs' ids are never reused after a delete (an
AUTOINCREMENT table in SQLite, as sweeps since 0012: a new table, so nothing to rebuild).

Revision ID: 0013
Revises: 0012
"""
import sqlalchemy as sa
from alembic import op

revision = "0013"
down_revision = "0012"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "cosim_runs",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("name", sa.String(200), nullable=False),
        sa.Column("source", sa.Text),
        sa.Column("source_sha256", sa.String(64)),
        sa.Column("source_file", sa.Text),
        sa.Column("engine", sa.String(20), nullable=False),
        sa.Column("coupling", sa.String(10), nullable=False),
        sa.Column("step", sa.Float, nullable=False),
        sa.Column("stop_time", sa.Float, nullable=False),
        sa.Column("storeys", sa.Integer, nullable=False),
        sa.Column("floor", sa.Integer, nullable=False),
        sa.Column("system", sa.JSON, nullable=False),
        sa.Column("block_parameters", sa.JSON, nullable=False),
        sa.Column("building_parameters", sa.JSON, nullable=False),
        sa.Column("record_id", sa.Integer, sa.ForeignKey("records.id")),
        sa.Column("base_scale", sa.Float, nullable=False),
        sa.Column("base_sha256", sa.String(64)),
        sa.Column("summary", sa.JSON),
        sa.Column("block_fmu_sha256", sa.String(64)),
        sa.Column("building_fmu_sha256", sa.String(64)),
        sa.Column("code_version", sa.String(40), nullable=False),
        sa.Column("wall_time", sa.Float),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sqlite_autoincrement=True,
    )
    op.create_index("ix_cosim_runs_record_id", "cosim_runs", ["record_id"])
    op.create_table(
        "cosim_series",
        sa.Column("run_id", sa.Integer, sa.ForeignKey("cosim_runs.id"), primary_key=True),
        sa.Column("names", sa.JSON, nullable=False),
        sa.Column("n_samples", sa.Integer, nullable=False),
        sa.Column("data", sa.LargeBinary, nullable=False),
    )


def downgrade() -> None:
    op.drop_table("cosim_series")
    op.drop_index("ix_cosim_runs_record_id", table_name="cosim_runs")
    op.drop_table("cosim_runs")
