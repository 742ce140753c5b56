"""The catalogue's blocks from Anagnostopoulos's thesis are named after it
(anagnostopoulos-block1..4) instead of the file number of a source document.

Revision ID: 0007
Revises: 0006
"""
import sqlalchemy as sa
from alembic import op

revision = "0007"
down_revision = "0006"
branch_labels = None
depends_on = None

RENAMES = [(f"seed000-block{i}", f"anagnostopoulos-block{i}") for i in range(1, 5)]


def upgrade() -> None:
    blocks = sa.table("blocks", sa.column("name", sa.String))
    conn = op.get_bind()
    for old, new in RENAMES:  # a block already under the new name keeps it; the old one stays as it is
        taken = conn.execute(sa.select(sa.func.count()).select_from(blocks).where(blocks.c.name == new)).scalar()
        if not taken:
            conn.execute(blocks.update().where(blocks.c.name == old).values(name=new))


def downgrade() -> None:
    blocks = sa.table("blocks", sa.column("name", sa.String))
    for old, new in RENAMES:
        op.get_bind().execute(blocks.update().where(blocks.c.name == new).values(name=old))
