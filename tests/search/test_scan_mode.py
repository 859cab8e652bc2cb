"""Scan mode (issue 12): virtual partial views of every model as extra index entries.

The geometry of the views and how they are described (``core.views``, ``core.pipeline``);
the bookkeeping of the index (views in their own partition, one result per model, deletes
remove every view, directly and through the change feed, re-describes replace them); the
scoring (a model's distance is its best entry's, checked against a direct computation);
the default mode untouched; the migration on both backends; and the API end to end.
"""

from __future__ import annotations

import io
import json
from dataclasses import replace
from typing import Any

import numpy as np
import pytest
import trimesh
from alembic import command
from fastapi.testclient import TestClient
from sqlalchemy import inspect, update
from sqlalchemy.orm import Session, sessionmaker

import core.rank.scan_order
from app.api.main import create_app
from app.db.feed import record_event
from app.db.migrate import alembic_config, upgrade
from app.db.models import Model
from app.db.session import make_engine
from app.ingest.describing import ingest_columns
from app.search.index import VIEW_ID_BASE, ShapeIndex, view_id, view_of, views_key
from app.search.similarity import find_similar, score_of
from app.settings import engine_settings
from core.pipeline import describe_points, scan_weights
from core.rank.hubness import (
    HUB_NEIGHBOURS,
    SCAN_HUB_NEIGHBOURS,
    SCAN_HUB_WEIGHT,
    hub_keys,
    neighbourhood_radii,
    rerank_depth,
)
from core.rank.reciprocal import pool_keys
from core.rank.scan_order import scan_depth
from core.settings import EngineSettings, ViewSettings
from core.views import (
    frame_directions,
    hidden_point_removal,
    signed_principal_axes,
    view_directions,
    view_from,
    virtual_views,
)
from tests.conftest import make_settings, wait_for_status
from tests.search.test_hub_search import hub_order
from tests.search.test_index import add_ready as add_model
from tests.search.test_index import delete_model
from tests.shapes import fibonacci_sphere_points, plate_points, torus_points

KEY = ("t", "v1")


# --- geometry ---------------------------------------------------------------------------


def test_views_of_a_sphere_each_see_the_near_cap_of_about_half_of_it() -> None:
    points = fibonacci_sphere_points(4000)
    views = virtual_views(points, 4)
    diagonal = 2.0 * np.sqrt(3.0)  # of the unit sphere's bounding box
    # A sphere seen from distance D sees the cap z > 1/D: (1 - 1/D) / 2 of its area.
    expected = (1.0 - 1.0 / (3.0 * diagonal)) / 2.0
    for view, direction in zip(views, view_directions(4), strict=True):
        assert len(view) / len(points) == pytest.approx(expected, abs=0.03)
        assert np.all(view @ direction > 0.0)  # all of it on the near side
    # Different directions see different caps.
    assert len({len(view) for view in views}) > 1 or not np.array_equal(views[0], views[1])


def test_hidden_point_removal_keeps_only_the_side_facing_the_viewpoint() -> None:
    # A large plate above a smaller one: seen from far above, the lower plate is hidden.
    top = plate_points(3000, seed=1) + [0.0, 0.0, 1.0]
    bottom = plate_points(1000, a=0.5, b=0.5, seed=2) + [0.25, 0.25, 0.0]
    points = np.vstack([top, bottom])
    visible = hidden_point_removal(points, np.array([0.5, 0.5, 50.0]))
    assert np.mean(visible < len(top)) > 0.97  # what is seen is the top plate
    assert np.isin(np.arange(len(top)), visible).mean() > 0.9  # most of it
    # From below, the lower plate is in front and is seen.
    from_below = hidden_point_removal(points, np.array([0.5, 0.5, -50.0]))
    assert np.isin(np.arange(len(top), len(points)), from_below).mean() > 0.9


@pytest.mark.slow
def test_views_are_described_as_scans_of_the_loaded_points() -> None:
    settings = EngineSettings(
        max_points=1500, outlier_filter=False, views=ViewSettings(boundary_weights=True)
    )
    whole = describe_points(torus_points(1500), settings, views=3)
    assert whole.views.shape == (3, len(whole.descriptor))
    np.testing.assert_allclose(np.linalg.norm(whole.views, axis=1), 1.0, atol=1e-5)
    # Each view equals describing that part of the (normalised) points as a scan.
    part = virtual_views(whole.points, 3)[1]
    alone = describe_points(part, settings, scan=True)
    assert alone.scan_descriptor is not None
    np.testing.assert_allclose(whole.views[1], alone.scan_descriptor, atol=1e-5)
    # A view has an open rim: its scan descriptor differs from its plain one.
    assert scan_weights(alone.points, settings).min() < 0.5
    assert np.linalg.norm(alone.scan_descriptor - alone.descriptor) > 1e-3


@pytest.mark.slow
def test_a_views_size_is_not_measured(monkeypatch: pytest.MonkeyPatch) -> None:
    """A view keeps only its scan descriptor: the oriented box of its points (a fifth of
    a view's time on a torus) is measured once, for the model, not once per view."""
    import core.size

    measured: list[int] = []
    of_points = core.size.ShapeSize.of_points

    def counting(points: np.ndarray, area: float) -> core.size.ShapeSize:
        measured.append(len(points))
        return of_points(points, area)

    monkeypatch.setattr(core.size.ShapeSize, "of_points", staticmethod(counting))
    whole = describe_points(torus_points(1500), EngineSettings(max_points=1500), views=3)
    assert whole.views.shape[0] == 3
    assert len(measured) == 1 and whole.size is not None
    assert measured[0] == len(whole.points)  # the model's own points


