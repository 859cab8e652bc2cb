"""Builds ``core/data/score-calibration.json``: what a similarity score means.

Every model of each tuning source (``python -m core.evaluation.sources SOURCES``) is
described with the service's default engine settings (``core.pipeline.describe``); for
every pair within a source the API's score ``1 - d^2 / 4`` is filed as

* ``copy``: the same part re-sampled and rotated (the ``parts`` source: one class per part);
* ``same kind``: two parts of one class of the other sources;
* ``different``: two parts of different classes of one source.

Two steps. The slow one describes the sources (minutes) and writes every pair's score to an
intermediate file (``--scores``), printing the quantiles per group, the share of each group
at or above candidate thresholds (the README's ``min_score`` guidance) and a
leave-one-source-out check of the calibration. The deterministic one (``--write``, from the
sources or from ``--from-scores``) keeps the quantiles of the different-kind scores as the
default layout's calibration, beside the earlier layouts' (``calibration_text``; read by
``core.rank.score_calibration``). ``PAIRS`` is the intermediate of the shipped file, kept
beside this module: the sources rebuilt and described on 2026-12-07 (``ss12``; 468 models,
24,418 pairs), from which the final step writes the shipped file byte for byte
(``tests/evaluation/test_artefacts.py``). A new default layout rewrites both::

    python -m core.evaluation.sources /work/tuning --sources parts madcad generated
    python -m core.evaluation.sources /work/tuning --sources gearworks vslot  # build123d's venv
    python -m research.artefacts.score_calibration /work/tuning \\
        --sources parts madcad gearworks generated vslot \\
        --scores research/artefacts/score-calibration-pairs.npz --write
    python -m research.artefacts.score_calibration --from-scores \\
        research/artefacts/score-calibration-pairs.npz           # the tables again, no describe
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

__all__ = ["GROUPS", "PAIRS", "calibration_text", "default_layout", "load_scores", "pair_scores",
           "save_scores"]

GROUPS = ("copy", "same kind", "different")
THRESHOLDS = (0.95, 0.97, 0.975, 0.98, 0.99, 0.995)
CALIBRATED_THRESHOLDS = (0.9, 0.95, 0.99, 0.999)
CALIBRATION_POINTS = 1001  # quantiles kept: every 0.1 % of the different-kind pairs
QUANTILES = (0.0, 0.01, 0.05, 0.5, 0.95, 0.99, 1.0)
#: The intermediate the shipped file was written from.
PAIRS = Path(__file__).resolve().parent / "score-calibration-pairs.npz"

#: Each group's pair scores, per source.
Scores = dict[str, dict[str, np.ndarray]]


def pair_scores(folder: Path) -> dict[str, np.ndarray]:
    """Every pair's score within the source ``folder`` (``<class>/<file>``), by group."""
    labels, vectors = [], []
    for path in sorted(folder.glob("*/*")):
        try:
            vectors.append(describe(path, EngineSettings()).descriptor.astype(np.float64))
        except InvalidShapeError:
            continue
        labels.append(path.parent.name)
    groups: dict[str, list[float]] = {name: [] for name in GROUPS}
    for i, j in itertools.combinations(range(len(labels)), 2):
        score = 1.0 - float(np.sum((vectors[i] - vectors[j]) ** 2)) / 4.0
        same = "copy" if folder.name == "parts" else "same kind"
        groups[same if labels[i] == labels[j] else "different"].append(score)
    print(f"{folder.name}: {len(labels)} models", flush=True)
    return {name: np.array(scores) for name, scores in groups.items()}


def save_scores(path: Path, scores: Scores) -> None:
    """The intermediate: every source's pair scores by group, sorted (it compresses better,
    and nothing reads the pairs' order)."""
    arrays = {f"{source}/{group}": np.sort(values) for source, groups in scores.items()
              for group, values in groups.items()}
    np.savez_compressed(path, **arrays)  # type: ignore[arg-type]  # numpy's stubs: ** could fill allow_pickle


def load_scores(path: Path) -> Scores:
    scores: Scores = {}
    with np.load(path) as data:
        for key in data.files:
            source, group = key.split("/", 1)
            scores.setdefault(source, {})[group] = data[key]
    return scores


def default_layout() -> str:
    """The default descriptor's layout: its ``descriptor_version`` without the digest."""
    settings = EngineSettings()
    return layout_of(DescriptorSpec.from_settings(settings.descriptor).version(settings))


