"""Why two parts match: one placed on the other, and how far apart they are, point by point.

- ``align``: the rotation, translation and (optionally) scale that put one point set on
  another (principal axes with their ambiguities tried, each start refined by ICP, the best
  kept); a partial scan is placed on the whole part it shows (``core.compare._align``);
- ``deviations``: each point's distance from the other part's surface both ways, RMS,
  mean, 95th percentile, maximum, the share within a tolerance, and the size ratios along
  the first part's principal axes (``core.compare._deviations``);
- ``compare``: both, on two parts' sample points in their units.

Pure functions of point arrays: the service (``app.search.comparing``) loads the stored
samples and answers, ``shapesearch compare`` prints the same figures for files.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from core.compare._align import (
    Alignment,
    AlignmentBudgetExceeded,
    Start,
    align,
    rotation_angle,
    spread_subset,
)
from core.compare._deviations import (
    Deviations,
    Direction,
    Surface,
    deviations,
    principal_extents,
    surface_distances,
)

__all__ = [
    "MAX_POINTS",
    "TOLERANCE_SHARE",
    "Alignment",
    "AlignmentBudgetExceeded",
    "Comparison",
    "Deviations",
    "Direction",
    "Start",
    "Surface",
    "align",
    "compare",
    "default_tolerance",
    "deviations",
    "diagonal",
    "principal_extents",
    "rotation_angle",
    "spread_subset",
    "surface_distances",
]

#: Points of each part that take part in a comparison (a seeded subset of more): the
#: alignment decides on fewer (``core.compare._align.WORKING_POINTS``), the deviations are
#: measured on these.
MAX_POINTS = 3000
#: The default tolerance: this share of the larger bounding-box diagonal of the two parts.
TOLERANCE_SHARE = 0.01


def diagonal(points: np.ndarray) -> float:
    """The bounding-box diagonal of ``points : (n, 3) float``."""
    points = np.asarray(points, dtype=np.float64)
    return float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))


def default_tolerance(a: np.ndarray, b_aligned: np.ndarray) -> float:
    """``TOLERANCE_SHARE`` of the larger bounding-box diagonal of ``a`` and ``b_aligned``
    (both ``(n, 3)``, in ``a``'s units)."""
    return TOLERANCE_SHARE * max(diagonal(a), diagonal(b_aligned))


@dataclass(frozen=True)
class Comparison:
    """Part ``b`` placed on part ``a`` and their deviations, in ``a``'s units.

    Attributes
    ----------
    alignment : Alignment
        ``b`` onto ``a``.
    deviations : Deviations
        ``a`` against the aligned ``b``; ``deviations.a_to_b.distances`` are per point of
        ``a_points``, ``deviations.b_to_a.distances`` per point of ``b_points``;
        ``extents_b`` (and the size ratios) at ``b``'s own size, the found scale undone.
    a_points : (n, 3) float
        The points of ``a`` measured (at most ``MAX_POINTS``).
    b_points : (m, 3) float
        The points of ``b`` measured, aligned (in ``a``'s frame).
    seconds : float
        Time taken.
    """

    alignment: Alignment
    deviations: Deviations
    a_points: np.ndarray
    b_points: np.ndarray
    seconds: float


def compare(
    a: np.ndarray,
    b: np.ndarray,
    *,
    scale: bool = False,
    partial: bool = False,
    tolerance: float | None = None,
    seed: int = 0,
    deadline: float | None = None,
) -> Comparison:
    """Place ``b`` on ``a`` (``align``) and measure their deviations (``deviations``).

    Parameters
    ----------
    a : (n, 3) float
        The reference part's sample points, in its units.
    b : (m, 3) float
        The other part's (or a scan's), in its own units and frame.
    scale : bool
        Also find a uniform scale (``b`` in unknown units).
    partial : bool
        ``b`` shows one side of ``a`` (a scan).
    tolerance : float, optional
        Within this distance (``a``'s units) a point counts as matched; > 0. Default:
        ``default_tolerance`` of the two aligned parts.
    seed : int
        Seed of the subsets.
    deadline : float, optional
        ``time.monotonic()`` value past which ``AlignmentBudgetExceeded`` is raised.

    Returns
    -------
    Comparison

    Raises
    ------
    ValueError
        Points that are not ``(n, 3)``, finite and extended, or a tolerance <= 0.
    AlignmentBudgetExceeded
        Past ``deadline``.
    """
    if tolerance is not None and not tolerance > 0:
        raise ValueError(f"tolerance must be positive, not {tolerance}")
    started = time.perf_counter()
    a_points = spread_subset(np.asarray(a, dtype=np.float64), MAX_POINTS, seed)
    b_own = spread_subset(np.asarray(b, dtype=np.float64), MAX_POINTS, seed)
    alignment = align(a_points, b_own, scale, partial=partial, seed=seed, deadline=deadline)
    b_points = alignment.apply(b_own)
    if tolerance is None:
        tolerance = default_tolerance(a_points, b_points)
    measured = deviations(a_points, b_points, tolerance)
    # Sizes as they are: a scale found to lay b on a is undone in b's extents.
    measured = replace(measured, extents_b=measured.extents_b / alignment.scale)
    return Comparison(
        alignment=alignment,
        deviations=measured,
        a_points=a_points,
        b_points=b_points,
        seconds=time.perf_counter() - started,
    )
