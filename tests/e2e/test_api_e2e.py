"""End to end with the real engine, on SQLite and PostgreSQL: real parts are uploaded and
described by the embedded workers, then searched.

One library of parts per backend is described once (module scope) and shared by the tests,
because describing is the expensive step; tests that delete use copies of their own.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh
from fastapi.testclient import TestClient

from app.api.main import create_app
from tests.conftest import (
    EDGE_CASES,
    PARTS,
    _Postgres,
    _require,
    make_settings,
    upload,
    wait_for_status,
)

LIBRARY = [
    "20mm-xyz-cube.stl",
    "angle_block.STL",
    "cylinder.stl",
    "plate_holes.STL",
    "round.stl",
    "teapot.stl",
]
COPIES = ["copy-a", "copy-b"]  # duplicates of the cube, deleted by the tests
DESCRIBE_TIMEOUT = 300.0


@dataclass
class Library:
    client: TestClient
    database_url: str
    ids: dict[str, str]  # external id -> model id

    def new_instance(self) -> TestClient:
        """A second API process over the same database (no worker of its own)."""
        app = create_app(make_settings(self.database_url, workers=0))
        return TestClient(app, raise_server_exceptions=False)


@pytest.fixture(scope="module", params=["sqlite", "postgresql"])
def library(
    request: pytest.FixtureRequest,
    tmp_path_factory: pytest.TempPathFactory,
    postgres: _Postgres | None,
) -> Iterator[Library]:
    if request.param == "sqlite":
        url = f"sqlite:///{tmp_path_factory.mktemp('e2e') / 'shapesearch.db'}"
    else:
        url = _require(postgres).new_database()
    app = create_app(make_settings(url, workers=2), embedded_worker=True)
    with TestClient(app, raise_server_exceptions=False) as client:
        ids = {}
        for i, name in enumerate(LIBRARY):
            meta = json.dumps({"family": "ab"[i % 2], "file": name})
            response = upload(client, PARTS / name, external_id=name, metadata=meta)
            assert response.status_code == 202, response.text
            ids[name] = response.json()["id"]
        for copy in COPIES:
            response = upload(client, PARTS / LIBRARY[0], external_id=copy, metadata='{"c": 1}')
            ids[copy] = response.json()["id"]
        for model_id in ids.values():
            body = wait_for_status(client, model_id, timeout=DESCRIBE_TIMEOUT)
            assert body["status"] == "ready", body
        yield Library(client=client, database_url=url, ids=ids)


def similar(client: TestClient, model_id: str, **params: Any) -> list[dict[str, Any]]:
    response = client.get(f"/v1/models/{model_id}/similar", params=params)
    assert response.status_code == 200, response.text
    return response.json()["results"]


def transformed_copy(path: Path, file_type: str, seed: int) -> bytes:
    """The part rotated, moved and re-triangulated (so resampled), in another format."""
    mesh = trimesh.load(path, force="mesh")
    rng = np.random.default_rng(seed)
    mesh.apply_transform(trimesh.transformations.random_rotation_matrix(rng.random(3)))
    mesh.apply_translation(rng.normal(scale=50.0, size=3))
    mesh = mesh.subdivide()
    exported = mesh.export(file_type=file_type)  # OBJ comes back as text, PLY as bytes
    return exported.encode() if isinstance(exported, str) else bytes(exported)


@pytest.mark.slow
def test_described_models_carry_their_cutoff_and_timings(library: Library) -> None:
    body = library.client.get(f"/v1/models/{library.ids['angle_block.STL']}").json()
    assert body["status"] == "ready" and body["error"] is None
    cutoff = body["cutoff"]
    assert cutoff["mode"] == "adaptive" and cutoff["solver_calls"] >= 1
    assert cutoff["n_min"] <= cutoff["n"] <= cutoff["n_max"]
    assert cutoff["xi"] > 0 and cutoff["t"] > 0
    assert 100 <= body["n_points"] <= 1500
    assert body["descriptor_version"] and body["timings"]["total"] > 0
    assert library.client.get("/readyz").status_code == 200


@pytest.mark.slow
def test_an_identical_file_scores_one_and_the_query_is_left_out(library: Library) -> None:
    cube = library.ids[LIBRARY[0]]
    results = similar(library.client, cube, k=3)
    assert cube not in [r["model"]["id"] for r in results]
    top = results[0]
    assert top["model"]["external_id"] in COPIES
    assert top["score"] == pytest.approx(1.0, abs=1e-6) and top["distance"] < 1e-3


@pytest.mark.slow
def test_a_rotated_resampled_copy_finds_its_part_first(library: Library) -> None:
    client = library.client
    part = "angle_block.STL"
    copy = transformed_copy(PARTS / part, "ply", seed=7)
    response = client.post("/v1/models", files={"file": ("moved.ply", copy)})
    assert response.status_code == 202, response.text
    moved = wait_for_status(client, response.json()["id"], timeout=DESCRIBE_TIMEOUT)
    assert moved["status"] == "ready" and moved["file"]["format"] == "ply"
    results = similar(client, moved["id"], k=3)
    assert results[0]["model"]["external_id"] == part, results
    # The tests' small engine is a layout without a calibration (test_score_calibration.py
    # covers the default's).
    assert all(r["calibrated_score"] is None for r in results)
    assert client.delete(f"/v1/models/{moved['id']}").status_code == 204

    # The same through the synchronous search, from an OBJ export.
    scan = transformed_copy(PARTS / part, "obj", seed=11)
    found = client.post("/v1/search", params={"k": 3}, files={"file": ("scan.obj", scan)})
    assert found.status_code == 200, found.text
    body = found.json()
    assert body["results"][0]["model"]["external_id"] == part
    assert body["query"]["n_points"] > 0 and body["query"]["cutoff"]["mode"] == "adaptive"


@pytest.mark.slow
def test_metadata_filters_apply_before_the_top_k_cut(library: Library) -> None:
    query = library.ids["round.stl"]
    results = similar(library.client, query, k=2, **{"metadata.family": "a"})
    assert len(results) == 2
    assert all(r["model"]["metadata"]["family"] == "a" for r in results)


def test_a_new_app_instance_answers_the_same(library: Library) -> None:
    query = library.ids["cylinder.stl"]
    before = similar(library.client, query, k=20)
    with library.new_instance() as other:
        after = similar(other, query, k=20)
        assert other.get("/readyz").status_code == 200
    assert [r["model"]["id"] for r in after] == [r["model"]["id"] for r in before]
    assert [r["distance"] for r in after] == pytest.approx([r["distance"] for r in before])


def test_deletes_leave_results_here_at_once_and_elsewhere_via_the_feed(
    library: Library,
) -> None:
    client = library.client
    cube = library.ids[LIBRARY[0]]
    copy_a, copy_b = (library.ids[c] for c in COPIES)

    def result_ids(on: TestClient) -> set[str]:
        return {r["model"]["id"] for r in similar(on, cube, k=20)}

    def leaves(on: TestClient, model_id: str) -> None:
        """A process that did not delete ``model_id`` kept its answer (response_cache_seconds)
        until the feed's event reaches its index: then the kept answers go."""
        deadline = time.monotonic() + 5.0
        while model_id in result_ids(on):
            assert time.monotonic() < deadline
            time.sleep(0.05)

    with library.new_instance() as other:
        assert {copy_a, copy_b} <= result_ids(client) and {copy_a, copy_b} <= result_ids(other)
        assert client.delete(f"/v1/models/{copy_a}").status_code == 204  # this process
        assert copy_a not in result_ids(client)
        leaves(other, copy_a)
        assert other.delete(f"/v1/models/{copy_b}").status_code == 204  # another process
        assert copy_b not in result_ids(other)
        leaves(client, copy_b)
        assert client.get("/readyz").status_code == 200
        assert other.get("/readyz").status_code == 200


