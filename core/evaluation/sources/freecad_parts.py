"""Parts drawn by FreeCAD's own modules (LGPL-2.1+, Debian's ``freecad``), a third-party source.

The tenth library, added after every setting had been chosen, to judge them and to bring
a kind that no other library here makes:
roller-chain sprockets, one of the held-out set's weakest kinds. One class per kind, eight
sizes each:

- ``sprocket``: PartDesign's sprocket profile (``fcsprocket``; ANSI B29.1 and ISO 606 chains,
  its own table of pitch, roller diameter and plate thickness), padded to the table's
  thickness, with a bore;
- ``spur_gear`` and ``ring_gear``: PartDesign's involute profiles (``fcgear``), external and
  internal, padded, with a bore or an outer rim;
- ``i_beam``, ``channel``, ``rect_tube``, ``round_tube``: Arch's steel sections from its own
  table of standard profiles (HEA, HEB, IPE, INP, UB, UC, W; UPE and Indian and aluminium
  channels; RHS and SHS; CHS), extruded.

FreeCAD draws every profile from its tables; the tooth counts, face widths, bores and
lengths are ours, in the range the parts come in.

Needs ``freecadcmd`` (``apt-get install freecad``): not a Python wheel, so this source is for
bench runs, never for the service or its tests.
"""

from __future__ import annotations

import tempfile
from collections.abc import Iterator
from pathlib import Path

import trimesh

from core.evaluation.sources._freecad import render, require_freecad

__all__ = ["KINDS", "parts"]

# (chain, teeth, bore in mm); pitch, roller diameter and thickness come from FreeCAD's table.
_SPROCKETS = (("ANSI 25", 32, 8), ("ANSI 35", 15, 10), ("ANSI 40", 24, 16),
              ("ANSI 50", 12, 16), ("ANSI 60", 40, 25), ("ISO 606 08B", 18, 12),
              ("ISO 606 12B", 21, 20), ("ANSI 80", 10, 20))
# (module, teeth, face width, bore) of external gears, all at 20 degrees.
_SPURS = ((1, 20, 8, 5), (1.5, 30, 12, 8), (2, 14, 16, 8), (2.5, 40, 20, 20),
          (1, 50, 6, 10), (3, 18, 24, 15), (2, 25, 10, 12), (1.25, 36, 15, 10))
# (module, teeth, face width, rim beyond the root circle) of internal gears.
_RINGS = ((1, 40, 8, 3), (1.5, 48, 12, 5), (2, 30, 16, 6), (2.5, 60, 20, 8),
          (1, 72, 6, 4), (3, 36, 24, 10), (2, 44, 10, 5), (1.25, 56, 15, 6))
# (Arch's profile name, length as a multiple of the section's larger side)
_I_BEAMS = (("IPE100", 4), ("HEA200", 3), ("HEB160", 5), ("INP120", 6),
            ("UB203x133x25", 2.5), ("UC152x152x23", 4), ("W8x31", 3.5), ("IPE300", 2))
_CHANNELS = (("UPE100", 4), ("UPE200", 3), ("ISMC100", 5), ("ISLC150", 2.5),
             ("ISJC125", 6), ("3x1.5 Channel", 4), ("6x2.5 Channel", 3), ("UPE300", 2))
_RECT_TUBES = (("RHS50x30x3", 4), ("RHS100x50x4", 3), ("RHS60x40x2.9", 6),
               ("RHS120x80x5", 2.5), ("RHS90x50x8", 5), ("SHS40x40x3.2", 4),
               ("SHS25x25x2.6", 8), ("RHS150x100x5", 2))
_ROUND_TUBES = (("CHS21.3x2.6", 6), ("CHS48.3x3.2", 4), ("CHS88.9x5", 3),
                ("CHS33.7x4.5", 8), ("CHS114.3x3.6", 2.5), ("CHS60.3x8", 5),
                ("CHS168.3x10", 2), ("CHS42.4x2.9", 3.5))

_PROFILE = """
import FreeCAD, Part
from {module} import {builder}, {profile}
wires = {builder}.FCWireBuilder()
{profile}.{create}
face = Part.Face(Part.Wire([edge.toShape() for edge in wires.wire]))
"""


