"""Issue 24 follow-up: do positional or multi-scale local features generalise across sources?

Measurement only (nothing under ``core/``, ``app/`` or ``tests/`` changes). Reads the per-model
features of ``bench/selection/local_features_extract.py`` (the same ``OUT`` as
``bench/selection/local_features_select.py``, whose loading, bases and scoring it reuses) and asks
whether extra per-point columns, added to today's local features before the VLAD pooling,
help a source that the choice did not see.

Extra per-point columns (each invariant to rotation, translation, uniform scale and point
order; computed on the stored normalised sample ``points`` with its ``areas``):

- ``rad``: the point's distance from the area-weighted centroid over the area-weighted RMS
  distance (extrinsic: where on the part the point sits, rim or hub);
- ``ax``: ``|cos|`` between the point's local normal (the smallest principal direction of its
  30 nearest neighbours, sign-free) and the direction from the centroid to the point;
- ``sv4``: the square-rooted surface variation (``core.local_features.surface_variation``) at
  5, 10, 30 and 60 neighbours, in place of today's 10 and 30.

Feature sets (16 log HKS columns of the stored signature first):

- ``hks+sv`` (today's, 18 columns: HKS + sqrt sv at 10, 30);
- ``hks+sv+rad`` (19), ``hks+sv+rad+ax`` (20);
- ``hks+sv4`` (20), ``hks+sv4+rad+ax`` (22).

The grid, written down before any score of it was seen: each feature set x words {32, 64} x
encoding ``vlad`` x weight {0.5, 1, 2} next to a base's weighted blocks (joined as
``local_features_select`` joins them: the whole scaled to unit norm once), on two bases:
``ss4-noprop`` (the ``ss5`` base) and ``ss4``; each base alone is a candidate too. The base is
never re-chosen: every rule below runs within one base.

The rule (as ``local_features_select``'s):

1. A source's score is its mAP (leave-one-out within the source, PSB conventions). The
   vocabulary that encodes source ``s`` is fitted on every other source (``per_model=200``,
   ``seed=0``); capod-nonrigid (capod's Human, Hand, Dog, Horse, Spider) is scored apart and
   encoded as capod.
2. Choice: the highest mean over the six sources (bendable, capod, gearworks, generated,
   madcad, parts), each weighing the same; within 0.002 of the best, the narrower vector.
3. Leave-one-source-out (LOSO), per base: for each source ``s``, the candidate chosen on the
   other five (among the base alone and the base with every local block of the grid), scored
   on ``s``. Reported next to the base alone and the same LOSO restricted to today's feature
   set ``hks+sv`` (the base alone and the base with ``hks+sv`` blocks only), so the question is
   whether the new feature sets add anything over today's local block chosen the same way.
4. Checks: the base-fixed LOSO from the selector's own ``sel.json`` (docs/results.md: ``ss4``
   0.824, ``ss4-noprop`` 0.823), recomputed here with this script's rule; and this script's
   ``hks+sv`` candidates against the same candidates in ``sel.json``.

A second round, added after the first run's tables were seen (disclosed as such; it adds no
candidate and does not change the rule's figures above):

5. Per feature set: the same base-fixed LOSO with the pool restricted to the base alone and
   the base with that one feature set's blocks (which feature set would generalise if it were
   fixed in advance; picking the best of these afterwards is itself a choice on all sources).
6. Nested: for each source ``s``, the feature set with the best item-5 LOSO mean over the
   other five alone (each of them left out in turn, the choice made on the remaining four;
   within 0.002 of the best, the first in ``FEATURE_SETS`` order, today's first), then the
   candidate the rule picks within the base and that feature set on the five, scored on ``s``:
   item 5's per-feature-set figure with the feature set itself chosen without ``s``.
7. Noise: a paired bootstrap over queries (within each source, 2000 draws, seed 0; the helper
   of ``bench/selection/rerank_select.py``) of the LOSO mean's difference to the today-only LOSO.

Cost: per model, the milliseconds to compute ``rad``, ``ax``, ``sv4`` and today's sv (10, 30)
from the stored points (one thread; the extra cost of ``sv4`` is its time less today's);
medians over models. Per-model columns and encoded blocks are cached under
``OUT/positional_cache``.

    nice -n 10 .venv/bin/python bench/selection/positional_features_select.py /work/study \\
        --json /work/study/positional.json
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import sys
import time
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from local_features_select import (  # noqa: E402
    NEIGHBOURS,
    NON_RIGID_CAPOD,
    Source,
    joined,
    load_source,
    score,
    split_capod,
)
from rerank_select import _bootstrap  # noqa: E402

from core.evaluation.metrics import (  # noqa: E402
    average_precision,
    pairwise_distances,
    ranked_relevance,
)
from core.local_features import Vocabulary, encode_vlad, surface_variation  # noqa: E402

STUDY_BASES = ("ss4-noprop", "ss4")
FEATURE_SETS = ("hks+sv", "hks+sv+rad", "hks+sv+rad+ax", "hks+sv4", "hks+sv4+rad+ax")
TODAY = "hks+sv"
WORDS = (32, 64)
WEIGHTS = (0.5, 1.0, 2.0)
SV4_NEIGHBOURS = (5, 10, 30, 60)
NORMAL_NEIGHBOURS = 30
TIE = 0.002
#: The six tuning sources of the rule; capod-nonrigid is scored apart.
RULE_SOURCES = ("bendable", "capod", "gearworks", "generated", "madcad", "parts")
SS5 = "ss4-noprop+vlad-hks+sv-64w1"


def radial(points: np.ndarray, areas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance from the area-weighted centroid over the area-weighted RMS distance.

    Returns
    -------
    rad : (n,) float
    offsets : (n, 3) float
        Each point less the centroid (for ``axial``).
    """
    weights = areas / max(float(areas.sum()), 1e-300)
    offsets = points - weights @ points
    distance = np.linalg.norm(offsets, axis=1)
    rms = np.sqrt(max(float(weights @ distance**2), 1e-300))
    return distance / rms, offsets


