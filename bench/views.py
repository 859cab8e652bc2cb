"""Benchmark: the ingest cost of scan mode's virtual views against a plain describe.

Per model (every loadable part of /work/shared/datasets/parts and a seeded sample of capod),
in this one process with BLAS pinned to one thread, alternately:

(plain) ``describe(path, EngineSettings())``: what a part cost before scan mode;
(views) ``describe(path, EngineSettings(), views=K, scan=True)``: the part, its scan
        descriptor and K virtual views, from the same loaded points (what the worker runs).

Each is repeated ``--repeat`` times and the per-model median kept. It prints per-model rows,
the median over models of each, the median per-model ratio views/plain and the ratio of the
summed times (the budget: model + views <= 3x a plain describe). CPU seconds are
reported next to wall seconds: on a machine shared with other jobs the wall clock is
stretched by them, CPU seconds much less.

Usage::

    .venv/bin/python -m bench.views                            # K = 3, 4: all parts + 20 capod
    .venv/bin/python -m bench.views --views 2 6 --capod 5 --repeat 1   # quick
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")


from bench.describe import label, model_files  # noqa: E402


def _timed(path: Path, views: int) -> tuple[float, float, int]:
    """Wall and CPU seconds of one describe, and the views it gave."""
    from core.pipeline import describe
    from core.settings import EngineSettings

    start, cpu = time.perf_counter(), time.process_time()
    description = describe(path, EngineSettings(), views=views, scan=views > 0)
    return time.perf_counter() - start, time.process_time() - cpu, len(description.views)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--views", type=int, nargs="+", default=[3, 4])
    parser.add_argument("--capod", type=int, default=20, help="seeded capod sample size")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--models", nargs="*", help="part stems (default: every part)")
    args = parser.parse_args(argv)

    from core.eigen import pin_blas_threads
    from core.errors import InvalidShapeError

    files = model_files(args.models, args.capod, args.seed)
    counts = [0, *args.views]
    rows: dict[int, list[tuple[str, float, float, int]]] = {count: [] for count in counts}
    print(f"{'model':40s} " + " ".join(f"{'K=' + str(c):>14s}" for c in counts) + "  (wall/cpu s)")
    with pin_blas_threads():
        for path in files:
            measured: dict[int, list[tuple[float, float, int]]] = {c: [] for c in counts}
            try:
                for _ in range(args.repeat):
                    for count in counts:  # interleaved: drift in machine load hits all alike
                        measured[count].append(_timed(path, count))
            except InvalidShapeError as error:
                print(f"{label(path):40s} skipped: {error}")
                continue
            cells = []
            for count in counts:
                wall = statistics.median(m[0] for m in measured[count])
                cpu = statistics.median(m[1] for m in measured[count])
                rows[count].append((label(path), wall, cpu, measured[count][0][2]))
                cells.append(f"{wall:6.2f}/{cpu:6.2f}")
            print(f"{label(path):40s} " + " ".join(f"{c:>14s}" for c in cells), flush=True)
    plain = rows[0]
    print(f"\nmodels: {len(plain)}, repeats: {args.repeat}")
    print(f"plain describe: median {statistics.median(r[1] for r in plain):.3f} s wall, "
          f"{statistics.median(r[2] for r in plain):.3f} s cpu")
    for count in args.views:
        mine = rows[count]
        ratios = [m[2] / p[2] for m, p in zip(mine, plain, strict=True)]
        total = sum(m[2] for m in mine) / sum(p[2] for p in plain)
        views = statistics.median(m[3] for m in mine)
        print(f"K={count}: median {statistics.median(r[1] for r in mine):.3f} s wall, "
              f"{statistics.median(r[2] for r in mine):.3f} s cpu; views described (median) "
              f"{views:g}; cpu ratio to plain: median {statistics.median(ratios):.2f}, "
              f"max {max(ratios):.2f}, of the sums {total:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
