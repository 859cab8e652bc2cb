"""What a similarity score means: score distributions of copies, same-kind parts and
different kinds, on the tuning sources (issue 21).

Every model of each source folder (``python -m core.evaluation.sources OUT``) is described
with the service's default engine settings; for every pair within a source the API's score
``1 - d^2 / 4`` is computed and filed as

* ``copy``: the same part re-sampled and rotated (the ``parts`` source: one class per part);
* ``same kind``: two parts of one class of the other sources (madcad, gearworks, generated,
  capod, ...);
* ``different``: two parts of different classes of one source.

Prints quantiles per group and, for candidate thresholds, the share of each group at or
above them: the figures behind the README's ``min_score`` guidance::

    .venv/bin/python bench/score_calibration.py /work/tuning [--sources parts madcad ...]
"""

from __future__ import annotations

import argparse
import itertools
import os
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

from core.errors import InvalidShapeError  # noqa: E402
from core.pipeline import describe  # noqa: E402
from core.settings import EngineSettings  # noqa: E402

THRESHOLDS = (0.95, 0.97, 0.98, 0.99, 0.995)
QUANTILES = (0.0, 0.01, 0.05, 0.5, 0.95, 0.99, 1.0)


def described(folder: Path) -> tuple[list[str], np.ndarray]:
    """Labels and unit descriptors of every model under ``folder/<class>/``."""
    labels, vectors = [], []
    for path in sorted(folder.glob("*/*")):
        try:
            vectors.append(describe(path, EngineSettings()).descriptor.astype(np.float64))
        except InvalidShapeError:
            continue
        labels.append(path.parent.name)
    return labels, np.array(vectors)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sources", type=Path)
    parser.add_argument("--sources", dest="names", nargs="*", default=None)
    args = parser.parse_args(argv)
    groups: dict[str, list[float]] = {"copy": [], "same kind": [], "different": []}
    folders = [p for p in sorted(args.sources.iterdir()) if p.is_dir()]
    for folder in folders:
        if args.names and folder.name not in args.names:
            continue
        labels, vectors = described(folder)
        print(f"{folder.name}: {len(labels)} models", flush=True)
        for i, j in itertools.combinations(range(len(labels)), 2):
            score = 1.0 - float(np.sum((vectors[i] - vectors[j]) ** 2)) / 4.0
            if labels[i] != labels[j]:
                groups["different"].append(score)
            else:
                groups["copy" if folder.name == "parts" else "same kind"].append(score)
    print("\n| pairs | count | " + " | ".join(f"q{q:g}" for q in QUANTILES) + " |")
    print("|---|---|" + "---|" * len(QUANTILES))
    for name, scores in groups.items():
        cells = " | ".join(f"{v:.4f}" for v in np.quantile(scores, QUANTILES)) if scores else ""
        print(f"| {name} | {len(scores)} | {cells} |")
    print("\n| min_score | " + " | ".join(groups) + " |")
    print("|---|" + "---|" * len(groups))
    for threshold in THRESHOLDS:
        shares = [np.mean(np.array(s) >= threshold) if s else float("nan")
                  for s in groups.values()]
        print(f"| {threshold} | " + " | ".join(f"{share:.1%}" for share in shares) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
