"""The service feeds the cutoff predictor from its stored models (app/ingest/describing.py)."""

from __future__ import annotations

import uuid
from pathlib import Path
from typing import Any

import pytest
from sqlalchemy.orm import Session, sessionmaker

from app.db.migrate import upgrade
from app.db.models import Model
from app.db.session import make_engine, make_session_factory
from app.ingest.describing import CutoffPredictorCache, descriptor_version
from app.jobs.worker import describe_handler
from app.settings import engine_settings
from tests.conftest import make_settings

PART = Path(__file__).parents[1] / "fixtures" / "parts" / "teapot.stl"


@pytest.fixture
def sessions(database_url: str) -> sessionmaker[Session]:
    engine = make_engine(database_url)
    upgrade(engine)
    return make_session_factory(engine)


def store(sessions: sessionmaker[Session], columns: dict[str, Any], status: str = "ready") -> None:
    with sessions.begin() as session:
        session.add(
            Model(
                id=uuid.uuid4(),
                tenant="t",
                meta={},
                status=status,
                file_name="part.stl",
                file_size=1,
                file_sha256="0" * 64,
                file_format="stl",
                **columns,
            )
        )


def record(n: int, features: list[float]) -> dict[str, Any]:
    return {"mode": "adaptive", "n": n, "features": features, "solver_calls": 2}


def test_predictor_learns_only_from_ready_models_of_its_version(sessions) -> None:
    cache = CutoffPredictorCache(sessions, "v1", refresh_seconds=3600)
    assert cache.predictor() is None  # empty database: the seed round
    store(sessions, {"cutoff": record(150, [1.0, 0.0]), "descriptor_version": "v1"})
    store(sessions, {"cutoff": record(400, [1.0, 0.0]), "descriptor_version": "v2"})
    store(sessions, {"cutoff": record(90, [1.0, 0.0]), "descriptor_version": "v1"}, "failed")
    store(sessions, {"cutoff": {"mode": "fixed", "n": 300, "solver_calls": 1},
                     "descriptor_version": "v1"})
    predictor = cache.predictor()  # a young catalogue refits on every call
    assert predictor is not None and predictor.n_samples_ == 1
    assert predictor.predict([1.0, 0.0]) == 150


@pytest.mark.slow
def test_worker_predicts_from_the_stored_models_and_keeps_n(database_url, sessions) -> None:
    settings = make_settings(database_url)
    handle = describe_handler(settings, sessions)
    content = PART.read_bytes()
    first = handle(content, PART.name)
    assert first["cutoff"]["prediction"] is None  # nothing stored yet: seeded
    assert first["cutoff"]["solver_calls"] >= 2 and len(first["cutoff"]["features"]) == 4
    assert first["descriptor_version"] == descriptor_version(engine_settings(settings))
    store(sessions, first)
    second = handle(content, PART.name)
    assert second["cutoff"]["prediction"] == first["cutoff"]["n"]
    assert second["cutoff"]["prediction_held"] is True
    assert second["cutoff"]["solver_calls"] == 1
    assert second["cutoff"]["n"] == first["cutoff"]["n"]
    assert second["descriptor"] == first["descriptor"]