def test_boundary_weights_are_a_switch_off_by_default() -> None:
    settings = EngineSettings(max_points=1500, outlier_filter=False)
    assert not settings.views.boundary_weights
    whole = describe_points(torus_points(1500), settings)
    part = virtual_views(whole.points, 3)[1]
    plain = describe_points(part, settings, scan=True)
    np.testing.assert_array_equal(scan_weights(plain.points, settings), 1.0)
    np.testing.assert_array_equal(plain.scan_descriptor, plain.descriptor)
    on = replace(settings, views=ViewSettings(boundary_weights=True))
    weighted = describe_points(part, on, scan=True)
    np.testing.assert_array_equal(weighted.descriptor, plain.descriptor)
    assert np.linalg.norm(weighted.scan_descriptor - weighted.descriptor) > 1e-3


def test_a_flat_part_seen_edge_on_loses_that_view_only() -> None:
    # View 1 of 3 lies in the plane z = 0 (view_directions' middle ring): edge-on to a plate.
    plate = plate_points(1200, a=1.0, b=0.6, seed=1)
    assert abs(view_directions(3)[1][2]) < 1e-12
    assert [len(view) > 0 for view in virtual_views(plate, 3)] == [True, False, True]
    described = describe_points(plate, EngineSettings(max_points=1200), views=3)
    assert described.views.shape == (2, len(described.descriptor))


def _screw_points(length: float, seed: int) -> np.ndarray:
    """A shaft of radius 0.1 along +x from 0 to ``length`` with a head (radius 0.2, length
    0.15) at x = 0: surface points."""
    shaft = trimesh.creation.cylinder(radius=0.1, height=length)
    shaft.apply_translation([0.0, 0.0, length / 2.0])
    head = trimesh.creation.cylinder(radius=0.2, height=0.15)
    head.apply_translation([0.0, 0.0, -0.075])
    screw = trimesh.util.concatenate([shaft, head])
    points = trimesh.sample.sample_surface(screw, 3000, seed=seed)[0]
    return points[:, [2, 1, 0]]  # the shaft along x


def test_frame_directions_turn_with_the_part_and_ignore_point_order() -> None:
    points = _screw_points(1.2, seed=3) * [1.0, 1.0, 0.7]  # no two spreads alike
    rotation = np.linalg.qr(np.random.default_rng(5).normal(size=(3, 3)))[0]
    for tilt in (np.radians(20.0), np.radians(45.0)):
        directions = frame_directions(points, tilt)
        np.testing.assert_allclose(directions @ directions.T, np.eye(3), atol=1e-12)
        np.testing.assert_allclose(frame_directions(points @ rotation.T, tilt),
                                   directions @ rotation.T, atol=1e-9)
        shuffled = points[np.random.default_rng(1).permutation(len(points))]
        np.testing.assert_allclose(frame_directions(shuffled, tilt), directions, atol=1e-9)
        # Each leans towards its own axis, and lies in no principal plane.
        lean = np.abs(directions @ signed_principal_axes(points))
        assert np.all(np.argmax(lean, axis=1) == [0, 1, 2])
        assert lean.min() > 0.1


def test_the_frame_is_signed_alike_for_parts_of_one_kind() -> None:
    # Two screws of other lengths, uploaded turned about: the long axis points from the head
    # to the tip (the points' longer tail) for both, whichever way they were uploaded.
    for length, seed in ((1.0, 1), (1.6, 2)):
        points = _screw_points(length, seed)
        for sign in (1.0, -1.0):
            axis = signed_principal_axes(points * [sign, 1.0, 1.0])[:, 0]
            assert axis[0] * sign > 0.99


def test_no_frame_view_of_a_plate_is_edge_on() -> None:
    plate = plate_points(1200, a=1.0, b=0.6, seed=1)
    for tilt in (np.radians(20.0), np.radians(45.0)):
        seen = [len(view_from(plate, direction)) for direction in frame_directions(plate, tilt)]
        assert min(seen) > 0.3 * len(plate)


def test_a_closed_surface_described_as_a_scan_is_unchanged() -> None:
    settings = EngineSettings(max_points=1500)
    sphere = describe_points(fibonacci_sphere_points(1500), settings, scan=True)
    assert sphere.scan_descriptor is not None
    np.testing.assert_array_equal(sphere.scan_descriptor, sphere.descriptor)
    assert sphere.views.shape[0] == 0  # none asked for


# --- index and scoring ------------------------------------------------------------------


def unit(rows: np.ndarray) -> np.ndarray:
    rows = np.asarray(rows, dtype=np.float32)
    return rows / np.linalg.norm(rows, axis=-1, keepdims=True)


def add_ready(
    sessions: sessionmaker[Session],
    vector: np.ndarray,
    views: np.ndarray | None,
    meta: dict[str, Any] | None = None,
) -> int:
    """A ready model of partition ``KEY`` with its views, unit vectors all."""
    return add_model(
        sessions,
        unit(vector),
        tenant=KEY[0],
        version=KEY[1],
        meta=meta,
        views=None if views is None else unit(views),
    )


def catalogue(
    sessions: sessionmaker[Session], count: int, views: int, seed: int = 0, d: int = 8
) -> dict[int, np.ndarray]:
    """``count`` random models with ``views`` random views each; id -> (1 + views, d) entries
    (the model first), and the metadata ``{"even": parity}``."""
    rng = np.random.default_rng(seed)
    entries = {}
    for number in range(count):
        rows = unit(rng.normal(size=(1 + views, d)))
        index_id = add_ready(sessions, rows[0], rows[1:], {"even": str(number % 2 == 0)})
        entries[index_id] = rows
    return entries


