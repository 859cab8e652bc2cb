"""Measurements of the embedded surface, for the descriptor's extrinsic blocks.

The spectral signatures are intrinsic: bending a sheet or moving the flanges of a profile
from one side to the other leaves them unchanged. These functions measure how a surface,
given as points that each stand for an area, sits in space. Every one is invariant to
rotation, translation and uniform scale, and to the sign of estimated normals, so that a
part's description does not depend on how it was placed or exported:

- ``pair_distance_ratios``: D2, distances of random point pairs (Osada et al. 2002);
- ``centroid_distance_ratios``: D1, distances from the centroid (Osada et al. 2002);
- ``normal_axis_cosines``: how the surface faces the principal axes (prismatic parts put
  their faces square to their own axes; an L, U and Z profile differ in how much);
- ``reflection_symmetry``: how far the surface is from its mirror images in its principal
  planes and its images under half-turns and inversion (Kazhdan et al. 2002 measure
  symmetry over all planes; the principal planes are where parts have theirs);
- ``angular_spectrum``: what repeats around the first and third principal axes (gear and
  sprocket teeth, bolt holes, hex heads and sockets), by soft shells of distance from the
  axis;
- ``end_profiles``: how each end of the part looks, along the first and third principal
  axes, in the part's own radius: a screw's head is the same one diameter deep whatever
  the screw's length; each axis averaged over the directions it could take
  (``soft_axis_weights``) when the shape does not define it.

``shortened_runs``, ``evened_spreads`` and ``evened_areas`` are not measurements but what
the measurements see: the part with each long run of one cross-section along its first axis
(a shank, a shaft, a key's length) shortened to a few radii, and its principal spreads
evened, so that a kind made in many lengths looks alike and its head or hub counts.

``core.descriptor``'s blocks turn them into the descriptor.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = [
    "ANGULAR_BANDS",
    "ANGULAR_SHELLS",
    "CAPS_SHARPNESS",
    "END_DIRECTIONS",
    "SHELL_CENTRES",
    "SIGN_FLIPS",
    "angular_spectrum",
    "centroid_distance_ratios",
    "end_profiles",
    "evened_areas",
    "evened_spreads",
    "neighbourhood_normals",
    "normal_axis_cosines",
    "pair_distance_ratios",
    "principal_frame",
    "reflection_symmetry",
    "shell_spectrum",
    "shortened_runs",
    "soft_axis_weights",
    "surface_normals",
]

#: The seven non-identity sign changes of the principal frame's axes: mirrors in the planes
#: normal to the first, second and third axis, half-turns about the third, second and first,
#: and inversion through the centroid. None depends on which way an axis points.
SIGN_FLIPS: np.ndarray = np.array(
    [
        [-1, 1, 1], [1, -1, 1], [1, 1, -1],
        [-1, -1, 1], [-1, 1, -1], [1, -1, -1],
        [-1, -1, -1],
    ],
    dtype=np.float64,
)

#: Bands of angular orders ``k`` (half-open ``[low, high)``) of ``angular_spectrum``: about
#: an octave each, from a part's overall lobes to the teeth of a fine gear.
ANGULAR_BANDS: tuple[tuple[int, int], ...] = ((1, 3), (3, 6), (6, 12), (12, 24), (24, 48))

#: Shells of distance from the axis in ``angular_spectrum``.
ANGULAR_SHELLS = 3

#: The shells' centres, in the area-weighted median distance from the axis: a point belongs
#: to the shells by linear interpolation between them (``shell_spectrum``). Chosen by
#: leave-one-source-out on third-party sources (+0.0011 mAP over shells cut at thirds of
#: the area; see the changelog), and re-sampled copies of a part come closer with them.
SHELL_CENTRES: tuple[float, float, float] = (0.5, 1.0, 1.5)

#: ``end_profiles``: the radial range of its histograms, in the part's median radius, and
#: the area share beyond each end that may be stray points (a scan's outlier does not
#: move an end).
END_RADIAL_RANGE = 2.5
END_QUANTILE = 0.005

#: ``end_profiles``: the sharpness of the kernel that averages each axis over the directions
#: it could take (``soft_axis_weights``). Chosen by leave-one-source-out on third-party
#: sources (+0.0024 mAP over the principal axes themselves; see the changelog).
CAPS_SHARPNESS = 4096.0

#: ``evened_spreads``: an axis is grown at most this many times (a washer stays a flat ring
#: rather than becoming a ball).
EVEN_FLATTEST = 10.0

#: ``shortened_runs``: slices this many radii wide; a slice's cross-section is these
#: area-weighted quantiles of the distance from the axis, in radii; neighbouring slices
#: are alike when their quantiles differ by at most ``RUN_STEP`` on average (a
#: Wasserstein-1 distance, which a section with two modes of distance, flats and corners,
#: does not jump in as its median does), and a run stays one cross-section while every
#: slice is within ``RUN_SPREAD`` of the run's median quantiles; a slice of fewer points is
#: not judged (and ends a run). Fixed before the study that chose ``runs_longest``.
RUN_SLICE_WIDTH = 0.5
RUN_QUANTILES = tuple(np.linspace(0.05, 0.95, 19).tolist())
RUN_STEP = 0.04
RUN_SPREAD = 0.08
RUN_FEWEST_POINTS = 8


def principal_frame(
    points: np.ndarray, areas: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The area-weighted principal axes of a surface.

    Parameters
    ----------
    points : (n, 3) float
    areas : (n,) float
        Non-negative, not all zero.

    Returns
    -------
    coordinates : (n, 3) float
        The points about their area-weighted centroid, in the principal frame.
    variances : (3,) float
        Area-weighted variance along each axis, largest first.
    axes : (3, 3) float
        Unit axes as columns, in the order of ``variances``; each axis' sign is arbitrary.
    """
    weights = areas / areas.sum()
    offsets = points - weights @ points
    covariance = (offsets * weights[:, None]).T @ offsets
    variances, axes = np.linalg.eigh(covariance)
    order = np.argsort(variances)[::-1]
    axes = axes[:, order]
    return offsets @ axes, np.maximum(variances[order], 0.0), axes


