"""Issue 24 follow-up: does a finer re-rank of the top candidates generalise across sources?

Measurement only (nothing under ``core/`` or ``app/`` changes). Reads the per-model features
of ``bench/selection/local_features_extract.py`` (the same ``OUT`` as
``bench/selection/local_features_select.py``) and scores a two-stage retrieval on every source,
leave-one-out within the source (PSB conventions, ``core.evaluation.metrics``).

First stage: the default ``ss5`` vectors (base ``ss4-noprop`` blocks joined with the VLAD of
per-point ``hks+sv`` features over 64 words at weight 1, unit rows), the vocabulary that
encodes source ``s`` fitted on every other source (as ``local_features_select`` scores it);
distances are Euclidean.

Second stage, per query: the top ``K`` models by first-stage distance are re-ordered by::

    d1 + w * d_fine / norm

and every model outside the top ``K`` keeps its first-stage order after them. ``norm`` is the
median ``d_fine`` over the within-source pairs of every *other* source (capod-nonrigid counts
as capod), so no source is normalised by itself. (Those other sources' ``d_fine`` use their own
standardisation, which was fitted with ``s`` among its sources: one scalar of ``s`` enters the
normaliser through four fifths of a mean; the per-source figures accept that.)

``d_fine`` (all invariant to rotation, translation, scale and point order; deterministic):

- ``chamfer-hks+sv``: symmetric Chamfer distance between the two models' local feature sets
  (16 log HKS + sqrt surface variation at 10/30 neighbours, 18 columns, standardised by the
  mean / scale of the vocabulary that encodes the source), each subsampled to ``POINTS``
  points (uniform without replacement, seeded by the model's label and name), area weighted:
  ``(sum_a w_a min_b |f_a - f_b| + sum_b w_b min_a |f_b - f_a|) / 2`` (exact nearest
  neighbours, by brute force in float32);
- ``sw1-hks+sv``: sliced Wasserstein-1 between the same area-weighted feature distributions:
  ``DIRECTIONS`` fixed random unit directions (seed 0), each distribution's quantile function
  at ``LEVELS`` mid-point levels, mean absolute quantile difference averaged over directions;
- ``chamfer-sig``, ``sw1-sig``: the same on the 32-column signature (16 log HKS, 16 log WKS),
  standardised by the mean / scale of the same kind of draw from the other sources.

The grid and the rule, written down before any re-rank score was seen:

- ``K`` in {5, 10, 20}; ``w`` in {0.25, 0.5, 1, 2, 4, inf} (``inf``: the top ``K`` ordered by
  ``d_fine`` alone, ties by ``d1``); plus ``none`` (``w = 0``: the first stage alone, ``ss5``).
- Score of a source: its mAP. The default is the candidate with the highest mean over the six
  tuning sources, each weighing the same; candidates within 0.002 of the best go to the
  cheapest: no re-rank, then the smaller ``K``, then ``sw1`` before ``chamfer``, ``hks+sv``
  before ``sig``, then the higher mean.
- Generalisation (leave-one-source-out, LOSO): for each source ``s``, the candidate the rule
  picks from the other five alone, scored on ``s``; their mean against ``ss5`` and ``ss4``.
- Full-pipeline LOSO (the first stage ``ss5`` itself was chosen with every source): the first
  stage for source ``s`` is the candidate ``local_features_select`` chose without ``s``
  (``--selection SEL.json``), the re-rank chosen on the other five with that first stage, scored
  on ``s``; compared with the selector's own LOSO (0.810 in docs/results.md).
- Noise: a paired bootstrap over queries (within each source, 2000 draws, seed 0) of the LOSO
  mean's difference to ``ss5`` and ``ss4``; and the spread of the best candidates' means.

Cost: median milliseconds per query to compute ``d_fine`` for ``K`` candidates from stored
subsamples (one thread), and the bytes per model to store them (``POINTS`` x columns float16,
plus the areas).

    .venv/bin/python bench/selection/rerank_select.py /work/study \\
        --selection /work/study/sel.json --json /work/study/rerank.json
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import re
import sys
import time
import zlib
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from local_features_select import (  # noqa: E402
    NON_RIGID_CAPOD,
    Source,
    _unit_rows,
    joined,
    load_source,
    split_capod,
)

from core.evaluation.metrics import (  # noqa: E402
    average_precision,
    pairwise_distances,
    score_rankings,
)
from core.local_features import Vocabulary, encode_bof, encode_vlad  # noqa: E402

POINTS = 512
DIRECTIONS = 64
LEVELS = 128
KS = (5, 10, 20)
WS = (0.25, 0.5, 1.0, 2.0, 4.0, float("inf"))
FINES = ("sw1-hks+sv", "chamfer-hks+sv", "sw1-sig", "chamfer-sig")
#: The six tuning sources of the rule; capod-nonrigid is scored apart.
RULE_SOURCES = ("bendable", "capod", "gearworks", "generated", "madcad", "parts")
FIRST_BASE, FIRST_FEATURES, FIRST_WORDS, FIRST_WEIGHT = "ss4-noprop", "hks+sv", 64, 1.0
_CANDIDATE = re.compile(
    r"^(?P<base>.+)\+(?P<encoding>bof|vlad)-(?P<features>sig\+sv|hks\+sv|sig|hks)"
    r"-(?P<words>\d+)w(?P<weight>[0-9.]+)$"
)


def _fitting_key(source: str) -> str:
    """The source whose vocabulary / standardisation / normaliser a source uses."""
    return "capod" if source == "capod-nonrigid" else source


def _standardiser(rows: list[np.ndarray], seed: int = 0, per_model: int = 200
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Mean and scale of the same draw as ``Vocabulary.fit`` (without the k-means)."""
    rng = np.random.default_rng(seed)
    sample = np.vstack([r[rng.choice(len(r), min(per_model, len(r)), replace=False)]
                        for r in rows])
    return sample.mean(axis=0), np.maximum(sample.std(axis=0), 1e-9)