def axial(points: np.ndarray, offsets: np.ndarray, neighbours: int = NORMAL_NEIGHBOURS
          ) -> np.ndarray:
    """``|cos|`` between each point's local normal and its direction from the centroid."""
    count = min(neighbours, len(points) - 1)
    _, index = cKDTree(points).query(points, k=count + 1)
    local = points[index]
    centred = local - local.mean(axis=1, keepdims=True)
    _, vectors = np.linalg.eigh(np.einsum("nki,nkj->nij", centred, centred))
    normals = vectors[:, :, 0]  # smallest principal direction, unit, sign-free below
    lengths = np.linalg.norm(offsets, axis=1)
    cosine = np.einsum("ni,ni->n", normals, offsets) / np.maximum(lengths, 1e-300)
    return np.where(lengths > 0, np.abs(cosine), 0.0)


def model_columns(points: np.ndarray, areas: np.ndarray) -> tuple[dict[str, np.ndarray],
                                                                 dict[str, float]]:
    """The extra columns of one model and the milliseconds each took."""
    times: dict[str, float] = {}
    start = time.perf_counter()
    rad, offsets = radial(points, areas)
    times["rad"] = time.perf_counter() - start
    start = time.perf_counter()
    ax = axial(points, offsets)
    times["ax"] = time.perf_counter() - start
    start = time.perf_counter()
    sv4 = np.sqrt(surface_variation(points, SV4_NEIGHBOURS))
    times["sv4"] = time.perf_counter() - start
    start = time.perf_counter()
    np.sqrt(surface_variation(points, NEIGHBOURS))  # today's, for the cost comparison
    times["sv"] = time.perf_counter() - start
    return {"rad": rad, "ax": ax, "sv4": sv4}, {k: 1000.0 * v for k, v in times.items()}


