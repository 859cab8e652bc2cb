"""Assemblies through HTTP (issue 76) on SQLite and PostgreSQL: an upload with
assembly=split gives the assembly and one model per distinct part with counts and
placements; where-used, also of a copy uploaded on its own; a new revision replaces the part
list; bombs are refused fast; tenants see only their own."""

from __future__ import annotations

import time
import uuid
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient
from sqlalchemy import create_engine, func, select

from app.auth.keys import create_key
from app.db.models import AssemblyPart, Model
from app.db.session import make_session_factory
from app.ingest.describing import encode_sample
from app.search.assemblies import UNCALIBRATED_COPY
from core.io import load_points
from tests.assembly_files import (
    assembly_3mf,
    assembly_glb,
    assembly_gltf,
    cyclic_bomb,
    deep_bomb,
    doubling_bomb,
    rotated_a_stl,
    step_assembly,
    translations,
    wide_bomb,
)
from tests.conftest import fake_describe, stored_duplicates, wait_for_status
from tests.plm_helpers import ClientFactory, started_clients

PROBLEM = "application/problem+json"


@pytest.fixture
def make_client(database_url: str) -> Iterator[ClientFactory]:
    with started_clients(database_url) as make:
        yield make


@pytest.fixture
def client(make_client: ClientFactory) -> TestClient:
    return make_client()


def post(client: TestClient, content: bytes, filename: str = "asm.glb",
         headers: dict[str, str] | None = None, **form: str) -> Any:
    return client.post("/v1/models", data=form, headers=headers,
                       files={"file": (filename, content, "application/octet-stream")})


def put(client: TestClient, external_id: str, content: bytes, **form: str) -> Any:
    return client.put(f"/v1/models/by-external-id/{external_id}",
                      files={"file": ("asm.glb", content, "application/octet-stream")},
                      data=form)


def parts_by_count(client: TestClient, assembly_id: str,
                   headers: dict[str, str] | None = None) -> dict[int, dict[str, Any]]:
    answer = client.get(f"/v1/models/{assembly_id}/parts", headers=headers)
    assert answer.status_code == 200, answer.text
    assert answer.json()["assembly_id"] == assembly_id
    return {part["count"]: part for part in answer.json()["parts"]}


def where_used(client: TestClient, model_id: str,
               headers: dict[str, str] | None = None) -> dict[str, int]:
    answer = client.get(f"/v1/models/{model_id}/where-used", headers=headers)
    assert answer.status_code == 200, answer.text
    return {entry["assembly"]["id"]: entry["count"] for entry in answer.json()["assemblies"]}


def assert_problem(response: Any, status: int, kind: str) -> dict[str, Any]:
    assert response.status_code == status, response.text
    assert response.headers["content-type"].startswith(PROBLEM)
    body: dict[str, Any] = response.json()
    assert body["type"].endswith(kind), body
    return body


def orphans(database_url: str) -> int:
    """assembly_parts rows whose assembly or part is gone."""
    engine = create_engine(database_url)
    try:
        with engine.connect() as connection:
            known = select(Model.id)
            return int(connection.scalar(
                select(func.count()).select_from(AssemblyPart).where(
                    AssemblyPart.assembly_id.not_in(known) | AssemblyPart.part_id.not_in(known))
            ) or 0)
    finally:
        engine.dispose()


def rows_of(database_url: str, assembly_id: str) -> int:
    engine = create_engine(database_url)
    try:
        with engine.connect() as connection:
            return int(connection.scalar(
                select(func.count()).select_from(AssemblyPart)
                .where(AssemblyPart.assembly_id == uuid.UUID(assembly_id))
            ) or 0)
    finally:
        engine.dispose()


