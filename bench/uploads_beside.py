"""What an operation costs the uploads written beside it: an upload's transaction (its
model, then its job, the write first as every write transaction of the service begins on
SQLite) in a loop in another thread while the operation runs. Shared by
``bench/history_retention.py`` and ``bench/webhook_recover.py``."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import TypeVar

from sqlalchemy.orm import Session, sessionmaker

from app.db.models import Model
from app.jobs.turns import queue_job

__all__ = ["beside_uploads", "upload_once"]

Result = TypeVar("Result")


def upload_once(sessions: sessionmaker[Session]) -> float:
    """Seconds of one upload's transaction."""
    started = time.perf_counter()
    with sessions.begin() as session:
        model = Model(tenant="writer", meta={}, status="queued", file_name="a.stl",
                      file_size=1, file_sha256="0" * 64, file_format="stl")
        session.add(model)
        session.flush()
        queue_job(session, tenant="writer", model_id=model.id)
    return time.perf_counter() - started


def beside_uploads(
    sessions: sessionmaker[Session], run: Callable[[], Result]
) -> tuple[Result, float, list[float]]:
    """``run()``'s result and seconds, and the seconds of each upload written meanwhile."""
    during: list[float] = []
    done = threading.Event()

    def uploads() -> None:
        while not done.is_set():
            during.append(upload_once(sessions))
            time.sleep(0.005)

    thread = threading.Thread(target=uploads)
    thread.start()
    started = time.perf_counter()
    try:
        result = run()
    finally:
        seconds = time.perf_counter() - started
        done.set()
        thread.join()
    return result, seconds, during
