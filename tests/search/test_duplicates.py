"""The duplicates report: the neighbour graph and its groups on synthetic vectors; the
stored report through HTTP (a job, then pages that stay put while models are added, and
``stale``) with the fake describer; and with the real engine (small settings), the
report against the direct all-pairs computation it replaced, and the CLI. Database tests
run on SQLite and PostgreSQL."""

from __future__ import annotations

import csv
import io
import json
import threading
import uuid
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
import trimesh
from alembic import command
from fastapi.testclient import TestClient
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from sqlalchemy import inspect, select
from sqlalchemy.orm import Session, sessionmaker

from app.api.cursors import encode_group
from app.api.main import create_app
from app.cli import main
from app.db.feed import record_event
from app.db.migrate import alembic_config, upgrade
from app.db.models import Job, Model
from app.db.session import make_engine, make_session_factory, open_sessions
from app.jobs.queue import JobQueue
from app.jobs.worker import Worker
from app.search.duplicate_reports import enqueue_report, is_stale, latest_report, store_report
from app.search.duplicates import DuplicatesQuery, compute_report, group_graph
from app.search.index import ShapeIndex
from tests.conftest import PARTS, fake_describe, make_settings, stored_duplicates, wait_for_status

UNRELATED = ["cylinder.stl", "20mm-xyz-cube.stl", "round.stl", "teapot.stl"]
FAKE = "fake-1"  # conftest.fake_describe's descriptor_version
KEY = ("t", "v")


def unit(rows: np.ndarray) -> np.ndarray:
    return (rows / np.linalg.norm(rows, axis=1, keepdims=True)).astype(np.float32)


def index_of(vectors: np.ndarray, exact_max: int = 5000, nprobe: int = 8) -> ShapeIndex:
    """An index holding ``vectors`` in partition ``KEY`` under ids 0 .. n-1."""
    index = ShapeIndex(None, exact_max=exact_max, nprobe=nprobe)
    index.build_partition(KEY, [(0, vectors)], expected=len(vectors))
    return index


def groups_of(
    vectors: np.ndarray, min_score: float, k: int = 16, **options: Any
) -> list[list[int]]:
    graph = index_of(vectors, **options).neighbour_graph(KEY, k)
    return [graph.ids[members].tolist() for members, _ in group_graph(graph, min_score)]


# --- the graph and its groups -------------------------------------------------------------


def test_groups_are_components_of_the_thresholded_knn_graph() -> None:
    rng = np.random.default_rng(0)
    centres = unit(rng.normal(size=(3, 32)))
    # 4 near-copies of centre 0, 2 of centre 1, 1 of centre 2 (a singleton: no group).
    rows = [centres[0] + 0.01 * rng.normal(size=32) for _ in range(4)]
    rows += [centres[1] + 0.01 * rng.normal(size=32) for _ in range(2)]
    rows += [centres[2]]
    vectors = unit(np.array(rows))
    assert groups_of(vectors, min_score=0.99) == [[0, 1, 2, 3], [4, 5]]
    assert groups_of(vectors, min_score=0.99, k=1)[0] == [0, 1, 2, 3]
    assert groups_of(vectors[:1], 0.9) == []
    # A chain a~b~c groups a and c although they are less alike than min_score; the
    # group's pairs are the two edges that joined it, not a~c.
    a = np.array([1.0, 0.0, 0.0])
    c = np.array([np.cos(0.6), np.sin(0.6), 0.0])
    b = (a + c) / np.linalg.norm(a + c)
    chain = unit(np.array([a, b, c]))
    assert (1 + chain[0] @ chain[2]) / 2 < 0.95 < (1 + chain[0] @ chain[1]) / 2
    graph = index_of(chain).neighbour_graph(KEY, 16)
    ((members, pairs),) = group_graph(graph, 0.95)
    assert graph.ids[members].tolist() == [0, 1, 2]
    assert sorted((i, j) for i, j, _ in pairs) == [(0, 1), (1, 2)]
    assert all(score == pytest.approx((1 + chain[i] @ chain[j]) / 2) for i, j, score in pairs)