@pytest.mark.slow
def test_a_split_glb_gives_its_parts_with_counts_and_where_used(client: TestClient) -> None:
    accepted = post(client, assembly_glb(), assembly="split", name="frame")
    assert accepted.status_code == 202, accepted.text
    assembly = accepted.json()
    parts = parts_by_count(client, assembly["id"])
    assert set(parts) == {1, 4}
    a, b = parts[4], parts[1]
    assert translations(a["placements"]) == [
        [0.0, 0.0, 0.0], [0.0, 0.0, 100.0], [60.0, 0.0, 0.0], [120.0, 0.0, 0.0]]
    assert all(len(p) == 16 for p in a["placements"])
    assert a["model"]["name"].startswith("frame / ")
    # The parts are models of their own, described like any upload; so is the assembly.
    for model_id in (assembly["id"], a["model"]["id"], b["model"]["id"]):
        assert wait_for_status(client, model_id)["status"] == "ready"
    assert len(client.get("/v1/models").json()["items"]) == 3
    assert where_used(client, a["model"]["id"]) == {assembly["id"]: 4}
    assert where_used(client, b["model"]["id"]) == {assembly["id"]: 1}
    assert where_used(client, assembly["id"]) == {}
    # A model uploaded whole has no parts; unknown ids are 404 Problems.
    whole = post(client, assembly_glb(), filename="whole.glb").json()
    assert client.get(f"/v1/models/{whole['id']}/parts").json()["parts"] == []
    for path in ("parts", "where-used"):
        assert_problem(client.get(f"/v1/models/00000000-0000-0000-0000-000000000000/{path}"),
                       404, "model-not-found")
        assert_problem(client.get(f"/v1/models/not-a-uuid/{path}"), 404, "model-not-found")


def test_the_default_split_setting_splits_assemblies_and_leaves_single_parts_whole(
        make_client: ClientFactory) -> None:
    client = make_client(assembly_default="split")
    assembly = post(client, assembly_glb(), name="frame").json()
    assert set(parts_by_count(client, assembly["id"])) == {1, 4}
    for content, filename in ((rotated_a_stl(), "a.stl"),
                              (assembly_glb(with_b=False, a_outside=0), "one.glb")):
        single = post(client, content, filename=filename)
        assert single.status_code == 202, single.text
        assert parts_by_count(client, single.json()["id"]) == {}
    # Asked for, whole wins over the default.
    whole = post(client, assembly_glb(), filename="whole.glb", assembly="whole").json()
    assert parts_by_count(client, whole["id"]) == {}
    assert len(client.get("/v1/models").json()["items"]) == 6  # 3 + 2 parts of the first


def test_gltf_and_3mf_assemblies_split_and_the_part_limit_is_a_setting(
        make_client: ClientFactory) -> None:
    client = make_client()
    gltf = post(client, assembly_gltf(), filename="asm.gltf", assembly="split")
    assert gltf.status_code == 202, gltf.text
    assert set(parts_by_count(client, gltf.json()["id"])) == {1, 4}
    package = post(client, assembly_3mf(a_count=3), filename="asm.3mf", assembly="split")
    assert package.status_code == 202, package.text
    assert set(parts_by_count(client, package.json()["id"])) == {1, 3}
    narrow = make_client(assembly_max_parts=1)
    body = assert_problem(post(narrow, assembly_3mf(), filename="asm.3mf", assembly="split"),
                          422, "assembly-too-large")
    assert "more than 1 distinct parts" in body["detail"]


def test_assembly_id_narrows_the_list_and_similar_to_its_parts(
        make_client: ClientFactory, database_url: str) -> None:
    client = make_client(auth_cache_seconds=0)
    engine = create_engine(database_url)
    with make_session_factory(engine).begin() as session:
        alice = {"Authorization": f"Bearer {create_key(session, 'alice')}"}
        bob = {"Authorization": f"Bearer {create_key(session, 'bob')}"}
    engine.dispose()
    client.headers.update(alice)
    assembly = post(client, assembly_glb(), assembly="split").json()
    other = post(client, assembly_glb(with_b=False), filename="other.glb",
                 assembly="split").json()
    loose = post(client, rotated_a_stl(), filename="bracket.stl").json()
    part_ids = {part["model"]["id"] for part in parts_by_count(client, assembly["id"]).values()}
    assert len(part_ids) == 2
    everything = [item["id"] for item in client.get("/v1/models").json()["items"]]
    for model_id in everything:
        assert wait_for_status(client, model_id)["status"] == "ready"
    listed = client.get("/v1/models", params={"assembly_id": assembly["id"]}).json()["items"]
    assert {item["id"] for item in listed} == part_ids
    # The other assembly's A is another model (its own upload): not in this list.
    assert parts_by_count(client, other["id"])[4]["model"]["id"] not in part_ids
    similar = client.get(f"/v1/models/{loose['id']}/similar",
                         params={"k": 10, "assembly_id": assembly["id"]})
    assert similar.status_code == 200, similar.text
    assert {r["model"]["id"] for r in similar.json()["results"]} == part_ids
    unfiltered = client.get(f"/v1/models/{loose['id']}/similar", params={"k": 10}).json()
    assert len(unfiltered["results"]) > len(part_ids)  # the filter did the narrowing
    # An id that places nothing (unknown, a part, another tenant's assembly): no results.
    nobody = str(uuid.uuid4())
    a_part = next(iter(part_ids))
    for assembly_id, headers in ((nobody, alice), (a_part, alice), (assembly["id"], bob)):
        assert client.get("/v1/models", params={"assembly_id": assembly_id},
                          headers=headers).json()["items"] == []
    assert client.get(f"/v1/models/{loose['id']}/similar",
                      params={"assembly_id": nobody}).json()["results"] == []
    assert_problem(client.get("/v1/models", params={"assembly_id": "nope"}), 422,
                   "validation-error")


