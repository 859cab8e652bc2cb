"""Hub-discount neighbourhoods saved by one index and restored by the next
(``app.search.index._saved``): what a restore keeps is what a pass over the catalogue as it
is now would keep, what changed since is forgotten, and a file that cannot be trusted is
not used."""

from __future__ import annotations

import dataclasses
import logging
import os
import time
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient
from sqlalchemy import delete, update
from sqlalchemy.orm import Session, sessionmaker

from app.api.main import create_app
from app.db.feed import record_event
from app.db.models import FeedState, IndexEvent, Model
from app.search.index import ShapeIndex, _neighbours
from app.search.index._kept import RESTORED_AS_PASS
from app.search.index._saved import computing, file_for, load, restore, save, tidy
from app.settings import Settings
from tests.conftest import make_settings
from tests.core.test_hubness import unit_rows
from tests.search.test_hub_search import KEY, hub_order, search
from tests.search.test_index import add_ready, delete_model

K = 4


def catalogue(sessions: sessionmaker[Session], count: int, seed: int) -> dict[int, np.ndarray]:
    rows = unit_rows(count, 6, seed=seed).astype(np.float32)
    return {add_ready(sessions, row): row for row in rows}


def saved_index(sessions: sessionmaker[Session], cache: Path) -> ShapeIndex:
    """An index that kept every neighbourhood by a whole pass, which saved them."""
    index = ShapeIndex(sessions, hub_neighbours=K, cache_dir=cache)
    index.rebuild()
    assert not file_for(cache, KEY, K).exists()
    assert index.keep_neighbourhoods() == len(index)
    assert file_for(cache, KEY, K).is_file()
    return index


