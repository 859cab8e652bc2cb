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
"""

from __future__ import annotations

from dataclasses import dataclass

import faiss
import numpy as np

from app.search.index._partition import Partition

__all__ = ["NeighbourGraph", "neighbour_graph"]

_BLOCK_PRODUCTS = 1 << 24  # products (floats) per block of a flat partition: 64 MB


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


def neighbour_graph(partition: Partition, k: int) -> NeighbourGraph:
    """The ``k`` most alike others of every vector of ``partition`` (call with its read
    lock held)."""
    if partition.index.ntotal == 0:
        return NeighbourGraph.empty(k)
    if partition.approximate:
        return _ivf_graph(partition, k)
    return _flat_graph(partition, k)


def _flat_graph(partition: Partition, k: int) -> NeighbourGraph:
    """Every vector against every other, a block of rows at a time."""
    index = partition.index  # IndexIDMap2(IndexFlatL2)
    ids = faiss.vector_to_array(index.id_map).astype(np.int64)
    vectors = index.index.reconstruct_n(0, index.ntotal)[:, : partition.dim]
    n = len(ids)
    positions = np.arange(n)
    neighbours = np.empty((n, k), dtype=np.int64)
    cosines = np.empty((n, k), dtype=np.float32)
    step = max(1, min(1024, _BLOCK_PRODUCTS // n))
    for start in range(0, n, step):
        rows = slice(start, start + step)
        neighbours[rows], cosines[rows] = _nearest(
            vectors[rows], positions[rows], vectors, positions, k
        )
    return NeighbourGraph(ids, neighbours, cosines, exact=True)


def _ivf_graph(partition: Partition, k: int) -> NeighbourGraph:
    """Each inverted list against the ``nprobe`` lists nearest it, on the full vectors."""
    ivf = faiss.extract_index_ivf(partition.index)
    assert partition.full is not None  # a compressed partition keeps its full vectors
    members = [_list_ids(ivf.invlists, number) for number in range(ivf.nlist)]
    ids = np.concatenate(members)
    starts = np.concatenate([[0], np.cumsum([len(m) for m in members])])
    probes = min(partition.nprobe, ivf.nlist)
    centroids = ivf.quantizer.reconstruct_n(0, ivf.nlist)
    _, nearby = ivf.quantizer.search(centroids, probes)
    neighbours = np.full((len(ids), k), -1, dtype=np.int64)
    cosines = np.full((len(ids), k), -np.inf, dtype=np.float32)
    for number in range(ivf.nlist):
        if len(members[number]) == 0:
            continue
        # Its own list first, whatever ties between equal centroids say.
        lists = [number, *(int(j) for j in nearby[number] if 0 <= j != number)][:probes]
        at = np.concatenate([np.arange(starts[j], starts[j + 1]) for j in lists])
        columns, _ = partition.full.get(ids[at].tolist())
        rows = slice(starts[number], starts[number + 1])
        count = starts[number + 1] - starts[number]
        neighbours[rows], cosines[rows] = _nearest(
            columns[:count], at[:count], columns, at, k
        )
    return NeighbourGraph(ids, neighbours, cosines, exact=probes >= ivf.nlist)


def _list_ids(invlists: faiss.InvertedLists, number: int) -> np.ndarray:
    """The ids held in inverted list ``number``."""
    size = invlists.list_size(number)
    if size == 0:
        return np.zeros(0, dtype=np.int64)
    return faiss.rev_swig_ptr(invlists.get_ids(number), size).astype(np.int64)


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
