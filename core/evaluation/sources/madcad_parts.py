"""Standard parts of pymadcad's ``madcad.standard`` (LGPL-3.0), a third-party source.

One class per kind: screws of four head types, hex nuts, washers, ball, roller and thrust
bearings, compression and tension springs and slide bearings (bushings), each in several
standard sizes and, for screws and springs, several proportions. pymadcad builds each part
as a triangle mesh from its own parametric model; we only choose the parameters.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import trimesh

__all__ = ["KINDS", "parts"]

_DIAMETERS = (3, 4, 5, 6, 8, 10, 12, 16, 20, 24)
# Length over diameter of screws: short to long, so a kind holds several proportions.
_SCREW_RATIOS = (1.6, 2.5, 3.3, 4.0, 5.0, 2.0, 3.0, 6.0, 2.2, 4.5)


def _call(function: str, *args: Any, **kwargs: Any) -> Callable[[Any], Any]:
    """``standard.<function>(*args, **kwargs)``, for the module ``standard`` given later
    (pymadcad is imported only when a part is built)."""
    return lambda standard: getattr(standard, function)(*args, **kwargs)


def _screws(head: str) -> Iterator[tuple[str, Callable[[Any], Any]]]:
    for d, ratio in zip(_DIAMETERS, _SCREW_RATIOS, strict=True):
        length = float(round(d * ratio))
        yield f"M{d}x{length:g}", _call("screw", d, length, head=head)


def _kinds() -> dict[str, Callable[[], Iterator[tuple[str, Callable[[Any], Any]]]]]:
    bearings = (10, 12, 15, 17, 20, 25, 30, 35, 40, 50)
    return {
        "screw_socket_head": lambda: _screws("SH"),
        "screw_button_head": lambda: _screws("BH"),
        "screw_flat_head": lambda: _screws("VH"),
        "screw_hex_head": lambda: _screws("HH"),
        "hex_nut": lambda: ((f"M{d}", _call("nut", d)) for d in _DIAMETERS),
        "washer": lambda: ((f"M{d}", _call("washer", d)) for d in _DIAMETERS),
        "ball_bearing": lambda: (
            (f"d{d}", _call("bearing", d, circulating="ball", detail=True))
            for d in bearings
        ),
        "roller_bearing": lambda: (
            (f"d{d}", _call("bearing", d, circulating="roller", detail=True))
            for d in bearings
        ),
        "thrust_bearing": lambda: (
            (f"d{d}", _call("bearing_thrust", d, 2.2 * d, 0.6 * d, detail=True))
            for d in bearings
        ),
        "compression_spring": lambda: (
            (f"L{length}d{d}", _call("coilspring_compression", length, d, 0.1 * d))
            for length, d in zip((20, 30, 40, 25, 50, 60, 35, 45, 80, 30),
                                 (8, 10, 10, 12, 12, 15, 8, 20, 20, 16), strict=True)
        ),
        "tension_spring": lambda: (
            (f"L{length}d{d}", _call("coilspring_tension", length, d, 0.1 * d))
            for length, d in zip((30, 40, 50, 35, 60, 70, 45, 55, 90, 40),
                                 (8, 10, 10, 12, 12, 15, 8, 20, 20, 16), strict=True)
        ),
        "slide_bearing": lambda: (
            (f"d{d}h{h}", _call("slidebearing", d, h, shoulder=shoulder))
            for d, h, shoulder in zip(bearings, (8, 10, 20, 12, 30, 20, 25, 40, 30, 45),
                                      (None, 2, None, 3, None, 4, None, 5, None, 6),
                                      strict=True)
        ),
    }


#: Every kind this source makes (its class labels).
KINDS: tuple[str, ...] = tuple(_kinds())


def _to_trimesh(built: Any) -> trimesh.Trimesh:
    """A madcad part (a ``Solid`` holding a ``Mesh``, or a ``Mesh``) as a trimesh."""
    mesh = built["part"] if hasattr(built, "keys") else built
    mesh = mesh.finish() if hasattr(mesh, "finish") else mesh
    points = np.array([tuple(point) for point in mesh.points], dtype=np.float64)
    faces = np.array([tuple(face) for face in mesh.faces], dtype=np.int64)
    return trimesh.Trimesh(points, faces, process=True)


def parts(kinds: tuple[str, ...] = KINDS) -> Iterator[tuple[str, str, trimesh.Trimesh]]:
    """``(kind, name, mesh)`` of every part of ``kinds``, in a fixed order.

    Raises
    ------
    ImportError
        pymadcad is not installed (``pip install 'shapesearch[tune]'``).
    """
    import madcad.standard as standard

    builders = _kinds()
    for kind in kinds:
        for name, build in builders[kind]():
            yield kind, name, _to_trimesh(build(standard))
