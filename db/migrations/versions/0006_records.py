"""Records as first-class excitations: a records table (samples, provenance, intensity
measures); an excitation refers to a record and a scale, and names the new pulse shapes.
Recorded excitations stored by earlier versions (ground and table motions imported with
import-measured) become records; their intensity measures are computed on first use.

Revision ID: 0006
Revises: 0005
"""
import hashlib
import zlib

import numpy as np
import sqlalchemy as sa
from alembic import op

revision = "0006"
down_revision = "0005"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "records",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("name", sa.String(200), nullable=False, unique=True),
        sa.Column("suite", sa.String(100)),
        sa.Column("event", sa.String(200)),
        sa.Column("year", sa.Integer),
        sa.Column("magnitude", sa.Float),
        sa.Column("station", sa.String(200)),
        sa.Column("distance_km", sa.Float),
        sa.Column("component", sa.String(100)),
        sa.Column("source", sa.Text),
        sa.Column("meta", sa.JSON),
        sa.Column("file_name", sa.Text),
        sa.Column("names", sa.JSON, nullable=False),
        sa.Column("n_samples", sa.Integer, nullable=False),
        sa.Column("data", sa.LargeBinary, nullable=False),
        sa.Column("sha256", sa.String(64), nullable=False),
        sa.Column("dt", sa.Float, nullable=False),
        sa.Column("duration", sa.Float, nullable=False),
        sa.Column("pga", sa.Float),
        sa.Column("pgv", sa.Float),
        sa.Column("pgd", sa.Float),
        sa.Column("arias", sa.Float),
        sa.Column("d5_95", sa.Float),
        sa.Column("mean_period", sa.Float),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
    )
    op.create_index("ix_records_suite", "records", ["suite"])
    with op.batch_alter_table("excitations") as batch:
        batch.alter_column("kind", type_=sa.String(30), existing_type=sa.String(20), existing_nullable=False)
        batch.add_column(sa.Column("gamma", sa.Float))
        batch.add_column(sa.Column("phase", sa.Float))
        batch.add_column(sa.Column("record_id", sa.Integer))
        batch.add_column(sa.Column("scale", sa.Float))
        batch.create_foreign_key("fk_excitations_record_id", "records", ["record_id"], ["id"])
        batch.create_index("ix_excitations_record_id", ["record_id"])

    conn = op.get_bind()
    rows = conn.execute(sa.text(
        "SELECT e.id, e.series, m.id, m.name, m.source, m.file_name, m.created_at FROM excitations e "
        "LEFT JOIN measurements m ON m.excitation_id = e.id AND m.kind NOT IN ('peaks', 'rotation') "
        "WHERE e.kind = 'recorded' AND e.series IS NOT NULL ORDER BY e.id")).all()
    seen: set[int] = set()
    for eid, blob, mid, mname, msource, mfile, created in rows:
        if eid in seen:  # two measurements on one excitation: one record
            continue
        seen.add(eid)
        raw = zlib.decompress(blob)
        data = np.frombuffer(raw, "<f8").reshape(2, -1)
        t = data[0]
        name = (f"measurement {mid}: {mname}" if mid is not None else f"excitation {eid}")[:200]
        rid = conn.execute(sa.text(
            "INSERT INTO records (name, source, file_name, names, n_samples, data, sha256, dt, duration, created_at) "
            "VALUES (:name, :source, :file, :names, :n, :data, :sha, :dt, :duration, :created) RETURNING id"),
            {"name": name, "source": msource, "file": mfile, "names": '["ah"]', "n": int(t.size), "data": blob,
             "sha": hashlib.sha256(raw).hexdigest(), "dt": float(np.min(np.diff(t))) if t.size > 1 else 0.0,
             "duration": float(t[-1] - t[0]), "created": created or "1970-01-01"}).scalar_one()
        conn.execute(sa.text("UPDATE excitations SET kind = 'record', record_id = :rid, scale = 1.0 WHERE id = :eid"),
                     {"rid": rid, "eid": eid})
    with op.batch_alter_table("excitations") as batch:
        batch.drop_column("series")
        batch.drop_column("series_dt")


def downgrade() -> None:
    with op.batch_alter_table("excitations") as batch:
        batch.add_column(sa.Column("series", sa.LargeBinary))
        batch.add_column(sa.Column("series_dt", sa.Float))
    conn = op.get_bind()
    conn.execute(sa.text(
        "UPDATE excitations SET kind = 'recorded', series = (SELECT data FROM records WHERE records.id = "
        "excitations.record_id), series_dt = (SELECT dt FROM records WHERE records.id = excitations.record_id) "
        "WHERE record_id IS NOT NULL"))
    with op.batch_alter_table("excitations") as batch:
        batch.drop_index("ix_excitations_record_id")
        batch.drop_constraint("fk_excitations_record_id", type_="foreignkey")
        for c in ("scale", "record_id", "phase", "gamma"):
            batch.drop_column(c)
        batch.alter_column("kind", type_=sa.String(20), existing_type=sa.String(30), existing_nullable=False)
    op.drop_index("ix_records_suite", "records")
    op.drop_table("records")