def brute_force(
    entries: dict[int, np.ndarray], query: np.ndarray, first_only: bool = False
) -> list[tuple[int, float]]:
    """Every model's best-entry distance (or its descriptor's), nearest first."""
    distances = {
        i: float(np.linalg.norm((rows[:1] if first_only else rows) - query, axis=1).min())
        for i, rows in entries.items()
    }
    return sorted(distances.items(), key=lambda item: (item[1], item[0]))


def scan_search(
    index: ShapeIndex, sessions: sessionmaker[Session], query: np.ndarray, **options: Any
) -> list[Any]:
    with sessions() as session:
        return find_similar(index, session.connection(), KEY, query, mode="scan", **options)


def test_view_ids_are_deterministic_and_apart_from_model_ids() -> None:
    assert view_id(7, 0) > VIEW_ID_BASE > 2**40
    assert view_of(view_id(123456, 5)) == (123456, 5)
    assert view_id(8, 0) == view_id(7, 15) + 1  # no overlap between models
    assert views_key(KEY) != KEY


def test_one_result_per_model_even_when_several_of_its_views_are_near(
    sessions: sessionmaker[Session],
) -> None:
    rng = np.random.default_rng(3)
    query = unit(rng.normal(size=8))
    near_views = unit(query + 0.05 * rng.normal(size=(4, 8)))
    crowd = add_ready(sessions, -query, near_views)  # far whole, four near views
    others = [add_ready(sessions, rng.normal(size=8), rng.normal(size=(4, 8))) for _ in range(3)]
    index = ShapeIndex(sessions, hub_neighbours=0)  # plain order
    index.rebuild()
    assert len(index) == 4 and index.partition_size(views_key(KEY)) == 16
    found = scan_search(index, sessions, query, k=3)
    ids = [m.model.index_id for m in found]
    assert len(ids) == len(set(ids)) == 3
    assert ids[0] == crowd
    best = np.linalg.norm(near_views - query, axis=1)
    assert found[0].view == int(np.argmin(best))
    assert found[0].distance == pytest.approx(best.min(), abs=1e-5)
    everything = scan_search(index, sessions, query, k=10)
    assert sorted(m.model.index_id for m in everything) == sorted([crowd, *others])


def test_best_view_scoring_agrees_with_a_direct_computation(
    sessions: sessionmaker[Session],
) -> None:
    entries = catalogue(sessions, 40, views=3, seed=5)
    index = ShapeIndex(sessions, hub_neighbours=0)  # plain order
    index.rebuild()
    rng = np.random.default_rng(6)
    for _ in range(5):
        query = unit(rng.normal(size=8))
        expected = brute_force(entries, query)
        found = scan_search(index, sessions, query, k=7)
        assert [m.model.index_id for m in found] == [i for i, _ in expected[:7]]
        for match, (_, distance) in zip(found, expected, strict=False):
            assert match.distance == pytest.approx(distance, abs=1e-5)
            assert match.score == pytest.approx(1.0 - distance**2 / 4.0, abs=1e-5)
            assert match.score == score_of(match.distance)
        # Filters and min_score apply to the best-entry ranking as in shape mode, both when
        # pushed down to SQL and when candidates are filtered in rounds.
        even = {i for i in entries if (list(entries).index(i) % 2 == 0)}
        wanted = [(i, d) for i, d in expected if i in even]
        cut = score_of(wanted[3][1]) - 1e-6  # below the 4th by rounding only
        assert score_of(wanted[4][1]) < cut
        for pushdown in (10_000, 0):
            with sessions() as session:
                filtered = find_similar(
                    index,
                    session.connection(),
                    KEY,
                    query,
                    k=5,
                    mode="scan",
                    min_score=cut,
                    filters={"even": "True"},
                    pushdown_max=pushdown,
                )
            assert [m.model.index_id for m in filtered] == [i for i, _ in wanted[:4]]


@pytest.mark.slow
def test_a_filter_that_few_models_pass_widens_the_search_in_rounds(
    sessions: sessionmaker[Session],
) -> None:
    # One model in 30 passes the filter: the first round's candidates hold fewer than k of
    # them, so the search widens; every later round must still apply the size filter and
    # distance (a loop variable once shadowed it with a partition's size).
    rng = np.random.default_rng(21)
    entries, rare = {}, set()
    for number in range(300):
        rows = unit(rng.normal(size=(4, 8)))
        kind = "rare" if number % 30 == 0 else "common"
        index_id = add_ready(sessions, rows[0], rows[1:], {"kind": kind})
        entries[index_id] = rows
        if kind == "rare":
            rare.add(index_id)
    index = ShapeIndex(sessions, hub_neighbours=0)  # plain order
    index.rebuild()
    query = unit(rng.normal(size=8))
    expected = [(i, d) for i, d in brute_force(entries, query) if i in rare][:5]
    found = scan_search(index, sessions, query, k=5, filters={"kind": "rare"}, pushdown_max=0)
    assert [m.model.index_id for m in found] == [i for i, _ in expected]
    for match, (_, distance) in zip(found, expected, strict=True):
        assert match.distance == pytest.approx(distance, abs=1e-5)


