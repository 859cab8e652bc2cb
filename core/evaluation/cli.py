"""``shapesearch eval DATASET_DIR``: score retrieval of every variant on a labelled dataset.

Stages (progress on stderr):

1. walk ``DATASET_DIR/CLASS/MODEL_FILE``, drop byte-identical duplicates;
2. per sampling (Laplacian, points, seed) and model: seeded random rotation, Laplacian,
   eigenpairs (cached under ``OUT/cache``), then every variant's cutoff and descriptor;
3. leave-one-out retrieval scores per variant (``core.evaluation.metrics``);
4. optionally: simulated scans queried against the clean models, the resampling study,
   and a direct timing check of the estimated eigen-solve seconds;
5. ``OUT/results.md``, ``OUT/results.json`` and PNG plots.
"""

from __future__ import annotations

import argparse
import platform
import random
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

import numpy as np

from core.errors import InvalidShapeError, SolverError
from core.evaluation.dataset import Dataset, Model, load_dataset
from core.evaluation.metrics import (
    pairwise_distances,
    per_class_scores,
    precision_recall_curve,
    ranked_relevance,
    score_rankings,
)
from core.evaluation.report import markdown_report, plots_from_record, write_json
from core.evaluation.runner import (
    ModelResult,
    Sampling,
    describe_sampling,
    group_by_sampling,
    progress,
    run_variants,
    sampling_of,
    time_variants_directly,
)
from core.evaluation.scan_retrieval import best_entry_distances
from core.evaluation.scans import view_kind
from core.evaluation.variants import SCAN_VARIANTS, resolve_variants
from core.rank.hubness import (
    HUB_NEIGHBOURS,
    HUB_WEIGHT,
    hub_discounted_keys,
)
from core.rank.reciprocal import (
    BLEND,
    EXPANSION,
    RECIPROCAL_NEIGHBOURS,
    reciprocal_keys,
    rescaled_rows,
)
from core.rank.scan_order import scan_mode_positions
from core.settings import EngineSettings

__all__ = ["evaluate", "run"]

ROTATION_SEED = 1
# Models per class in the direct timing check (each runs every distinct cutoff afresh).
_TIMING_MODELS = 5

Results = dict[str, dict[str, ModelResult]]  # variant -> model name -> result


def _machine() -> str:
    try:
        lscpu = subprocess.run(["lscpu"], capture_output=True, text=True, check=False).stdout
        model = next(
            (line.split(":", 1)[1].strip() for line in lscpu.splitlines()
             if line.startswith("Model name")),
            platform.processor() or "unknown CPU",
        )
    except OSError:
        model = platform.processor() or "unknown CPU"
    import os

    return f"{model}, {os.cpu_count()} cores, Python {platform.python_version()}"


def _solver_factory() -> Callable[[Any, Any], Any]:
    from core.eigen import SpectralSolver

    return lambda stiffness, mass: SpectralSolver(stiffness, mass)


def describe_all(
    models: list[Model],
    variants: dict[str, EngineSettings],
    cache_dir: Path | None,
    scan: str,
    counters: dict[str, int],
    failures: list[str],
    rotation_seed: int = ROTATION_SEED,
) -> Results:
    """Every variant on every model for one kind of query (clean or a scan)."""
    factory = _solver_factory()
    results: Results = {name: {} for name in variants}
    for sampling, group in group_by_sampling(variants, rotation_seed, scan).items():
        settings = next(iter(group.values()))
        label = f"{scan} {sampling.laplacian} {sampling.max_points} pts, {len(group)} variants"
        print(f"describing {len(models)} models ({label})", file=sys.stderr, flush=True)
        started = time.perf_counter()
        for index, model in enumerate(models, 1):
            try:
                store = describe_sampling(model, sampling, settings, cache_dir, factory)
                cached = store.count > 0
                for name, result in run_variants(store, group).items():
                    results[name][model.name] = result
                if store.changed and cache_dir is not None:
                    store.save(cache_dir / sampling.cache_name(model.sha256))
                counters["cached" if cached else "computed"] += 1
            except (InvalidShapeError, SolverError, ValueError, RuntimeError) as error:
                failures.append(f"{model.name} ({scan}, {sampling.laplacian}): {error}")
                print(f"  failed: {failures[-1]}", file=sys.stderr)
            if index % 10 == 0 or index == len(models):
                progress(index, len(models), started, label)
    return results


