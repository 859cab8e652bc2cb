"""The search index: an in-memory FAISS cache of the ready descriptors in the database.

The database is the source of truth. Each process builds its index from the database at
start-up (``rebuild``) and then follows the change feed (``index_events``, see
``app.db.feed``) with ``sync``: it keeps the last revision it applied and reads only newer
events, so a sync that finds nothing new is one indexed query. Deletes made in this
process are also applied at once with ``remove``.

One exact index per (tenant, descriptor_version): tenants never see each other's models
and descriptors of different layouts are never compared. Vectors are unit-norm float32,
stored in ``IndexIDMap2(IndexFlatL2)`` under the model's integer ``index_id``.
"""

from __future__ import annotations

import threading
from collections.abc import Iterable

import faiss
import numpy as np
from sqlalchemy import select
from sqlalchemy.orm import Session, sessionmaker

from app.db.models import FeedState, IndexEvent, Model

__all__ = ["PartitionKey", "ShapeIndex"]

PartitionKey = tuple[str, str]  # (tenant, descriptor_version)

_EVENT_BATCH = 5000


class ShapeIndex:
    """Ready descriptors by partition, kept in step with the database."""

    def __init__(self, sessions: sessionmaker[Session]) -> None:
        self.sessions = sessions
        self.revision = 0  # last change-feed revision applied
        self._partitions: dict[PartitionKey, faiss.IndexIDMap2] = {}
        self._partition_of: dict[int, PartitionKey] = {}
        self._lock = threading.Lock()  # guards the FAISS structures
        self._sync_lock = threading.Lock()  # one sync at a time

    # --- reading ----------------------------------------------------------------------

    def __len__(self) -> int:
        with self._lock:
            return len(self._partition_of)

    def __contains__(self, index_id: int) -> bool:
        with self._lock:
            return index_id in self._partition_of

    def partition_size(self, key: PartitionKey) -> int:
        with self._lock:
            partition = self._partitions.get(key)
            return 0 if partition is None else int(partition.ntotal)

    def search(self, key: PartitionKey, vector: np.ndarray, k: int) -> list[tuple[int, float]]:
        """The ``k`` nearest ``(index_id, L2 distance)`` in one partition, nearest first."""
        query = np.ascontiguousarray(vector, dtype=np.float32).reshape(1, -1)
        with self._lock:
            partition = self._partitions.get(key)
            if partition is None or partition.ntotal == 0 or partition.d != query.shape[1]:
                return []
            squared, ids = partition.search(query, min(k, int(partition.ntotal)))
        return [
            (int(i), float(np.sqrt(max(0.0, d))))
            for i, d in zip(ids[0], squared[0], strict=True)
            if i >= 0
        ]

    # --- writing ----------------------------------------------------------------------

    def add(self, index_id: int, key: PartitionKey, vector: np.ndarray) -> None:
        with self._lock:
            self._add(index_id, key, vector)

    def remove(self, index_id: int) -> None:
        with self._lock:
            self._remove(index_id)

    def _add(self, index_id: int, key: PartitionKey, vector: np.ndarray) -> None:
        self._remove(index_id)  # re-adding replaces: applying an event twice is harmless
        row = np.ascontiguousarray(vector, dtype=np.float32).reshape(1, -1)
        partition = self._partitions.get(key)
        if partition is None:
            partition = faiss.IndexIDMap2(faiss.IndexFlatL2(row.shape[1]))
            self._partitions[key] = partition
        partition.add_with_ids(row, np.array([index_id], dtype=np.int64))
        self._partition_of[index_id] = key

    def _remove(self, index_id: int) -> None:
        key = self._partition_of.pop(index_id, None)
        if key is not None:
            self._partitions[key].remove_ids(np.array([index_id], dtype=np.int64))

    # --- following the database -------------------------------------------------------

    def rebuild(self) -> None:
        """Load every ready descriptor, then catch up with the change feed."""
        with self._sync_lock:
            with self.sessions() as session:
                # Read the revision first: every change after it is replayed by sync, and
                # replaying a change already loaded here is harmless.
                revision = session.execute(
                    select(FeedState.revision).where(FeedState.id == 1)
                ).scalar_one()
                rows = session.execute(
                    select(
                        Model.index_id, Model.tenant, Model.descriptor_version, Model.descriptor
                    ).where(Model.status == "ready")
                ).all()
            with self._lock:
                self._partitions.clear()
                self._partition_of.clear()
                self._load(rows)
                self.revision = int(revision)
        self.sync()

    def sync(self) -> int:
        """Apply the change-feed events newer than ``revision``; returns how many."""
        applied = 0
        with self._sync_lock:
            while True:
                with self.sessions() as session:
                    events = session.execute(
                        select(IndexEvent.revision, IndexEvent.index_id, IndexEvent.kind)
                        .where(IndexEvent.revision > self.revision)
                        .order_by(IndexEvent.revision)
                        .limit(_EVENT_BATCH)
                    ).all()
                    if not events:
                        return applied
                    latest = {event.index_id: event.kind for event in events}  # last one wins
                    wanted = [i for i, kind in latest.items() if kind == "ready"]
                    rows = (
                        session.execute(
                            select(
                                Model.index_id,
                                Model.tenant,
                                Model.descriptor_version,
                                Model.descriptor,
                            ).where(Model.index_id.in_(wanted), Model.status == "ready")
                        ).all()
                        if wanted
                        else []
                    )
                with self._lock:
                    for index_id in latest:
                        self._remove(index_id)
                    self._load(rows)  # models deleted meanwhile are simply not found
                    self.revision = int(events[-1].revision)
                applied += len(events)

    def _load(self, rows: Iterable[tuple[int, str, str | None, bytes | None]]) -> None:
        for index_id, tenant, version, descriptor in rows:
            if descriptor is None or version is None:
                continue
            self._add(index_id, (tenant, version), np.frombuffer(descriptor, dtype=np.float32))
