"""Retrieval scores on a distance matrix: pure functions, no I/O.

Conventions follow the Princeton Shape Benchmark (Shilane et al. 2004) as used in SHREC:

- every query ranks the whole database by distance, ascending; the query itself (or, for a
  scan, the clean model it was made from) is excluded, so a perfect score is reachable;
- ``C`` is the number of relevant (same-class) models left in the database for that query;
- nearest neighbour (NN): is the first result relevant;
- first tier (FT): share of the ``C`` relevant models among the first ``C`` results;
- second tier (ST): share of the ``C`` relevant models among the first ``2 C`` results;
- discounted cumulative gain (DCG): ``G_1 + sum_{i >= 2} G_i / log2(i)`` over the whole
  ranking, divided by the same sum for an ideal ranking (all ``C`` relevant first);
- average precision (AP): mean of the precision at the rank of every relevant model; its
  mean over queries is mAP;
- top-5 hit rate: share of relevant models among the first 5 results (Williams & Ilies).

Ties in distance are broken by database index (stable sort), so scores are deterministic.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

import numpy as np

__all__ = [
    "METRICS",
    "average_precision",
    "dcg",
    "first_tier",
    "nearest_neighbour",
    "pairwise_distances",
    "per_class_scores",
    "precision_recall_curve",
    "ranked_relevance",
    "score_rankings",
    "second_tier",
    "top_k_hit_rate",
]

#: Names of the scalar metrics, in report order.
METRICS: tuple[str, ...] = ("nn", "ft", "st", "dcg", "map", "top5")


def pairwise_distances(queries: np.ndarray, database: np.ndarray) -> np.ndarray:
    """Euclidean distances between descriptor rows.

    Parameters
    ----------
    queries : (q, d) float
    database : (m, d) float

    Returns
    -------
    distances : (q, m) float64
    """
    queries = np.asarray(queries, dtype=np.float64)
    database = np.asarray(database, dtype=np.float64)
    squared = (
        (queries**2).sum(axis=1)[:, None]
        + (database**2).sum(axis=1)[None, :]
        - 2.0 * queries @ database.T
    )
    # Round-off can make a zero distance slightly negative.
    return np.sqrt(np.maximum(squared, 0.0))


def ranked_relevance(
    distances: np.ndarray,
    query_labels: Sequence[object],
    database_labels: Sequence[object],
    exclude: np.ndarray | None = None,
) -> list[np.ndarray]:
    """Relevance of every ranked result, per query.

    Parameters
    ----------
    distances : (q, m) float
    query_labels : (q,) labels
    database_labels : (m,) labels
    exclude : (q, m) bool, optional
        Pairs left out of the ranking (the query itself, its source model).

    Returns
    -------
    relevance : list of q arrays of bool
        ``relevance[i][r]`` is True when the result at rank ``r`` (0-based) of query ``i``
        has the query's label. Excluded models are removed, so lengths may differ.
    """
    database = np.asarray(database_labels, dtype=object)
    return [database[order] == label
            for order, label in zip(_rankings(distances, exclude), query_labels, strict=True)]


def _rankings(distances: np.ndarray, exclude: np.ndarray | None) -> list[np.ndarray]:
    """Each query's database indices, nearest first, without its excluded ones."""
    distances = np.asarray(distances, dtype=np.float64)
    orders = []
    for row in range(distances.shape[0]):
        keep = np.ones(distances.shape[1], dtype=bool) if exclude is None else ~exclude[row]
        candidates = np.flatnonzero(keep)
        orders.append(candidates[np.argsort(distances[row, candidates], kind="stable")])
    return orders


def per_class_scores(
    distances: np.ndarray,
    query_labels: Sequence[str],
    database_labels: Sequence[str],
    exclude: np.ndarray | None = None,
) -> dict[str, dict[str, object]]:
    """NN, mAP and the first answers' wrong kinds, per query label.

    Parameters are ``ranked_relevance``'s. Returns, per label with a scored query (one
    with a relevant model left), ``queries``, ``nn``, ``map`` and ``mistakes``: the labels
    of wrong first answers with their counts, most first (ties by label).
    """
    database = np.asarray(database_labels, dtype=object)
    # Per label: (nn, ap, first answer's label) of each scored query.
    queries: dict[str, list[tuple[float, float, str]]] = {}
    for order, label in zip(_rankings(distances, exclude), query_labels, strict=True):
        relevance = database[order] == label
        if relevance.any():
            queries.setdefault(label, []).append((nearest_neighbour(relevance),
                                                  average_precision(relevance),
                                                  str(database[order[0]])))
    result: dict[str, dict[str, object]] = {}
    for label, rows in sorted(queries.items()):
        nn, ap, first = zip(*rows, strict=True)
        wrong = Counter(answer for answer in first if answer != label)
        result[label] = {
            "queries": len(rows),
            "nn": float(np.mean(nn)),
            "map": float(np.mean(ap)),
            "mistakes": dict(sorted(wrong.items(), key=lambda item: (-item[1], item[0]))),
        }
    return result


