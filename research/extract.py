"""Stage 1 of every study: what the candidates need of every model of every tuning source.

For every model of every source (``SOURCES/<source>/<class>/<file>``, written by
``python -m core.evaluation.sources SOURCES``) the service's own stages run once, as
``shapesearch eval`` runs them (``core.evaluation.runner``: the seeded sample and rotation,
the robust Laplacian, the default adaptive cutoff), and one file per model keeps what a
candidate descriptor is computed from, so that a study only recombines:

- ``points``, ``areas``: the normalised sample and the area each point stands for;
- ``signature``: log scaled HKS at the default's times, then log WKS at its energies;
- ``eigenvalues``: the unit-area eigenvalues up to the cutoff (``n`` of them);
- ``label``, ``name``: the model's class and ``<class>/<file>``.

Everything in float64, so a candidate's blocks are the service's for the same settings.

    python -m research.extract SOURCES OUT [--only NAME ...] [--seed S]

``--seed`` draws another extraction of the same models (the sample seed ``S``, the rotation
seed ``ROTATION_SEED + S``): the unseen extraction a fixed choice is confirmed on.
Eigenpairs are cached under ``OUT/cache`` (the evaluation's cache layout), the models'
files under ``OUT/features/<source>/``; a re-run resumes, and drops the files of models a
rebuilt source no longer holds.
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

from core.descriptor import DescriptorSpec  # noqa: E402
from core.eigen import SpectralSolver  # noqa: E402
from core.errors import InvalidShapeError, SolverError  # noqa: E402
from core.evaluation.dataset import load_dataset  # noqa: E402
from core.evaluation.runner import describe_sampling, run_variants, sampling_of  # noqa: E402
from core.evaluation.scan_retrieval import ROTATION_SEED  # noqa: E402
from core.settings import EngineSettings  # noqa: E402

__all__ = ["extract"]


def extract(sources: Path, out: Path, only: list[str] | None = None, seed: int = 0) -> None:
    """Write ``OUT/features/<source>/<sha>.npz`` for every model of every source folder."""
    settings = replace(EngineSettings(), sample_seed=seed)
    spec = DescriptorSpec.from_settings(settings.descriptor)
    cache = out / "cache"
    sampling = sampling_of(settings, ROTATION_SEED + seed)
    for source in sorted(p for p in sources.iterdir() if p.is_dir()):
        if only and source.name not in only:
            continue
        models = load_dataset(source).models
        target = out / "features" / source.name
        target.mkdir(parents=True, exist_ok=True)
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
                store = describe_sampling(model, sampling, settings, cache, SpectralSolver)
                n = run_variants(store, {"default": settings})["default"].cutoff.n
                if store.changed:
                    store.save(cache / sampling.cache_name(model.sha256))
            except (InvalidShapeError, SolverError, ValueError, RuntimeError) as error:
                print(f"  failed {source.name}/{model.name}: {error}", file=sys.stderr)
                continue
            assert store.points is not None
            np.savez(path, label=model.label, name=model.name, n=n,
                     points=store.points, areas=store.areas,
                     signature=spec.signature(store.eigenvalues[:n], store.eigenvectors[:, :n]),
                     eigenvalues=store.eigenvalues[:n])
            if index % 20 == 0 or index == len(models):
                print(f"  {source.name} [{index}/{len(models)}] "
                      f"{time.perf_counter() - started:.0f}s", file=sys.stderr, flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sources", type=Path)
    parser.add_argument("out", type=Path)
    parser.add_argument("--only", nargs="*")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    extract(args.sources, args.out, args.only, args.seed)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
