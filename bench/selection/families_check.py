"""The distances behind tests/test_families.py, printed for both families and for ``ss4``.

A straight tube and the same tube bent by 90 degrees, a finger and the same finger with its
knuckles turned, against a box, a torus and a cone (``parts`` and ``bendable`` families);
pymadcad's standard socket-head and button-head screws of two sizes (``ss4``, the default
before issue 24, and the default ``parts`` family)::

    .venv/bin/python bench/selection/families_check.py
"""

from __future__ import annotations

import numpy as np
import trimesh
from madcad import standard

from core.evaluation.sources.bendable import bend_check_shapes
from core.evaluation.sources.madcad_parts import _to_trimesh
from core.evaluation.variants import SS4_DESCRIPTOR
from core.pipeline import describe_points
from core.settings import DESCRIPTOR_FAMILIES, DescriptorSettings, EngineSettings


def sampled(mesh: trimesh.Trimesh, seed: int) -> np.ndarray:
    points, _ = trimesh.sample.sample_surface(mesh, 3000, seed=seed)
    return np.asarray(points)


def described(
    meshes: dict[str, trimesh.Trimesh], descriptor: DescriptorSettings
) -> dict[str, np.ndarray]:
    settings = EngineSettings(descriptor=descriptor)
    return {
        name: describe_points(sampled(mesh, seed), settings).descriptor.astype(np.float64)
        for seed, (name, mesh) in enumerate(meshes.items())
    }


def main() -> int:
    shapes = bend_check_shapes()
    others = ("box", "torus", "cone")
    for family in ("parts", "bendable"):
        vectors = described(shapes, DESCRIPTOR_FAMILIES[family])

        def distance(a: str, b: str, v: dict[str, np.ndarray] = vectors) -> float:
            return float(np.linalg.norm(v[a] - v[b]))

        print(f"{family}: straight-bent {distance('straight', 'bent'):.3f} "
              f"(others >= {min(distance('straight', o) for o in others):.3f}); "
              f"finger-bent {distance('finger', 'finger-bent'):.3f} "
              f"(others >= {min(distance('finger', o) for o in others):.3f})")
    screws = {
        "socket-M10x25": _to_trimesh(standard.screw(10, 25, head="SH")),
        "socket-M6x15": _to_trimesh(standard.screw(6, 15, head="SH")),
        "button-M10x25": _to_trimesh(standard.screw(10, 25, head="BH")),
        "socket-M10x25-again": _to_trimesh(standard.screw(10, 25, head="SH")),
    }
    for name, descriptor in (("ss4", SS4_DESCRIPTOR), ("default", DESCRIPTOR_FAMILIES["parts"])):
        vectors = described(screws, descriptor)

        def distance(a: str, b: str, v: dict[str, np.ndarray] = vectors) -> float:
            return float(np.linalg.norm(v[a] - v[b]))

        print(f"{name}: socket M10x25 -> socket M6x15 "
              f"{distance('socket-M10x25', 'socket-M6x15'):.3f}, -> button M10x25 "
              f"{distance('socket-M10x25', 'button-M10x25'):.3f}, -> itself resampled "
              f"{distance('socket-M10x25', 'socket-M10x25-again'):.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
