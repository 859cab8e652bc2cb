"""The search tests' index, on either backend: ``make_index`` is ``ShapeIndex`` with
``backend`` set by the ``index_backend`` parameter (``faiss``; ``milvus`` on a milvus-lite
file of the test's own, skipped where pymilvus is not installed but never on CI)."""

from __future__ import annotations

import importlib.util
import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from sqlalchemy.orm import Session, sessionmaker

from app.search.index import ShapeIndex

MakeIndex = Callable[..., ShapeIndex]


def milvus_missing() -> str | None:
    """Why the Milvus cases cannot run here, or None (on CI they must: a failure then)."""
    if importlib.util.find_spec("pymilvus") and importlib.util.find_spec("milvus_lite"):
        return None
    if os.environ.get("CI") == "true":
        pytest.fail("CI runs the Milvus backend's tests: install the milvus extra")
    return "pymilvus and milvus-lite are not installed (the milvus extra)"


@pytest.fixture(params=["faiss", "milvus"])
def index_backend(request: pytest.FixtureRequest) -> str:
    backend: str = request.param
    if backend == "milvus" and (reason := milvus_missing()):
        pytest.skip(reason)
    return backend


@pytest.fixture
def make_index(index_backend: str, tmp_path: Path) -> Iterator[MakeIndex]:
    """``ShapeIndex(sessions, **options)`` on the test's backend; the Milvus ones share one
    milvus-lite file, as processes share one Milvus."""
    made: list[ShapeIndex] = []

    def make(sessions: sessionmaker[Session] | None, **options: Any) -> ShapeIndex:
        if index_backend == "milvus":
            options = {"backend": "milvus", "milvus_uri": str(tmp_path / "milvus.db"),
                       **options}
        index = ShapeIndex(sessions, **options)
        made.append(index)
        return index

    yield make
    for index in made:
        index.close()
