"""GET /v1/models/{id}/compare/{other_id} and POST /v1/search?explain=true.

The contract on both backends, with a fast describer whose models carry the real sample
points of their files (``load_points``, as the engine samples them) and a fake descriptor;
the search's explanation end to end with the real engine (it needs the real descriptors to
find the part first).
"""

from __future__ import annotations

import io
import uuid
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh
from fastapi.testclient import TestClient
from sqlalchemy import create_engine

from app.api.main import create_app
from app.auth.keys import create_key
from app.db.session import make_session_factory
from app.ingest.describing import encode_sample
from app.ingest.previews import encode_preview
from app.search.comparing import EXPLAINED_RESULTS, Comparer
from core.compare import diagonal, rotation_angle
from core.errors import InvalidShapeError
from core.evaluation.scans import ScanSettings, random_rotation, single_view_scan
from core.io import load_points
from tests.conftest import PARTS, fake_describe, make_settings, upload, wait_for_status
from tests.plm_helpers import started_clients

PROBLEM = "application/problem+json"
PART = PARTS / "featuretype.STL"
SAMPLE_POINTS = 1500

ClientFactory = Callable[..., TestClient]


def sampled_describe(content: bytes, filename: str) -> dict[str, Any]:
    """``fake_describe`` with the file's real sample points (``Model.sample``); a file
    named ``old-*`` gets only a preview (a model described before samples were kept), one
    named ``broken-*`` fails, one named ``bare-*`` has neither."""
    if filename.startswith("broken-"):
        raise InvalidShapeError("degenerate", "all points lie on a single line")
    columns = fake_describe(content, filename)
    if filename.startswith("bare-"):
        return columns
    points = load_points(content, filename=filename, max_points=SAMPLE_POINTS).points
    if not filename.startswith("old-"):
        return {**columns, "sample": encode_sample(points)}
    # The preview's points: centred on the box, at unit area (as core.normalise leaves
    # them); the mesh's area is the model's size_area, as the engine measures it.
    area = float(trimesh.load(io.BytesIO(content), file_type="stl").area)
    centred = (points - (points.min(axis=0) + points.max(axis=0)) / 2) / np.sqrt(area)
    preview = encode_preview(centred, np.zeros((len(points), 2)), np.array([0.1, 1.0]),
                             np.arange(4.0))
    return {**columns, "preview": preview, "size_length": 1.0, "size_width": 1.0,
            "size_height": 1.0, "size_area": area}


@pytest.fixture
def make_client(database_url: str) -> Iterator[ClientFactory]:
    """``make_client(**settings)``: started apps whose worker describes by ``sampled_describe``."""
    with started_clients(database_url) as make:
        yield lambda **overrides: make(handler=sampled_describe, **overrides)


@pytest.fixture
def client(make_client: ClientFactory) -> TestClient:
    return make_client()


def assert_problem(response: Any, status: int, kind: str) -> dict[str, Any]:
    assert response.status_code == status, response.text
    assert response.headers["content-type"].startswith(PROBLEM)
    body: dict[str, Any] = response.json()
    assert body["status"] == status and body["type"] == f"urn:shapesearch:problem:{kind}"
    assert body["title"] and body["detail"]
    return body


def stl_bytes(path: Path, transform: Callable[[np.ndarray], np.ndarray]) -> bytes:
    mesh = trimesh.load(path, file_type="stl")
    mesh.vertices = transform(np.asarray(mesh.vertices))
    return bytes(mesh.export(file_type="stl"))


def ready(client: TestClient, name: str, content: bytes, **form: str) -> str:
    response = client.post("/v1/models", files={"file": (name, content)}, data=form)
    assert response.status_code == 202, response.text
    model_id: str = response.json()["id"]
    assert wait_for_status(client, model_id)["status"] == "ready"
    return model_id