def _ranking_inputs(
    database: dict[str, ModelResult],
    queries: dict[str, ModelResult],
    labels: dict[str, str],
    hub_neighbours: int,
    clean: bool,
) -> tuple[np.ndarray, list[str], list[str], np.ndarray]:
    """What ranks ``queries`` against ``database`` leave-one-out: distances (or the
    service's keys), the query and database labels and the excluded pairs (a query's own
    model). With ``hub_neighbours``, ``clean`` queries (the database itself) rank as the
    service does, by the hub discount re-ranked k-reciprocally over the whole catalogue, the
    discount's first answer kept first (``core.rank.reciprocal``); scans by the hub discount
    alone (a scan is no member of the catalogue whose neighbourhoods the re-rank compares:
    said by ``clean``, since a scan is named after its model)."""
    names = sorted(database)
    query_names = sorted(queries)
    base = np.array([database[name].descriptor for name in names])
    query = np.array([queries[name].descriptor for name in query_names])
    exclude = np.array([[q == d for d in names] for q in query_names])
    if hub_neighbours == 0:
        distances = pairwise_distances(query, base)
    else:
        distances = hub_discounted_keys(query, base, hub_neighbours, HUB_WEIGHT, exclude)
        if clean:
            distances = reciprocal_keys(base, rescaled_rows(distances))
    return distances, [labels[q] for q in query_names], [labels[d] for d in names], exclude


def score_variant(
    database: dict[str, ModelResult],
    queries: dict[str, ModelResult],
    labels: dict[str, str],
    hub_neighbours: int = 0,
    per_class: bool = False,
    clean: bool = False,
) -> tuple[dict[str, float], tuple[np.ndarray, np.ndarray], dict[str, Any] | None]:
    """Leave-one-out scores of ``queries`` against ``database``, the mean PR curve and, with
    ``per_class``, ``per_class_scores`` (else None) of the same ranking.

    A query is left out of the database under its own model name (itself for clean queries,
    its source model for scans). ``hub_neighbours`` above 0 ranks with the hub discount
    (``core.rank.hubness``, that ``k`` and the chosen weight), the left-out model counted in no
    candidate's neighbourhood; ``clean`` queries (the database itself) are then re-ranked
    k-reciprocally as the service's shape mode does, scans are not.
    """
    inputs = _ranking_inputs(database, queries, labels, hub_neighbours, clean)
    relevance = ranked_relevance(*inputs)
    curves = [precision_recall_curve(r) for r in relevance if r.any()]
    recall = curves[0][0] if curves else np.linspace(0.05, 1, 20)
    precision = np.mean([c[1] for c in curves], axis=0) if curves else np.zeros_like(recall)
    classes = per_class_scores(*inputs) if per_class else None
    return score_rankings(relevance), (recall, precision), classes


def score_scan_mode(
    database: dict[str, ModelResult],
    views: list[dict[str, ModelResult]],
    queries: dict[str, ModelResult],
    labels: dict[str, str],
    discounted: bool = True,
) -> dict[str, float]:
    """Leave-one-out scores of scans ``queries`` in the search service's scan mode: each
    model of ``database`` is an entry whole and one per ``views`` (its virtual views that
    could be described); a scan ranks the models as the service answers 10 results, the hub
    discount among entries for the first answer and that answer's shape-mode order for the
    rest (``core.rank.scan_order.scan_ranking``), or (``discounted`` False) by best entry."""
    names = sorted(database)
    index = {name: position for position, name in enumerate(names)}
    rows, owners = [], []
    for name in names:
        for entry in (database, *views):
            if name in entry:
                rows.append(entry[name].descriptor)
                owners.append(index[name])
    entries, owner = np.array(rows), np.array(owners)
    query_names = sorted(name for name in queries if name in index)
    scans = np.array([queries[name].descriptor for name in query_names])
    own = np.array([index[name] for name in query_names])
    if discounted:
        whole = np.array([database[name].descriptor for name in names])
        keys = scan_mode_positions(scans, entries, owner, own, whole)
    else:
        keys = best_entry_distances(scans, entries, owner, len(names))
    exclude = own[:, None] == np.arange(len(names))[None, :]
    relevance = ranked_relevance(keys, [labels[q] for q in query_names],
                                 [labels[d] for d in names], exclude)
    return score_rankings(relevance)


