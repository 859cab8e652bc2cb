"""Benchmark: what the descriptor's blocks cost per part, against the default's earlier
blocks, in one run.

Every loadable part of the shared parts folder and a seeded sample of capod is described end
to end (``core.pipeline.describe``) with the blocks the default had before the local, ring
and caps blocks
(``pre-24``: the spectral blocks, D2, D1, normals and symmetry as today, without the local,
ring and caps blocks and the shortened runs; ``ss4``, the layout of that time, also had
spread and axis-offset blocks, which the engine no longer has), the intrinsic ``spectral``
layout, the layout before today's (``ss11``: the part's runs of one cross-section as they
are), the present default and the ``bendable`` family, interleaved per part (so drifting
machine load falls on all alike), ``--repeats`` times; BLAS pinned to one thread. Prints
per-kind medians of wall and CPU seconds, the ratios to ``pre-24`` and the descriptor widths
(index memory and exact-search time grow with the width)::

    .venv/bin/python -m bench.descriptor_cost [--capod 12] [--repeats 3]
"""

from __future__ import annotations

import argparse
import os
import random
import statistics
import time
from dataclasses import replace
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

from core.errors import InvalidShapeError  # noqa: E402
from core.evaluation.sources import SHARED  # noqa: E402
from core.evaluation.variants import SPECTRAL_DESCRIPTOR, SS11_DESCRIPTOR  # noqa: E402
from core.pipeline import describe  # noqa: E402
from core.settings import DESCRIPTOR_FAMILIES, EngineSettings  # noqa: E402

SUFFIXES = {".stl", ".ply", ".obj", ".off"}
BASELINE = "pre-24"
KINDS = {
    BASELINE: EngineSettings(descriptor=replace(
        SS11_DESCRIPTOR, local_weight=0.0, ring_weight=0.0, caps_weight=0.0)),
    "spectral": EngineSettings(descriptor=SPECTRAL_DESCRIPTOR),
    "ss11": EngineSettings(descriptor=SS11_DESCRIPTOR),
    "default": EngineSettings(),
    "bendable": EngineSettings(descriptor=DESCRIPTOR_FAMILIES["bendable"]),
}


def models(capod: int, seed: int) -> list[Path]:
    parts = sorted(p for p in (SHARED / "parts").iterdir() if p.suffix.lower() in SUFFIXES)
    objects = sorted((SHARED / "capod").glob("*/*.obj"))
    return parts + random.Random(seed).sample(objects, min(capod, len(objects)))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--capod", type=int, default=12)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    wall: dict[str, list[float]] = {kind: [] for kind in KINDS}
    cpu: dict[str, list[float]] = {kind: [] for kind in KINDS}
    widths: dict[str, int] = {}
    for path in models(args.capod, args.seed):
        for _ in range(args.repeats):
            for kind, settings in KINDS.items():
                started, started_cpu = time.perf_counter(), time.process_time()
                try:
                    description = describe(path, settings)
                except InvalidShapeError:
                    break
                wall[kind].append(time.perf_counter() - started)
                cpu[kind].append(time.process_time() - started_cpu)
                widths[kind] = description.descriptor.size
    load = os.getloadavg()[0]
    print(f"{len(wall[BASELINE])} describes per kind; load average {load:.2f}")
    print(f"| kind | width | wall median s | CPU median s | wall / {BASELINE} | CPU / {BASELINE} |")
    print("|---|---|---|---|---|---|")
    base_wall, base_cpu = statistics.median(wall[BASELINE]), statistics.median(cpu[BASELINE])
    for kind in KINDS:
        w, c = statistics.median(wall[kind]), statistics.median(cpu[kind])
        print(f"| {kind} | {widths[kind]} | {w:.3f} | {c:.3f} | {w / base_wall:.2f} | "
              f"{c / base_cpu:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