def test_the_duplicates_report_says_which_assemblies_use_each_group(
        client: TestClient) -> None:
    first = post(client, assembly_glb(), assembly="split").json()
    second = post(client, assembly_glb(with_b=False, a_outside=1), filename="two.glb",
                  assembly="split").json()
    loose = post(client, rotated_a_stl(), filename="bracket.stl").json()
    for model_id in [item["id"] for item in client.get("/v1/models").json()["items"]]:
        assert wait_for_status(client, model_id)["status"] == "ready"
    a_first = parts_by_count(client, first["id"])[4]["model"]["id"]
    a_second = parts_by_count(client, second["id"])[2]["model"]["id"]
    # The fake engine: equal files, equal descriptors; A is the same file in both.
    plain = stored_duplicates(client, descriptor_version="fake-1", min_score=0.99)
    group = next(g for g in plain["groups"] if a_first in {m["id"] for m in g["members"]})
    assert {m["id"] for m in group["members"]} == {a_first, a_second}
    assert "where_used" not in group  # absent unless asked
    page = client.get("/v1/duplicates", params={
        "descriptor_version": "fake-1", "min_score": 0.99, "where_used": "true"}).json()
    group = next(g for g in page["groups"] if a_first in {m["id"] for m in g["members"]})
    used = {entry["assembly"]["id"]: (entry["count"], entry["parts"])
            for entry in group["where_used"]}
    assert used == {first["id"]: (4, [a_first]), second["id"]: (2, [a_second])}
    assert all(g["where_used"] == [] for g in page["groups"]
               if loose["id"] in {m["id"] for m in g["members"]})


def sampled_describe(content: bytes, filename: str) -> dict[str, Any]:
    """``fake_describe`` with the file's real sample points (``Model.sample``)."""
    points = load_points(content, filename=filename, max_points=1500).points
    return {**fake_describe(content, filename), "sample": encode_sample(points)}


def test_the_assembly_points_are_labelled_with_the_part_they_lie_on(
        make_client: ClientFactory) -> None:
    client = make_client(handler=sampled_describe)
    assembly = post(client, assembly_glb(), assembly="split").json()
    parts = parts_by_count(client, assembly["id"])
    for model_id in (assembly["id"], parts[4]["model"]["id"], parts[1]["model"]["id"]):
        assert wait_for_status(client, model_id)["status"] == "ready"
    answer = client.get(f"/v1/models/{assembly['id']}/parts/points", params={"points": 900})
    assert answer.status_code == 200, answer.text
    body = answer.json()
    points, labels = np.asarray(body["points"]), np.asarray(body["labels"])
    assert len(points) == len(labels) == 900
    pin = body["part_ids"].index(parts[1]["model"]["id"])
    bracket = body["part_ids"].index(parts[4]["model"]["id"])
    assert set(labels.tolist()) == {pin, bracket}
    # The pin (radius 4, length 30 along z) is placed at y = 60, the brackets far from it.
    on_pin = (np.abs(points[:, 1] - 60.0) <= 4.01) & (np.abs(points[:, 2]) <= 15.01)
    assert on_pin.sum() > 20
    assert np.array_equal(labels == pin, on_pin)
    assert_problem(client.get(f"/v1/models/{assembly['id']}/parts/points",
                              params={"points": 0}), 422, "validation-error")