def _involute(create: str) -> str:
    """The lines that make ``face``, the involute profile ``fcgear``'s ``create`` draws."""
    return _PROFILE.format(module="fcgear", builder="fcgear", profile="involute",
                           create=create)


def _sprocket(chain: str, teeth: int, bore: float) -> str:
    return (
        "from SprocketFeature import Sprocket\n"
        f"pitch, roller, thickness = (25.4 * v for v in "
        f"Sprocket.SprocketReferenceRollerTable[{chain!r}])\n"
        + _PROFILE.format(module="fcsprocket", builder="fcsprocket", profile="sprocket",
                          create=f"CreateSprocket(wires, pitch, {teeth}, roller)")
        + "plate = face.extrude(FreeCAD.Vector(0, 0, thickness))\n"
        f"shape = plate.cut(Part.makeCylinder({bore / 2}, 3 * thickness, "
        "FreeCAD.Vector(0, 0, -thickness)))\n"
    )


def _spur(module: float, teeth: int, width: float, bore: float) -> str:
    return (
        _involute(f"CreateExternalGear(wires, {module}, {teeth}, 20, False)")
        + f"gear = face.extrude(FreeCAD.Vector(0, 0, {width}))\n"
        f"shape = gear.cut(Part.makeCylinder({bore / 2}, {3 * width}, "
        f"FreeCAD.Vector(0, 0, {-width})))\n"
    )


def _ring(module: float, teeth: int, width: float, rim: float) -> str:
    outer = module * teeth / 2 + 1.25 * module + rim
    return (
        _involute(f"CreateInternalGear(wires, {module}, {teeth}, 20, False)")
        + f"teeth = face.extrude(FreeCAD.Vector(0, 0, {3 * width}))\n"
        f"teeth.translate(FreeCAD.Vector(0, 0, {-width}))\n"
        f"shape = Part.makeCylinder({outer}, {width}).cut(teeth)\n"
    )


def _section(name: str, length: float) -> str:
    return (
        "import FreeCAD, ArchProfile\n"
        "FreeCAD.newDocument('part')\n"
        f"preset = {{row[2]: row for row in ArchProfile.readPresets()}}[{name!r}]\n"
        "section = ArchProfile.makeProfile(preset)\n"
        "FreeCAD.ActiveDocument.recompute()\n"
        "face = section.Shape.Faces[0]\n"
        "box = face.optimalBoundingBox()  # the plain box of a circle is loose\n"
        "side = max(box.XLength, box.YLength)\n"
        f"shape = face.extrude(FreeCAD.Vector(0, 0, {length} * side))\n"
    )


def _scripts() -> dict[str, list[str]]:
    """Kind -> one FreeCAD script per size, each building ``shape``."""
    return {
        "sprocket": [_sprocket(*size) for size in _SPROCKETS],
        "spur_gear": [_spur(*size) for size in _SPURS],
        "ring_gear": [_ring(*size) for size in _RINGS],
        "i_beam": [_section(*size) for size in _I_BEAMS],
        "channel": [_section(*size) for size in _CHANNELS],
        "rect_tube": [_section(*size) for size in _RECT_TUBES],
        "round_tube": [_section(*size) for size in _ROUND_TUBES],
    }


#: Every kind this source makes (its class labels).
KINDS: tuple[str, ...] = ("sprocket", "spur_gear", "ring_gear", "i_beam", "channel",
                          "rect_tube", "round_tube")


def parts(kinds: tuple[str, ...] = KINDS) -> Iterator[tuple[str, str, trimesh.Trimesh]]:
    """``(kind, name, mesh)`` of every part of ``kinds``, in a fixed order.

    Raises
    ------
    FileNotFoundError
        ``freecadcmd`` is not on the path (``apt-get install freecad``).
    RuntimeError
        FreeCAD built no valid solid for a size (the message says why).
    """
    require_freecad()
    scripts = _scripts()
    with tempfile.TemporaryDirectory(prefix="freecad-") as folder:
        for kind in kinds:
            for index, script in enumerate(scripts[kind]):
                yield kind, f"{kind}_{index:02d}", render(script, Path(folder))
