"""API keys: creating, listing and revoking them, and the lookup behind ``Bearer``
(the commands are ``shapesearch keys ...``, ``app.cli.keys``).

A key is ``ss_`` + a 12-hex-digit public prefix + a 256-bit random secret. The database
keeps the prefix (to find the row) and the SHA-256 of the whole key; a salt adds nothing
to a random 256-bit secret. Comparison is constant-time.
"""

from __future__ import annotations

import hashlib
import hmac
import secrets

from sqlalchemy import delete, exists, select
from sqlalchemy.orm import Session

from app.db.models import ApiKey
from app.db.session import rows_changed

__all__ = [
    "DEFAULT_TENANT",
    "create_key",
    "keys_exist",
    "list_keys",
    "revoke_key",
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



def list_keys(session: Session) -> list[ApiKey]:
    """Every key's row (prefix, tenant, creation time), oldest first; never the secret."""
    return list(session.scalars(select(ApiKey).order_by(ApiKey.created_at, ApiKey.prefix)))


def revoke_key(session: Session, prefix: str) -> int:
    """Delete the keys with this public prefix (``ss_`` optional); returns how many."""
    prefix = prefix.strip().removeprefix("ss_")[:_PREFIX_LEN]
    if len(prefix) != _PREFIX_LEN:
        return 0
    result = session.execute(delete(ApiKey).where(ApiKey.prefix == prefix))
    return rows_changed(result)

