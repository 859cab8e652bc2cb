"""Endpoint secrets in the Standard Webhooks form (``whsec_`` + base64)."""

from __future__ import annotations

import base64
import secrets

__all__ = ["new_secret", "valid_secret"]


def new_secret() -> str:
    """A Standard Webhooks secret: ``whsec_`` + base64 of 24 random bytes."""
    return "whsec_" + base64.b64encode(secrets.token_bytes(24)).decode()


def valid_secret(secret: str) -> bool:
    """True if ``secret`` is ``whsec_``-prefixed (or bare) base64 of at least 16 bytes."""
    try:
        raw = base64.b64decode(secret.removeprefix("whsec_") + "==", validate=False)
    except ValueError:
        return False
    return len(raw) >= 16