def hub_keys_of(
    entries: dict[int, np.ndarray], query: np.ndarray, k: int, exclude: int | None = None,
    depth: int | None = None, gone: frozenset[int] = frozenset(),
) -> dict[int, float]:
    """Scan mode's hub discount computed directly over the whole catalogue: the
    ``depth`` (``rerank_depth(k)`` unless given) nearest models by best entry (not those
    ``gone``: deleted since the index synced, still in every radius), each keyed
    by its least
    ``|q - e|^2 + SCAN_HUB_WEIGHT r(e)``, ``r(e)`` the mean over the 5 other models (not
    ``exclude``) most alike ``e`` of ``e``'s largest cosine to their entries."""
    catalogue_ids = [i for i in entries if i != exclude]
    plain = [i for i, _ in brute_force({i: entries[i] for i in catalogue_ids}, query)
             if i not in gone]
    keys = {}
    for model in plain[: rerank_depth(k) if depth is None else depth]:
        entry_keys = []
        for entry in entries[model]:
            others = [other for other in catalogue_ids if other != model]
            best = sorted((float((entries[o] @ entry).max()) for o in others), reverse=True)
            best = best[:SCAN_HUB_NEIGHBOURS]
            radius = sum(best) / len(best)
            entry_keys.append(float(np.sum((entry - query) ** 2)) + SCAN_HUB_WEIGHT * radius)
        keys[model] = min(entry_keys)
    return keys


def discounted_order(
    entries: dict[int, np.ndarray], query: np.ndarray, k: int, exclude: int | None = None
) -> list[int]:
    """The hub keys' order alone (``hub_keys_of``)."""
    keys = hub_keys_of(entries, query, k, exclude)
    return sorted(keys, key=lambda i: (keys[i], i))[:k]


def scan_order(
    entries: dict[int, np.ndarray], query: np.ndarray, k: int, exclude: int | None = None,
    reciprocal: bool = False, gone: frozenset[int] = frozenset(),
    neighbours: int | None = None,
) -> list[int]:
    """Scan mode's order computed directly: of the pool (the plain nearest
    ``scan_depth(k)``) the least hub key first, then the rest of the pool joined with the
    ``neighbours`` (``ANCHOR_NEIGHBOURS`` unless given) models nearest the first answer's
    whole descriptor ``a`` (not ``exclude``), as a shape query for ``a`` orders them:
    ``|x - a|^2 + r_10(x)``, ``r_10`` over every whole descriptor but ``exclude``'s, then
    (``reciprocal``) ``pool_keys`` among them. Models ``gone`` are in no pool and in every
    radius (deleted since the index synced, or refused by a filter)."""
    keys = hub_keys_of(entries, query, k, exclude, scan_depth(k), gone)
    first = min(keys, key=lambda i: (keys[i], i))
    anchor = entries[first][0].astype(np.float64)
    ids = [i for i in entries if i != exclude]
    radii = dict(zip(ids, neighbourhood_radii(np.array([entries[i][0] for i in ids]),
                                              HUB_NEIGHBOURS), strict=True))
    others = [i for i in ids if i != first and i not in gone]
    by_nearness = sorted(others, key=lambda i: (float(np.sum((entries[i][0] - anchor) ** 2)), i))
    if neighbours is None:
        neighbours = core.rank.scan_order.ANCHOR_NEIGHBOURS
    pool = [i for i in keys if i != first]  # nearest by best entry first
    rest = pool + [i for i in by_nearness[:neighbours] if i not in pool]
    squared = np.array([float(np.sum((entries[i][0] - anchor) ** 2)) for i in rest])
    near = hub_keys(squared, np.array([radii[i] for i in rest]))
    if reciprocal:
        near = pool_keys(anchor, np.array([entries[i][0] for i in rest]), near)
    order = sorted(range(len(rest)), key=lambda j: (near[j], rest[j]))
    return [first, *(rest[j] for j in order)][:k]


