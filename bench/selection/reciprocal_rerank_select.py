"""Issue 24 follow-up: does k-reciprocal re-ranking carry over better than the hub discount?

Why: mAP is the held-out figure that misses most (the rest of a kind comes late). Query
expansion was declined because an expanded query drifts toward its first mistake (gears);
k-reciprocal re-ranking (Zhong et al., CVPR 2017) expands only with neighbours that have the
query among their own nearest, which is meant to stop that drift, and it is a standard mAP
gain in instance retrieval. Measurement only: adopting it would need each model's neighbour
list in the index (not only its radius), so it is measured first, like the hub discount was.

The method, as published, on ``ss9``'s unit rows; every model of a source is a query and the
others its catalogue (all together form the set the neighbourhoods are taken in, as in the
paper, where probe and gallery are ranked together):

1. ``D``: squared distances, each row divided by its largest; ``N(i, k)`` the ``k + 1``
   nearest of ``i`` (itself included), ``R(i, k)`` those ``j`` of them with ``i`` in
   ``N(j, k)``;
2. ``R*(i)``: ``R(i, k1)`` joined with each ``R(j, round(k1 / 2))``, ``j`` in ``R(i, k1)``,
   that shares more than two thirds of its members with ``R(i, k1)``;
3. ``V[i, j] = exp(-D[i, j])`` for ``j`` in ``R*(i)`` (0 elsewhere), each row summing to 1,
   then each row replaced by the mean of the rows of its ``k2`` nearest (itself included);
4. ``d_J(i, j) = 1 - sum(min(V_i, V_j)) / sum(max(V_i, V_j))`` and the final distance
   ``(1 - lambda) d_J + lambda D``, ``lambda`` 0.3 (the paper's).

Grid, rule and ship test written before any score of them was seen: ``k1`` in {5, 10, 20}
x ``k2`` in {1, 3} (``k2`` 1: no local expansion); the pool is those six and the shipped hub
discount (``csls k10 beta1``), the reference and the tie target; plain ``ss9`` reported for
context. The rule and the ship condition are ``hub_measures_select.py``'s (mAP per source,
mean over the seven, ties within 0.002 to the reference first, then the grid's order;
leave-one-source-out with a paired bootstrap; ship only if above the reference by more than
0.002 with the interval above zero, and the ``bendable`` family's mean over (bendable,
capod-nonrigid) not below the reference's by more than 0.002). The three third-party sources
as one catalogue reported beside for plain, the reference and the choice. A candidate within
``SAME_DESCRIPTOR`` of the query comes first, as in the service.

**Round 2** (``--round 2``; written after round 1's table was seen, disclosed as such: round
1's choice passed the parts test and failed the ``bendable`` family check by 0.001, and the
hub discount is what lifts that family): the blended distance term ``lambda D`` orders
whatever lies outside the reciprocal neighbourhoods (where ``d_J`` is 1: most of a
catalogue), so it is taken from the shipped hub discount instead of the plain distance: the
CSLS keys (``k`` 10, ``beta`` 1, the query left out), each row rescaled to [0, 1] over the
other models. Grid ``k1`` in {5, 10}, ``k2`` 3, the pool those two, round 1's two with
``k2`` 3 and the reference; the same rule, ties to the reference first, then this order.

**Result** (2026-11-27, tenth session; docs/results.md, "k-reciprocal re-ranking"): the rule
chose ``k1`` 5, ``k2`` 3 without every source, **+0.0173 (95 % +0.0131 .. +0.0215)** left out
against the hub discount, every source up or level; the ``bendable`` family check fails
(0.9806 against 0.9836), so by its rule it does not ship; one catalogue mAP 0.769 -> 0.792,
NN 0.874 -> 0.866. Round 2: the hub-term ``k1`` 5 candidate scores 0.8876 and passes the
family check (0.9868), but ties (within 0.002) with round 1's ``k1`` 5, ``k2`` 3, which the
rule keeps: not shipped either.

    nice -n 10 .venv/bin/python bench/selection/reciprocal_rerank_select.py /work/study \\
        --json /work/study/reciprocal_rerank.json [--round 2]
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from hub_measures_select import PLAIN, REFERENCE, Candidate, run_search_study  # noqa: E402
from hubness_select import hub_discounted  # noqa: E402
from profile_block_select import study_command  # noqa: E402

from core.rank.reciprocal import reciprocal_keys as core_reciprocal_keys  # noqa: E402
from core.rank.reciprocal import rescaled_rows  # noqa: E402

FIRST = (5, 10, 20)
EXPANSION = (1, 3)
SECOND_FIRST = (5, 10)
SECOND_EXPANSION = (3,)
LAMBDA = 0.3


def hub_term(rows: np.ndarray) -> np.ndarray:
    """Round 2's distance term: the hub discount's keys (``k`` 10, ``beta`` 1, the query
    left out), each row rescaled to [0, 1] over the other models, 0 for the query itself."""
    return rescaled_rows(hub_discounted(rows, 10, 1.0))


def reciprocal_keys(rows: np.ndarray, k1: int, k2: int, weight: float = LAMBDA,
                    term: np.ndarray | None = None) -> np.ndarray:
    """``(m, m)`` final distances (lower first) of k-reciprocal re-ranking of unit ``rows``
    (``core.rank.reciprocal.reciprocal_keys``, since the eleventh session: the loop this study
    first ran, moved there and vectorised, gives the same keys to the last bit on random
    vectors); ``term``: the blended distance term in place of the scaled squared distance.
    The re-rank as studied: without the first answer kept (``core.rank.reciprocal.first_kept``,
    since the thirteenth session the service's step 5), so that every study re-runs as it
    ran."""
    return core_reciprocal_keys(rows, term, k1, k2, weight, keep_first=False)


def candidate_grid(round_: int = 1) -> list[Candidate]:
    """Every candidate's name and keys ``(m, m)`` of unit rows, in tie order."""
    grid: list[Candidate] = [
        (REFERENCE, lambda rows: hub_discounted(rows, 10, 1.0)),
        (PLAIN, lambda rows: hub_discounted(rows, 0, 0.0)),
    ]
    first, expansion = (FIRST, EXPANSION) if round_ == 1 else (SECOND_FIRST, SECOND_EXPANSION)
    for k1 in first:
        for k2 in expansion:
            grid.append((f"k-reciprocal k1 {k1} k2 {k2}",
                         lambda rows, k1=k1, k2=k2: reciprocal_keys(rows, k1, k2)))
    if round_ == 2:
        for k1 in first:
            for k2 in expansion:
                grid.append((f"k-reciprocal k1 {k1} k2 {k2} + hub term",
                             lambda rows, k1=k1, k2=k2: reciprocal_keys(
                                 rows, k1, k2, term=hub_term(rows))))
    return grid


def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(__doc__, argv, rounds=(1, 2))
    run_search_study(args, study, cache, candidate_grid(args.round),
                     "k-reciprocal re-ranking, parts family", (PLAIN,))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
