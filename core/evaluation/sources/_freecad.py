"""Running FreeCAD scripts that build a part, shared by the sources drawn inside FreeCAD
(its own modules; cqparts, on CadQuery 1.x).

FreeCAD is not a Python wheel (Debian's ``freecad``); its headless ``freecadcmd`` runs a
script that builds a ``Part`` shape named ``shape``; the lines added here mesh it and write an
STL, which trimesh reads back.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import trimesh

__all__ = ["render", "require_freecad"]

#: The folders of FreeCAD's modules whose Python parts the scripts import.
MODULES = Path("/usr/share/freecad/Mod")

# Mesh the solid finely enough that its small features (a tooth's flank, a fillet) are
# several triangles wide: deflection as a share of the part's bounding-box diagonal.
_EXPORT = """
import MeshPart
assert shape.isValid() and shape.Volume > 0, "not a valid solid"
deflection = shape.BoundBox.DiagonalLength / 800
mesh = MeshPart.meshFromShape(Shape=shape, LinearDeflection=deflection,
                              AngularDeflection=0.3)
mesh.write({stl!r})
"""


def require_freecad() -> None:
    """Raise ``FileNotFoundError`` naming the Debian package to install when ``freecadcmd``
    is not on the path."""
    if shutil.which("freecadcmd") is None:
        raise FileNotFoundError("freecadcmd is not installed: apt-get install freecad")


def render(script: str, folder: Path, paths: tuple[Path, ...] = ()) -> trimesh.Trimesh:
    """The mesh of the solid ``shape`` that ``script`` builds (FreeCAD's own mesher, read
    back by trimesh); ``paths`` go first on the script's ``sys.path`` (a folder of Python
    libraries that build on FreeCAD).

    Raises
    ------
    RuntimeError
        The script failed or built no valid solid: the message holds its traceback's end.
    """
    source, stl = folder / "part.py", folder / "part.stl"
    stl.unlink(missing_ok=True)
    folders = [*map(str, paths), *(str(MODULES / m) for m in ("PartDesign", "Arch"))]
    preamble = f"import sys\nsys.path[:0] = {folders}\n"
    source.write_text(preamble + script + _EXPORT.format(stl=str(stl)))
    run = subprocess.run(["freecadcmd", str(source)], capture_output=True, text=True,
                         timeout=600)
    if not stl.exists():
        reason = (run.stderr or run.stdout).strip().splitlines()[-3:]
        raise RuntimeError(f"freecadcmd built no part: {' | '.join(reason)}")
    mesh = trimesh.load_mesh(stl, process=True)
    stl.unlink()
    return mesh
