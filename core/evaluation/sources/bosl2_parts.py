"""Parts of the BOSL2 OpenSCAD library (BSD-2-Clause), a third-party source.

The ninth source, added after every search and descriptor setting had been chosen on the
others, so that it can judge them. Its kinds are the
held-out set's kind of part: ISO screws of five head types (socket, button, countersunk,
hex, pan) and set screws (``screws.scad``), hex and square nuts of the ISO and DIN
thicknesses, deep-groove ball bearings (``ball_bearings.scad``'s trade sizes), LMxUU linear
bearings, spur, straight bevel and ring gears and racks (``gears.scad``) and NEMA stepper
motors (``nema_steppers.scad``), each in eight sizes. BOSL2 draws the geometry from its own
tables of the standards and OpenSCAD renders it to a triangle mesh; the sizes are ours, in
the range the parts come in. Screws and nuts are unthreaded, as the other libraries' are.

BOSL2 comes inside the ``solidpython2`` wheel (the ``tune`` extra); only its ``.scad`` files
are used, found through the package's location without importing it. The ``openscad``
program is not a wheel (``apt-get install openscad``), so this source is for bench runs,
never for the service or its tests.
"""

from __future__ import annotations

import importlib.util
import tempfile
from collections.abc import Iterator
from pathlib import Path

import trimesh

from core.evaluation.sources._openscad import render, require_openscad

__all__ = ["KINDS", "bosl2_folder", "parts"]

_HEADER = "\n".join(f"include <BOSL2/{name}.scad>" for name in (
    "std", "screws", "ball_bearings", "linear_bearings", "gears", "nema_steppers"))

# (ISO diameter, length): lengths of 2 to 7 diameters, so a kind holds several proportions;
# BOSL2's tables hold hex heads from M5 and pan heads up to M10.
_SCREWS = ((3, 8), (4, 20), (5, 30), (6, 16), (8, 50), (10, 35), (12, 80), (16, 60))
_HEX_SCREWS = ((5, 12), (6, 30), (8, 20), (10, 60), (12, 40), (16, 100), (20, 70), (24, 120))
_PAN_SCREWS = ((2, 6), (2.5, 12), (3, 16), (4, 10), (5, 25), (6, 20), (8, 40), (10, 30))
_SET_SCREWS = ((3, 4), (4, 8), (5, 6), (6, 12), (8, 10), (10, 20), (12, 16), (16, 25))
# Nut thickness after ISO 4035 / 4032 / 4033 ("thin", "normal", "thick") and DIN, where
# BOSL2's tables hold the size (no thin M8 nut, no thick hex nut below M5).
_HEX_NUTS = ((3, "normal"), (4, "DIN"), (5, "thin"), (6, "thick"), (8, "normal"),
             (10, "thin"), (12, "thick"), (16, "DIN"))
_SQUARE_NUTS = ((3, "normal"), (4, "thin"), (5, "thick"), (6, "normal"), (8, "thick"),
                (10, "thin"), (12, "normal"), (16, "thick"))
_BALL_BEARINGS = ("608", "635", "6001", "6202", "6205", "6303", "R8", "6007")
_LINEAR_BEARINGS = (4, 6, 8, 10, 12, 16, 20, 25)
# (module, teeth, thickness, shaft diameter)
_SPUR_GEARS = ((1, 12, 4, 3), (1.5, 17, 8, 5), (1, 20, 10, 5), (2, 24, 12, 8),
               (1, 30, 6, 6), (1.25, 36, 8, 8), (2, 40, 10, 10), (1.5, 48, 6, 8))
# (module, teeth, mate's teeth, face width, shaft diameter)
_BEVEL_GEARS = ((1, 12, 24, 4, 3), (1.5, 16, 16, 6, 5), (1, 20, 40, 5, 5),
                (2, 24, 18, 10, 8), (1, 30, 15, 6, 6), (1.25, 36, 24, 8, 8),
                (2, 18, 36, 8, 6), (1.5, 28, 28, 7, 8))
# (module, teeth, thickness, backing)
_RING_GEARS = ((1, 30, 6, 3), (1.5, 36, 8, 4), (1, 48, 10, 3), (2, 40, 12, 5),
               (1, 60, 6, 4), (1.25, 42, 8, 3), (2, 32, 10, 6), (1.5, 56, 6, 4))
