"""A rebuild with the Milvus backend: attach to what Milvus holds, or upload it all.

A FAISS index reads every descriptor at start-up; with Milvus, a process reads only what it
keeps of each model (its partition, public id and count of views: no vector), and starts
following the change feed from the revision Milvus is in step with (``MilvusStore.revision``)
or the database's, whichever is older, so that every change Milvus may lack is replayed
(writes by primary key: a replay duplicates nothing). Milvus is uploaded whole, every ready
descriptor streamed from the database and what it holds of models no longer ready deleted,
when it was never built, when it is behind the change feed's pruning, or when asked
(``shapesearch index rebuild``).
"""

from __future__ import annotations

import logging
import uuid
from collections import defaultdict
from collections.abc import Iterator

import numpy as np
from sqlalchemy import func, select

from app.db.models import FeedState, Model
from app.search.index._held import ROW_CHUNK, Held
from app.search.index._milvus import AnyPartition, MilvusPartition, MilvusStore
from app.search.index._rows import ModelRows
from app.search.index._view_ids import PartitionKey, view_ids, views_array, views_key
from core.settings import MAX_VIEWS

__all__ = ["attach"]

log = logging.getLogger("shapesearch.index")


def attach(held: Held, rows: ModelRows, *, upload: bool = False) -> bool:
    """Make ``held`` hold the database's models with their vectors in Milvus; whether Milvus
    was uploaded whole (``upload``, or it had to be). ``held.revision`` becomes the revision
    from which the caller catches up with the feed (``_feed.follow``)."""
    store = held.store
    assert store is not None and rows.only is None  # one partition alone: FAISS
    with held.lock, store.writer(rows.sessions):
        with rows.sessions() as session:
            revision, pruned = session.execute(
                select(FeedState.revision, FeedState.pruned_through).where(FeedState.id == 1)
            ).one()
        remote = store.revision()
        if upload or remote is None or remote < pruned:
            if not upload:
                log.warning("Milvus at %s %s: uploading every ready descriptor", store.uri,
                            "never built" if remote is None else
                            f"at revision {remote}, behind the feed's pruning")
            _upload(store, rows, held.nprobe)
            store.set_revision(int(revision))
            remote, upload = int(revision), True
        partitions, partition_of, views_of, index_id_of = _mapped(store, rows, held.nprobe)
        held.install(partitions, partition_of, views_of, index_id_of,
                     min(int(revision), remote))
    return upload


def _mapped(
    store: MilvusStore, rows: ModelRows, nprobe: int
) -> tuple[dict[PartitionKey, AnyPartition], dict[int, PartitionKey], dict[int, int],
           dict[int, int]]:
    """What the index keeps of each ready model, read from the database without vectors."""
    partition_of: dict[int, PartitionKey] = {}
    views_of: dict[int, int] = {}
    index_id_of: dict[int, int] = {}
    sizes: dict[PartitionKey, int] = defaultdict(int)
    dims: dict[PartitionKey, int] = {}
    for index_id, tenant, version, descriptor_bytes, view_bytes, model_id in _light(rows):
        key = (tenant, version)
        dim = descriptor_bytes // 4
        partition_of[index_id] = key
        index_id_of[model_id.int] = index_id
        sizes[key] += 1
        dims[key] = dim
        views = 0
        if view_bytes and descriptor_bytes and view_bytes % descriptor_bytes == 0:
            views = min(view_bytes // descriptor_bytes, MAX_VIEWS)
        if views:
            views_of[index_id] = views
            sizes[views_key(key)] += views
            dims[views_key(key)] = dim
    partitions: dict[PartitionKey, AnyPartition] = {
        key: MilvusPartition(store, key, dims[key], size, nprobe=nprobe)
        for key, size in sizes.items()
    }
    return partitions, partition_of, views_of, index_id_of


def _light(rows: ModelRows) -> Iterator[tuple[int, str, str, int, int, uuid.UUID]]:
    """Every ready model's index_id, tenant, version, descriptor and views' byte lengths
    and public id, ``ROW_CHUNK * 10`` rows per query (keyset on index_id)."""
    views = func.coalesce(func.length(Model.view_descriptors), 0)
    last = -1
    while True:
        with rows.sessions() as session:
            batch = session.execute(
                select(Model.index_id, Model.tenant, Model.descriptor_version,
                       func.length(Model.descriptor), views, Model.id)
                .where(
                    Model.index_id > last,
                    Model.status == "ready",
                    Model.descriptor.is_not(None),
                    Model.descriptor_version.is_not(None),
                    rows.in_scope(),
                )
                .order_by(Model.index_id)
                .limit(ROW_CHUNK * 10)
            ).all()
        if not batch:
            return
        for row in batch:
            yield int(row[0]), row[1], row[2], int(row[3]), int(row[4] or 0), row[5]
        last = int(batch[-1][0])


def _upload(store: MilvusStore, rows: ModelRows, nprobe: int) -> None:
    """Write every ready descriptor (and its views) to Milvus, then delete what Milvus holds
    of any other id."""
    pending: dict[PartitionKey, tuple[list[int], list[np.ndarray]]] = {}
    partitions: dict[PartitionKey, MilvusPartition] = {}
    written: dict[str, list[np.ndarray]] = defaultdict(list)

    def flush(key: PartitionKey) -> None:
        ids, vectors = pending.pop(key)
        partition = partitions.get(key)
        if partition is None:
            partition = partitions[key] = MilvusPartition(store, key, len(vectors[0]),
                                                          nprobe=nprobe)
        partition.put(ids, np.stack(vectors))
        written[partition.name].append(np.asarray(ids, dtype=np.int64))

    def put(key: PartitionKey, index_id: int, vector: np.ndarray) -> None:
        ids, vectors = pending.setdefault(key, ([], []))
        ids.append(index_id)
        vectors.append(vector)
        if len(ids) >= ROW_CHUNK // 4:
            flush(key)

    uploaded = 0
    for index_id, tenant, version, descriptor, view_blob, _ in rows.ready():
        key = (tenant, version)
        vector = np.frombuffer(descriptor, dtype=np.float32)
        put(key, index_id, vector)
        views = views_array(view_blob, len(vector))
        if views is not None:
            for entry, view in zip(view_ids(index_id, len(views)), views, strict=True):
                put(views_key(key), entry, view)
        uploaded += 1
        if uploaded % 10_000 == 0:
            log.info("Milvus upload: %d models written", uploaded)
    for key in list(pending):
        flush(key)
    for partition in partitions.values():
        store.flush(partition.name)
    for name in store.collections():
        kept = np.unique(np.concatenate([np.zeros(0, dtype=np.int64), *written.get(name, [])]))
        stale = [held[~np.isin(held, kept)] for held in store.ids(name)]
        gone = np.concatenate([np.zeros(0, dtype=np.int64), *stale])
        if len(gone):
            store.delete(name, gone.tolist())
    log.info("Milvus upload: %d models written to %s", uploaded, store.uri)
