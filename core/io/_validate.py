"""Checks every point cloud passes before it is described, and thinning of large ones.

Order of the checks, each with its reason code:

1. shape ``(n, 3)``                                   -> ``unparsable``
2. at most ``MAX_PARSED_POINTS`` rows                  -> ``too_large``
3. every coordinate finite (never silently dropped),
   and distances between them too                     -> ``non_finite``
4. at least ``min_points`` distinct points             -> ``too_few_points``
5. not all on one line or at one point                  -> ``degenerate``

Then clouds above ``max_points`` are thinned evenly (``voxel_downsample``). Flat clouds (a
plate) are valid: the Laplacian of a surface patch is well defined.
"""

from __future__ import annotations

import numpy as np

from core.errors import InvalidShapeError
from core.io._outliers import OUTLIER_RATIO, spacing_inliers
from core.io._sampling import voxel_downsample

__all__ = ["MAX_PARSED_POINTS", "MAX_RECORD_BYTES", "validate_points"]

#: Beyond this many points a file is not a reasonable upload (the API limits bytes first).
MAX_PARSED_POINTS = 5_000_000
#: Most bytes of point records a compressed file (LAZ, LZF-compressed PCD) may expand to:
#: 5 million records of about 100 bytes. Compressed points are not bounded by the upload
#: size, so this is checked against what the header declares, before decompressing.
MAX_RECORD_BYTES = 512 * 1024 * 1024
# Points closer than this fraction of the bounding-box diagonal count as one point: far below
# any real feature, far above float64 round-off of coordinates written by different programs.
_DUPLICATE_TOLERANCE = 1e-9
# Second singular value below this fraction of the first: the points lie on a line.
_LINE_TOLERANCE = 1e-6


def _upload_hint(min_points: int) -> str:
    return f"upload a point cloud or mesh with at least {min_points} distinct points"