def _stats(results: dict[str, ModelResult]) -> dict[str, Any]:
    n = np.array([r.cutoff.n for r in results.values()], dtype=float)
    calls = np.array([r.cutoff.solver_calls for r in results.values()], dtype=float)
    eig = np.array([r.eigensolve_seconds for r in results.values()])
    desc = np.array([r.descriptor_seconds for r in results.values()])
    ingest = np.array([r.extra.get("front_seconds", 0.0) for r in results.values()]) + eig + desc
    return {
        "n": {
            "min": float(n.min()), "p5": float(np.percentile(n, 5)),
            "median": float(np.median(n)), "mean": float(n.mean()),
            "p95": float(np.percentile(n, 95)), "max": float(n.max()),
        },
        "solver_calls_mean": float(calls.mean()),
        "solver_calls_share_le2": float(np.mean(calls <= 2)),
        "eigensolve_seconds_mean": float(eig.mean()),
        "eigensolve_seconds_total": float(eig.sum()),
        "descriptor_seconds_mean": float(desc.mean()),
        "ingest_seconds_mean": float(ingest.mean()),
    }


def _resampling_study(
    models: list[Model],
    settings: EngineSettings,
    sizes: list[int],
    cache_dir: Path | None,
    counters: dict[str, int],
    failures: list[str],
    name: str,
) -> dict[str, Any]:
    """Each model at several point counts: spread of n, and is the NN another sampling of it."""
    runs: dict[int, dict[str, ModelResult]] = {}
    for size in sizes:
        variant = {name: replace(settings, max_points=size)}
        runs[size] = describe_all(models, variant, cache_dir, "clean", counters, failures)[name]
    common = sorted(set.intersection(*(set(r) for r in runs.values())))
    spreads = []
    per_model = []
    for model_name in common:
        counts = np.array([runs[size][model_name].cutoff.n for size in sizes], dtype=float)
        spreads.append((counts.max() - counts.min()) / np.median(counts))
        per_model.append({"model": model_name, "n": counts.tolist(),
                          "points": [runs[size][model_name].n_points for size in sizes]})
    keys = [(m, size) for m in common for size in sizes]
    vectors = np.array([runs[size][m].descriptor for m, size in keys])
    distances = pairwise_distances(vectors, vectors)
    np.fill_diagonal(distances, np.inf)
    nearest = distances.argmin(axis=1)
    same_model = np.mean([keys[i][0] == keys[j][0] for i, j in enumerate(nearest)])
    same_class = np.mean(
        [keys[i][0].split("/")[0] == keys[j][0].split("/")[0] for i, j in enumerate(nearest)]
    )
    summary = {
        "spread_median": float(np.median(spreads)) if spreads else float("nan"),
        "spread_mean": float(np.mean(spreads)) if spreads else float("nan"),
        "spread_max": float(np.max(spreads)) if spreads else float("nan"),
        "nn_same_model": float(same_model),
        "nn_same_class": float(same_class),
        "per_model": per_model,
    }
    return summary


def _subset(models: list[Model], per_class: int, seed: int) -> list[Model]:
    """A seeded subset of ``per_class`` models of every class."""
    by_class: dict[str, list[Model]] = {}
    for model in models:
        by_class.setdefault(model.label, []).append(model)
    rng = random.Random(seed)
    chosen = [m for label in sorted(by_class)
              for m in rng.sample(by_class[label], min(per_class, len(by_class[label])))]
    return sorted(chosen, key=lambda m: (m.label, m.path.name))


def _direct_timing(
    models: list[Model], variants: dict[str, EngineSettings], results: Results
) -> dict[str, Any]:
    """Fresh-solver timing of every distinct (sampling, cutoff) on a few models."""
    factory = _solver_factory()
    sharing: dict[tuple[Sampling, Any], list[str]] = {}
    for name, settings in variants.items():
        sharing.setdefault((sampling_of(settings, ROTATION_SEED), settings.cutoff), []).append(name)
    # One timing per distinct cutoff, filed under the first variant that uses it.
    distinct = {key: names[0] for key, names in sharing.items()}
    measured: dict[str, list[float]] = {name: [] for name in distinct.values()}
    estimated: dict[str, list[float]] = {name: [] for name in distinct.values()}
    print(f"direct timing of {len(measured)} cutoffs on {len(models)} models", file=sys.stderr)
    for model in models:
        for (sampling, _), name in distinct.items():
            if model.name not in results.get(name, {}):
                continue
            seconds = time_variants_directly(model, sampling, {name: variants[name]}, factory)
            measured[name].append(seconds[name])
            estimated[name].append(results[name][model.name].eigensolve_seconds)
    shared_by = {names[0]: names for names in sharing.values()}
    return {
        "models": len(models),
        "variants": {
            " = ".join(shared_by[name]): {
                "measured": float(np.mean(measured[name])) if measured[name] else None,
                "estimated": float(np.mean(estimated[name])) if estimated[name] else None,
            }
            for name in measured
        },
    }


