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
  (bench/search_scale.py; docs/benchmarks.md, "Search at catalogue scale").

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

``ShapeIndex`` is the face of the modules that do the work:

    _held       what the index holds (partitions, each model's place) and ``apply``, the
                one way it changes
    _rows       the models as rows of the database: which, which columns, streamed
    _rebuild    a rebuild from the database, built aside and swapped in
    _feed       following the change feed
    _keeper     the hub-discount neighbourhoods kept, saved and restored
    _partition, _builder, _neighbours, _entry_neighbours, _kept, _saved, _projection
                one partition, how it is built and what is computed and kept from it
"""

from __future__ import annotations

import logging
import uuid
from collections import Counter
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np
from sqlalchemy.orm import Session, sessionmaker

from app.search.index import _feed, _milvus_rebuild, _rebuild
from app.search.index._entry_neighbours import KeptEntryNeighbours, entry_neighbours
from app.search.index._heap import trim_heap
from app.search.index._held import Held
from app.search.index._keeper import NeighbourhoodKeeper
from app.search.index._milvus import INDEX_TYPES, AnyPartition, MilvusStore, MilvusUnavailable
from app.search.index._neighbours import NeighbourGraph, neighbour_graph, neighbourhood_radii
from app.search.index._rows import ModelRows
from app.search.index._view_ids import (
    VIEW_ID_BASE,
    PartitionKey,
    view_id,
    view_ids,
    view_of,
    views_key,
)
from core.rank.hubness import HUB_NEIGHBOURS

log = logging.getLogger("shapesearch.index")

#: Where the vectors are: ``faiss`` (this process, the default) or ``milvus``.
BACKENDS = ("faiss", "milvus")
MILVUS_INDEX_TYPES = INDEX_TYPES

__all__ = [
    "BACKENDS",
    "MILVUS_INDEX_TYPES",
    "VIEW_ID_BASE",
    "MilvusUnavailable",
    "NeighbourGraph",
    "PartitionKey",
    "ShapeIndex",
    "view_id",
    "view_of",
    "views_key",
]


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
    backend : str
        ``faiss`` (default): the partitions are FAISS indexes of this process. ``milvus``:
        the vectors are in Milvus at ``milvus_uri`` (``_milvus``), searched there; an index
        with ``only`` is FAISS whatever this says (it reads its one partition once).
    milvus_uri : str, optional
        A Milvus server (``http://host:19530``) or a milvus-lite file.
    milvus_index : str
        The Milvus collections' vector index: ``FLAT`` (exact), ``HNSW`` or ``IVF_FLAT``.
    milvus_prefix : str
        What the names of this catalogue's Milvus collections start with.
    milvus_token : str, optional
        The Milvus server's credentials.
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
        backend: str = "faiss",
        milvus_uri: str | None = None,
        milvus_index: str = "FLAT",
        milvus_prefix: str = "shapesearch",
        milvus_token: str | None = None,
    ) -> None:
        if backend not in BACKENDS:
            raise ValueError(f"index backend {backend!r}: one of {BACKENDS}")
        store = None
        if backend == "milvus" and only is None:
            if not milvus_uri:
                raise ValueError("the milvus index backend needs a Milvus URI")
            store = MilvusStore(milvus_uri, index_type=milvus_index, prefix=milvus_prefix,
                                token=milvus_token)
        # Fixed once made: the parts below are given them.
        self.sessions = sessions
        self.only = only
        self.rerank_factor = rerank_factor
        self.hub_neighbours = hub_neighbours
        self.reciprocal = reciprocal
        self.cache_dir = cache_dir
        self._held = Held(exact_max=exact_max, compact_min=compact_min, nprobe=nprobe,
                          projected_dims=projected_dims, store=store)
        self._rows = None if sessions is None else ModelRows(sessions, only)
        self._keeper = NeighbourhoodKeeper(self._held, sessions, cache_dir,
                                           every_partition=only is None)
        self._entry_neighbours = KeptEntryNeighbours()  # scan mode's, per partition pair

    @property
    def backend(self) -> str:
        """``faiss`` or ``milvus``: where the vectors are."""
        return "faiss" if self._held.store is None else "milvus"

    @property
    def milvus(self) -> MilvusStore | None:
        """The Milvus collections of the ``milvus`` backend."""
        return self._held.store

    def close(self) -> None:
        """Let go of Milvus (a milvus-lite file is then free for another process)."""
        if self._held.store is not None:
            self._held.store.close()

    @property
    def exact_max(self) -> int:
        return self._held.exact_max

    @property
    def compact_min(self) -> int:
        return self._held.compact_min

    @property
    def nprobe(self) -> int:
        return self._held.nprobe

    @property
    def projected_dims(self) -> int:
        return self._held.projected_dims

    @property
    def revision(self) -> int:
        """The last change-feed revision applied."""
        return self._held.revision

    @property
    def changes(self) -> int:
        """Moves on every applied change: answers cached before are stale."""
        return self._held.changes

    @property
    def _partitions(self) -> dict[PartitionKey, AnyPartition]:
        """The partitions by key (for tests and benchmarks that look inside)."""
        return self._held.partitions

    @property
    def _partition_of(self) -> dict[int, PartitionKey]:
        """Each model's partition (for tests and benchmarks that look inside)."""
        return self._held.partition_of

    # --- reading ----------------------------------------------------------------------

    def __len__(self) -> int:
        """Models held (their views not counted)."""
        return len(self._held.partition_of)

    def views_held(self, index_id: int) -> int:
        """How many view entries model ``index_id`` has in the index."""
        return self._held.views_of.get(index_id, 0)

    def __contains__(self, index_id: int) -> bool:
        return index_id in self._held.partition_of

    def locate(self, tenant: str, model_id: uuid.UUID) -> tuple[int, PartitionKey] | None:
        """The ``index_id`` and partition of the tenant's model ``model_id`` as this index
        holds it, or None. The index may lag the database by a sync: confirm in SQL."""
        index_id = self._held.index_id_of.get(model_id.int)
        key = None if index_id is None else self._held.partition_of.get(index_id)
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
        partition = self._held.partitions.get(key)
        if partition is None:
            return None
        with partition.lock.reading():
            return partition.exact_vectors(ids)

    def partition_size(self, key: PartitionKey) -> int:
        partition = self._held.partitions.get(key)
        return 0 if partition is None else partition.size

    def nbytes(self) -> int:
        """Bytes of vectors, codes, ids and centroids held (allocator slack not counted;
        none of Milvus' vectors)."""
        return sum(partition.nbytes() for partition in list(self._held.partitions.values()))

    def file_bytes(self) -> int:
        """Bytes of the compressed partitions' full-vector files (``app.search.full_vectors``:
        local disk and the kernel's page cache, not this process's own memory)."""
        return sum(
            partition.full.file_bytes
            for partition in list(self._held.partitions.values())
            if partition.full is not None
        )

    def describe(self, key: PartitionKey) -> str:
        """The kind of a partition: "flat", "ivf-sq8", "ivf-sq4" (prefixed "pcaN-" when
        the codes hold N principal components) or "empty"."""
        partition = self._held.partitions.get(key)
        return "empty" if partition is None else partition.kind

    def kinds(self) -> dict[str, int]:
        """How many partitions of each kind (``describe``) the index holds: what an
        operator checks after changing the ``SHAPESEARCH_INDEX_*`` settings."""
        return dict(Counter(partition.kind for partition in list(self._held.partitions.values())))

    def is_approximate(self, key: PartitionKey) -> bool:
        partition = self._held.partitions.get(key)
        return partition is not None and partition.approximate

    def stamp(self, key: PartitionKey) -> tuple[int, ...] | None:
        """What partition ``key`` holds and the hub-discount neighbourhoods it keeps, as
        numbers that move on every change of either and are never those of another
        partition (None without such a partition): what was computed from them (a query
        model's order, ``app.search.similarity``) is current while its stamp is."""
        partition = self._held.partitions.get(key)
        if partition is None:
            return None
        kept = partition.kept
        return partition.serial, partition.version, kept.k, kept.moves

    def neighbour_graph(self, key: PartitionKey, k: int) -> NeighbourGraph:
        """The ``k`` most alike others of every vector of partition ``key`` (see
        ``app.search.index._neighbours``); empty without such a partition."""
        partition = self._held.partitions.get(key)
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
        partition = self._held.partitions.get(key)
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
        partitions = (self._held.partitions.get(key), self._held.partitions.get(views_key(key)))
        return entry_neighbours(self._entry_neighbours, key, partitions, self.search_batch,
                                entry_ids, owners, vectors)

    # --- hub-discount neighbourhoods (``_keeper``) --------------------------------------

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
        return self._keeper.keep(self.hub_neighbours)

    def save_neighbourhoods(self) -> int:
        """Save each partition's kept hub-discount neighbourhoods that changed since it
        last saved them to ``cache_dir`` (``_saved``: a file per partition, written whole),
        and remove the files there that no partition reads (``_saved.tidy``); the count of
        files written. A directory that cannot be written is said in the log, and nothing
        else happens."""
        return self._keeper.save(self.hub_neighbours)

    def wants_neighbourhoods(self) -> bool:
        """Whether ``keep_neighbourhoods`` would keep more: a partition large enough to keep
        them has changed since a pass last went through it, and holds fewer than half or
        its last pass was stopped by a change (``_kept.KeptNeighbourhoods.wanted``)."""
        return self._keeper.wanted(self.hub_neighbours)

    def neighbourhoods_kept(self) -> float:
        """The share of models, in partitions large enough to keep them, whose hub-discount
        neighbourhood is kept (1.0 with none such, or the discount off)."""
        return self._keeper.share_kept(self.hub_neighbours)

    # --- searching ----------------------------------------------------------------------

    def rerank_candidates(self, key: PartitionKey, k: int) -> int:
        """How many candidates to fetch from partition ``key`` for ``k`` exact results:
        ``k`` from an exact one, a margin for re-ranking from an approximate one."""
        partition = self._held.partitions.get(key)
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
        partition = self._held.partitions.get(key)
        if partition is None or partition.dim != queries.shape[1]:
            return [[] for _ in queries]
        allowed_ids = None if allowed is None else np.asarray(allowed, dtype=np.int64)
        with partition.lock.reading():
            held = partition.size
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
                entry for i in allowed for entry in view_ids(i, self._held.views_of.get(i, 0))
            ]
        hits = self.search(views_key(key), vector, k, allowed=allowed_views)
        return [(*view_of(entry), distance) for entry, distance in hits]

    # --- writing (``_held``) ------------------------------------------------------------

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
        with self._held.lock:
            self._held.apply([index_id], [(index_id, key, vector, views, model_id)])

    def remove(self, index_id: int) -> None:
        self.remove_many([index_id])

    def remove_many(self, index_ids: Iterable[int]) -> None:
        """Remove ids in one batch per partition (unknown ids are ignored)."""
        with self._held.lock:
            self._held.apply(index_ids, [])

    def build_partition(
        self, key: PartitionKey, batches: Iterable[tuple[int, np.ndarray]], expected: int
    ) -> None:
        """Fill partition ``key`` from ``(first_id, (m, d) float32)`` batches whose ids run
        on from ``first_id`` (benchmarks, and any bulk load without a database)."""
        self._held.build_partition(key, batches, expected)

    # --- following the database (``_rebuild``, ``_feed``) -----------------------------

    def rebuild(self, *, upload: bool = False) -> None:
        """Stream every ready descriptor from the database into new partitions, swap them
        in, then catch up with the change feed.

        With Milvus, only what the index keeps of each model besides its vector is read,
        and the feed is followed from the revision Milvus is in step with
        (``_milvus_rebuild``); Milvus is uploaded whole when it was never built, is behind
        the feed's pruning, or with ``upload`` (``shapesearch index rebuild``). FAISS reads
        every descriptor whatever ``upload`` says."""
        assert self._rows is not None
        if self._held.store is not None:
            _milvus_rebuild.attach(self._held, self._rows, upload=upload)
        else:
            _rebuild.rebuild(self._held, self._rows)
        trim_heap()  # the rows streamed and the builders' buffers, freed
        self.sync()

    def sync(self) -> int:
        """Apply the change-feed events newer than ``revision``; returns how many.

        An index behind the feed's pruning (``app.db.retention``: it stopped following for
        longer than the history is kept) may have missed events that are gone; it rebuilds
        from the models instead."""
        assert self._rows is not None
        applied, missed = _feed.follow(self._held, self._rows)
        if missed:
            log.warning("search index at change-feed revision %d, behind the feed's pruning "
                        "(or its Milvus collections gone): rebuilding it from the models",
                        self.revision)
            self.rebuild()
        return applied
