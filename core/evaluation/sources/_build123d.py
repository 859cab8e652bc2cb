"""Tessellation of build123d solids, shared by the sources that build on it."""

from __future__ import annotations

from typing import Any

import numpy as np
import trimesh

__all__ = ["to_trimesh"]


def to_trimesh(part: Any) -> trimesh.Trimesh:
    """The triangle mesh of a build123d ``part``.

    OpenCascade's chordal tolerance is 0.2 % of the bounding-box diagonal, so that a small
    part and a large one get the same relative detail; angular tolerance 0.3 rad.
    """
    box = part.bounding_box()
    diagonal = float(np.linalg.norm(np.subtract(tuple(box.max), tuple(box.min))))
    vertices, triangles = part.tessellate(2e-3 * diagonal, 0.3)
    points = np.array([tuple(vertex) for vertex in vertices], dtype=np.float64)
    return trimesh.Trimesh(points, np.asarray(triangles, dtype=np.int64), process=True)
