"""Benchmark: stock fixed-300 eigsh vs banded SpectralSolver vs the adaptive descriptor.

For each part of /work/shared/datasets/parts and each point count, in a fresh worker process
(so that peak RSS is per run), with BLAS pinned to one thread:

(a) stock  ``scipy.sparse.linalg.eigsh(L, 300, M, sigma=<small negative>)``, default settings;
(b) banded ``SpectralSolver(L, M).solve(300)``;
(c) adaptive ``core.pipeline.describe(path, EngineSettings(max_points=N))`` end to end
    (load, Laplacian, adaptive cutoff eigensolve, signatures, descriptor).

The worker runs (c) first and reads the peak RSS right after it, so that figure is the
adaptive descriptor's own peak; the later peaks include (b) and (a).

``--compare`` instead times, on the same (L, M) and at the same n (the adaptive cutoff's n),
the previous banded solver (SuperLU LDL^T per shift, ARPACK basis 2k + 1), the current one
(QDLDL LDL^T per shift, basis 1.5k)
and stock ``eigsh(L, n, M, sigma)``, interleaved and repeated (the medians are printed).

``--predict`` describes every part twice at each point count: seeded, then with a cutoff
predictor fitted on all the other parts (leave one out); it prints prediction hits, solver
calls and eigen-solve seconds of both paths, and checks that n is the same.

Usage::

    .venv/bin/python -m bench.eigensolve                 # all parts, 20k and 50k points
    .venv/bin/python -m bench.eigensolve --quick         # 3 parts, 20k points
    .venv/bin/python -m bench.eigensolve --points 20000 --models bunny teapot
    nice -n 10 .venv/bin/python -m bench.eigensolve --compare --points 3000 5000 20000 \
        --models angle_block bunny teapot plate_holes cycloidal
    nice -n 10 .venv/bin/python -m bench.eigensolve --compare --repeats 1 --points 20000
    nice -n 10 .venv/bin/python -m bench.eigensolve --predict --points 3000
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

# Pin every BLAS/OpenMP pool before numpy loads (threadpoolctl below pins again).
for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

from bench._common import REPO, peak_rss_mb  # noqa: E402
from core.evaluation.sources import SHARED  # noqa: E402

PARTS = SHARED / "parts"
MESH_SUFFIXES = {".stl", ".ply", ".obj", ".off"}
QUICK_MODELS = ("angle_block", "bunny", "teapot")
FIXED_COUNT = 300


def part_files(selected: list[str] | None) -> list[Path]:
    """The part files to run, by stem (all mesh and point files when ``selected`` is None)."""
    files = sorted(path for path in PARTS.iterdir() if path.suffix.lower() in MESH_SUFFIXES)
    if selected:
        files = [path for path in files if path.stem in selected]
    return files


def run_worker(path: Path, max_points: int) -> dict:
    """All three measurements for one part at one point count (runs in a fresh process)."""
    from scipy.sparse.linalg import eigsh

    from core.eigen import SpectralSolver, default_shift, pin_blas_threads
    from core.io import load_points
    from core.laplacian import build_laplacian
    from core.normalise import centre, unit_area_mass
    from core.pipeline import describe
    from core.settings import EngineSettings

    result: dict = {"model": path.stem, "max_points": max_points}
    with pin_blas_threads():
        start = time.perf_counter()
        description = describe(path, EngineSettings(max_points=max_points))
        result["adaptive_total_s"] = time.perf_counter() - start
        result["adaptive_eigensolve_s"] = description.timings.get("eigensolve")
        result["adaptive_laplacian_s"] = description.timings.get("laplacian")
        result["adaptive_n"] = description.cutoff.n
        result["adaptive_calls"] = description.cutoff.solver_calls
        result["adaptive_peak_mb"] = peak_rss_mb()

        # Same points and normalisation as the pipeline, for (a) and (b).
        points = centre(load_points(path, max_points=max_points).points)
        start = time.perf_counter()
        stiffness, mass = build_laplacian(points)
        result["laplacian_s"] = time.perf_counter() - start
        points, mass = unit_area_mass(points, mass)
        result["points"] = int(points.shape[0])

        start = time.perf_counter()
        solver = SpectralSolver(stiffness, mass)
        banded_values, _ = solver.solve(FIXED_COUNT)
        result["banded_s"] = time.perf_counter() - start
        result["banded_calls"] = solver.solver_calls_
        result["banded_bands"] = len(solver.bands_)
        result["banded_factorisations"] = solver.factorisations_
        result["banded_factor_s"] = sum(band.factor_seconds for band in solver.bands_)
        result["banded_retries"] = sum(band.attempts - 1 for band in solver.bands_)
        result["banded_peak_mb"] = peak_rss_mb()

        start = time.perf_counter()
        stock_values = np.sort(
            eigsh(stiffness, FIXED_COUNT, mass, sigma=default_shift(mass), which="LM")[0]
        )
        result["stock_s"] = time.perf_counter() - start
        result["stock_peak_mb"] = peak_rss_mb()
        result["max_relative_difference"] = float(
            np.max(np.abs(banded_values - stock_values) / np.maximum(stock_values[-1], 1e-300))
        )
    return result


def run_compare(path: Path, max_points: int, repeats: int = 3) -> dict:
    """Old banded vs new banded vs stock at the adaptive n, on the same operators."""
    from scipy.sparse.linalg import eigsh

    import core.eigen._factor as factor_module
    import core.eigen._solver as solver_module
    from bench.previous_solver import PREVIOUS_BASIS_FACTOR, superlu_ldl
    from core.cutoff import make_cutoff
    from core.eigen import SpectralSolver, default_shift, pin_blas_threads
    from core.io import load_points
    from core.pipeline import normalised_operators
    from core.settings import EngineSettings

    settings = EngineSettings(max_points=max_points)
    points = load_points(path, max_points=max_points, seed=settings.sample_seed).points
    result: dict = {"model": path.stem, "max_points": max_points, "mode": "compare"}
    new_ldl, new_basis = factor_module._symmetric_ldl, solver_module._BASIS_FACTOR
    with pin_blas_threads():
        start = time.perf_counter()
        _, stiffness, mass = normalised_operators(points, settings)
        result["laplacian_s"] = time.perf_counter() - start
        result["points"] = int(stiffness.shape[0])
        solver = SpectralSolver(stiffness, mass)
        cutoff = make_cutoff(settings.cutoff).select(solver)
        count = cutoff.n
        result["n"], result["adaptive_calls"] = count, cutoff.solver_calls
        times: dict[str, list[float]] = {"old": [], "new": [], "stock": []}
        values: dict[str, np.ndarray] = {}
        for _ in range(repeats):
            for name in ("old", "new"):
                # The previous solver: SuperLU LDL^T and ARPACK's default basis (2k + 1).
                factor_module._symmetric_ldl = superlu_ldl if name == "old" else new_ldl
                solver_module._BASIS_FACTOR = PREVIOUS_BASIS_FACTOR if name == "old" else new_basis
                try:
                    start = time.perf_counter()
                    values[name] = SpectralSolver(stiffness, mass).solve(count)[0]
                    times[name].append(time.perf_counter() - start)
                finally:
                    factor_module._symmetric_ldl = new_ldl
                    solver_module._BASIS_FACTOR = new_basis
            start = time.perf_counter()
            stock = eigsh(stiffness, count, mass, sigma=default_shift(mass), which="LM")[0]
            times["stock"].append(time.perf_counter() - start)
            values["stock"] = np.sort(stock)
    for name, seconds in times.items():
        result[f"{name}_s"] = statistics.median(seconds)
    scale = values["stock"][-1]
    result["max_rel_new_vs_stock"] = float(np.max(np.abs(values["new"] - values["stock"])) / scale)
    result["max_rel_new_vs_old"] = float(np.max(np.abs(values["new"] - values["old"])) / scale)
    return result


def print_compare(row: dict) -> None:
    if "error" in row:
        print(f"{row['model']:<22} {row['max_points']:>6}  ERROR {row['error'].splitlines()[-1]}")
        return
    print(
        f"{row['model']:<22} {row['points']:>6} n={row['n']:>3} laplacian "
        f"{row['laplacian_s']:5.2f}s  old banded {row['old_s']:6.2f}s  new {row['new_s']:6.2f}s  "
        f"stock {row['stock_s']:6.2f}s  old/new {row['old_s'] / row['new_s']:4.2f}x  "
        f"stock/new {row['stock_s'] / row['new_s']:4.2f}x  max|dl|/l_n new-stock "
        f"{row['max_rel_new_vs_stock']:.1e} new-old {row['max_rel_new_vs_old']:.1e}",
        flush=True,
    )


def print_compare_summary(rows: list[dict], max_points: int) -> None:
    done = [row for row in rows if "error" not in row and row["max_points"] == max_points]
    if not done:
        return

    def median(key: str) -> float:
        return statistics.median(row[key] for row in done)

    print(
        f"\nmedians at max_points={max_points} over {len(done)} models (n {median('n'):.0f}): "
        f"laplacian {median('laplacian_s'):.2f}s, old banded {median('old_s'):.2f}s, new "
        f"{median('new_s'):.2f}s, stock {median('stock_s'):.2f}s; ratios old/new "
        f"{statistics.median(row['old_s'] / row['new_s'] for row in done):.2f}x, stock/new "
        f"{statistics.median(row['stock_s'] / row['new_s'] for row in done):.2f}x",
        flush=True,
    )


def run_predict(paths: list[Path], max_points: int) -> None:
    """Seeded vs leave-one-out predicted cutoff on every part, in this process."""
    from core.cutoff_predictor import CutoffPredictor
    from core.eigen import pin_blas_threads
    from core.pipeline import describe
    from core.settings import EngineSettings

    settings = EngineSettings(max_points=max_points)
    seeded = {}
    with pin_blas_threads():
        for path in paths:
            try:
                seeded[path.stem] = describe(path, settings)
            except Exception as error:  # an edge case the engine refuses: not this bench's job
                print(f"{path.stem:<22} skipped: {error}", flush=True)
        names = list(seeded)
        features = np.array([seeded[name].features for name in names])
        counts = np.array([seeded[name].cutoff.n for name in names])
        rows = []
        for index, name in enumerate(names):
            others = np.arange(len(names)) != index
            predictor = CutoffPredictor().fit(features[others], counts[others])
            path = next(path for path in paths if path.stem == name)
            predicted = describe(path, settings, predictor=predictor)
            before = seeded[name]
            rows.append(
                {
                    "n": before.cutoff.n,
                    "same_n": predicted.cutoff.n == before.cutoff.n,
                    "prediction": predicted.cutoff.prediction,
                    "held": bool(predicted.cutoff.prediction_held),
                    "seeded_calls": before.cutoff.solver_calls,
                    "predicted_calls": predicted.cutoff.solver_calls,
                    "seeded_s": before.timings["eigensolve"],
                    "predicted_s": predicted.timings["eigensolve"],
                }
            )
            row = rows[-1]
            print(
                f"{name:<22} n={row['n']:>3} prediction {row['prediction']:>3} "
                f"held={row['held']!s:<5} same n={row['same_n']!s:<5} calls seeded "
                f"{row['seeded_calls']} predicted {row['predicted_calls']}  eigensolve "
                f"{row['seeded_s']:.2f}s -> {row['predicted_s']:.2f}s",
                flush=True,
            )
    if rows:
        print(
            f"\n{max_points} points, {len(rows)} parts: prediction held "
            f"{sum(row['held'] for row in rows)}/{len(rows)}, same n "
            f"{sum(row['same_n'] for row in rows)}/{len(rows)}, mean calls seeded "
            f"{statistics.mean(row['seeded_calls'] for row in rows):.2f} predicted "
            f"{statistics.mean(row['predicted_calls'] for row in rows):.2f}, median eigensolve "
            f"seeded {statistics.median(row['seeded_s'] for row in rows):.2f}s predicted "
            f"{statistics.median(row['predicted_s'] for row in rows):.2f}s",
            flush=True,
        )


def spawn_worker(path: Path, max_points: int, compare: bool = False, repeats: int = 3) -> dict:
    """Run ``run_worker`` (or ``run_compare``) in a child process and return its JSON result."""
    command = [sys.executable, "-m", "bench.eigensolve", "--worker", str(path), str(max_points)]
    command += ["--compare", "--repeats", str(repeats)] if compare else []
    completed = subprocess.run(command, capture_output=True, text=True, check=False, cwd=REPO)
    if completed.returncode != 0:
        return {"model": path.stem, "max_points": max_points, "error": completed.stderr[-400:]}
    return json.loads(completed.stdout.strip().splitlines()[-1])


def print_row(row: dict) -> None:
    if "error" in row:
        print(f"{row['model']:<22} {row['max_points']:>6}  ERROR {row['error'].splitlines()[-1]}")
        return
    print(
        f"{row['model']:<22} {row['points']:>6} "
        f"stock300 {row['stock_s']:7.2f}s  banded300 {row['banded_s']:7.2f}s "
        f"({row['banded_bands']} bands, {row['banded_factorisations']} fact "
        f"{row['banded_factor_s']:.2f}s, {row['banded_retries']} retries)  "
        f"adaptive n={row['adaptive_n']:>3} calls={row['adaptive_calls']} "
        f"eig {row['adaptive_eigensolve_s']:6.2f}s total {row['adaptive_total_s']:6.2f}s  "
        f"stock/banded {row['stock_s'] / row['banded_s']:5.2f}x  "
        f"stock/adaptive-eig {row['stock_s'] / row['adaptive_eigensolve_s']:5.2f}x  "
        f"peak adaptive {row['adaptive_peak_mb']:6.0f} MB  max |dlambda|/lambda_max "
        f"{row['max_relative_difference']:.1e}",
        flush=True,
    )


def print_summary(rows: list[dict], max_points: int) -> None:
    done = [row for row in rows if "error" not in row and row["max_points"] == max_points]
    if not done:
        return

    def median(key: str) -> float:
        return statistics.median(row[key] for row in done)

    stock_over_banded = statistics.median(row["stock_s"] / row["banded_s"] for row in done)
    stock_over_adaptive = statistics.median(
        row["stock_s"] / row["adaptive_eigensolve_s"] for row in done
    )
    # End to end: a fixed-300 descriptor costs at least Laplacian + stock solve.
    fixed_over_adaptive_total = statistics.median(
        (row["laplacian_s"] + row["stock_s"]) / row["adaptive_total_s"] for row in done
    )
    print(
        f"\nmedians at max_points={max_points} over {len(done)} models: "
        f"points {median('points'):.0f}, stock300 {median('stock_s'):.2f}s, "
        f"banded300 {median('banded_s'):.2f}s, adaptive eigensolve "
        f"{median('adaptive_eigensolve_s'):.2f}s (n={median('adaptive_n'):.0f}, calls "
        f"{median('adaptive_calls'):.0f}), adaptive total {median('adaptive_total_s'):.2f}s\n"
        f"  ratio stock/banded {stock_over_banded:.2f}x, stock/adaptive-eigensolve "
        f"{stock_over_adaptive:.2f}x, (laplacian+stock)/adaptive-total "
        f"{fixed_over_adaptive_total:.2f}x\n"
        f"  peak RSS adaptive: median {median('adaptive_peak_mb'):.0f} MB, max "
        f"{max(row['adaptive_peak_mb'] for row in done):.0f} MB; whole worker max "
        f"{max(row['stock_peak_mb'] for row in done):.0f} MB",
        flush=True,
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, nargs="+", default=[20000, 50000])
    parser.add_argument("--models", nargs="+", help="part file stems (default: all)")
    parser.add_argument("--quick", action="store_true", help="3 models, 20k points")
    parser.add_argument("--compare", action="store_true", help="old vs new banded vs stock")
    parser.add_argument("--predict", action="store_true", help="seeded vs predicted cutoff")
    parser.add_argument("--repeats", type=int, default=3, help="--compare repeats per solver")
    parser.add_argument("--json", type=Path, help="also write the rows to this file")
    parser.add_argument("--worker", nargs=2, metavar=("PATH", "POINTS"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        path, points = Path(args.worker[0]), int(args.worker[1])
        row = run_compare(path, points, args.repeats) if args.compare else run_worker(path, points)
        print(json.dumps(row))
        return 0
    if args.quick:
        args.models, args.points = list(QUICK_MODELS), [20000]
    if args.predict:
        for max_points in args.points:
            print(f"== max_points {max_points}: seeded vs leave-one-out predicted cutoff")
            run_predict(part_files(args.models), max_points)
        return 0
    rows: list[dict] = []
    for max_points in args.points:
        print(f"== max_points {max_points} (BLAS 1 thread, one worker process per run)")
        for path in part_files(args.models):
            row = spawn_worker(path, max_points, args.compare, args.repeats)
            rows.append(row)
            (print_compare if args.compare else print_row)(row)
        (print_compare_summary if args.compare else print_summary)(rows, max_points)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
