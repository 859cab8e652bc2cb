"""Database layer: tables, engine/session factory, migrations at start-up."""
