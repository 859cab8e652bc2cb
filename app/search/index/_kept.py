"""The hub-discount neighbourhoods a partition keeps, and what a change makes them forget.

A similar query orders its candidates by ``d^2 + r_k`` (``core.rank.hubness``), ``r_k`` a
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

Memory: a whole pass (``start_pass``, ``put_block``) keeps its neighbourhoods in arrays,
three floats, an id, a flag and the low 32 bits of its ``k + 1`` members' ids per model (77
bytes at ``k`` 10: 7.7 MB at 10^5 models, 77 MB at 10^6); those a query computes for itself
meanwhile, or after a change, go to a small dict (about 190 bytes each with their Python
objects, measured), which a pass does not grow. The members are what lets a table saved to
disk (``saved``, ``_saved``) be restored after a restart: a model deleted since is found
among them, where its vector, needed to find them otherwise, is gone.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from app.search.index._milvus import AnyPartition

__all__ = [
    "FORGET_BATCH",
    "FORGET_NEAREST",
    "KeptNeighbourhoods",
    "Neighbourhood",
    "RESTORED_AS_PASS",
    "PassTable",
    "entered",
    "member_keys",
]

FORGET_NEAREST = 64
FORGET_BATCH = 64
# A restore keeping this share counts as a pass. A choice: with a quarter missing, a query's
# 40 candidates need about ten searches of their own (~40 ms at 10^6 models).
RESTORED_AS_PASS = 0.75


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


@dataclass(frozen=True, slots=True)
class PassTable:
    """A pass's neighbourhoods: ``ids : (n,) int64`` sorted, ``values : (n, 3) float64``
    (``top``, ``kth``, ``after`` per id), ``members : (n, k + 1) uint32`` (the low 32 bits
    of the ids of each one's ``k + 1`` nearest: ``member_keys``) and ``held : (n,) bool``
    (computed, not forgotten). Replaced as a whole, so a reader never mixes the arrays of
    two passes."""

    ids: np.ndarray
    values: np.ndarray
    members: np.ndarray
    held: np.ndarray

    @classmethod
    def empty(cls) -> PassTable:
        return cls(np.zeros(0, dtype=np.int64), np.zeros((0, 3)),
                   np.zeros((0, 0), dtype=np.uint32), np.zeros(0, dtype=bool))

    @classmethod
    def of(cls, ids: np.ndarray, values: np.ndarray, members: np.ndarray) -> PassTable:
        """Every row held, sorted by id."""
        order = np.argsort(ids, kind="stable")
        return cls(ids[order], values[order], members[order], np.ones(len(ids), dtype=bool))

    def kept_rows(self) -> PassTable:
        """A copy of the rows held."""
        return self.without(np.zeros(len(self.ids), dtype=bool))

    def lookup(self, ids: list[int]) -> list[Neighbourhood | None]:
        """The neighbourhood of each of ``ids`` the table holds (None: not held)."""
        rows = self.rows(np.asarray(ids, dtype=np.int64)).tolist()
        values = self.values
        return [Neighbourhood(*values[row].tolist()) if row >= 0 else None for row in rows]

    def without(self, drop: np.ndarray) -> PassTable:
        """The rows held but those of ``(n,) bool`` ``drop``."""
        keep = self.held & ~drop
        return PassTable(self.ids[keep], self.values[keep], self.members[keep], keep[keep])

    def rows(self, ids: np.ndarray) -> np.ndarray:
        """The row of each of ``ids : (m,) int64`` that the table holds, -1 elsewhere."""
        rows = _positions(self.ids, ids)
        found = rows >= 0
        found[found] = self.held[rows[found]]
        return np.where(found, rows, -1)


def member_keys(ids: np.ndarray) -> np.ndarray:
    """What a table keeps of each member's ``ids`` (int64, any shape): their low 32 bits.
    Two models whose ids differ by a multiple of 2^32 share a key, so a change to one also
    forgets the neighbourhoods the other is among: a forget too many, never one too few."""
    return np.asarray(ids, dtype=np.int64).astype(np.uint32)


def _positions(sorted_ids: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """The position of each of ``ids`` in ``sorted_ids``, -1 where it is absent."""
    if len(sorted_ids) == 0:
        return np.full(len(ids), -1, dtype=np.int64)
    rows = np.minimum(np.searchsorted(sorted_ids, ids), len(sorted_ids) - 1)
    return np.where(sorted_ids[rows] == ids, rows, -1)


class KeptNeighbourhoods:
    """The neighbourhoods one partition keeps, for one ``k``. Read and filled under the
    partition's read lock (a dict's single operations are atomic, a pass's table is written
    by its one thread, each value before its flag); ``changed`` is called under its write
    lock, which waits for every reader."""

    def __init__(self) -> None:
        self.k = 0
        self.version = 0  # moves on every change of the partition
        self.pass_version = -1  # the version a whole pass (keep_neighbourhoods) went through
        self.pass_stopped = False  # the last pass was stopped by a change before its end
        self.saved_as: tuple[int, int] = (-1, 0)  # (version, count) last saved to disk
        # Moves whenever a neighbourhood is kept or forgotten (``version`` moves with the
        # partition): what was computed from the kept ones is current while both stand.
        self.moves = 0
        self._table = PassTable.empty()
        self._entries: dict[int, Neighbourhood] = {}  # kept outside a pass

    def __len__(self) -> int:
        """How many are kept (an id kept by a query and by a pass counts twice)."""
        return self.tabled + len(self._entries)

    def use(self, k: int) -> None:
        """Keep neighbourhoods of ``k`` from now on (another ``k``: forget the others)."""
        if k != self.k:
            self.k = k
            self.forget()

    def wanted(self, k: int, held: int) -> bool:
        """Whether a whole pass would keep more: the partition (``held`` vectors) is large
        enough to keep neighbourhoods of ``k``, it changed since a pass last went through
        it, and fewer than half are kept or the last pass was stopped before its end (the
        next one goes on from there). The few that single changes forget are left to the
        queries that need them."""
        return (held >= k + 2 and not self.passed
                and (self.k != k or len(self) < held / 2 or self.pass_stopped))

    @property
    def passed(self) -> bool:
        """Whether a whole pass (or a restore that counts as one) went through the
        partition since its last change."""
        return self.pass_version == self.version

    def get(self, own: int) -> Neighbourhood | None:
        """The kept neighbourhood of ``own``, or None."""
        return self.lookup([own])[0]

    def lookup(self, ids: list[int]) -> list[Neighbourhood | None]:
        """The kept neighbourhood of each of ``ids`` (None: not kept), in one pass."""
        entries = self._entries
        return [entries.get(own) or from_table
                for own, from_table in zip(ids, self._table.lookup(ids), strict=True)]

    def holding(self, ids: np.ndarray) -> np.ndarray:
        """Whether a neighbourhood of each of ``ids : (m,) int64`` is kept: ``(m,) bool``."""
        held = self._table.rows(np.asarray(ids, dtype=np.int64)) >= 0
        entries = self._entries
        if entries:
            held |= np.fromiter((own in entries for own in ids.tolist()), bool, len(ids))
        return held

    def holds_all(self, ids: np.ndarray) -> bool:
        """Whether the neighbourhood of every one of ``ids : (m,) int64`` is kept."""
        return bool(self.holding(ids).all())

    def put(self, own: int, entry: Neighbourhood) -> None:
        """Keep one neighbourhood a query computed."""
        self._entries[own] = entry
        self.moves += 1

    def start_pass(self, ids: np.ndarray) -> None:
        """A whole pass over ``ids : (n,) int64`` (the partition's) begins: a table for all
        of them, holding what the last one held of them; ``put_block`` fills it."""
        order = np.sort(np.asarray(ids, dtype=np.int64))
        values, held = np.zeros((len(order), 3)), np.zeros(len(order), dtype=bool)
        members = np.zeros((len(order), self.k + 1), dtype=np.uint32)
        previous = self._table.kept_rows()
        if len(previous.ids):
            rows = _positions(order, previous.ids)
            present = rows >= 0
            values[rows[present]] = previous.values[present]
            members[rows[present]] = previous.members[present]
            held[rows[present]] = True
        self._table = PassTable(order, values, members, held)
        self.moves += 1

    def put_block(self, ids: np.ndarray, cosines: np.ndarray, members: np.ndarray) -> None:
        """Keep the neighbourhoods of ``ids : (m,) int64`` of the running pass, from each
        one's ``(m, k + 1)`` largest cosines, largest first, to the ``(m, k + 1)`` models
        (ids) ``members``."""
        table = self._table
        rows = np.searchsorted(table.ids, ids)
        k = self.k
        table.values[rows, 0] = cosines[:, :k].sum(axis=1, dtype=np.float64)
        table.values[rows, 1] = cosines[:, k - 1]
        table.values[rows, 2] = cosines[:, k]
        table.members[rows] = member_keys(members)
        table.held[rows] = True  # after the values: a reader that sees the flag sees them
        self.moves += 1

    def saved(self) -> PassTable:
        """A copy of the pass's neighbourhoods still kept, to save (``_saved``); call with
        no change running (the index's sync lock)."""
        return self._table.kept_rows()

    @property
    def tabled(self) -> int:
        """How many a pass (or a restore) keeps, not counting the queries' own."""
        return int(self._table.held.sum())

    def restore(self, table: PassTable, held: int) -> None:
        """Keep ``table`` (restored, every row held) in place of any pass's, in a partition
        of ``held`` vectors (the queries' own stay). Holding at least ``RESTORED_AS_PASS``
        of them, it counts as a pass through the partition as it is: the rest is left to
        the queries that need them, as after single changes. Holding fewer, a pass goes on
        from it (the queries find the restored ones meanwhile), so that a restart from a
        file saved long after its pass brings the partition back to whole."""
        self._table = table
        self.moves += 1
        if len(table.ids) >= held * RESTORED_AS_PASS:
            self.pass_version, self.pass_stopped = self.version, False

    def forget(self) -> None:
        self._table = PassTable.empty()
        self._entries = {}
        self.moves += 1

    def _discard(self, ids: list[int]) -> None:
        for own in ids:
            self._entries.pop(own, None)
        table = self._table
        rows = table.rows(np.asarray(ids, dtype=np.int64))
        table.held[rows[rows >= 0]] = False

    def changed(
        self, partition: AnyPartition, ids: np.ndarray, vectors: np.ndarray | None = None
    ) -> None:
        """Models ``ids`` are about to be added to ``partition`` with ``(m, d)`` ``vectors``,
        or removed from it (no ``vectors``: read while they are still held): forget their
        own neighbourhoods and those they enter or leave."""
        self.version += 1
        if len(self) == 0 or len(ids) == 0:
            return
        if len(ids) > FORGET_BATCH:
            self.forget()
            return
        if vectors is None:
            vectors, present = partition.exact_vectors(ids.tolist())
            ids, vectors = ids[present], vectors[present]
        self._discard(ids.tolist())
        self._discard(entered(partition, vectors, self.lookup))


def entered(
    partition: AnyPartition,
    vectors: np.ndarray,
    lookup: Callable[[list[int]], list[Neighbourhood | None]],
) -> list[int]:
    """The models among whose ``k + 1`` nearest a model at each of ``vectors : (m, d)``
    is, of those that ``lookup`` finds a neighbourhood for: each vector's
    ``FORGET_NEAREST`` nearest in ``partition`` whose ``k + 1``-th cosine it reaches (call
    with the partition's read lock held)."""
    held = partition.size
    if held == 0 or len(vectors) == 0:
        return []
    _, found = partition.search(vectors, min(FORGET_NEAREST, held), None)
    moved: list[int] = []
    for vector, row in zip(vectors, found, strict=True):
        candidates = [int(i) for i in row if i >= 0]
        entries = lookup(candidates)
        near = [own for own, entry in zip(candidates, entries, strict=True) if entry]
        if not near:
            continue
        cosines = partition.exact_vectors(near)[0] @ vector
        afters = [entry.after for entry in entries if entry]
        moved.extend(other for other, cosine, after
                     in zip(near, cosines.tolist(), afters, strict=True) if cosine >= after)
    return moved