def test_an_ivf_partition_finds_the_exact_groups_with_exact_scores() -> None:
    # 60 clusters of 2-6 near copies among 600 vectors: above exact_max the partition is
    # IVF-SQ8, and the graph compares only nearby lists, scoring on the full vectors.
    rng = np.random.default_rng(1)
    centres = unit(rng.normal(size=(60, 64)))
    copies = [centre + 0.02 * rng.normal(size=(rng.integers(2, 7), 64)) for centre in centres]
    vectors = unit(np.concatenate([*copies, rng.normal(size=(600 - sum(map(len, copies)), 64))]))
    flat = index_of(vectors)
    ivf = index_of(vectors, exact_max=100, nprobe=4)
    assert flat.describe(KEY) == "flat" and ivf.describe(KEY) == "ivf-sq8"
    exact, approximate = flat.neighbour_graph(KEY, 16), ivf.neighbour_graph(KEY, 16)
    assert exact.exact and not approximate.exact
    flat_groups = [sorted(exact.ids[m].tolist()) for m, _ in group_graph(exact, 0.98)]
    ivf_groups = [sorted(approximate.ids[m].tolist()) for m, _ in group_graph(approximate, 0.98)]
    assert sorted(flat_groups) == sorted(ivf_groups) and len(flat_groups) == 60
    # Every cosine is the full vectors' own, not the 8-bit codes' estimate.
    rows, slots = np.nonzero(approximate.neighbours >= 0)
    first = vectors[approximate.ids[rows]]
    second = vectors[approximate.ids[approximate.neighbours[rows, slots]]]
    true = np.einsum("ij,ij->i", first, second)
    assert np.abs(approximate.cosines[rows, slots] - true).max() < 1e-5


def test_size_tolerance_drops_edges_between_different_sizes() -> None:
    vectors = unit(np.array([[1.0, 0.0], [1.0, 0.001], [1.0, 0.002]]))
    graph = index_of(vectors).neighbour_graph(KEY, 4)
    extents = np.array([[10.0, 5.0, 2.0], [10.4, 5.1, 2.0], [30.0, 15.0, 6.0]])
    same_size = group_graph(graph, 0.99, extents, size_tolerance=0.05)
    assert [graph.ids[m].tolist() for m, _ in same_size] == [[0, 1]]
    unknown = extents.copy()
    unknown[1] = np.nan  # no size: groups with none
    assert group_graph(graph, 0.99, unknown, size_tolerance=0.05) == []


# --- the stored report through HTTP (fake describer) ---------------------------------------


@pytest.fixture
def client(database_url: str) -> Iterator[TestClient]:
    settings = make_settings(database_url, workers=1)
    with TestClient(create_app(settings, embedded_worker=True, job_handler=fake_describe)) as c:
        yield c


def points(label: str) -> bytes:
    """A small point cloud (.xyz) of its own per label."""
    rng = np.random.default_rng(list(label.encode()))
    return "\n".join(" ".join(f"{v:.6f}" for v in row) for row in rng.random((200, 3))).encode()


def upload_copies(client: TestClient, label: str, names: list[str]) -> list[str]:
    """Upload the cloud of ``label`` once per name (equal files: equal fake descriptors);
    their ids, once ready."""
    content = points(label)
    ids = []
    for name in names:
        response = client.post("/v1/models", files={"file": (f"{name}.xyz", content)},
                               data={"external_id": name, "name": name.upper()})
        assert response.status_code == 202, response.text
        ids.append(response.json()["id"])
    for model_id in ids:
        assert wait_for_status(client, model_id)["status"] == "ready"
    return ids


def report(client: TestClient, limit: int = 50, **params: Any) -> dict[str, Any]:
    return stored_duplicates(client, limit, descriptor_version=FAKE, **params)


def names(group: dict[str, Any]) -> list[str]:
    return [member["external_id"] for member in group["members"]]