# (module, teeth, thickness, height)
_RACKS = ((1, 12, 5, 6), (1.5, 16, 8, 8), (1, 24, 6, 5), (2, 10, 12, 10),
          (1, 30, 8, 8), (1.25, 20, 6, 7), (2, 16, 10, 12), (1.5, 24, 6, 6))
# (NEMA size, body length)
_STEPPERS = ((11, 32), (14, 28), (14, 40), (17, 34), (17, 48), (23, 56), (23, 76), (34, 66))


def _screws(head: str, drive: str,
            sizes: tuple[tuple[float, int], ...] = _SCREWS) -> list[str]:
    return [f'screw("M{d:g}", length={length}, head="{head}", drive="{drive}", thread=false);'
            for d, length in sizes]


def _programs() -> dict[str, list[str]]:
    """Kind -> one OpenSCAD statement per size."""
    return {
        "socket_head_screw": _screws("socket", "hex"),
        "button_head_screw": _screws("button", "hex"),
        "countersunk_screw": _screws("flat", "hex"),
        "hex_head_screw": _screws("hex", "none", _HEX_SCREWS),
        "pan_head_screw": _screws("pan", "phillips", _PAN_SCREWS),
        "set_screw": _screws("none", "hex", _SET_SCREWS),
        "hex_nut": [f'nut("M{d}", shape="hex", thickness="{t}", thread=false);'
                    for d, t in _HEX_NUTS],
        "square_nut": [f'nut("M{d}", shape="square", thickness="{t}", thread=false);'
                       for d, t in _SQUARE_NUTS],
        "ball_bearing": [f'ball_bearing("{size}", $fn=32);' for size in _BALL_BEARINGS],
        "linear_bearing": [f"lmXuu_bearing({size}, $fn=48);" for size in _LINEAR_BEARINGS],
        "spur_gear": [f"spur_gear(mod={m}, teeth={n}, thickness={t}, shaft_diam={s});"
                      for m, n, t, s in _SPUR_GEARS],
        "bevel_gear": [f"bevel_gear(mod={m}, teeth={n}, mate_teeth={mate}, face_width={f}, "
                       f"shaft_diam={s}, spiral=0);" for m, n, mate, f, s in _BEVEL_GEARS],
        "ring_gear": [f"ring_gear(mod={m}, teeth={n}, thickness={t}, backing={b});"
                      for m, n, t, b in _RING_GEARS],
        "rack": [f"rack(mod={m}, teeth={n}, thickness={t}, height={h});"
                 for m, n, t, h in _RACKS],
        "stepper_motor": [f"nema_stepper_motor({size}, h={h});" for size, h in _STEPPERS],
    }


#: Every kind this source makes (its class labels).
KINDS: tuple[str, ...] = tuple(_programs())


def bosl2_folder() -> Path:
    """The folder that holds ``BOSL2/`` inside the installed ``solidpython2`` package.

    Raises
    ------
    FileNotFoundError
        ``solidpython2`` is not installed (the ``tune`` extra).
    """
    spec = importlib.util.find_spec("solid2")
    if spec is None or not spec.submodule_search_locations:
        raise FileNotFoundError("BOSL2 ships in solidpython2: pip install -e '.[tune]'")
    folder = Path(next(iter(spec.submodule_search_locations))) / "extensions" / "bosl2"
    if not (folder / "BOSL2" / "std.scad").is_file():
        raise FileNotFoundError(f"no BOSL2 under {folder}")
    return folder


def parts(kinds: tuple[str, ...] = KINDS) -> Iterator[tuple[str, str, trimesh.Trimesh]]:
    """``(kind, name, mesh)`` of every part of ``kinds``, in a fixed order.

    Raises
    ------
    FileNotFoundError
        ``openscad`` is not on the path, or ``solidpython2`` (which carries BOSL2) is not
        installed.
    """
    require_openscad("openscad")
    library, programs = bosl2_folder(), _programs()
    with tempfile.TemporaryDirectory(prefix="bosl2-") as folder:
        for kind in kinds:
            for index, statement in enumerate(programs[kind]):
                program = f"{_HEADER}\n{statement}\n"
                yield kind, f"{kind}_{index:02d}", render(program, Path(folder), library)
