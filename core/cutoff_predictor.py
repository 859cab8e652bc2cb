"""Predict the adaptive cutoff's n before the solve, from models already described.

The paper's closing idea: once a database holds described models, a new shape's n can be
guessed from cheap features, and the cutoff can solve straight to ``prediction + 2 margin``
instead of a seed round followed by a second call. ``core.cutoff.AdaptiveCutoff`` checks the
rule on what was computed and continues if needed, so a prediction only changes the number
of solver calls, never n.

``shape_features``
    The pre-solve features of a normalised point cloud: rotation- and scale-invariant.
``CutoffPredictor``
    k-nearest-neighbour regression of n on those features (scikit-learn style ``fit`` /
    ``predict``), fitted on models of one descriptor version.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["FEATURE_NAMES", "CutoffPredictor", "shape_features"]

FEATURE_NAMES = ("log_points", "log_area_over_extent2", "middle_over_long", "short_over_long")


def shape_features(points: np.ndarray, mass: sp.spmatrix) -> np.ndarray:
    """Features known once the Laplacian is built, before any eigenpair.

    Parameters
    ----------
    points : (n, 3) float
        The points the Laplacian was built on.
    mass : (n, n) sparse
        Its mass matrix (the diagonal holds the area per point).

    Returns
    -------
    features : (4,) float
        ``FEATURE_NAMES``: log point count (sampling density sets where the discrete spectrum
        bends away from Weyl's law), log area over the squared longest principal extent (how
        much surface is folded into the shape's size), and the principal extent ratios.
    """
    centred = points - points.mean(axis=0)
    # Principal extents: invariant under rotation, unlike an axis-aligned bounding box.
    extents = np.sqrt(np.maximum(np.linalg.eigvalsh(centred.T @ centred / len(points)), 0.0))
    short, middle, long = np.maximum(extents, 1e-12 * max(float(extents[-1]), 1e-300))
    area = float(mass.diagonal().sum())
    return np.array(
        [np.log(len(points)), np.log(area / long**2), middle / long, short / long],
        dtype=np.float64,
    )


class CutoffPredictor:
    """k-nearest-neighbour regression of the adaptive cutoff's n on ``shape_features``.

    Parameters
    ----------
    neighbours : int
        Models averaged per prediction (fewer when fewer are known).

    Attributes
    ----------
    n_samples_ : int
        Models fitted on (0: ``predict`` returns None, the cutoff falls back to its seed).
    scale_ : (f,) float
        Per-feature standard deviation used to make the distance unit-free.
    """

    def __init__(self, neighbours: int = 5) -> None:
        self.neighbours = neighbours

    def fit(self, features: np.ndarray, n: np.ndarray) -> CutoffPredictor:
        """Remember the models' features ``(m, f)`` and cutoffs ``(m,)``; returns self."""
        n = np.asarray(n, dtype=np.float64).ravel()
        features = np.asarray(features, dtype=np.float64)
        if features.ndim != 2 or features.shape[0] != n.size:
            raise ValueError(f"features must be (m, f) with m = {n.size}, not {features.shape}")
        if self.neighbours < 1:
            raise ValueError(f"neighbours must be at least 1, not {self.neighbours}")
        finite = np.all(np.isfinite(features), axis=1) & np.isfinite(n)
        self.features_, self.n_ = features[finite], n[finite]
        self.n_samples_ = int(self.n_.size)
        spread = self.features_.std(axis=0) if self.n_samples_ else np.ones(features.shape[1])
        self.scale_ = np.where(spread > 1e-12, spread, 1.0)
        return self

    def predict(self, features: np.ndarray) -> int | None:
        """Predicted n for one model's ``features : (f,) float``; None without data."""
        if getattr(self, "n_samples_", 0) == 0:
            return None
        features = np.asarray(features, dtype=np.float64).ravel()
        if features.shape != self.scale_.shape or not np.all(np.isfinite(features)):
            return None
        distances = np.linalg.norm((self.features_ - features) / self.scale_, axis=1)
        nearest = np.argsort(distances, kind="stable")[: self.neighbours]
        # The median resists one odd neighbour (a multi-part model, a thin wall).
        return int(round(float(np.median(self.n_[nearest]))))
