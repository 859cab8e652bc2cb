"""Benchmark: describing one part, previous default against the new default, and throughput.

Per model (every loadable part of /work/shared/datasets/parts and a seeded sample of capod),
each measurement in a fresh child process (so its peak RSS is its own), BLAS pinned to one
thread:

(a) the previous default: 20000 points, seeded adaptive cutoff (t = 0.01, xi = 1e-10, seed 50,
    margin 10, n in [80, 500]), described with ``core.pipeline.describe`` on the previous
    solver (banded SuperLU LDLᵀ, ARPACK basis 2k + 1: ``bench.previous_solver``). The
    settings are spelled out here so that (a) stays this baseline when the defaults change;
    the cutoff rule is today's (a function of the spectrum alone), which moves n by a few.
(b) the new default end to end: ``describe(path, EngineSettings())``.
(c) stock ``eigsh(L, 300, M, sigma)`` (``core.eigen.smallest_eigenpairs``) at (b)'s point
    count: the eigen-solve alone, on the same operators the pipeline builds.

It prints per-model rows, medians and the ratios (a)/(b) and (c)/(b) (end to end; (c)/(b)
also against (b)'s own eigen-solve), solver calls, prediction hits (when the cutoff result
records them; printed as "-" otherwise) and peak memory; then parts per minute of the new
default with one worker process, two worker processes, and two threads in one process (does
the GIL let threads scale?). Wall and CPU seconds are both recorded: on a machine shared with
other jobs the wall clock is stretched by them, the CPU seconds of the child much less.

Usage::

    .venv/bin/python -m bench.describe                        # all parts + 30 capod models
    .venv/bin/python -m bench.describe --capod 5 --models angle_block bunny   # quick
    .venv/bin/python -m bench.describe --no-throughput --json rows.json
"""

from __future__ import annotations

import argparse
import json
import os
import random
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from pathlib import Path
from typing import Any

# Pin every BLAS/OpenMP pool before numpy loads (pin_blas_threads pins again).
for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

from bench._common import REPO, peak_rss_mb  # noqa: E402
from core.evaluation.sources import SHARED  # noqa: E402

PARTS = SHARED / "parts"
CAPOD = SHARED / "capod"
SUFFIXES = {".stl", ".ply", ".obj", ".off"}
STOCK_COUNT = 300
KINDS = ("a", "b", "c")


def previous_default() -> Any:
    """(a): the engine defaults before the point budget was chosen by measurement."""
    from core.settings import CutoffSettings, EngineSettings

    return EngineSettings(
        max_points=20000,
        cutoff=CutoffSettings(
            mode="adaptive", xi=1e-10, t=1e-2, seed=50, n_min=80, n_max=500, margin=10
        ),
    )


def model_files(parts: list[str] | None, capod: int, seed: int) -> list[Path]:
    """Loadable parts (by stem when ``parts`` is given) and a seeded sample of capod models."""
    files = sorted(p for p in PARTS.iterdir() if p.suffix.lower() in SUFFIXES)
    if parts is not None:
        files = [p for p in files if p.stem in parts]
    if capod and CAPOD.is_dir():
        pool = sorted(p for p in CAPOD.glob("*/*") if p.suffix.lower() in SUFFIXES)
        files += sorted(random.Random(seed).sample(pool, min(capod, len(pool))))
    return files


def label(path: Path) -> str:
    return f"{path.parent.name}/{path.name}" if path.parent != PARTS else path.stem


def _prediction(cutoff: Any) -> bool | None:
    """Whether a predicted n held (None: no prediction, the seed round ran; this bench
    describes each part as into an empty database; ``bench/eigensolve.py --predict``
    measures the predicted path)."""
    return cutoff.prediction_held


def measure(kind: str, path: Path) -> dict[str, Any]:
    """One measurement of one model (run in a fresh process by ``spawn``)."""
    from core.eigen import pin_blas_threads, smallest_eigenpairs
    from core.io import load_points
    from core.pipeline import describe, normalised_operators
    from core.settings import EngineSettings

    row: dict[str, Any] = {"model": label(path), "kind": kind}
    with pin_blas_threads():
        if kind in ("a", "b"):
            if kind == "a":
                from bench.previous_solver import use_previous_solver

                use_previous_solver()
            settings = previous_default() if kind == "a" else EngineSettings()
            start, cpu = time.perf_counter(), time.process_time()
            description = describe(path, settings)
            row["seconds"] = time.perf_counter() - start
            row["cpu_s"] = time.process_time() - cpu
            row["eigensolve_s"] = description.timings.get("eigensolve", float("nan"))
            row["points"] = description.n_points
            row["n"] = int(description.cutoff.n)
            row["calls"] = int(description.cutoff.solver_calls)
            row["prediction"] = _prediction(description.cutoff)
        else:
            settings = EngineSettings()
            shape = load_points(path, max_points=settings.max_points,
                                min_points=settings.min_points, seed=settings.sample_seed)
            _, stiffness, mass = normalised_operators(shape.points, settings)
            count = min(STOCK_COUNT, mass.shape[0] - 2)
            start, cpu = time.perf_counter(), time.process_time()
            smallest_eigenpairs(stiffness, mass, count)
            row["seconds"] = time.perf_counter() - start
            row["cpu_s"] = time.process_time() - cpu
            row["points"] = int(mass.shape[0])
            row["n"] = count
    row["peak_mb"] = peak_rss_mb()
    return row


