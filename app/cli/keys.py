"""``shapesearch keys create --tenant NAME | list | revoke PREFIX``."""

from __future__ import annotations

import sys

from app.auth.keys import create_key, list_keys, revoke_key
from app.db.session import open_sessions
from app.settings import Settings

__all__ = ["create", "list_all", "revoke"]


def create(tenant: str) -> int:
    """Print a new key for ``tenant`` once (it is not stored, only its digest)."""
    try:
        with open_sessions(Settings().resolved_database_url).begin() as session:
            token = create_key(session, tenant)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(token)
    print(
        f"API key for tenant {tenant.strip()!r}; store it now, it is not shown again. "
        "Send it as 'Authorization: Bearer <key>'.",
        file=sys.stderr,
    )
    return 0


def list_all() -> int:
    """One line per key: prefix, tenant, created."""
    with open_sessions(Settings().resolved_database_url)() as session:
        rows = list_keys(session)
    print(f"{'PREFIX':<16} {'TENANT':<30} CREATED")
    for row in rows:
        created = row.created_at.isoformat(timespec="seconds")
        print(f"ss_{row.prefix:<13} {row.tenant:<30} {created}")
    return 0


def revoke(prefix: str) -> int:
    """Delete the keys with this prefix: they stop working at once."""
    with open_sessions(Settings().resolved_database_url).begin() as session:
        count = revoke_key(session, prefix)
    if count == 0:
        print(f"error: no key with prefix {prefix!r} (see `shapesearch keys list`)",
              file=sys.stderr)
        return 1
    print(f"revoked {count} key(s) with prefix {prefix}", file=sys.stderr)
    return 0