def evaluate(
    dataset: Dataset,
    variants: dict[str, EngineSettings],
    out: Path,
    *,
    scans: tuple[str, ...] = (),
    scan_variants: tuple[str, ...] = SCAN_VARIANTS,
    resampling_sizes: tuple[int, ...] = (),
    resampling_per_class: int = 4,
    timing_models: int = 0,
    command: str = "",
    use_cache: bool = True,
    hub_neighbours: int = 0,
    scan_views: int = 0,
) -> dict[str, Any]:
    """Run the whole evaluation and write the report; returns the JSON record.

    ``scan_views`` above 0 also describes that many virtual views of every model (for the
    scan variants) and scores the ``scans`` in the service's scan mode, under each variant's
    ``scan_mode`` entry (``score_scan_mode``; its order with the hub discount when
    ``hub_neighbours`` is above 0, by best entry otherwise).

    ``hub_neighbours`` above 0 also scores every ranking with the hub discount
    (``core.rank.hubness``), under each variant's ``hub`` entry: the order the search service
    gives shape-mode answers (``app.search.similarity``; the same as long as a query's
    ``k`` is at least a quarter of the catalogue, else its re-rank of the plain nearest
    ``4 k`` agreed with this for most queries).
    """
    from core.eigen import pin_blas_threads

    started = time.perf_counter()
    out.mkdir(parents=True, exist_ok=True)
    cache_dir = out / "cache" if use_cache else None
    counters = {"computed": 0, "cached": 0}
    failures: list[str] = []
    labels = {m.name: m.label for m in dataset.models}
    record: dict[str, Any] = {
        "command": command,
        "machine": _machine(),
        "dataset": {
            "root": str(dataset.root),
            "models": len(dataset.models),
            "classes": len(set(dataset.labels)),
            "duplicates": [f"{a} = {b}" for a, b in dataset.duplicates],
            "cla_mismatches": dataset.cla_mismatches,
        },
        "variants": {},
    }
    if hub_neighbours > 0:
        record["hub_discount"] = {
            "neighbours": hub_neighbours, "weight": HUB_WEIGHT,
            "reciprocal": {"neighbours": RECIPROCAL_NEIGHBOURS, "expansion": EXPANSION,
                           "blend": BLEND},
        }
    with pin_blas_threads():
        clean = describe_all(dataset.models, variants, cache_dir, "clean", counters, failures)
        for name in variants:
            scores, curve, classes = score_variant(clean[name], clean[name], labels,
                                                   per_class=True)
            record["variants"][name] = {
                "settings": asdict(variants[name]),
                "scores": {"clean": scores},
                "stats": {"clean": _stats(clean[name])},
                "pr": {"clean": {"recall": curve[0], "precision": curve[1]}},
                "per_model": {
                    m: {"n": r.cutoff.n, "calls": r.cutoff.solver_calls, "points": r.n_points,
                        "eig_s": round(r.eigensolve_seconds, 4)}
                    for m, r in clean[name].items()
                },
            }
            record["variants"][name]["per_class"] = classes
            if hub_neighbours > 0:
                hub_scores, _, hub_classes = score_variant(
                    clean[name], clean[name], labels, hub_neighbours, per_class=True,
                    clean=True)
                record["variants"][name]["hub"] = {"clean": hub_scores}
                record["variants"][name]["hub_per_class"] = hub_classes
        chosen_scan = {n: variants[n] for n in scan_variants if n in variants}
        views = [describe_all(dataset.models, chosen_scan, cache_dir, view_kind(i, scan_views),
                              counters, failures)
                 for i in range(scan_views)] if scans and chosen_scan else []
        if views:
            record["scan_mode"] = {"views": scan_views, "discounted": hub_neighbours > 0}
        for kind in scans:
            if not chosen_scan:
                break
            scanned = describe_all(dataset.models, chosen_scan, cache_dir, kind, counters,
                                   failures)
            for name, results in scanned.items():
                scores, curve, _ = score_variant(clean[name], results, labels)
                entry = record["variants"][name]
                entry["scores"][kind] = scores
                entry["stats"][kind] = _stats(results)
                entry["pr"][kind] = {"recall": curve[0], "precision": curve[1]}
                if hub_neighbours > 0:
                    entry["hub"][kind] = score_variant(clean[name], results, labels,
                                                       hub_neighbours)[0]
                if views:
                    entry.setdefault("scan_mode", {})[kind] = score_scan_mode(
                        clean[name], [view[name] for view in views], results, labels,
                        hub_neighbours > 0)
        if resampling_sizes:
            subset = _subset(dataset.models, resampling_per_class, seed=0)
            record["resampling"] = {"sizes": list(resampling_sizes), "models": len(subset),
                                    "variants": {}}
            for name in ("default",) if "default" in variants else list(variants)[:1]:
                summary = _resampling_study(
                    subset, variants[name], list(resampling_sizes), cache_dir, counters,
                    failures, name,
                )
                record["resampling"]["variants"][name] = summary
        if timing_models:
            subset = _subset(dataset.models, 1, seed=1)[:timing_models]
            record["direct_timing"] = _direct_timing(subset, variants, clean)
    record["plots"] = []
    record["failures"] = failures
    record["computed_samplings"] = counters["computed"]
    record["cached_samplings"] = counters["cached"]
    record["wall_seconds"] = time.perf_counter() - started
    # The numbers are on disk before any plot is drawn: a plotting failure never loses a run.
    write_report(record, out)
    record["plots"] = _plots(record, out)
    if record["plots"]:
        write_report(record, out)
    return record


