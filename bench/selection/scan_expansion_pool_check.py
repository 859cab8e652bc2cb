"""Does the search service's pool change scan mode's expansion? (a check, chooses nothing)

``scan_expansion_select.py`` scored its candidates with the pool taken as the 40 models of
least scan-mode key over the whole catalogue. The service takes the ``rerank_depth(k)``
models nearest by plain best entry (``app.search.similarity._best_entries``), places the
one of least key first and orders the rest of that pool by ``expansion_keys``. This emulates
the service's order from each source's saved descriptors (pool 40, 80 and 160 by plain
distance; beyond the pool, by key as in the study) and prints its mAP beside the study's
(``core.hubness.scan_ranking`` at depth 40), with the share of queries whose first 10 are
the same. ``scan_hubs_service_check.py`` checks the service itself against the emulation
(first 10 identical at ``k`` 10: BOSL2 0.958, MCAD 0.852, bd-vslot 0.979, pymadcad 0.925,
py-gearworks 0.971, as the emulation at pool 40 says).

    .venv/bin/python bench/selection/scan_expansion_pool_check.py /work/scanrev

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
from core.hubness import expansion_keys, scan_hub_keys, scan_ranking  # noqa: E402

SOURCES = ("madcad", "gearworks", "vslot", "mcad", "generated", "bendable", "capod", "bosl2")
STUDY_DEPTH = 40
DEPTHS = (40, 80, 160)


def service_positions(keys: np.ndarray, plain: np.ndarray, whole: np.ndarray,
                      depth: int) -> np.ndarray:
    """The service's order for one query: pool by ``plain`` distance, first by key, the
    rest of the pool by ``expansion_keys``, the others by key (``inf`` stays last)."""
    pool = np.argsort(plain, kind="stable")[:depth]
    pool = pool[np.argsort(keys[pool], kind="stable")]
    rest = pool[1:]
    spread = np.sum((whole[rest] - whole[pool[0]]) ** 2, axis=1)
    rest = rest[np.argsort(expansion_keys(keys[rest], spread), kind="stable")]
    inside = set(pool.tolist())
    beyond = [i for i in np.argsort(keys, kind="stable") if i not in inside]
    order = np.concatenate([pool[:1], rest, beyond]).astype(int)
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
    whole = catalogue.entries[~catalogue.is_view]
    plain = best_entry_distances(queries, catalogue.entries, catalogue.owners, models)
    exclude = own[:, None] == np.arange(models)[None, :]
    labels = [catalogue.labels[m] for m in own]
    for rows in (keys, plain):
        rows[np.arange(len(own)), own] = np.inf
    study = np.array([scan_ranking(row, whole, STUDY_DEPTH) for row in keys])
    result = {"study": score_rankings(ranked_relevance(study, labels, catalogue.labels,
                                                       exclude))["map"]}
    for depth in DEPTHS:
        service = np.array([service_positions(k, p, whole, depth)
                            for k, p in zip(keys, plain, strict=True)])
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
