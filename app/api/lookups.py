"""Looking up what a tenant owns: a model by id, or 404 (a tenant never learns whether
another tenant's model exists)."""

from __future__ import annotations

import uuid

from sqlalchemy import select
from sqlalchemy.orm import Session, undefer

from app.api.problems import Problem
from app.db.models import Model

__all__ = ["load_model", "model_not_found", "parse_model_id"]


def parse_model_id(text: str) -> uuid.UUID | None:
    """``text`` as a model id, or None when it is not a UUID (then no model has it)."""
    try:
        return uuid.UUID(text)
    except ValueError:
        return None


def model_not_found(model_id: str) -> Problem:
    """The 404 of a model id this tenant does not own (or that does not exist)."""
    return Problem("model-not-found", f"There is no model {model_id}.")


def load_model(session: Session, tenant: str, model_id: str, *, descriptor: bool = False) -> Model:
    """The tenant's model ``model_id``, or 404 (also for ids that are not UUIDs)."""
    parsed = parse_model_id(model_id)
    query = select(Model).where(Model.id == parsed, Model.tenant == tenant)
    if descriptor:
        query = query.options(undefer(Model.descriptor), undefer(Model.scan_descriptor))
    model = session.scalar(query) if parsed is not None else None
    if model is None:
        raise model_not_found(model_id)
    return model