def evened_spreads(points: np.ndarray, areas: np.ndarray,
                   flattest: float = EVEN_FLATTEST) -> np.ndarray:
    """The surface in its principal frame with its three spreads evened, ``(n, 3) float``.

    Each principal coordinate is scaled so that its area-weighted standard deviation is the
    middle axis' (an axis thinner than ``1 / flattest`` of it is grown ``flattest`` times
    only). Distances measured on the result (D2, D1) describe how the surface is laid out
    apart from its proportions: a long and a short screw of one head come closer, while the
    head, whose share of the length grows, counts more (a kind comes in many lengths).
    Rotation, translation, uniform scale and point order do not change it beyond
    the principal axes' signs, which distances do not see.

    Parameters
    ----------
    points : (n, 3) float
    areas : (n,) float
        Non-negative, not all zero.
    flattest : float
        How many times an axis may be grown at most, >= 1.

    Returns
    -------
    evened : (n, 3) float
        The points about their area-weighted centroid, in the principal frame, evened; the
        frame alone when the middle spread is zero (a segment).
    """
    coordinates, variances, _ = principal_frame(points, areas)
    factors = _evening_factors(variances, flattest)
    return coordinates if factors is None else coordinates * factors


def evened_areas(points: np.ndarray, areas: np.ndarray, normals: np.ndarray,
                 flattest: float = EVEN_FLATTEST, power: float = 1.0) -> np.ndarray:
    """The area each point would stand for on the evened surface (``evened_spreads``),
    ``(n,) float`` with the same total as ``areas``.

    Scaling the principal coordinates by ``F = diag(f)`` takes a surface element of unit
    normal ``nu`` to ``det(F) |F^-1 nu|`` times its area; ``det(F)`` is one constant, so each
    area is multiplied by ``|F^-1 nu|`` and the total restored. A screw's shank, its normal
    across the long axis that the evening shortens, keeps the share it has per unit length
    of the evened part, and the head's share no longer follows the screw's length (area
    shares weigh every histogram). Rotation, translation, uniform scale, point order and
    the normals' signs do not change it.

    Parameters
    ----------
    points : (n, 3) float
    areas : (n,) float
        Non-negative, not all zero.
    normals : (n, 3) float
        Unit normals of ``points``, either sign (``surface_normals``).
    flattest : float
        As in ``evened_spreads``.
    power : float
        The factor ``|F^-1 nu|`` is raised to it: 1 for the evened surface (the descriptor),
        0 for the sample's own areas.

    Returns
    -------
    (n,) float
        ``areas`` itself when the middle spread is zero (a segment).
    """
    _, variances, axes = principal_frame(points, areas)
    factors = _evening_factors(variances, flattest)
    if factors is None:
        return areas
    evened = areas * np.linalg.norm((normals @ axes) / factors, axis=1) ** power
    return evened * (areas.sum() / evened.sum())


