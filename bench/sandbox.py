"""What the describe sandbox costs the worker per file (``app/ingest/sandbox.py``).

Every upload is parsed and described in a fresh child of a forkserver, which first lets
OpenBLAS allocate its work buffers (``_warm_blas``) and then sets the memory limit. Prints,
over ``--repeats`` rounds of every part in ``tests/fixtures/parts``, the median seconds of

- the production handler, in its sandbox (``app.jobs.worker.describe_handler``);
- the same work in this process (``ingest_columns``: the baseline of the same run);
- a sandboxed call that does nothing (the child's start, warm-up and teardown);
- the warm-up alone, in this process;

and the ratios of the sandbox's and the warm-up's cost to the in-process describe.

    .venv/bin/python -m bench.sandbox [--repeats 3]
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from collections.abc import Callable
from functools import partial

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

from bench._common import PARTS  # noqa: E402


def nothing() -> None:
    return None


def median_seconds(call: Callable[[], object], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        call()
        times.append(time.perf_counter() - started)
    return statistics.median(times)


def main() -> int:
    # Imported here, not at the top: every sandboxed child re-runs this module's top level
    # (multiprocessing prepares a child from the parent's main module), as the service's
    # children re-run the small ``shapesearch`` script; the timings stay the service's.
    from app.ingest.describing import ingest_columns, pin_blas_threads
    from app.ingest.sandbox import _warm_blas, sandbox_of
    from app.jobs.worker import describe_handler, engine_settings
    from app.settings import Settings
    from core.errors import InvalidShapeError

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        settings = Settings(database_url=f"sqlite:///{folder}/bench.sqlite")
        handler = describe_handler(settings)
        engine = engine_settings(settings)
        pin_blas_threads()
        files = [(path.read_bytes(), path.name) for path in sorted(PARTS.iterdir())
                 if path.suffix.lower() in {".stl", ".ply", ".obj", ".off"}]
        sandboxed, in_process = [], []
        for data, name in files:
            try:
                handler(data, name)  # and a first, unmeasured run
            except InvalidShapeError:  # refused by design (a five-point cloud): not timed
                continue
            sandboxed.append(median_seconds(partial(handler, data, name), args.repeats))
            in_process.append(median_seconds(partial(ingest_columns, data, name, engine),
                                             args.repeats))
        empty = sandbox_of(settings, settings.describe_timeout_seconds)
        start = median_seconds(lambda: empty.run(nothing), 5 * args.repeats)
        warm = median_seconds(_warm_blas, 5 * args.repeats)
    own, boxed = statistics.median(in_process), statistics.median(sandboxed)
    print(f"{len(in_process)} parts x {args.repeats}: describe in the sandbox median "
          f"{boxed:.3f} s, in this process {own:.3f} s ({boxed / own:.2f}x)")
    print(f"an empty sandboxed call {1000 * start:.1f} ms ({start / own:.3f}x a describe); "
          f"the BLAS warm-up alone {1000 * warm:.2f} ms ({warm / own:.4f}x)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
