"""Scan mode's entry neighbours: each catalogue entry's most alike other models, kept.

Scan mode's hub discount (``core.rank.hubness.model_radii``) needs, for each candidate entry (a
model's whole descriptor or one of its virtual views), the other models most alike it: its
largest cosine to each model's entries. One search per partition (the models' and their
views'), batched over the entries asked, finds them; ``nearest_models`` reduces the hits to
one value per model.
What was found is kept per partition pair while neither partition changes (``Partition``'s
``serial`` and ``version``), so a stream of scan queries over a quiet catalogue searches once
per entry; any change to either partition starts afresh (the radii then come from the new
catalogue). At most ``CAPACITY`` entries are kept over all partitions (then every pair
starts afresh): each holds ``KEPT_MODELS`` model ids and cosines (460 bytes with its
Python objects and its place in the dict, measured with tracemalloc: 46 MB in all).
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Hashable, Sequence

import numpy as np

from app.search.index._milvus import AnyPartition
from app.search.index._view_ids import PartitionKey, view_of, views_key
from core.rank.hubness import SCAN_HUB_NEIGHBOURS

__all__ = [
    "CAPACITY", "KEPT_MODELS", "KeptEntryNeighbours", "entry_neighbours", "nearest_models",
]

#: Models kept per entry: one more than the discount averages, for a query's own model,
#: which leaves the catalogue for its own search.
KEPT_MODELS = SCAN_HUB_NEIGHBOURS + 1
CAPACITY = 100_000

# (model ids (KEPT_MODELS,) int64, -1 where there are fewer; cosines (KEPT_MODELS,) float64)
Neighbours = tuple[np.ndarray, np.ndarray]
# A partition's search: (key, (m, d) queries, k) -> each query's (id, L2 distance), nearest first.
Search = Callable[[PartitionKey, np.ndarray, int], list[list[tuple[int, float]]]]


def entry_neighbours(
    kept: KeptEntryNeighbours,
    key: PartitionKey,
    partitions: tuple[AnyPartition | None, AnyPartition | None],
    search: Search,
    entry_ids: Sequence[int],
    owners: Sequence[int],
    vectors: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """``nearest_models`` of each entry ``entry_ids`` (owned by ``owners``, ``vectors : (e,
    d)``) of partition ``key``, whose models' and views' partitions are ``partitions``:
    those ``kept`` while neither changed, the others found by ``search`` (``KEPT_MODELS + 1``
    models and as many times the views a model has on average) and kept. As ``(e,
    KEPT_MODELS)`` model ids and cosines."""
    stamp = tuple(None if p is None else (p.serial, p.version) for p in partitions)
    found = kept.get(key, stamp, entry_ids)
    missing = [row for row, neighbours in enumerate(found) if neighbours is None]
    if missing:
        sizes = [0 if p is None else p.size for p in partitions]
        per_model = max(1, -(-sizes[1] // max(sizes[0], 1)))
        rows = np.ascontiguousarray(np.asarray(vectors)[missing], dtype=np.float32)
        model_hits = search(key, rows, KEPT_MODELS + 1)
        view_hits = search(views_key(key), rows, (KEPT_MODELS + 1) * per_model)
        fresh = {}
        for place, row in enumerate(missing):
            hits = [(i, 1.0 - d * d / 2.0) for i, d in model_hits[place]]
            hits += [(view_of(i)[0], 1.0 - d * d / 2.0) for i, d in view_hits[place]]
            found[row] = fresh[entry_ids[row]] = nearest_models(hits, owners[row])
        kept.put(key, stamp, fresh)
    held = [neighbours for neighbours in found if neighbours is not None]
    return np.stack([k[0] for k in held]), np.stack([k[1] for k in held])


def nearest_models(hits: Sequence[tuple[int, float]], own: int) -> Neighbours:
    """The ``KEPT_MODELS`` models other than ``own`` with the largest cosine among ``hits``
    (``(model, cosine)`` of an entry's nearest entries, in any order), each at its largest;
    ties in model order."""
    best: dict[int, float] = {}
    for model, cosine in hits:
        if model != own and cosine > best.get(model, -np.inf):
            best[model] = cosine
    top = sorted(best.items(), key=lambda item: (-item[1], item[0]))[:KEPT_MODELS]
    models = np.full(KEPT_MODELS, -1, dtype=np.int64)
    cosines = np.zeros(KEPT_MODELS)
    for place, (model, cosine) in enumerate(top):
        models[place], cosines[place] = model, cosine
    return models, cosines


class KeptEntryNeighbours:
    """``nearest_models`` of entries, per partition pair, while the pair is unchanged.

    ``stamp`` (any hashable) names the state of a pair: what was put under another stamp of
    the same pair is gone. Thread-safe.
    """

    def __init__(self, capacity: int = CAPACITY) -> None:
        self.capacity = capacity
        self._lock = threading.Lock()
        self._pairs: dict[Hashable, tuple[Hashable, dict[int, Neighbours]]] = {}
        self._count = 0

    def __len__(self) -> int:
        return self._count

    def get(self, pair: Hashable, stamp: Hashable, entry_ids: Sequence[int]
            ) -> list[Neighbours | None]:
        """What is kept for each of ``entry_ids`` under ``stamp`` (None: nothing)."""
        with self._lock:
            held = self._pairs.get(pair)
            if held is None or held[0] != stamp:
                return [None] * len(entry_ids)
            return [held[1].get(entry_id) for entry_id in entry_ids]

    def put(self, pair: Hashable, stamp: Hashable, found: dict[int, Neighbours]) -> None:
        """Keep ``found`` (entry id -> neighbours) under ``stamp``, forgetting the pair's
        older stamp."""
        with self._lock:
            if self._count + len(found) > self.capacity:
                self._pairs.clear()
                self._count = 0
                if len(found) > self.capacity:
                    return
            held = self._pairs.get(pair)
            if held is None or held[0] != stamp:
                self._count -= 0 if held is None else len(held[1])
                held = (stamp, {})
                self._pairs[pair] = held
            before = len(held[1])
            held[1].update(found)
            self._count += len(held[1]) - before