def _check_shape(points: np.ndarray) -> np.ndarray:
    """Return ``points`` as a C-contiguous (n, 3) float64 array or refuse it."""
    try:
        array = np.ascontiguousarray(points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidShapeError(
            "unparsable", f"points must be numbers in an (n, 3) array: {exc}"
        ) from exc
    if array.ndim != 2 or array.shape[1] != 3:
        raise InvalidShapeError(
            "unparsable",
            f"points must form an (n, 3) array of x, y, z coordinates, got shape {array.shape}",
        )
    return array


def _check_size(n: int) -> None:
    if n > MAX_PARSED_POINTS:
        raise InvalidShapeError(
            "too_large",
            f"the shape has {n:,} points, more than the {MAX_PARSED_POINTS:,} accepted: "
            "thin the point cloud or simplify the mesh before uploading it",
        )


def _check_finite(points: np.ndarray) -> None:
    """Refuse rows with NaN or infinite coordinates, saying how many and where the first is."""
    bad = ~np.isfinite(points).all(axis=1)
    n_bad = int(bad.sum())
    if n_bad:
        first = int(np.argmax(bad))
        raise InvalidShapeError(
            "non_finite",
            f"{n_bad:,} of {len(points):,} points have NaN or infinite coordinates (the first "
            f"is point {first + 1}): remove or fix those points and upload the file again",
        )


def _check_span(points: np.ndarray) -> None:
    """Refuse coordinates so large that the bounding-box diagonal overflows float64."""
    with np.errstate(over="ignore", invalid="ignore"):
        diagonal = np.linalg.norm(np.ptp(points, axis=0)) if len(points) else 0.0
    if not np.isfinite(diagonal):
        raise InvalidShapeError(
            "non_finite",
            "the coordinates are so large that distances between points overflow: rescale the "
            "part (for example to millimetres) and upload it again",
        )


def _distinct(points: np.ndarray) -> np.ndarray:
    """Indices of the distinct points, in an order the row order of the input cannot change.

    Points in the same cell of a grid of edge ``_DUPLICATE_TOLERANCE * diagonal`` are one
    point; the lexicographically smallest of them stands for it.

    Parameters
    ----------
    points : (n, 3) float
        Finite points, n >= 1.

    Returns
    -------
    (m,) int
        Indices into ``points`` sorted by (cell, x, y, z), ``1 <= m <= n``.
    """
    low = points.min(axis=0)
    diagonal = float(np.linalg.norm(points.max(axis=0) - low))
    if diagonal == 0.0:
        return np.zeros(1, dtype=np.intp)
    # At most 1e9 < 2**30 cells per axis: x and y cells pack into one int64, z stays apart.
    cells = ((points - low) * (1.0 / (diagonal * _DUPLICATE_TOLERANCE))).astype(np.int64)
    high_key, low_key = (cells[:, 0] << 30) | cells[:, 1], cells[:, 2]
    order = np.argsort(high_key)
    # Rows sharing an (x, y) cell are rare (duplicates, or points stacked along z): only they
    # need the slow full sort on (z cell, x, y, z) that makes the order canonical.
    sorted_high = high_key[order]
    same = sorted_high[1:] == sorted_high[:-1]
    tied = np.flatnonzero(np.r_[same, False] | np.r_[False, same])
    if len(tied):
        rows = order[tied]
        sub = np.lexsort(
            (points[rows, 2], points[rows, 1], points[rows, 0], low_key[rows], high_key[rows])
        )
        order[tied] = rows[sub]
    first = np.r_[True, (high_key[order][1:] != high_key[order][:-1])]
    first[1:] |= low_key[order][1:] != low_key[order][:-1]
    return order[first]


def _check_not_degenerate(points: np.ndarray) -> None:
    """Refuse a cloud whose points all lie on one line (or at one point); planes are fine.

    Parameters
    ----------
    points : (n, 3) float
        Distinct finite points, n >= 1.
    """
    centred = points - points.mean(axis=0)
    singular = np.linalg.svd(centred, compute_uv=False)
    if len(points) < 3 or singular[0] == 0.0 or singular[1] < _LINE_TOLERANCE * singular[0]:
        raise InvalidShapeError(
            "degenerate",
            "all points lie on a single line (or at one point), so the shape has no surface "
            "to describe: upload a part with extent in at least two directions",
        )


def validate_points(
    points: np.ndarray,
    *,
    max_points: int = 20000,
    min_points: int = 100,
    seed: int = 0,
    remove_outliers: bool = False,
    outlier_ratio: float = OUTLIER_RATIO,
) -> np.ndarray:
    """Check a point cloud and thin it to at most ``max_points`` points.

    Parameters
    ----------
    points : (n, 3) float
        Coordinates, any row order.
    max_points : int
        Clouds with more distinct points are thinned evenly to exactly this many.
    min_points : int
        Fewer distinct points than this are refused.
    seed : int
        Seed of the thinning; same points and seed give the same result.
    remove_outliers : bool
        Drop outliers (stray scan points) before thinning.
    outlier_ratio : float
        A point is an outlier when its mean distance to its 8 nearest neighbours exceeds this
        many times the median of that distance (``core.io._outliers``).

    Returns
    -------
    (m, 3) float64
        The distinct points, ``min_points <= m <= max_points``. Exact and near duplicates
        (closer than 1e-9 of the bounding-box diagonal) are merged. Without thinning the rows
        keep the order of the input; thinned clouds come in a canonical order, and the set of
        points returned does not depend on the order of the input rows either way.

    Raises
    ------
    InvalidShapeError
        ``unparsable`` (not (n, 3) numbers), ``too_large``, ``non_finite``,
        ``too_few_points`` or ``degenerate``.
    """
    if max_points < 1 or min_points > max_points:
        raise ValueError("validate_points needs 1 <= max_points and min_points <= max_points")
    array = _check_shape(points)
    _check_size(len(array))
    _check_finite(array)
    _check_span(array)
    distinct = _distinct(array) if len(array) else np.zeros(0, dtype=np.intp)
    if remove_outliers and len(distinct) > min_points:
        distinct = distinct[spacing_inliers(array[distinct], ratio=outlier_ratio)]
    if len(distinct) < max(min_points, 1):
        repeated = f" ({len(array):,} points with repeats)" if len(array) > len(distinct) else ""
        raise InvalidShapeError(
            "too_few_points",
            f"the shape has only {len(distinct):,} distinct points{repeated}: "
            + _upload_hint(min_points),
        )
    if len(distinct) > max_points:
        canonical = array[distinct]
        result = canonical[voxel_downsample(canonical, max_points, seed)]
    else:
        # Nothing to thin: keep the points in the order of the file.
        result = array[np.sort(distinct)]
    _check_not_degenerate(result)
    return result
