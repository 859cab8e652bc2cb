"""Size-aware search (issue 21): size measured at describe time, units, size filters,
same-size ranking, and duplicates that are the same size as well as the same shape."""

from __future__ import annotations

import io
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh
from fastapi.testclient import TestClient

from app.api.main import create_app
from core.pipeline import describe
from core.size import ShapeSize, _unique_rows, box_extents, closed_volume
from tests.conftest import (
    PARTS,
    _Postgres,
    _require,
    make_settings,
    stored_duplicates,
    wait_for_status,
)

PART = PARTS / "featuretype.STL"  # 5 x 2.5 x 1.375, distinct extents, watertight


def transformed(path: Path, scale: float = 1.0, seed: int | None = None) -> bytes:
    """The part as STL bytes, scaled and (with ``seed``) rotated and moved."""
    mesh = trimesh.load(path, force="mesh")
    mesh.apply_scale(scale)
    if seed is not None:
        rng = np.random.default_rng(seed)
        mesh.apply_transform(trimesh.transformations.random_rotation_matrix(rng.random(3)))
        mesh.apply_translation(rng.normal(scale=10.0, size=3))
    buffer = io.BytesIO()
    mesh.export(buffer, file_type="stl")
    return buffer.getvalue()


# --- measuring ------------------------------------------------------------------------


def test_a_box_has_its_analytic_extents_area_and_volume() -> None:
    box = trimesh.creation.box((10.0, 40.0, 20.0))
    size = ShapeSize.of_mesh(np.asarray(box.vertices), np.asarray(box.faces))
    assert size.extents == pytest.approx([40.0, 20.0, 10.0])
    assert size.area == pytest.approx(2 * (400 + 200 + 800))
    assert size.volume == pytest.approx(8000.0)


def test_a_cylinder_has_its_analytic_area_and_volume() -> None:
    radius, height, sections = 3.0, 10.0, 256
    cylinder = trimesh.creation.cylinder(radius, height, sections=sections)
    size = ShapeSize.of_mesh(np.asarray(cylinder.vertices), np.asarray(cylinder.faces))
    # A 256-gon: area and volume within its tessellation error (~1e-4) of the circle's.
    assert size.area == pytest.approx(2 * np.pi * radius * (radius + height), rel=1e-3)
    assert size.volume == pytest.approx(np.pi * radius**2 * height, rel=1e-3)
    assert size.extents == pytest.approx([height, 2 * radius, 2 * radius], rel=1e-3)


@pytest.mark.parametrize("offset", [1e9, 1e12])
def test_a_part_far_from_its_files_origin_keeps_its_size(offset: float) -> None:
    # Site coordinates: a part placed 1e9 of its size away. The signed tetrahedra from the
    # file's origin cancelled to noise (8e10 for this 8000 box) and the merge keys passed
    # int64 (no triangle left); from the part's own corner both are exact.
    box = trimesh.creation.box((10.0, 40.0, 20.0))
    far = np.asarray(box.vertices) + np.array([offset, -0.5 * offset, 0.25 * offset])
    size = ShapeSize.of_mesh(far, np.asarray(box.faces))
    assert size.extents == pytest.approx([40.0, 20.0, 10.0], rel=1e-6)
    assert size.area == pytest.approx(2800.0, rel=1e-6)
    assert size.volume == pytest.approx(8000.0, rel=1e-6)
    assert closed_volume(far, np.asarray(box.faces)) == pytest.approx(8000.0, rel=1e-6)


def test_an_open_mesh_has_no_volume() -> None:
    box = trimesh.creation.box((10.0, 40.0, 20.0))
    open_box = trimesh.Trimesh(box.vertices, box.faces[:-2])  # one face missing
    size = ShapeSize.of_mesh(np.asarray(open_box.vertices), np.asarray(open_box.faces))
    assert size.volume is None


def test_a_flipped_or_repeated_triangle_leaves_no_volume() -> None:
    box = trimesh.creation.box((10.0, 40.0, 20.0))
    vertices, faces = np.asarray(box.vertices), np.asarray(box.faces)
    flipped = faces.copy()
    flipped[0] = flipped[0, ::-1]  # closed, but not consistently wound
    repeated = np.vstack([faces, faces[:1]])
    assert closed_volume(vertices, faces) == pytest.approx(8000.0)
    assert closed_volume(vertices, flipped) is None
    assert closed_volume(vertices, repeated) is None


def test_unique_rows_agree_with_numpys_unique() -> None:
    rows = np.random.default_rng(2).integers(-3, 3, size=(5000, 3))
    first, inverse = _unique_rows(rows)
    _, expected_first, expected_inverse = np.unique(
        rows, axis=0, return_index=True, return_inverse=True
    )
    np.testing.assert_array_equal(first, expected_first)
    np.testing.assert_array_equal(inverse, expected_inverse.ravel())


