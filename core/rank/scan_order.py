"""Scan mode's order: the first answer by scan mode's hub discount, the rest as that answer's
own shape-mode answer.

A partial scan is far from every whole model, but its first answer is a whole model, and a
whole model finds its kind well: in shape mode, by the hub discount (``core.rank.hubness``) and
the k-reciprocal re-rank over it (``core.rank.reciprocal``). So scan mode places its first answer
by ``core.rank.hubness.scan_hub_keys`` (each model's best entry, whole or a virtual view,
discounted among the other models' entries), and orders the rest of its pool as the search
service orders the candidates of a shape query for that first answer's whole descriptor:
hub keys ``|x - a|^2 + r_10(x)``, then ``core.rank.reciprocal.pool_keys`` among the pool. The
scan's own keys no longer order the rest; they choose the pool and the first answer. The
first answer's own ``ANCHOR_NEIGHBOURS`` nearest models (by whole descriptor) join the pool
for the rest: models of its kind that the scan's partial view put far off.

Chosen by leave-one-source-out on third-party sources (see the changelog): single-view
scans +0.015 mAP left out over seven sources (95 % +0.010 .. +0.021) against ordering the
rest by ``(1 - 0.75) key + 0.75 |x - a|^2``, with merged scans, clean queries, BOSL2 (no
choice saw it) and the ``bendable`` family up, and chosen again on a second draw of every
scan. The first answer's neighbours joined the pool by the same rule: +0.013 mAP of
single-view scans left out over seven sources (95 % +0.007 .. +0.019) on a third draw of
every scan, merged scans, clean queries, BOSL2 and the ``bendable`` family level or up.
"""

from __future__ import annotations

import numpy as np

from core.rank.hubness import (
    HUB_NEIGHBOURS,
    hub_keys,
    neighbourhood_radii,
    rerank_depth,
    scan_hub_keys,
)
from core.rank.reciprocal import pool_keys

__all__ = ["ANCHOR_NEIGHBOURS", "SCAN_POOL", "scan_depth", "scan_mode_positions",
           "scan_ranking"]

#: The fewest models nearest by plain best entry that scan mode re-orders: shape mode's pool
#: size. 160 lifts single views a little (+0.007 left out) at 2.5x the search (3.7x before
#: the pool was ordered from the index's vectors), more than the 1.5x allowed.
SCAN_POOL = 40

#: How many models nearest the first answer's whole descriptor join the pool for the rest
#: of the answer (0: none). The pool of 160 reached some of them, at every entry of every
#: model read and bounded; these cost their vectors alone (``bench/scan_search.py
#: --anchor-neighbours``). Chosen among {0, 40, 120} by leave-one-source-out.
ANCHOR_NEIGHBOURS = 120


def scan_depth(k: int) -> int:
    """How many models nearest by plain best entry scan mode re-orders for ``k`` results:
    ``max(4 k, SCAN_POOL)``."""
    return max(rerank_depth(k), SCAN_POOL)


def scan_ranking(keys: np.ndarray, whole: np.ndarray, depth: int, radii: np.ndarray,
                 neighbours: int = ANCHOR_NEIGHBOURS) -> np.ndarray:
    """Scan mode's order of a whole catalogue for one query: the first answer (least key)
    first; then the rest of the ``depth`` least keys joined with the first answer's
    ``neighbours`` nearest models (by whole descriptor, among those of finite key), in the
    first answer's shape-mode order among them; the others after them by key. The search
    service orders its pool so, with ``depth = scan_depth(k)``; its pool is the nearest by
    plain best entry rather than by key (which changes the answers little).

    Parameters
    ----------
    keys : (m,) float
        ``scan_hub_keys`` of every model (``inf`` for a model left out: it is in no pool).
    whole : (m, d) float
        Each model's whole descriptor (unit rows).
    depth : int
        The pool re-ordered.
    radii : (m,) float
        Each model's shape-mode ``r_10`` (``core.rank.hubness.neighbourhood_radii`` over the
        whole descriptors, the left-out model in no neighbourhood).
    neighbours : int
        How many of the first answer's nearest join the pool (``ANCHOR_NEIGHBOURS``).

    Returns
    -------
    positions : (m,) float
        Each model's place in the answer, lower first (``inf`` where ``keys`` is).
    """
    keys = np.asarray(keys, dtype=float)
    order = np.argsort(keys, kind="stable")
    order = order[np.isfinite(keys[order])]
    if len(order) > 1:
        anchor = order[0]
        squared = np.sum((whole - whole[anchor]) ** 2, axis=1)
        # Nearest the first answer: itself and the models of infinite key left out.
        squared[anchor] = np.inf
        squared[~np.isfinite(keys)] = np.inf
        near_anchor = np.argsort(squared, kind="stable")[:neighbours]
        near_anchor = near_anchor[np.isfinite(squared[near_anchor])]
        # The pool's others (by key), then the joined (nearest the first answer first).
        rest = np.concatenate([order[1:depth], near_anchor[~np.isin(near_anchor, order[:depth])]])
        near = pool_keys(whole[anchor], whole[rest], hub_keys(squared[rest], radii[rest]))
        head = np.concatenate([order[:1], rest[np.argsort(near, kind="stable")]])
        order = np.concatenate([head, order[~np.isin(order, head)]])
    positions = np.full(len(keys), np.inf)
    positions[order] = np.arange(len(order), dtype=float)
    return positions


def scan_mode_positions(queries: np.ndarray, entries: np.ndarray, owners: np.ndarray,
                        left_out: np.ndarray, whole: np.ndarray,
                        depth: int | None = None) -> np.ndarray:
    """Each query's ``scan_ranking`` over a whole catalogue, as the search service answers
    10 results (``depth`` ``scan_depth(10)`` unless given).

    Parameters
    ----------
    queries, entries, owners, left_out
        As ``core.rank.hubness.scan_hub_keys`` (``left_out`` -1: none).
    whole : (m, d) float
        Each model's whole descriptor (unit rows).

    Returns
    -------
    positions : (q, m) float
        Lower first; ``inf`` for each query's left-out model.
    """
    keys = scan_hub_keys(queries, entries, owners, left_out)
    left_out = np.asarray(left_out)
    whole = np.asarray(whole, dtype=np.float64)
    rows = np.flatnonzero(left_out >= 0)
    keys[rows, left_out[rows]] = np.inf
    excluded = left_out[:, None] == np.arange(len(whole))[None, :]
    radii = neighbourhood_radii(whole, HUB_NEIGHBOURS, exclude=excluded)
    pool = scan_depth(10) if depth is None else depth
    return np.array([scan_ranking(row, whole, pool, row_radii)
                     for row, row_radii in zip(keys, radii, strict=True)])
