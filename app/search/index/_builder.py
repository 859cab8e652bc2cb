"""Building a partition from a stream of rows (a rebuild), flat or compressed by size."""

from __future__ import annotations

import math

import numpy as np

from app.search.index._partition import TRAIN_PER_LIST, Partition

__all__ = ["Builder"]


class Builder:
    """Fills one new partition from a stream of rows: flat, or IVF trained on the first
    ``TRAIN_PER_LIST * nlist`` vectors when ``expected`` exceeds ``exact_max`` (4-bit codes
    when it exceeds ``compact_min``)."""

    def __init__(
        self,
        expected: int,
        *,
        exact_max: int,
        compact_min: int,
        nprobe: int,
        projected_dims: int,
        chunk: int,
    ) -> None:
        self.expected = expected
        self.exact_max = exact_max
        self.compact_min = compact_min
        self.nprobe = nprobe
        self.projected_dims = projected_dims
        self.chunk = chunk
        self.partition: Partition | None = None
        self.ids: list[int] = []
        self._pending: list[tuple[np.ndarray, np.ndarray]] = []
        self._pending_count = 0
        self._one_ids: list[int] = []
        self._one_vectors: list[np.ndarray] = []

    def add_one(self, index_id: int, vector: np.ndarray) -> None:
        self._one_ids.append(index_id)
        self._one_vectors.append(vector)
        if len(self._one_ids) >= self.chunk:
            self._flush_ones()

    def _flush_ones(self) -> None:
        if self._one_ids:
            ids = np.asarray(self._one_ids, dtype=np.int64)
            self._one_ids, vectors, self._one_vectors = [], np.stack(self._one_vectors), []
            self.add(ids, vectors)

    def add(self, ids: np.ndarray, vectors: np.ndarray) -> None:
        vectors = np.ascontiguousarray(vectors, dtype=np.float32)
        self.ids.extend(ids.tolist())
        if self.partition is None:
            self._pending.append((ids, vectors))
            self._pending_count += len(ids)
            nlist = math.sqrt(max(self.expected, 1))
            enough = self.expected <= self.exact_max or (
                self._pending_count >= TRAIN_PER_LIST * nlist
            )
            if enough:
                self._start()
            return
        self.partition.add(ids, vectors)

    def _start(self) -> None:
        ids = np.concatenate([i for i, _ in self._pending])
        vectors = np.concatenate([v for _, v in self._pending])
        self._pending, self._pending_count = [], 0
        self.partition = Partition(vectors.shape[1], self.nprobe, self.projected_dims)
        if self.expected > self.exact_max:
            bits = 4 if self.expected > self.compact_min else 8
            self.partition.compress(vectors, self.expected, bits)
        self.partition.add(ids, vectors)

    def finish(self) -> Partition | None:
        self._flush_ones()
        if self.partition is None and self._pending:
            self._start()
        return self.partition
