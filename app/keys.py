"""API keys: ``shapesearch keys create --tenant NAME`` and the lookup behind ``Bearer``.

A key is ``ss_`` + a 12-hex-digit public prefix + a 256-bit random secret. The database
keeps the prefix (to find the row) and the SHA-256 of the whole key; a salt adds nothing
to a random 256-bit secret. Comparison is constant-time.
"""

from __future__ import annotations

import hashlib
import hmac
import secrets
import sys

from sqlalchemy import delete, exists, select
from sqlalchemy.orm import Session

from app.db.models import ApiKey

__all__ = [
    "DEFAULT_TENANT",
    "create_key",
    "create_key_command",
    "keys_exist",
    "list_keys",
    "list_keys_command",
    "revoke_key",
    "revoke_key_command",
    "tenant_for_key",
]

DEFAULT_TENANT = "default"  # the one tenant of a service without keys
_PREFIX_LEN = 12


def _digest(token: str) -> str:
    return hashlib.sha256(token.encode()).hexdigest()


def create_key(session: Session, tenant: str) -> str:
    """Store a new key for ``tenant`` and return it; it cannot be recovered later."""
    tenant = tenant.strip()
    if not tenant or len(tenant) > 200:
        raise ValueError("tenant must be 1 to 200 characters")
    prefix = secrets.token_hex(_PREFIX_LEN // 2)
    token = f"ss_{prefix}{secrets.token_urlsafe(32)}"
    session.add(ApiKey(tenant=tenant, prefix=prefix, key_sha256=_digest(token)))
    return token


def tenant_for_key(session: Session, token: str) -> str | None:
    """The tenant of ``token``, or None if it is not a valid key."""
    if not token.startswith("ss_") or len(token) < 3 + _PREFIX_LEN + 16:
        return None
    prefix = token[3 : 3 + _PREFIX_LEN]
    digest = _digest(token)
    tenant = None
    for row in session.scalars(select(ApiKey).where(ApiKey.prefix == prefix)):
        if hmac.compare_digest(row.key_sha256, digest):
            tenant = row.tenant
    return tenant


def keys_exist(session: Session) -> bool:
    return bool(session.scalar(select(exists().where(ApiKey.id.is_not(None)))))


def create_key_command(tenant: str) -> int:
    """``shapesearch keys create``: print the new key once."""
    from app.db.migrate import upgrade
    from app.db.session import make_engine, make_session_factory
    from app.settings import Settings

    engine = make_engine(Settings().resolved_database_url)
    upgrade(engine)
    try:
        with make_session_factory(engine).begin() as session:
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


def list_keys(session: Session) -> list[ApiKey]:
    """Every key's row (prefix, tenant, creation time), oldest first; never the secret."""
    return list(session.scalars(select(ApiKey).order_by(ApiKey.created_at, ApiKey.prefix)))


def revoke_key(session: Session, prefix: str) -> int:
    """Delete the keys with this public prefix (``ss_`` optional); returns how many."""
    prefix = prefix.strip().removeprefix("ss_")[:_PREFIX_LEN]
    if len(prefix) != _PREFIX_LEN:
        return 0
    result = session.execute(delete(ApiKey).where(ApiKey.prefix == prefix))
    return int(result.rowcount or 0)


def _sessions():  # type: ignore[no-untyped-def]
    from app.db.migrate import upgrade
    from app.db.session import make_engine, make_session_factory
    from app.settings import Settings

    engine = make_engine(Settings().resolved_database_url)
    upgrade(engine)
    return make_session_factory(engine)


def list_keys_command() -> int:
    """``shapesearch keys list``: one line per key: prefix, tenant, created."""
    with _sessions()() as session:
        rows = list_keys(session)
    print(f"{'PREFIX':<16} {'TENANT':<30} CREATED")
    for row in rows:
        created = row.created_at.isoformat(timespec="seconds")
        print(f"ss_{row.prefix:<13} {row.tenant:<30} {created}")
    return 0


def revoke_key_command(prefix: str) -> int:
    """``shapesearch keys revoke PREFIX``: the key stops working at once."""
    with _sessions().begin() as session:
        count = revoke_key(session, prefix)
    if count == 0:
        print(f"error: no key with prefix {prefix!r} (see `shapesearch keys list`)",
              file=sys.stderr)
        return 1
    print(f"revoked {count} key(s) with prefix {prefix}", file=sys.stderr)
    return 0