def test_a_part_against_itself_rotated_in_other_units(client: TestClient) -> None:
    """The copy is turned, moved and stored in centimetres: the comparison converts it to
    the model's millimetres, finds the turn within 2 degrees and the parts 0.5 % of the
    diagonal apart at most."""
    rotation = random_rotation(np.random.default_rng(4))
    model = ready(client, "featuretype.stl", PART.read_bytes(), units="mm")
    other = ready(client, "featuretype-turned.stl",
                  stl_bytes(PART, lambda v: (v @ rotation.T + [40.0, -7.0, 3.0]) / 10.0),
                  units="cm")
    size = diagonal(load_points(PART, max_points=SAMPLE_POINTS).points)

    response = client.get(f"/v1/models/{model}/compare/{other}", params={"points": 120})
    assert response.status_code == 200, response.text
    body = response.json()
    assert body["model"]["id"] == model and body["other"]["id"] == other
    assert body["units"] == "mm"
    found = np.array(body["alignment"]["rotation"])
    assert rotation_angle(found @ rotation) <= 2.0
    assert body["alignment"]["scale"] == pytest.approx(10.0, rel=1e-9)  # cm -> mm
    assert body["alignment"]["candidates"] >= 4
    for direction in ("model_to_other", "other_to_model"):
        figures = body[direction]
        assert figures["rms"] <= 0.005 * size
        assert figures["mean"] <= figures["rms"] <= figures["max"]
        assert figures["p95"] <= figures["max"] and figures["within"] > 0.95
    assert body["tolerance"] == pytest.approx(0.01 * size, rel=0.02)
    assert body["size_ratios"] == pytest.approx([1.0, 1.0, 1.0], abs=0.02)
    assert body["extents"]["model"] == pytest.approx(body["extents"]["other"], rel=0.02)
    assert body["points_source"] == {"model": "sample", "other": "sample"}
    for part, direction in (("model", "model_to_other"), ("other", "other_to_model")):
        points = body["points"][part]
        assert len(points["positions"]) == len(points["deviations"]) == 120
        assert all(len(p) == 3 for p in points["positions"])
        assert max(points["deviations"]) <= body[direction]["max"] + 1e-6
    # The other's points, aligned, lie where the model's are (its frame, its units).
    model_points = np.array(body["points"]["model"]["positions"])
    other_points = np.array(body["points"]["other"]["positions"])
    assert np.allclose(model_points.mean(axis=0), other_points.mean(axis=0), atol=0.05 * size)

    # Asked again: the same answer, from the cache; without points: none.
    again = client.get(f"/v1/models/{model}/compare/{other}", params={"points": 120})
    assert again.json() == body
    assert client.get(f"/v1/models/{model}/compare/{other}").json()["points"] is None
    services = client.app.state.services  # type: ignore[attr-defined]
    assert len(services.comparer._cache) == 1  # points are cut from one cached comparison


def test_a_tolerance_and_a_scale_are_the_callers(client: TestClient) -> None:
    model = ready(client, "featuretype.stl", PART.read_bytes())
    half = ready(client, "featuretype-half.stl", stl_bytes(PART, lambda v: v * 0.5))
    loose = client.get(f"/v1/models/{model}/compare/{half}", params={"tolerance": 1000}).json()
    assert loose["tolerance"] == 1000 and loose["model_to_other"]["within"] == 1.0
    scaled = client.get(f"/v1/models/{model}/compare/{half}", params={"scale": "true"}).json()
    assert scaled["alignment"]["scale"] == pytest.approx(2.0, rel=0.01)
    assert scaled["other_to_model"]["rms"] < 0.2 * loose["other_to_model"]["rms"]
    # Laid on the model at twice its size, the half-size copy's extents are still its own.
    assert scaled["size_ratios"] == pytest.approx([0.5, 0.5, 0.5], rel=0.02)


def test_a_model_described_before_samples_compares_on_its_preview(client: TestClient) -> None:
    model = ready(client, "featuretype.stl", PART.read_bytes())
    old = ready(client, "old-featuretype.stl", PART.read_bytes())
    body = client.get(f"/v1/models/{model}/compare/{old}").json()
    assert body["points_source"] == {"model": "sample", "other": "preview"}
    size = diagonal(load_points(PART, max_points=SAMPLE_POINTS).points)
    # The preview's float16 points, scaled back, lie on the part.
    assert body["other_to_model"]["rms"] <= 0.005 * size
    bare = ready(client, "bare-featuretype.stl", PART.read_bytes())
    assert_problem(client.get(f"/v1/models/{model}/compare/{bare}"), 409,
                   "points-not-available")


