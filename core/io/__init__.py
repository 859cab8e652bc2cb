"""Loading shape files as checked point clouds.

Public face of the package; everything else in ``core.io`` is private::

    from core.io import load_points, validate_points, detect_format, LoadedShape

``load_points`` reads point clouds (``.xyz .txt .csv .pts .ply .pcd .npy``), scanner files
(``.e57 .las .laz``), meshes (``.stl .obj .off .ply .glb .gltf .3mf``) and CAD files
(``.step .iges``; meshes and CAD are sampled by area with a fixed seed), then
``split_assembly`` splits an assembly into its distinct parts with their placements;
``validate_points`` refuses bad geometry and thins large clouds evenly; ``denoise_points``
projects scanned points onto local surface fits. Every refusal is a
``core.errors.InvalidShapeError`` whose ``reason`` a program can test and whose message a user
can act on.
"""

from core.io._assembly import (
    MAX_PARTS,
    AssemblyPart,
    check_gltf_graph,
    split_assembly,
    stl_bytes,
)
from core.io._denoise import denoise_points
from core.io._formats import (
    CRASHING_FORMATS,
    EXPANDING_FORMATS,
    FILE_EXTENSIONS,
    SUPPORTED_FORMATS,
    detect_format,
)
from core.io._headers import check_header
from core.io._loader import LoadedShape, load_points
from core.io._outliers import OUTLIER_RATIO, spacing_inliers
from core.io._validate import MAX_PARSED_POINTS, validate_points

__all__ = [
    "MAX_PARTS",
    "AssemblyPart",
    "check_gltf_graph",
    "split_assembly",
    "stl_bytes",
    "CRASHING_FORMATS",
    "EXPANDING_FORMATS",
    "FILE_EXTENSIONS",
    "MAX_PARSED_POINTS",
    "OUTLIER_RATIO",
    "SUPPORTED_FORMATS",
    "check_header",
    "denoise_points",
    "LoadedShape",
    "detect_format",
    "load_points",
    "spacing_inliers",
    "validate_points",
]