def spawn(kind: str, path: Path) -> dict[str, Any]:
    """``measure`` in a child process; a failure becomes a row with ``error``."""
    command = [sys.executable, "-m", "bench.describe", "--measure", kind, str(path)]
    done = subprocess.run(command, capture_output=True, text=True, check=False, cwd=REPO)
    if done.returncode != 0:
        return {"model": label(path), "kind": kind, "error": done.stderr.strip()[-300:]}
    return json.loads(done.stdout.strip().splitlines()[-1])


def _fmt(value: Any, spec: str) -> str:
    return "-" if value is None else format(value, spec)


def print_model(rows: dict[str, dict[str, Any]]) -> None:
    a, b, c = (rows[k] for k in KINDS)
    name = a["model"]
    errors = [f"({k}) {r['error'].splitlines()[-1]}" for k, r in rows.items() if "error" in r]
    if errors:
        print(f"{name:<28} ERROR {'; '.join(errors)}", flush=True)
        return
    print(
        f"{name:<28} (a) {a['points']:>6} pts n={a['n']:>3} calls={a['calls']} "
        f"{a['seconds']:6.2f}s {a['peak_mb']:5.0f}MB | (b) {b['points']:>6} pts n={b['n']:>3} "
        f"calls={b['calls']} pred={_fmt(b['prediction'], '')} {b['seconds']:6.2f}s "
        f"(eig {b['eigensolve_s']:5.2f}s) {b['peak_mb']:5.0f}MB | (c) stock {c['n']} "
        f"{c['seconds']:6.2f}s {c['peak_mb']:5.0f}MB | a/b {a['seconds'] / b['seconds']:5.1f}x"
        f" (CPU s a {a['cpu_s']:.2f} b {b['cpu_s']:.2f} c {c['cpu_s']:.2f})",
        flush=True,
    )


def summarise(title: str, models: list[dict[str, dict[str, Any]]]) -> None:
    done = [m for m in models if not any("error" in r for r in m.values())]
    if not done:
        print(f"\n{title}: no model finished")
        return

    def median(kind: str, key: str) -> float:
        return statistics.median(m[kind][key] for m in done)

    def ratio(top: Callable[[dict], float], bottom: Callable[[dict], float]) -> float:
        return statistics.median(top(m) / bottom(m) for m in done)

    predictions = [m["b"]["prediction"] for m in done if m["b"].get("prediction") is not None]
    print(
        f"\n{title}: {len(done)} models ({len(models) - len(done)} failed)\n"
        f"  (a) previous default: median {median('a', 'seconds'):.2f} s, points "
        f"{median('a', 'points'):.0f}, n {median('a', 'n'):.0f}, calls mean "
        f"{statistics.mean(m['a']['calls'] for m in done):.2f}, peak "
        f"{median('a', 'peak_mb'):.0f} MB (max {max(m['a']['peak_mb'] for m in done):.0f})\n"
        f"  (b) new default:      median {median('b', 'seconds'):.2f} s (eigen-solve "
        f"{median('b', 'eigensolve_s'):.2f} s), points {median('b', 'points'):.0f}, n "
        f"{median('b', 'n'):.0f}, calls mean {statistics.mean(m['b']['calls'] for m in done):.2f},"
        f" peak {median('b', 'peak_mb'):.0f} MB (max {max(m['b']['peak_mb'] for m in done):.0f})"
        f", prediction: {predictions or 'none (cold database)'}\n"
        f"  (c) stock eigsh {STOCK_COUNT}: median {median('c', 'seconds'):.2f} s, peak "
        f"{median('c', 'peak_mb'):.0f} MB\n"
        f"  ratios (median of per-model ratios): (a)/(b) "
        f"{ratio(lambda m: m['a']['seconds'], lambda m: m['b']['seconds']):.1f}x, (c)/(b) "
        f"{ratio(lambda m: m['c']['seconds'], lambda m: m['b']['seconds']):.2f}x end to end, "
        f"(c)/(b eigen-solve) "
        f"{ratio(lambda m: m['c']['seconds'], lambda m: m['b']['eigensolve_s']):.2f}x\n"
        f"  CPU seconds (robust on a shared machine): (a) {median('a', 'cpu_s'):.2f}, (b) "
        f"{median('b', 'cpu_s'):.2f}, (c) {median('c', 'cpu_s'):.2f}; (a)/(b) "
        f"{ratio(lambda m: m['a']['cpu_s'], lambda m: m['b']['cpu_s']):.1f}x, (c)/(b) "
        f"{ratio(lambda m: m['c']['cpu_s'], lambda m: m['b']['cpu_s']):.2f}x",
        flush=True,
    )