@pytest.mark.slow
def test_bad_input_is_answered_with_problems(
    make_client: ClientFactory, database_url: str
) -> None:
    client = make_client(auth_cache_seconds=0)
    model = ready(client, "featuretype.stl", PART.read_bytes())
    failed = client.post("/v1/models", files={"file": ("broken-part.stl", PART.read_bytes())})
    failed_id = failed.json()["id"]
    assert wait_for_status(client, failed_id)["status"] == "failed"
    compare = f"/v1/models/{model}/compare"

    unknown = uuid.uuid4()
    for path in (f"{compare}/{unknown}", f"/v1/models/{unknown}/compare/{model}",
                 f"{compare}/not-a-uuid"):
        assert_problem(client.get(path), 404, "model-not-found")
    for path in (f"{compare}/{failed_id}", f"/v1/models/{failed_id}/compare/{model}"):
        body = assert_problem(client.get(path), 409, "model-not-ready")
        assert body["model_status"] == "failed"
    for params in ({"points": 4001}, {"points": -1}, {"tolerance": 0}, {"tolerance": -2.5},
                   {"tolerance": "nan"}):
        body = assert_problem(client.get(f"{compare}/{model}", params=params), 422,
                              "validation-error")
        assert body["pointer"].startswith("/query/")
    assert client.get(f"{compare}/{model}", params={"points": 4000}).status_code == 200

    # Tenants: another tenant's model is not found, whichever side it is on.
    engine = create_engine(database_url)
    with make_session_factory(engine).begin() as session:
        alice = {"Authorization": f"Bearer {create_key(session, 'alice')}"}
    engine.dispose()
    mine = client.post("/v1/models", files={"file": ("featuretype.stl", PART.read_bytes())},
                       headers=alice).json()["id"]
    wait_for_status(client, mine, headers=alice)
    assert client.get(f"/v1/models/{mine}/compare/{mine}", headers=alice).status_code == 200
    assert_problem(client.get(f"/v1/models/{mine}/compare/{model}", headers=alice), 404,
                   "model-not-found")


@pytest.mark.slow
def test_a_comparison_beyond_its_slots_or_budget_is_busy(client: TestClient) -> None:
    model = ready(client, "featuretype.stl", PART.read_bytes())
    other = ready(client, "featuretype-small.stl", stl_bytes(PART, lambda v: v * 0.9))
    services = client.app.state.services  # type: ignore[attr-defined]
    for comparer in (Comparer(max_concurrent=0), Comparer(budget_seconds=0.0)):
        services.comparer = comparer
        response = client.get(f"/v1/models/{model}/compare/{other}")
        body = assert_problem(response, 503, "busy")
        assert response.headers["Retry-After"] == "1"
        assert "comparison" in body["detail"]


# --- the search's explanation, with the real engine ---------------------------------------


@pytest.fixture(scope="module")
def engine_client(tmp_path_factory: pytest.TempPathFactory) -> Iterator[TestClient]:
    path = tmp_path_factory.mktemp("explain") / "shapesearch.db"
    app = create_app(make_settings(f"sqlite:///{path}", workers=2), embedded_worker=True)
    with TestClient(app, raise_server_exceptions=False) as client:
        yield client