def test_a_small_hull_gets_trimeshs_box_unchanged() -> None:
    # Sizes stored before the hull's subset existed stay exactly as they were: with 2562
    # hull vertices (at most 3000) trimesh still sees every point, in their order (given
    # only the hull's vertices it picks another face per bin of directions here).
    rng = np.random.default_rng(0)
    ellipsoid = trimesh.creation.icosphere(subdivisions=4).apply_scale((1.0, 1.5, 4.0))
    ellipsoid.apply_transform(
        trimesh.transformations.random_rotation_matrix(np.array([0.2, 0.4, 0.6]))
    )
    surface = np.asarray(ellipsoid.vertices)
    inside = 0.5 * surface[rng.permutation(len(surface))[:1000]]
    points = np.vstack([inside, surface])[rng.permutation(len(surface) + 1000)]
    to_box, _ = trimesh.bounds.oriented_bounds(points)
    local = trimesh.transform_points(points, to_box)
    assert box_extents(points) == tuple(np.sort(np.ptp(local, axis=0))[::-1])


@pytest.mark.slow
def test_a_finely_tessellated_turned_cylinder_keeps_its_analytic_size() -> None:
    # 8192 sides: 16384 hull vertices, so the box's axes come from a seeded subset of
    # them (every point is still measured); before, a 16384-sided one took 134 s here.
    radius, height = 3.0, 10.0
    cylinder = trimesh.creation.cylinder(radius, height, sections=8192)
    turn = trimesh.transformations.random_rotation_matrix(np.array([0.3, 0.7, 0.1]))
    cylinder.apply_transform(turn)
    vertices, faces = np.asarray(cylinder.vertices), np.asarray(cylinder.faces)
    size = ShapeSize.of_mesh(vertices, faces)
    assert size.extents == pytest.approx([height, 2 * radius, 2 * radius], rel=1e-5)
    assert size.volume == pytest.approx(np.pi * radius**2 * height, rel=1e-5)
    assert ShapeSize.of_mesh(vertices, faces) == size  # the subset is seeded


@pytest.mark.slow
def test_size_is_rotation_invariant_sorted_and_scales_with_the_part() -> None:
    plain = describe(transformed(PART), filename="p.stl").size
    turned = describe(transformed(PART, seed=3), filename="p.stl").size
    tripled = describe(transformed(PART, scale=3.0, seed=5), filename="p.stl").size
    assert plain is not None and turned is not None and tripled is not None
    assert plain.length >= plain.width >= plain.height
    assert turned.extents == pytest.approx(plain.extents, rel=0.01)
    assert turned.area == pytest.approx(plain.area, rel=0.01)
    assert plain.volume is not None and turned.volume == pytest.approx(plain.volume, rel=0.01)
    assert tripled.length / plain.length == pytest.approx(3.0, rel=0.02)
    assert tripled.volume == pytest.approx(27 * plain.volume, rel=0.02)


@pytest.mark.slow
def test_a_point_cloud_gets_extents_and_an_area_estimate() -> None:
    mesh = trimesh.load(PART, force="mesh")
    points, _ = trimesh.sample.sample_surface(mesh, 6000, seed=1)
    text = "\n".join(" ".join(f"{v:.6f}" for v in p) for p in points).encode()
    cloud = describe(text, filename="p.xyz").size
    exact = describe(PART).size
    assert cloud is not None and exact is not None and cloud.volume is None
    assert cloud.extents == pytest.approx(exact.extents, rel=0.05)
    assert cloud.area == pytest.approx(exact.area, rel=0.1)


# --- through the API, both backends ---------------------------------------------------


@pytest.fixture(params=["sqlite", "postgresql"])
def client(
    request: pytest.FixtureRequest, tmp_path: Path, postgres: _Postgres | None,
    index_backend: str,
) -> Iterator[TestClient]:
    if request.param == "sqlite":
        url = f"sqlite:///{tmp_path / 'shapesearch.db'}"
    else:
        url = _require(postgres).new_database()
    milvus = {} if index_backend == "faiss" else {
        "index_backend": "milvus", "milvus_uri": str(tmp_path / "milvus.db"),
        "milvus_index": "FLAT"}
    app = create_app(make_settings(url, workers=2, **milvus), embedded_worker=True)
    with TestClient(app, raise_server_exceptions=False) as test_client:
        yield test_client


def post(client: TestClient, content: bytes, name: str, **form: str) -> str:
    response = client.post(
        "/v1/models", files={"file": (f"{name}.stl", content, "application/octet-stream")},
        data={"external_id": name, **form},
    )
    assert response.status_code == 202, response.text
    return str(response.json()["id"])


