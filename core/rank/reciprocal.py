"""k-reciprocal re-ranking (Zhong et al., CVPR 2017) over the hub discount's order.

A model near a query is more likely of the query's kind when the query is near it too: its
``k1`` nearest hold the query. The method compares neighbourhoods instead of vectors:

1. ``D``: squared distances, each row divided by its largest; ``N(i, k)`` the ``k + 1``
   nearest of ``i`` (itself included); ``R(i, k)`` those ``j`` of them with ``i`` in
   ``N(j, k)``;
2. ``R*(i)``: ``R(i, k1)`` joined with each ``R(j, round(k1 / 2))``, ``j`` in ``R(i, k1)``,
   that shares more than two thirds of its members with ``R(i, k1)``;
3. ``V[i, j] = exp(-D[i, j])`` for ``j`` in ``R*(i)`` (0 elsewhere), each row summing to 1,
   then each row replaced by the mean of the rows of its ``k2`` nearest (itself included);
4. ``d_J(i, j) = 1 - sum(min(V_i, V_j)) / sum(max(V_i, V_j))``, and the key, lower first,
   ``(1 - blend) d_J + blend T``, ``T`` the hub discount's keys (``core.rank.hubness``) rescaled
   to [0, 1] per query: outside the reciprocal neighbourhoods ``d_J`` is 1, and there the
   hub discount's order decides;
5. with that term, the hub discount's first answer stays first (``first_kept``): the
   re-rank lifts mAP but moves right first answers down more often than it lifts wrong ones
   (four extractions of eight sources: the re-rank alone lowers the first answer of a
   catalogue of 326 third-party parts from 0.847 to 0.835; with the first answer kept it
   stays 0.847 and mAP is the re-rank's, 0.712 against the discount's 0.676).

Chosen by leave-one-source-out on third-party sources (see the changelog): ``k1`` 5,
``k2`` 3 (+0.017 mAP left out over seven sources with ``blend`` 0.3), confirmed on an eighth
source that no setting had seen, OpenSCAD's MCAD parts (+0.039, 95 % +0.026 .. +0.052); then
``blend`` 0.1 (``k1`` {3, 5, 7} x ``lambda`` {0.1, 0.2, 0.3, 0.5}, +0.0034 mAP left out over
eight sources, 95 % +0.0006 .. +0.0062; fixed, on two extractions no score had read,
+0.0062 and +0.0055, 95 % +0.0045 .. +0.0082 and +0.0038 .. +0.0075): the Jaccard distance
of the neighbourhoods decides more and the hub discount's order less, and since its first
answer is kept, no first answer moves.
``reciprocal_keys`` ranks a whole catalogue (the evaluation); ``pool_keys`` ranks one query's
nearest candidates among themselves (the search service, which re-orders the
``reciprocal_depth(k)`` nearest: a neighbourhood is then taken within those candidates,
measured against the whole catalogue's order).
"""

from __future__ import annotations

import numpy as np

from core.rank.hubness import SAME_DESCRIPTOR, rerank_depth

__all__ = ["BLEND", "EXPANSION", "RECIPROCAL_NEIGHBOURS", "RECIPROCAL_POOL", "first_kept",
           "pool_keys", "reciprocal_depth", "reciprocal_keys", "rescaled_rows"]

#: ``k1``, ``k2`` and ``lambda`` of the rules' choices.
RECIPROCAL_NEIGHBOURS = 5
EXPANSION = 3
BLEND = 0.1
#: The fewest plain nearest candidates a search re-ranks among themselves: 4 per result for
#: 10 results, the hub discount's own depth, chosen for cost after the measurement
#: (on 326 parts: precision at 10 0.555 against the whole catalogue's re-rank 0.569 and
#: the discount's 0.539, NN level; 160 gives 0.563 at 3.2x the discount's time per query
#: in-process at 10^5 models, 40 at 1.4-1.6x: ``bench/search_scale.py --reciprocal-pools``).
RECIPROCAL_POOL = 40