def add_feature_sets(source: Source, folder: Path, cache: Path) -> dict[str, list[float]]:
    """Put the new feature sets into ``source.local``; return per-model timings (ms)."""
    path = cache / f"columns-{source.name}-{len(source.labels)}.npz"
    files = sorted(folder.glob("*.npz"))
    if path.exists():
        with np.load(path) as stored:
            offsets = stored["offsets"]
            rad, ax, sv4 = stored["rad"], stored["ax"], stored["sv4"]
            times = {key: stored[f"time_{key}"].tolist() for key in ("rad", "ax", "sv4", "sv")}
    else:
        columns: dict[str, list[np.ndarray]] = {"rad": [], "ax": [], "sv4": []}
        times = {"rad": [], "ax": [], "sv4": [], "sv": []}
        for file in files:
            with np.load(file) as data:
                points = data["points"].astype(np.float64)
                areas = data["areas"].astype(np.float64)
            extra, took = model_columns(points, areas)
            for key, value in extra.items():
                columns[key].append(value)
            for key, value in took.items():
                times[key].append(value)
        offsets = np.cumsum([0] + [len(c) for c in columns["rad"]])
        rad, ax = np.concatenate(columns["rad"]), np.concatenate(columns["ax"])
        sv4 = np.vstack(columns["sv4"])
        np.savez(path, offsets=offsets, rad=rad, ax=ax, sv4=sv4,
                 **{f"time_{key}": np.array(value) for key, value in times.items()})
    assert len(offsets) == len(source.labels) + 1
    for name in FEATURE_SETS[1:]:
        source.local[name] = []
    for i, today in enumerate(source.local[TODAY]):
        lo, hi = offsets[i], offsets[i + 1]
        hks = today[:, :-len(NEIGHBOURS)]
        r, a = rad[lo:hi, None], ax[lo:hi, None]
        source.local["hks+sv+rad"].append(np.hstack([today, r]))
        source.local["hks+sv+rad+ax"].append(np.hstack([today, r, a]))
        source.local["hks+sv4"].append(np.hstack([hks, sv4[lo:hi]]))
        source.local["hks+sv4+rad+ax"].append(np.hstack([hks, sv4[lo:hi], r, a]))
    return times


def per_query_ap(vectors: np.ndarray, labels: list[str]) -> np.ndarray:
    """Each query's average precision, as ``score`` ranks (queries with a relevant result)."""
    distances = pairwise_distances(vectors, vectors)
    relevance = ranked_relevance(distances, labels, labels, np.eye(len(labels), dtype=bool))
    return np.array([average_precision(r) for r in relevance if r.any()])


def choose(table: dict[str, dict[str, dict[str, float]]], widths: dict[str, int],
           pool: list[str], over: list[str]) -> str:
    """The rule: the best mean mAP over ``over``; within ``TIE`` of it, the narrower."""
    means = {c: float(np.mean([table[c][s]["map"] for s in over])) for c in pool}
    best = max(means.values())
    close = [c for c in pool if means[c] >= best - TIE]
    return min(close, key=lambda c: (widths[c], -means[c]))


def loso(table: dict[str, dict[str, dict[str, float]]], widths: dict[str, int],
         pool: list[str], sources: tuple[str, ...] = RULE_SOURCES) -> dict[str, str]:
    """Per source of ``sources``: the candidate ``choose`` picks on the others."""
    return {s: choose(table, widths, pool, [o for o in sources if o != s]) for s in sources}


def nested_loso(table: dict[str, dict[str, dict[str, float]]], widths: dict[str, int],
                pools: dict[str, list[str]]) -> dict[str, tuple[str, str]]:
    """Per source: the feature set chosen by LOSO on the other five, then its candidate."""
    result = {}
    for s in RULE_SOURCES:
        rest = [o for o in RULE_SOURCES if o != s]
        inner = {features: float(np.mean([
            table[choose(table, widths, pool, [o for o in rest if o != u])][u]["map"]
            for u in rest])) for features, pool in pools.items()}
        best = max(inner.values())
        features = next(f for f in pools if inner[f] >= best - TIE)
        result[s] = (features, choose(table, widths, pools[features], rest))
    return result


