"""Stage 1 of the engineering-parts study (issue 24): per-point features of every model.

For every model of every source (``SOURCES/<source>/<class>/<file>``) the service's own
stages run once (``core.evaluation.runner``: seeded sample, seeded rotation, robust
Laplacian, the default adaptive cutoff), and what every descriptor candidate needs is
saved, so that stage 2 (``bench/selection/local_features_select.py``) only recombines:

- ``points``, ``areas``: the normalised sample and the area each point stands for;
- ``signature``: log scaled HKS at the 16 default times and log WKS at the 16 energies;
- ``blocks_*``: the unit blocks of the default descriptor (every weight 1), D2 and D1 of the
  sample as it is (``ss9``'s; the default's evened ones are built from ``points``).

    .venv/bin/python bench/selection/local_features_extract.py SOURCES OUT [--scan KIND]
        [--feature-share S] [--max-points N] [--cutoff-t T] [--hks-scale F] [--wks-sigma W]
        [--seed S] [--evened-spectrum]

``--feature-share`` samples clean models feature-aware (``core.evaluation.feature_sampling``)
instead of uniformly, ``--max-points`` changes the point budget (the engine's default 3000),
``--cutoff-t`` the adaptive cutoff's ``t`` (default 0.01), ``--hks-scale`` multiplies the
16 heat-kernel times (default 1: 0.001 to 0.1), ``--wks-sigma`` sets the wave kernel's band
width in energy steps (default 2): the studies of ``bench/selection/extraction_select.py``, one
``OUT`` per setting. ``--seed`` draws another extraction of the same models: the sample seed
``S`` (the engine's default 0) and the rotation seed ``ROTATION_SEED + S``, for checks that a
result is not one sample's (``bench/selection/reciprocal_seeds_check.py``).
``--evened-spectrum`` solves the Laplacian of the sample with its principal spreads evened
(``core.extrinsic.evened_spreads``, with the sample's areas) instead of the sample's own, and
stores that surface's points, areas, signature and blocks under ``OUT/features/<kind>-evened/``:
the spectrum of the evened part (``bench/selection/evened_spectrum_select.py``).

Eigenpairs are cached under ``OUT/cache`` (the evaluation's cache layout), features under
``OUT/features/<kind>/<source>/``; a re-run resumes.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

from core.descriptor import BLOCK_WEIGHTS, DescriptorSpec  # noqa: E402
from core.eigen import SpectralSolver  # noqa: E402
from core.errors import InvalidShapeError, SolverError  # noqa: E402
from core.evaluation.dataset import load_dataset  # noqa: E402
from core.evaluation.runner import (  # noqa: E402
    EigenStore,
    describe_sampling,
    run_variants,
    sampling_of,
)
from core.evaluation.scan_retrieval import ROTATION_SEED  # noqa: E402
from core.extrinsic import evened_spreads  # noqa: E402
from core.pipeline import normalised_operators  # noqa: E402
from core.settings import EngineSettings  # noqa: E402


def evened_store(store: EigenStore, settings: EngineSettings) -> EigenStore:
    """A lazy eigen store of the evened part of ``store``'s sample: its points, principal
    spreads evened with the sample's areas, centred and scaled to unit area again, and
    their own Laplacian (eigenpairs computed when a variant asks for them)."""
    assert store.points is not None
    evened = evened_spreads(store.points, store.areas)
    points, stiffness, mass = normalised_operators(evened, settings)
    return EigenStore(
        eigenvalues=np.empty(0), eigenvectors=np.empty((mass.shape[0], 0)),
        areas=np.asarray(mass.diagonal(), dtype=np.float64), bands=[],
        timings=dict(store.timings), factory=lambda: SpectralSolver(stiffness, mass),
        points=points)


def extract(sources: Path, out: Path, scan: str, only: list[str] | None,
            feature_share: float = 0.0, max_points: int | None = None,
            cutoff_t: float | None = None, hks_scale: float = 1.0,
            wks_sigma: float | None = None, seed: int = 0,
            evened_spectrum: bool = False) -> None:
    settings = replace(EngineSettings(), sample_seed=seed)
    if hks_scale != 1.0:
        times = tuple(hks_scale * time for time in settings.descriptor.hks_times)
        settings = replace(settings, descriptor=replace(settings.descriptor, hks_times=times))
    if wks_sigma:
        settings = replace(settings,
                           descriptor=replace(settings.descriptor, wks_sigma=wks_sigma))
    if max_points:
        settings = replace(settings, max_points=max_points)
    if cutoff_t:
        settings = replace(settings, cutoff=replace(settings.cutoff, t=cutoff_t))
    unit = {field: 1.0 for block, field in BLOCK_WEIGHTS.items() if block != "local"}
    # D2 and D1 of the sample as it is: the studies' base is ``ss9``'s, and the evened ones
    # of ``ss10`` are built from the stored sample (stretch_blocks_select.py), as are the
    # shortened runs of ``ss12`` (collapsed_runs_select.py).
    ones = replace(settings.descriptor, **unit, evened_distances=False, runs_longest=None)
    spec = DescriptorSpec.from_settings(ones)
    cache = out / "cache"
    sampling = sampling_of(settings, ROTATION_SEED + seed, scan, feature_share)
    for source in sorted(p for p in sources.iterdir() if p.is_dir()):
        if only and source.name not in only:
            continue
        models = load_dataset(source).models
        kind = f"{scan}-evened" if evened_spectrum else scan
        target = out / "features" / kind / source.name
        target.mkdir(parents=True, exist_ok=True)
        # Features of files the source no longer holds (it was rebuilt) must not be scored.
        current = {f"{model.sha256[:24]}.npz" for model in models}
        for stale in target.glob("*.npz"):
            if stale.name not in current:
                stale.unlink()
        started = time.perf_counter()
        for index, model in enumerate(models, 1):
            path = target / f"{model.sha256[:24]}.npz"
            if path.exists():
                continue
            try:
                if evened_spectrum:
                    # The sample's points and areas only: no eigenpair of the part itself.
                    plain = describe_sampling(model, sampling, settings, None, SpectralSolver)
                    store = evened_store(plain, settings)
                else:
                    store = describe_sampling(model, sampling, settings, cache, SpectralSolver)
                result = run_variants(store, {"default": settings})["default"]
                if store.changed and not evened_spectrum:
                    store.save(cache / sampling.cache_name(model.sha256))
            except (InvalidShapeError, SolverError, ValueError, RuntimeError) as error:
                print(f"  failed {source.name}/{model.name}: {error}", file=sys.stderr)
                continue
            values = store.eigenvalues[: result.cutoff.n]
            vectors = store.eigenvectors[:, : result.cutoff.n]
            signature = spec.signature(values, vectors)
            blocks = spec.blocks(signature, store.areas, values, store.points)
            np.savez(
                path,
                label=model.label,
                name=model.name,
                points=store.points.astype(np.float32),
                areas=store.areas,
                signature=signature.astype(np.float32),
                eigenvalues=values,
                n=result.cutoff.n,
                **{f"blocks_{key}": value for key, value in blocks.items()},
            )
            if index % 20 == 0 or index == len(models):
                elapsed = time.perf_counter() - started
                print(f"  {source.name} {scan} [{index}/{len(models)}] {elapsed:.0f}s",
                      file=sys.stderr, flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sources", type=Path)
    parser.add_argument("out", type=Path)
    parser.add_argument("--scan", default="clean")
    parser.add_argument("--only", nargs="*")
    parser.add_argument("--feature-share", type=float, default=0.0)
    parser.add_argument("--max-points", type=int)
    parser.add_argument("--cutoff-t", type=float)
    parser.add_argument("--hks-scale", type=float, default=1.0)
    parser.add_argument("--wks-sigma", type=float)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--evened-spectrum", action="store_true")
    args = parser.parse_args(argv)
    extract(args.sources, args.out, args.scan, args.only, args.feature_share, args.max_points,
            args.cutoff_t, args.hks_scale, args.wks_sigma, args.seed, args.evened_spectrum)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
