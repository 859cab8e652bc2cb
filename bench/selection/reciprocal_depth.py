"""How many nearest candidates the search service must re-rank k-reciprocally.

The service cannot take every model's neighbourhood over the whole catalogue per query: it
re-orders the plain nearest ``factor * k`` candidates that pass a query's filters, and
``core.rank.reciprocal.pool_keys`` takes each neighbourhood among the query and those candidates
alone (the hub discount's keys of the candidates, from the index's kept radii, as its
blended term). This measures how often that agrees with ``core.rank.reciprocal.reciprocal_keys``
over the whole catalogue, per ``factor`` in {4, 8, 16}, for ``k`` 10, each query leave-one-
out, on the four third-party part sources as one catalogue (``mcad_check.py``'s: pymadcad,
py-gearworks, bd-vslot and MCAD, 326 parts, one vocabulary fitted on the other sources).

The rule, written before the run (like the hub discount's ``HUB_RERANK_FACTOR``): the
smallest factor whose first 10 equal the whole catalogue's for at least 95 % of the
queries; failing that, the smallest whose NN and precision at 10 are both within 0.005 of
the whole catalogue's order. For each factor it prints that share, NN and precision at 10,
beside the hub discount's own (``factor`` 4, the service before this).

    nice -n 10 .venv/bin/python bench/selection/reciprocal_depth.py /work/study8

**Result** (2026-11-27, eleventh session; docs/results.md, "An eighth source"): first 10 as
the whole catalogue's for 47.2 % (factor 4), 61.0 % (8), 74.8 % (16) of the queries;
precision at 10 0.5546, 0.5595, 0.5632 against 0.5687 (the hub discount alone: 0.5387); NN
0.8528, 0.8497, 0.8497 against 0.8497. No factor met the rule's words, and ``choose`` then
returns the largest factor, a fallback its docstring did not state (disclosed). The service
re-ranks the hub discount's own 4 per result, at least 40 (``core.rank.reciprocal.RECIPROCAL_POOL``),
chosen for cost afterwards: 16 per result cost 3.2x the discount's time per query at 10^5
models (``bench/search_scale.py --reciprocal-pools 40 80 160``), 4 per result 1.4-1.6x.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from hubness_select import hub_discounted, pooled_rows  # noqa: E402
from local_features_select import load_study  # noqa: E402
from mcad_check import CATALOGUE  # noqa: E402

from core.rank.hubness import HUB_NEIGHBOURS, hub_keys, neighbourhood_radii  # noqa: E402
from core.rank.reciprocal import pool_keys, reciprocal_keys, rescaled_rows  # noqa: E402

FACTORS = (4, 8, 16)
RESULTS = 10
AGREEMENT = 0.95
SLACK = 0.005


def first(keys: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """The first ``RESULTS`` of ``ids`` by ``keys``, ties to the lower id."""
    return ids[np.lexsort((ids, keys))][:RESULTS]


def measure(rows: np.ndarray, labels: list[str]) -> dict[str, dict[str, float]]:
    """Per factor (and the whole catalogue, and the hub discount at factor 4): the share
    of queries whose first ``RESULTS`` equal the whole catalogue's, NN and precision."""
    m = len(rows)
    kinds = np.array(labels)
    exclude = np.eye(m, dtype=bool)
    whole = reciprocal_keys(rows, rescaled_rows(hub_discounted(rows, HUB_NEIGHBOURS, 1.0)))
    radii = neighbourhood_radii(rows, HUB_NEIGHBOURS, exclude)
    squared = np.maximum(2.0 - 2.0 * rows @ rows.T, 0.0)
    lists: dict[str, list[np.ndarray]] = {"whole catalogue": [], "hub discount, 4": []}
    for factor in FACTORS:
        lists[f"factor {factor}"] = []
    for query in range(m):
        others = np.flatnonzero(~exclude[query])
        lists["whole catalogue"].append(first(whole[query, others], others))
        plain = others[np.lexsort((others, squared[query, others]))]
        hub = hub_keys(squared[query], radii[query])
        lists["hub discount, 4"].append(first(hub[plain[: 4 * RESULTS]], plain[: 4 * RESULTS]))
        for factor in FACTORS:
            pool = plain[: factor * RESULTS]
            keys = pool_keys(rows[query], rows[pool], hub[pool])
            lists[f"factor {factor}"].append(first(keys, pool))
    report = {}
    for name, found in lists.items():
        same = np.mean([a.tolist() == b.tolist()
                        for a, b in zip(found, lists["whole catalogue"], strict=True)])
        nn = np.mean([kinds[f[0]] == kinds[q] for q, f in enumerate(found)])
        precision = np.mean([(kinds[f] == kinds[q]).mean() for q, f in enumerate(found)])
        report[name] = {"same": float(same), "nn": float(nn), "precision": float(precision)}
        print(f"| {name} | {100 * same:.1f} % | {nn:.4f} | {precision:.4f} |")
    return report


def choose(report: dict[str, dict[str, float]]) -> int:
    """The rule (module docstring)."""
    for factor in FACTORS:
        if report[f"factor {factor}"]["same"] >= AGREEMENT:
            return factor
    whole = report["whole catalogue"]
    for factor in FACTORS:
        row = report[f"factor {factor}"]
        if abs(row["nn"] - whole["nn"]) <= SLACK and abs(row["precision"]
                                                         - whole["precision"]) <= SLACK:
            return factor
    return FACTORS[-1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    args = parser.parse_args(argv)
    study = load_study(args.out / "features" / "clean")
    rows, labels = pooled_rows(study, CATALOGUE)
    print(f"{len(labels)} parts, {len(set(labels))} kinds, k {RESULTS}")
    print("| order | first 10 as the whole catalogue's | NN | precision at 10 |\n|---|---|---|---|")
    print("rule's factor:", choose(measure(rows, labels)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