def counted_passes(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """A list that grows by one for each block of neighbourhoods a pass computes."""
    computed: list[int] = []
    nearest = _neighbours._nearest

    def counted(*args: object) -> tuple[np.ndarray, np.ndarray]:
        computed.append(1)
        return nearest(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(_neighbours, "_nearest", counted)
    return computed


def fresh_neighbourhood(vectors: dict[int, np.ndarray], own: int) -> tuple[float, float, float]:
    """(top, kth, after) of ``own`` counted over the whole catalogue."""
    cosines = sorted((float(vectors[own] @ vectors[other]) for other in vectors if other != own),
                     reverse=True)
    return sum(cosines[:K]), cosines[K - 1], cosines[K]


def near(vector: np.ndarray, seed: int) -> np.ndarray:
    moved = vector + 0.05 * unit_rows(1, 6, seed=seed)[0]
    return (moved / np.linalg.norm(moved)).astype(np.float32)


@pytest.mark.slow
def test_a_restart_restores_what_a_pass_over_the_changed_catalogue_keeps(
    sessions: sessionmaker[Session], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    vectors = catalogue(sessions, 120, seed=31)
    before = saved_index(sessions, tmp_path)
    kept = before._partitions[KEY].kept
    # Changes after the save: a model deleted (its vector gone with it), one re-described,
    # two added next to models whose neighbourhoods they enter.
    ids = list(vectors)
    gone = ids[7]
    among = [own for own in ids if own != gone and gone in sorted(
        ids, key=lambda other: -float(vectors[own] @ vectors[other]))[1:K + 2]]
    assert among  # neighbourhoods the deleted model is among
    delete_model(sessions, gone)
    del vectors[gone]
    for seed, target in ((1, ids[20]), (2, ids[40])):
        vector = near(vectors[target], seed)
        vectors[add_ready(sessions, vector)] = vector
    redescribed, vector = ids[30], near(vectors[ids[60]], 3)  # moved next to another
    with sessions.begin() as session:
        session.execute(update(Model).where(Model.index_id == redescribed).values(
            descriptor=vector.tobytes()))
        record_event(session, redescribed, "ready", "t")
    vectors[redescribed] = vector
    computed = counted_passes(monkeypatch)
    after = ShapeIndex(sessions, hub_neighbours=K, cache_dir=tmp_path)
    after.rebuild()
    assert after.wants_neighbourhoods()
    query = unit_rows(1, 6, seed=78)[0].astype(np.float32)
    asked = [m.model.index_id for m in search(after, sessions, query, k=5)]
    assert asked == hub_order(vectors, query, 5, K)  # computed its candidates' own
    restored = after.keep_neighbourhoods()
    assert computed == []  # restored, not computed
    assert not after.wants_neighbourhoods()  # counts as a pass: the rest is the queries'
    assert len(vectors) * RESTORED_AS_PASS <= restored < len(vectors) - len(among)
    table = after._partitions[KEY].kept.saved()  # what the restore keeps, queries' aside
    restored_ids = table.ids.tolist()
    assert len(restored_ids) == restored
    assert not set(restored_ids) & set(among)  # the deleted model's are forgotten
    as_saved = kept.saved().lookup(restored_ids)
    for own, entry, saved in zip(restored_ids, table.lookup(restored_ids), as_saved, strict=True):
        assert entry is not None and entry == saved  # as saved, not computed again
        assert (entry.top, entry.kth, entry.after) == pytest.approx(
            fresh_neighbourhood(vectors, own), abs=1e-5)
    for query in unit_rows(5, 6, seed=77).astype(np.float32):
        assert [m.model.index_id for m in search(after, sessions, query, k=5)] == hub_order(
            vectors, query, 5, K)


@pytest.mark.slow
def test_without_changes_everything_is_restored_and_saved_once(
    sessions: sessionmaker[Session], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    catalogue(sessions, 30, seed=32)
    before = saved_index(sessions, tmp_path)
    assert before.save_neighbourhoods() == 0  # nothing changed since its pass saved
    computed = counted_passes(monkeypatch)
    after = ShapeIndex(sessions, hub_neighbours=K, cache_dir=tmp_path)
    after.rebuild()
    assert after.keep_neighbourhoods() == 30 and computed == []
    assert after.neighbourhoods_kept() == 1.0
    ours, theirs = before._partitions[KEY].kept, after._partitions[KEY].kept
    assert all(ours.get(own) == theirs.get(own) for own in before._partition_of)


@pytest.mark.slow
@pytest.mark.parametrize(
    "fault",
    ["pruned", "other data", "a model gone unsaid", "another history", "corrupt",
     "too many changes"],
)
def test_a_file_that_cannot_be_trusted_is_not_used(
    sessions: sessionmaker[Session], tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    caplog: pytest.LogCaptureFixture, fault: str,
) -> None:
    vectors = catalogue(sessions, 40, seed=33)
    saved_at = saved_index(sessions, tmp_path).revision
    path = file_for(tmp_path, KEY, K)
    if fault == "pruned":  # events after the save were deleted: what they named is unknown
        delete_model(sessions, next(iter(vectors)))
        with sessions.begin() as session:
            session.execute(update(FeedState).values(pruned_through=FeedState.revision))
    elif fault == "other data":  # the same ids, other vectors: another database's file
        saved = load(path, KEY, K)
        assert saved is not None
        save(path, dataclasses.replace(saved, probe_vectors=saved.probe_vectors[::-1].copy()))
    elif fault == "a model gone unsaid":  # not in the feed: the file is not of this data
        with sessions.begin() as session:
            session.execute(delete(Model).where(Model.index_id == next(iter(vectors))))
    elif fault == "another history":  # restored from an older backup, then changed
        with sessions.begin() as session:
            session.execute(update(IndexEvent).where(IndexEvent.revision == saved_at).values(
                created_at=datetime(2020, 1, 1, tzinfo=UTC)))
    elif fault == "corrupt":
        path.write_bytes(path.read_bytes()[:200])
    else:  # more changes than half the neighbourhoods survive
        for seed in range(4):
            add_ready(sessions, unit_rows(1, 6, seed=500 + seed)[0].astype(np.float32))
    computed = counted_passes(monkeypatch)
    after = ShapeIndex(sessions, hub_neighbours=K, cache_dir=tmp_path)
    after.rebuild()
    with caplog.at_level(logging.INFO, logger="shapesearch.index"):
        assert after.keep_neighbourhoods() == len(after)
    assert computed  # a pass computed them
    assert "restored (" not in caplog.text
    assert ("unreadable" in caplog.text) == (fault == "corrupt")


def test_a_stale_version_restores_nothing(
    sessions: sessionmaker[Session], tmp_path: Path
) -> None:
    catalogue(sessions, 20, seed=34)
    saved_index(sessions, tmp_path)
    saved = load(file_for(tmp_path, KEY, K), KEY, K)
    assert saved is not None
    index = ShapeIndex(sessions, hub_neighbours=K)
    index.rebuild()
    partition = index._partitions[KEY]
    version = partition.kept.version
    assert restore(partition, saved, np.zeros(0, dtype=np.int64), version + 1) is None
    assert len(partition.kept) == 0  # the partition changed meanwhile: nothing kept
    assert restore(partition, saved, np.zeros(0, dtype=np.int64), version) == 20


def test_a_directory_that_cannot_be_written_is_said_and_nothing_else(
    sessions: sessionmaker[Session], tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    catalogue(sessions, 20, seed=35)
    blocked = tmp_path / "a file"
    blocked.write_text("not a directory")
    index = ShapeIndex(sessions, hub_neighbours=K, cache_dir=blocked)
    index.rebuild()
    with caplog.at_level(logging.WARNING, logger="shapesearch.index"):
        assert index.keep_neighbourhoods() == 20  # computed all the same
        assert index.save_neighbourhoods() == 0
    assert "no lock" in caplog.text and "not saved" in caplog.text
    assert index.neighbourhoods_kept() == 1.0


def test_the_cache_defaults_to_the_data_directory_with_the_embedded_database(
    tmp_path: Path,
) -> None:
    assert Settings(data_dir=tmp_path).index_options["cache_dir"] == tmp_path / "index-cache"
    assert make_settings("postgresql+psycopg://x@y/z").index_options["cache_dir"] is None
    chosen = make_settings("postgresql+psycopg://x@y/z", index_cache_dir=tmp_path)
    assert chosen.index_options["cache_dir"] == tmp_path


@pytest.mark.slow
def test_the_service_saves_on_shutdown_and_restores_at_start(
    database_url: str, sessions: sessionmaker[Session], tmp_path: Path,
    caplog: pytest.LogCaptureFixture,
) -> None:
    catalogue(sessions, 30, seed=36)
    settings = make_settings(database_url, index_cache_dir=tmp_path, search_hub_neighbours=K)
    with caplog.at_level(logging.INFO, logger="shapesearch"):
        for _ in range(2):
            app = create_app(settings)
            with TestClient(app):
                index = app.state.services.index
                deadline = time.monotonic() + 30
                while index.wants_neighbourhoods() and time.monotonic() < deadline:
                    time.sleep(0.05)
                assert index.neighbourhoods_kept() == 1.0
            assert file_for(tmp_path, KEY, K).is_file()
    assert caplog.text.count("restored (") == 1  # the second start, not the first


def test_one_process_computes_and_the_others_restore_what_it_saves(
    sessions: sessionmaker[Session], tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    caplog: pytest.LogCaptureFixture,
) -> None:
    catalogue(sessions, 30, seed=37)
    computed = counted_passes(monkeypatch)
    first, second = (ShapeIndex(sessions, hub_neighbours=K, cache_dir=tmp_path)
                     for _ in range(2))
    first.rebuild()
    second.rebuild()
    with computing(file_for(tmp_path, KEY, K)) as ours:  # another process's pass, under way
        assert ours
        with caplog.at_level(logging.INFO, logger="shapesearch.index"):
            for _ in range(3):  # a look at each quiet sync
                assert second.keep_neighbourhoods() == 0 and computed == []  # left to it
        assert second.wants_neighbourhoods()
        assert caplog.text.count("another process computes") == 1  # said once
    assert first.keep_neighbourhoods() == 30  # the pass, saved at its end
    assert computed
    computed.clear()
    assert second.keep_neighbourhoods() == 30 and computed == []  # restored its file
    assert not second.wants_neighbourhoods()


@pytest.mark.slow
def test_a_restore_keeping_less_than_most_is_carried_on_by_a_pass(
    sessions: sessionmaker[Session], tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    caplog: pytest.LogCaptureFixture,
) -> None:
    # A file saved long after its pass: half the catalogue arrived one at a time since
    # (each kept by no pass), so the file holds the older half only.
    rows = unit_rows(60, 6, seed=38).astype(np.float32)
    for row in rows[:30]:
        add_ready(sessions, row)
    index = saved_index(sessions, tmp_path)
    for row in rows[30:]:
        add_ready(sessions, row)
        index.sync()  # one change per sync: each forgets the few it moves
    assert index.save_neighbourhoods() == 1  # what its pass still keeps: under half
    computed = counted_passes(monkeypatch)
    after = ShapeIndex(sessions, hub_neighbours=K, cache_dir=tmp_path)
    after.rebuild()
    with caplog.at_level(logging.INFO, logger="shapesearch.index"):
        assert after.keep_neighbourhoods() == 60  # restored, then the rest by a pass
    assert "restored (" in caplog.text
    assert computed and not after.wants_neighbourhoods()
    assert after.neighbourhoods_kept() == 1.0


@pytest.mark.slow
def test_a_process_that_restored_part_takes_the_whole_another_saves(
    sessions: sessionmaker[Session], tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
) -> None:
    rows = unit_rows(38, 6, seed=39).astype(np.float32)
    for row in rows[:30]:
        add_ready(sessions, row)
    index = saved_index(sessions, tmp_path)
    for row in rows[30:]:  # the file keeps under half: a pass must carry a restore on
        add_ready(sessions, row)
        index.sync()
    assert index.save_neighbourhoods() == 1
    computed = counted_passes(monkeypatch)
    waiting, computing_one = (ShapeIndex(sessions, hub_neighbours=K, cache_dir=tmp_path)
                              for _ in range(2))
    waiting.rebuild()
    computing_one.rebuild()
    with computing(file_for(tmp_path, KEY, K)):  # another process's pass, under way
        assert 0 < waiting.keep_neighbourhoods() < 38 * RESTORED_AS_PASS  # the file's part
    assert computed == [] and waiting.wants_neighbourhoods()
    assert computing_one.keep_neighbourhoods() == 38 and computed  # restored, carried on
    computed.clear()
    assert waiting.keep_neighbourhoods() == 38 and computed == []  # the whole, restored
    assert not waiting.wants_neighbourhoods()


def aged(path: Path, days: float) -> Path:
    """``path`` made (if it is not there) and last written ``days`` ago."""
    path.touch()
    stamp = time.time() - days * 86400
    os.utime(path, (stamp, stamp))
    return path


def test_tidy_removes_what_no_partition_reads_once_a_day_old(tmp_path: Path) -> None:
    read = aged(file_for(tmp_path, KEY, K), 3)  # a stable catalogue's: old, still read
    read_lock = aged(read.with_suffix(".lock"), 3)
    other_k = aged(file_for(tmp_path, KEY, K + 1), 2)
    gone = aged(file_for(tmp_path, ("retired", "ss1"), K), 2)
    gone_lock = aged(gone.with_suffix(".lock"), 2)
    killed_save = aged(tmp_path / f".{read.name}.x1y2z3", 2)
    recent = aged(file_for(tmp_path, ("rolling", "ss9"), K), 0.5)  # a deploy's older k
    recent_save = aged(tmp_path / f".{gone.name}.a1b2c3", 0)
    held = file_for(tmp_path, ("computing", "ss1"), K)
    unrelated = aged(tmp_path / "notes.txt", 9)
    with computing(held) as ours:  # another lock file, held while tidy looks
        assert ours
        aged(held.with_suffix(".lock"), 2)
        removed = tidy(tmp_path, [read])
    assert sorted(removed) == sorted([other_k, gone, gone_lock, killed_save])
    assert all(not path.exists() for path in removed)
    for path in (read, read_lock, recent, recent_save, held.with_suffix(".lock"), unrelated):
        assert path.exists()
    a_day_on = tidy(tmp_path, [read], now=time.time() + 86400)
    assert sorted(a_day_on) == sorted([recent, recent_save, held.with_suffix(".lock")])
    assert tidy(tmp_path / "absent", [read]) == []


def test_saving_removes_the_files_of_a_partition_emptied_since(
    sessions: sessionmaker[Session], tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    vectors = catalogue(sessions, 20, seed=37)
    index = saved_index(sessions, tmp_path)
    ours = aged(file_for(tmp_path, KEY, K), 2)
    retired = aged(file_for(tmp_path, ("default", "ss0"), K), 2)
    with caplog.at_level(logging.INFO, logger="shapesearch.index"):
        index.save_neighbourhoods()
    assert ours.is_file() and not retired.exists()
    assert "removed 1 saved" in caplog.text
    for own in vectors:
        delete_model(sessions, own)
    index.sync()
    index.save_neighbourhoods()
    assert not ours.exists()  # no model left reads it
