"""Every vector's k most alike others in one partition: the k-nearest-neighbour graph.

The duplicates report (``app.search.duplicates``) needs, for each of n parts, its k nearest
others. Asking the index n single queries would scan ``nprobe`` inverted lists of 8-bit
codes per query, one query at a time: ~200 s at 10^5 vectors of 2787 floats on one core.
The same comparisons as a few hundred matrix products (BLAS) take 26-28 s there
(``bench/search_scale.py --phases duplicates``), so the graph is computed block-wise here:

* a flat partition (exact): every vector against every other, in blocks of rows;
* an IVF partition: the vectors of each inverted list against those of the ``nprobe``
  lists whose centroids are nearest its own centroid (its own list first), one product per
  list. A pair is compared when one's list is among the other's nearby lists, so pairs
  split by a list boundary are found unless their lists are far apart; near-identical
  parts sit in one list or in adjacent ones (the recall against exact search is measured
  by ``bench/search_scale.py``).

Scores are never those of the codes: both cases multiply the full float32 vectors (a
flat partition's own, an IVF partition's ``full_vectors``), so every cosine is exact and
only the choice of pairs compared is approximate. Memory: one block of vectors and one
block of products at a time (tens of MB at 10^5), never n x n.

``neighbourhood_radii`` gives a few vectors' ``r_k``, the mean cosine to their ``k`` most
alike others (``core.rank.hubness``: the hub discount a similar query is ordered by), from the
neighbourhoods the partition keeps (``_kept``) or one batched search for those it does not;
its cosines are exact too (an IVF partition's are recomputed from the full vectors), its
neighbours those the partition's own search finds. ``keep_neighbourhoods`` computes every
one from the graph instead, one block per read lock (an API process, in the background).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import faiss
import numpy as np

from app.search.index._kept import Neighbourhood
from app.search.index._milvus import AnyPartition
from app.search.index._partition import Partition, list_ids

__all__ = [
    "NeighbourGraph",
    "graph_blocks",
    "keep_neighbourhoods",
    "neighbour_graph",
    "neighbourhood_radii",
]

_BLOCK_PRODUCTS = 1 << 24  # products (floats) per block of a flat partition: 64 MB
_BLOCK_ROW_PRODUCTS = 1 << 20  # pairs per block of an IVF partition's list


@dataclass(frozen=True)
class NeighbourGraph:
    """The k most alike others of every vector of a partition.

    ids : (n,) int64
        The vectors' ids (model ``index_id``).
    neighbours : (n, k) int64
        Rows of ``ids``, most alike first; -1 where fewer than k others were compared.
    cosines : (n, k) float32
        Their exact cosines (unit vectors: inner products); -inf where ``neighbours`` is -1.
    exact : bool
        Every pair was compared (a flat partition, or an IVF one with ``nprobe`` covering
        every list); False: only pairs within nearby inverted lists.
    """

    ids: np.ndarray
    neighbours: np.ndarray
    cosines: np.ndarray
    exact: bool

    @classmethod
    def empty(cls, k: int) -> NeighbourGraph:
        return cls(
            np.zeros(0, dtype=np.int64),
            np.zeros((0, k), dtype=np.int64),
            np.zeros((0, k), dtype=np.float32),
            exact=True,
        )


def neighbour_graph(partition: AnyPartition, k: int) -> NeighbourGraph:
    """The ``k`` most alike others of every vector of ``partition`` (call with its read
    lock held)."""
    if partition.size == 0:
        return NeighbourGraph.empty(k)
    ids, blocks, exact = graph_blocks(partition, k)
    neighbours = np.full((len(ids), k), -1, dtype=np.int64)
    cosines = np.full((len(ids), k), -np.inf, dtype=np.float32)
    for rows, block_neighbours, block_cosines in blocks:
        neighbours[rows], cosines[rows] = block_neighbours, block_cosines
    return NeighbourGraph(ids, neighbours, cosines, exact=exact)


#: One block of the graph: the rows (a slice of ``ids``), their neighbours (positions in
#: ``ids``, -1: none) and cosines (-inf: none).
GraphBlock = tuple[slice, np.ndarray, np.ndarray]


#: Whether a block of rows with these ``(m,)`` ids may be left out (it is known already).
Skip = Callable[[np.ndarray], bool]


def graph_blocks(
    partition: AnyPartition, k: int, skip: Skip | None = None
) -> tuple[np.ndarray, Iterator[GraphBlock], bool]:
    """The graph of ``partition`` (not empty) block by block: the ``(n,)`` ids, the blocks,
    each computed when the iterator is advanced (but those ``skip`` leaves out), and whether
    every pair is compared. The read lock must be held while the ids are taken and while
    each block is computed, and the partition unchanged in between
    (``Partition.kept.version``): a caller may release the lock between blocks and stop
    when the partition changed."""
    if isinstance(partition, Partition) and partition.approximate:
        return _ivf_blocks(partition, k, skip)
    return _flat_blocks(partition, k, skip)


def _flat_blocks(
    partition: AnyPartition, k: int, skip: Skip | None
) -> tuple[np.ndarray, Iterator[GraphBlock], bool]:
    """Every vector against every other, a block of rows at a time (a Milvus partition's
    read back from Milvus first)."""
    if isinstance(partition, Partition):
        index = partition.index  # IndexIDMap2(IndexFlatL2)
        ids = faiss.vector_to_array(index.id_map).astype(np.int64)
        vectors = index.index.reconstruct_n(0, index.ntotal)[:, : partition.dim]
    else:
        ids = np.sort(partition.ids())
        vectors = partition.exact_vectors(ids.tolist())[0]
    n = len(ids)
    positions = np.arange(n)
    step = max(1, min(1024, _BLOCK_PRODUCTS // n))

    def blocks() -> Iterator[GraphBlock]:
        for start in range(0, n, step):
            rows = slice(start, start + step)
            if skip is not None and skip(ids[rows]):
                continue
            yield rows, *_nearest(vectors[rows], positions[rows], vectors, positions, k)

    return ids, blocks(), True


def neighbourhood_radii(
    partition: AnyPartition,
    ids: Sequence[int],
    k: int,
    exclude: int | None = None,
    excluded_cosines: Sequence[float] | None = None,
) -> dict[int, float]:
    """``r_k`` of each of ``ids`` that ``partition`` holds: its mean cosine to its ``k`` most
    alike others, ``exclude`` (a query model, leave-one-out) counted in no neighbourhood
    (call with the partition's read lock held). ``excluded_cosines``: the cosine of
    ``exclude`` to each of ``ids``, when the caller knows it (else read from the vectors).

    A partition of at least ``k + 2`` vectors keeps each neighbourhood it computed, until a
    change moves it (``_kept``); leaving ``exclude`` out of a kept one is arithmetic. A
    smaller partition is counted afresh each time, ``k`` being what there is (the same for
    every id; none at all: an empty answer). Two ids with the same vector are each other's
    neighbours (an id is left out of its own neighbourhood by id, not by distance).
    """
    asked = [int(i) for i in ids]
    if partition.size < k + 2:
        vectors, held = partition.exact_vectors(asked)
        held_ids = [own for own, h in zip(asked, held.tolist(), strict=True) if h]
        return _counted_radii(partition, held_ids, vectors[held], k, exclude) if held_ids else {}
    kept = partition.kept
    kept.use(k)
    # A kept neighbourhood is of a model still held (a removal forgets it): only the others'
    # vectors are read, to compute theirs.
    entries = dict(zip(asked, kept.lookup(asked), strict=True))
    missing = [own for own in asked if entries[own] is None]
    if missing:
        vectors, held = partition.exact_vectors(missing)
        held_ids = [own for own, h in zip(missing, held.tolist(), strict=True) if h]
        found = _nearest_others(partition, held_ids, vectors[held], k + 1)
        for own, cosines in zip(held_ids, found, strict=True):
            if len(cosines) > k:
                entries[own] = computed = Neighbourhood.of(cosines, k)
                kept.put(own, computed)
            else:  # the search found fewer (an IVF corner): what it found, not kept
                padded = np.concatenate([cosines, np.full(k + 1 - len(cosines), cosines[-1])])
                entries[own] = Neighbourhood.of(padded, k)
    left_out = dict(zip(asked, excluded_cosines, strict=True)) if excluded_cosines else None
    if exclude is not None and left_out is None:
        vectors, held = partition.exact_vectors([exclude, *asked])
        left_out = ({own: float(v @ vectors[0]) for own, v in zip(asked, vectors[1:], strict=True)}
                    if held[0] else None)
    radii = {}
    for own in asked:
        entry = entries[own]
        if entry is None:  # not held
            continue
        top = entry.top
        if left_out is not None and own != exclude:
            cosine = left_out[own]
            if cosine >= entry.kth:  # the left-out model is one of its k: the next steps in
                top += entry.after - cosine
        radii[own] = top / k
    return radii


def keep_neighbourhoods(partition: Partition, k: int) -> int:
    """Compute and keep every neighbourhood of ``partition`` that ``neighbourhood_radii``
    would, from the neighbour graph (one block-wise pass instead of a search per model);
    the count kept. Stops early when the partition changed meanwhile (those kept so far
    stay: the change forgot the ones it moved).

    The read lock is held for one block at a time: a change waits for that block, not for
    the pass. An IVF list's rows go in blocks of about 10^6 pairs (131 rows of a list of
    ~1,000 at 10^6 models, where a whole list took about a second), so that a change, and
    the searches queued behind it (the lock lets no reader pass a waiting writer), wait for
    one such block at most.

    A block whose every neighbourhood is kept already is not computed again, so the next
    pass (``KeptNeighbourhoods.wanted``: a stopped pass is wanted again) goes on where a
    stopped one ended. Starting over instead, a pass longer than the time between two
    changes never got past its first blocks while parts kept arriving, and started again
    after every change (``bench/neighbourhood_pass.py``)."""
    kept = partition.kept
    with partition.lock.reading():
        kept.use(k)
        version = kept.version
        if partition.size < k + 2:
            kept.pass_version = version
            return 0
        ids, blocks, _ = graph_blocks(partition, k + 1, skip=kept.holds_all)
        kept.start_pass(ids)
    while True:
        with partition.lock.reading():
            if kept.version != version or kept.k != k:
                kept.pass_stopped = True
                break
            block = next(blocks, None)
            if block is None:
                kept.pass_version, kept.pass_stopped = version, False
                break
            rows, neighbours, cosines = block
            complete = np.isfinite(cosines).all(axis=1)
            kept.put_block(ids[rows][complete], cosines[complete], ids[neighbours[complete]])
    return int(kept.holding(ids).sum())


def _counted_radii(
    partition: AnyPartition, ids: list[int], vectors: np.ndarray, k: int, exclude: int | None
) -> dict[int, float]:
    """``neighbourhood_radii`` of a partition with fewer than ``k + 2`` vectors, counted."""
    others = partition.size - 1
    if exclude is not None and partition.exact_vectors([exclude])[1][0]:
        others -= 1
    k = min(k, others)
    if k < 1:
        return {}
    found = _nearest_others(partition, ids, vectors, k + 1, exclude)
    return {own: float(cosines[:k].mean()) for own, cosines in zip(ids, found, strict=True)}


def _nearest_others(
    partition: AnyPartition, ids: list[int], vectors: np.ndarray, count: int,
    exclude: int | None = None,
) -> list[np.ndarray]:
    """For each of ``ids`` (at ``vectors : (m, d) float32``), the exact cosines of its
    ``count`` most alike others (fewer when the partition holds fewer), largest first;
    ``exclude`` is no one's neighbour."""
    fetch = count + 2  # itself and the excluded model may be among the nearest
    if partition.approximate:  # estimated order: a margin, as for any exact re-rank
        fetch = partition.rerank_scale * max(2 * fetch, fetch + 10)
    _, found = partition.search(vectors, min(fetch, partition.size), None)
    rows = [[int(i) for i in row if i >= 0 and i != own and i != exclude]
            for own, row in zip(ids, found, strict=True)]
    if isinstance(partition, Partition):
        fetched = [partition.exact_vectors(neighbours)[0] for neighbours in rows]
    else:  # one round trip to Milvus for every id's neighbours
        union = sorted({i for neighbours in rows for i in neighbours})
        at = {i: row for row, i in enumerate(union)}
        every = partition.exact_vectors(union)[0]
        fetched = [every[[at[i] for i in neighbours]] for neighbours in rows]
    return [np.sort(near @ vector)[::-1][:count].astype(np.float64)
            for near, vector in zip(fetched, vectors, strict=True)]


