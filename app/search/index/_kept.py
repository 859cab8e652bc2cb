"""The hub-discount neighbourhoods a partition keeps, and what a change makes them forget.

A similar query orders its candidates by ``d^2 + r_k`` (``core.hubness``), ``r_k`` a
candidate's mean cosine to its ``k`` most alike other models of the partition. Computing
``r_k`` costs a search per candidate (~1 ms at 10^5 models), so each partition keeps every
neighbourhood it computed (``_neighbours``: the background pass, or a query's own
candidates) for as long as it stays right. A model added or removed changes the
neighbourhoods it is (or was) among the ``k + 1`` nearest of: a kept one whose ``k + 1``-th
cosine the model reaches. The changed vector's ``FORGET_NEAREST`` nearest are checked and
those forgotten at once (a model can have a hub among its ``k + 1`` nearest without being
among the hub's 64 nearest: that radius then stays, off by at most the hub's cosine over
``k``). More changes at once than ``FORGET_BATCH`` (a bulk load) forget everything, and the
API process computes them again once its index is quiet (``ShapeIndex.wants_neighbourhoods``).

Memory: three floats per model kept (about 230 bytes with the dict entry: 23 MB at 10^5
models, 230 MB at 10^6).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from app.search.index._partition import Partition

__all__ = ["FORGET_BATCH", "FORGET_NEAREST", "KeptNeighbourhoods", "Neighbourhood"]

FORGET_NEAREST = 64
FORGET_BATCH = 64


@dataclass(frozen=True, slots=True)
class Neighbourhood:
    """A model's ``k + 1`` most alike others: the sum of the ``k`` largest cosines, the
    ``k``-th and the ``k + 1``-th cosine (which say whether a query model left out, or a
    model coming or going, changes ``r_k``)."""

    top: float
    kth: float
    after: float

    @classmethod
    def of(cls, cosines: np.ndarray, k: int) -> Neighbourhood:
        """From the ``(k + 1,)`` largest cosines, largest first."""
        return cls(float(cosines[:k].sum()), float(cosines[k - 1]), float(cosines[k]))


class KeptNeighbourhoods:
    """The neighbourhoods one partition keeps, for one ``k``. Read and filled under the
    partition's read lock (a dict's single operations are atomic); ``changed`` is called
    under its write lock, which waits for every reader."""

    def __init__(self) -> None:
        self.k = 0
        self.version = 0  # moves on every change of the partition
        self.pass_version = -1  # the version a whole pass (keep_neighbourhoods) went through
        self._entries: dict[int, Neighbourhood] = {}

    def __len__(self) -> int:
        return len(self._entries)

    def use(self, k: int) -> None:
        """Keep neighbourhoods of ``k`` from now on (another ``k``: forget the others)."""
        if k != self.k:
            self.k = k
            self.forget()

    def wanted(self, k: int, held: int) -> bool:
        """Whether a whole pass would keep more: the partition (``held`` vectors) is large
        enough to keep neighbourhoods of ``k``, fewer than half are kept, and it changed
        since a pass last went through it."""
        return (held >= k + 2 and self.pass_version != self.version
                and (self.k != k or len(self._entries) < held / 2))

    def get(self, own: int) -> Neighbourhood | None:
        """The kept neighbourhood of ``own``, or None."""
        return self._entries.get(own)

    def put(self, own: int, entry: Neighbourhood) -> None:
        self._entries[own] = entry

    def forget(self) -> None:
        self._entries = {}

    def changed(
        self, partition: Partition, ids: np.ndarray, vectors: np.ndarray | None = None
    ) -> None:
        """Models ``ids`` are about to be added to ``partition`` with ``(m, d)`` ``vectors``,
        or removed from it (no ``vectors``: read while they are still held): forget their
        own neighbourhoods and those they enter or leave."""
        self.version += 1
        if not self._entries or len(ids) == 0:
            return
        if len(ids) > FORGET_BATCH:
            self.forget()
            return
        if vectors is None:
            vectors, present = partition.exact_vectors(ids.tolist())
            ids, vectors = ids[present], vectors[present]
        for own in ids.tolist():
            self._entries.pop(own, None)
        held = int(partition.index.ntotal)
        if held == 0:
            return
        _, found = partition.search(vectors, min(FORGET_NEAREST, held), None)
        for vector, row in zip(vectors, found, strict=True):
            near = [int(i) for i in row if i >= 0 and int(i) in self._entries]
            if not near:
                continue
            cosines = partition.exact_vectors(near)[0] @ vector
            for other, cosine in zip(near, cosines.tolist(), strict=True):
                if cosine >= self._entries[other].after:
                    del self._entries[other]
