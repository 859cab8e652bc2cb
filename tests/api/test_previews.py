"""Model previews (app/ingest/previews.py, GET /v1/models/{id}/preview) and GET /v1/stats/cutoff."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

import app.api.routes.stats
from app.api.main import create_app
from app.db.models import Model
from app.db.session import make_engine, make_session_factory
from app.ingest.describing import model_columns
from app.ingest.previews import PREVIEW_POINTS, decode_preview, encode_preview, subsample
from app.settings import Settings, engine_settings
from core.pipeline import describe_points
from tests.conftest import (
    PARTS,
    SMALL_ENGINE,
    fake_describe,
    make_settings,
    upload,
    wait_for_status,
)
from tests.shapes import sphere_points, torus_points

CUBE = PARTS / "20mm-xyz-cube.stl"
ANGLE = PARTS / "angle_block.STL"
TIMES = np.geomspace(1e-3, 1e-1, 4)

# --- the blob ---------------------------------------------------------------------------


def test_preview_round_trip_keeps_a_fixed_subsample() -> None:
    rng = np.random.default_rng(1)
    points = rng.normal(size=(5000, 3))
    log_hks = rng.normal(size=(5000, TIMES.size))
    eigenvalues = np.arange(12.0)
    blob = encode_preview(points, log_hks, TIMES, eigenvalues)
    preview = decode_preview(blob)
    keep = subsample(5000)
    assert keep.size == PREVIEW_POINTS and np.all(np.diff(keep) > 0)
    np.testing.assert_allclose(preview.points, points[keep], rtol=1e-3, atol=1e-3)
    np.testing.assert_allclose(preview.log_hks, log_hks[keep], rtol=1e-3, atol=1e-3)
    np.testing.assert_allclose(preview.times, TIMES, rtol=1e-6)
    np.testing.assert_array_equal(preview.eigenvalues, eigenvalues)
    # float16 points and HKS: 2 bytes a value, plus the float32 grids and a 16-byte header.
    assert len(blob) == 16 + 4 * (TIMES.size + 12) + 2 * PREVIEW_POINTS * (3 + TIMES.size)
    assert encode_preview(points, log_hks, TIMES, eigenvalues) == blob


def test_small_clouds_keep_every_point_and_bad_blobs_are_refused() -> None:
    points = np.random.default_rng(2).normal(size=(300, 3))
    preview = decode_preview(encode_preview(points, np.zeros((300, 4)), TIMES, np.ones(3)))
    assert preview.points.shape == (300, 3) and preview.log_hks.shape == (300, 4)
    with pytest.raises(ValueError):
        encode_preview(points, np.zeros((300, 3)), TIMES, np.ones(3))
    blob = encode_preview(points, np.zeros((300, 4)), TIMES, np.ones(3))
    for bad in (b"", b"XXXX" + blob[4:], blob[:-2]):
        with pytest.raises(ValueError):
            decode_preview(bad)


def test_model_columns_store_the_descriptors_hks_at_the_preview_points() -> None:
    engine = engine_settings(Settings(**SMALL_ENGINE))
    description = describe_points(torus_points(3000), engine)
    times = engine.descriptor.hks_times
    preview = decode_preview(model_columns(description, times)["preview"])
    keep = subsample(description.n_points)
    assert preview.points.shape == (keep.size, 3)
    np.testing.assert_allclose(preview.points, description.points[keep], atol=2e-3, rtol=1e-3)
    expected = description.signature[keep, : len(times)]
    np.testing.assert_allclose(preview.log_hks, expected, atol=5e-3, rtol=1e-3)
    np.testing.assert_allclose(preview.times, times, rtol=1e-6)
    assert preview.eigenvalues.size == description.cutoff.n


def test_preview_hks_of_a_sphere_is_nearly_constant() -> None:
    """Every point of a sphere is alike: its scaled HKS is 1 (log 0) everywhere, at every
    time, up to the discretisation; a torus is not homogeneous and varies."""
    engine = engine_settings(Settings(**SMALL_ENGINE))
    times = engine.descriptor.hks_times
    sphere = decode_preview(model_columns(describe_points(sphere_points(1500), engine), times)[
        "preview"
    ])
    torus = decode_preview(model_columns(describe_points(torus_points(1500), engine), times)[
        "preview"
    ])
    middle = len(times) // 2
    sphere_spread = float(np.std(sphere.log_hks[:, middle].astype(float)))
    torus_spread = float(np.std(torus.log_hks[:, middle].astype(float)))
    assert abs(float(np.mean(sphere.log_hks[:, middle].astype(float)))) < 0.05
    assert sphere_spread < 0.05 < torus_spread


# --- the endpoints (instant fake describer, both backends) -------------------------------


def describe_with_preview(content: bytes, filename: str) -> dict[str, Any]:
    """``fake_describe`` plus a preview made from the content's hash, and a cutoff that
    depends on the file so that the statistics have something to count."""
    columns = fake_describe(content, filename)
    rng = np.random.default_rng(len(content))
    columns["preview"] = encode_preview(
        rng.normal(size=(50, 3)), rng.normal(size=(50, 4)), TIMES, np.arange(10.0)
    )
    columns["n_points"] = len(content) % 1000 + 100
    columns["cutoff"] = {**columns["cutoff"], "solver_calls": 2 + len(content) % 2}
    return columns


@pytest.fixture
def client(database_url: str) -> Iterator[TestClient]:
    settings = make_settings(database_url)
    app = create_app(settings, embedded_worker=True, job_handler=describe_with_preview)
    with TestClient(app, raise_server_exceptions=False) as client:
        yield client


@pytest.mark.slow
def test_preview_is_served_with_an_etag_and_answers_304(client: TestClient) -> None:
    model = upload(client, CUBE).json()
    wait_for_status(client, model["id"], ("ready",))
    response = client.get(f"/v1/models/{model['id']}/preview")
    assert response.status_code == 200
    assert response.headers["content-type"] == "application/vnd.shapesearch.preview"
    expected = describe_with_preview(CUBE.read_bytes(), CUBE.name)["preview"]
    assert response.content == expected
    etag = response.headers["etag"]
    again = client.get(f"/v1/models/{model['id']}/preview", headers={"If-None-Match": etag})
    assert again.status_code == 304 and again.content == b""
    stale = client.get(f"/v1/models/{model['id']}/preview", headers={"If-None-Match": '"x"'})
    assert stale.status_code == 200


def test_preview_of_an_unknown_model_is_404(client: TestClient) -> None:
    assert client.get("/v1/models/not-a-uuid/preview").status_code == 404
    unknown = client.get("/v1/models/00000000-0000-0000-0000-000000000000/preview")
    assert unknown.status_code == 404
    assert unknown.json()["type"] == "urn:shapesearch:problem:model-not-found"


@pytest.mark.slow
def test_preview_of_a_model_described_without_one_is_404(database_url: str) -> None:
    app = create_app(make_settings(database_url), embedded_worker=True, job_handler=fake_describe)
    with TestClient(app, raise_server_exceptions=False) as client:
        model = upload(client, CUBE).json()
        wait_for_status(client, model["id"], ("ready",))
        response = client.get(f"/v1/models/{model['id']}/preview")
    assert response.status_code == 404
    assert response.json()["type"] == "urn:shapesearch:problem:preview-not-available"


def test_preview_of_a_queued_model_is_409(database_url: str) -> None:
    app = create_app(make_settings(database_url))  # no worker: stays queued
    with TestClient(app, raise_server_exceptions=False) as client:
        model = upload(client, CUBE).json()
        response = client.get(f"/v1/models/{model['id']}/preview")
    assert response.status_code == 409
    assert response.json()["type"] == "urn:shapesearch:problem:model-not-ready"


@pytest.mark.slow
def test_cutoff_stats_list_every_ready_model_and_the_solver_call_histogram(
    client: TestClient,
) -> None:
    empty = client.get("/v1/stats/cutoff").json()
    assert empty == {"fixed_n": 300, "ready_models": 0, "mean_n": None, "models": [],
                     "solver_calls": []}
    files = [CUBE, ANGLE, PARTS / "cylinder.stl"]
    ids = {}
    for path in files:
        ids[upload(client, path).json()["id"]] = path
    for model_id in ids:
        wait_for_status(client, model_id, ("ready",))
    stats = client.get("/v1/stats/cutoff").json()
    by_id = {point["id"]: point for point in stats["models"]}
    assert set(by_id) == set(ids)
    for model_id, path in ids.items():
        size = path.stat().st_size
        assert by_id[model_id]["n_points"] == size % 1000 + 100
        assert by_id[model_id]["cutoff"]["solver_calls"] == 2 + size % 2
        assert by_id[model_id]["cutoff"]["n"] == 10
    counts: dict[int, int] = {}
    for path in files:
        counts[2 + path.stat().st_size % 2] = counts.get(2 + path.stat().st_size % 2, 0) + 1
    assert stats["solver_calls"] == [
        {"solver_calls": c, "models": counts[c]} for c in sorted(counts)
    ]
    n_points = [point["n_points"] for point in stats["models"]]
    assert n_points == sorted(n_points)
    assert stats["ready_models"] == 3 and stats["mean_n"] == 10


def test_cutoff_stats_plot_every_kth_model_of_a_large_catalogue_and_count_them_all(
    database_url: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """At most PLOTTED_MAX models are plotted, evenly spaced by point count; the count, the
    mean n and the histogram cover every ready model, old cutoff records included."""
    monkeypatch.setattr(app.api.routes.stats, "PLOTTED_MAX", 4)
    settings = make_settings(database_url)
    with TestClient(create_app(settings, embedded_worker=False)) as client:
        sessions = make_session_factory(make_engine(database_url))
        with sessions.begin() as session:
            for number in range(10):  # point counts 1000, 1100, ... 1900 in shuffled order
                place = (number * 7) % 10
                record = {"mode": "adaptive", "n": 100 + place, "solver_calls": 2}
                if place == 9:  # written before the record's present form
                    record = {"n": 109, "params": {"mode": "adaptive", "solver_calls": 3}}
                session.add(Model(tenant="default", meta={}, status="ready", file_name="a.stl",
                                  file_size=1, file_sha256="0" * 64, file_format="stl",
                                  n_points=1000 + 100 * place, cutoff=record))
            session.add(Model(tenant="default", meta={}, status="queued", file_name="b.stl",
                              file_size=1, file_sha256="0" * 64, file_format="stl"))
        stats = client.get("/v1/stats/cutoff").json()
    assert [point["n_points"] for point in stats["models"]] == [1000, 1300, 1600, 1900]
    assert [point["cutoff"]["n"] for point in stats["models"]] == [100, 103, 106, 109]
    assert stats["models"][-1]["cutoff"]["solver_calls"] == 3
    assert stats["ready_models"] == 10
    assert stats["mean_n"] == pytest.approx(104.5)
    assert stats["solver_calls"] == [{"solver_calls": 2, "models": 9},
                                     {"solver_calls": 3, "models": 1}]
