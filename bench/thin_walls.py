"""Benchmark: what a thin-walled part loses at a smaller point budget.

A point budget ``N`` spreads ``N`` points over the surface, a spacing of about
``sqrt(area / N)``. Where a wall is thinner than a few spacings, the Laplacian's neighbourhoods
reach across the wall and join its two faces, which changes the low spectrum. Per part and
budget this prints:

- spacing / thickness (the thinnest bounding-box extent stands for the wall);
- the spectrum change against 20000 points: median and largest relative difference of the
  unit-area eigenvalues lambda_2..lambda_31;
- the descriptor distance to the same part at 20000 points, against the distance between two
  samplings (seeds 0 and 1) at the same budget and against the distance to the nearest other
  part of the set at that budget (can the part still find itself).

Usage::

    .venv/bin/python -m bench.thin_walls                      # default parts and budgets
    .venv/bin/python -m bench.thin_walls --parts plate_holes --budgets 3000 20000
"""

from __future__ import annotations

import argparse
import os
import time
from dataclasses import replace
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

PARTS = Path("/work/shared/datasets/parts")
#: Thin-walled parts first, then thick controls.
DEFAULT_PARTS = ("plate_holes", "idler_riser", "1002_tray_bottom", "angle_block", "box")
REFERENCE = 20000
LOW_EIGENVALUES = 30


def part_path(stem: str) -> Path:
    return next(p for p in PARTS.iterdir() if p.stem == stem)


def spacing_over_thickness(path: Path, points: int) -> float:
    import trimesh

    mesh = trimesh.load(path, force="mesh")
    return float(np.sqrt(mesh.area / points) / min(mesh.extents))


def low_spectrum(path: Path, points: int) -> np.ndarray:
    """Unit-area eigenvalues lambda_2..lambda_31 at ``points`` points."""
    from core.eigen import SpectralSolver
    from core.io import load_points
    from core.pipeline import normalised_operators
    from core.settings import EngineSettings

    settings = EngineSettings(max_points=points)
    shape = load_points(path, max_points=points, seed=settings.sample_seed)
    _, stiffness, mass = normalised_operators(shape.points, settings)
    values, _ = SpectralSolver(stiffness, mass).solve(LOW_EIGENVALUES + 1)
    return np.asarray(values[1:])


def descriptor(path: Path, points: int, seed: int = 0) -> np.ndarray:
    from core.pipeline import describe
    from core.settings import EngineSettings

    settings = replace(EngineSettings(), max_points=points, sample_seed=seed)
    return np.asarray(describe(path, settings).descriptor, dtype=np.float64)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parts", nargs="+", default=list(DEFAULT_PARTS))
    parser.add_argument("--budgets", nargs="+", type=int, default=[3000, 5000, 10000])
    args = parser.parse_args(argv)
    from core.eigen import pin_blas_threads

    started = time.perf_counter()
    budgets = sorted(set(args.budgets) | {REFERENCE})
    paths = {stem: part_path(stem) for stem in args.parts}
    with pin_blas_threads():
        spectra = {(s, b): low_spectrum(p, b) for s, p in paths.items() for b in budgets}
        vectors = {(s, b): descriptor(p, b) for s, p in paths.items() for b in budgets}
        resampled = {(s, b): descriptor(p, b, seed=1) for s, p in paths.items() for b in budgets}
    print(f"{'part':<18} {'points':>6} {'spacing/wall':>12} {'dlambda med':>11} "
          f"{'dlambda max':>11} {'d(to 20k)':>9} {'d(seed 0-1)':>11} {'d(nearest other)':>16}")
    for stem, path in paths.items():
        for budget in budgets:
            change = np.abs(spectra[stem, budget] / spectra[stem, REFERENCE] - 1)
            others = [np.linalg.norm(vectors[stem, budget] - vectors[o, budget])
                      for o in paths if o != stem]
            print(
                f"{stem:<18} {budget:>6} {spacing_over_thickness(path, budget):12.2f} "
                f"{np.median(change):11.3f} {change.max():11.3f} "
                f"{np.linalg.norm(vectors[stem, budget] - vectors[stem, REFERENCE]):9.3f} "
                f"{np.linalg.norm(vectors[stem, budget] - resampled[stem, budget]):11.3f} "
                f"{min(others) if others else float('nan'):16.3f}",
                flush=True,
            )
    print(f"({time.perf_counter() - started:.0f} s wall)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