def _subsample(source: Source, index: int) -> np.ndarray:
    """Deterministic point subset of one model (seeded by its label and name)."""
    count = len(source.areas[index])
    seed = zlib.crc32(f"{source.labels[index]}/{source.names[index]}".encode())
    if count <= POINTS:
        return np.arange(count)
    return np.sort(np.random.default_rng(seed).choice(count, POINTS, replace=False))


def _quantiles(features: np.ndarray, weights: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Quantile functions ``(DIRECTIONS, LEVELS)`` of the weighted projections."""
    projected = features @ directions.T  # (n, D)
    order = np.argsort(projected, axis=0, kind="stable")
    levels = (np.arange(LEVELS) + 0.5) / LEVELS
    out = np.empty((directions.shape[0], LEVELS))
    for d in range(directions.shape[0]):
        cumulative = np.cumsum(weights[order[:, d]])
        at = np.minimum(np.searchsorted(cumulative, levels * cumulative[-1]), len(cumulative) - 1)
        out[d] = projected[order[at, d], d]
    return out


def _chamfer_row(query: np.ndarray, query_w: np.ndarray, others: list[np.ndarray],
                 others_w: list[np.ndarray], chunk: int = 32) -> np.ndarray:
    """Symmetric area-weighted Chamfer distance from one set to each of ``others``.

    Exact nearest neighbours by brute force in float32, ``chunk`` sets of equal size stacked
    per matrix product.
    """
    q = query.astype(np.float32)
    q2 = (q**2).sum(axis=1)
    out = np.empty(len(others))
    start = 0
    while start < len(others):
        size = len(others[start])
        stop = start + 1
        while stop < len(others) and stop - start < chunk and len(others[stop]) == size:
            stop += 1
        block = np.stack(others[start:stop]).astype(np.float32)  # (c, n, d)
        flat = block.reshape(-1, block.shape[2])
        squared = q2[:, None] + (flat**2).sum(axis=1)[None, :] - 2.0 * q @ flat.T
        np.maximum(squared, 0.0, out=squared)
        squared = squared.reshape(len(q), stop - start, size)
        forward = np.sqrt(squared.min(axis=2)).T @ query_w  # (c,)
        backward = np.sqrt(squared.min(axis=0))  # (c, n)
        weights = np.stack(others_w[start:stop])
        out[start:stop] = 0.5 * (forward + (backward * weights).sum(axis=1))
        start = stop
    return out


def fine_matrices(source: Source, standard: dict[str, tuple[np.ndarray, np.ndarray]],
                  directions: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Every ``d_fine`` between every pair of the source's models ``{fine: (m, m)}``."""
    m = len(source.labels)
    subsets = [_subsample(source, i) for i in range(m)]
    weights = []
    for i, keep in enumerate(subsets):
        a = source.areas[i][keep].astype(np.float64)
        weights.append(a / max(a.sum(), 1e-300))
    result = {}
    for features in ("hks+sv", "sig"):
        mean, scale = standard[features]
        sets = [(source.local[features][i][keep] - mean) / scale
                for i, keep in enumerate(subsets)]
        q = np.array([_quantiles(s, w, directions[features]).ravel()
                      for s, w in zip(sets, weights, strict=True)])
        sw = np.zeros((m, m))
        for i in range(m):
            sw[i] = np.abs(q - q[i]).mean(axis=1)
        result[f"sw1-{features}"] = sw
        ch = np.zeros((m, m))
        for i in range(m):
            ch[i, i + 1:] = _chamfer_row(sets[i], weights[i], sets[i + 1:], weights[i + 1:])
        result[f"chamfer-{features}"] = ch + ch.T
    return result


def rerank_relevance(d1: np.ndarray, fine: np.ndarray | None, labels: list[str], k: int,
                     w: float, norm: float) -> list[np.ndarray]:
    """Relevance lists (query left out) after re-ranking each query's top ``k``."""
    label_array = np.asarray(labels, dtype=object)
    out = []
    for i in range(len(labels)):
        candidates = np.delete(np.arange(len(labels)), i)
        order = candidates[np.argsort(d1[i, candidates], kind="stable")]
        if fine is not None and w > 0:
            top = order[:k]
            if np.isinf(w):
                top = top[np.lexsort((d1[i, top], fine[i, top]))]
            else:
                top = top[np.argsort(d1[i, top] + w * fine[i, top] / norm, kind="stable")]
            order = np.concatenate([top, order[k:]])
        out.append(label_array[order] == labels[i])
    return out


def _scores(relevance: list[np.ndarray]) -> tuple[dict[str, float], np.ndarray]:
    scored = score_rankings(relevance)
    per_query = np.array([average_precision(r) for r in relevance if r.any()])
    return scored, per_query


def _cost_key(name: str, means: dict[str, float]) -> tuple:
    if name in ("none", "ss5"):
        return (0, 0, 0, 0, -means[name])
    fine, k, _ = name.split("|")
    return (1, int(k[1:]), fine.startswith("chamfer"), fine.endswith("sig"), -means[name])


def choose(table: dict[str, dict[str, float]], pool: list[str], over: list[str]) -> str:
    means = {c: float(np.mean([table[c][s] for s in over])) for c in pool}
    best = max(means.values())
    close = [c for c in pool if means[c] >= best - 0.002]
    return min(close, key=lambda c: _cost_key(c, means))


def _first_stage(sources: list[Source], base: str, features: str, words: int, encoding: str,
                 weight: float) -> tuple[dict[str, np.ndarray], dict[str, Vocabulary]]:
    """Unit first-stage rows per source, each encoded by a vocabulary fitted on the others."""
    vectors, vocabularies = {}, {}
    for source in sources:
        others = [s for s in sources if s.name != source.name]
        vocabulary = Vocabulary.fit([r for s in others for r in s.local[features]], words,
                                    seed=0, per_model=200)
        encode = encode_vlad if encoding == "vlad" else encode_bof
        block = np.array([encode(f, a, vocabulary) for f, a in
                          zip(source.local[features], source.areas, strict=True)])
        vectors[source.name] = joined(source.bases[base], block, weight)
        vocabularies[source.name] = vocabulary
    return vectors, vocabularies


def _nonrigid(rows: np.ndarray, capod: Source, pairs: bool = False) -> np.ndarray:
    """capod's non-rigid models: rows of vectors, or (``pairs``) a square matrix's block."""
    keep = [i for i, label in enumerate(capod.labels) if label in NON_RIGID_CAPOD]
    return rows[np.ix_(keep, keep)] if pairs else rows[keep]


def measure_cost(source: Source, standard: dict[str, tuple[np.ndarray, np.ndarray]],
                 directions: dict[str, np.ndarray], queries: int = 40) -> dict[str, float]:
    """Median ms per query for ``d_fine`` of K candidates from float16 stored subsets."""
    m = len(source.labels)
    stored = {}
    for features in ("hks+sv", "sig"):
        mean, scale = standard[features]
        stored[features] = []
        for i in range(m):
            keep = _subsample(source, i)
            a = source.areas[i][keep]
            stored[features].append((((source.local[features][i][keep] - mean) / scale)
                                     .astype(np.float16), (a / a.sum()).astype(np.float16)))
    timings: dict[str, float] = {}
    for fine, k in itertools.product(FINES, KS):
        kind, features = fine.split("-", 1)
        times = []
        for q in range(min(queries, m)):
            candidates = [(q + 1 + j) % m for j in range(k)]
            started = time.perf_counter()
            qf, qw = (x.astype(np.float64) for x in stored[features][q])
            cf = [stored[features][c][0].astype(np.float64) for c in candidates]
            cw = [stored[features][c][1].astype(np.float64) for c in candidates]
            if kind == "chamfer":
                _chamfer_row(qf, qw, cf, cw)
            else:
                qq = _quantiles(qf, qw, directions[features]).ravel()
                cq = np.array([_quantiles(f, w, directions[features]).ravel()
                               for f, w in zip(cf, cw, strict=True)])
                np.abs(cq - qq).mean(axis=1)
            times.append(time.perf_counter() - started)
        timings[f"{fine}|K{k}"] = 1000.0 * float(np.median(times))
    return timings


def _parse(name: str) -> tuple[str, str, int, str, float] | None:
    match = _CANDIDATE.match(name)
    if match is None:
        return None
    return (match["base"], match["features"], int(match["words"]), match["encoding"],
            float(match["weight"]))


def _bootstrap(per_query_a: dict[str, np.ndarray], per_query_b: dict[str, np.ndarray],
               over: list[str], draws: int = 2000) -> tuple[float, float, float]:
    """Mean over sources of (a - b) mAP, with a 95 % paired bootstrap interval over queries."""
    rng = np.random.default_rng(0)
    diffs = np.zeros(draws)
    for s in over:
        delta = per_query_a[s] - per_query_b[s]
        picks = rng.integers(0, len(delta), size=(draws, len(delta)))
        diffs += delta[picks].mean(axis=1) / len(over)
    point = float(np.mean([np.mean(per_query_a[s] - per_query_b[s]) for s in over]))
    low, high = np.percentile(diffs, [2.5, 97.5])
    return point, float(low), float(high)



def _print_loso(
    choices: dict[str, str],
    table: dict[str, dict[str, dict[str, float]]],
    mean: dict[str, float],
    references: tuple[str, ...],
) -> float:
    """Print a leave-one-source-out table (per source left out: the candidate chosen without
    it, its mAP / NN there, the references' mAP; then the means); return the chosen mean."""
    print("\n| source left out | choice without it | its mAP / NN | " + " | ".join(references)
          + " |\n|" + "---|" * (3 + len(references)))
    for s, c in choices.items():
        cells = " | ".join(f"{table[r][s]['map']:.3f}" for r in references)
        print(f"| {s} | {c} | {table[c][s]['map']:.3f} / {table[c][s]['nn']:.3f} | {cells} |")
    chosen_mean = float(np.mean([table[c][s]["map"] for s, c in choices.items()]))
    print(f"| **mean** | | **{chosen_mean:.3f}** | "
          + " | ".join(f"{mean[r]:.3f}" for r in references) + " |")
    return chosen_mean


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--kind", default="clean")
    parser.add_argument("--selection", type=Path,
                        help="local_features_select --json output (full-pipeline LOSO)")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    folder = args.out / "features" / args.kind
    sources = [load_source(p) for p in sorted(folder.iterdir()) if p.is_dir()]
    by_name = {s.name: s for s in sources}
    scored = list(sources) + split_capod(by_name["capod"])
    rule_sources = [s for s in RULE_SOURCES if s in by_name]
    print("sources:", {s.name: len(s.labels) for s in scored}, flush=True)

    # First stage (ss5) and the vocabularies whose mean / scale standardise hks+sv.
    started = time.perf_counter()
    first, vocabularies = _first_stage(sources, FIRST_BASE, FIRST_FEATURES, FIRST_WORDS,
                                       "vlad", FIRST_WEIGHT)
    first["capod-nonrigid"] = _unit_rows(_nonrigid(first["capod"], by_name["capod"]))
    print(f"first stage {time.perf_counter() - started:.0f}s", flush=True)

    rng = np.random.default_rng(0)
    directions = {}
    for features, width in (("hks+sv", 18), ("sig", 32)):
        raw = rng.standard_normal((DIRECTIONS, width))
        directions[features] = raw / np.linalg.norm(raw, axis=1, keepdims=True)
    standards: dict[str, dict[str, tuple[np.ndarray, np.ndarray]]] = {}
    fine: dict[str, dict[str, np.ndarray]] = {}
    for source in sources:
        others = [s for s in sources if s.name != source.name]
        vocabulary = vocabularies[source.name]
        standards[source.name] = {
            "hks+sv": (vocabulary.mean, vocabulary.scale),
            "sig": _standardiser([r for s in others for r in s.local["sig"]]),
        }
        started = time.perf_counter()
        # Cached per source, its size and the settings (a re-run only recombines).
        path = args.out / "rerank_cache" / args.kind / (
            f"{source.name}{len(source.labels)}-p{POINTS}-d{DIRECTIONS}-l{LEVELS}-"
            + "-".join(f"{o.name}{len(o.labels)}" for o in others) + ".npz")
        if path.exists():
            with np.load(path) as stored:
                fine[source.name] = {kind: stored[kind] for kind in FINES}
        else:
            fine[source.name] = fine_matrices(source, standards[source.name], directions)
            path.parent.mkdir(parents=True, exist_ok=True)
            np.savez(path, **fine[source.name])
        print(f"fine {source.name}: {time.perf_counter() - started:.0f}s", flush=True)
    fine["capod-nonrigid"] = {k: _nonrigid(v, by_name["capod"], pairs=True)
                              for k, v in fine["capod"].items()}
    # Normaliser per (scored source, fine): median within-source pair over other sources.
    norms: dict[str, dict[str, float]] = {}
    for source in scored:
        key = _fitting_key(source.name)
        norms[source.name] = {}
        for kind in FINES:
            values = [fine[o.name][kind][np.triu_indices(len(o.labels), 1)]
                      for o in sources if o.name != key]
            norms[source.name][kind] = float(np.median(np.concatenate(values)))

    def grid(first_rows: dict[str, np.ndarray]
             ) -> tuple[dict[str, dict[str, dict[str, float]]], dict[str, dict[str, np.ndarray]]]:
        table: dict[str, dict[str, dict[str, float]]] = {}
        per_query: dict[str, dict[str, np.ndarray]] = {}
        names = ["none"] + [f"{f}|K{k}|w{w:g}" for f, k, w in itertools.product(FINES, KS, WS)]
        d1s = {s.name: pairwise_distances(first_rows[s.name], first_rows[s.name])
               for s in scored}
        for name in names:
            table[name], per_query[name] = {}, {}
            for source in scored:
                if name == "none":
                    relevance = rerank_relevance(d1s[source.name], None, source.labels, 0, 0, 1)
                else:
                    kind, k, w = name.split("|")
                    relevance = rerank_relevance(
                        d1s[source.name], fine[source.name][kind], source.labels, int(k[1:]),
                        float(w[1:]), norms[source.name][kind])
                table[name][source.name], per_query[name][source.name] = _scores(relevance)
        return table, per_query

    started = time.perf_counter()
    table, per_query = grid(first)
    print(f"grid {time.perf_counter() - started:.0f}s", flush=True)
    ss4 = {s.name: _unit_rows(s.bases["ss4"]) for s in sources}
    ss4["capod-nonrigid"] = _unit_rows(_nonrigid(by_name["capod"].bases["ss4"], by_name["capod"]))
    table["ss4"], per_query["ss4"] = {}, {}
    for source in scored:
        d = pairwise_distances(ss4[source.name], ss4[source.name])
        table["ss4"][source.name], per_query["ss4"][source.name] = _scores(
            rerank_relevance(d, None, source.labels, 0, 0, 1))
    table["ss5"], per_query["ss5"] = table.pop("none"), per_query.pop("none")

    maps = {c: {s: v["map"] for s, v in row.items()} for c, row in table.items()}
    pool = [c for c in maps if c != "ss4"]
    mean = {c: float(np.mean([maps[c][s] for s in rule_sources])) for c in maps}
    chosen = choose(maps, pool, rule_sources)
    loso = {s: choose(maps, pool, [o for o in rule_sources if o != s]) for s in rule_sources}

    header = ["candidate", "mean mAP", *[s.name for s in scored]]
    ranked = sorted(pool, key=lambda c: -mean[c])
    shown = list(dict.fromkeys(["ss4", "ss5", chosen, *ranked[:5]]))
    print("\n| " + " | ".join(header) + " |\n|" + "---|" * len(header))
    for c in shown:
        cells = [f"{table[c][s.name]['map']:.3f} / {table[c][s.name]['nn']:.3f}" for s in scored]
        print(f"| {c} | {mean[c]:.3f} | " + " | ".join(cells) + " |")
    print(f"\nrule's choice: {chosen} (mean {mean[chosen]:.3f}; ss5 {mean['ss5']:.3f}, "
          f"ss4 {mean['ss4']:.3f})")
    print("spread of the best five means:", [round(mean[c], 4) for c in ranked[:5]])
    loso_mean = _print_loso(loso, table, mean, ("ss5", "ss4"))
    loso_per_query = {s: per_query[c][s] for s, c in loso.items()}
    for ref in ("ss5", "ss4"):
        point, low, high = _bootstrap(loso_per_query, per_query[ref], rule_sources)
        print(f"LOSO re-rank - {ref}: {point:+.4f} (95% bootstrap over queries "
              f"{low:+.4f} .. {high:+.4f})")
    # Diagnostic, not the rule (added after the first run, which declined every re-rank):
    # the same choice among re-rank candidates only (w > 0), to see whether any re-rank
    # chosen without a source helps on it.
    forced_pool = [c for c in pool if c != "ss5"]
    forced = {s: choose(maps, forced_pool, [o for o in rule_sources if o != s])
              for s in rule_sources}
    print("\ndiagnostic (re-rank forced, w > 0 only; not the rule):")
    forced_mean = _print_loso(forced, table, mean, ("ss5",))
    point, low, high = _bootstrap({s: per_query[c][s] for s, c in forced.items()},
                                  per_query["ss5"], rule_sources)
    print(f"forced LOSO - ss5: {point:+.4f} (95% bootstrap {low:+.4f} .. {high:+.4f})")
    nonrigid = "capod-nonrigid"
    print(f"{nonrigid}: chosen {table[chosen][nonrigid]['map']:.3f}, ss5 "
          f"{table['ss5'][nonrigid]['map']:.3f}, ss4 {table['ss4'][nonrigid]['map']:.3f}")
    print("normalisers:", {s: {k: round(v, 4) for k, v in n.items()} for s, n in norms.items()})

    result: dict[str, object] = {
        "table": table, "mean": mean, "chosen": chosen, "loso": loso, "loso_mean": loso_mean,
        "norms": norms, "forced_loso": forced, "forced_loso_mean": forced_mean,
    }

    # Full-pipeline LOSO: the first stage the selector chose without s.
    if args.selection is not None and args.selection.exists():
        selection = json.loads(args.selection.read_text())
        sel_loso: dict[str, str] = selection["loso"]
        sel_table = selection["table"]
        sel_loso_mean = float(np.mean([sel_table[c][s]["map"] for s, c in sel_loso.items()
                                       if s in rule_sources]))
        rows = []
        cache: dict[str, tuple[dict, dict]] = {}
        for s in rule_sources:
            parsed = _parse(sel_loso[s])
            if parsed is None:  # a base alone
                base_rows = {o.name: _unit_rows(o.bases[sel_loso[s]]) for o in sources}
                base_rows["capod-nonrigid"] = _unit_rows(
                    _nonrigid(by_name["capod"].bases[sel_loso[s]], by_name["capod"]))
                first_s = base_rows
            else:
                base, features, words, encoding, weight = parsed
                first_s, _ = _first_stage(sources, base, features, words, encoding, weight)
                first_s["capod-nonrigid"] = _unit_rows(
                    _nonrigid(first_s["capod"], by_name["capod"]))
            if sel_loso[s] not in cache:
                cache[sel_loso[s]] = grid(first_s)
            t_s, _ = cache[sel_loso[s]]
            m_s = {c: {o: v["map"] for o, v in row.items()} for c, row in t_s.items()}
            without = [o for o in rule_sources if o != s]
            c_s = choose(m_s, list(m_s), without)
            f_s = choose(m_s, [c for c in m_s if c != "none"], without)  # diagnostic
            rows.append((s, sel_loso[s], c_s, m_s[c_s][s], m_s["none"][s], f_s, m_s[f_s][s]))
        print("\nfull-pipeline LOSO (first stage = the selector's choice without s):")
        print("| source | first stage | re-rank chosen without s | mAP | first stage alone "
              "| forced re-rank (diagnostic) | its mAP |")
        print("|---|---|---|---|---|---|---|")
        for s, first_name, c_s, value, alone, f_s, f_value in rows:
            print(f"| {s} | {first_name} | {c_s} | {value:.3f} | {alone:.3f} | {f_s} "
                  f"| {f_value:.3f} |")
        full_mean = float(np.mean([r[3] for r in rows]))
        print(f"| **mean** | | | **{full_mean:.3f}** | {np.mean([r[4] for r in rows]):.3f} "
              f"(selector's LOSO {sel_loso_mean:.3f}) | | {np.mean([r[6] for r in rows]):.3f} |")
        result["full_loso"] = rows
        result["selector_loso_mean"] = sel_loso_mean

    timings = measure_cost(by_name["madcad"] if "madcad" in by_name else sources[0],
                           standards.get("madcad", standards[sources[0].name]), directions)
    print("\ncost, median ms per query for d_fine of K candidates (one thread):")
    for key, value in timings.items():
        print(f"  {key}: {value:.1f} ms")
    for features, width in (("hks+sv", 18), ("sig", 32)):
        print(f"  store {features}: {POINTS} x {width} float16 + {POINTS} areas float16 = "
              f"{POINTS * width * 2 + POINTS * 2} bytes per model")
    result["timings"] = timings
    if args.json:
        args.json.write_text(json.dumps(result, indent=1, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