def calibration_text(different: np.ndarray, pairs: dict[str, int], layout: str,
                     earlier: dict[str, list[float]]) -> str:
    """The file's text: ``CALIBRATION_POINTS`` quantiles of the ``different``-kind scores,
    to 6 decimals, as ``layout``'s entry after the ``earlier`` layouts' (which keep theirs:
    a catalogue described before an upgrade is read with its own calibration until it is
    re-described; an earlier entry of ``layout`` is replaced in place); ``pairs``: each
    group's count."""
    quantiles = np.quantile(different, np.linspace(0, 1, CALIBRATION_POINTS))
    table = {"different_kind_quantiles": {**earlier,
                                          layout: [round(float(q), 6) for q in quantiles]},
             "pairs": pairs}
    return json.dumps(table, indent=1) + "\n"


def _shares(groups: dict[str, np.ndarray], thresholds: tuple[float, ...],
            score: ScoreCalibration | None = None) -> None:
    print(f"| {'calibrated_score' if score else 'min_score'} >= | " + " | ".join(groups) + " |")
    print("|---|" + "---|" * len(groups))
    for threshold in thresholds:
        values = [np.array([score(s) for s in v]) if score else v for v in groups.values()]
        print(f"| {threshold} | " + " | ".join(
            f"{np.mean(v >= threshold):.1%}" if v.size else "-" for v in values) + " |")


def report(scores: Scores) -> dict[str, np.ndarray]:
    """Print the groups' quantiles, the shares at each threshold and the held-out check
    (calibrated on the other sources' different-kind pairs, what 0.99 keeps of a source:
    1 % of its different-kind pairs if the calibration generalises); the groups pooled."""
    groups = {g: np.concatenate([s[g] for s in scores.values()]) for g in GROUPS}
    print("\n| pairs | count | " + " | ".join(f"q{q:g}" for q in QUANTILES) + " |")
    print("|---|---|" + "---|" * len(QUANTILES))
    for name, values in groups.items():
        cells = (" | ".join(f"{v:.4f}" for v in np.quantile(values, QUANTILES))
                 if values.size else "")
        print(f"| {name} | {values.size} | {cells} |")
    print()
    _shares(groups, THRESHOLDS)
    print("\n| left out | its pairs >= 0.99 calibrated: copy | same kind | different |")
    print("|---|---|---|---|")
    for left_out, own in scores.items():
        others = [s["different"] for name, s in scores.items() if name != left_out]
        if others and np.concatenate(others).size:
            calibration = ScoreCalibration(
                np.quantile(np.concatenate(others), np.linspace(0, 1, CALIBRATION_POINTS)))
            shares = [f"{np.mean([calibration(s) >= 0.99 for s in own[g]]):.1%}"
                      if own[g].size else "-" for g in GROUPS]
            print(f"| {left_out} | " + " | ".join(shares) + " |")
    return groups


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sources", type=Path, nargs="?", help="the tuning sources' folder")
    parser.add_argument("--sources", dest="names", nargs="*", default=None)
    parser.add_argument("--scores", type=Path, help="write the pair scores here")
    parser.add_argument("--from-scores", type=Path, help="read the pair scores from here")
    parser.add_argument("--write", action="store_true",
                        help=f"store the calibration in {CALIBRATION_FILE.name}")
    args = parser.parse_args(argv)
    if args.from_scores:
        scores = load_scores(args.from_scores)
    elif args.sources:
        scores = {folder.name: pair_scores(folder) for folder in sorted(args.sources.iterdir())
                  if folder.is_dir() and (not args.names or folder.name in args.names)}
    else:
        parser.error("give the sources' folder or --from-scores")
    if args.scores:
        save_scores(args.scores, scores)
    groups = report(scores)
    if args.write:
        earlier = (json.loads(CALIBRATION_FILE.read_text())["different_kind_quantiles"]
                   if CALIBRATION_FILE.exists() else {})
        CALIBRATION_FILE.write_text(calibration_text(
            groups["different"], {g: int(v.size) for g, v in groups.items()}, default_layout(),
            earlier))
        print(f"\nwrote {CALIBRATION_FILE}\n")
        _shares(groups, CALIBRATED_THRESHOLDS, ScoreCalibration(
            np.quantile(groups["different"], np.linspace(0, 1, CALIBRATION_POINTS))))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
