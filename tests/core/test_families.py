"""Descriptor families (``core.settings.DESCRIPTOR_FAMILIES``): a bent copy of a bendable
shape stays nearer to itself than to other shapes with the ``bendable`` family, and a
screw's head type counts more than its size with the default ``parts`` family."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from core.evaluation.sources.bendable import bend_check_shapes
from core.pipeline import describe_points
from core.settings import DESCRIPTOR_FAMILIES, EngineSettings


def sampled(mesh: trimesh.Trimesh, seed: int) -> np.ndarray:
    points, _ = trimesh.sample.sample_surface(mesh, 3000, seed=seed)
    return np.asarray(points)


def describe_all(meshes: dict[str, trimesh.Trimesh], family: str) -> dict[str, np.ndarray]:
    settings = EngineSettings(descriptor=DESCRIPTOR_FAMILIES[family])
    return {
        name: describe_points(sampled(mesh, seed), settings).descriptor.astype(np.float64)
        for seed, (name, mesh) in enumerate(meshes.items())
    }


@pytest.fixture(scope="module")
def bendable_shapes() -> dict[str, trimesh.Trimesh]:
    return bend_check_shapes()


@pytest.mark.slow
def test_bendable_family_keeps_a_bent_copy_near_itself(bendable_shapes) -> None:
    vectors = describe_all(bendable_shapes, "bendable")

    def distance(a: str, b: str) -> float:
        return float(np.linalg.norm(vectors[a] - vectors[b]))

    others = ("box", "torus", "cone")
    # Measured by the families check (see the changelog): 0.05 against >= 0.32 to the other
    # shapes; 0.09 against >= 0.30 for the finger.
    assert distance("straight", "bent") < 0.3 * min(distance("straight", o) for o in others)
    assert distance("finger", "finger-bent") < 0.5 * min(distance("finger", o) for o in others)
    # Nearer to its own bent copy than to another straight tube.
    assert distance("straight", "bent") < distance("straight", "finger")


@pytest.mark.slow
def test_parts_family_sees_the_bend_that_bendable_ignores(bendable_shapes) -> None:
    # Why two families: the default sees how a surface sits in space, so a bent tube is
    # further from its straight self, relative to other shapes, than with ``bendable``.
    ratios = {}
    for family in ("parts", "bendable"):
        vectors = describe_all(
            {k: bendable_shapes[k] for k in ("straight", "bent", "box", "cone")}, family
        )
        bend = np.linalg.norm(vectors["straight"] - vectors["bent"])
        other = min(np.linalg.norm(vectors["straight"] - vectors[o]) for o in ("box", "cone"))
        ratios[family] = bend / other
    assert ratios["bendable"] < 0.5 * ratios["parts"]


@pytest.mark.slow
def test_screw_head_type_counts_more_than_size() -> None:
    # A socket-head screw finds a socket-head screw of another size before a button-head
    # screw of its own size (pymadcad's standard screws, made in code).
    standard = pytest.importorskip(
        "madcad.standard", reason="pymadcad (the test extra) is not installed"
    )
    from core.evaluation.sources.madcad_parts import _to_trimesh

    screws = {
        "socket-M10x25": _to_trimesh(standard.screw(10, 25, head="SH")),
        "socket-M6x15": _to_trimesh(standard.screw(6, 15, head="SH")),
        "button-M10x25": _to_trimesh(standard.screw(10, 25, head="BH")),
        "socket-M10x25-again": _to_trimesh(standard.screw(10, 25, head="SH")),
    }
    vectors = describe_all(screws, "parts")

    def distance(a: str, b: str) -> float:
        return float(np.linalg.norm(vectors[a] - vectors[b]))

    # Measured by the families check (see the changelog): 0.055 to the smaller socket head, 0.38 to
    # the button head, 0.059 to itself sampled again; ss4, before the local block: 0.040, 0.26,
    # 0.045. Both tell the head types apart.
    assert distance("socket-M10x25", "socket-M6x15") < 0.5 * distance(
        "socket-M10x25", "button-M10x25"
    )
    # The head type is well outside the noise of sampling the same screw again.
    assert distance("socket-M10x25", "button-M10x25") > 3 * distance(
        "socket-M10x25", "socket-M10x25-again"
    )
