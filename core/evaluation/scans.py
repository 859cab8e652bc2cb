"""Simulated 3D scans of a sampled model: what a depth sensor would see of it.

A scan sees only the side of the object facing the sensor, adds range noise and picks up a
few stray points. From a dense point sample of a clean model we make:

- a single-view scan: points visible from one random viewpoint, found by hidden point removal
  (Katz, Tal & Basri 2007: spherical flipping about the viewpoint, then the convex hull of the
  flipped points and the viewpoint; points on the hull are visible);
- a multi-view scan: the union of what three random viewpoints see;
- a turntable scan (``sensor_scan``): registered views of a depth camera around the object,
  with depth-dependent quantisation and noise, missing patches, the table plane cut away and
  outliers left in; and a single view of the same sensor (see the section further down).

Then isotropic Gaussian noise with standard deviation ``noise`` times the bounding-box diagonal
of the model, and uniform outlier points in the model's (slightly enlarged) bounding box, as
many as make up a share ``outliers`` of the result.
Everything is drawn from one ``numpy.random.Generator``, so a seed fixes the scan.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.views import (
    frame_directions,
    hidden_point_removal,
    view_directions,
    view_from,
    virtual_view,
)

__all__ = [
    "SCAN_KINDS",
    "ScanSettings",
    "SensorSettings",
    "add_noise_and_outliers",
    "hidden_point_removal",
    "multi_view_scan",
    "random_rotation",
    "missing_patch_mask",
    "random_viewpoint",
    "scan_of_kind",
    "sensor_depth",
    "sensor_scan",
    "simulate_scan",
    "single_view_scan",
    "turntable_viewpoints",
    "view_directions",
    "view_kind",
    "virtual_view",
]


@dataclass(frozen=True)
class ScanSettings:
    """Parameters of the scan simulator.

    Attributes
    ----------
    noise : float
        Standard deviation of the Gaussian noise, as a fraction of the bbox diagonal.
    outliers : float
        Share of outlier points in the final scan.
    views : int
        Viewpoints merged by the multi-view scan.
    distance : float
        Distance of the viewpoint from the bbox centre, in bbox diagonals.
    hpr_exponent : float
        Katz et al.'s ``gamma``: the flipping radius is ``10**gamma`` times the farthest point.
        Larger sees more (and lets hidden points through). On a densely sampled sphere 2-3.5
        matches the true visible cap; on concave models (a human figure) 3 keeps about 30 %
        of the points from 3 diagonals away; 5 lets through half of the far side.
    """

    noise: float = 0.005
    outliers: float = 0.01
    views: int = 3
    distance: float = 3.0
    hpr_exponent: float = 3.0


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A rotation drawn uniformly from SO(3), ``(3, 3)``.

    QR of a Gaussian matrix with the signs of R's diagonal moved into Q gives a Haar-uniform
    orthogonal matrix (Mezzadri 2007); a reflection is turned into a rotation.
    """
    q, r = np.linalg.qr(rng.standard_normal((3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


def _bbox(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    low, high = points.min(axis=0), points.max(axis=0)
    return low, high, float(np.linalg.norm(high - low))


def random_viewpoint(points: np.ndarray, rng: np.random.Generator, distance: float) -> np.ndarray:
    """A viewpoint ``(3,)`` in a uniformly random direction, ``distance`` diagonals away."""
    low, high, diagonal = _bbox(points)
    direction = rng.standard_normal(3)
    direction /= np.linalg.norm(direction)
    return (low + high) / 2.0 + distance * diagonal * direction


def add_noise_and_outliers(
    points: np.ndarray,
    rng: np.random.Generator,
    diagonal: float,
    box: tuple[np.ndarray, np.ndarray],
    noise: float,
    outliers: float,
) -> np.ndarray:
    """Gaussian noise on every point, then uniform outliers in the enlarged box.

    Parameters
    ----------
    points : (n, 3) float
    diagonal : float
        Bounding-box diagonal of the clean model: the unit of ``noise``.
    box : (low, high), each (3,) float
        Bounding box of the clean model; outliers fall in it, enlarged by 10 % per side.
    noise, outliers : float
        See ``ScanSettings``.

    Returns
    -------
    scan : (n + o, 3) float
        ``o = round(n * outliers / (1 - outliers))`` so outliers are that share of the result;
        outliers are appended last.
    """
    noisy = points + rng.normal(scale=noise * diagonal, size=points.shape)
    count = int(round(len(points) * outliers / (1.0 - outliers)))
    low, high = box
    pad = 0.1 * (high - low)
    stray = rng.uniform(low - pad, high + pad, size=(count, 3))
    return np.vstack([noisy, stray])


def single_view_scan(
    points: np.ndarray, rng: np.random.Generator, settings: ScanSettings = ScanSettings()
) -> np.ndarray:
    """What one random viewpoint sees of ``points : (n, 3)``, with noise and outliers."""
    return simulate_scan(points, rng, settings, views=1)


def multi_view_scan(
    points: np.ndarray, rng: np.random.Generator, settings: ScanSettings = ScanSettings()
) -> np.ndarray:
    """The union of what ``settings.views`` random viewpoints see, with noise and outliers."""
    return simulate_scan(points, rng, settings, views=settings.views)


def simulate_scan(
    points: np.ndarray,
    rng: np.random.Generator,
    settings: ScanSettings = ScanSettings(),
    views: int = 1,
) -> np.ndarray:
    """Scan ``points : (n, 3) float`` from ``views`` random viewpoints.

    Returns
    -------
    scan : (m, 3) float
        Visible points (each at most once, even if several views see it) with noise, then
        the outliers.
    """
    low, high, diagonal = _bbox(points)
    seen = np.zeros(len(points), dtype=bool)
    for _ in range(views):
        viewpoint = random_viewpoint(points, rng, settings.distance)
        seen[hidden_point_removal(points, viewpoint, settings.hpr_exponent)] = True
    return add_noise_and_outliers(
        points[seen], rng, diagonal, (low, high), settings.noise, settings.outliers
    )


# -- turntable scans with a depth-sensor model ------------------------------------------------
#
# The paper's queries were Kinect scans: the object stands on a turntable, a depth camera
# looks at it from above the table at about a metre, 18 rotations are registered into one
# frame, the table and background are cut away, and stray points stay in. What that does to
# the points, and what the functions below model:
#
# - only the side facing the camera is seen (hidden point removal, as above);
# - depth is measured along the optical axis, quantised in steps that grow with depth squared
#   (disparity is quantised; about 1 cm at object distance) and noisy
#   with a standard deviation that also grows with depth squared (Khoshelham & Elberink 2012);
#   both act along the camera ray, so the pixel's direction is kept;
# - dark or shiny patches return nothing, from every view (they are a property of the surface);
# - the base of the object is lost with the table plane when the background is clipped;
# - each view is registered with a small rigid error;
# - outliers (flying pixels) are left in.
#
# Lengths are in metres of a real object: the model's bounding-box diagonal is mapped to
# ``SensorSettings.object_size``. The turntable axis is the model's z axis (the evaluation
# rotates every model at random first, so it stands on the table in a random pose).


@dataclass(frozen=True)
class SensorSettings:
    """A Kinect-like depth camera looking at a turntable.

    Attributes
    ----------
    object_size : float
        Bounding-box diagonal of the object, metres.
    distance : float
        Camera to turntable axis, metres.
    elevation : float
        Camera height above the table plane, as an angle seen from the object's centre,
        degrees.
    depth_step : float
        Depth quantisation step at ``distance``, metres; scales with (depth / distance)^2.
    depth_noise : float
        Standard deviation of depth noise at ``distance``, metres; scales the same way.
    views : int
        Turntable rotations registered into one scan (evenly spaced, random start).
    missing_patches : int
        Dark or shiny patches that return no depth.
    patch_radius : float
        Radius of each patch, as a fraction of the bbox diagonal.
    table_clip : float
        Height above the table plane cut away with the background, metres.
    registration : float
        Standard deviation of each view's registration error: translation in metres, and
        rotation in radians times ``object_size`` (the same displacement at the object's rim).
    outliers : float
        Share of outlier points in the final scan.
    hpr_exponent : float
        Katz et al.'s ``gamma`` (see ``ScanSettings``).
    """

    object_size: float = 0.5
    distance: float = 1.0
    elevation: float = 25.0
    depth_step: float = 0.01
    depth_noise: float = 0.0015
    views: int = 18
    missing_patches: int = 3
    patch_radius: float = 0.06
    table_clip: float = 0.01
    registration: float = 0.002
    outliers: float = 0.01
    hpr_exponent: float = 3.0


def turntable_viewpoints(
    points: np.ndarray, views: int, settings: SensorSettings, phase: float = 0.0
) -> np.ndarray:
    """Camera positions ``(views, 3)`` around the z axis through the bbox centre.

    The camera circles the object at ``settings.distance`` (scaled to the model's units) and
    ``settings.elevation`` degrees above the horizontal through the centre; ``phase`` (radians)
    is the angle of the first view.
    """
    low, high, diagonal = _bbox(points)
    radius = settings.distance * diagonal / settings.object_size
    elevation = np.radians(settings.elevation)
    angles = phase + 2.0 * np.pi * np.arange(views) / views
    ring = np.column_stack([
        np.cos(angles) * np.cos(elevation),
        np.sin(angles) * np.cos(elevation),
        np.full(views, np.sin(elevation)),
    ])
    return (low + high) / 2.0 + radius * ring


def sensor_depth(
    points: np.ndarray,
    viewpoint: np.ndarray,
    target: np.ndarray,
    rng: np.random.Generator,
    reference: float,
    step: float,
    noise: float,
) -> np.ndarray:
    """Noisy, quantised depth measurement of ``points : (n, 3)`` seen from ``viewpoint``.

    Depth is the coordinate along the optical axis (``viewpoint`` towards ``target``). Both the
    noise's standard deviation and the quantisation step scale with ``(depth / reference)^2``;
    each point moves along its own ray, so it stays on the same pixel.

    Returns
    -------
    measured : (n, 3) float
        Every measured depth is a whole multiple of the step at the point's true depth (when
        ``step > 0``).
    """
    axis = (target - viewpoint) / np.linalg.norm(target - viewpoint)
    rays = points - viewpoint
    depth = rays @ axis
    growth = (depth / reference) ** 2
    measured = depth + rng.normal(size=depth.shape) * noise * growth
    if step > 0:
        steps = step * growth
        measured = np.round(measured / steps) * steps
    return viewpoint + rays * (measured / depth)[:, None]


def missing_patch_mask(
    points: np.ndarray, rng: np.random.Generator, count: int, radius: float
) -> np.ndarray:
    """``(n,)`` bool, False inside ``count`` balls of ``radius`` centred on random points."""
    keep = np.ones(len(points), dtype=bool)
    for centre in points[rng.choice(len(points), size=count, replace=False)] if count else []:
        keep &= np.linalg.norm(points - centre, axis=1) > radius
    return keep


def _small_rotation(rng: np.random.Generator, angle_std: float) -> np.ndarray:
    """Rotation by a Gaussian angle (std ``angle_std`` radians) about a random axis (Rodrigues)."""
    axis = rng.standard_normal(3)
    axis /= np.linalg.norm(axis)
    angle = rng.normal(scale=angle_std)
    cross = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * cross + (1 - np.cos(angle)) * cross @ cross


def sensor_scan(
    points: np.ndarray,
    rng: np.random.Generator,
    settings: SensorSettings = SensorSettings(),
    views: int | None = None,
) -> np.ndarray:
    """A registered turntable scan of ``points : (n, 3) float`` (one view when ``views=1``).

    The object stands on a table at its lowest z; each view sees what hidden point removal
    lets through, measures it with the sensor model, and is registered into the object's frame
    with a small rigid error; the views are merged, the base within ``table_clip`` of the
    table is cut away, and outliers are added in the enlarged bbox.

    Returns
    -------
    scan : (m, 3) float
        Merged views (a surface point seen by k views appears k times, each measured on its
        own), then the outliers.
    """
    views = settings.views if views is None else views
    low, high, diagonal = _bbox(points)
    metre = diagonal / settings.object_size  # model units per metre
    centre = (low + high) / 2.0
    surface = points[missing_patch_mask(
        points, rng, settings.missing_patches, settings.patch_radius * diagonal
    )]
    cameras = turntable_viewpoints(points, views, settings, phase=rng.uniform(0, 2 * np.pi))
    merged = []
    for camera in cameras:
        seen = surface[hidden_point_removal(surface, camera, settings.hpr_exponent)]
        measured = sensor_depth(
            seen, camera, centre, rng, settings.distance * metre,
            settings.depth_step * metre, settings.depth_noise * metre,
        )
        rotation = _small_rotation(rng, settings.registration / settings.object_size)
        shift = rng.normal(scale=settings.registration * metre, size=3)
        merged.append((measured - centre) @ rotation.T + centre + shift)
    scan = np.vstack(merged)
    scan = scan[scan[:, 2] > low[2] + settings.table_clip * metre]
    return add_noise_and_outliers(scan, rng, diagonal, (low, high), 0.0, settings.outliers)


def view_kind(index: int, count: int) -> str:
    """The scan-kind name of virtual view ``index`` of ``count``: ``view<index>of<count>``."""
    return f"view{index}of{count}"


#: Scan kinds the evaluation can ask for (without the ``+sor`` suffix), besides the virtual
#: views ``view<i>of<count>``.
SCAN_KINDS: tuple[str, ...] = ("single", "multi", "turntable", "kinect-view")


def scan_of_kind(points: np.ndarray, rng: np.random.Generator, kind: str) -> np.ndarray:
    """The scan named ``kind`` (one of ``SCAN_KINDS``) of ``points : (n, 3) float``.

    ``single`` and ``multi`` are the original simulator (unchanged, for comparison);
    ``turntable`` is an 18-view registered sensor scan, ``kinect-view`` one view of it;
    ``view<i>of<count>`` is a clean virtual view of a catalogue model (``virtual_view``).

    Raises
    ------
    ValueError
        Unknown kind.
    """
    if kind == "single":
        return simulate_scan(points, rng, ScanSettings(), views=1)
    if kind == "multi":
        return simulate_scan(points, rng, ScanSettings(), views=ScanSettings().views)
    # Diagnostics that split the multi-view scan's loss into its causes: occlusion alone
    # (the three views, no noise, no outliers) and noise alone (every point, noise, outliers).
    if kind == "multi-nonoise":
        return simulate_scan(points, rng, ScanSettings(noise=0.0, outliers=0.0),
                             views=ScanSettings().views)
    if kind == "whole-noisy":
        low, high, diagonal = _bbox(points)
        settings = ScanSettings()
        return add_noise_and_outliers(points, rng, diagonal, (low, high), settings.noise,
                                      settings.outliers)
    if kind == "turntable":
        return sensor_scan(points, rng)
    if kind == "kinect-view":
        return sensor_scan(points, rng, views=1)
    if kind.startswith("merge") and "of" in kind:
        # merge<digits>of<count>: the union of those clean virtual views, a merged scan's
        # catalogue counterpart.
        indices, _, count = kind[5:].partition("of")
        if indices.isdigit() and count.isdigit() and max(map(int, indices)) < int(count):
            low, high, diagonal = _bbox(points)
            seen = np.zeros(len(points), dtype=bool)
            for index in map(int, indices):
                viewpoint = (low + high) / 2.0 + 3.0 * diagonal * view_directions(int(count))[index]
                seen[hidden_point_removal(points, viewpoint)] = True
            return points[seen]
    if kind.startswith("fview") and "t" in kind:
        # fview<index>t<degrees>: a view fixed in the shape's own frame (views.frame_directions).
        view, _, degrees = kind[5:].partition("t")
        if view.isdigit() and int(view) < 3 and degrees.isdigit():
            return view_from(points, frame_directions(points, np.radians(int(degrees)))[int(view)])
    if kind.startswith("view") and "of" in kind:
        view, _, views = kind[4:].partition("of")
        if view.isdigit() and views.isdigit() and int(view) < int(views):
            return virtual_view(points, int(view), int(views))
    raise ValueError(f"unknown scan kind {kind!r}; known: {', '.join(SCAN_KINDS)}")