@pytest.mark.slow
def test_a_copy_of_a_part_is_recognised_by_where_used(client: TestClient) -> None:
    """The fake describer gives equal files equal descriptors: the same part's file in a
    second assembly, and uploaded alone, is a copy; both assemblies are listed."""
    first = post(client, assembly_glb(), assembly="split").json()
    second = post(client, assembly_glb(with_b=False, a_outside=1), filename="other.glb",
                  assembly="split").json()
    a_first = parts_by_count(client, first["id"])[4]["model"]["id"]
    a_second = parts_by_count(client, second["id"])[2]["model"]["id"]
    assert a_first != a_second  # each assembly has its own part models
    for model_id in (a_first, a_second):
        wait_for_status(client, model_id)
    time.sleep(0.5)  # the index follows the feed
    assert where_used(client, a_first) == {first["id"]: 4, second["id"]: 2}
    assert where_used(client, a_second) == {first["id"]: 4, second["id"]: 2}
    # Similar answers tell it too, when asked.
    similar = client.get(f"/v1/models/{a_first}/similar", params={"where_used": "true"})
    assert similar.status_code == 200, similar.text
    found = {r["model"]["id"]: r for r in similar.json()["results"]}
    assert {e["assembly"]["id"]: e["count"] for e in found[a_second]["where_used"]} == {
        first["id"]: 4, second["id"]: 2}
    assert found[a_second]["where_used"][0]["parts"][0] in (a_first, a_second)
    plain = client.get(f"/v1/models/{a_first}/similar").json()["results"]
    assert all("where_used" not in result for result in plain)


@pytest.mark.slow
def test_a_new_revision_replaces_the_part_list(client: TestClient, database_url: str) -> None:
    created = put(client, "ASM-1", assembly_glb(), assembly="split")
    assert created.status_code == 201, created.text
    assembly_id = created.json()["id"]
    before = parts_by_count(client, assembly_id)
    a_id, b_id = before[4]["model"]["id"], before[1]["model"]["id"]
    revised = put(client, "ASM-1", assembly_glb(with_b=False, a_outside=1), assembly="split")
    assert revised.status_code == 202, revised.text
    after = parts_by_count(client, assembly_id)
    assert list(after) == [2] and after[2]["model"]["id"] == a_id  # the same part model
    assert where_used(client, a_id) == {assembly_id: 2}
    assert where_used(client, b_id) == {}  # B stays a model, used nowhere
    assert client.get(f"/v1/models/{b_id}").status_code == 200
    assert rows_of(database_url, assembly_id) == 2
    # Deleting the assembly takes its rows with it.
    assert client.delete(f"/v1/models/{assembly_id}").status_code == 204
    assert rows_of(database_url, assembly_id) == 0 and orphans(database_url) == 0
    assert client.get(f"/v1/models/{a_id}/where-used").json()["assemblies"] == []


@pytest.mark.slow
def test_a_step_assembly_is_split_into_its_solids(client: TestClient) -> None:
    pytest.importorskip("OCP.STEPControl", reason="OpenCascade (cadquery-ocp) is not installed")
    accepted = post(client, step_assembly(), filename="asm.step", assembly="split")
    assert accepted.status_code == 202, accepted.text
    parts = parts_by_count(client, accepted.json()["id"])
    assert set(parts) == {1, 4}
    assert parts[4]["model"]["id"] != parts[1]["model"]["id"]
    assert where_used(client, parts[4]["model"]["id"]) == {accepted.json()["id"]: 4}


@pytest.mark.slow
@pytest.mark.parametrize("bomb", [wide_bomb, deep_bomb, doubling_bomb, cyclic_bomb])
def test_assembly_bombs_are_refused(client: TestClient, bomb: Any) -> None:
    data = bomb()
    started = time.monotonic()
    answer = post(client, data, filename="bomb.glb", assembly="split")
    assert time.monotonic() - started < 2.0
    assert_problem(answer, 422, "assembly-too-large")
    assert client.get("/v1/models").json()["items"] == []  # nothing stored


