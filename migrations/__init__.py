"""Alembic migrations, shipped inside the package so installed services can apply them."""