def write_report(record: dict[str, Any], out: Path) -> None:
    """``OUT/results.json`` and ``OUT/results.md`` of one run."""
    write_json(record, out / "results.json")
    (out / "results.md").write_text(markdown_report(record))


def _plots(record: dict[str, Any], out: Path) -> list[str]:
    """Draw the plots; without matplotlib, say so in one line and draw none."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        print(
            f"shapesearch eval: matplotlib is not installed, so no plots were drawn; results are"
            f" in {out}/results.md (pip install 'shapesearch[eval]', then"
            f" python -m core.evaluation.report {out} draws them)",
            file=sys.stderr,
        )
        return []
    return plots_from_record(record, out)


def hub_neighbours_for(asked: int | None, models: int) -> int:
    """``--hub-discount``'s ``K``: as asked, or when not asked the service's default
    (``core.rank.hubness.HUB_NEIGHBOURS``) for a set of at least 3 models, else 0 (none)."""
    if asked is not None:
        return asked
    return HUB_NEIGHBOURS if models >= 3 else 0


def run(args: argparse.Namespace) -> int:
    """Entry point of ``shapesearch eval``."""
    try:
        variants = resolve_variants(args.variants)
    except ValueError as error:
        print(f"shapesearch eval: {error}", file=sys.stderr)
        return 2
    dataset = load_dataset(args.dataset, getattr(args, "limit_per_class", None))
    if getattr(args, "model_list", None):
        wanted = set(Path(args.model_list).read_text().split())
        dataset.models = [model for model in dataset.models if model.name in wanted]
    if not dataset.models:
        print(f"shapesearch eval: no models under {args.dataset}", file=sys.stderr)
        return 2
    hub_neighbours = hub_neighbours_for(getattr(args, "hub_discount", None), len(dataset.models))
    if hub_neighbours < 0 or (hub_neighbours > 0 and len(dataset.models) < 3):
        print("shapesearch eval: --hub-discount needs K >= 1 and at least 3 models",
              file=sys.stderr)
        return 2
    print(
        f"{len(dataset.models)} models in {len(set(dataset.labels))} classes"
        f" ({len(dataset.duplicates)} duplicates dropped), {len(variants)} variants",
        file=sys.stderr,
    )
    scans = tuple(getattr(args, "scans", None) or ())
    sizes = tuple(getattr(args, "resampling", None) or ())
    record = evaluate(
        dataset,
        variants,
        Path(args.out),
        scans=scans,
        scan_variants=tuple(getattr(args, "scan_variants", None) or SCAN_VARIANTS),
        resampling_sizes=sizes,
        resampling_per_class=getattr(args, "resampling_per_class", 4) or 4,
        timing_models=getattr(args, "timing_models", 0) or 0,
        command="shapesearch " + " ".join(sys.argv[1:]),
        use_cache=not getattr(args, "no_cache", False),
        hub_neighbours=hub_neighbours,
        scan_views=getattr(args, "scan_views", 0) or 0,
    )
    print(f"wrote {args.out}/results.md, results.json and {len(record['plots'])} plots "
          f"in {record['wall_seconds']:.0f} s", file=sys.stderr)
    return 0
