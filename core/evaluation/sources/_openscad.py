"""Rendering OpenSCAD programs to meshes, shared by the sources drawn by OpenSCAD libraries."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import trimesh

__all__ = ["render", "require_openscad"]


def require_openscad(packages: str) -> None:
    """Raise ``FileNotFoundError`` naming the Debian ``packages`` to install when the
    ``openscad`` program is not on the path (it is not a Python wheel)."""
    if shutil.which("openscad") is None:
        raise FileNotFoundError(f"openscad is not installed: apt-get install {packages}")


def render(program: str, folder: Path, library_path: Path | None = None) -> trimesh.Trimesh:
    """The mesh OpenSCAD renders from ``program`` (its STL, written in ``folder``, read back
    by trimesh); ``library_path`` is searched for ``include``/``use`` (``OPENSCADPATH``).

    Raises
    ------
    RuntimeError
        OpenSCAD refused the program (a library's assertion, e.g. a size its tables lack):
        the message holds the program's last line and OpenSCAD's reason.
    """
    source, stl = folder / "part.scad", folder / "part.stl"
    source.write_text(program)
    environment = dict(os.environ)
    if library_path is not None:
        environment["OPENSCADPATH"] = str(library_path)
    run = subprocess.run(["openscad", "-q", "-o", str(stl), str(source)],
                         capture_output=True, text=True, timeout=600, env=environment)
    if run.returncode:
        statement = program.strip().splitlines()[-1]
        raise RuntimeError(f"openscad could not render {statement!r}: {run.stderr.strip()}")
    mesh = trimesh.load_mesh(stl, process=True)
    stl.unlink()
    return mesh
