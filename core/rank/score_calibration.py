"""What a similarity score means, as a number a user can threshold: the calibrated score.

The raw score ``1 - d^2/4`` of two unit descriptors crowds near 1: two different kinds of
part often score 0.95, so ``0.98`` reads "near-identical" when it is not (README, "What a
score means"). The calibrated score of a pair is the share of pairs of *different kinds* of
part that score lower, measured on the tuning sources (third-party parts, real meshes and
our generator; ``bench/selection/score_calibration.py --write``). A calibrated score of 0.99 means
only 1 % of different-kind pairs score as high: a threshold on it is a false-match rate, the same
for every descriptor it is measured for.

The table holds the quantiles of the different-kind scores of one descriptor layout, named
by its descriptor_version without the closing digest (library versions move the digest, not
the meaning of a score); other layouts have no calibration (None).
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path

import numpy as np

__all__ = ["CALIBRATION_FILE", "ScoreCalibration", "calibration_for"]

CALIBRATION_FILE = Path(__file__).parents[1] / "data" / "score-calibration.json"


class ScoreCalibration:
    """Maps raw scores to the share of different-kind pairs scoring lower.

    Parameters
    ----------
    quantiles : (q,) float
        Non-decreasing scores of different-kind pairs at evenly spaced probabilities from 0
        to 1 (``np.quantile`` of the measured scores).
    """

    def __init__(self, quantiles: np.ndarray) -> None:
        self.quantiles = np.asarray(quantiles, dtype=np.float64)
        self.probabilities_ = np.linspace(0.0, 1.0, len(self.quantiles))

    def __call__(self, score: float) -> float:
        """The calibrated score of ``score``, in [0, 1]; non-decreasing in ``score``."""
        return float(np.interp(score, self.quantiles, self.probabilities_))


def layout_of(descriptor_version: str) -> str:
    """A descriptor_version without its closing digest (``...;9c01b8c4ea``)."""
    return descriptor_version.rsplit(";", 1)[0]


@cache
def _table() -> dict[str, list[float]]:
    if not CALIBRATION_FILE.exists():
        return {}
    return dict(json.loads(CALIBRATION_FILE.read_text())["different_kind_quantiles"])


def calibration_for(descriptor_version: str) -> ScoreCalibration | None:
    """The calibration of the layout of ``descriptor_version``; None when none was measured."""
    return _calibration_of(layout_of(descriptor_version))


@cache
def _calibration_of(layout: str) -> ScoreCalibration | None:
    quantiles = _table().get(layout)
    return None if quantiles is None else ScoreCalibration(np.asarray(quantiles))
