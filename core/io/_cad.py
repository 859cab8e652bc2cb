"""STEP and IGES parts through OpenCascade (the optional ``cadquery-ocp`` wheel, or
``cadquery-ocp-novtk``: the same ``OCP`` module without VTK).

A CAD file holds exact surfaces (B-rep), not triangles. ``read_cad`` reads it, merges all
root shapes into one (an assembly becomes one shape: its parts at their placements, as one
would scan the assembled product), and tessellates it with a linear deflection of
``RELATIVE_DEFLECTION`` times the bounding-box diagonal, so a 5 mm pin and a 5 m frame get
the same relative fidelity. The triangles are then sampled like any mesh.

The wheel is large (about 1.3 GB installed with its VTK dependency, 380 MB without), so it
is an extra: ``pip install 'shapesearch[cad]'`` (or ``[cad-novtk]``). Without it ``read_cad``
raises ``cad_unavailable``.
"""

from __future__ import annotations

import os
import tempfile
from types import SimpleNamespace
from typing import Any

import numpy as np

from core.errors import InvalidShapeError
from core.io._meshes import RawGeometry

__all__ = ["CAD_HINT", "RELATIVE_DEFLECTION", "read_cad"]

#: Chordal deflection of the tessellation, relative to the bounding-box diagonal.
RELATIVE_DEFLECTION = 1e-3
#: Angular deflection in radians: curved faces get at least ~12 segments per full turn.
ANGULAR_DEFLECTION = 0.5

CAD_HINT = (
    "reading STEP and IGES needs OpenCascade, an optional part of shapesearch: install it "
    "with pip install 'shapesearch[cad]' (the Docker image includes it)"
)


def _import_ocp() -> Any:
    """The OpenCascade classes used here; ImportError without the extra."""
    from OCP.Bnd import Bnd_Box
    from OCP.BRep import BRep_Tool
    from OCP.BRepBndLib import BRepBndLib
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.IGESControl import IGESControl_Reader
    from OCP.STEPControl import STEPControl_Reader
    from OCP.TopAbs import TopAbs_FACE, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    return SimpleNamespace(
        Bnd_Box=Bnd_Box, BRep_Tool=BRep_Tool, BRepBndLib=BRepBndLib,
        BRepMesh_IncrementalMesh=BRepMesh_IncrementalMesh, IFSelect_RetDone=IFSelect_RetDone,
        IGESControl_Reader=IGESControl_Reader, STEPControl_Reader=STEPControl_Reader,
        TopAbs_FACE=TopAbs_FACE, TopAbs_REVERSED=TopAbs_REVERSED,
        TopExp_Explorer=TopExp_Explorer, TopLoc_Location=TopLoc_Location, TopoDS=TopoDS,
    )


def _read_shape(ocp: Any, data: bytes, fmt: str) -> Any:
    """The file's root shapes as one shape; unparsable when nothing can be read."""
    reader = ocp.STEPControl_Reader() if fmt == "step" else ocp.IGESControl_Reader()
    # The readers take a path only; the temporary file lives for the read alone.
    handle, path = tempfile.mkstemp(suffix=f".{fmt}")
    try:
        with os.fdopen(handle, "wb") as file:
            file.write(data)
        status = reader.ReadFile(path)
    finally:
        os.unlink(path)
    if status != ocp.IFSelect_RetDone:
        raise InvalidShapeError(
            "unparsable",
            f"could not read this .{fmt} file (OpenCascade status {int(status)}): check that "
            f"it is a complete {fmt.upper()} file, or export the part again",
        )
    reader.TransferRoots()
    shape = reader.OneShape()
    if shape is None or shape.IsNull():
        raise InvalidShapeError(
            "unparsable", f"this .{fmt} file holds no shape OpenCascade can transfer"
        )
    return shape


def _tessellate(ocp: Any, shape: Any) -> RawGeometry:
    box = ocp.Bnd_Box()
    ocp.BRepBndLib.Add_s(shape, box)
    if box.IsVoid():
        raise InvalidShapeError("degenerate", "the CAD shape has no extent (no geometry)")
    corner_min = np.array(box.CornerMin().Coord())
    corner_max = np.array(box.CornerMax().Coord())
    diagonal = float(np.linalg.norm(corner_max - corner_min))
    if not np.isfinite(diagonal) or diagonal <= 0:
        raise InvalidShapeError("degenerate", "the CAD shape has no extent")
    ocp.BRepMesh_IncrementalMesh(
        shape, RELATIVE_DEFLECTION * diagonal, False, ANGULAR_DEFLECTION, True
    )
    vertices: list[np.ndarray] = []
    faces: list[np.ndarray] = []
    offset = 0
    explorer = ocp.TopExp_Explorer(shape, ocp.TopAbs_FACE)
    while explorer.More():
        face = ocp.TopoDS.Face(explorer.Current())
        explorer.Next()
        location = ocp.TopLoc_Location()
        triangulation = ocp.BRep_Tool.Triangulation_s(face, location)
        if triangulation is None:
            continue
        transform = location.Transformation()
        points = np.array(
            [
                triangulation.Node(i).Transformed(transform).Coord()
                for i in range(1, triangulation.NbNodes() + 1)
            ],
            dtype=np.float64,
        ).reshape(-1, 3)
        triangles = np.array(
            [triangulation.Triangle(i).Get() for i in range(1, triangulation.NbTriangles() + 1)],
            dtype=np.int64,
        ).reshape(-1, 3) - 1
        if face.Orientation() == ocp.TopAbs_REVERSED:
            triangles = triangles[:, ::-1]
        vertices.append(points)
        faces.append(triangles + offset)
        offset += len(points)
    if not faces:
        raise InvalidShapeError(
            "empty_file", "the CAD file holds no surfaces to tessellate (wireframe or empty)"
        )
    return RawGeometry(np.concatenate(vertices), np.concatenate(faces))


def read_cad(data: bytes, fmt: str) -> RawGeometry:
    """Tessellate a STEP or IGES file.

    Parameters
    ----------
    data : bytes
        The file's content.
    fmt : str
        ``"step"`` or ``"iges"``.

    Returns
    -------
    RawGeometry
        vertices : (v, 3) float64 and faces : (f, 3) int64 of all faces of all root shapes.

    Raises
    ------
    InvalidShapeError
        ``cad_unavailable`` without OpenCascade; ``unparsable``, ``degenerate`` or
        ``empty_file`` for files it cannot turn into triangles.
    """
    try:
        ocp = _import_ocp()
    except ImportError as error:
        raise InvalidShapeError("cad_unavailable", CAD_HINT) from error
    return _tessellate(ocp, _read_shape(ocp, data, fmt))
