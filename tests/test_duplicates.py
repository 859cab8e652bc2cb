"""The duplicate report: the grouping on synthetic vectors, then through HTTP and the CLI
with the real engine (small settings) on SQLite and PostgreSQL."""

from __future__ import annotations

import csv
import io
import json

import numpy as np
import pytest
import trimesh
from conftest import PARTS, make_settings, wait_for_status
from fastapi.testclient import TestClient

from app.api.main import create_app
from app.cli import main
from app.search.duplicates import group_vectors

UNRELATED = ["cylinder.stl", "20mm-xyz-cube.stl", "round.stl", "teapot.stl"]


def unit(rows: np.ndarray) -> np.ndarray:
    return (rows / np.linalg.norm(rows, axis=1, keepdims=True)).astype(np.float32)


def test_groups_are_components_of_the_thresholded_knn_graph() -> None:
    rng = np.random.default_rng(0)
    centres = unit(rng.normal(size=(3, 32)))
    # 4 near-copies of centre 0, 2 of centre 1, 1 of centre 2 (a singleton: no group).
    rows = [centres[0] + 0.01 * rng.normal(size=32) for _ in range(4)]
    rows += [centres[1] + 0.01 * rng.normal(size=32) for _ in range(2)]
    rows += [centres[2]]
    vectors = unit(np.array(rows))
    groups = group_vectors(vectors, min_score=0.99)
    assert [g.tolist() for g in groups] == [[0, 1, 2, 3], [4, 5]]
    assert group_vectors(vectors, min_score=0.99, neighbours=2)[0].tolist() == [0, 1, 2, 3]
    assert group_vectors(vectors[:1], 0.9) == []
    # A chain a~b~c groups a and c although they are less alike than min_score.
    a = np.array([1.0, 0.0, 0.0])
    c = np.array([np.cos(0.6), np.sin(0.6), 0.0])
    b = (a + c) / np.linalg.norm(a + c)
    chain = unit(np.array([a, b, c]))
    assert (1 + chain[0] @ chain[2]) / 2 < 0.95 < (1 + chain[0] @ chain[1]) / 2
    assert [g.tolist() for g in group_vectors(chain, 0.95)] == [[0, 1, 2]]


def moved_copy(name: str, *, mirror: bool) -> bytes:
    mesh = trimesh.load(PARTS / name, force="mesh")
    rng = np.random.default_rng(5)
    mesh.apply_transform(trimesh.transformations.random_rotation_matrix(rng.random(3)))
    mesh.apply_scale(2.5)
    if mirror:
        mesh.apply_transform(np.diag([-1.0, 1.0, 1.0, 1.0]))
    return bytes(mesh.export(file_type="stl"))


def test_a_rotated_rescaled_and_a_mirrored_copy_group_with_their_part(
    database_url: str, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    app = create_app(make_settings(database_url, workers=1), embedded_worker=True)
    with TestClient(app) as client:
        files = {name: (PARTS / name).read_bytes() for name in ["angle_block.STL", *UNRELATED]}
        files["copy.stl"] = moved_copy("angle_block.STL", mirror=False)
        files["mirror.stl"] = moved_copy("angle_block.STL", mirror=True)
        ids = {}
        for name, content in files.items():
            response = client.post("/v1/models", files={"file": (name, content)},
                                   data={"external_id": name})
            ids[name] = response.json()["id"]
        for model_id in ids.values():
            assert wait_for_status(client, model_id, timeout=300)["status"] == "ready"

        report = client.get("/v1/duplicates", params={"min_score": 0.98}).json()
        (group,) = report["groups"]
        members = {m["external_id"] for m in group["members"]}
        assert members == {"angle_block.STL", "copy.stl", "mirror.stl"}
        assert group["size"] == 3 and len(group["pairs"]) == 3
        assert all(p["score"] >= 0.98 for p in group["pairs"])
        scores = [p["score"] for p in group["pairs"]]
        assert scores == sorted(scores, reverse=True)
        paged = client.get("/v1/duplicates", params={"min_score": 0.5, "limit": 1}).json()
        assert len(paged["groups"]) == 1 and paged["groups"][0]["size"] == 7
        assert paged["next_cursor"] is None
        assert client.get("/v1/duplicates", params={"cursor": "x"}).status_code == 422

    monkeypatch.setenv("SHAPESEARCH_DATABASE_URL", database_url)
    for name, value in make_settings(database_url).model_dump().items():
        if name.startswith(("cutoff_", "max_points", "descriptor_")) and value is not None:
            monkeypatch.setenv(f"SHAPESEARCH_{name.upper()}", str(value))
    assert main(["duplicates", "--min-score", "0.98", "--format", "csv"]) == 0
    rows = list(csv.DictReader(io.StringIO(capsys.readouterr().out)))
    assert {row["external_id"] for row in rows} == members
    assert {row["group"] for row in rows} == {"1"} and {row["size"] for row in rows} == {"3"}
    assert main(["duplicates", "--min-score", "0.98", "--format", "json"]) == 0
    groups = json.loads(capsys.readouterr().out)
    assert [{m["external_id"] for m in g["members"]} for g in groups] == [members]
