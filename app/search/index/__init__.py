"""The search index: an in-memory FAISS cache of the ready descriptors in the database.

The database is the source of truth. Each process builds its index from the database at
start-up (``rebuild``, streamed in chunks of rows) and then follows the change feed
(``index_events``, see ``app.db.feed``) with ``sync``, run by a background thread: it keeps
the last revision it applied and reads only newer events, so a sync that finds nothing new
is two indexed reads (the events, then how far the feed was pruned). Deletes made in this
process are also applied at once with ``remove``. Events older than the history kept are
pruned (``app.db.retention``); an index that was behind them all that time rebuilds
instead.

One partition per (tenant, descriptor_version): tenants never see each other's models and
descriptors of different layouts are never compared. Scan mode's extra entries, the
descriptors of each model's virtual partial views (``Model.view_descriptors``), live in a
partition of their own, ``views_key(key)``, so that the default search never meets them; view
``v`` of model ``i`` has the id ``view_id(i, v)``, and adding, replacing or removing a model
does the same to all its views in the same batch. Vectors are unit-norm float32 under
the model's integer ``index_id``. A partition is

* ``flat``: exact ``IndexIDMap2(IndexFlatL2)`` while it holds at most ``exact_max``
  vectors (4 d bytes each: ~680 MB for 10^5 vectors of 1686 dims, hence the limit);
* ``ivf-sq8``: above that, ``IndexIVFScalarQuantizer`` with 8-bit codes (d bytes per vector,
  4x smaller) in ``sqrt(n)`` inverted lists, ``nprobe`` of them searched per query. Its
  distances are approximate: callers fetch ``rerank_candidates(key, k)`` and re-rank them
  exactly (``app.search.similarity``) against the full vectors, which the partition keeps in a
  memory-mapped file (``app.search.full_vectors``: page cache, not the process's own memory);
* ``ivf-sq4``: the same with 4-bit codes (0.5 d bytes per vector: 1.5 GB at 10^6 models of
  the 2961-dim default instead of 3.0 GB) for a partition built with more than
  ``compact_min`` vectors. Its estimates err more, so it returns twice the candidates for
  the exact re-rank (``rerank_candidates``); its scan costs about what the 8-bit one does
  (bench/search_scale.py, README).

An IVF partition's codes leave out the dimensions constant over its training sample: they
would add the same to every estimate (``_partition``). With ``projected_dims`` (off by
default), an IVF partition's codes hold the leading principal
components of its vectors instead of every dimension (``_projection``): a shorter scan and
smaller codes, the same exact re-rank, at a recall that depends on the catalogue.

The index also knows each model's public id (``locate``) and gives back the vectors it
holds, exactly as added (``vector``, ``exact_vectors``), so a similar query by model id reads
no descriptor from the database.

``neighbour_graph`` gives every vector of a partition its k most alike others at once (the
duplicates report, ``app.search.duplicates``), ``neighbourhood_radii`` a few vectors' mean
cosine to theirs (the hub discount similar queries are ordered by, ``core.rank.hubness``); an
index built with ``only`` holds one partition and no views, which is what a duplicates job
loads.

Searches hold a partition's read lock and run side by side (FAISS releases the GIL);
writes (batched per sync) take the write lock briefly. A rebuild builds new partitions
aside and swaps them in, so searches never wait for it.
"""

from __future__ import annotations

import logging
import threading
import uuid
from collections import Counter, defaultdict
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any, cast

import numpy as np
from sqlalchemy import ColumnElement, func, null, select, true
from sqlalchemy.orm import QueryableAttribute, Session, sessionmaker

from app.db.feed import event_stamp, models_touched
from app.db.models import FeedState, IndexEvent, Model
from app.search.index._builder import Builder
from app.search.index._entry_neighbours import KEPT_MODELS, KeptEntryNeighbours, nearest_models
from app.search.index._heap import trim_heap
from app.search.index._neighbours import (
    NeighbourGraph,
    keep_neighbourhoods,
    neighbour_graph,
    neighbourhood_radii,
)
from app.search.index._partition import Partition
from app.search.index._saved import (
    SavedNeighbourhoods,
    computing,
    file_for,
    load,
    restore,
    save,
    tidy,
)
from app.search.index._view_ids import (
    VIEW_ID_BASE,
    PartitionKey,
    holds_views,
    view_id,
    view_ids,
    view_of,
    views_array,
    views_key,
)
from core.rank.hubness import HUB_NEIGHBOURS
from core.settings import MAX_VIEWS

