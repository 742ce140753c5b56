"""Experiment database: schema (schema.py), engine and sessions (session.py),
migrations (migrations/, Alembic) and the shipped block catalogue (catalogue.py)."""