def _evening_factors(variances: np.ndarray, flattest: float) -> np.ndarray | None:
    """``evened_spreads``' scale per principal axis, ``(3,) float``; None when the middle
    spread is zero."""
    spreads = np.sqrt(variances)
    if spreads[1] <= 0.0:
        return None
    return spreads[1] / np.maximum(spreads, spreads[1] / flattest)


def shortened_runs(points: np.ndarray, areas: np.ndarray, longest: float
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The part with each run of one cross-section along its first principal axis that is
    longer than ``longest`` radii shortened to ``longest`` radii.

    What a screw's shank, a shaft or a key adds when it grows is more of one cross-section;
    the extrinsic blocks measured on the shortened part see a kind made in many lengths
    alike, and what differs (a head, a neck, a groove) at its own size. The radius ``rho``
    is the area-weighted median distance from the axis. The part is cut into slices
    ``RUN_SLICE_WIDTH`` radii wide, laid from the centroid so that a flipped axis gives the
    same slices; a slice's cross-section is its ``RUN_QUANTILES`` of the
    distance from the axis, over ``rho``. A run is a maximal chain of neighbouring slices
    that are alike (``RUN_STEP``) and stay one cross-section over the whole run
    (``RUN_SPREAD``); a run longer than ``longest`` radii is scaled along the axis to
    ``longest`` radii, its points' areas by the same factor (its lateral surface shrinks
    with it). Heads, necks, bearings and gears keep their length. Rotation, translation,
    uniform scale and point order do not change the result beyond the frame's axis signs.

    Parameters
    ----------
    points : (n, 3) float
    areas : (n,) float
        Non-negative, not all zero.
    longest : float
        Radii a run of one cross-section keeps at most, > 0.

    Returns
    -------
    coordinates : (n, 3) float
        The part in its principal frame (``principal_frame``), shortened, about its new
        area-weighted centroid.
    areas : (n,) float
        The shortened runs' points' areas times their run's factor.
    axes : (3, 3) float
        The principal axes as columns: ``normals @ axes`` turns the sample's normals into
        the frame (a shortened run faces where it faced).
    """
    coordinates, _, axes = principal_frame(points, areas)
    along = coordinates[:, 0]
    radial = np.linalg.norm(coordinates[:, 1:], axis=1)
    rho = _weighted_quantile(radial, areas / areas.sum(), 0.5)
    if not rho > 0:
        return coordinates, areas, axes
    width = RUN_SLICE_WIDTH * rho
    index = np.floor(along / width).astype(np.int64)
    slot = index - index.min()
    factors = _run_factors(_slice_profiles(slot, radial / rho, areas), width / rho, longest)
    starts = np.concatenate([[0.0], np.cumsum(factors * width)[:-1]])
    moved = starts[slot] + (along - index * width) * factors[slot]
    shortened = areas * factors[slot]
    coordinates = coordinates.copy()
    coordinates[:, 0] = moved - np.average(moved, weights=shortened)
    return coordinates, shortened, axes


def _slice_profiles(slot: np.ndarray, radial: np.ndarray, areas: np.ndarray) -> np.ndarray:
    """Each slice's ``RUN_QUANTILES`` of ``radial``, ``(s, q)``; NaN where a slice holds
    fewer than ``RUN_FEWEST_POINTS`` or no area."""
    count = int(slot.max()) + 1
    profiles = np.full((count, len(RUN_QUANTILES)), np.nan)
    for s in np.flatnonzero(np.bincount(slot, minlength=count) >= RUN_FEWEST_POINTS):
        members = slot == s
        total = areas[members].sum()
        if total > 0:  # a slice of points that stand for no area is not judged
            profiles[s] = _weighted_quantiles(radial[members], areas[members] / total,
                                              RUN_QUANTILES)
    return profiles


def _run_factors(profiles: np.ndarray, width: float, longest: float) -> np.ndarray:
    """Each slice's factor along the axis, ``(s,)``: ``longest / length`` in a run of one
    cross-section longer than ``longest`` (``width`` and lengths in radii), 1 elsewhere."""
    steps = np.abs(np.diff(profiles, axis=0))
    judged = ~np.isnan(steps).any(axis=1)
    alike = np.zeros(len(steps), dtype=bool)
    alike[judged] = steps[judged].mean(axis=1) <= RUN_STEP
    factors = np.ones(len(profiles))
    # Boundaries alike..not alike delimit the runs: slices first..last.
    edges = np.flatnonzero(np.diff(np.concatenate([[0], alike.astype(np.int8), [0]])))
    for first, last in zip(edges[::2], edges[1::2], strict=True):
        length = (last - first + 1) * width
        run = profiles[first:last + 1]
        spread = np.abs(run - np.median(run, axis=0)).mean(axis=1).max()
        if length > longest and spread <= RUN_SPREAD:
            factors[first:last + 1] = longest / length
    return factors


def pair_distance_ratios(
    points: np.ndarray, areas: np.ndarray, pairs: int, seed: int
) -> np.ndarray:
    """D2: distances of ``pairs`` random point pairs over their mean, ``(pairs,) float``.

    Each end is drawn with probability proportional to its area (uniform on the surface,
    however unevenly it was sampled); ``seed`` makes the draw repeatable.
    """
    rng = np.random.default_rng(seed)
    ends = rng.choice(points.shape[0], size=(2, pairs), p=areas / areas.sum())
    distances = np.linalg.norm(points[ends[0]] - points[ends[1]], axis=1)
    mean = distances.mean()
    return distances / mean if mean > 0 else distances


def centroid_distance_ratios(points: np.ndarray, areas: np.ndarray) -> np.ndarray:
    """D1: each point's distance from the area-weighted centroid over their area-weighted
    mean, ``(n,) float`` (all zero for a single point)."""
    weights = areas / areas.sum()
    distances = np.linalg.norm(points - weights @ points, axis=1)
    mean = weights @ distances
    return distances / mean if mean > 0 else distances


def surface_normals(points: np.ndarray, neighbours: int) -> np.ndarray:
    """Unoriented unit normals ``(n, 3)`` by local PCA of ``points : (n, 3)``.

    The normal of a point is the direction of least spread of its ``neighbours`` nearest
    other points (Hoppe et al. 1992); its sign is arbitrary.
    """
    count = min(neighbours, len(points) - 1)
    _, index = cKDTree(points).query(points, k=count + 1)
    return neighbourhood_normals(points, index[:, 1:])


def neighbourhood_normals(points: np.ndarray, neighbourhoods: np.ndarray) -> np.ndarray:
    """``surface_normals`` from neighbourhoods already found: ``neighbourhoods : (n, k) int``
    rows of ``points`` around each point (for callers that need the neighbours too)."""
    local = points[neighbourhoods]
    centred = local - local.mean(axis=1, keepdims=True)
    _, axes = np.linalg.eigh(np.einsum("nki,nkj->nij", centred, centred))
    return axes[:, :, 0]


def normal_axis_cosines(
    points: np.ndarray, areas: np.ndarray, normals: np.ndarray
) -> np.ndarray:
    """``|cos|`` of the angle between each normal and each principal axis, ``(n, 3)``.

    Columns follow ``principal_frame``'s axes, largest extent first. Absolute values make
    the result independent of the signs of the normals and of the axes.
    """
    _, _, axes = principal_frame(points, areas)
    return np.abs(normals @ axes)


def reflection_symmetry(points: np.ndarray, areas: np.ndarray) -> np.ndarray:
    """Distance of the surface from each of its ``SIGN_FLIPS`` images, ``(7,) float``.

    For every flip of the principal frame, the area-weighted mean distance from each flipped
    point to the nearest original point, over the surface's RMS radius: 0 for a surface
    with that symmetry (up to sampling), growing as it departs from it.
    """
    coordinates, variances, _ = principal_frame(points, areas)
    radius = float(np.sqrt(variances.sum()))
    if radius == 0:
        return np.zeros(len(SIGN_FLIPS))
    weights = areas / areas.sum()
    tree = cKDTree(coordinates)
    distances = [tree.query(coordinates * signs)[0] for signs in SIGN_FLIPS]
    return np.array([weights @ gap for gap in distances]) / radius


def angular_spectrum(points: np.ndarray, areas: np.ndarray,
                     shell_centres: tuple[float, float, float] = SHELL_CENTRES) -> np.ndarray:
    """What repeats around the first and the third principal axis, ``(2, 3, 5) float``.

    The symmetry axis of a turned part is its first principal axis when it is long (a
    screw) and its third when it is flat (a washer, a flange, a gear). About each, the
    points fall into ``ANGULAR_SHELLS`` soft shells of distance from the axis (hub, web,
    rim: ``shell_spectrum``), and in each shell the area-weighted angular Fourier
    coefficients ``c_k = sum(w e^(-ik theta)) / sum(w)`` measure ``k``-fold repetition: a
    20-tooth sprocket's rim has its power at ``k = 20``, four bolt holes at ``k = 4``, a hex
    head at ``k = 6``, a plain cylinder none. Each value is the root mean ``|c_k|^2`` over one
    of ``ANGULAR_BANDS``, in [0, 1].

    ``|c_k|`` does not depend on where the angle starts or which way it turns, so the
    spectrum is invariant to rotation (including the principal axes' arbitrary signs and,
    about an axis, the choice of the other two), translation, uniform scale and point order.
    Uniform sampling noise puts about ``sqrt(1 / points per shell)`` into every band.

    Parameters
    ----------
    points : (n, 3) float
    areas : (n,) float
        Non-negative, not all zero.
    shell_centres : (3,) float
        The soft shells' centres (``shell_spectrum``).

    Returns
    -------
    spectrum : (2, 3, 5) float
        Axis (first, third), shell (innermost first), band (``ANGULAR_BANDS``).
    """
    coordinates, _, _ = principal_frame(points, areas)
    weights = areas / areas.sum()
    spectrum = np.zeros((2, ANGULAR_SHELLS, len(ANGULAR_BANDS)))
    # About the first axis the angle lies in the plane of the second and third, about the
    # third in that of the first and second; the coordinate along the axis does not enter.
    for row, (u, v) in enumerate(((1, 2), (0, 1))):
        spectrum[row] = shell_spectrum(coordinates[:, u] - 1j * coordinates[:, v], weights,
                                       shell_centres)
    return spectrum


def shell_spectrum(across: np.ndarray, weights: np.ndarray,
                   centres: tuple[float, float, float] = SHELL_CENTRES) -> np.ndarray:
    """The band powers of ``angular_spectrum`` about one axis, ``(ANGULAR_SHELLS, bands)``.

    Parameters
    ----------
    across : (n,) complex
        Each point's position across the axis, ``x - i y`` in the plane normal to it.
    weights : (n,) float
        Non-negative.
    centres : (3,) float
        The soft shells: a point at distance ``r`` from the axis, over the weighted median
        distance, belongs to the shells by linear interpolation between these centres (all
        to the first below the first centre, to the last beyond the last). Shells cut at
        fixed shares of the area would cut through a wall whose points all lie at one
        distance, and which side of the cut a point falls on would follow the axis'
        sampling noise; a membership that changes continuously with ``r`` does not jump. A
        shell's coefficients are over its mass or a third of the whole, whichever is
        larger: a nearly empty shell (the sliver of a wall just beyond a centre, lopsided
        by the same noise) counts by its share, not as if it were a whole shell.

    Returns
    -------
    (ANGULAR_SHELLS, len(ANGULAR_BANDS)) float
        Each band's root mean power per shell, in [0, 1].
    """
    highest = max(high for _, high in ANGULAR_BANDS)
    radius = np.abs(across)
    # e^(-i theta) per point (1 on the axis itself, where theta is undefined), and its
    # powers 1 .. highest - 1 by repeated products rather than one exp per order.
    unit = np.where(radius > 0, across / np.where(radius > 0, radius, 1.0), 1.0)
    powers = np.cumprod(np.repeat(unit[:, None], highest - 1, axis=1), axis=1)
    order = np.argsort(radius, kind="stable")
    share = np.cumsum(weights[order])
    # One product for all shells: each row holds the weights of one shell's points.
    by_shell = np.zeros((ANGULAR_SHELLS, len(radius)))
    median = radius[order][min(np.searchsorted(share, 0.5 * share[-1]), len(radius) - 1)]
    relative = radius / median if median > 0 else np.zeros_like(radius)
    for shell, indicator in enumerate(np.eye(ANGULAR_SHELLS)):
        by_shell[shell] = weights * np.interp(relative, centres, indicator)
    mass = np.maximum(by_shell.sum(axis=1), share[-1] / ANGULAR_SHELLS)
    coefficients = (by_shell @ powers) / np.where(mass > 0, mass, 1.0)[:, None]
    power = np.abs(coefficients) ** 2
    return np.stack([np.sqrt(power[:, low - 1 : high - 1].mean(axis=1))
                     for low, high in ANGULAR_BANDS], axis=1)


def end_profiles(points: np.ndarray, areas: np.ndarray, bins: int, depth: float,
                 sharpness: float = CAPS_SHARPNESS) -> np.ndarray:
    """Each end's depth-radius profile in the part's own radius, ``(2, 2, bins, bins)``.

    About each of the first and the third principal axis (the symmetry axis of a long and
    of a flat turned part), ``z`` is the coordinate along it and ``r`` the distance from it,
    both over ``R``, the area-weighted median of ``r``. The two ends lie at the area-weighted
    ``END_QUANTILE`` and ``1 - END_QUANTILE`` quantiles of ``z``. For each end, the points
    less than ``depth`` radii deep from it give the area-weighted joint histogram of (depth
    in ``bins`` equal bins over ``[0, depth)``, ``r / R`` in ``bins`` equal bins over
    ``[0, END_RADIAL_RANGE)``, values beyond in the last bin), summing to 1 (zeros when the
    end holds no area). Measured from the end and in radii, not over the part's size, a
    profile does not change with the part's length: a socket head, a countersink or a
    thread's end looks the same on a screw of any length.

    The ends come wider first (by their area-weighted mean ``r / R``): an axis' sign is
    arbitrary, and a head is wider than a tip. Invariant to rotation, translation, uniform
    scale and point order.

    Parameters
    ----------
    points : (n, 3) float
    areas : (n,) float
        Non-negative, not all zero.
    bins : int
        Bins per coordinate.
    depth : float
        How deep an end reaches, in radii.
    sharpness : float
        Each axis' profile is the kernel-weighted mean of the profiles along
        ``END_DIRECTIONS`` (see ``soft_axis_weights``), so that an axis the shape does not
        define (a square plate's first, a cube's every) is averaged over the directions it
        could take instead of following the sampling; the sharper, the nearer the axis
        itself when the shape defines it.

    Returns
    -------
    profiles : (2, 2, bins, bins) float
        Axis (first, third), end (wider first), depth bin, radius bin.
    """
    coordinates, variances, _ = principal_frame(points, areas)
    weights = areas / areas.sum()
    kernels = soft_axis_weights(variances, END_DIRECTIONS, sharpness)
    used = (kernels > _NEGLIGIBLE * kernels.max(axis=1, keepdims=True)).any(axis=0)
    profiles = np.zeros((2, 2, bins, bins))
    for direction, kernel in zip(END_DIRECTIONS[used], kernels[:, used].T, strict=True):
        z = coordinates @ direction
        r = np.linalg.norm(coordinates - z[:, None] * direction, axis=1)
        ends = _direction_ends(z, r, weights, bins, depth)
        profiles += kernel[:, None, None, None] * ends[None]
    return profiles


def _hemisphere(count: int) -> np.ndarray:
    """The three axes and about ``count`` directions on the upper half sphere, ``(k, 3)
    float``: a Fibonacci spiral's points in one octant and their mirrors in the first two
    axes. A profile's ends come wider first, so ``d`` and ``-d`` agree; with the mirrors,
    the set maps onto itself when an axis' sign (which ``principal_frame`` leaves to the
    eigensolver) flips, so the average does not depend on it."""
    index = np.arange(count) + 0.5
    height = index / count
    ring = np.sqrt(1.0 - height**2)
    angle = np.pi * (3.0 - np.sqrt(5.0)) * index
    spiral = np.column_stack([ring * np.cos(angle), ring * np.sin(angle), height])
    octant = spiral[(spiral[:, 0] > 0) & (spiral[:, 1] > 0)]
    mirrors = [octant * np.array([x, y, 1.0]) for x in (1.0, -1.0) for y in (1.0, -1.0)]
    return np.vstack([np.eye(3), *mirrors])


#: Directions of the principal frame that ``end_profiles`` averages over.
END_DIRECTIONS: np.ndarray = _hemisphere(128)

#: ``soft_axis_weights`` below this share of the largest are left out (they cannot change
#: a histogram bin by more than the float error of the others' sum).
_NEGLIGIBLE = 1e-4


def soft_axis_weights(variances: np.ndarray, directions: np.ndarray,
                      sharpness: float) -> np.ndarray:
    """How much each direction stands for the first and the third principal axis.

    An estimated eigenvector turns by about the covariance's error over its eigen-gap
    (Davis and Kahan 1970), so a direction ``d`` of the principal frame stands for the first
    axis with weight ``exp(-s |(l1 I - C) d|^2 / l1^2)`` and for the third with
    ``exp(-s |(C - l3 I) d|^2 / l1^2)`` (``C = diag(l)``, ``s`` the sharpness): a
    well-separated axis keeps all the weight on itself; an axis that shares its variance
    with another spreads it over the plane they span; a cube's, over every direction. A
    function of ``C``, not of the frame, so the spread does not follow the sampling.

    Parameters
    ----------
    variances : (3,) float
        Principal variances, largest first.
    directions : (k, 3) float
        Unit directions in the principal frame.
    sharpness : float

    Returns
    -------
    weights : (2, k) float
        Rows for the first and the third axis, each summing to 1.
    """
    scale = max(float(variances[0]), np.finfo(float).tiny)
    first = ((variances[0] - variances) / scale) ** 2 @ (directions**2).T
    third = ((variances - variances[2]) / scale) ** 2 @ (directions**2).T
    kernels = np.exp(-sharpness * np.vstack([first, third]))
    return kernels / kernels.sum(axis=1, keepdims=True)


def _direction_ends(z: np.ndarray, r: np.ndarray, weights: np.ndarray, bins: int,
                    depth: float) -> np.ndarray:
    """The two ends' histograms along one direction, wider first, ``(2, bins, bins)``."""
    radius = _weighted_quantile(r, weights, 0.5)
    radial = r / radius if radius > 0 else np.zeros_like(r)
    scale = radius if radius > 0 else 1.0
    low = _weighted_quantile(z, weights, END_QUANTILE)
    high = _weighted_quantile(z, weights, 1.0 - END_QUANTILE)
    ends = [_end_profile((high - z) / scale, radial, weights, bins, depth),
            _end_profile((z - low) / scale, radial, weights, bins, depth)]
    ends.sort(key=lambda end: -end[0])
    return np.stack([histogram for _, histogram in ends])