@pytest.mark.slow
def test_the_stored_report_pages_stably_while_models_are_added_and_turns_stale(
    client: TestClient,
) -> None:
    missing = client.get("/v1/duplicates", params={"descriptor_version": FAKE})
    assert missing.status_code == 404
    assert missing.json()["type"] == "urn:shapesearch:problem:duplicates-report-not-found"
    assert "POST /v1/duplicates" in missing.json()["detail"]
    # Seven groups of 5, 4, 3, 2, 2, 2, 2 equal files and three lone ones.
    sizes = {"a": 5, "b": 4, "c": 3, "d": 2, "e": 2, "f": 2, "g": 2, "x": 1, "y": 1, "z": 1}
    for letter, count in sizes.items():
        upload_copies(client, letter, [f"{letter}{i}" for i in range(count)])
    first = report(client, limit=3)
    assert first["models"] == 23 and first["group_count"] == 7 and first["exact"]
    assert first["stale"] is False and first["size_tolerance"] is None
    assert [group["number"] for group in first["groups"]] == [1, 2, 3]
    assert [names(group) for group in first["groups"]] == [
        [f"a{i}" for i in range(5)], [f"b{i}" for i in range(4)], ["c0", "c1", "c2"]]
    assert first["groups"][0]["members"][0]["name"] == "A0"
    assert all(pair["score"] == pytest.approx(1.0) for pair in first["groups"][0]["pairs"])

    # New models: copies that would join groups 1 and 4, and a new group that would come
    # first (7 members). The pages of the stored report do not move.
    upload_copies(client, "a", ["a5"])
    upload_copies(client, "d", ["d2"])
    upload_copies(client, "n", [f"n{i}" for i in range(7)])
    groups, cursor = list(first["groups"]), first["next_cursor"]
    while cursor is not None:
        page = client.get("/v1/duplicates", params={"cursor": cursor, "limit": 3}).json()
        assert page["id"] == first["id"] and page["stale"] is True
        groups += page["groups"]
        cursor = page["next_cursor"]
    assert [group["number"] for group in groups] == list(range(1, 8))  # no repeat, no gap
    assert [names(group) for group in groups][3:] == [
        ["d0", "d1"], ["e0", "e1"], ["f0", "f1"], ["g0", "g1"]]
    # Without a cursor: the same stored report, still without the new models, and stale.
    again = client.get("/v1/duplicates", params={"descriptor_version": FAKE}).json()
    assert again["id"] == first["id"] and again["stale"] is True
    assert "a5" not in names(again["groups"][0])

    fresh = report(client)
    assert fresh["id"] != first["id"] and fresh["stale"] is False and fresh["models"] == 32
    assert [names(group) for group in fresh["groups"]][:2] == [
        [f"n{i}" for i in range(7)], [f"a{i}" for i in range(6)]]
    # Deleting a member makes it stale; the member shows without its names until recomputed.
    deleted = fresh["groups"][0]["members"][0]["id"]
    assert client.delete(f"/v1/models/{deleted}").status_code == 204
    after = client.get("/v1/duplicates", params={"descriptor_version": FAKE}).json()
    assert after["stale"] is True and after["groups"][0]["members"][0]["external_id"] is None


@pytest.mark.slow
def test_reports_are_kept_per_parameters_and_cursors_are_checked(client: TestClient) -> None:
    upload_copies(client, "a", ["a0", "a1"])
    strict = report(client, min_score=0.99)
    other = client.get("/v1/duplicates", params={"descriptor_version": FAKE, "min_score": 0.9})
    assert other.status_code == 404  # a report of other parameters is not answered
    assert client.get("/v1/duplicates", params={"cursor": "x"}).status_code == 422
    cursor_of = {"cursor": encode_group(uuid.UUID(strict["id"]), 0)}
    assert client.get("/v1/duplicates", params=cursor_of).json()["id"] == strict["id"]
    # Two newer reports of the same parameters: the first one is pruned, its cursor is 404.
    report(client, min_score=0.99)
    report(client, min_score=0.99)
    gone = client.get("/v1/duplicates", params=cursor_of)
    assert gone.status_code == 404 and "replaced" in gone.json()["detail"]
    too_low = client.post("/v1/duplicates", json={"min_score": 0.2})
    assert too_low.status_code == 422
    assert too_low.json()["type"] == "urn:shapesearch:problem:validation-error"


