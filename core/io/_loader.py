"""``load_points``: any supported file in, checked ``(n, 3)`` points out.

    bytes -> detect format -> parse (points, or vertices + triangles)
          -> meshes: area-weighted surface sampling -> validate_points

Every parser runs inside one net that turns any exception into
``InvalidShapeError("unparsable")``: a malformed upload must never crash a worker with a
``struct.error`` from deep inside a library.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core.errors import NO_SPACE_ERRNOS, InvalidShapeError
from core.io._cad import read_cad
from core.io._e57 import read_e57
from core.io._formats import CAD_FORMATS, TEXT_POINT_FORMATS, detect_format
from core.io._headers import check_header
from core.io._las import read_las
from core.io._meshes import RawGeometry, read_mesh
from core.io._outliers import OUTLIER_RATIO
from core.io._pcd import read_pcd
from core.io._pointfiles import read_npy, read_text_points
from core.io._sampling import sample_surface, triangle_areas
from core.io._validate import validate_points
from core.size import ShapeSize

__all__ = ["LoadedShape", "load_points"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class LoadedShape:
    """A loaded, checked shape.

    Attributes
    ----------
    points : (n, 3) float64
        Finite, distinct points, ``min_points <= n <= max_points``.
    format : str
        Detected format: ``"stl"``, ``"obj"``, ``"off"``, ``"ply"``, ``"glb"``, ``"xyz"``,
        ``"txt"``, ``"csv"``, ``"pts"``, ``"pcd"``, ``"npy"``, ``"e57"``, ``"las"``,
        ``"laz"``, ``"step"``, ``"iges"`` (``"array"`` for in-memory points).
    kind : str
        ``"mesh"`` (points sampled on triangles) or ``"points"`` (points from the file).
    n_input : int
        Number of points, or of mesh vertices, in the file.
    size : ShapeSize or None
        A mesh's size, measured on its triangles in the file's units (``core.size``); None
        for a point cloud, whose area is estimated later (``core.pipeline``).
    """

    points: np.ndarray
    format: str
    kind: str
    n_input: int
    size: ShapeSize | None = None


def _read_source(source: str | os.PathLike[str] | bytes) -> tuple[bytes, str | None]:
    """The file's bytes and, for a path, its name. OSError (missing file) is the caller's."""
    if isinstance(source, bytes | bytearray | memoryview):
        return bytes(source), None
    path = Path(source)
    return path.read_bytes(), path.name


def _parse(data: bytes, fmt: str) -> RawGeometry:
    """Run the parser of ``fmt``; faces are empty for point formats."""
    no_faces = np.zeros((0, 3), dtype=np.int64)
    if fmt in TEXT_POINT_FORMATS:
        return RawGeometry(read_text_points(data, fmt), no_faces)
    if fmt == "pcd":
        return RawGeometry(read_pcd(data), no_faces)
    if fmt == "npy":
        return RawGeometry(read_npy(data), no_faces)
    if fmt in ("las", "laz"):
        return RawGeometry(read_las(data, fmt), no_faces)
    if fmt == "e57":
        return RawGeometry(read_e57(data), no_faces)
    if fmt in CAD_FORMATS:
        return read_cad(data, fmt)
    check_header(data, fmt)  # before trimesh expands anything the header promises
    return read_mesh(data, fmt)


def _parse_safely(data: bytes, fmt: str) -> RawGeometry:
    """``_parse`` with every unexpected exception turned into ``unparsable``, except
    ``MemoryError`` (the sandbox's limit: too large) and a full disk (the machine's fault)."""
    try:
        return _parse(data, fmt)
    except (InvalidShapeError, MemoryError):  # a memory limit means too large, not unreadable
        raise
    except Exception as exc:  # any library error on a bad file means the same to the user
        if isinstance(exc, OSError) and exc.errno in NO_SPACE_ERRNOS:
            raise  # a reader's temporary copy found no room: the machine's fault, not the file's
        logger.info("unparsable .%s upload: %r", fmt, exc)
        raise InvalidShapeError(
            "unparsable",
            f"could not read this .{fmt} file ({type(exc).__name__}: {str(exc)[:120]}): check "
            f"that it is a complete, valid .{fmt} file, or export the part again",
        ) from exc


def _check_mesh_finite(vertices: np.ndarray) -> None:
    bad = ~np.isfinite(vertices).all(axis=1)
    if bad.any():
        raise InvalidShapeError(
            "non_finite",
            f"{int(bad.sum()):,} of {len(vertices):,} mesh vertices have NaN or infinite "
            f"coordinates (the first is vertex {int(np.argmax(bad)) + 1}): repair the mesh and "
            "upload it again",
        )


def _mesh_points(
    geometry: RawGeometry, *, max_points: int, min_points: int, seed: int
) -> np.ndarray:
    """Sample ``max_points`` points on the triangles, then validate them.

    A mesh without area (every triangle degenerate) falls back to its vertices when it has
    enough distinct ones; otherwise it is ``degenerate``.
    """
    _check_mesh_finite(geometry.vertices)
    areas = triangle_areas(geometry.vertices, geometry.faces)
    total = float(areas.sum())
    if not np.isfinite(total):
        raise InvalidShapeError(
            "non_finite",
            "the mesh coordinates are too large to compute its area: rescale the part "
            "(for example to millimetres) and upload it again",
        )
    if total > 0.0:
        sampled = sample_surface(geometry.vertices, geometry.faces, areas, max_points, seed)
        return validate_points(sampled, max_points=max_points, min_points=min_points, seed=seed)
    try:
        return validate_points(
            geometry.vertices, max_points=max_points, min_points=min_points, seed=seed
        )
    except InvalidShapeError as exc:
        if exc.reason != "too_few_points":
            raise
        raise InvalidShapeError(
            "degenerate",
            "every triangle of the mesh has zero area and it has too few distinct vertices "
            f"to use as points ({exc.message}): upload a mesh with a real surface",
        ) from exc


def _mesh_size(geometry: RawGeometry) -> ShapeSize | None:
    """The mesh's size; None if it cannot be measured (then the pipeline measures the
    sampled points instead): size is told beside the shape, never a reason to refuse it."""
    try:
        return ShapeSize.of_mesh(geometry.vertices, geometry.faces)
    except MemoryError:
        raise
    except Exception as exc:  # a library error on odd geometry must not fail the describe
        logger.info("mesh size not measured: %r", exc)
        return None


def load_points(
    source: str | os.PathLike[str] | bytes,
    *,
    filename: str | None = None,
    max_points: int = 20000,
    min_points: int = 100,
    seed: int = 0,
    remove_outliers: bool = False,
    outlier_ratio: float = OUTLIER_RATIO,
    measure_size: bool = True,
) -> LoadedShape:
    """Load a point cloud or mesh file as checked points.

    Parameters
    ----------
    source : path or bytes
        The file, or its content.
    filename : str, optional
        Original file name; its extension tells the format (case-insensitive). Defaults to the
        name of the path; for bytes without it the format is sniffed from the content.
    max_points : int
        Meshes are sampled with exactly this many points; larger clouds are thinned evenly.
    min_points : int
        Fewer distinct points are refused.
    seed : int
        Seed of mesh sampling and thinning: the same file always gives the same points.
    remove_outliers : bool
        Drop outliers from point clouds (scans). Points sampled from a mesh lie on its
        surface by construction and are never filtered.
    outlier_ratio : float
        Outlier cut, in median neighbour spacings (``validate_points``).
    measure_size : bool
        Measure a mesh's size (``core.size.ShapeSize``); without it ``size`` is None. A
        check that only parses and samples skips it: on a large, round mesh it costs most of
        the load.

    Returns
    -------
    LoadedShape

    Raises
    ------
    core.errors.InvalidShapeError
        For any file that cannot be loaded; ``reason`` is one of ``empty_file``,
        ``unknown_format``, ``unparsable``, ``non_finite``, ``too_few_points``,
        ``degenerate``, ``too_large``.
    OSError
        ``source`` is a path that cannot be read.
    """
    data, name = _read_source(source)
    filename = filename or name
    if not data or data.isspace():
        raise InvalidShapeError(
            "empty_file",
            f"file is empty: upload a point cloud or mesh with at least {min_points} "
            "distinct points",
        )
    fmt = detect_format(filename, data[:4096])
    geometry = _parse_safely(data, fmt)
    n_input = len(geometry.vertices)
    if n_input == 0:
        raise InvalidShapeError(
            "empty_file",
            f"this .{fmt} file contains no points: upload a point cloud or mesh with at least "
            f"{min_points} distinct points",
        )
    if len(geometry.faces):
        points = _mesh_points(geometry, max_points=max_points, min_points=min_points, seed=seed)
        return LoadedShape(points=points, format=fmt, kind="mesh", n_input=n_input,
                           size=_mesh_size(geometry) if measure_size else None)
    points = validate_points(
        geometry.vertices,
        max_points=max_points,
        min_points=min_points,
        seed=seed,
        remove_outliers=remove_outliers,
        outlier_ratio=outlier_ratio,
    )
    return LoadedShape(points=points, format=fmt, kind="points", n_input=n_input)