# What each edge case of the trimesh test corpus must become. Files that are broken beyond
# use are refused at upload with the engine's reason; files whose defect does not touch the
# geometry (a NaN in a vertex colour, one face with two indices among valid ones, odd
# whitespace, a mislabelled STL header) are described: refusing them would lose real parts.
EDGE_CASE_OUTCOMES = {
    "busted.STL": "ready",
    "empty.stl": "empty_file",
    "nancolor.obj": "ready",
    "notenoughindices.obj": "ready",
    "ply_empty_header.ply": "empty_file",
    "stl_empty_bin.stl": "empty_file",
    "whitespace.off": "ready",
}


@pytest.mark.slow
def test_edge_case_files_end_as_documented_and_the_worker_keeps_serving(
    library: Library,
) -> None:
    client = library.client
    assert {path.name for path in EDGE_CASES.iterdir()} == set(EDGE_CASE_OUTCOMES)
    accepted: dict[str, str] = {}
    for path in sorted(EDGE_CASES.iterdir()):
        response = upload(client, path)
        expected = EDGE_CASE_OUTCOMES[path.name]
        if expected == "ready":
            assert response.status_code == 202, (path.name, response.text)
            accepted[path.name] = response.json()["id"]
            continue
        assert response.status_code == 422, (path.name, response.text)
        assert response.headers["content-type"].startswith("application/problem+json")
        problem = response.json()
        assert problem["reason"] == expected and problem["detail"], path.name
    for name, model_id in accepted.items():
        body = wait_for_status(client, model_id, timeout=DESCRIBE_TIMEOUT)
        assert body["status"] == "ready" and body["error"] is None, (name, body)

    # The worker is still serving.
    good = upload(client, PARTS / "octagonal_pocket.stl").json()
    assert wait_for_status(client, good["id"], timeout=DESCRIBE_TIMEOUT)["status"] == "ready"


def test_search_refuses_bad_uploads_like_model_uploads(library: Library) -> None:
    client = library.client
    bad_format = client.post("/v1/search", files={"file": ("x.docx", b"\x00junk")})
    assert bad_format.status_code == 415
    empty = client.post("/v1/search", files={"file": ("x.stl", b"")})
    assert empty.status_code == 422
    assert empty.headers["content-type"].startswith("application/problem+json")