def test_an_equal_job_still_waiting_is_answered_again(sessions: sessionmaker[Session]) -> None:
    query = DuplicatesQuery(descriptor_version=FAKE)
    with sessions.begin() as session:
        first = enqueue_report(session, "t", query).id
        assert enqueue_report(session, "t", query).id == first
        assert enqueue_report(session, "u", query).id != first  # another tenant
        other = DuplicatesQuery(descriptor_version=FAKE, size_tolerance=0.02)
        assert enqueue_report(session, "t", other).id != first


def add_ready(
    sessions: sessionmaker[Session], tenant: str, version: str, vector: np.ndarray
) -> int:
    """A ready model with ``vector`` (and two views), announced on the change feed."""
    with sessions.begin() as session:
        model = Model(
            tenant=tenant, status="ready", file_name="x.stl", file_size=1,
            file_sha256="0" * 64, file_format="stl", descriptor_version=version,
            descriptor=vector.astype(np.float32).tobytes(),
            view_descriptors=np.stack([vector, vector]).astype(np.float32).tobytes(),
        )
        session.add(model)
        session.flush()
        record_event(session, model.index_id, "ready", tenant)
        return model.index_id


def test_an_index_of_one_partition_loads_that_partition_alone(
    sessions: sessionmaker[Session],
) -> None:
    vectors = unit(np.random.default_rng(2).normal(size=(6, 8)))
    mine = [add_ready(sessions, "t", "v", vector) for vector in vectors[:3]]
    add_ready(sessions, "t", "w", vectors[3])  # another version
    add_ready(sessions, "u", "v", vectors[4])  # another tenant
    index = ShapeIndex(sessions, only=("t", "v"))
    index.rebuild()
    assert index.partition_size(("t", "v")) == 3
    assert index.partition_size(("t", "w")) == index.partition_size(("u", "v")) == 0
    assert all(index.views_held(i) == 0 for i in mine)  # never loaded
    add_ready(sessions, "u", "v", vectors[5])
    latest = add_ready(sessions, "t", "v", vectors[5])
    index.sync()
    assert index.partition_size(("t", "v")) == 4 and latest in index
    assert index.partition_size(("u", "v")) == 0


def test_a_report_is_stale_after_its_tenants_changes_only(
    sessions: sessionmaker[Session],
) -> None:
    add_ready(sessions, "t", "v", unit(np.ones((1, 8)))[0])
    query = DuplicatesQuery(descriptor_version="v")
    report = compute_report(sessions, "t", query, exact_max=10, compact_min=100, nprobe=2)
    with sessions.begin() as session:
        store_report(session, "t", report, job_id=None)
    with sessions() as session:
        stored = latest_report(session, "t", query)
        assert stored is not None and stored.models == 1 and not is_stale(session, stored)
    add_ready(sessions, "u", "v", unit(np.ones((1, 8)))[0])  # another tenant's model
    with sessions() as session:
        assert not is_stale(session, stored)
    add_ready(sessions, "t", "w", unit(np.ones((1, 8)))[0])  # this tenant's, any version
    with sessions() as session:
        assert is_stale(session, stored)


def test_a_failing_report_job_fails_readably_and_touches_no_model(
    sessions: sessionmaker[Session],
) -> None:
    with sessions.begin() as session:
        job_id = enqueue_report(session, "t", DuplicatesQuery(descriptor_version=FAKE)).id
    queue = JobQueue(sessions, lease_seconds=30, max_attempts=1)

    def broken(claim: Any) -> Any:
        raise ValueError("no luck")

    worker = Worker(queue, fake_describe, worker_id="w", poll_interval=0.01,
                    stop=threading.Event(), reports=broken)
    assert worker.run_once()
    with sessions() as session:
        job = session.get(Job, job_id)
        assert job is not None and job.status == "failed" and job.model_id is None
        assert job.last_error is not None
        assert job.last_error["detail"] == "ValueError: no luck"


