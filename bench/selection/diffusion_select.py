"""Issue 24 follow-up: does diffusion on the catalogue's neighbour graph carry over better than
the shipped k-reciprocal re-rank?

Measurement only (the search service does not change in this step). Why: the two search-time
orders that shipped (the hub discount, then k-reciprocal re-ranking) are the only changes that
lifted every source, because they use the catalogue's structure rather than a view of one
part. Scored by kind, the four third-party libraries as one catalogue lose most mAP where a
kind spans several libraries' styles (screws 0.55-0.67, ball bearings 0.53;
``catalogue_by_kind.py``): the rest of the kind is reachable from the query only through
chains of neighbours. Diffusion (Zhou et al., NIPS 2004; Iscen et al., CVPR 2017) ranks by
how much of the query's affinity reaches each part along the graph, which is meant to follow
such chains, and is a standard mAP gain over k-reciprocal re-ranking in instance retrieval.

The method, on ``ss9``'s unit rows (every model of a source a query, the source its
catalogue, the query's own node in the graph as for a search by id):

1. ``A[i, j] = max(cos(i, j), 0) ** 3`` for ``j`` among the ``k`` nearest others of ``i``
   (0 elsewhere, no self-loops); ``W = (A + A^T) / 2``; ``S = D^-1/2 W D^-1/2`` with ``D``
   the row sums (a node without edges keeps a zero row);
2. for query ``q`` the seed ``y = A[q]`` (its ``k`` nearest, weighted), the scores
   ``f = (I - alpha S)^-1 y``;
3. rank by ``f``, largest first; the parts ``f`` does not reach (0: another component of the
   graph) after them by plain cosine; a candidate within ``SAME_DESCRIPTOR`` of the query
   first, as in the service.

Grid, rule and ship test written before any score of them was seen: ``k`` in {5, 10} x
``alpha`` in {0.8, 0.95}: 4 candidates. The reference and tie target is the search service's
order since the eleventh session (k-reciprocal ``k1`` 5, ``k2`` 3, ``lambda`` 0.3, the hub
discount's keys as its blended term), the pool those five; plain ``ss9`` reported beside.
The rule: mAP per source, mean over the eight sources (``/work/study8``: the seven and MCAD;
capod-nonrigid scored apart), ties within 0.002 to the reference first, then the grid's
order; leave-one-source-out with a paired bootstrap over queries against the reference. It
ships only if all three hold: (1) the leave-one-source-out mean is above the reference's by
more than 0.002 with the 95 % interval above zero; (2) the ``bendable`` family's mean over
(bendable, capod-nonrigid) is not below the reference's by more than 0.002; (3) the four
third-party libraries as one catalogue scored by kind (``catalogue_by_kind.py``): its mAP not
below the reference's and its NN not below by more than 0.01.

    nice -n 10 .venv/bin/python bench/selection/diffusion_select.py /work/study8 \\
        --json /work/study8/diffusion.json

**Result** (2026-11-27, twelfth session; docs/results.md, "Diffusion"): declined. Every
candidate's mean is below the reference's (0.8683; ``k`` 5, ``alpha`` 0.8: 0.8535; ``k`` 10,
``alpha`` 0.95: 0.7643), the rule keeps the reference without every source (+0.0000 left
out). Diffusion helps only capod (0.985 -> 0.990) and the non-rigid shapes; it costs
py-gearworks (0.591 -> 0.560), our generator, pymadcad, MCAD (0.726 -> 0.690) and bd-vslot:
with kinds of 8 to 10 members, the walk leaves the kind through look-alike kinds sooner
than it reaches the rest of its own.
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from catalogue_by_kind import KIND_OF, scores  # noqa: E402
from hubness_select import family_check, family_rows, pooled_rows  # noqa: E402
from mcad_check import CANDIDATE, CATALOGUE, KEYS  # noqa: E402
from profile_block_select import decide, score_distances, study_command  # noqa: E402

from core.rank.hubness import SAME_DESCRIPTOR  # noqa: E402

PLAIN = "ss9"
NEIGHBOURS = (5, 10)
ALPHAS = (0.8, 0.95)
GAMMA = 3
NN_SLACK = 0.01


def diffusion_keys(rows: np.ndarray, neighbours: int, alpha: float) -> np.ndarray:
    """``(m, m)`` keys (lower first) of diffusion over the ``neighbours``-nearest graph of
    unit ``rows`` ``(m, d)``; row ``q`` ranks every model for query ``q``."""
    m = len(rows)
    cosines = rows @ rows.T
    others = np.where(np.eye(m, dtype=bool), -np.inf, cosines)
    nearest = np.argsort(-others, axis=1, kind="stable")[:, :neighbours]
    affinity = np.zeros((m, m))
    ranks = np.arange(m)[:, None]
    affinity[ranks, nearest] = np.maximum(cosines[ranks, nearest], 0.0) ** GAMMA
    graph = 0.5 * (affinity + affinity.T)
    degree = graph.sum(axis=1)
    scale = np.where(degree > 0, 1.0 / np.sqrt(np.where(degree > 0, degree, 1.0)), 0.0)
    normalised = scale[:, None] * graph * scale[None, :]
    # f_q = (I - alpha S)^-1 A[q] for every q at once: the solve's columns are the seeds.
    reached = np.linalg.solve(np.eye(m) - alpha * normalised, affinity.T).T
    top = np.maximum(reached.max(axis=1, keepdims=True), 1e-300)
    share = reached / top
    # Reached parts in [-3, -2] by their share of the query's best, the rest by -cos.
    keys = np.where(share > 1e-12, -2.0 - share, -cosines)
    distances = 2.0 - 2.0 * cosines
    return np.where(distances <= SAME_DESCRIPTOR, -np.inf, keys)


def candidate_grid() -> list[tuple[str, Callable[[np.ndarray], np.ndarray]]]:
    """The reference first, then the grid, in tie order; plain ``ss9`` last (reported)."""
    grid: list[tuple[str, Callable[[np.ndarray], np.ndarray]]] = [(CANDIDATE, KEYS[CANDIDATE])]
    for neighbours in NEIGHBOURS:
        for alpha in ALPHAS:
            grid.append((f"diffusion k{neighbours} alpha{alpha:g}",
                         lambda rows, k=neighbours, a=alpha: diffusion_keys(rows, k, a)))
    grid.append((PLAIN, KEYS[PLAIN]))
    return grid


def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(__doc__, argv)
    scored = study.scored
    grid = candidate_grid()
    parts_rows, bendable_rows = family_rows(study, cache)
    order = {name: rank for rank, (name, _) in enumerate(grid)}
    pool = [name for name, _ in grid if name != PLAIN]

    def candidates(rows: dict[str, np.ndarray]) -> Iterator[tuple[str, dict[str, np.ndarray]]]:
        for name, keys in grid:
            yield name, {s.name: keys(rows[s.name]) for s in scored}

    table, queries = score_distances(candidates(parts_rows), scored)
    report = decide(table, queries, order, "diffusion, parts family",
                    tuple(s.name for s in study.sources), CANDIDATE, args.json,
                    tie_key="tie order", widths=order, pool=pool)
    chosen = str(report["chosen"])
    bendable_table, _ = score_distances(candidates(bendable_rows), scored)
    family_mean, second = family_check(bendable_table, report, CANDIDATE)
    rows, library_kinds = pooled_rows(study, CATALOGUE)
    kinds = [KIND_OF.get(label, label) for label in library_kinds]
    catalogue = {name: scores(keys(rows), kinds) for name, keys in grid
                 if name in (CANDIDATE, chosen, PLAIN)}
    for name, result in catalogue.items():
        print(f"one catalogue by kind ({len(kinds)} parts), {name}: NN {result['nn']:.3f}, "
              f"mAP {result['map']:.3f}, top-5 {result['top5']:.3f}")
    third = (catalogue[chosen]["map"] >= catalogue[CANDIDATE]["map"]
             and catalogue[chosen]["nn"] >= catalogue[CANDIDATE]["nn"] - NN_SLACK)
    ships = second and third
    print(f"ships (parts test, family check, catalogue by kind): {ships}")
    if args.json:
        data = json.loads(args.json.read_text())
        args.json.write_text(json.dumps({**data, "bendable_table": bendable_table,
                                         "bendable_mean": family_mean,
                                         "catalogue_by_kind": catalogue, "ships": ships},
                                        indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