log = logging.getLogger("shapesearch.index")

__all__ = [
    "VIEW_ID_BASE",
    "NeighbourGraph",
    "PartitionKey",
    "ShapeIndex",
    "view_id",
    "view_of",
    "views_key",
]

# One model added: (index_id, partition, (d,) descriptor, (v, d) views or None, its public
# id or None).
_Added = tuple[int, PartitionKey, np.ndarray, "np.ndarray | None", "uuid.UUID | None"]

_EVENT_BATCH = 5000
_Column = QueryableAttribute[Any] | ColumnElement[Any]
#: A row of ``_INDEXED``: index_id, tenant, descriptor_version, descriptor, views, id.
_Row = tuple[int, str, str, bytes, "bytes | None", uuid.UUID]
# What the index holds of a model: the rows a rebuild streams and a sync reads.
_INDEXED: tuple[_Column, ...] = (
    Model.index_id,
    Model.tenant,
    Model.descriptor_version,
    Model.descriptor,
    Model.view_descriptors,
    Model.id,
)

_ROW_CHUNK = 2000  # rows per query of a streamed rebuild


class ShapeIndex:
    """Ready descriptors by partition, kept in step with the database.

    Parameters
    ----------
    sessions : sessionmaker or None
        The database; None for an index filled only with ``build_partition`` (benchmarks).
    exact_max : int
        Largest partition searched exactly; larger ones are IVF-SQ8.
    compact_min : int
        Partitions built with more vectors than this are IVF-SQ4 instead of IVF-SQ8.
    nprobe : int
        Inverted lists searched per query in an IVF partition.
    rerank_factor : int
        Candidates per wanted result fetched from an IVF partition for exact re-ranking.
    projected_dims : int
        Principal components an IVF partition's codes hold instead of every dimension
        (``_projection``); 0, the default: every dimension.
    hub_neighbours : int
        ``k`` of the hub discount that similar queries rank by (``core.rank.hubness``,
        ``neighbourhood_radii``); 0: plain distance order, in scan mode too (whose discount
        has its own ``k``, ``core.rank.hubness.SCAN_HUB_NEIGHBOURS``).
    reciprocal : bool
        With ``hub_neighbours`` above 0: similar queries re-rank the hub discount's order
        k-reciprocally (``core.rank.reciprocal``). The service's default is on
        (``SHAPESEARCH_SEARCH_RECIPROCAL``); off here, so that a bare index ranks by the
        discount alone.
    cache_dir : Path, optional
        Where the hub discount's neighbourhoods are saved (``save_neighbourhoods``) and
        restored from when the index wants them (``keep_neighbourhoods``); None: neither.
    only : PartitionKey, optional
        Hold this partition alone, without its views: one tenant's descriptors of one
        version, read once (a duplicates job). None: every partition.
    """

    def __init__(
        self,
        sessions: sessionmaker[Session] | None,
        *,
        exact_max: int = 5_000,
        compact_min: int = 500_000,
        nprobe: int = 8,
        rerank_factor: int = 2,
        projected_dims: int = 0,
        hub_neighbours: int = HUB_NEIGHBOURS,
        reciprocal: bool = False,
        cache_dir: Path | None = None,
        only: PartitionKey | None = None,
    ) -> None:
        self.sessions = sessions
        self.only = only
        self.exact_max = exact_max
        self.compact_min = compact_min
        self.nprobe = nprobe
        self.rerank_factor = rerank_factor
        self.projected_dims = projected_dims
        self.hub_neighbours = hub_neighbours
        self.reciprocal = reciprocal
        self.cache_dir = cache_dir
        self.revision = 0  # last change-feed revision applied
        self.changes = 0  # moves on every applied change: answers cached before are stale
        self._partitions: dict[PartitionKey, Partition] = {}
        self._partition_of: dict[int, PartitionKey] = {}  # models only
        self._views_of: dict[int, int] = {}  # model index_id -> views it has in the index
        # Public model id (its 128-bit int) <-> index_id, both ways, so that a similar query
        # by model id finds the query vector here (``locate``, ``vector``). Ints, not UUID
        # objects: ~170 bytes per model for both maps.
        self._index_id_of: dict[int, int] = {}
        self._public_id_of: dict[int, int] = {}
        self._entry_neighbours = KeptEntryNeighbours()  # scan mode's, per partition pair
        # The saved neighbourhoods' file each partition last tried to restore, by its stat.
        self._restores_tried: dict[PartitionKey, tuple[int, int, int]] = {}
        self._waiting: set[PartitionKey] = set()  # for another process's pass (said once)
        self._sync_lock = threading.Lock()  # one writer of the maps at a time

    # --- reading ----------------------------------------------------------------------

    def __len__(self) -> int:
        """Models held (their views not counted)."""
        return len(self._partition_of)

    def views_held(self, index_id: int) -> int:
        """How many view entries model ``index_id`` has in the index."""
        return self._views_of.get(index_id, 0)

    def __contains__(self, index_id: int) -> bool:
        return index_id in self._partition_of

    def locate(self, tenant: str, model_id: uuid.UUID) -> tuple[int, PartitionKey] | None:
        """The ``index_id`` and partition of the tenant's model ``model_id`` as this index
        holds it, or None. The index may lag the database by a sync: confirm in SQL."""
        index_id = self._index_id_of.get(model_id.int)
        key = None if index_id is None else self._partition_of.get(index_id)
        if index_id is None or key is None or key[0] != tenant:
            return None
        return index_id, key

    def vector(self, key: PartitionKey, index_id: int) -> np.ndarray | None:
        """The ``(d,) float32`` vector of ``index_id`` as it was added to partition ``key``,
        or None when the partition does not hold it."""
        vectors = self.exact_vectors(key, [index_id])
        return None if vectors is None or not vectors[1][0] else vectors[0][0]

    def exact_vectors(
        self, key: PartitionKey, ids: Sequence[int]
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """``(m, d) float32`` vectors of ``ids`` as added to partition ``key`` (for a
        compressed partition, from its full vectors: ``app.search.full_vectors``) and a ``(m,)
        bool`` mask of those it holds; None without such a partition."""
        partition = self._partitions.get(key)
        if partition is None:
            return None
        with partition.lock.reading():
            return partition.exact_vectors(ids)

    def partition_size(self, key: PartitionKey) -> int:
        partition = self._partitions.get(key)
        return 0 if partition is None else int(partition.index.ntotal)

    def nbytes(self) -> int:
        """Bytes of vectors, codes, ids and centroids held (allocator slack not counted)."""
        return sum(partition.nbytes() for partition in list(self._partitions.values()))

    def file_bytes(self) -> int:
        """Bytes of the compressed partitions' full-vector files (``app.search.full_vectors``:
        local disk and the kernel's page cache, not this process's own memory)."""
        return sum(
            partition.full.file_bytes
            for partition in list(self._partitions.values())
            if partition.full is not None
        )

    def describe(self, key: PartitionKey) -> str:
        """The kind of a partition: "flat", "ivf-sq8", "ivf-sq4" (prefixed "pcaN-" when
        the codes hold N principal components) or "empty"."""
        partition = self._partitions.get(key)
        return "empty" if partition is None else partition.kind

    def kinds(self) -> dict[str, int]:
        """How many partitions of each kind (``describe``) the index holds: what an
        operator checks after changing the ``SHAPESEARCH_INDEX_*`` settings."""
        return dict(Counter(partition.kind for partition in list(self._partitions.values())))

    def is_approximate(self, key: PartitionKey) -> bool:
        partition = self._partitions.get(key)
        return partition is not None and partition.approximate

    def neighbour_graph(self, key: PartitionKey, k: int) -> NeighbourGraph:
        """The ``k`` most alike others of every vector of partition ``key`` (see
        ``app.search.index._neighbours``); empty without such a partition."""
        partition = self._partitions.get(key)
        if partition is None:
            return NeighbourGraph.empty(k)
        with partition.lock.reading():
            return neighbour_graph(partition, k)

    def neighbourhood_radii(
        self,
        key: PartitionKey,
        ids: Sequence[int],
        exclude: int | None = None,
        excluded_cosines: Sequence[float] | None = None,
    ) -> dict[int, float]:
        """``r_k`` (``k`` = ``hub_neighbours``) of each of ``ids`` that partition ``key``
        holds, ``exclude`` counted in no neighbourhood (see ``_neighbours``; its cosine to
        each id may be given); empty when the discount is off or the partition holds no
        other models."""
        partition = self._partitions.get(key)
        if partition is None or self.hub_neighbours < 1:
            return {}
        with partition.lock.reading():
            return neighbourhood_radii(partition, ids, self.hub_neighbours, exclude,
                                       excluded_cosines)

    def entry_neighbours(
        self,
        key: PartitionKey,
        entry_ids: Sequence[int],
        owners: Sequence[int],
        vectors: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Scan mode's ``(e, KEPT_MODELS)`` most alike other models of each entry of
        partition ``key`` and their cosines, -1 and 0 where there are fewer
        (``_entry_neighbours.nearest_models``).

        ``entry_ids`` are the entries' ids (a model's ``index_id``, or a ``view_id``),
        ``owners`` their models, ``vectors : (e, d) float`` the entries. Each entry's nearest
        ``KEPT_MODELS + 1`` models and as many times the views a model has on average are
        searched in one batch per partition (exact while no model has more views than the
        average and the partitions are exact; an approximate partition's estimates
        otherwise), and kept until either partition changes.
        """
        partitions = (self._partitions.get(key), self._partitions.get(views_key(key)))
        stamp = tuple(None if p is None else (p.serial, p.version) for p in partitions)
        found = self._entry_neighbours.get(key, stamp, entry_ids)
        missing = [row for row, neighbours in enumerate(found) if neighbours is None]
        if missing:
            sizes = [0 if p is None else int(p.index.ntotal) for p in partitions]
            per_model = max(1, -(-sizes[1] // max(sizes[0], 1)))
            rows = np.ascontiguousarray(np.asarray(vectors)[missing], dtype=np.float32)
            model_hits = self.search_batch(key, rows, KEPT_MODELS + 1)
            view_hits = self.search_batch(views_key(key), rows, (KEPT_MODELS + 1) * per_model)
            fresh = {}
            for place, row in enumerate(missing):
                hits = [(i, 1.0 - d * d / 2.0) for i, d in model_hits[place]]
                hits += [(view_of(i)[0], 1.0 - d * d / 2.0) for i, d in view_hits[place]]
                found[row] = fresh[entry_ids[row]] = nearest_models(hits, owners[row])
            self._entry_neighbours.put(key, stamp, fresh)
        kept = [neighbours for neighbours in found if neighbours is not None]
        return np.stack([k[0] for k in kept]), np.stack([k[1] for k in kept])

    def keep_neighbourhoods(self) -> int:
        """Compute every model's hub-discount neighbourhood now, partition by partition
        (``_neighbours.keep_neighbourhoods``), so that similar queries find them kept
        instead of computing their candidates' (an API process runs this in the background
        after ``rebuild``; changes wait for one block of it at a time); the count kept.

        With a ``cache_dir`` (``_saved``), a partition first restores those saved there
        (a restore that keeps most counts as its pass), and a pass is computed by one
        process at a time and saved at its end: a process that finds another computing
        leaves the partition for now (the index still wants its neighbourhoods) and
        restores what the other saves."""
        if self.hub_neighbours < 1:
            return 0
        kept = 0
        for key, partition in list(self._partitions.items()):
            if holds_views(key):
                continue
            if self.cache_dir is None:
                kept += keep_neighbourhoods(partition, self.hub_neighbours)
                continue
            self._restore_neighbourhoods(key, partition)
            if not partition.kept.passed:
                self._compute_or_wait(key, partition)
            kept += partition.kept.tabled
        trim_heap()  # the pass's blocks, freed: most of what it grew the process by
        return kept

    def _compute_or_wait(self, key: PartitionKey, partition: Partition) -> None:
        """Compute partition ``key``'s pass and save it, unless another process of the
        cache directory is computing it (then this one restores what that one saves)."""
        assert self.cache_dir is not None
        with computing(file_for(self.cache_dir, key, self.hub_neighbours)) as ours:
            if ours:
                self._waiting.discard(key)
                # The last holder may have saved its pass since the caller's look.
                self._restore_neighbourhoods(key, partition)
                if not partition.kept.passed:
                    keep_neighbourhoods(partition, self.hub_neighbours)
                    self._save_neighbourhoods(key, partition)
            elif key not in self._waiting:
                log.info("another process computes the hub-discount neighbourhoods of %s: "
                         "restoring what it saves", key)
                self._waiting.add(key)

    def save_neighbourhoods(self) -> int:
        """Save each partition's kept hub-discount neighbourhoods that changed since it
        last saved them to ``cache_dir`` (``_saved``: a file per partition, written whole),
        and remove the files there that no partition reads (``_saved.tidy``); the count of
        files written. A directory that cannot be written is said in the log, and nothing
        else happens."""
        if self.cache_dir is None or self.hub_neighbours < 1:
            return 0
        partitions = [(key, partition) for key, partition in list(self._partitions.items())
                      if not holds_views(key)]
        written = sum(self._save_neighbourhoods(key, partition) for key, partition in partitions)
        if self.only is None:  # it knows every partition: what none reads can go
            read = [file_for(self.cache_dir, key, self.hub_neighbours)
                    for key, partition in partitions if partition.index.ntotal > 0]
            removed = tidy(self.cache_dir, read)
            if removed:
                log.info("removed %d saved hub-discount neighbourhood files no partition "
                         "reads from %s", len(removed), self.cache_dir)
        return written

    def _save_neighbourhoods(self, key: PartitionKey, partition: Partition) -> bool:
        """Save partition ``key``'s kept neighbourhoods if they changed since it last did;
        whether it wrote them (a failure is said in the log)."""
        assert self.cache_dir is not None and self.sessions is not None
        kept = partition.kept
        with self._sync_lock:  # no change between the table, the revision and the probes
            state = (kept.version, len(kept))
            if kept.k != self.hub_neighbours or state == kept.saved_as:
                return False
            table = kept.saved()
            if len(table.ids) == 0:
                return False
            with self.sessions() as session:
                stamp = event_stamp(session, self.revision)
            if stamp is None:  # pruned already: no restore could recognise the file
                return False
            saved = SavedNeighbourhoods.of(partition, key, kept.k, self.revision, stamp, table)
        path = file_for(self.cache_dir, key, saved.k)
        try:
            save(path, saved)
        except OSError as error:
            log.warning("hub-discount neighbourhoods not saved to %s: %s", path, error)
            return False
        kept.saved_as = state
        return True

    def _restore_neighbourhoods(self, key: PartitionKey, partition: Partition) -> int | None:
        """Restore partition ``key``'s saved neighbourhoods (``_saved``; those queries
        computed meanwhile stay) when no pass went through it since its last change, the
        file is not one tried before, and it keeps more than what the partition's passes
        kept (a restore, or a pass stopped by a change); the count kept, or None."""
        assert self.cache_dir is not None
        k = self.hub_neighbours
        path = file_for(self.cache_dir, key, k)
        if self.sessions is None or partition.kept.passed or not path.is_file():
            return None
        stamp = path.stat()
        seen = (stamp.st_mtime_ns, stamp.st_size, stamp.st_ino)
        if self._restores_tried.get(key) == seen:
            return None
        self._restores_tried[key] = seen
        saved = load(path, key, k)
        if saved is None:
            return None
        with self._sync_lock:  # the partition as of the revision
            version, revision = partition.kept.version, self.revision
        with self.sessions() as session:
            touched = None
            if event_stamp(session, saved.revision) == saved.stamp:  # this database's feed
                touched = models_touched(session, saved.revision, revision)
        restored = None if touched is None else restore(partition, saved, touched, version)
        if restored is None:
            log.info("saved hub-discount neighbourhoods of %s (revision %d) not restored at "
                     "revision %d", key, saved.revision, revision)
        else:
            log.info("hub-discount neighbourhoods of %d models of %s restored (revision %d, "
                     "%d models changed since)", restored, key, saved.revision,
                     0 if touched is None else len(touched))
            kept = partition.kept  # no need to write back what the file holds
            kept.saved_as = (kept.version, len(kept))
        return restored

    def wants_neighbourhoods(self) -> bool:
        """Whether ``keep_neighbourhoods`` would keep more: a partition large enough to keep
        them has changed since a pass last went through it, and holds fewer than half or
        its last pass was stopped by a change (``_kept.KeptNeighbourhoods.wanted``)."""
        return self.hub_neighbours > 0 and any(
            partition.kept.wanted(self.hub_neighbours, int(partition.index.ntotal))
            for key, partition in list(self._partitions.items()) if not holds_views(key))

    def neighbourhoods_kept(self) -> float:
        """The share of models, in partitions large enough to keep them, whose hub-discount
        neighbourhood is kept (1.0 with none such, or the discount off)."""
        if self.hub_neighbours < 1:
            return 1.0
        sizes = [
            (min(len(partition.kept), held), held)
            for key, partition in list(self._partitions.items())
            if not holds_views(key)
            and (held := int(partition.index.ntotal)) >= self.hub_neighbours + 2
        ]
        total = sum(held for _, held in sizes)
        return sum(kept for kept, _ in sizes) / total if total else 1.0

    def rerank_candidates(self, key: PartitionKey, k: int) -> int:
        """How many candidates to fetch from partition ``key`` for ``k`` exact results:
        ``k`` from an exact one, a margin for re-ranking from an approximate one."""
        partition = self._partitions.get(key)
        scale = 0 if partition is None else partition.rerank_scale
        return k if scale == 0 else scale * max(self.rerank_factor * k, k + 10)

    def search(
        self,
        key: PartitionKey,
        vector: np.ndarray,
        k: int,
        *,
        allowed: Sequence[int] | None = None,
    ) -> list[tuple[int, float]]:
        """The ``k`` nearest ``(index_id, L2 distance)`` in one partition, nearest first;
        only among ``allowed`` ids when given. Distances of an approximate partition are
        estimates: re-rank against the full vectors."""
        query = np.ascontiguousarray(vector, dtype=np.float32).reshape(1, -1)
        return self.search_batch(key, query, k, allowed=allowed)[0]

    def search_batch(
        self,
        key: PartitionKey,
        queries: np.ndarray,
        k: int,
        *,
        allowed: Sequence[int] | None = None,
    ) -> list[list[tuple[int, float]]]:
        """``search`` for each row of ``queries : (m, d) float``, in one FAISS call."""
        queries = np.ascontiguousarray(queries, dtype=np.float32)
        partition = self._partitions.get(key)
        if partition is None or partition.dim != queries.shape[1]:
            return [[] for _ in queries]
        allowed_ids = None if allowed is None else np.asarray(allowed, dtype=np.int64)
        with partition.lock.reading():
            held = int(partition.index.ntotal)
            if held == 0 or (allowed_ids is not None and len(allowed_ids) == 0):
                return [[] for _ in queries]
            squared, ids = partition.search(queries, min(k, held), allowed_ids)
        distances = np.sqrt(np.maximum(squared, 0.0)).tolist()  # plain floats, one call
        return [
            [(i, d) for i, d in zip(row_ids, row_d, strict=True) if i >= 0]
            for row_ids, row_d in zip(ids.tolist(), distances, strict=True)
        ]

    def search_views(
        self,
        key: PartitionKey,
        vector: np.ndarray,
        k: int,
        *,
        allowed: Sequence[int] | None = None,
    ) -> list[tuple[int, int, float]]:
        """The ``k`` nearest view entries of partition ``key``'s models, as ``(index_id,
        view, L2 distance)`` nearest first (a model may appear once per view); only views
        of the ``allowed`` model ids when given."""
        allowed_views = None
        if allowed is not None:
            allowed_views = [
                entry for i in allowed for entry in view_ids(i, self._views_of.get(i, 0))
            ]
        hits = self.search(views_key(key), vector, k, allowed=allowed_views)
        return [(*view_of(entry), distance) for entry, distance in hits]

    # --- writing ----------------------------------------------------------------------

    def add(
        self,
        index_id: int,
        key: PartitionKey,
        vector: np.ndarray,
        views: np.ndarray | None = None,
        model_id: uuid.UUID | None = None,
    ) -> None:
        """Add (or replace) model ``index_id`` (public id ``model_id``) with ``vector : (d,)``
        and its scan-mode ``views : (v, d)`` (v <= ``MAX_VIEWS``)."""
        with self._sync_lock:
            self._apply([index_id], [(index_id, key, vector, views, model_id)])

    def remove(self, index_id: int) -> None:
        self.remove_many([index_id])

    def remove_many(self, index_ids: Iterable[int]) -> None:
        """Remove ids in one batch per partition (unknown ids are ignored)."""
        with self._sync_lock:
            self._apply(index_ids, [])

    def build_partition(
        self, key: PartitionKey, batches: Iterable[tuple[int, np.ndarray]], expected: int
    ) -> None:
        """Fill partition ``key`` from ``(first_id, (m, d) float32)`` batches whose ids run
        on from ``first_id`` (benchmarks, and any bulk load without a database)."""
        with self._sync_lock:
            built = self._builder(expected)
            for first, vectors in batches:
                ids = np.arange(first, first + len(vectors), dtype=np.int64)
                built.add(ids, vectors)
            partition = built.finish()
            if partition is not None:
                self._partitions[key] = partition
                for index_id in built.ids:
                    self._partition_of[index_id] = key

    def _builder(self, expected: int) -> Builder:
        return Builder(expected, exact_max=self.exact_max, compact_min=self.compact_min,
                       nprobe=self.nprobe, projected_dims=self.projected_dims,
                       chunk=_ROW_CHUNK)

    def _apply(self, removed: Iterable[int], added: Iterable[_Added]) -> None:
        """Remove, then add, models with their views, grouped by partition; call with
        ``_sync_lock`` held."""
        self.changes += 1
        gone: dict[PartitionKey, list[int]] = defaultdict(list)
        for index_id in removed:
            key = self._partition_of.pop(index_id, None)
            public = self._public_id_of.pop(index_id, None)
            if public is not None:
                self._index_id_of.pop(public, None)
            if key is not None:
                gone[key].append(index_id)
                gone[views_key(key)].extend(view_ids(index_id, self._views_of.pop(index_id, 0)))
        for key, gone_ids in gone.items():
            partition = self._partitions.get(key)
            if partition is not None and gone_ids:
                with partition.lock.writing():
                    partition.remove(np.asarray(gone_ids, dtype=np.int64))
        fresh: dict[PartitionKey, list[tuple[int, np.ndarray]]] = defaultdict(list)
        for index_id, key, vector, views, model_id in added:
            if index_id in self._partition_of:  # re-adding replaces, views and all
                self._apply([index_id], [])
            if model_id is not None:
                self._index_id_of[model_id.int] = index_id
                self._public_id_of[index_id] = model_id.int
            fresh[key].append((index_id, np.asarray(vector, dtype=np.float32)))
            if views is not None and len(views):
                views = np.asarray(views, dtype=np.float32)[:MAX_VIEWS]
                fresh[views_key(key)].extend(
                    zip(view_ids(index_id, len(views)), views, strict=True)
                )
                self._views_of[index_id] = len(views)
        for key, rows in fresh.items():
            ids = np.array([i for i, _ in rows], dtype=np.int64)
            vectors = np.ascontiguousarray(np.stack([v for _, v in rows]))
            partition = self._partitions.get(key)
            if partition is None:
                partition = Partition(vectors.shape[1], self.nprobe, self.projected_dims)
                self._partitions[key] = partition
            with partition.lock.writing():
                if not partition.approximate and partition.index.ntotal + len(ids) > self.exact_max:
                    flat = partition.index.index
                    held = flat.reconstruct_n(0, flat.ntotal)[:, : partition.dim]
                    sample = np.concatenate([held, vectors])
                    partition.compress(sample, expected=len(sample))
                partition.add(ids, vectors)
            if not holds_views(key):
                for index_id in ids.tolist():
                    self._partition_of[index_id] = key

    # --- following the database -------------------------------------------------------

    def rebuild(self) -> None:
        """Stream every ready descriptor from the database into new partitions, swap them
        in, then catch up with the change feed."""
        assert self.sessions is not None
        with self._sync_lock:
            with self.sessions() as session:
                # Read the revision first: every change after it is replayed by sync, and
                # replaying a change already loaded here is harmless.
                revision = session.execute(
                    select(FeedState.revision).where(FeedState.id == 1)
                ).scalar_one()
                sizes: dict[PartitionKey, int] = {}
                view_bytes_of = (
                    null() if self.only else func.sum(func.length(Model.view_descriptors))
                )
                for tenant, version, count, view_bytes, vector_bytes in session.execute(
                    select(
                        Model.tenant,
                        Model.descriptor_version,
                        func.count(),
                        view_bytes_of,
                        func.max(func.length(Model.descriptor)),
                    )
                    .where(
                        Model.status == "ready",
                        Model.descriptor_version.is_not(None),
                        self._in_scope(),
                    )
                    .group_by(Model.tenant, Model.descriptor_version)
                ):
                    sizes[(tenant, version)] = int(count)
                    if view_bytes and vector_bytes:
                        sizes[views_key((tenant, version))] = int(view_bytes) // int(vector_bytes)
            builders = {key: self._builder(size) for key, size in sizes.items()}
            views_of: dict[int, int] = {}
            index_id_of: dict[int, int] = {}
            for index_id, tenant, version, descriptor, view_blob, model_id in self._ready_rows():
                builder = builders.get((tenant, version))
                if builder is None:  # became ready after the count: sync replays it
                    continue
                vector = np.frombuffer(descriptor, dtype=np.float32)
                builder.add_one(index_id, vector)
                index_id_of[model_id.int] = index_id
                views = views_array(view_blob, len(vector))
                view_builder = builders.get(views_key((tenant, version)))
                if views is not None and view_builder is not None:
                    for entry, view in zip(view_ids(index_id, len(views)), views, strict=True):
                        view_builder.add_one(entry, view)
                    views_of[index_id] = len(views)
            partitions: dict[PartitionKey, Partition] = {}
            partition_of: dict[int, PartitionKey] = {}
            for key, builder in builders.items():
                partition = builder.finish()
                if partition is not None:
                    partitions[key] = partition
                    if not holds_views(key):
                        partition_of.update(dict.fromkeys(builder.ids, key))
            self._partitions, self._partition_of = partitions, partition_of
            self._views_of = views_of
            self._index_id_of = index_id_of
            self._public_id_of = {index_id: public for public, index_id in index_id_of.items()}
            self.revision = int(revision)
            self.changes += 1
        trim_heap()  # the rows streamed and the builders' buffers, freed
        self.sync()

    def _in_scope(self) -> ColumnElement[bool]:
        """The models this index holds: all, or those of partition ``only``."""
        if self.only is None:
            return true()
        tenant, version = self.only
        return (Model.tenant == tenant) & (Model.descriptor_version == version)

    def _indexed(self) -> tuple[_Column, ...]:
        """The columns read of each model: with ``only``, no views (never used there, and
        up to 16 times the descriptor's bytes)."""
        if self.only is None:
            return _INDEXED
        return tuple(null() if column is Model.view_descriptors else column for column in _INDEXED)

    def _ready_rows(self) -> Iterator[_Row]:
        """Every ready descriptor with its views, ``_ROW_CHUNK`` rows per query (keyset on
        index_id)."""
        assert self.sessions is not None
        last = -1
        while True:
            with self.sessions() as session:
                rows = cast(list[_Row], session.execute(
                    select(*self._indexed())
                    .where(
                        Model.index_id > last,
                        Model.status == "ready",
                        Model.descriptor.is_not(None),
                        Model.descriptor_version.is_not(None),
                        self._in_scope(),
                    )
                    .order_by(Model.index_id)
                    .limit(_ROW_CHUNK)
                ).all())
            if not rows:
                return
            yield from rows
            last = rows[-1][0]

    def sync(self) -> int:
        """Apply the change-feed events newer than ``revision``; returns how many.

        An index behind the feed's pruning (``app.db.retention``: it stopped following for
        longer than the history is kept) may have missed events that are gone; it rebuilds
        from the models instead."""
        applied, missed = self._follow()
        if missed:
            log.warning("search index at change-feed revision %d, behind the feed's pruning: "
                        "rebuilding it from the models", self.revision)
            self.rebuild()
        return applied

    def _follow(self) -> tuple[int, bool]:
        """Apply the events newer than ``revision``: how many, and whether some of them
        were pruned before they could be read."""
        assert self.sessions is not None
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
                    # Read after the events: a pruning that deleted one of them before
                    # that read had committed, and so shows here.
                    pruned_through = session.execute(
                        select(FeedState.pruned_through).where(FeedState.id == 1)
                    ).scalar_one()
                    if pruned_through > self.revision:
                        return applied, True
                    if not events:
                        return applied, False
                    latest = {event.index_id: event.kind for event in events}  # last one wins
                    wanted = [i for i, kind in latest.items() if kind == "ready"]
                    rows = cast(list[_Row], (
                        session.execute(
                            select(*self._indexed()).where(
                                Model.index_id.in_(wanted),
                                Model.status == "ready",
                                self._in_scope(),
                            )
                        ).all()
                        if wanted
                        else []
                    ))
                # Models deleted meanwhile are simply not found; their views go with them.
                self._apply(latest, [_added(*row) for row in rows if row[3] and row[2]])
                self.revision = int(events[-1].revision)
                applied += len(events)


def _added(
    index_id: int,
    tenant: str,
    version: str,
    descriptor: bytes,
    view_blob: bytes | None,
    model_id: uuid.UUID,
) -> _Added:
    """A ready row as ``_apply`` adds it."""
    vector = np.frombuffer(descriptor, dtype=np.float32)
    return index_id, (tenant, version), vector, views_array(view_blob, len(vector)), model_id
