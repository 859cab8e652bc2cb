"""The real part meshes of ``shared/datasets/parts`` (trimesh project, MIT) as a source.

Unlabelled files, so this source is *instance-level*: every part is a class of its own, and
its members are the part stretched by up to +-10 % along each of its own principal axes (a
different size and proportion of the same design, as a catalogue holds), re-triangulated
by subdivision for half of them. Point-only files and classic test shapes (bunny, teapot)
are left out.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import trimesh

__all__ = ["EXCLUDED", "MEMBERS", "parts"]

#: Files that are not engineering parts, or not meshes.
EXCLUDED = frozenset({"bunny.ply", "teapot.stl", "points_ascii.ply", "points_bin.ply"})
#: Members per part.
MEMBERS = 6


def _stretched(mesh: trimesh.Trimesh, factors: np.ndarray) -> trimesh.Trimesh:
    """``mesh`` scaled by ``factors : (3,)`` along its principal axes (about its centroid)."""
    centred = mesh.vertices - mesh.vertices.mean(axis=0)
    _, _, axes = np.linalg.svd(centred, full_matrices=False)
    stretched = ((centred @ axes.T) * factors) @ axes
    return trimesh.Trimesh(stretched, mesh.faces.copy(), process=False)


def parts(root: Path, seed: int = 0) -> Iterator[tuple[str, str, trimesh.Trimesh]]:
    """``(part name, member name, mesh)`` for every mesh file directly under ``root``."""
    rng = np.random.default_rng(seed)
    for path in sorted(root.iterdir()):
        if not path.is_file() or path.name in EXCLUDED or path.suffix.lower() not in (
                ".stl", ".obj", ".ply", ".off"):
            continue
        mesh = trimesh.load(path, force="mesh")
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            continue
        label = path.stem.replace(".", "_")
        for member in range(MEMBERS):
            factors = rng.uniform(0.9, 1.1, size=3) if member else np.ones(3)
            variant = _stretched(mesh, factors)
            if member % 2:
                variant = variant.subdivide()
            yield label, f"{label}_{member}", variant