def test_migration_0010_goes_up_and_down(database_url: str) -> None:
    engine = make_engine(database_url)
    try:
        upgrade(engine)
        with make_session_factory(engine).begin() as session:
            enqueue_report(session, "t", DuplicatesQuery(descriptor_version=FAKE))
        config = alembic_config()
        with engine.connect() as connection:
            config.attributes["connection"] = connection
            command.downgrade(config, "0009")  # the duplicates job goes: it has no model
            connection.commit()
        tables = set(inspect(engine).get_table_names())
        assert "duplicate_reports" not in tables and "duplicate_groups" not in tables
        jobs = {c["name"]: c["nullable"] for c in inspect(engine).get_columns("jobs")}
        assert jobs["model_id"] is False and "params" not in jobs
        upgrade(engine)
        jobs = {c["name"]: c["nullable"] for c in inspect(engine).get_columns("jobs")}
        assert jobs["model_id"] is True and "params" in jobs
        assert {"duplicate_reports", "duplicate_groups"} <= set(inspect(engine).get_table_names())
    finally:
        engine.dispose()


# --- the real engine ------------------------------------------------------------------------


def moved_copy(name: str, *, mirror: bool) -> bytes:
    mesh = trimesh.load(PARTS / name, force="mesh")
    rng = np.random.default_rng(5)
    mesh.apply_transform(trimesh.transformations.random_rotation_matrix(rng.random(3)))
    mesh.apply_scale(2.5)
    if mirror:
        mesh.apply_transform(np.diag([-1.0, 1.0, 1.0, 1.0]))
    return bytes(mesh.export(file_type="stl"))


def direct_groups(database_url: str, min_score: float, k: int = 16) -> set[frozenset[str]]:
    """The groups as the API computed them before reports were stored: every ready
    descriptor read from the database, an exact all-pairs kNN, components."""
    sessions = open_sessions(database_url)
    with sessions() as session:
        rows = session.execute(
            select(Model.external_id, Model.descriptor).where(Model.status == "ready")
        ).all()
    vectors = np.stack([np.frombuffer(row.descriptor, dtype=np.float32) for row in rows])
    scores = (1 + vectors @ vectors.T) / 2
    np.fill_diagonal(scores, -np.inf)
    nearest = np.argsort(-scores, axis=1)[:, :k]
    first = np.repeat(np.arange(len(rows)), nearest.shape[1])
    keep = scores[first, nearest.ravel()] >= min_score
    graph = coo_matrix((np.ones(keep.sum()), (first[keep], nearest.ravel()[keep])),
                       shape=(len(rows), len(rows)))
    _, labels = connected_components(graph, directed=False)
    members = [frozenset(rows[i].external_id for i in np.flatnonzero(labels == label))
               for label in set(labels.tolist())]
    return {group for group in members if len(group) >= 2}


@pytest.mark.slow
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
        version = client.get("/v1/stats").json()["current_descriptor_version"]

        stored = stored_duplicates(client, min_score=0.98)
        assert stored["descriptor_version"] == version and stored["models"] == 7
        (group,) = stored["groups"]
        members = {m["external_id"] for m in group["members"]}
        assert members == {"angle_block.STL", "copy.stl", "mirror.stl"}
        assert group["size"] == 3 and len(group["pairs"]) == 3
        assert all(p["score"] >= 0.98 for p in group["pairs"])
        scores = [p["score"] for p in group["pairs"]]
        assert scores == sorted(scores, reverse=True)
        assert direct_groups(database_url, 0.98) == {frozenset(members)}

    monkeypatch.setenv("SHAPESEARCH_DATABASE_URL", database_url)
    for name, value in make_settings(database_url).model_dump().items():
        if name.startswith(("cutoff_", "max_points", "descriptor_")) and value is not None:
            monkeypatch.setenv(f"SHAPESEARCH_{name.upper()}", str(value))
    # The CLI computes and stores the same report in its own process.
    assert main(["duplicates", "--min-score", "0.98", "--format", "csv"]) == 0
    rows = list(csv.DictReader(io.StringIO(capsys.readouterr().out)))
    assert {row["external_id"] for row in rows} == members
    assert {row["group"] for row in rows} == {"1"} and {row["size"] for row in rows} == {"3"}
    assert main(["duplicates", "--min-score", "0.5", "--format", "json"]) == 0
    groups = json.loads(capsys.readouterr().out)
    assert {frozenset(m["external_id"] for m in g["members"]) for g in groups} == direct_groups(
        database_url, 0.5)
