"""The catalogue's blocks from Anagnostopoulos's thesis are named after it
(anagnostopoulos-block1..4). Databases made before this revision named them after
the number of a source document's file followed by "-blockN"; those rows are found
by that shape (LEGACY) and renamed.

Revision ID: 0007
Revises: 0006
"""
import re

import sqlalchemy as sa
from alembic import op

revision = "0007"
down_revision = "0006"
branch_labels = None
depends_on = None

LEGACY = re.compile(r"seed0{3}-block([1-4])")  # the old names: a document's file number, then the block


def upgrade() -> None:
    blocks = sa.table("blocks", sa.column("name", sa.String))
    conn = op.get_bind()
    names = set(conn.execute(sa.select(blocks.c.name)).scalars())
    for old in sorted(names):
        m = LEGACY.fullmatch(old)
        new = m and f"anagnostopoulos-block{m.group(1)}"
        if new and new not in names:  # a block already under the new name keeps it; the old one stays as it is
            conn.execute(blocks.update().where(blocks.c.name == old).values(name=new))
            names.add(new)


def downgrade() -> None:
    """The new names stay: writing a file number back into a block's name would only undo the
    point of this revision, and names are labels the earlier schema accepts as they are."""