@pytest.mark.slow
def test_a_single_view_scan_is_placed_on_the_part_it_shows(engine_client: TestClient) -> None:
    client = engine_client
    ids = {name: upload(client, PARTS / name).json()["id"]
           for name in ("featuretype.STL", "cylinder.stl", "angle_block.STL")}
    for model_id in ids.values():
        assert wait_for_status(client, model_id, timeout=300)["status"] == "ready"
    # One view of the closed block, with the simulator's noise and stray points, turned and
    # in metres: the scanner's units are not the catalogue's.
    rng = np.random.default_rng(8)
    dense = load_points(PART, max_points=20000, seed=3).points
    view = single_view_scan(dense, rng, ScanSettings())
    scan = (view @ random_rotation(rng).T + rng.normal(size=3) * 50) / 1000.0
    text = "\n".join(" ".join(f"{v:.7g}" for v in row) for row in scan).encode()
    size = diagonal(load_points(PART, max_points=SAMPLE_POINTS).points)

    for mode in ("shape", "scan"):
        response = client.post("/v1/search", files={"file": ("view.xyz", text)},
                               params={"explain": "true", "points": 50, "k": 3, "mode": mode})
        assert response.status_code == 200, response.text
        results = response.json()["results"]
        assert all(r["explanation"] is not None for r in results[:EXPLAINED_RESULTS])
        if mode == "shape":  # (scan mode orders three parts by its own discount)
            assert results[0]["model"]["id"] == ids["featuretype.STL"]
        (part,) = [r for r in results if r["model"]["id"] == ids["featuretype.STL"]]
        explained = part["explanation"]
        assert explained["rms"] <= 0.02 * size, (mode, explained["rms"], size)
        assert 0.25 <= explained["coverage"] <= 0.75, (mode, explained["coverage"])
        assert explained["alignment"]["scale"] == pytest.approx(1000.0, rel=0.03)
        assert explained["tolerance"] == pytest.approx(0.01 * size, rel=0.05)
        assert explained["points_source"] == "sample"
        assert len(explained["points"]["model"]["positions"]) == 50
        assert len(explained["points"]["other"]["deviations"]) == 50
        # Scan mode names the view of the part that matched (null: its whole descriptor).
        assert explained["view"] is None or (mode == "scan" and explained["view"] >= 0)

    plain = client.post("/v1/search", files={"file": ("view.xyz", text)}).json()
    assert all(r["explanation"] is None for r in plain["results"])


# --- shapesearch compare ---------------------------------------------------------------


@pytest.mark.slow
def test_the_command_line_prints_the_services_figures(
    client: TestClient, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
    tmp_path: Path,
) -> None:
    """Ids are asked of the service (here through the test client), files are read here;
    either way the same comparison answers."""
    import json

    from app.cli import compare as command
    from app.cli import main

    rotation = random_rotation(np.random.default_rng(9))
    model = ready(client, "featuretype.stl", PART.read_bytes(), units="mm")
    turned = stl_bytes(PART, lambda v: v @ rotation.T)
    other = ready(client, "featuretype-turned.stl", turned, units="mm")
    asked: list[str] = []

    def through_client(url: str | None, key: str | None, path: str, params: Any) -> Any:
        asked.append(path)
        response = client.get(path, params=params)
        if response.status_code != 200:
            raise command.CompareError(f"{response.status_code}: {response.json()['detail']}")
        return response.json()

    monkeypatch.setattr(command, "_get", through_client)
    size = diagonal(load_points(PART, max_points=SAMPLE_POINTS).points)

    assert main(["compare", model, other, "--url", "http://service", "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    served = client.get(f"/v1/models/{model}/compare/{other}").json()
    for name in ("alignment", "model_to_other", "other_to_model", "size_ratios", "units"):
        assert printed[name] == served[name]
    assert asked == [f"/v1/models/{model}/compare/{other}"]

    # A file against a model: the model's stored points, compared here.
    path = tmp_path / "turned.stl"
    path.write_bytes(turned)
    assert main(["compare", model, str(path), "--url", "http://service", "--json"]) == 0
    local = json.loads(capsys.readouterr().out)
    assert asked[-1] == f"/v1/models/{model}/compare/{model}"
    assert local["units"] == "mm" and local["other_to_model"]["rms"] <= 0.005 * size
    assert rotation_angle(np.array(local["alignment"]["rotation"]) @ rotation) <= 2.0

    # Two files: no service at all; the text names both and the figures.
    assert main(["compare", str(PART), str(path)]) == 0
    text = capsys.readouterr().out
    assert str(PART) in text and "RMS" in text and "95th percentile" in text
    # An id without a service, a name that is neither, a tolerance <= 0: refused.
    assert main(["compare", model, str(path)]) == 2
    assert "--url" in capsys.readouterr().err
    assert main(["compare", "no-such-file.stl", str(path)]) == 2
    assert main(["compare", str(PART), str(path), "--tolerance", "0"]) == 2
    assert main(["compare", str(uuid.uuid4()), model, "--url", "http://service"]) == 2
    assert "404" in capsys.readouterr().err
