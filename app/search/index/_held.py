"""What a search index holds, and the one way it changes.

``Held`` keeps the partitions and, for each model, its partition, how many views it has and
its public id (both ways). Every change goes through ``apply`` (remove, then add, batched per
partition) or replaces everything at once (``install``, a rebuild's swap), with ``lock``
held: one writer at a time. Searches do not take ``lock``; each holds its partition's read
lock, which ``apply`` takes for writing only while it changes that partition.
"""

from __future__ import annotations

import threading
import uuid
from collections import defaultdict
from collections.abc import Iterable

import numpy as np

from app.search.index._builder import Builder
from app.search.index._milvus import AnyPartition, MilvusPartition, MilvusStore
from app.search.index._partition import Partition
from app.search.index._view_ids import PartitionKey, holds_views, view_ids, views_key
from core.settings import MAX_VIEWS

__all__ = ["ROW_CHUNK", "Added", "Held"]

# One model added: (index_id, partition, (d,) descriptor, (v, d) views or None, its public
# id or None).
Added = tuple[int, PartitionKey, np.ndarray, "np.ndarray | None", "uuid.UUID | None"]

ROW_CHUNK = 2000  # rows per query of a streamed rebuild, and per batch a builder adds


class Held:
    """The partitions of an index and where each model is in them.

    Parameters
    ----------
    exact_max, compact_min, nprobe, projected_dims
        How partitions are built: see ``ShapeIndex``.
    store : MilvusStore, optional
        Where the vectors are with the Milvus backend (``_milvus``); None: FAISS partitions
        in this process.
    """

    def __init__(
        self, *, exact_max: int, compact_min: int, nprobe: int, projected_dims: int,
        store: MilvusStore | None = None,
    ) -> None:
        self.store = store
        self.exact_max = exact_max
        self.compact_min = compact_min
        self.nprobe = nprobe
        self.projected_dims = projected_dims
        self.revision = 0  # last change-feed revision applied
        self.changes = 0  # moves on every applied change: answers cached before are stale
        self.partitions: dict[PartitionKey, AnyPartition] = {}
        self.partition_of: dict[int, PartitionKey] = {}  # models only
        self.views_of: dict[int, int] = {}  # model index_id -> views it has in the index
        # Public model id (its 128-bit int) <-> index_id, both ways, so that a similar query
        # by model id finds the query vector here (``locate``, ``vector``). Ints, not UUID
        # objects: ~170 bytes per model for both maps.
        self.index_id_of: dict[int, int] = {}
        self.public_id_of: dict[int, int] = {}
        self.lock = threading.Lock()  # one writer of the maps at a time

    def new_partition(self, key: PartitionKey, dim: int) -> AnyPartition:
        """An empty partition ``key`` of ``dim``-float vectors, of this index's backend."""
        if self.store is not None:
            return MilvusPartition(self.store, key, dim, nprobe=self.nprobe)
        return Partition(dim, self.nprobe, self.projected_dims)

    def builder(self, expected: int) -> Builder:
        """A builder of one new partition of about ``expected`` vectors."""
        return Builder(expected, exact_max=self.exact_max, compact_min=self.compact_min,
                       nprobe=self.nprobe, projected_dims=self.projected_dims,
                       chunk=ROW_CHUNK)

    def build_partition(
        self, key: PartitionKey, batches: Iterable[tuple[int, np.ndarray]], expected: int
    ) -> None:
        """Fill partition ``key`` from ``(first_id, (m, d) float32)`` batches whose ids run
        on from ``first_id``."""
        with self.lock:
            if self.store is not None:
                self._upload_partition(key, batches)
                return
            built = self.builder(expected)
            for first, vectors in batches:
                ids = np.arange(first, first + len(vectors), dtype=np.int64)
                built.add(ids, vectors)
            partition = built.finish()
            if partition is not None:
                self.partitions[key] = partition
                for index_id in built.ids:
                    self.partition_of[index_id] = key

    def _upload_partition(
        self, key: PartitionKey, batches: Iterable[tuple[int, np.ndarray]]
    ) -> None:
        """``build_partition`` with the Milvus backend: the batches written to Milvus."""
        store = self.store
        assert store is not None
        partition: MilvusPartition | None = None
        for first, vectors in batches:
            if partition is None:
                partition = MilvusPartition(store, key, vectors.shape[1], nprobe=self.nprobe)
            ids = list(range(first, first + len(vectors)))
            partition.put(ids, np.ascontiguousarray(vectors, dtype=np.float32))
            partition.size += len(ids)
            self.partition_of.update(dict.fromkeys(ids, key))
        if partition is not None:
            store.flush(partition.name)
            self.partitions[key] = partition

    def install(
        self,
        partitions: dict[PartitionKey, AnyPartition],
        partition_of: dict[int, PartitionKey],
        views_of: dict[int, int],
        index_id_of: dict[int, int],
        revision: int,
    ) -> None:
        """Replace everything held with ``partitions`` (built aside) and their maps, as of
        change-feed ``revision``; call with ``lock`` held."""
        self.partitions, self.partition_of = partitions, partition_of
        self.views_of = views_of
        self.index_id_of = index_id_of
        self.public_id_of = {index_id: public for public, index_id in index_id_of.items()}
        self.revision = revision
        self.changes += 1

    def apply(self, removed: Iterable[int], added: Iterable[Added]) -> None:
        """Remove, then add, models with their views, grouped by partition; call with
        ``lock`` held."""
        self.changes += 1
        gone: dict[PartitionKey, list[int]] = defaultdict(list)
        for index_id in removed:
            key = self.partition_of.pop(index_id, None)
            public = self.public_id_of.pop(index_id, None)
            if public is not None:
                self.index_id_of.pop(public, None)
            if key is not None:
                gone[key].append(index_id)
                gone[views_key(key)].extend(view_ids(index_id, self.views_of.pop(index_id, 0)))
        for key, gone_ids in gone.items():
            partition = self.partitions.get(key)
            if partition is not None and gone_ids:
                with partition.lock.writing():
                    partition.remove(np.asarray(gone_ids, dtype=np.int64))
        fresh: dict[PartitionKey, list[tuple[int, np.ndarray]]] = defaultdict(list)
        for index_id, key, vector, views, model_id in added:
            if index_id in self.partition_of:  # re-adding replaces, views and all
                self.apply([index_id], [])
            if model_id is not None:
                self.index_id_of[model_id.int] = index_id
                self.public_id_of[index_id] = model_id.int
            fresh[key].append((index_id, np.asarray(vector, dtype=np.float32)))
            if views is not None and len(views):
                views = np.asarray(views, dtype=np.float32)[:MAX_VIEWS]
                fresh[views_key(key)].extend(
                    zip(view_ids(index_id, len(views)), views, strict=True)
                )
                self.views_of[index_id] = len(views)
        for key, rows in fresh.items():
            ids = np.array([i for i, _ in rows], dtype=np.int64)
            vectors = np.ascontiguousarray(np.stack([v for _, v in rows]))
            partition = self.partitions.get(key)
            if partition is None:
                partition = self.new_partition(key, vectors.shape[1])
                self.partitions[key] = partition
            with partition.lock.writing():
                if (isinstance(partition, Partition) and not partition.approximate
                        and partition.size + len(ids) > self.exact_max):
                    flat = partition.index.index
                    held = flat.reconstruct_n(0, flat.ntotal)[:, : partition.dim]
                    sample = np.concatenate([held, vectors])
                    partition.compress(sample, expected=len(sample))
                partition.add(ids, vectors)
            if not holds_views(key):
                for index_id in ids.tolist():
                    self.partition_of[index_id] = key
