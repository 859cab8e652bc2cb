"""Completing a partial scan of a turned part by its axis of revolution.

A single sensor view sees about half of a screw, a nut, a bearing or a shaft. Most engineering
parts are surfaces of revolution (or nearly), and for those the unseen half follows from the
seen one: every normal line of a surface of revolution meets its axis, so the axis can be
fitted to a partial view's points and normals alone, linearly (the normals form a linear line
complex of pitch 0: Pottmann & Randrup 1998, "Rotational and helical surface approximation
for reverse engineering"). Turning the seen points about that axis gives the whole surface.

``fit_axis`` returns the axis and how well the view agrees with it (the share of the points
whose normals cross the side of the part and still meet the axis); ``revolve`` samples the
completed surface. Flat faces whose normals run along the axis agree with every axis, so they
do not count as agreement: a plate is not taken for a disc.

Measured for scan mode's queries (the ``+rev`` step of ``core.evaluation.runner``) and
declined: the service does not complete scans.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.extrinsic import surface_normals

__all__ = ["AXIS_NEIGHBOURS", "Axis", "fit_axis", "revolve"]

#: Neighbours per point for the normals (as the normals block's default).
AXIS_NEIGHBOURS = 12
#: A normal line "meets" the axis when it passes within this share of the RMS radius.
MEET_TOLERANCE = 0.1
#: Normals within this angle of the axis (end faces) agree with any axis: not counted.
SIDE_ANGLE_DEGREES = 30.0
#: Robust re-weighting passes of the linear fit.
PASSES = 5


@dataclass(frozen=True)
class Axis:
    """A fitted axis of revolution.

    Attributes
    ----------
    direction : (3,) float
        Unit direction.
    origin : (3,) float
        The axis' point nearest the points' centroid.
    agreement : float
        Share of the side points (normal at least ``SIDE_ANGLE_DEGREES`` from the axis) whose
        normal line passes within ``MEET_TOLERANCE`` RMS radii of the axis, in [0, 1].
    side_share : float
        Share of all points that are side points.
    """

    direction: np.ndarray
    origin: np.ndarray
    agreement: float
    side_share: float


def _solve(lines: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Direction and moment of the line meeting the weighted normal lines best.

    ``lines : (n, 6)`` rows ``(p x n, n)``; a line ``(a, m)`` (unit direction, moment) meets
    normal line ``i`` when ``a . (p_i x n_i) + m . n_i = 0``. The moment is eliminated in closed
    form (a Schur complement), the direction is the least eigenvector, and the moment's part
    along the direction (the pitch of a helical complex) is dropped: an axis is a line.
    """
    weighted = lines * weights[:, None]
    gram = weighted.T @ lines
    moment_gram = np.linalg.pinv(gram[3:, 3:])
    reduced = gram[:3, :3] - gram[:3, 3:] @ moment_gram @ gram[3:, :3]
    _, vectors = np.linalg.eigh(reduced)
    direction = vectors[:, 0]
    moment = -moment_gram @ gram[3:, :3] @ direction
    moment -= (moment @ direction) * direction
    return direction, moment


def fit_axis(points: np.ndarray, neighbours: int = AXIS_NEIGHBOURS) -> Axis:
    """The axis of revolution that ``points`` agree with best.

    Parameters
    ----------
    points : (n, 3) float
        A (possibly partial) sample of a surface, ``n >= neighbours + 1``.
    neighbours : int
        Neighbours per point for its normal.

    Returns
    -------
    axis : Axis
    """
    centroid = points.mean(axis=0)
    # Work in units of the RMS radius so the tolerance and the linear system are scale-free.
    scale = float(np.sqrt(((points - centroid) ** 2).sum(axis=1).mean())) or 1.0
    unit = (points - centroid) / scale
    normals = surface_normals(unit, neighbours)
    lines = np.hstack([np.cross(unit, normals), normals])
    weights = np.ones(len(unit))
    side_cosine = np.cos(np.radians(SIDE_ANGLE_DEGREES))
    for _ in range(PASSES):
        direction, moment = _solve(lines, weights)
        # |a . (p x n) + m . n| is the distance of the two lines times the sine of their angle.
        residual = np.abs(lines @ np.concatenate([direction, moment]))
        weights = 1.0 / np.maximum(residual / MEET_TOLERANCE, 1.0)  # Huber-like
    sine = np.sqrt(np.maximum(1.0 - (normals @ direction) ** 2, 0.0))
    side = np.abs(normals @ direction) <= side_cosine  # at least 30 degrees off the axis
    distance = residual / np.maximum(sine, 1e-12)
    agreement = float((distance[side] <= MEET_TOLERANCE).mean()) if side.any() else 0.0
    origin = centroid + scale * np.cross(direction, moment)
    return Axis(direction=direction, origin=origin, agreement=agreement,
                side_share=float(side.mean()))


def revolve(points: np.ndarray, axis: Axis, count: int, seed: int = 0) -> np.ndarray:
    """``count`` points of the surface swept by turning ``points`` about ``axis``.

    Each output point is a seen point turned by a random angle; seen points are drawn in
    proportion to their distance from the axis, the length of the circle they sweep, so the
    completed surface is sampled evenly by area.

    Parameters
    ----------
    points : (n, 3) float
    axis : Axis
    count : int
    seed : int

    Returns
    -------
    revolved : (count, 3) float
    """
    rng = np.random.default_rng(seed)
    relative = points - axis.origin
    along = relative @ axis.direction
    radial = relative - along[:, None] * axis.direction
    radius = np.linalg.norm(radial, axis=1)
    weights = radius / radius.sum() if radius.sum() > 0 else None
    chosen = rng.choice(len(points), size=count, p=weights)
    angle = rng.uniform(0.0, 2.0 * np.pi, size=count)
    # Rodrigues' rotation of each chosen radial vector about the axis.
    r = radial[chosen]
    turned = (r * np.cos(angle)[:, None]
              + np.cross(axis.direction, r) * np.sin(angle)[:, None])
    return axis.origin + along[chosen, None] * axis.direction + turned
