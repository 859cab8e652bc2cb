"""Metadata filters in SQL (``app.search.similarity.matching_ids``) select exactly the models that
``metadata_matches`` accepts, on both backends, and stay right as metadata changes: on
SQLite through the triggers of migration 0007, also for rows that existed before it."""

from __future__ import annotations

from typing import Any

import pytest
from sqlalchemy import create_engine, text, update
from sqlalchemy.orm import Session, sessionmaker

from app.db.migrate import upgrade
from app.db.models import Model
from app.search.index import ShapeIndex
from app.search.similarity import (
    find_similar,
    matching_ids,
    metadata_in_ranges,
    metadata_matches,
)
from tests.search.test_index import add_ready, delete_model, unit

KEY = ("t", "v1")
METADATA: list[dict[str, Any]] = [
    {"material": "steel", "qty": 3},
    {"material": "steel", "qty": 4, "coated": True},
    {"material": "aluminium", "qty": 3.5, "coated": False},
    {"material": "3", "sizes": [1, 2]},
    {"material": "steel", "note": None, "spec": {"iso": "2768"}},
    {},
]
FILTERS: list[dict[str, str]] = [
    {"material": "steel"},
    {"material": "steel", "qty": "3"},
    {"material": "3"},
    {"qty": "3.5"},
    {"coated": "true"},
    {"coated": "false"},
    {"sizes": "[1, 2]"},
    {"spec": '{"iso": "2768"}'},
    {"material": "brass"},
    {"qty": "three"},
]


def expected(ids: dict[int, dict[str, Any]], filters: dict[str, str]) -> list[int]:
    return sorted(i for i, meta in ids.items() if metadata_matches(meta, filters))


def selected(sessions: sessionmaker[Session], filters: dict[str, str]) -> list[int]:
    with sessions() as session:
        found = matching_ids(session.connection(), KEY, filters, limit=100)
    assert found is not None
    return sorted(found)


def test_sql_selects_exactly_what_metadata_matches_accepts(
    sessions: sessionmaker[Session],
) -> None:
    ids = {add_ready(sessions, unit(i, 8), meta=meta): meta for i, meta in enumerate(METADATA)}
    add_ready(sessions, unit(9, 8), tenant="other", meta={"material": "steel"})
    assert expected(ids, {"material": "steel"})  # the cases are not vacuous
    for filters in FILTERS:
        assert selected(sessions, filters) == expected(ids, filters), filters


def test_changed_and_deleted_metadata_is_followed(sessions: sessionmaker[Session]) -> None:
    first = add_ready(sessions, unit(0, 8), meta={"material": "steel"})
    second = add_ready(sessions, unit(1, 8), meta={"material": "brass"})
    with sessions.begin() as session:
        session.execute(
            update(Model).where(Model.index_id == first).values(meta={"material": "brass"})
        )
    assert selected(sessions, {"material": "steel"}) == []
    assert selected(sessions, {"material": "brass"}) == sorted([first, second])
    delete_model(sessions, second)
    assert selected(sessions, {"material": "brass"}) == [first]
    with sessions.begin() as session:  # moved to another tenant: gone from this one
        session.execute(update(Model).where(Model.index_id == first).values(tenant="other"))
    assert selected(sessions, {"material": "brass"}) == []


def test_k_results_when_sql_allows_models_the_filter_refuses(
    sessions: sessionmaker[Session],
) -> None:
    """SQLite stores true as 1, so ``qty=1`` allows a model whose qty is true; it is the
    nearest here, and refused, and the search still returns both models whose qty is 1."""
    nearest = add_ready(sessions, unit(0, 8), meta={"qty": True})
    ones = [add_ready(sessions, unit(0, 8) + 0.1 * unit(i, 8), meta={"qty": 1}) for i in (1, 2)]
    index = ShapeIndex(sessions)
    index.rebuild()
    with sessions() as session:
        matches = find_similar(
            index, session.connection(), KEY, unit(0, 8), k=2, filters={"qty": "1"}
        )
    assert sorted(m.model.index_id for m in matches) == sorted(ones)
    assert nearest not in {m.model.index_id for m in matches}


