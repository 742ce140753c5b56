"""Sweep ids are never reused. SQLite gives a new row the id after the highest stored one, so
after ``runners db delete sweep N`` of the newest sweep the next sweep was N again, and figures,
recordings (recordings/sweep-N) and notes naming sweep N named another sweep. An AUTOINCREMENT
table's ids pass every id it ever gave (SQLite keeps the highest in sqlite_sequence), so the
sweeps table of an SQLite database is rebuilt as one: one small row per sweep, a cheap copy. (Ids
deleted before this revision are not known to it.) PostgreSQL's sequences never give an id twice:
nothing changes there. Runs and records keep SQLite's rule (docs/database.md): their tables can
be large, and rebuilding them on opening a database would not be cheap.

Revision ID: 0012
Revises: 0011
"""
from alembic import op

revision = "0012"
down_revision = "0011"
branch_labels = None
depends_on = None


def _rebuild_sweeps(autoincrement: bool) -> None:
    if op.get_bind().dialect.name != "sqlite":
        return
    with op.batch_alter_table("sweeps", recreate="always", table_kwargs={"sqlite_autoincrement": autoincrement}):
        pass


def upgrade() -> None:
    _rebuild_sweeps(True)


def downgrade() -> None:
    _rebuild_sweeps(False)
