"""The program library: SQLAlchemy models, migrations at start-up, and the Library API.

SQLite file in instance/ by default; any database DATABASE_URL names otherwise (PostgreSQL
for a shop server). Every entry point calls `open_library()`, which brings an empty or
older database up to date with the committed Alembic migrations before anything else.
"""
