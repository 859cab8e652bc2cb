"""Feature-aware sampling: spend more of the point budget where the surface bends.

Uniform sampling gives a screw's hex socket, a flange's hub fillet or a sprocket's teeth
their share of the *area*, which at 3000 points is a few dozen points. Here a dense uniform
sample (``FEATURE_OVERSAMPLING`` times the budget) is thinned to the budget with a seeded
weighted draw, each point's weight rising with its surface variation (Pauly et al. 2002):

    w = (1 - share) + share * min(sigma / mean(sigma), cap)

``share = 0`` is uniform; ``share`` near 1 puts almost every point on edges and curved
features. The cap keeps corners (the largest ``sigma``) from taking the whole budget, and
``1 - share`` keeps flat faces sampled, so the Laplacian still sees every region. Every
later stage weighs points by the area they stand for (the Laplacian's lumped mass), so a
denser edge gets finer resolution, not more weight, in the area-weighted blocks.

Used by the evaluation's ``Sampling`` (``feature_share``), to decide by leave-one-source-out
on third-party sources whether the service should sample this way.
"""

from __future__ import annotations

import numpy as np

from core.local_features import surface_variation

__all__ = [
    "FEATURE_CAP",
    "FEATURE_NEIGHBOURS",
    "FEATURE_OVERSAMPLING",
    "feature_weighted_subsample",
]

#: The dense sample is this many times the budget.
FEATURE_OVERSAMPLING = 4
#: Neighbours of the surface variation that sets the weights (on the dense sample).
FEATURE_NEIGHBOURS = 16
#: A point's weight is at most this many times the mean's.
FEATURE_CAP = 4.0


def feature_weighted_subsample(points: np.ndarray, target: int, share: float, seed: int
                               ) -> np.ndarray:
    """Indices of ``target`` points drawn without replacement, denser where the surface bends.

    Parameters
    ----------
    points : (n, 3) float
        A dense, roughly uniform sample of the surface, ``n > target``.
    target : int
        Points to keep.
    share : float
        In [0, 1]: how much of the weight follows the surface variation.
    seed : int
        Seed of the draw; the same points and seed give the same indices.

    Returns
    -------
    (target,) int
        Sorted indices into ``points``.
    """
    if not 0.0 <= share <= 1.0:
        raise ValueError(f"share must lie in [0, 1], got {share}")
    if len(points) <= target:
        return np.arange(len(points))
    sigma = surface_variation(points, (FEATURE_NEIGHBOURS,))[:, 0]
    ratio = np.minimum(sigma / max(float(sigma.mean()), 1e-300), FEATURE_CAP)
    weights = (1.0 - share) + share * ratio
    # Efraimidis-Spirakis: the target largest keys log(u) / w are a weighted draw without
    # replacement; weights are > 0 unless share = 1 on a perfectly flat patch.
    keys = np.log(np.random.default_rng(seed).random(len(points))) / np.maximum(weights, 1e-12)
    return np.sort(np.argpartition(-keys, target - 1)[:target])
