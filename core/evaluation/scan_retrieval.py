"""Scan-robust retrieval, measured at descriptor level.

Two ideas, each measured against the global descriptor of the service today:

- **view entries**: every catalogue model is described whole *and* as ``views`` clean virtual
  partial views (hidden point removal from fixed directions, ``scans.virtual_view``); a model's
  distance to a query is the smallest over its entries (best view), and the ranking has one
  row per model;
- **boundary down-weighting**: points near the open boundary of a partial surface carry the
  Laplacian's free-boundary artefacts; their histogram weight (area) is scaled by
  ``boundary_weights`` (0 on the rim, rising to 1 a diffusion length inside). On a closed
  surface nothing is a rim and the descriptor is unchanged.

Queries are clean models, registered turntable scans and single sensor views (``scans``),
each left out of the catalogue under its own model name. Eigenpairs come from the evaluation's
cache (``runner.describe_sampling``), so a rerun only computes what is new::

    python -m core.evaluation.scan_retrieval DATASET --out OUT [--per-class 2] [--views 6]

writes ``OUT/scan_retrieval.json`` and prints a Markdown table. Catalogues with views are
scored twice: by best entry (``views<n>``) and in the search service's scan-mode order for
10 results, the hub discount among entries for the first answer, that answer's shape-mode
order for the rest (``views<n>+hub``, ``core.rank.scan_order.scan_ranking``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from core.errors import InvalidShapeError, SolverError
from core.evaluation.dataset import Model, load_dataset
from core.evaluation.metrics import pairwise_distances, ranked_relevance, score_rankings
from core.evaluation.runner import (
    _sample_points,
    describe_sampling,
    run_variants,
    sampling_of,
)
from core.evaluation.scans import view_kind
from core.evaluation.variants import EVAL_POINTS, SS11_DESCRIPTOR
from core.pipeline import descriptor_from_eigenpairs
from core.rank.scan_order import scan_mode_positions
from core.settings import DESCRIPTOR_FAMILIES, DescriptorSettings, EngineSettings
from core.views import boundary_weights

__all__ = [
    "DESCRIPTORS",
    "QUERY_KINDS",
    "best_entry_distances",
    "boundary_weights",
    "main",
    "run",
    "view_subsets",
]

ROTATION_SEED = 1
#: Query kinds: clean models, the simple merged three-view and single-view scans and the two
#: sensor scans, all through the engine's outlier filter. A further ``+<fit><k>[x<passes>]``
#: step (``runner._cleanup_steps``) denoises a scan after the filter, e.g. ``multi+sor+plane16``.
QUERY_KINDS: tuple[str, ...] = (
    "clean", "multi+sor", "single+sor", "turntable+sor", "kinect-view+sor",
)

_DEFAULT = DescriptorSettings()
#: Descriptor variant -> (descriptor settings, down-weight the boundary?).
DESCRIPTORS: dict[str, tuple[DescriptorSettings, bool]] = {
    "default": (_DEFAULT, False),
    # The layout before the shortened runs, and the family for bendable shapes.
    "ss11": (SS11_DESCRIPTOR, False),
    "bendable": (DESCRIPTOR_FAMILIES["bendable"], False),
    "boundary": (_DEFAULT, True),
    # ShapeDNA is a global spectrum: a partial surface's eigenvalues are not the whole's.
    "boundary-nodna": (replace(_DEFAULT, dna_count=0), True),
    # Short diffusion times only: local geometry, less reach to a missing side.
    "short-hks-boundary": (
        replace(_DEFAULT, hks_times=tuple(np.geomspace(1e-3, 1e-2, 16).tolist()),
                hks_weight=1.0, wks_energies=0, dna_count=0, local_weight=0.0),
        True,
    ),
}


def view_subsets(views: int) -> list[tuple[int, ...]]:
    """The sets of view indices scored: all ``views``, and spread subsets of 2 and 3.

    Models are rotated at random before they are viewed, so which fixed directions are kept
    does not matter, only how many (and that they are spread: every other one).
    """
    if views < 1:
        return []
    subsets = [tuple(range(views))]
    for count in (3, 2):
        if views > count:
            subsets.append(tuple(range(0, views, views // count))[:count])
    return subsets


def best_entry_distances(
    queries: np.ndarray, entries: np.ndarray, owners: np.ndarray, models: int
) -> np.ndarray:
    """Distance ``(q, models)`` from each query to each model's nearest entry (best view).

    Parameters
    ----------
    queries : (q, d) float
    entries : (e, d) float
    owners : (e,) int
        The model (0 .. models - 1) each entry belongs to.
    """
    distances = pairwise_distances(queries, entries)
    best = np.full((len(queries), models), np.inf)
    for model in range(models):
        mine = owners == model
        if mine.any():
            best[:, model] = distances[:, mine].min(axis=1)
    return best


@dataclass
class Described:
    """The descriptor variants of one sampling of one model, and what it cost."""

    descriptors: dict[str, np.ndarray]
    seconds: dict[str, float] = field(default_factory=dict)


def describe(
    model: Model, kind: str, settings: EngineSettings, cache_dir: Path | None, factory: Any,
    variants: tuple[str, ...] = tuple(DESCRIPTORS), rotation_seed: int = ROTATION_SEED,
) -> Described:
    """The ``DESCRIPTORS`` ``variants`` of ``model`` under scan ``kind`` (``clean`` too),
    rotated and scanned by the draws of ``rotation_seed``."""
    sampling = sampling_of(settings, rotation_seed, kind)
    store = describe_sampling(model, sampling, settings, cache_dir, factory)
    result = run_variants(store, {"default": settings})["default"]
    if store.changed and cache_dir is not None:
        store.save(cache_dir / sampling.cache_name(model.sha256))
    n = result.cutoff.n
    values, vectors = store.eigenvalues[:n], store.eigenvectors[:, :n]
    points, _ = _sample_points(model, sampling, settings.min_points)
    started = time.perf_counter()
    weights = boundary_weights(points)
    weight_seconds = time.perf_counter() - started
    descriptors = {}
    for name in variants:
        descriptor, down_weight = DESCRIPTORS[name]
        areas = store.areas * weights if down_weight else store.areas
        variant = replace(settings, descriptor=descriptor)
        descriptors[name] = descriptor_from_eigenpairs(
            values, vectors, areas, points, variant
        )[1]
    seconds = {
        "load": store.timings.get("load", 0.0),
        "laplacian": store.timings.get("laplacian", 0.0),
        "eigensolve": result.eigensolve_seconds,
        "descriptor": result.descriptor_seconds,
        "boundary": weight_seconds,
    }
    return Described(descriptors=descriptors, seconds=seconds)


def _scores(
    queries: dict[str, Described],
    catalogue: dict[str, list[Described]],
    labels: dict[str, str],
    descriptor: str,
    hub: bool = False,
) -> dict[str, float]:
    """Leave-one-out scores of ``queries`` against ``catalogue`` (each model's entries) by
    best entry, plain or (``hub``) in the search service's scan-mode order
    (``core.rank.scan_order.scan_ranking``)."""
    names = sorted(catalogue)
    query_names = sorted(queries)
    entries, owners = [], []
    for index, name in enumerate(names):
        for entry in catalogue[name]:
            entries.append(entry.descriptors[descriptor])
            owners.append(index)
    query_rows = np.array([queries[q].descriptors[descriptor] for q in query_names])
    if hub:
        position = {name: index for index, name in enumerate(names)}
        left_out = np.array([position.get(q, -1) for q in query_names])
        whole = np.array([catalogue[name][0].descriptors[descriptor] for name in names])
        distances = scan_mode_positions(query_rows, np.array(entries), np.array(owners),
                                        left_out, whole)
    else:
        distances = best_entry_distances(query_rows, np.array(entries), np.array(owners),
                                         len(names))
    exclude = np.array([[q == d for d in names] for q in query_names])
    relevance = ranked_relevance(
        distances, [labels[q] for q in query_names], [labels[d] for d in names], exclude
    )
    return score_rankings(relevance)


def run(
    dataset_root: str | Path,
    out: str | Path,
    per_class: int | None = 2,
    views: int = 6,
    query_kinds: tuple[str, ...] = QUERY_KINDS,
    points: int = EVAL_POINTS,
    cached_only: bool = False,
    merged: tuple[str, ...] = (),
    variants: tuple[str, ...] = tuple(DESCRIPTORS),
    rotation_seed: int = ROTATION_SEED,
    extra_kinds: tuple[str, ...] = (),
) -> dict[str, Any]:
    """Describe catalogue and queries, score every (mode, descriptor, query kind).

    ``variants`` names the ``DESCRIPTORS`` computed and scored (default: all of them);
    ``rotation_seed`` draws each model's rotation and its scans (another seed, another draw).
    ``extra_kinds`` are described and saved with the rest (``scan_retrieval_descriptors.npz``)
    but not scored: catalogue entries for a study to combine after the fact (e.g. the views
    fixed in a shape's own frame, ``fview<i>t<degrees>``).

    ``merged`` names merged virtual views (e.g. ``("merge012of4", "merge123of4")``) that add
    the catalogue modes ``merged`` (clean + those) and ``merged+views`` (+ the single views).

    With ``cached_only``, models whose samplings are not all in ``OUT/cache`` are skipped
    (to score what an interrupted run finished).
    """
    from core.eigen import SpectralSolver, pin_blas_threads

    out = Path(out)
    cache_dir = out / "cache"
    dataset = load_dataset(dataset_root, per_class)
    labels = {m.name: m.label for m in dataset.models}
    settings = EngineSettings(max_points=points)
    factory = lambda stiffness, mass: SpectralSolver(stiffness, mass)  # noqa: E731
    kinds = list(dict.fromkeys(["clean", *[view_kind(i, views) for i in range(views)],
                                *merged, *query_kinds, *extra_kinds]))
    described: dict[str, dict[str, Described]] = {kind: {} for kind in kinds}
    failures: list[str] = []
    skipped: list[str] = []
    started = time.perf_counter()
    with pin_blas_threads():
        for number, model in enumerate(dataset.models, 1):
            if cached_only and not all(
                (cache_dir / sampling_of(settings, rotation_seed, kind).cache_name(
                    model.sha256)).exists() for kind in kinds
            ):
                skipped.append(model.name)
                continue
            for kind in kinds:
                try:
                    described[kind][model.name] = describe(
                        model, kind, settings, cache_dir, factory, variants, rotation_seed
                    )
                except (InvalidShapeError, SolverError, ValueError, RuntimeError) as error:
                    failures.append(f"{model.name} ({kind}): {error}")
            print(f"  [{number}/{len(dataset.models)}] {time.perf_counter() - started:.0f} s",
                  file=sys.stderr, flush=True)
    catalogues = {"global": {m: [d] for m, d in described["clean"].items()}}
    for subset in view_subsets(views):
        chosen = [view_kind(i, views) for i in subset]
        catalogues[f"views{len(subset)}"] = {
            m: [d, *(described[v][m] for v in chosen if m in described[v])]
            for m, d in described["clean"].items()
        }
    if merged:
        # Merged virtual views (scans.scan_of_kind "merge<digits>of<count>") as extra entries,
        # alone and next to all single views.
        singles = [view_kind(i, views) for i in range(views)]
        for mode, extra in (("merged", list(merged)), ("merged+views", [*merged, *singles])):
            catalogues[mode] = {
                m: [d, *(described[k][m] for k in extra if m in described[k])]
                for m, d in described["clean"].items()
            }
    scores: dict[str, Any] = {}
    for mode, catalogue in catalogues.items():
        # Catalogues with views are also scored in the service's scan-mode order.
        orders = (False, True) if mode.startswith("views") else (False,)
        for descriptor in variants:
            for kind in query_kinds:
                for hub in orders:
                    scores[f"{mode}{'+hub' if hub else ''}|{descriptor}|{kind}"] = _scores(
                        described[kind], catalogue, labels, descriptor, hub
                    )
    record = {
        "dataset": str(dataset_root),
        "models": len(dataset.models),
        "classes": len(set(dataset.labels)),
        "per_class": per_class,
        "views": views,
        "points": points,
        "rotation_seed": rotation_seed,
        "scores": scores,
        "seconds": {kind: _mean_seconds(described[kind]) for kind in kinds},
        "failures": failures,
        "skipped": skipped,
        "scored_models": sorted(described["clean"]),
        "wall_seconds": time.perf_counter() - started,
    }
    out.mkdir(parents=True, exist_ok=True)
    (out / "scan_retrieval.json").write_text(json.dumps(record, indent=1))
    # Every descriptor, for analyses after the fact: key "<kind>|<descriptor>|<model>".
    np.savez_compressed(out / "scan_retrieval_descriptors.npz", **{  # type: ignore[arg-type]
        f"{kind}|{name}|{model}": vector
        for kind, by_model in described.items() for model, entry in by_model.items()
        for name, vector in entry.descriptors.items()
    })
    return record


def _mean_seconds(described: dict[str, Described]) -> dict[str, float]:
    keys = ("load", "laplacian", "eigensolve", "descriptor", "boundary")
    return {k: float(np.mean([d.seconds[k] for d in described.values()])) for k in keys}


def markdown(record: dict[str, Any]) -> str:
    """The scores as a Markdown table: one row per (mode, descriptor), NN and mAP per kind."""
    kinds = sorted({key.split("|")[2] for key in record["scores"]},
                   key=lambda k: (QUERY_KINDS.index(k) if k in QUERY_KINDS else 99, k))
    header = "| mode | descriptor | " + " | ".join(f"{k} NN | {k} mAP" for k in kinds) + " |"
    lines = [header, "|" + "---|" * (2 + 2 * len(kinds))]
    rows = sorted({tuple(key.split("|")[:2]) for key in record["scores"]})
    for mode, descriptor in rows:
        cells = []
        for kind in kinds:
            score = record["scores"][f"{mode}|{descriptor}|{kind}"]
            cells += [f"{score['nn']:.3f}", f"{score['map']:.3f}"]
        lines.append(f"| {mode} | {descriptor} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """``python -m core.evaluation.scan_retrieval DATASET --out OUT``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset")
    parser.add_argument("--out", required=True)
    parser.add_argument("--per-class", type=int, default=2,
                        help="seeded subset of models per class (0: all)")
    parser.add_argument("--views", type=int, default=6, help="virtual views per model (0: none)")
    parser.add_argument("--kinds", nargs="+", default=list(QUERY_KINDS),
                        help="query kinds (default: %(default)s)")
    parser.add_argument("--merged", nargs="*", default=[],
                        help="merged virtual-view entry kinds, e.g. merge012of4 merge123of4")
    parser.add_argument("--descriptors", nargs="+", default=list(DESCRIPTORS),
                        choices=list(DESCRIPTORS),
                        help="descriptor variants to compute and score (default: all)")
    parser.add_argument("--rotation-seed", type=int, default=ROTATION_SEED,
                        help="seed of each model's rotation and scans (default %(default)s)")
    parser.add_argument("--extra-kinds", nargs="*", default=[],
                        help="catalogue entry kinds described and saved, not scored, e.g. "
                             "fview0t45 fview1t45 fview2t45")
    parser.add_argument("--cached-only", action="store_true",
                        help="score only the models an earlier run fully cached")
    args = parser.parse_args(argv)
    record = run(args.dataset, args.out, args.per_class or None, args.views,
                 query_kinds=tuple(args.kinds), cached_only=args.cached_only,
                 merged=tuple(args.merged), variants=tuple(args.descriptors),
                 rotation_seed=args.rotation_seed, extra_kinds=tuple(args.extra_kinds))
    print(markdown(record))
    print(json.dumps(record["seconds"], indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
