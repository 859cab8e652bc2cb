"""Does the search service's pool change scan mode's order? (a check, chooses nothing)

``scan_expansion_select.py`` scored its candidates with the pool taken as the 40 models of
least scan-mode key over the whole catalogue. The service takes the ``rerank_depth(k)``
models nearest by plain best entry (``app.search.similarity._scan.scan_matches``), places the
one of least key first and orders the rest of that pool by ``expansion_keys``. This emulates
the service's order from each source's saved descriptors (pool 40, 80 and 160 by plain
distance; beyond the pool, by key as in the study) and prints its mAP beside the study's
(``core.rank.hubness.scan_ranking`` at depth 40), with the share of queries whose first 10 are
the same. ``scan_hubs_service_check.py`` checks the service itself against the emulation
(first 10 identical at ``k`` 10: BOSL2 0.958, MCAD 0.852, bd-vslot 0.979, pymadcad 0.925,
py-gearworks 0.971, as the emulation at pool 40 says).

    .venv/bin/python bench/selection/scan_expansion_pool_check.py /work/scanrev

Since the thirty-eighth session scan mode orders the rest of its pool as a shape query for
the first answer (``core.rank.scan_order``, ``scan_expansion_select.py --round 2``): the
emulation and the study's order are that one; the sixteenth session's result below is of
the expansion it replaced.

**Result** (2026-11-27, sixteenth session): at pool 40 the service's order scores the
study's mAP within 0.003 on all eight sources; its first 10 are the study's for 0.85 (MCAD)
to 1.00 of the queries (the pools differ at their edge: plain distance against key), and a
deeper pool neither brings them closer (MCAD 0.84 at 80) nor costs mAP (equal or up to
+0.015): the depth stays ``4 k``.
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
from scan_hubs_select import Catalogue, load_catalogue  # noqa: E402

from core.evaluation.metrics import ranked_relevance, score_rankings  # noqa: E402
from core.evaluation.scan_retrieval import best_entry_distances  # noqa: E402
from core.rank.hubness import HUB_NEIGHBOURS, neighbourhood_radii, scan_hub_keys  # noqa: E402
from core.rank.scan_order import scan_ranking  # noqa: E402

SOURCES = ("madcad", "gearworks", "vslot", "mcad", "generated", "bendable", "capod", "bosl2")
STUDY_DEPTH = 40
DEPTHS = (40, 80, 160)


def service_positions(keys: np.ndarray, plain: np.ndarray, whole: np.ndarray,
                      radii: np.ndarray, depth: int) -> np.ndarray:
    """The service's order for one query: pool by ``plain`` distance, in it the first by
    key and the rest in the first answer's shape-mode order (``scan_ranking`` of the pool
    alone), the others by key (``inf`` stays last)."""
    pool = np.argsort(plain, kind="stable")[:depth]
    pool_keys = np.full(len(keys), np.inf)
    pool_keys[pool] = keys[pool]
    inside = scan_ranking(pool_keys, whole, depth, radii)
    ordered = [int(i) for i in np.argsort(inside, kind="stable") if np.isfinite(inside[i])]
    placed = set(ordered)
    beyond = [i for i in np.argsort(keys, kind="stable") if i not in placed]
    order = np.concatenate([ordered, beyond]).astype(int)
    positions = np.empty(len(keys))
    positions[order] = np.arange(len(keys), dtype=float)
    positions[~np.isfinite(keys)] = np.inf
    return positions


def check(catalogue: Catalogue) -> dict[str, float]:
    """The study's mAP and, per pool depth, the service's mAP and first-10 agreement."""
    queries = catalogue.queries["single+sor"]
    own = catalogue.query_models["single+sor"]
    models = len(catalogue.models)
    keys = scan_hub_keys(queries, catalogue.entries, catalogue.owners, own)
    whole = catalogue.entries[~catalogue.is_view].astype(np.float64)
    radii = neighbourhood_radii(whole, HUB_NEIGHBOURS, exclude=own[:, None] == np.arange(
        models)[None])
    plain = best_entry_distances(queries, catalogue.entries, catalogue.owners, models)
    exclude = own[:, None] == np.arange(models)[None, :]
    labels = [catalogue.labels[m] for m in own]
    for rows in (keys, plain):
        rows[np.arange(len(own)), own] = np.inf
    study = np.array([scan_ranking(row, whole, STUDY_DEPTH, r)
                      for row, r in zip(keys, radii, strict=True)])
    result = {"study": score_rankings(ranked_relevance(study, labels, catalogue.labels,
                                                       exclude))["map"]}
    for depth in DEPTHS:
        service = np.array([service_positions(k, p, whole, r, depth)
                            for k, p, r in zip(keys, plain, radii, strict=True)])
        result[f"service {depth}"] = score_rankings(
            ranked_relevance(service, labels, catalogue.labels, exclude))["map"]
        result[f"first10 {depth}"] = float(np.mean([
            np.array_equal(np.argsort(a, kind="stable")[:10], np.argsort(b, kind="stable")[:10])
            for a, b in zip(study, service, strict=True)]))
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="folder of scan_retrieval outputs per source")
    args = parser.parse_args(argv)
    print("| source | study mAP | " + " | ".join(
        f"service pool {d}: mAP, first 10 same" for d in DEPTHS) + " |")
    print("|---|---|" + "---|" * len(DEPTHS))
    for source in SOURCES:
        result = check(load_catalogue(args.out / source, "default", kinds=("single+sor",)))
        cells = [f"{result[f'service {d}']:.3f}, {result[f'first10 {d}']:.2f}" for d in DEPTHS]
        print(f"| {source} | {result['study']:.3f} | " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