def _ivf_blocks(
    partition: Partition, k: int, skip: Skip | None
) -> tuple[np.ndarray, Iterator[GraphBlock], bool]:
    """Each inverted list against the ``nprobe`` lists nearest it, on the full vectors, a
    block of the list's rows at a time."""
    ivf = faiss.extract_index_ivf(partition.index)
    full = partition.full
    assert full is not None  # a compressed partition keeps its full vectors
    members = [list_ids(ivf.invlists, number) for number in range(ivf.nlist)]
    ids = np.concatenate(members)
    starts = np.concatenate([[0], np.cumsum([len(m) for m in members])])
    probes = min(partition.nprobe, ivf.nlist)
    centroids = ivf.quantizer.reconstruct_n(0, ivf.nlist)
    _, nearby = ivf.quantizer.search(centroids, probes)

    def blocks() -> Iterator[GraphBlock]:
        for number in range(ivf.nlist):
            first, end = int(starts[number]), int(starts[number + 1])
            if first == end:
                continue
            # Its own list first, whatever ties between equal centroids say.
            lists = [number, *(int(j) for j in nearby[number] if 0 <= j != number)][:probes]
            at = np.concatenate([np.arange(starts[j], starts[j + 1]) for j in lists])
            # Rows a block at a time, about _BLOCK_ROW_PRODUCTS pairs each (a list of 10^6
            # models against 8 lists: 131 of its ~1000 rows, about 0.1 s).
            step = max(1, _BLOCK_ROW_PRODUCTS // len(at))
            wanted = [slice(row, min(row + step, end)) for row in range(first, end, step)]
            wanted = [rows for rows in wanted if skip is None or not skip(ids[rows])]
            if not wanted:
                continue
            # Copies, which the list's blocks share: valid while the partition is unchanged.
            columns, _ = full.get(ids[at].tolist())
            for rows in wanted:
                own = slice(rows.start - first, rows.stop - first)
                yield rows, *_nearest(columns[own], at[own], columns, at, k)

    return ids, blocks(), probes >= ivf.nlist


def _nearest(
    rows: np.ndarray, row_at: np.ndarray, columns: np.ndarray, column_at: np.ndarray, k: int
) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` most alike columns of each row, itself left out.

    Parameters
    ----------
    rows : (m, d) float32
        Unit vectors, at graph positions ``row_at : (m,) int``.
    columns : (c, d) float32
        Unit vectors compared with them, at positions ``column_at : (c,) int``.
    k : int
        Neighbours kept per row.

    Returns
    -------
    (m, k) int64 positions, most alike first (-1: none), and their (m, k) float32 cosines
    (-inf: none).
    """
    products = rows @ columns.T
    products[row_at[:, None] == column_at[None, :]] = -np.inf  # not its own neighbour
    take = min(k, products.shape[1])
    best = np.argpartition(-products, take - 1, axis=1)[:, :take]
    best_cosines = np.take_along_axis(products, best, axis=1)
    order = np.argsort(-best_cosines, axis=1, kind="stable")
    best = np.take_along_axis(best, order, axis=1)
    best_cosines = np.take_along_axis(best_cosines, order, axis=1)
    positions = np.where(np.isfinite(best_cosines), column_at[best], -1)
    neighbours = np.full((len(rows), k), -1, dtype=np.int64)
    cosines = np.full((len(rows), k), -np.inf, dtype=np.float32)
    neighbours[:, :take], cosines[:, :take] = positions, best_cosines
    return neighbours, cosines