# -- throughput --------------------------------------------------------------------------------


def _describe_default(path: str) -> float:
    """One new-default describe; returns the CPU seconds of the calling thread."""
    from core.eigen import pin_blas_threads
    from core.pipeline import describe

    start = time.thread_time()
    with pin_blas_threads():
        describe(path)
    return time.thread_time() - start


def _warm() -> int:
    """Import the engine in a pool worker before the clock starts."""
    import core.pipeline  # noqa: F401

    return os.getpid()


def run_batch(files: list[Path], workers: int, mode: str) -> tuple[float, float]:
    """New-default describes of ``files`` with ``workers`` processes or threads.

    Returns parts per minute and the parallelism achieved: CPU seconds of the describes
    (per thread, so a thread blocked on the GIL is not counted) over wall seconds. On an idle
    machine two workers that really run in parallel reach ~2; on a machine shared with other
    jobs the wall clock is stretched for everyone, but workers serialised by the GIL still
    stay at ~1 whatever the load.
    """
    paths = [str(p) for p in files]
    if mode == "processes":
        import multiprocessing

        context = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(workers, mp_context=context) as pool:
            for future in [pool.submit(_warm) for _ in range(workers)]:
                future.result()
            start = time.perf_counter()
            cpu = sum(pool.map(_describe_default, paths))
            seconds = time.perf_counter() - start
    else:
        from core.eigen import pin_blas_threads

        _warm()
        # Process-wide pin, as the service does once per process (limits are not per thread).
        with pin_blas_threads(), ThreadPoolExecutor(workers) as pool:
            start = time.perf_counter()
            cpu = sum(pool.map(_describe_default, paths))
            seconds = time.perf_counter() - start
    return 60.0 * len(paths) / seconds, cpu / seconds


def throughput(files: list[Path]) -> None:
    print(f"\nthroughput of the new default on {len(files)} models ({os.cpu_count()} cores;"
          f" load average {os.getloadavg()[0]:.1f} at the start):", flush=True)
    rates: dict[str, float] = {}
    for name, workers, mode in (("1 worker process", 1, "processes"),
                                ("2 worker processes", 2, "processes"),
                                ("2 threads, one process", 2, "threads")):
        rate, parallelism = run_batch(files, workers, mode)
        rates[name] = rate
        print(f"  {name:<24} {rate:6.1f} parts/min ({rate / rates['1 worker process']:.2f}x),"
              f" parallelism (describe CPU s / wall s) {parallelism:.2f}", flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="*", default=None,
                        help="part file stems (default: every loadable part)")
    parser.add_argument("--capod", type=int, default=30, help="capod models sampled (seeded)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the capod sample")
    parser.add_argument("--no-throughput", action="store_true")
    parser.add_argument("--throughput-models", type=int, default=12,
                        help="models of the throughput runs (the first N measured)")
    parser.add_argument("--throughput-only", action="store_true",
                        help="skip (a)-(c); only the throughput runs")
    parser.add_argument("--json", type=Path, help="also write every row to this file")
    parser.add_argument("--measure", nargs=2, metavar=("KIND", "PATH"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.measure:
        print(json.dumps(measure(args.measure[0], Path(args.measure[1]))))
        return 0
    from core.settings import EngineSettings

    print(f"(a) previous default: {previous_default().max_points} points, seeded adaptive cutoff;"
          f" (b) new default: {EngineSettings().max_points} points; (c) stock eigsh "
          f"{STOCK_COUNT} at (b)'s points. One child process per measurement, BLAS 1 thread.",
          flush=True)
    results: list[dict[str, dict[str, Any]]] = []
    files = model_files(args.models, args.capod, args.seed)
    if args.throughput_only:
        throughput(files[: args.throughput_models])
        return 0
    for path in files:
        rows = {kind: spawn(kind, path) for kind in KINDS}
        results.append(rows)
        print_model(rows)
    is_part = [m["a"]["model"].count("/") == 0 for m in results]
    summarise("parts", [m for m, part in zip(results, is_part, strict=True) if part])
    summarise("capod sample", [m for m, part in zip(results, is_part, strict=True) if not part])
    summarise("all", results)
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))
    if not args.no_throughput:
        loadable = [p for p, m in zip(files, results, strict=True)
                    if not any("error" in r for r in m.values())]
        throughput(loadable[: args.throughput_models])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
