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
above them: the figures behind the README's ``min_score`` guidance. With ``--write`` it stores
the quantiles of the different-kind scores as the default descriptor's calibration
(``core/data/score-calibration.json``, read by ``core.rank.score_calibration``) and prints how the
calibrated score separates the three groups::

    .venv/bin/python bench/selection/score_calibration.py /work/tuning \\
        [--sources parts madcad ...] [--write]
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

from core.descriptor import DescriptorSpec  # noqa: E402
from core.errors import InvalidShapeError  # noqa: E402
from core.pipeline import describe  # noqa: E402
from core.rank.score_calibration import CALIBRATION_FILE, ScoreCalibration, layout_of  # noqa: E402
from core.settings import EngineSettings  # noqa: E402

THRESHOLDS = (0.95, 0.97, 0.975, 0.98, 0.99, 0.995)
CALIBRATED_THRESHOLDS = (0.9, 0.95, 0.99, 0.999)
CALIBRATION_POINTS = 1001  # quantiles kept: every 0.1 % of the different-kind pairs
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
    parser.add_argument("--write", action="store_true",
                        help=f"store the calibration in {CALIBRATION_FILE.name}")
    args = parser.parse_args(argv)
    groups: dict[str, list[float]] = {"copy": [], "same kind": [], "different": []}
    by_source: dict[str, dict[str, list[float]]] = {}
    folders = [p for p in sorted(args.sources.iterdir()) if p.is_dir()]
    for folder in folders:
        if args.names and folder.name not in args.names:
            continue
        labels, vectors = described(folder)
        print(f"{folder.name}: {len(labels)} models", flush=True)
        own = by_source[folder.name] = {name: [] for name in groups}
        for i, j in itertools.combinations(range(len(labels)), 2):
            score = 1.0 - float(np.sum((vectors[i] - vectors[j]) ** 2)) / 4.0
            if labels[i] != labels[j]:
                group = "different"
            else:
                group = "copy" if folder.name == "parts" else "same kind"
            groups[group].append(score)
            own[group].append(score)
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
    held_out_check(by_source)
    if args.write:
        write_calibration(groups)
    return 0


def held_out_check(by_source: dict[str, dict[str, list[float]]]) -> None:
    """Leave one source out: calibrate on the others' different-kind pairs, then measure on
    the left-out source what a calibrated threshold of 0.99 keeps (1 % of different-kind
    pairs if the calibration generalises)."""
    print("\n| left out | its pairs >= 0.99 calibrated: copy | same kind | different |")
    print("|---|---|---|---|")
    for left_out, own in by_source.items():
        others = [s for name, groups in by_source.items() if name != left_out
                  for s in groups["different"]]
        if not others:
            continue
        calibration = ScoreCalibration(np.quantile(others, np.linspace(0, 1, CALIBRATION_POINTS)))
        shares = [f"{np.mean([calibration(s) >= 0.99 for s in own[g]]):.1%}" if own[g] else "-"
                  for g in ("copy", "same kind", "different")]
        print(f"| {left_out} | " + " | ".join(shares) + " |")


def write_calibration(groups: dict[str, list[float]]) -> None:
    """Store the different-kind quantiles for the default layout beside the earlier layouts';
    print the separation."""
    quantiles = np.quantile(groups["different"], np.linspace(0, 1, CALIBRATION_POINTS))
    settings = EngineSettings()
    layout = layout_of(DescriptorSpec.from_settings(settings.descriptor).version(settings))
    # Earlier layouts keep theirs: a catalogue described before an upgrade is read with its
    # own calibration until it is re-described.
    earlier = (json.loads(CALIBRATION_FILE.read_text())["different_kind_quantiles"]
               if CALIBRATION_FILE.exists() else {})
    table = {"different_kind_quantiles": {**earlier,
                                          layout: [round(float(q), 6) for q in quantiles]},
             "pairs": {name: len(scores) for name, scores in groups.items()}}
    CALIBRATION_FILE.write_text(json.dumps(table, indent=1) + "\n")
    calibration = ScoreCalibration(quantiles)
    print(f"\nwrote {CALIBRATION_FILE}\n\n| calibrated_score >= | " + " | ".join(groups) + " |")
    print("|---|" + "---|" * len(groups))
    for threshold in CALIBRATED_THRESHOLDS:
        shares = [np.mean([calibration(s) >= threshold for s in scores]) if scores
                  else float("nan") for scores in groups.values()]
        print(f"| {threshold} | " + " | ".join(f"{share:.1%}" for share in shares) + " |")


if __name__ == "__main__":
    raise SystemExit(main())