def test_a_filter_broad_in_the_tenant_but_narrow_in_the_partition_answers_exactly(
    sessions: sessionmaker[Session], database_url: str,
) -> None:
    """SQLite judges a filter broad from its metadata entries alone, counted across the
    tenant before any model's partition is checked. Here five models on another descriptor
    version make ``material=steel`` name more entries than the limit (3) while two in the
    query's partition pass: SQLite hands the search no ids (it screens the nearest rows),
    PostgreSQL the two. The answer is those two either way, and the nearest model, which
    the filter refuses, is in neither."""
    base = unit(0, 8)
    passing = [add_ready(sessions, base + 0.1 * unit(i, 8), meta={"material": "steel"})
               for i in (1, 2)]
    for i in range(3, 8):
        add_ready(sessions, unit(i, 8), version="v0", meta={"material": "steel"})
    nearest = add_ready(sessions, base, meta={"material": "brass"})
    steel = {"material": "steel"}
    with sessions() as session:
        found = matching_ids(session.connection(), KEY, steel, limit=3)
        assert matching_ids(session.connection(), KEY, {"material": "brass"}, limit=3) == [
            nearest]
    if database_url.startswith("sqlite"):
        assert found is None
    else:
        assert found is not None and sorted(found) == sorted(passing)
    index = ShapeIndex(sessions)
    index.rebuild()
    for mode in ("shape", "scan"):
        with sessions() as session:
            matches = find_similar(index, session.connection(), KEY, base, k=2, filters=steel,
                                   pushdown_max=3, mode=mode)
        assert sorted(m.model.index_id for m in matches) == sorted(passing), mode


def test_sqlite_rows_from_before_the_migration_are_filled_in(
    tmp_path: pytest.TempPathFactory,
) -> None:
    url = f"sqlite:///{tmp_path}/old.db"
    engine = create_engine(url)
    upgrade(engine, "0006")
    with engine.begin() as connection:
        for index_id, meta in ((1, '{"material": "steel"}'), (2, '{"material": "brass"}')):
            connection.execute(
                text(
                    "INSERT INTO models (index_id, id, tenant, metadata, status, file_name, "
                    "file_size, file_sha256, file_format, descriptor_version, created_at, "
                    "updated_at) VALUES (:i, :id, 't', :meta, 'ready', 'x.stl', 1, :sha, "
                    "'stl', 'v1', '2026-11-23 00:00:00', '2026-11-23 00:00:00')"
                ),
                {"i": index_id, "id": f"{index_id:032x}", "meta": meta, "sha": "0" * 64},
            )
    upgrade(engine)
    with engine.connect() as connection:
        assert matching_ids(connection, KEY, {"material": "steel"}, limit=10) == [1]
    engine.dispose()


RANGES: list[dict[str, tuple[float | None, float | None]]] = [
    {"qty": (3.0, None)},
    {"qty": (None, 3.5)},
    {"qty": (3.2, 3.8)},
    {"qty": (10.0, None)},
    {"coated": (0.0, 1.0)},  # booleans are not numbers
    {"material": (0.0, 10.0)},  # "3" is text, not a number
    {"qty": (3.0, 4.0), "sizes": (None, None)},  # a list is not a number either
]


def test_numeric_ranges_in_sql_select_exactly_what_metadata_in_ranges_accepts(
    sessions: sessionmaker[Session],
) -> None:
    ids = {add_ready(sessions, unit(i, 8), meta=meta): meta for i, meta in enumerate(METADATA)}
    add_ready(sessions, unit(9, 8), tenant="other", meta={"qty": 3})
    for ranges in RANGES:
        want = sorted(i for i, meta in ids.items() if metadata_in_ranges(meta, ranges))
        with sessions() as session:
            found = matching_ids(session.connection(), KEY, {}, 100, ranges=ranges)
        assert found is not None and sorted(found) == want, ranges
    # Not vacuous: the ranges select some models and refuse others.
    assert [metadata_in_ranges(m, {"qty": (3.2, 3.8)}) for m in METADATA[:3]] == [
        False, False, True]
    index = ShapeIndex(sessions)
    index.rebuild()
    with sessions() as session:
        matches = find_similar(index, session.connection(), KEY, unit(0, 8), k=5,
                               metadata_ranges={"qty": (3.0, 3.9)})
    assert sorted(m.model.meta["qty"] for m in matches) == [3, 3.5]



def test_numeric_ranges_keep_k_results_when_k_match_without_pushdown(
    sessions: sessionmaker[Session],
) -> None:
    """Not selective enough to push down (pushdown_max=1): the search widens until k
    models pass the range, however far they lie from the query."""
    for i in range(40):
        add_ready(sessions, unit(i, 8), meta={"qty": i})
    index = ShapeIndex(sessions)
    index.rebuild()
    with sessions() as session:
        matches = find_similar(index, session.connection(), KEY, unit(0, 8), k=3,
                               metadata_ranges={"qty": (30.0, 35.0)}, pushdown_max=1)
    assert len(matches) == 3
    assert all(30 <= m.model.meta["qty"] <= 35 for m in matches)