def nearest_neighbour(relevance: np.ndarray) -> float:
    """1.0 when the first result is relevant, else 0.0."""
    return float(relevance[0]) if relevance.size else 0.0


def first_tier(relevance: np.ndarray) -> float:
    """Share of the ``C`` relevant results among the first ``C``."""
    count = int(relevance.sum())
    return float(relevance[:count].sum() / count) if count else 0.0


def second_tier(relevance: np.ndarray) -> float:
    """Share of the ``C`` relevant results among the first ``2 C``."""
    count = int(relevance.sum())
    return float(relevance[: 2 * count].sum() / count) if count else 0.0


def _discounts(length: int) -> np.ndarray:
    """``1, 1/log2(2), 1/log2(3), ...``: rank 1 is not discounted (PSB convention)."""
    ranks = np.arange(1, length + 1, dtype=np.float64)
    discounts = np.ones(length)
    discounts[1:] = 1.0 / np.log2(ranks[1:])
    return discounts


def dcg(relevance: np.ndarray) -> float:
    """Normalised discounted cumulative gain over the whole ranking."""
    count = int(relevance.sum())
    if not count:
        return 0.0
    discounts = _discounts(relevance.size)
    return float((relevance * discounts).sum() / discounts[:count].sum())


def average_precision(relevance: np.ndarray) -> float:
    """Mean precision at the ranks of the relevant results."""
    hits = np.flatnonzero(relevance)
    if not hits.size:
        return 0.0
    precision_at_hits = np.arange(1, hits.size + 1) / (hits + 1.0)
    return float(precision_at_hits.mean())


def top_k_hit_rate(relevance: np.ndarray, k: int = 5) -> float:
    """Share of relevant results among the first ``k`` (fewer if the ranking is shorter)."""
    head = relevance[:k]
    return float(head.mean()) if head.size else 0.0


def precision_recall_curve(
    relevance: np.ndarray, recall: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Interpolated precision at fixed recall levels.

    Parameters
    ----------
    relevance : (m,) bool
    recall : (r,) float, optional
        Recall levels; default 0.05, 0.10, ..., 1.0.

    Returns
    -------
    recall : (r,) float
    precision : (r,) float
        Highest precision reached at any recall >= each level (the usual interpolation).
    """
    recall = np.linspace(0.05, 1.0, 20) if recall is None else np.asarray(recall, dtype=float)
    hits = np.flatnonzero(relevance)
    if not hits.size:
        return recall, np.zeros_like(recall)
    reached = np.arange(1, hits.size + 1) / hits.size
    precision = np.arange(1, hits.size + 1) / (hits + 1.0)
    # Running maximum from the right: best precision at this recall or beyond.
    best = np.maximum.accumulate(precision[::-1])[::-1]
    index = np.searchsorted(reached, recall - 1e-12, side="left")
    return recall, best[np.minimum(index, hits.size - 1)]


def score_rankings(relevance: list[np.ndarray], k: int = 5) -> dict[str, float]:
    """Mean of every metric over queries that have at least one relevant model.

    Parameters
    ----------
    relevance : list of (m_i,) bool
        From ``ranked_relevance``.
    k : int
        Depth of the hit rate (5 in the paper).

    Returns
    -------
    scores : dict
        ``nn, ft, st, dcg, map, top5`` in [0, 1] (nan when no query could be scored) and
        ``queries`` (count scored).
    """
    scored = [r for r in relevance if r.any()]
    functions = {
        "nn": nearest_neighbour,
        "ft": first_tier,
        "st": second_tier,
        "dcg": dcg,
        "map": average_precision,
        "top5": lambda r: top_k_hit_rate(r, k),
    }
    scores = {
        name: float(np.mean([function(r) for r in scored])) if scored else float("nan")
        for name, function in functions.items()
    }
    scores["queries"] = float(len(scored))
    return scores
