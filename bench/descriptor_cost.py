"""Benchmark: what the local, ring and caps blocks of issue 24 cost per part, against ``ss4``
in one run.

Every loadable part of the shared parts folder and a seeded sample of capod is described end
to end (``core.pipeline.describe``) with the default before issue 24 (``ss4``: no local
block), its first default (``ss5``: no ring block), its second (``ss6``: no caps block), its
third (``ss7``: the caps block along the principal axes alone), its fourth (``ss8``: the
ring block's shells the area tertiles), its fifth (``ss9``: D2 and D1 of the sample as it
is), its sixth (``ss10``: every block weighed by the sample's areas), its seventh
(``ss11``: the part's runs of one cross-section as they are), the present default and the
``bendable`` family,
interleaved per part (so drifting machine load falls on all alike), ``--repeats`` times;
BLAS pinned to one thread. Prints per-kind medians of wall and CPU seconds, the ratios to
``ss4`` and the descriptor widths (index memory and exact-search time grow with the
width)::

    .venv/bin/python bench/descriptor_cost.py [--capod 12] [--repeats 3]
"""

from __future__ import annotations

import argparse
import os
import random
import statistics
import time
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

from core.errors import InvalidShapeError  # noqa: E402
from core.evaluation.sources import SHARED  # noqa: E402
from core.evaluation.variants import (  # noqa: E402
    SS4_DESCRIPTOR,
    SS5_DESCRIPTOR,
    SS6_DESCRIPTOR,
    SS7_DESCRIPTOR,
    SS8_DESCRIPTOR,
    SS9_DESCRIPTOR,
    SS10_DESCRIPTOR,
    SS11_DESCRIPTOR,
)
from core.pipeline import describe  # noqa: E402
from core.settings import DESCRIPTOR_FAMILIES, EngineSettings  # noqa: E402

SUFFIXES = {".stl", ".ply", ".obj", ".off"}
KINDS = {
    "ss4": EngineSettings(descriptor=SS4_DESCRIPTOR),
    "ss5": EngineSettings(descriptor=SS5_DESCRIPTOR),
    "ss6": EngineSettings(descriptor=SS6_DESCRIPTOR),
    "ss7": EngineSettings(descriptor=SS7_DESCRIPTOR),
    "ss8": EngineSettings(descriptor=SS8_DESCRIPTOR),
    "ss9": EngineSettings(descriptor=SS9_DESCRIPTOR),
    "ss10": EngineSettings(descriptor=SS10_DESCRIPTOR),
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
    print(f"{len(wall['ss4'])} describes per kind; load average {load:.2f}")
    print("| kind | width | wall median s | CPU median s | wall / ss4 | CPU / ss4 |")
    print("|---|---|---|---|---|---|")
    base_wall, base_cpu = statistics.median(wall["ss4"]), statistics.median(cpu["ss4"])
    for kind in KINDS:
        w, c = statistics.median(wall[kind]), statistics.median(cpu[kind])
        print(f"| {kind} | {widths[kind]} | {w:.3f} | {c:.3f} | {w / base_wall:.2f} | "
              f"{c / base_cpu:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