def selector_check(selection: Path) -> dict[str, float]:
    """Base-fixed LOSO means recomputed from the selector's ``sel.json``."""
    data = json.loads(selection.read_text())
    table, widths = data["table"], data["widths"]
    result = {}
    for base in STUDY_BASES:
        pool = [base] + [c for c in table if c.startswith(base + "+")]
        choices = loso(table, widths, pool)
        result[base] = float(np.mean([table[c][s]["map"] for s, c in choices.items()]))
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--kind", default="clean")
    parser.add_argument("--json", type=Path)
    parser.add_argument("--selection", type=Path, help="the selector's JSON (default "
                        "OUT/sel.json) for the checks")
    args = parser.parse_args(argv)
    folder = args.out / "features" / args.kind
    cache = args.out / "positional_cache" / args.kind
    cache.mkdir(parents=True, exist_ok=True)
    folders = [path for path in sorted(folder.iterdir()) if path.is_dir()]
    sources = [load_source(path) for path in folders]
    times: dict[str, list[float]] = {}
    for source, path in zip(sources, folders, strict=True):
        for key, value in add_feature_sets(source, path, cache).items():
            times.setdefault(key, []).extend(value)
        print("columns done:", source.name, flush=True)
    fitting = {source.name: source for source in sources}
    scored = list(sources) + (split_capod(fitting["capod"]) if "capod" in fitting else [])
    names = [s.name for s in scored]
    print("sources:", {s.name: len(s.labels) for s in scored})

    blocks: dict[tuple[str, int], dict[str, np.ndarray]] = {}
    for features, words in itertools.product(FEATURE_SETS, WORDS):
        per_source = blocks.setdefault((features, words), {})
        for source in sources:
            others = [s for s in sources if s.name != source.name]
            key = f"{features}-{words}-{source.name}-" + "-".join(
                f"{s.name}{len(s.labels)}" for s in others)
            path = cache / f"vlad-{key}.npz"
            if path.exists():
                with np.load(path) as stored:
                    per_source[source.name] = stored["vlad"]
                continue
            vocabulary = Vocabulary.fit([r for s in others for r in s.local[features]],
                                        words, seed=0, per_model=200)
            per_source[source.name] = np.array([
                encode_vlad(f, a, vocabulary)
                for f, a in zip(source.local[features], source.areas, strict=True)])
            np.savez(path, vlad=per_source[source.name])
        if "capod" in per_source:
            keep = [i for i, label in enumerate(fitting["capod"].labels)
                    if label in NON_RIGID_CAPOD]
            per_source["capod-nonrigid"] = per_source["capod"][keep]
        print("vocabularies done:", features, words, flush=True)

    candidates: dict[str, dict[str, object]] = {}
    for base in STUDY_BASES:
        candidates[base] = {"base": base, "local": None, "weight": 0.0}
        for (features, words), weight in itertools.product(blocks, WEIGHTS):
            candidates[f"{base}+vlad-{features}-{words}w{weight:g}"] = {
                "base": base, "local": (features, words), "weight": weight}
    table: dict[str, dict[str, dict[str, float]]] = {}
    widths: dict[str, int] = {}
    queries: dict[str, dict[str, np.ndarray]] = {}
    for name, spec in candidates.items():
        table[name] = {}
        for source in scored:
            block = (None if spec["local"] is None
                     else blocks[spec["local"]][source.name])  # type: ignore[index]
            vectors = joined(source.bases[str(spec["base"])], block, float(spec["weight"]))
            widths[name] = int(vectors.shape[1])
            table[name][source.name] = score(vectors, source.labels)
            queries.setdefault(name, {})[source.name] = per_query_ap(vectors, source.labels)
    mean = {c: float(np.mean([table[c][s]["map"] for s in RULE_SOURCES])) for c in table}

    def row(c: str) -> str:
        cells = [f"{table[c][s]['map']:.3f} / {table[c][s]['nn']:.3f}" for s in names]
        return f"| {c} | {widths[c]} | {mean[c]:.4f} | " + " | ".join(cells) + " |"

    header = ["candidate", "width", "mean mAP", *names]
    print("\n| " + " | ".join(header) + " |\n|" + "---|" * len(header))
    new = [c for c in table if candidates[c]["local"] is not None
           and candidates[c]["local"][0] != TODAY]  # type: ignore[index]
    best_new = sorted(new, key=lambda c: -mean[c])[:5]
    for c in [*STUDY_BASES, SS5, *best_new]:
        print(row(c))

    report: dict[str, object] = {}
    for base in STUDY_BASES:
        pool_all = [c for c in table if candidates[c]["base"] == base]
        pool_today = [c for c in pool_all if candidates[c]["local"] is None
                      or candidates[c]["local"][0] == TODAY]  # type: ignore[index]
        chosen_all = choose(table, widths, pool_all, list(RULE_SOURCES))
        chosen_today = choose(table, widths, pool_today, list(RULE_SOURCES))
        by_all, by_today = loso(table, widths, pool_all), loso(table, widths, pool_today)
        score_all = {s: table[c][s]["map"] for s, c in by_all.items()}
        score_today = {s: table[c][s]["map"] for s, c in by_today.items()}
        means = {"new allowed": float(np.mean(list(score_all.values()))),
                 "today only": float(np.mean(list(score_today.values()))),
                 "base alone": mean[base]}
        print(f"\nbase {base}: rule's choice over the six, new allowed: {chosen_all} "
              f"(mean {mean[chosen_all]:.4f}, width {widths[chosen_all]}); today only: "
              f"{chosen_today} (mean {mean[chosen_today]:.4f}, width {widths[chosen_today]})")
        print("| source left out | choice without it (new allowed) | mAP / NN | "
              "choice without it (today only) | mAP / NN | base alone |")
        print("|---|---|---|---|---|---|")
        for s in RULE_SOURCES:
            a, t = by_all[s], by_today[s]
            print(f"| {s} | {a} | {table[a][s]['map']:.3f} / {table[a][s]['nn']:.3f} | {t} | "
                  f"{table[t][s]['map']:.3f} / {table[t][s]['nn']:.3f} | "
                  f"{table[base][s]['map']:.3f} / {table[base][s]['nn']:.3f} |")
        print(f"| **mean** | | **{means['new allowed']:.4f}** | | **{means['today only']:.4f}**"
              f" | {means['base alone']:.4f} |")
        today_queries = {s: queries[c][s] for s, c in by_today.items()}
        point, low, high = _bootstrap({s: queries[c][s] for s, c in by_all.items()},
                                      today_queries, list(RULE_SOURCES))
        print(f"LOSO new allowed - today only: {point:+.4f} (95% bootstrap over queries "
              f"{low:+.4f} .. {high:+.4f})")
        print("second round (after the fact): LOSO with the pool fixed to one feature set")
        per_set = {}
        for features in FEATURE_SETS:
            pool = [base] + [c for c in pool_all if candidates[c]["local"] is not None
                             and candidates[c]["local"][0] == features]  # type: ignore[index]
            by_set = loso(table, widths, pool)
            point, low, high = _bootstrap({s: queries[c][s] for s, c in by_set.items()},
                                          today_queries, list(RULE_SOURCES))
            per_set[features] = {"loso": by_set, "mean": float(np.mean(
                [table[c][s]["map"] for s, c in by_set.items()])),
                "minus_today": [point, low, high]}
            print(f"  {features}: LOSO mean {per_set[features]['mean']:.4f}, - today only "
                  f"{point:+.4f} ({low:+.4f} .. {high:+.4f}); " + ", ".join(
                      f"{s} {table[c][s]['map']:.3f} ({c.split('vlad-')[-1]})"
                      for s, c in by_set.items()))
        nested = nested_loso(table, widths, {f: [base] + [
            c for c in pool_all if candidates[c]["local"] is not None
            and candidates[c]["local"][0] == f] for f in FEATURE_SETS})  # type: ignore[index]
        point, low, high = _bootstrap({s: queries[c][s] for s, (_, c) in nested.items()},
                                      today_queries, list(RULE_SOURCES))
        nested_mean = float(np.mean([table[c][s]["map"] for s, (_, c) in nested.items()]))
        print(f"  nested (feature set chosen without s): LOSO mean {nested_mean:.4f}, - today "
              f"only {point:+.4f} ({low:+.4f} .. {high:+.4f}); " + ", ".join(
                  f"{s} {table[c][s]['map']:.3f} ({c.split('vlad-')[-1]})"
                  for s, (_, c) in nested.items()))
        per_set["nested"] = {"loso": nested, "mean": nested_mean,
                             "minus_today": [point, low, high]}
        report[base] = {"chosen": chosen_all, "chosen_today": chosen_today,
                        "loso": by_all, "loso_today": by_today, "means": means,
                        "per_feature_set": per_set}

    cost = {key: float(np.median(value)) for key, value in times.items()}
    extra = [r + a + s4 - s for r, a, s4, s in
             zip(times["rad"], times["ax"], times["sv4"], times["sv"], strict=True)]
    cost["extra rad+ax+sv4 less today's sv"] = float(np.median(extra))
    print("\nper-model cost, median ms over", len(times["rad"]), "models:",
          {k: round(v, 2) for k, v in cost.items()})

    selection = args.selection or args.out / "sel.json"
    checks: dict[str, object] = {}
    if selection.exists():
        checks["selector base-fixed LOSO"] = selector_check(selection)
        stored = json.loads(selection.read_text())["table"]
        differences = [abs(table[c][s]["map"] - stored[c][s]["map"])
                       for c in table if c in stored for s in names]
        checks["max |mAP - sel.json| over shared candidates"] = max(differences, default=None)
        checks["shared candidates"] = sum(c in stored for c in table)
        print("checks:", checks)
    if args.json:
        args.json.write_text(json.dumps({
            "table": table, "mean": mean, "widths": widths, "per_base": report,
            "cost_ms": cost, "checks": checks, "best_new": best_new,
        }, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