def reciprocal_depth(k: int) -> int:
    """How many plain nearest candidates a search re-ranks for ``k`` results: the hub
    discount's ``rerank_depth(k)``, at least ``RECIPROCAL_POOL``."""
    return max(rerank_depth(k), RECIPROCAL_POOL)


def _reciprocal_members(ranks: np.ndarray, k: int) -> np.ndarray:
    """``(m, m)`` bool: row ``i`` marks ``R(i, k)``."""
    m = len(ranks)
    forward = ranks[:, : k + 1]
    backward = ranks[forward, : k + 1]  # (m, k + 1, k + 1)
    mutual = (backward == np.arange(m)[:, None, None]).any(axis=2)
    members = np.zeros((m, m), dtype=bool)
    rows = np.broadcast_to(np.arange(m)[:, None], forward.shape)
    members[rows[mutual], forward[mutual]] = True
    return members


def _weights(squared: np.ndarray, neighbours: int, expansion: int,
             ranks: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``V`` (step 3) and the scaled distances ``D``, each ``(m, m)``, of the ``(m, m)``
    squared distances (a zero diagonal); the neighbourhoods in ``ranks`` ``(m, m)`` (each
    row's models, nearest first, itself first) when given, in ``D``'s order otherwise."""
    scaled = squared / np.maximum(squared.max(axis=1, keepdims=True), 1e-12)
    if ranks is None:
        ranks = np.argsort(scaled, axis=1, kind="stable")
    m = len(squared)
    k1 = min(neighbours, m - 1)
    core = _reciprocal_members(ranks, k1)
    half = _reciprocal_members(ranks, max(1, round(k1 / 2)))
    # j in R(i, k1) whose R(j, k1/2) shares more than two thirds of its members with R(i, k1)
    # (counts of a few members: exact in float32, whose products are the faster)
    shared = core.astype(np.float32) @ half.T.astype(np.float32)
    joins = core & (shared > 2.0 / 3.0 * half.sum(axis=1)[None, :])
    expanded = core | (joins.astype(np.float32) @ half.astype(np.float32) > 0)
    weights = np.where(expanded, np.exp(-scaled), 0.0)
    weights /= weights.sum(axis=1, keepdims=True)
    if expansion > 1:
        weights = weights[ranks[:, : min(expansion, m)]].mean(axis=1)
    return weights, scaled


def _jaccard(weights: np.ndarray, row: int) -> np.ndarray:
    """``d_J(row, j)`` for every ``j``: each row of ``weights`` sums to 1, so the sum of the
    maxima is ``2 -`` the sum of the minima."""
    shared = np.minimum(weights[row], weights).sum(axis=1)
    return 1.0 - shared / np.maximum(2.0 - shared, 1e-12)


def rescaled_rows(keys: np.ndarray) -> np.ndarray:
    """Each row of ``(m, m)`` keys rescaled to [0, 1] over the other columns (the diagonal,
    the query itself, set to 0)."""
    off = ~np.eye(len(keys), dtype=bool)
    low = np.where(off, keys, np.inf).min(axis=1, keepdims=True)
    high = np.where(off, keys, -np.inf).max(axis=1, keepdims=True)
    return np.where(off, (keys - low) / np.maximum(high - low, 1e-12), 0.0)


def first_kept(keys: np.ndarray, term: np.ndarray) -> np.ndarray:
    """``keys`` with each query's first answer by ``term`` put before every other answer.

    Parameters
    ----------
    keys : (c,) or (m, c) float
        Ranking keys, lower first, one row per query; ``-inf`` marks the query's own part
        (and ``reciprocal_keys``' diagonal, the query itself), which stays where it is.
    term : (c,) or (m, c) float
        The keys whose order's first answer is kept (the hub discount's); among equal
        ones, the earlier column.

    Returns
    -------
    keys : like ``keys``
        A copy; in each row, the finite key of ``term``'s lowest column among the finite
        ones set below the row's other finite keys.
    """
    kept = np.array(keys, dtype=np.float64)
    rows, terms = np.atleast_2d(kept), np.atleast_2d(term)  # a view: rows writes into kept
    finite = np.isfinite(rows)
    for row in np.flatnonzero(finite.any(axis=1)):
        first = np.argmin(np.where(finite[row], terms[row], np.inf))
        rows[row, first] = rows[row, finite[row]].min() - 1.0
    return kept


def reciprocal_keys(rows: np.ndarray, term: np.ndarray | None = None,
                    neighbours: int = RECIPROCAL_NEIGHBOURS, expansion: int = EXPANSION,
                    blend: float = BLEND, keep_first: bool = True) -> np.ndarray:
    """Ranking keys of every model (row) for every other: a whole catalogue.

    Parameters
    ----------
    rows : (m, d) float
        Unit rows; each is a query and the others its catalogue (all of them form the set
        the neighbourhoods are taken in, the query included, as in the paper).
    term : (m, m) float, optional
        The blended distance term, each row in [0, 1] (``rescaled_rows`` of the hub
        discount's keys), whose first answer then stays first (step 5); ``D`` when not
        given (the paper's, no answer kept).
    neighbours, expansion, blend : int, int, float
        ``k1``, ``k2`` and ``lambda``.
    keep_first : bool
        With ``term``, keep its first answer first (step 5); False gives the plain
        blended re-rank.

    Returns
    -------
    keys : (m, m) float
        Lower first; a model within ``SAME_DESCRIPTOR`` of the query gets ``-inf`` (it is
        the query's own part). The diagonal is the query itself: callers leave it out.
    """
    rows = np.asarray(rows, dtype=np.float64)
    squared = np.maximum(2.0 - 2.0 * rows @ rows.T, 0.0)
    np.fill_diagonal(squared, 0.0)
    weights, scaled = _weights(squared, neighbours, expansion)
    jaccard = np.vstack([_jaccard(weights, i) for i in range(len(rows))])
    keys = (1.0 - blend) * jaccard + blend * (scaled if term is None else term)
    keys = np.where(np.sqrt(squared) <= SAME_DESCRIPTOR, -np.inf, keys)
    return first_kept(keys, term) if keep_first and term is not None else keys


def pool_keys(query: np.ndarray, candidates: np.ndarray, hub: np.ndarray,
              neighbours: int = RECIPROCAL_NEIGHBOURS, expansion: int = EXPANSION,
              blend: float = BLEND) -> np.ndarray:
    """Ranking keys of one query's candidates, the neighbourhoods taken among the query and
    the candidates alone.

    Parameters
    ----------
    query : (d,) float
        Unit vector.
    candidates : (c, d) float
        Unit rows, ``c >= 1``: the query's nearest models.
    hub : (c,) float
        The candidates' hub discount keys for the query (``core.rank.hubness.hub_keys``), the
        blended term once rescaled to [0, 1].

    Returns
    -------
    keys : (c,) float
        Lower first; ``-inf`` for a candidate within ``SAME_DESCRIPTOR`` of the query; then
        the hub discount's first answer among the others (step 5).
    """
    candidates = np.asarray(candidates)
    query = np.asarray(query, dtype=candidates.dtype).ravel()
    # The products in the vectors' own precision (float32 in the service: twice as fast, and
    # no copy of the candidates in float64), ...
    rows = np.vstack([query, candidates])
    squared = np.maximum(2.0 - 2.0 * (rows @ rows.T).astype(np.float64), 0.0)
    # ... the query's own distances from differences: exactly 0 for its own part.
    own = np.sum(np.square(candidates - query), axis=1, dtype=np.float64)
    squared[0, 1:] = squared[1:, 0] = own
    np.fill_diagonal(squared, 0.0)
    weights, _ = _weights(squared, neighbours, expansion)
    same = np.sqrt(own) <= SAME_DESCRIPTOR
    hub = np.asarray(hub, dtype=np.float64)
    # Rescaled over the other candidates: the query's own part has a key of its own kind.
    others = hub[~same]
    low, high = (others.min(), others.max()) if len(others) else (0.0, 0.0)
    term = (hub - low) / max(high - low, 1e-12)
    keys = (1.0 - blend) * _jaccard(weights, 0)[1:] + blend * term
    return first_kept(np.where(same, -np.inf, keys), term)
