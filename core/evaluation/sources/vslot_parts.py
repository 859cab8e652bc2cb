"""Linear-motion parts of bd-vslot (MIT) on build123d (Apache-2.0), a third-party source.

One class per kind of part the library models: build plates and L brackets with hole grids,
rail end caps, V-groove wheels, sealed bearings and sliding T-nuts, each in several sizes (hole
grids, thicknesses, diameters). The library draws the geometry; the sizes are ours, in the
range the parts come in. Its rails are left out: bd-vslot 0.0.2 builds their profile with an
empty location list, which build123d 0.13 (the version py-gearworks brings) refuses.
OpenCascade (through build123d) tessellates with a chordal tolerance relative to the part's
size (``core.evaluation.sources._build123d``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import trimesh

from core.evaluation.sources._build123d import to_trimesh

__all__ = ["KINDS", "parts"]

# Per kind, the positional arguments of each size.
# (thickness, holes along x, holes along y, hole radius, corner radius)
_PLATES = ((3.0, 4, 4, 1.55, 0.0), (4.0, 6, 4, 2.05, 2.0), (5.0, 8, 6, 2.55, 4.0),
           (3.0, 3, 8, 1.55, 1.0), (6.0, 10, 10, 3.05, 5.0), (4.0, 5, 3, 2.05, 0.0),
           (8.0, 6, 6, 2.55, 3.0), (5.0, 12, 4, 2.55, 2.0))
# (thickness, holes along x, holes along y, holes along z, hole radius)
_L_PLATES = ((3.0, 2, 2, 2, 1.55), (4.0, 3, 2, 2, 2.05), (5.0, 4, 3, 3, 2.55),
             (3.0, 2, 4, 2, 1.55), (6.0, 5, 2, 4, 3.05), (4.0, 3, 3, 5, 2.05),
             (5.0, 6, 2, 2, 2.55), (4.0, 2, 3, 3, 2.05))
# (thickness, holes along x, holes along y, hole radius, corner radius)
_END_CAPS = ((3.0, 1, 1, 2.55, 0.0), (4.0, 1, 2, 2.55, 1.0), (3.0, 2, 2, 2.55, 2.0),
             (5.0, 1, 4, 2.55, 0.0), (4.0, 3, 2, 2.55, 1.0), (6.0, 2, 4, 2.55, 2.0),
             (3.0, 1, 3, 2.05, 1.0), (5.0, 3, 3, 3.05, 0.0))
# (outer diameter, inner diameter, outer thickness, inner thickness); the first two the
# library's own 2020 wheel and mini wheel
_WHEELS = ((23.9, 16.0, 10.2, 5.9), (15.2, 10.0, 8.8, 5.8), (30.0, 20.0, 12.0, 7.0),
           (20.0, 12.0, 9.0, 5.0), (40.0, 26.0, 14.0, 8.0), (18.0, 11.0, 8.0, 5.0),
           (34.0, 22.0, 11.0, 6.5), (26.0, 14.0, 10.0, 6.0))
# (outer diameter, inner diameter, thickness): 625, 688 and 105 are the library's own
_BEARINGS = ((16.0, 5.0, 5.0), (16.0, 8.0, 5.0), (10.0, 5.0, 4.0), (22.0, 8.0, 7.0),
             (26.0, 10.0, 8.0), (13.0, 4.0, 5.0), (19.0, 6.0, 6.0), (32.0, 12.0, 10.0))
_T_NUTS = (1.5, 2.0, 2.5, 3.0, 1.8, 2.2, 2.8, 1.6)


def _kinds() -> dict[str, tuple[tuple[tuple[float, ...], ...], Callable[..., Any]]]:
    """Kind -> (the arguments of each size, the library's part class they are passed to)."""
    import bd_vslot as vs

    return {
        "build_plate": (_PLATES, vs.BuildPlate),
        "l_bracket": (_L_PLATES, vs.LPlate),
        "end_cap": (_END_CAPS, vs.VSlot2020EndCap),
        "wheel": (_WHEELS, vs.Wheel),
        "bearing": (_BEARINGS, vs.Bearing),
        "t_nut": (tuple((radius,) for radius in _T_NUTS), vs.VSlot2020SlidingTNut),
    }


#: Every kind this source makes (its class labels).
KINDS: tuple[str, ...] = ("build_plate", "l_bracket", "end_cap", "wheel", "bearing", "t_nut")


def parts(kinds: tuple[str, ...] = KINDS) -> Iterator[tuple[str, str, trimesh.Trimesh]]:
    """``(kind, name, mesh)`` of every part of ``kinds``, in a fixed order.

    Raises
    ------
    ImportError
        bd-vslot is not installed (``pip install 'shapesearch[tune]'``).
    """
    table = _kinds()
    for kind in kinds:
        arguments, build = table[kind]
        for index, args in enumerate(arguments):
            yield kind, f"{kind}_{index:02d}", to_trimesh(build(*args))
