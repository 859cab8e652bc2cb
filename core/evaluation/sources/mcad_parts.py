"""Parts of OpenSCAD's MCAD library (LGPL-2.1, Debian's ``openscad-mcad``), a third-party source.

The eighth tuning source, added after every search and descriptor setting had been chosen
on the other seven, so that it can judge them. One class
per kind of part MCAD models: cap, countersunk and hex bolts (``metric_fastners.scad``), deep
groove ball bearings (``bearing.scad``'s own table), spur and helical gears with hubs and
bevel gears (``involute_gears.scad``), NEMA stepper motors (``stepper.scad``), brick-built
blocks (``lego_compatibility.scad``), tubes (``regular_shapes.scad``) and rounded boxes
(``boxes.scad``), each in eight sizes or proportions. MCAD draws the geometry and OpenSCAD
renders it to a triangle mesh; the sizes are ours, in the range the parts come in.

Left out: MCAD's nuts and washers scale every dimension with the thread's diameter, so the
sizes of one kind are copies of one shape after the evaluation's normalisation (a class of
copies is trivially found), and its servos and screws come in one or two models.

Needs the ``openscad`` program and MCAD (``apt-get install openscad openscad-mcad``); they are
not Python wheels, so this source is for bench runs, never for the service or its tests.
"""

from __future__ import annotations

import tempfile
from collections.abc import Iterator
from pathlib import Path

import trimesh

from core.evaluation.sources._openscad import render, require_openscad

__all__ = ["KINDS", "parts"]

# (diameter, length) of bolts: lengths 3 to 7 diameters, so a kind holds several proportions.
_BOLTS = ((3, 10), (4, 25), (5, 16), (6, 40), (8, 30), (10, 70), (12, 45), (16, 100))
# bearing.scad's own models: 6xx series of several widths over diameters.
_BEARINGS = (603, 608, 625, 636, 674, 688, 695, 629)
# (teeth, circular pitch, gear thickness, rim thickness, hub thickness, hub diameter, bore,
# lightening holes)
_GEARS = ((12, 200, 5, 6, 10, 12, 4, 0), (18, 250, 4, 7, 12, 16, 5, 0),
          (24, 300, 6, 8, 12, 18, 6, 4), (30, 250, 5, 8, 14, 20, 8, 5),
          (40, 200, 4, 6, 10, 16, 6, 6), (16, 350, 8, 10, 16, 20, 8, 0),
          (36, 300, 5, 9, 15, 24, 10, 6), (20, 400, 7, 10, 18, 24, 8, 4))
# (teeth, cone distance, face width, outside circular pitch, bore)
_BEVELS = ((12, 40, 10, 500, 5), (16, 50, 12, 500, 6), (20, 60, 15, 600, 8),
           (24, 70, 15, 550, 8), (14, 45, 14, 600, 6), (30, 80, 18, 500, 10),
           (18, 55, 10, 550, 6), (26, 75, 20, 600, 12))
_MOTORS = (("Nema08", "NemaShort"), ("Nema11", "NemaMedium"), ("Nema14", "NemaLong"),
           ("Nema17", "NemaShort"), ("Nema17", "NemaLong"), ("Nema23", "NemaMedium"),
           ("Nema34", "NemaShort"), ("Nema34", "NemaLong"))
# (knobs across, knobs along, height in bricks)
_BLOCKS = ((1, 2, 1), (2, 2, 1), (2, 4, 1), (1, 4, 1), (2, 3, 3), (1, 6, 1), (2, 6, 3),
           (1, 3, 3))
# (height, radius, wall)
_TUBES = ((20, 5, 1), (40, 8, 1.5), (15, 10, 2), (60, 6, 1), (30, 12, 3), (10, 8, 1),
          (80, 10, 2), (25, 15, 2.5))
# (x, y, z, edge radius)
_BOXES = ((20, 10, 5, 1), (30, 30, 10, 3), (40, 20, 20, 4), (50, 10, 10, 2),
          (25, 25, 25, 5), (60, 40, 8, 3), (15, 30, 45, 2), (35, 20, 12, 5))


def _bolt(module: str) -> list[str]:
    return [f"use <MCAD/metric_fastners.scad>\n{module}({d}, {length});"
            for d, length in _BOLTS]


def _gear(twist: int) -> list[str]:
    return [
        "use <MCAD/involute_gears.scad>\n"
        f"gear(number_of_teeth={n}, circular_pitch={pitch}, gear_thickness={gear}, "
        f"rim_thickness={rim}, rim_width=4, hub_thickness={hub}, hub_diameter={hub_d}, "
        f"bore_diameter={bore}, circles={holes}, twist={twist});"
        for n, pitch, gear, rim, hub, hub_d, bore, holes in _GEARS
    ]


def _programs() -> dict[str, list[str]]:
    """Kind -> one OpenSCAD program per size."""
    return {
        "cap_bolt": _bolt("cap_bolt"),
        "countersunk_bolt": _bolt("csk_bolt"),
        "hex_bolt": _bolt("bolt"),
        "ball_bearing": [f"use <MCAD/bearing.scad>\nbearing(model={m});" for m in _BEARINGS],
        "spur_gear": _gear(0),
        "helical_gear": _gear(200),
        "bevel_gear": [
            "use <MCAD/involute_gears.scad>\n"
            f"bevel_gear(number_of_teeth={n}, cone_distance={cone}, face_width={face}, "
            f"outside_circular_pitch={pitch}, bore_diameter={bore});"
            for n, cone, face, pitch, bore in _BEVELS
        ],
        "stepper_motor": [f"include <MCAD/stepper.scad>\nmotor({model}, {size});"
                          for model, size in _MOTORS],
        "block": [f"use <MCAD/lego_compatibility.scad>\nblock({w}, {n}, {h}, "
                  "reinforcement=true);" for w, n, h in _BLOCKS],
        "tube": [f"use <MCAD/regular_shapes.scad>\ncylinder_tube({h}, {r}, {wall}, $fn=64);"
                 for h, r, wall in _TUBES],
        "rounded_box": [f"use <MCAD/boxes.scad>\nroundedBox([{x}, {y}, {z}], {r}, false, "
                        "$fn=32);" for x, y, z, r in _BOXES],
    }


#: Every kind this source makes (its class labels).
KINDS: tuple[str, ...] = ("cap_bolt", "countersunk_bolt", "hex_bolt", "ball_bearing",
                          "spur_gear", "helical_gear", "bevel_gear", "stepper_motor", "block",
                          "tube", "rounded_box")


def parts(kinds: tuple[str, ...] = KINDS, resolution: str = ""
          ) -> Iterator[tuple[str, str, trimesh.Trimesh]]:
    """``(kind, name, mesh)`` of every part of ``kinds``, in a fixed order.

    Parameters
    ----------
    kinds : tuple of str
    resolution : str
        OpenSCAD lines put before every program, e.g. ``"$fa = 3; $fs = 0.25;\\n"``: the
        same parts at another tessellation (a program's own ``$fn`` still wins). Empty: as
        the library renders them by default (``$fa`` 12, ``$fs`` 2: an M3 shank has five
        sides).

    Raises
    ------
    FileNotFoundError
        ``openscad`` is not on the path (``apt-get install openscad openscad-mcad``).
    """
    require_openscad("openscad openscad-mcad")
    programs = _programs()
    with tempfile.TemporaryDirectory(prefix="mcad-") as folder:
        for kind in kinds:
            for index, program in enumerate(programs[kind]):
                yield kind, f"{kind}_{index:02d}", render(resolution + program, Path(folder))
