"""What a similarity score means, as a number a user can threshold: the calibrated score.

The raw score ``1 - d^2/4`` of two unit descriptors crowds near 1: two different kinds of
part often score 0.95, so ``0.98`` reads "near-identical" when it is not (README, "What a
score means"). The calibrated score of a pair is the share of pairs of *different kinds* of
part that score lower, measured on the tuning sources (third-party parts, real meshes and
our generator). A calibrated score of 0.99 means
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
from typing import Literal

import numpy as np

__all__ = [
    "CALIBRATION_FILE", "LIKENESS", "Likeness", "ScoreCalibration", "calibration_for",
    "in_words",
]

CALIBRATION_FILE = Path(__file__).parents[1] / "data" / "score-calibration.json"

Likeness = Literal["copy", "same kind", "different kind"]

#: A calibrated score in words, from the highest threshold down: each threshold is a
#: false-match rate, the share of different-kind pairs that score as high (0.5 %, 5 %).
#: Measured with ``ss12`` on the tuning sources (README, "What a score means"): a
#: calibrated 0.995 is a raw score of about 0.985, which about 95 % of re-sampled copies
#: and 40 % of same-kind pairs reach; 0.95 a raw 0.96, which about 70 % of same-kind pairs
#: reach. The words cannot tell a copy from a part of the same kind and proportions (the
#: descriptor is scale-invariant): they read a score, they are not a verdict.
LIKENESS: tuple[tuple[float, Likeness], ...] = (
    (0.995, "copy"),
    (0.95, "same kind"),
    (0.0, "different kind"),
)


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


def in_words(calibrated: float) -> Likeness:
    """``LIKENESS``' word for a calibrated score in [0, 1]."""
    for threshold, words in LIKENESS:
        if calibrated >= threshold:
            return words
    return LIKENESS[-1][1]