@pytest.mark.slow
def test_tenants_see_only_their_own_parts(make_client: ClientFactory, database_url: str) -> None:
    client = make_client(auth_cache_seconds=0)
    engine = create_engine(database_url)
    with make_session_factory(engine).begin() as session:
        alice = {"Authorization": f"Bearer {create_key(session, 'alice')}"}
        bob = {"Authorization": f"Bearer {create_key(session, 'bob')}"}
    engine.dispose()
    mine = post(client, assembly_glb(), assembly="split", headers=alice).json()
    theirs = post(client, assembly_glb(), assembly="split", headers=bob).json()
    a_mine = parts_by_count(client, mine["id"], alice)[4]["model"]["id"]
    a_theirs = parts_by_count(client, theirs["id"], bob)[4]["model"]["id"]
    wait_for_status(client, a_mine, headers=alice)
    wait_for_status(client, a_theirs, headers=bob)
    time.sleep(0.5)
    # bob's identical part is not a copy alice can see, nor his assembly a place of use.
    assert where_used(client, a_mine, alice) == {mine["id"]: 4}
    for path in ("parts", "where-used"):
        assert_problem(client.get(f"/v1/models/{mine['id']}/{path}", headers=bob),
                       404, "model-not-found")
        assert_problem(client.get(f"/v1/models/{a_mine}/{path}", headers=bob),
                       404, "model-not-found")


@pytest.mark.slow
def test_a_rotated_copy_uploaded_alone_finds_the_assembly(make_client: ClientFactory,
                                                          backend: str) -> None:
    """The real engine: part A turned and moved, uploaded on its own, scores as a copy of
    the assembly's A (likeness "copy", or without a calibration a raw score of at least
    UNCALIBRATED_COPY; the same size)."""
    if backend != "sqlite":
        pytest.skip("the real engine's answer does not depend on the backend")
    client = make_client(handler=None)
    assembly = post(client, assembly_glb(), assembly="split").json()
    a_id = parts_by_count(client, assembly["id"])[4]["model"]["id"]
    alone = post(client, rotated_a_stl(), filename="bracket.stl").json()
    for model_id in [item["id"] for item in client.get("/v1/models").json()["items"]]:
        assert wait_for_status(client, model_id)["status"] == "ready"
    time.sleep(0.5)
    assert where_used(client, alone["id"]) == {assembly["id"]: 4}
    listed = client.get(f"/v1/models/{alone['id']}/where-used").json()["assemblies"]
    assert listed[0]["parts"] == [a_id]
    similar = client.get(f"/v1/models/{alone['id']}/similar",
                         params={"where_used": "true"}).json()["results"]
    found = {r["model"]["id"]: r for r in similar}
    # The test engine's descriptor layout has no calibration: the raw score decides.
    assert found[a_id]["likeness"] == "copy" or (
        found[a_id]["likeness"] is None and found[a_id]["score"] >= UNCALIBRATED_COPY)
    assert [(e["assembly"]["id"], e["count"]) for e in found[a_id]["where_used"]] == [
        (assembly["id"], 4)]
    # A search by upload (the real engine describes it): narrowed to the assembly's parts,
    # each with where it is used.
    searched = client.post(
        "/v1/search", params={"k": 5, "assembly_id": assembly["id"], "where_used": "true"},
        files={"file": ("scan.stl", rotated_a_stl(), "model/stl")})
    assert searched.status_code == 200, searched.text
    results = searched.json()["results"]
    part_ids = {p["model"]["id"] for p in parts_by_count(client, assembly["id"]).values()}
    assert {r["model"]["id"] for r in results} == part_ids  # not `alone`, not the assembly
    assert results[0]["model"]["id"] == a_id
    assert [(e["assembly"]["id"], e["count"]) for e in results[0]["where_used"]] == [
        (assembly["id"], 4)]
    plain = client.post("/v1/search", params={"k": 5},
                        files={"file": ("scan.stl", rotated_a_stl(), "model/stl")}).json()
    assert {r["model"]["id"] for r in plain["results"]} > part_ids
    assert all("where_used" not in r for r in plain["results"])