def _end_profile(depth: np.ndarray, radial: np.ndarray, weights: np.ndarray, bins: int,
                 reach: float) -> tuple[float, np.ndarray]:
    """One end of ``end_profiles``: its area-weighted mean ``radial`` and its histogram."""
    inside = (depth >= 0) & (depth < reach)
    mass = weights[inside].sum()
    row = np.clip((depth[inside] / reach * bins).astype(int), 0, bins - 1)
    column = np.clip((radial[inside] / END_RADIAL_RANGE * bins).astype(int), 0, bins - 1)
    histogram = np.bincount(row * bins + column, weights=weights[inside], minlength=bins * bins)
    if mass <= 0:
        return 0.0, histogram.reshape(bins, bins)
    width = float(weights[inside] @ radial[inside] / mass)
    return width, (histogram / histogram.sum()).reshape(bins, bins)


def _weighted_quantile(values: np.ndarray, weights: np.ndarray, share: float) -> float:
    """The value below which ``share`` of ``weights`` (summing to 1) lies."""
    return float(_weighted_quantiles(values, weights, (share,))[0])


def _weighted_quantiles(values: np.ndarray, weights: np.ndarray,
                        shares: tuple[float, ...]) -> np.ndarray:
    """The values below which each of ``shares`` of ``weights`` (summing to 1) lies,
    ``(len(shares),) float``: one sort for them all."""
    order = np.argsort(values, kind="stable")
    cumulative = np.cumsum(weights[order])
    positions = np.minimum(np.searchsorted(cumulative, shares), len(values) - 1)
    return values[order][positions]
