"""How big a shape is, in the units of its file.

The descriptor is scale-invariant by design (an M6 and an M12 screw of the same proportions
describe alike), so size is measured beside it and compared on its own:

* ``length >= width >= height``: the extents of the shape's minimum-volume oriented bounding
  box (``trimesh.bounds.oriented_bounds``), sorted; unchanged by rotation, translation and
  point order. A mesh's box is that of its vertices (exact); a point cloud's that of its
  points after the outlier filter. (The box of the principal axes was the first idea; those
  axes swing by up to 45 degrees when two principal moments are close, as on an L-shaped
  block, and its extents with them.)
* ``area``: the triangles' total area for a mesh; for a cloud, the total of the Laplacian's
  mass matrix built on the raw points (an estimate, as good as the sampling).
* ``volume``: the enclosed volume of a watertight, consistently wound mesh (coincident
  vertices merged first); None otherwise and for clouds.

A partial scan measures only what the scanner saw: its extents are lower bounds.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import trimesh

__all__ = ["SIZE_FIELDS", "UNIT_MILLIMETRES", "ShapeSize", "box_extents", "closed_volume"]

# Share of a cloud's points allowed outside its measured box, at each end of each axis.
_TRIM = 0.002
# Vertices closer than 1e-9 of the mesh's size are one vertex.
_MERGE_STEPS = 1e9

#: The measurements of a ``ShapeSize``, in the order of its fields.
SIZE_FIELDS = ("length", "width", "height", "area", "volume")

#: Millimetres per unit, for the units a client may declare.
UNIT_MILLIMETRES: dict[str, float] = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4}


@dataclass(frozen=True)
class ShapeSize:
    """Extents (sorted, largest first), surface area and enclosed volume of a shape."""

    length: float
    width: float
    height: float
    area: float
    volume: float | None = None

    @property
    def extents(self) -> np.ndarray:
        """``(3,) float``: length, width, height."""
        return np.array([self.length, self.width, self.height])

    def scaled(self, factor: float) -> ShapeSize:
        """The size of the shape scaled by ``factor`` (e.g. millimetres per unit)."""
        return ShapeSize(
            self.length * factor, self.width * factor, self.height * factor,
            self.area * factor**2, None if self.volume is None else self.volume * factor**3,
        )

    def to_json(self) -> dict[str, Any]:
        return {"length": self.length, "width": self.width, "height": self.height,
                "area": self.area, "volume": self.volume}

    @classmethod
    def of_points(cls, points: np.ndarray, area: float) -> ShapeSize:
        """The size of a point cloud ``points : (n, 3) float`` whose area is ``area``.

        The box's extents are measured between the 0.2 % and 99.8 % quantiles of the points
        along its axes: a few stray points that the outlier filter kept do not stretch it.
        """
        length, width, height = box_extents(points, trim=_TRIM)
        return cls(length, width, height, float(area))

    @classmethod
    def of_mesh(cls, vertices: np.ndarray, faces: np.ndarray) -> ShapeSize:
        """The size of a triangle mesh ``vertices : (v, 3) float``, ``faces : (f, 3) int``."""
        vertices, faces = _merged(vertices, faces)
        if len(faces) == 0:
            raise ValueError("the mesh has no triangle with three distinct vertices")
        length, width, height = box_extents(vertices)
        a, b, c = (vertices[faces[:, i]] for i in range(3))
        area = float(0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())
        return cls(length, width, height, area, closed_volume(vertices, faces))


def _merged(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The mesh with coincident vertices merged (files such as STL repeat each vertex per
    triangle; exports round differently), only the vertices that triangles use, and
    without the triangles that merging collapses."""
    used = np.unique(faces)
    if len(used) == 0:
        return vertices[:0], faces[:0]
    vertices, faces = vertices[used], np.searchsorted(used, faces)
    scale = float(np.ptp(vertices, axis=0).max()) or 1.0
    keys = np.round(vertices / scale * _MERGE_STEPS).astype(np.int64)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    faces = inverse.reshape(-1)[faces]
    distinct = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (
        faces[:, 2] != faces[:, 0])
    return vertices[first], faces[distinct]


def closed_volume(vertices: np.ndarray, faces: np.ndarray) -> float | None:
    """The volume a watertight, consistently wound mesh encloses, else None.

    Watertight and consistently wound: every directed edge appears exactly once and its
    reverse exactly once. The volume is then the divergence-theorem sum of signed
    tetrahedra.
    """
    if len(faces) < 4:
        return None
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    forward, counts = np.unique(directed, axis=0, return_counts=True)
    if counts.max() > 1:
        return None
    reverse = np.unique(directed[:, ::-1], axis=0)
    if not np.array_equal(forward, reverse):
        return None
    a, b, c = (vertices[faces[:, i]] for i in range(3))
    volume = abs(float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0))
    return volume if volume > 0 else None


def box_extents(points: np.ndarray, trim: float = 0.0) -> tuple[float, float, float]:
    """Extents of the minimum-volume oriented bounding box of ``points : (n, 3) float``,
    largest first; with ``trim``, between the ``trim`` and ``1 - trim`` quantiles of the
    points along the box's axes. Points in a plane or on a line (no 3D hull) are measured
    along their principal axes instead."""
    points = np.asarray(points, dtype=np.float64)
    try:
        to_box, _ = trimesh.bounds.oriented_bounds(points)
        local = trimesh.transform_points(points, to_box)
    except MemoryError:
        raise
    except Exception:  # qhull refuses flat or collinear points
        centred = points - points.mean(axis=0)
        local = centred @ np.linalg.svd(centred, full_matrices=False)[2].T
    low, high = np.quantile(local, [trim, 1.0 - trim], axis=0)
    length, width, height = (float(e) for e in np.sort(high - low)[::-1])
    return length, width, height
