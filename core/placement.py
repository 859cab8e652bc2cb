"""Which placed part each point of an assembly lies on.

An assembly split on upload (``core.io.split_assembly``) is its parts, each in its own frame,
placed by 4x4 transforms. Given points sampled on the whole assembly and points sampled on
each part, ``part_labels`` places every part's points at each of its placements and gives
each assembly point the part whose placed surface is nearest: what a viewer needs to
highlight one part in the assembly's picture.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["MAX_PLACED_POINTS", "part_labels"]

#: Most part points placed in all (each part's points thinned evenly to stay under it).
MAX_PLACED_POINTS = 200_000


def _placed(points: np.ndarray, placements: np.ndarray, budget: int) -> np.ndarray:
    """``points : (m, 3)`` at every placement ``(p, 4, 4)``, at most ``budget`` of them per
    placement: ``(p * min(m, budget), 3)``."""
    if len(points) > budget:
        points = points[np.linspace(0, len(points) - 1, budget).astype(np.int64)]
    rotations, shifts = placements[:, :3, :3], placements[:, :3, 3]
    return (np.einsum("pij,mj->pmi", rotations, points) + shifts[:, None, :]).reshape(-1, 3)


def part_labels(
    points: np.ndarray,
    parts: Sequence[tuple[np.ndarray, np.ndarray] | None],
    tolerance: float = 0.05,
) -> np.ndarray:
    """The part each point of an assembly lies on.

    Parameters
    ----------
    points : (n, 3) float
        Points on the whole assembly, in its frame.
    parts : sequence of ((m, 3) float, (p, 4, 4) float) or None
        Per part, points on it in its own frame and its placements (part frame to assembly
        frame); None for a part whose points are not known (it labels nothing).
    tolerance : float
        A point farther than this share of the assembly's bounding-box diagonal from every
        placed part is on none (label -1): a placement the points do not show.

    Returns
    -------
    labels : (n,) int64
        Index into ``parts``, or -1.
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    labels = np.full(len(points), -1, dtype=np.int64)
    known = [(number, np.asarray(part[0], np.float64).reshape(-1, 3),
              np.asarray(part[1], np.float64).reshape(-1, 4, 4))
             for number, part in enumerate(parts) if part is not None and len(part[0])]
    instances = sum(len(placements) for _, _, placements in known)
    if not len(points) or not instances:
        return labels
    budget = max(16, MAX_PLACED_POINTS // instances)
    placed = [_placed(part_points, placements, budget) for _, part_points, placements in known]
    owners = np.concatenate([np.full(len(block), number, dtype=np.int64)
                             for (number, _, _), block in zip(known, placed, strict=True)])
    distances, nearest = cKDTree(np.concatenate(placed)).query(points)
    reach = tolerance * float(np.linalg.norm(np.ptp(points, axis=0)))
    near = distances <= max(reach, 1e-12)
    labels[near] = owners[nearest[near]]
    return labels