def similar(client: TestClient, model_id: str, **params: Any) -> list[str]:
    response = client.get(f"/v1/models/{model_id}/similar", params={"k": 10, **params})
    assert response.status_code == 200, response.text
    return [result["model"]["external_id"] for result in response.json()["results"]]


@pytest.mark.slow
def test_size_tolerance_weight_filters_and_duplicates(client: TestClient) -> None:
    ids = {
        "part": post(client, transformed(PART), "part", units="mm", metadata='{"qty": 1}'),
        "turned": post(client, transformed(PART, seed=1), "turned", units="mm",
                       metadata='{"qty": 2}'),
        "x1.05": post(client, transformed(PART, scale=1.05, seed=2), "x1.05", units="mm",
                      metadata='{"qty": 3.5}'),
        "x3": post(client, transformed(PART, scale=3.0, seed=3), "x3", units="mm",
                   metadata='{"qty": "many"}'),
    }
    bodies = {name: wait_for_status(client, i) for name, i in ids.items()}
    assert all(body["status"] == "ready" for body in bodies.values()), bodies
    size = bodies["part"]["size"]
    assert size["units"] == "mm" and size["length"] >= size["width"] >= size["height"]
    assert bodies["x3"]["size"]["length"] / size["length"] == pytest.approx(3.0, rel=0.02)

    # The descriptor alone cannot tell the sizes apart: every copy is found.
    assert set(similar(client, ids["part"])) == {"turned", "x1.05", "x3"}
    # Tolerance: the 5 % larger copy is within 10 %, the triple is not.
    assert set(similar(client, ids["part"], size_tolerance=0.1)) == {"turned", "x1.05"}
    # Weight: the nearer size ranks first among the scaled copies.
    ranked = similar(client, ids["part"], size_weight=1.0)
    assert ranked.index("x1.05") < ranked.index("x3")
    results = client.get(f"/v1/models/{ids['part']}/similar",
                         params={"size_weight": 1.0}).json()["results"]
    by_name = {r["model"]["external_id"]: r for r in results}
    assert by_name["x3"]["score"] < by_name["x1.05"]["score"] <= 1.0
    assert by_name["x3"]["model"]["size"]["length"] > 2 * size["length"]
    # A range on the length, in millimetres, before the top-k cut.
    limit = 2 * size["length"]
    assert "x3" not in similar(client, ids["part"], **{"size.length.lte": limit})
    assert similar(client, ids["part"], **{"size.length.gte": limit}) == ["x3"]
    # Numeric metadata ranges, pushed down like the size filters ("many" is no number).
    assert set(similar(client, ids["part"], **{"metadata.qty.gte": 2})) == {"turned", "x1.05"}
    assert similar(client, ids["part"], **{"metadata.qty.gte": 2, "metadata.qty.lte": 3}) == [
        "turned"]
    bad = client.get(f"/v1/models/{ids['part']}/similar", params={"metadata.qty.gte": "x"})
    assert bad.status_code == 422 and bad.json()["pointer"] == "/query/metadata.qty.gte"
    # Duplicates: the same shape at the same size only.
    report = stored_duplicates(client, min_score=0.95, size_tolerance=0.02)
    groups = [{m["external_id"] for m in group["members"]} for group in report["groups"]]
    assert groups == [{"part", "turned"}] and report["size_tolerance"] == 0.02
    families = stored_duplicates(client, min_score=0.95)
    assert [len(group["members"]) for group in families["groups"]] == [4]


@pytest.mark.slow
def test_inches_match_millimetres_at_the_same_physical_size(client: TestClient) -> None:
    millimetre_part = post(client, transformed(PART, scale=25.4), "mm-part", units="mm")
    inch_part = post(client, transformed(PART, seed=4), "in-part", units="in")
    other_size = post(client, transformed(PART, seed=5), "as-given")  # no units: 25.4x smaller
    for model_id in (millimetre_part, inch_part, other_size):
        assert wait_for_status(client, model_id)["status"] == "ready"
    inch = client.get(f"/v1/models/{inch_part}").json()["size"]
    assert inch["units"] == "in" and inch["length"] == pytest.approx(5.0, rel=0.01)
    assert similar(client, millimetre_part, size_tolerance=0.02) == ["in-part"]
    # Bad size parameters are a 422 that names them.
    bad = client.get(f"/v1/models/{millimetre_part}/similar", params={"size.depth.gte": 1})
    assert bad.status_code == 422 and bad.json()["pointer"] == "/query/size.depth.gte"
    bad = client.get(f"/v1/models/{millimetre_part}/similar", params={"size.length.gte": "x"})
    assert bad.status_code == 422 and bad.json()["pointer"] == "/query/size.length.gte"
    stats = client.get("/v1/stats").json()
    assert stats["ready_without_size"] == 0
