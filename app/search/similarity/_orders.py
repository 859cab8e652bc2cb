"""Shape mode's order of a query model's nearest candidates, kept while the index is as it was.

A similar query by model id, without filters or ``min_score``, orders the ``depth`` nearest
models of its partition from the index alone (a FAISS search, the hub discount's radii, the
k-reciprocal re-rank: most of its time) before the database confirms them
(``_shape.hub_answer``). That order depends on nothing but the query model, ``depth``, how
many candidates were fetched, and what the partition holds and keeps (``ShapeIndex.stamp``):
the same for every request until the index changes. It is kept here (the least recently
used go first), under the partition's stamp, so a query that asks again (another ``k`` with
the same depth, the same part from another client) reads it instead of computing it; the
database still confirms every answer.
"""

from __future__ import annotations

import threading
from array import array
from collections import OrderedDict
from typing import NamedTuple

__all__ = ["KEPT_ORDERS", "KeptOrder", "KeptOrders"]

#: Orders kept per process: about 1 KB each at the default depth.
KEPT_ORDERS = 4096


class KeptOrder(NamedTuple):
    """The ordered candidates (``index_id``), their plain distances, and whether models
    beyond them may qualify (``hub_answer``'s ``beyond``)."""

    order: array[int]
    distances: array[float]
    beyond: bool


class KeptOrders:
    """At most ``size`` orders by key (``size`` 0: none kept); safe for many threads."""

    def __init__(self, size: int = KEPT_ORDERS) -> None:
        self.size = size
        self._entries: OrderedDict[tuple[object, ...], KeptOrder] = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key: tuple[object, ...]) -> KeptOrder | None:
        with self._lock:
            found = self._entries.get(key)
            if found is not None:
                self._entries.move_to_end(key)
            return found

    def put(self, key: tuple[object, ...], order: list[int], distances: list[float],
            beyond: bool) -> None:
        if self.size < 1:
            return
        kept = KeptOrder(array("q", order), array("d", distances), beyond)
        with self._lock:
            self._entries[key] = kept
            self._entries.move_to_end(key)
            while len(self._entries) > self.size:
                self._entries.popitem(last=False)

    def clear(self) -> None:
        with self._lock:
            self._entries.clear()

    def __len__(self) -> int:
        return len(self._entries)


#: The process's kept orders (keyed by partition stamps, which no two partitions share).
ORDERS = KeptOrders()