@pytest.mark.slow
@pytest.mark.parametrize("reciprocal", [False, True])
@pytest.mark.parametrize("neighbours", [12, core.rank.scan_order.ANCHOR_NEIGHBOURS])
def test_scan_mode_orders_as_a_direct_computation(
    sessions: sessionmaker[Session], reciprocal: bool, neighbours: int,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """With the first answer's 12 nearest joining the pool (some of 60 models), and with
    the shipped number (every model)."""
    monkeypatch.setattr(core.rank.scan_order, "ANCHOR_NEIGHBOURS", neighbours)
    entries = catalogue(sessions, 60, views=3, seed=5)
    index = ShapeIndex(sessions, reciprocal=reciprocal)
    index.rebuild()
    rng = np.random.default_rng(7)
    moved = reordered = joined = 0
    for _ in range(6):
        query = unit(rng.normal(size=8))
        expected = scan_order(entries, query, 7, reciprocal=reciprocal)
        joined += expected != scan_order(entries, query, 7, reciprocal=reciprocal,
                                         neighbours=0)
        found = scan_search(index, sessions, query, k=7)
        assert [m.model.index_id for m in found] == expected
        # Distances and scores stay the plain best entry's.
        plain = dict(brute_force(entries, query))
        for match in found:
            assert match.distance == pytest.approx(plain[match.model.index_id], abs=1e-5)
        moved += discounted_order(entries, query, 7) != [
            i for i, _ in brute_force(entries, query)[:7]]
        reordered += expected[1:] != discounted_order(entries, query, 7)[1:]
    # The discount, the first answer's order and its joined neighbours each changed some
    # answers, or this test shows nothing.
    assert moved > 0 and reordered > 0 and joined > 0
    # A query by model id: that model is in no radius and no answer.
    own = list(entries)[3]
    expected = scan_order(entries, entries[own][0], 5, exclude=own, reciprocal=reciprocal)
    found = scan_search(index, sessions, entries[own][0], k=5, exclude=own)
    assert [m.model.index_id for m in found] == expected
    assert own not in expected


@pytest.mark.slow
def test_min_score_keeps_scan_modes_order_among_the_models_that_pass(
    sessions: sessionmaker[Session],
) -> None:
    """A model below ``min_score`` by its best entry is in no pool and joins no first
    answer, but still counts in every radius; the models that pass keep scan mode's order,
    their distances and views the plain best entry's (read for the joined ones too)."""
    entries = catalogue(sessions, 60, views=3, seed=5)
    index = ShapeIndex(sessions, reciprocal=True)
    index.rebuild()
    rng = np.random.default_rng(8)
    for _ in range(3):
        query = unit(rng.normal(size=8))
        plain = brute_force(entries, query)
        cut = score_of(plain[11][1]) - 1e-6  # twelve pass, by rounding only
        below = frozenset(i for i, distance in plain if score_of(distance) < cut)
        assert len(below) == len(plain) - 12
        expected = scan_order(entries, query, 10, reciprocal=True, gone=below)
        unfiltered = scan_order(entries, query, 10, reciprocal=True)
        assert expected != [i for i in unfiltered if i not in below][:10]  # not a filter after
        found = scan_search(index, sessions, query, k=10, min_score=cut)
        assert [m.model.index_id for m in found] == expected
        nearest = dict(plain)
        for match in found:
            rows = entries[match.model.index_id]
            assert match.distance == pytest.approx(nearest[match.model.index_id], abs=1e-5)
            best = int(np.argmin(np.linalg.norm(rows - query, axis=1)))
            assert match.view == (None if best == 0 else best - 1)


@pytest.mark.slow
def test_a_model_deleted_since_the_index_synced_is_never_an_answer(
    sessions: sessionmaker[Session],
) -> None:
    """Scan mode orders its pool from the index's own vectors, then confirms answers in the
    database in that order: a model deleted a moment ago (the index not synced) is passed
    over for the next in the order. When it would be the first answer, which orders the
    rest, the general search (every candidate confirmed first) answers: its pool holds the
    ready models alone, the index's radii still count the deleted one."""
    entries = catalogue(sessions, 60, views=3, seed=5)
    index = ShapeIndex(sessions, reciprocal=True)
    index.rebuild()
    query = unit(np.random.default_rng(9).normal(size=8))
    expected = scan_order(entries, query, 8, reciprocal=True)
    later = expected[3]
    delete_model(sessions, later)
    found = [m.model.index_id for m in scan_search(index, sessions, query, k=7)]
    assert found == [i for i in expected if i != later][:7]
    first = expected[0]
    delete_model(sessions, first)
    found = [m.model.index_id for m in scan_search(index, sessions, query, k=7)]
    without = scan_order(entries, query, 7, reciprocal=True, gone=frozenset({first, later}))
    assert found == without
    # Had the rest been ordered from the deleted first answer, it would read otherwise.
    assert found != [i for i in expected if i not in (first, later)][:7]


@pytest.mark.slow
@pytest.mark.parametrize("pushdown", [10_000, 0])
def test_a_filtered_scan_orders_the_models_that_pass_as_a_direct_computation(
    sessions: sessionmaker[Session], pushdown: int,
) -> None:
    """Filters narrow the pool, not the neighbourhoods: with a filter, scan mode's order is
    the direct computation with every model that fails it in no pool and in every radius,
    whether SQL hands the index the ids that pass (``pushdown_max`` 10,000) or too many
    pass for that (0: the certain candidates' rows are read nearest first until the pool
    is full)."""
    entries = catalogue(sessions, 120, views=3, seed=9)
    index = ShapeIndex(sessions, reciprocal=True)
    index.rebuild()
    odd = frozenset(i for number, i in enumerate(entries) if number % 2)
    assert len(entries) - len(odd) > scan_depth(7)  # the pool is a choice among them
    rng = np.random.default_rng(10)
    unfiltered_differs = 0
    for _ in range(4):
        query = unit(rng.normal(size=8))
        expected = scan_order(entries, query, 7, reciprocal=True, gone=odd)
        found = scan_search(index, sessions, query, k=7, filters={"even": "True"},
                            pushdown_max=pushdown)
        assert [m.model.index_id for m in found] == expected
        plain = dict(brute_force(entries, query))
        for match in found:
            assert match.distance == pytest.approx(plain[match.model.index_id], abs=1e-5)
        unfiltered = scan_order(entries, query, 7, reciprocal=True)
        unfiltered_differs += [i for i in unfiltered if i not in odd] != expected
    # Leaving the failing models out of the pool changes the order of those that pass, or
    # this test could not tell a filtered pool from a filtered answer.
    assert unfiltered_differs > 0


def test_after_the_first_answer_its_kind_comes_before_views_as_near_the_scan(
    sessions: sessionmaker[Session],
) -> None:
    """A scan meets one part's view best; other parts of that kind are whole much like it
    but were seen from elsewhere, while parts of another kind have views a little nearer
    the scan. Plain order puts the other kind second; scan mode puts the first answer's
    kind there (the rest follows the first answer's own shape-mode order)."""
    d = 16
    basis = np.eye(d)
    query = basis[0]
    kind = unit(basis[1] + basis[2])  # what the first answer's kind looks like whole
    first = add_ready(sessions, kind, (query + 0.3 * basis[3])[None, :])
    same = [add_ready(sessions, unit(kind + 0.15 * basis[4 + n]),
                      unit(query + 1.3 * basis[8 + n])[None, :]) for n in range(3)]
    other = [add_ready(sessions, unit(basis[12] + 0.15 * basis[13 + n]),
                       unit(query + 1.0 * basis[13 + n])[None, :]) for n in range(3)]
    index = ShapeIndex(sessions)
    index.rebuild()
    found = [m.model.index_id for m in scan_search(index, sessions, query, k=7)]
    assert found[0] == first
    assert set(found[1:4]) == set(same) and set(found[4:7]) == set(other)
    plain = ShapeIndex(sessions, hub_neighbours=0)
    plain.rebuild()
    found_plain = [m.model.index_id for m in scan_search(plain, sessions, query, k=7)]
    assert found_plain[0] == first and set(found_plain[1:4]) == set(other)


@pytest.mark.slow
def test_kept_entry_neighbours_follow_the_catalogue_as_it_changes(
    sessions: sessionmaker[Session],
) -> None:
    """The entry neighbours a query found are kept for the next; a model added, re-added or
    deleted (here or through another process's change feed) is seen at once."""
    entries = catalogue(sessions, 30, views=3, seed=8)
    index = ShapeIndex(sessions)
    index.rebuild()
    rng = np.random.default_rng(9)
    queries = unit(rng.normal(size=(3, 8)))
    for query in queries:
        assert [m.model.index_id for m in scan_search(index, sessions, query, k=5)] == (
            scan_order(entries, query, 5)
        )
    kept = len(index._entry_neighbours)
    # Entries are searched best bound first, only as far as the answer needs: fewer than
    # the 4 k candidates' 4 entries each.
    assert 0 < kept < 3 * rerank_depth(5) * 4
    scan_search(index, sessions, queries[0], k=5)
    assert len(index._entry_neighbours) == kept  # the same entries: nothing searched again
    # New models crowd around the first answer's best view: the index's neighbours of that
    # entry name them at once, here and in the order.
    first = scan_search(index, sessions, queries[0], k=1)[0]
    owner = first.model.index_id
    entry = owner if first.view is None else view_id(owner, first.view)
    crowded = entries[owner][0 if first.view is None else 1 + first.view]
    before, _ = index.entry_neighbours(KEY, [entry], [owner], crowded[None, :])
    crowd = set()
    for _ in range(6):
        near = unit(crowded + 0.05 * rng.normal(size=8))
        crowd.add(add_ready(sessions, near, near[None, :]))
        entries[max(crowd)] = np.stack([near, near])
    assert index.sync() == 6
    after, cosines = index.entry_neighbours(KEY, [entry], [owner], crowded[None, :])
    assert not crowd & set(before[0].tolist()) and set(after[0].tolist()) >= crowd
    assert cosines[0][:6].min() > 0.95
    for query in queries:
        assert [m.model.index_id for m in scan_search(index, sessions, query, k=5)] == (
            scan_order(entries, query, 5)
        )
    gone = first.model.index_id
    delete_model(sessions, gone)
    index.remove(gone)
    del entries[gone]
    assert [m.model.index_id for m in scan_search(index, sessions, queries[0], k=5)] == (
        scan_order(entries, queries[0], 5)
    )


def test_a_view_near_every_model_comes_after_a_model_as_near_the_scan(
    sessions: sessionmaker[Session],
) -> None:
    """A hub: one model's view lies a little nearer the scan than the right model's view,
    and next to six other models. Plain order puts the hub first, scan mode's discount the
    model whose entries lie apart."""
    d = 16
    basis = np.eye(d)
    query = basis[0]
    right = add_ready(sessions, basis[1], (query + 0.52 * basis[2])[None, :])
    hub_view = unit(query + 0.5 * basis[3])
    hub = add_ready(sessions, basis[4], hub_view[None, :])
    for number in range(6):
        crowd = unit(hub_view + 0.3 * basis[3] + 0.12 * basis[5 + number])  # cosine 0.97
        add_ready(sessions, crowd, crowd[None, :])
    plain_index = ShapeIndex(sessions, hub_neighbours=0)
    plain_index.rebuild()
    assert [m.model.index_id for m in scan_search(plain_index, sessions, query, k=2)] == [
        hub,
        right,
    ]
    index = ShapeIndex(sessions)
    index.rebuild()
    found = scan_search(index, sessions, query, k=2)
    assert [m.model.index_id for m in found] == [right, hub]
    assert found[0].score == score_of(found[0].distance)  # the plain score, unchanged
    right_view = unit(query + 0.52 * basis[2])
    assert found[0].distance == pytest.approx(float(np.linalg.norm(right_view - query)), abs=1e-5)
    assert found[0].view == 0


def box_points(n: int, seed: int = 0) -> np.ndarray:
    """Area-uniform samples of the surface of a 2 x 1.2 x 0.8 box, ``(n, 3)``."""
    rng = np.random.default_rng(seed)
    half = np.array([1.0, 0.6, 0.4])
    areas = 8.0 * np.array([half[1] * half[2], half[0] * half[2], half[0] * half[1]])
    axis = rng.choice(3, size=n, p=areas / areas.sum())
    points = rng.uniform(-1.0, 1.0, size=(n, 3)) * half
    points[np.arange(n), axis] = rng.choice([-1.0, 1.0], size=n) * half[axis]
    return points


def catalogue_shapes(n: int) -> dict[str, np.ndarray]:
    return {
        "sphere": fibonacci_sphere_points(n),
        "torus": torus_points(n, seed=1),
        "plate": plate_points(n, a=1.0, b=0.6, seed=1),
        "box": box_points(n),
    }


def sphere_scan(n: int, direction: np.ndarray) -> np.ndarray:
    """What a viewpoint far along ``direction`` sees of another sampling of the sphere."""
    sphere = fibonacci_sphere_points(n)
    return sphere[hidden_point_removal(sphere, 20.0 * direction)]


@pytest.mark.slow
def test_scan_mode_on_compressed_partitions_agrees_with_a_direct_computation(
    sessions: sessionmaker[Session],
) -> None:
    entries = catalogue(sessions, 60, views=3, seed=12, d=16)
    # The 180 views are IVF-SQ8, the models flat; plain order.
    index = ShapeIndex(sessions, exact_max=100, hub_neighbours=0)
    index.rebuild()
    assert index.describe(views_key(KEY)) == "ivf-sq8" and index.describe(KEY) == "flat"
    query = unit(np.random.default_rng(13).normal(size=16))
    expected = brute_force(entries, query)[:5]
    found = scan_search(index, sessions, query, k=5)
    assert [m.model.index_id for m in found] == [i for i, _ in expected]
    for match, (_, distance) in zip(found, expected, strict=True):
        assert match.distance == pytest.approx(distance, abs=1e-5)  # exact, not the estimate
    # Scan mode's own order takes its distances from the index's full vectors: exact too.
    ordered = ShapeIndex(sessions, exact_max=100, reciprocal=True)
    ordered.rebuild()
    plain = dict(brute_force(entries, query))
    found = scan_search(ordered, sessions, query, k=5)
    assert [m.model.index_id for m in found] == scan_order(entries, query, 5, reciprocal=True)
    for match in found:
        assert match.distance == pytest.approx(plain[match.model.index_id], abs=1e-6)


@pytest.mark.slow
def test_a_partial_scan_finds_its_model_first_by_its_best_view(
    sessions: sessionmaker[Session],
) -> None:
    """Real descriptors: four shapes with their views; the query is the near cap of the
    sphere seen from a direction between two of its views, described as a scan. Whole, the
    sphere is far from a cap (the plate is nearer); its best view is near."""
    settings = EngineSettings(max_points=1200)
    ids, entries = {}, {}
    for name, points in catalogue_shapes(1200).items():
        description = describe_points(points, settings, views=3)
        ids[name] = add_ready(sessions, description.descriptor, description.views)
        entries[ids[name]] = np.vstack([description.descriptor, description.views])
    index = ShapeIndex(sessions)
    index.rebuild()
    direction = unit(view_directions(3)[0] + view_directions(3)[1])
    scan = describe_points(sphere_scan(1500, direction), settings, scan=True)
    assert scan.scan_descriptor is not None
    found = scan_search(index, sessions, scan.scan_descriptor, k=4)
    assert found[0].model.index_id == ids["sphere"]
    best = np.linalg.norm(entries[ids["sphere"]] - scan.scan_descriptor, axis=1)
    assert found[0].view is not None and found[0].view == int(np.argmin(best)) - 1
    assert found[0].distance == pytest.approx(best.min(), abs=1e-5)
    assert found[0].score == pytest.approx(1.0 - best.min() ** 2 / 4.0, abs=1e-5)
    expected = brute_force(entries, scan.scan_descriptor)
    assert [m.model.index_id for m in found] == [i for i, _ in expected]
    # The default mode compares whole models: the sphere is not first there.
    with sessions() as session:
        whole = find_similar(index, session.connection(), KEY, scan.descriptor, k=4)
    assert whole[0].model.index_id != ids["sphere"]


@pytest.mark.slow
def test_default_mode_answers_exactly_as_before(sessions: sessionmaker[Session]) -> None:
    entries = catalogue(sessions, 30, views=4, seed=8)
    index = ShapeIndex(sessions)
    index.rebuild()
    rng = np.random.default_rng(9)
    query = unit(rng.normal(size=8))
    # A model whose view is the query itself: found first in scan mode, never by its view in
    # the default mode.
    planted = add_ready(sessions, -query, np.vstack([query, -query]))
    entries[planted] = unit(np.vstack([-query, query, -query]))
    index.sync()
    with sessions() as session:
        shape = find_similar(index, session.connection(), KEY, query, k=8)
    # Whole models only, in the hub-discounted order (views in no neighbourhood either).
    expected = hub_order({i: rows[0] for i, rows in entries.items()}, query, 8, 10)
    assert [(m.model.index_id, m.view) for m in shape] == [(i, None) for i in expected]
    plain = dict(brute_force(entries, query, first_only=True))
    for match in shape:
        assert match.distance == pytest.approx(plain[match.model.index_id], abs=1e-5)
    assert planted not in [m.model.index_id for m in shape]
    scan = scan_search(index, sessions, query, k=8)
    assert scan[0].model.index_id == planted and scan[0].view == 0


@pytest.mark.slow
def test_deletes_remove_every_view_directly_and_through_the_change_feed(
    sessions: sessionmaker[Session],
) -> None:
    entries = catalogue(sessions, 6, views=3, seed=10)
    here, elsewhere = ShapeIndex(sessions), ShapeIndex(sessions)
    here.rebuild()
    elsewhere.rebuild()
    gone = list(entries)[2]
    query = entries[gone][2]  # exactly one of its views
    assert scan_search(here, sessions, query, k=1)[0].model.index_id == gone
    delete_model(sessions, gone)
    here.remove(gone)  # this process's delete
    assert elsewhere.sync() == 1  # another process's change feed
    for index in (here, elsewhere):
        assert gone not in index and index.views_held(gone) == 0
        assert index.partition_size(views_key(KEY)) == 5 * 3
        assert all(i != gone for i, _, _ in index.search_views(KEY, query, 100))
        assert gone not in [m.model.index_id for m in scan_search(index, sessions, query, k=10)]
    # A rebuild agrees.
    fresh = ShapeIndex(sessions)
    fresh.rebuild()
    assert fresh.partition_size(views_key(KEY)) == 15 and len(fresh) == 5


def test_a_redescribe_replaces_the_views_and_models_without_views_still_count(
    sessions: sessionmaker[Session],
) -> None:
    entries = catalogue(sessions, 3, views=4, seed=11)
    plain = add_ready(sessions, np.ones(8), None)  # described before scan mode
    index, other = ShapeIndex(sessions), ShapeIndex(sessions)
    index.rebuild()
    other.rebuild()
    changed = list(entries)[0]
    one_view = unit(np.arange(8.0) + 1.0)
    with sessions.begin() as session:
        session.execute(
            update(Model)
            .where(Model.index_id == changed)
            .values(view_descriptors=one_view.tobytes())
        )
        record_event(session, changed, "ready", KEY[0])
    other.sync()
    assert other.views_held(changed) == 1 and other.views_held(plain) == 0
    assert other.partition_size(views_key(KEY)) == 4 + 4 + 1
    found = scan_search(other, sessions, one_view, k=10)
    assert found[0].model.index_id == changed and found[0].view == 0
    assert sorted(m.model.index_id for m in found) == sorted([*entries, plain])
    assert index.views_held(changed) == 4  # until it syncs too
    index.sync()
    assert index.views_held(changed) == 1


@pytest.mark.slow
def test_migration_0006_goes_up_and_down(database_url: str) -> None:
    engine = make_engine(database_url)
    try:
        upgrade(engine)
        columns = {c["name"] for c in inspect(engine).get_columns("models")}
        assert {"view_descriptors", "scan_descriptor"} <= columns
        config = alembic_config()
        with engine.connect() as connection:
            config.attributes["connection"] = connection
            command.downgrade(config, "0005")
            connection.commit()
        columns = {c["name"] for c in inspect(engine).get_columns("models")}
        assert not {"view_descriptors", "scan_descriptor"} & columns
        upgrade(engine)
        columns = {c["name"] for c in inspect(engine).get_columns("models")}
        assert {"view_descriptors", "scan_descriptor"} <= columns
    finally:
        engine.dispose()


# --- the API ----------------------------------------------------------------------------


def xyz(points: np.ndarray) -> bytes:
    buffer = io.StringIO()
    np.savetxt(buffer, points, fmt="%.6f")
    return buffer.getvalue().encode()


@pytest.mark.slow
def test_scan_mode_through_the_api(tmp_path: Any) -> None:
    settings = make_settings(f"sqlite:///{tmp_path / 'shapesearch.db'}", workers=1, scan_views=3)
    engine = engine_settings(settings)

    def handler(content: bytes, filename: str) -> dict[str, Any]:
        return ingest_columns(content, filename, engine)

    shapes = catalogue_shapes(1500)
    app = create_app(settings, embedded_worker=True, job_handler=handler)
    with TestClient(app, raise_server_exceptions=False) as client:
        ids = {}
        for name, points in shapes.items():
            answer = client.post(
                "/v1/models",
                files={"file": (f"{name}.xyz", xyz(points))},
                data={"metadata": json.dumps({"kind": name})},
            )
            ids[name] = answer.json()["id"]
        for model_id in ids.values():
            assert wait_for_status(client, model_id)["status"] == "ready"
        index = app.state.services.index
        scan = sphere_scan(2000, unit(np.array([0.0, 15.0, 8.0])))
        files = {"file": ("scan.xyz", xyz(scan))}
        found = client.post("/v1/search", params={"mode": "scan", "k": 5}, files=files)
        assert found.status_code == 200, found.text
        results = found.json()["results"]
        assert [r["model"]["id"] for r in results][0] == ids["sphere"]
        assert len({r["model"]["id"] for r in results}) == len(results) == 4
        # The describe cache keys on the mode: the same bytes in shape mode are described
        # without the scan weights (a different query vector, so different distances).
        shape = client.post("/v1/search", params={"k": 5}, files=files).json()["results"]
        assert len(shape) == 4
        assert {r["model"]["id"]: r["distance"] for r in shape} != {
            r["model"]["id"]: r["distance"] for r in results
        }
        again = client.post("/v1/search", params={"mode": "scan", "k": 5}, files=files).json()
        assert again["results"] == results
        similar = client.get(
            f"/v1/models/{ids['sphere']}/similar", params={"mode": "scan", "metadata.kind": "plate"}
        )
        assert similar.status_code == 200
        assert [r["model"]["id"] for r in similar.json()["results"]] == [ids["plate"]]
        refused = client.get(f"/v1/models/{ids['sphere']}/similar", params={"mode": "views"})
        assert refused.status_code == 422
        assert refused.headers["content-type"].startswith("application/problem+json")
        # Deleting a model takes its views out of the index.
        version = client.get(f"/v1/models/{ids['sphere']}").json()["descriptor_version"]
        key = ("default", version)
        held = index.partition_size(views_key(key))
        assert held == 3 + 3 + 2 + 3  # the plate's edge-on view is left out
        assert client.delete(f"/v1/models/{ids['sphere']}").status_code == 204
        assert index.partition_size(views_key(key)) == held - 3
        after = client.post("/v1/search", params={"mode": "scan"}, files=files).json()["results"]
        assert ids["sphere"] not in [r["model"]["id"] for r in after]
