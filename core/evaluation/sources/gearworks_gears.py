"""Gears of py-gearworks (MIT) on build123d (Apache-2.0), a third-party source.

One class per gear kind: spur, helical, herringbone, bevel, internal (ring), rack and
cycloid gears, each with several tooth counts, modules and face widths; spur, helical,
herringbone and bevel gears get a bore, as made. The solids come from py-gearworks'
parametric tooth geometry and are tessellated by OpenCascade (through build123d) with a
chordal tolerance relative to the part's size.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import trimesh

from core.evaluation.sources._build123d import to_trimesh

__all__ = ["KINDS", "parts"]

# (teeth, module, face width): small to large, thin to wide.
_SIZES = ((12, 1.0, 4.0), (17, 1.5, 8.0), (20, 1.0, 10.0), (24, 2.0, 12.0), (30, 1.0, 6.0),
          (36, 1.5, 10.0), (40, 2.0, 15.0), (48, 1.0, 8.0), (15, 3.0, 20.0), (56, 1.5, 12.0))


def _kinds() -> dict[str, Callable[[Any, int, float, float], Any]]:
    return {
        "spur_gear": lambda gw, z, m, h: gw.SpurGear(number_of_teeth=z, module=m, height=h),
        "helical_gear": lambda gw, z, m, h: gw.HelicalGear(
            number_of_teeth=z, module=m, height=h, helix_angle=0.35),
        "herringbone_gear": lambda gw, z, m, h: gw.HelicalGear(
            number_of_teeth=z, module=m, height=h, helix_angle=0.45, herringbone=True),
        "bevel_gear": lambda gw, z, m, h: gw.BevelGear(
            number_of_teeth=z, module=m, height=0.4 * h, cone_angle=0.8),
        "ring_gear": lambda gw, z, m, h: gw.SpurRingGear(
            number_of_teeth=z + 12, module=m, height=h),
        "rack": lambda gw, z, m, h: gw.InvoluteRack(number_of_teeth=z // 2 + 4, module=m,
                                                    height=h),
        "cycloid_gear": lambda gw, z, m, h: gw.CycloidGear(number_of_teeth=z, module=m,
                                                           height=h),
    }


#: Every kind this source makes (its class labels).
KINDS: tuple[str, ...] = tuple(_kinds())
_BORED = ("spur_gear", "helical_gear", "herringbone_gear", "bevel_gear")


def _solid(kind: str, teeth: int, module: float, width: float) -> Any:
    import build123d as bd
    import py_gearworks as gw

    part = _kinds()[kind](gw, teeth, module, width).build_part()
    if kind in _BORED:
        box = part.bounding_box()
        radius = 0.15 * teeth * module  # about a third of the pitch radius
        bore = bd.Pos(*box.center()) * bd.Cylinder(radius, 4 * (box.max.Z - box.min.Z))
        part = part - bore
    return part


def parts(kinds: tuple[str, ...] = KINDS) -> Iterator[tuple[str, str, trimesh.Trimesh]]:
    """``(kind, name, mesh)`` of every gear of ``kinds``, in a fixed order.

    Raises
    ------
    ImportError
        py-gearworks is not installed (``pip install 'shapesearch[tune]'``).
    """
    for kind in kinds:
        for teeth, module, width in _SIZES:
            name = f"z{teeth}m{module:g}b{width:g}"
            yield kind, name, to_trimesh(_solid(kind, teeth, module, width))
