"""Hub discount for ranking: cross-domain similarity local scaling (CSLS).

In high-dimensional retrieval some vectors ("hubs") lie near many queries of other kinds
and push true answers down every list they enter (Radovanovic et al., JMLR 2010). CSLS
(Conneau et al., ICLR 2018) ranks a candidate ``x`` for a query ``q`` by
``cos(q, x) - (weight / 2) r_k(x)``, ``r_k(x)`` the mean cosine of ``x`` to its ``k``
nearest other vectors of the catalogue: a hub's is high, so it comes a little later.
Nothing is fitted; it uses only the catalogue searched.

For unit vectors ``|q - x|^2 = 2 - 2 cos(q, x)``, so the key ``|q - x|^2 + weight r_k(x)``,
lower first, ranks exactly as CSLS does; it is what ``hub_discounted_keys`` returns.
Chosen by leave-one-source-out on third-party sources (``k`` 10, ``weight`` 1: +0.011 mAP
left out over seven tuning sources; see the changelog); ``shapesearch eval --hub-discount
10`` scores it. The search service ranks shape-mode answers this way (``app.search.similarity``): it
fetches the ``rerank_depth(k)`` nearest models in plain distance order, takes their radii
from the index and re-orders them by ``hub_keys``; a model whose descriptor equals the
query's (``SAME_DESCRIPTOR``: the same part) stays first.

Scan mode (a partial scan against each model's whole descriptor and its virtual views) has a
discount of its own, since a scan is a query from another domain than whole models: a
catalogue entry's radius is its nearness to the *other models* as a scan could meet them,
the mean over its ``SCAN_HUB_NEIGHBOURS`` most alike other models of its largest cosine to
any of their entries (``model_radii``), weight ``SCAN_HUB_WEIGHT``; a model's key is its
best entry's ``hub_keys``. Chosen by the same rule (+0.006 mAP of single-view scans left
out over seven sources, every pre-registered test passed). It places scan mode's first
answer; ``core.rank.scan_order`` orders the rest.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "HUB_NEIGHBOURS",
    "HUB_RERANK_FACTOR",
    "HUB_WEIGHT",
    "SAME_DESCRIPTOR",
    "SCAN_HUB_NEIGHBOURS",
    "SCAN_HUB_WEIGHT",
    "hub_discounted_keys",
    "hub_keys",
    "model_radii",
    "model_radii_among",
    "neighbourhood_radii",
    "rerank_depth",
    "scan_hub_keys",
]

#: ``k`` and ``weight`` of the rule's choice.
HUB_NEIGHBOURS = 10
HUB_WEIGHT = 1.0
#: Candidates per wanted result that a search re-orders by ``hub_keys``: the plain top
#: ``rerank_depth(k)``. Chosen for agreement with the discount over the whole catalogue,
#: not for a score.
HUB_RERANK_FACTOR = 4
#: Distance at or below which two unit descriptors count as the same (float32 rounding of
#: one file described twice): such a candidate is the query's own part and is never
#: discounted below another.
SAME_DESCRIPTOR = 1e-4
#: Scan mode's ``k`` and ``weight`` (radii over every entry of the other models, the
#: smallest ``k`` and ``weight`` of the grid chosen from).
SCAN_HUB_NEIGHBOURS = 5
SCAN_HUB_WEIGHT = 0.5
def rerank_depth(k: int) -> int:
    """How many plain nearest candidates a search re-orders for ``k`` results."""
    return HUB_RERANK_FACTOR * k


def hub_keys(squared_distances: np.ndarray, radii: np.ndarray,
             weight: float = HUB_WEIGHT) -> np.ndarray:
    """The ranking key, lower first: ``|q - x|^2 + weight r_k(x)`` (CSLS order).

    Parameters
    ----------
    squared_distances : (...) float
        ``|q - x|^2`` of unit vectors.
    radii : (...) float
        ``r_k(x)`` of the same candidates (broadcast against ``squared_distances``).
    weight : float
        0 ranks by distance alone.

    Returns
    -------
    keys : (...) float
        A candidate within ``SAME_DESCRIPTOR`` of the query gets a key below every other's
        (keys otherwise exceed ``-|weight|``, cosines being at least -1), nearest first.
    """
    squared = np.asarray(squared_distances, dtype=np.float64)
    keys = squared + weight * np.asarray(radii)
    return np.where(squared <= SAME_DESCRIPTOR**2, squared - 1.0 - 2.0 * abs(weight), keys)


def model_radii(cosines: np.ndarray, owners: np.ndarray,
                neighbours: int = SCAN_HUB_NEIGHBOURS) -> np.ndarray:
    """Scan mode's ``r(e)``: per entry, the mean over the ``neighbours`` models it is most
    alike of its largest cosine to each model's entries.

    Parameters
    ----------
    cosines : (e, h) float
        Each entry's cosine to ``h`` catalogue entries (all of them, or its nearest: exact
        when those hold every entry of its ``neighbours`` most alike models that beats their
        best).
    owners : (e, h) int
        The model of each of those entries; negative ones are not counted (the entry's own
        model, a query's model left out of the catalogue, padding).
    neighbours : int
        ``k``; fewer models average those there are.

    Returns
    -------
    radii : (e,) float
        0 for an entry with no other model.
    """
    radii = np.zeros(len(cosines))
    for row, (values, models) in enumerate(zip(np.asarray(cosines), np.asarray(owners),
                                               strict=True)):
        best: dict[int, float] = {}
        for model, value in zip(models.tolist(), values.tolist(), strict=True):
            if model >= 0 and value > best.get(model, -np.inf):
                best[model] = value
        if best:
            top = sorted(best.values(), reverse=True)[:neighbours]
            radii[row] = sum(top) / len(top)
    return radii


def model_radii_among(entries: np.ndarray, owners: np.ndarray,
                      neighbours: int = SCAN_HUB_NEIGHBOURS,
                      among: np.ndarray | None = None,
                      rows: np.ndarray | None = None) -> np.ndarray:
    """``model_radii`` with the catalogue cut down to ``entries`` (or to those ``among``
    them): a lower bound of each entry's ``r(e)`` in any catalogue that holds them (the
    mean of the ``neighbours`` largest of more values is no smaller).

    Parameters
    ----------
    entries : (e, d) float
        Unit rows.
    owners : (e,) int
        The model of each.
    neighbours : int
        ``k``.
    among : (e,) bool, optional
        The entries the radii look at (default all): fewer make a looser bound at less
        cost, ``e`` by their number.
    rows : (r,) int, optional
        The entries bounded (default all).

    Returns
    -------
    bounds : (e,) or (r,) float
        -1 (the least a mean cosine can be) where those entries hold fewer than
        ``neighbours`` models besides the entry's own, since a catalogue with fewer would
        average fewer.
    """
    owners = np.asarray(owners)
    among = np.ones(len(owners), dtype=bool) if among is None else np.asarray(among, bool)
    column = np.unique(owners, return_inverse=True)[1]
    if len(np.unique(owners[among])) - 1 < neighbours:
        return np.full(len(owners) if rows is None else len(rows), -1.0)
    per_model = _best_per_model(np.asarray(entries, dtype=np.float64), column, among, rows)
    top = -np.partition(-per_model, neighbours - 1, axis=1)[:, :neighbours]
    return top.mean(axis=1)


def scan_hub_keys(queries: np.ndarray, entries: np.ndarray, owners: np.ndarray,
                  left_out: np.ndarray, neighbours: int = SCAN_HUB_NEIGHBOURS,
                  weight: float = SCAN_HUB_WEIGHT, pool: np.ndarray | None = None
                  ) -> np.ndarray:
    """Scan mode's ranking keys of every model over a whole catalogue, lower first: each
    model's least ``hub_keys(|q - e|^2, r(e))`` over its entries (what the search service
    computes for its ``4 k`` nearest, ``app.search.similarity``).

    Parameters
    ----------
    queries : (q, d) float
        Unit rows.
    entries : (e, d) float
        Unit rows: every model's entries (its whole descriptor and its views).
    owners : (e,) int
        The model of each entry, ``0 .. m - 1``.
    left_out : (q,) int
        The model each query leaves out of the catalogue (its own, leave-one-out), or -1:
        no radius counts it (its keys are still given; the caller leaves it out).
    neighbours, weight : int, float
        ``k`` and the weight of ``r``.
    pool : (e,) bool, optional
        The entries a radius looks at (default all: ``model_radii``'s choice; the views
        alone were a candidate, not chosen).

    Returns
    -------
    keys : (q, m) float
    """
    entries = np.asarray(entries)  # float32 as stored, or float64
    owners = np.asarray(owners)
    models = int(owners.max()) + 1
    per_model = _best_per_model(entries, owners, pool)
    radii = _left_out_radii(per_model, np.asarray(left_out), neighbours)
    squared = np.maximum(2.0 - 2.0 * np.asarray(queries) @ entries.T, 0.0)
    entry_keys = hub_keys(squared, radii, weight)
    keys = np.full((len(squared), models), np.inf)
    for model in range(models):
        keys[:, model] = entry_keys[:, owners == model].min(axis=1)
    return keys


def _best_per_model(entries: np.ndarray, owners: np.ndarray,
                    pool: np.ndarray | None = None,
                    rows: np.ndarray | None = None) -> np.ndarray:
    """``(e, m)``, or ``(r, m)`` for the entries ``rows``: each entry's largest cosine to
    each model's ``pool`` entries (default all), -inf for its own model and for a model
    with none in the pool."""
    pool = np.ones(len(owners), dtype=bool) if pool is None else np.asarray(pool, dtype=bool)
    columns = np.flatnonzero(pool)
    # Every row against a copy of the pool even when it is every entry: ``x @ x.T`` would
    # take another BLAS routine, whose sums round differently.
    bounded, pooled = (entries, entries[columns]) if rows is None else (
        entries[rows], entries if len(columns) == len(owners) else entries[columns])
    rows = np.arange(len(owners)) if rows is None else np.asarray(rows)
    per_model = np.full((len(rows), int(owners.max()) + 1), -np.inf)
    if len(columns):
        # The pool's entries grouped by model: one reduction per group, not a pass over
        # every column per model (a third of a scan search at a pool of 160).
        cosines = bounded @ pooled.T
        by_model = np.argsort(owners[columns], kind="stable")
        grouped = owners[columns][by_model]
        starts = np.flatnonzero(np.r_[True, grouped[1:] != grouped[:-1]])
        per_model[:, grouped[starts]] = np.maximum.reduceat(cosines[:, by_model], starts,
                                                            axis=1)
    per_model[np.arange(len(rows)), owners[rows]] = -np.inf
    return per_model


def _left_out_radii(per_model: np.ndarray, left_out: np.ndarray, k: int) -> np.ndarray:
    """``(q, e)`` means of each row's ``k`` largest finite values of ``per_model : (e, m)``
    without column ``left_out[q]`` (-1: none); fewer where fewer are finite."""
    order = np.argsort(-per_model, axis=1)[:, : k + 1]
    nearest = np.take_along_axis(per_model, order, axis=1)
    if nearest.shape[1] <= k or not np.isfinite(nearest).all():
        # A small catalogue (or entries without k + 1 models to compare): row by row.
        radii = np.zeros((len(left_out), len(per_model)))
        for row, model in enumerate(left_out.tolist()):
            values = per_model.copy()
            if model >= 0:
                values[:, model] = -np.inf
            for entry, entry_values in enumerate(values):
                finite = np.sort(entry_values[np.isfinite(entry_values)])[::-1][:k]
                radii[row, entry] = finite.mean() if len(finite) else 0.0
        return radii
    sums = nearest[:, :k].sum(axis=1)
    radii = np.broadcast_to(sums / k, (len(left_out), len(sums))).copy()
    # A left-out model among an entry's k nearest: the (k+1)-th takes its place.
    for row, model in enumerate(left_out.tolist()):
        if model >= 0:
            inside = (order[:, :k] == model).any(axis=1)
            radii[row, inside] = (sums[inside] - per_model[inside, model]
                                  + nearest[inside, k]) / k
    return radii


def neighbourhood_radii(database: np.ndarray, neighbours: int,
                        exclude: np.ndarray | None = None) -> np.ndarray:
    """``r_k(x)``: each database vector's mean cosine to its ``k`` nearest others.

    Parameters
    ----------
    database : (m, d) float
        Unit rows.
    neighbours : int
        ``k``; fewer when the catalogue holds fewer others (at least 1).
    exclude : (q, m) bool, optional
        Per query, at most one database vector that is not in the catalogue for it (the
        query itself, leave-one-out; a scan's own model): no radius counts it.

    Returns
    -------
    radii : (m,) float, or (q, m) float with ``exclude``
    """
    database = np.asarray(database, dtype=np.float64)
    count = database.shape[0]
    spare = 1 if exclude is not None else 0
    k = min(neighbours, count - 1 - spare)
    if k < 1:
        raise ValueError(f"a hub discount needs at least {2 + spare} vectors, got {count}")
    cosines = database @ database.T
    np.fill_diagonal(cosines, -np.inf)
    # Each row's k + 1 largest, nearest first: the (k+1)-th replaces an excluded neighbour.
    nearest = -np.sort(-cosines, axis=1)[:, : k + 1]
    radii = nearest[:, :k].mean(axis=1)
    if exclude is None:
        return radii
    exclude = np.asarray(exclude, dtype=bool)
    if exclude.shape[1] != count or (exclude.sum(axis=1) > 1).any():
        raise ValueError("exclude must be (queries, database) with at most one True per row")
    per_query = np.broadcast_to(radii, exclude.shape).copy()
    for query, left_out in zip(*np.nonzero(exclude), strict=True):
        to_left_out = cosines[:, left_out]
        inside = to_left_out >= nearest[:, k - 1]
        swapped = nearest[:, :k].sum(axis=1) - to_left_out + nearest[:, k]
        per_query[query, inside] = swapped[inside] / k
    return per_query


def hub_discounted_keys(queries: np.ndarray, database: np.ndarray,
                        neighbours: int = HUB_NEIGHBOURS, weight: float = HUB_WEIGHT,
                        exclude: np.ndarray | None = None) -> np.ndarray:
    """Ranking keys, lower first: ``|q - x|^2 + weight r_k(x)`` (CSLS order).

    Parameters
    ----------
    queries : (q, d) float
        Unit rows.
    database : (m, d) float
        Unit rows; the catalogue.
    neighbours : int
        ``k`` of ``r_k``.
    weight : float
        0 ranks by distance alone.
    exclude : (q, m) bool, optional
        As ``neighbourhood_radii``'s; the pairs themselves are still given keys (the caller
        leaves them out of its ranking).

    Returns
    -------
    keys : (q, m) float
    """
    queries = np.asarray(queries, dtype=np.float64)
    database = np.asarray(database, dtype=np.float64)
    squared = np.maximum(2.0 - 2.0 * queries @ database.T, 0.0)
    if weight == 0:
        return squared
    return hub_keys(squared, neighbourhood_radii(database, neighbours, exclude), weight)
