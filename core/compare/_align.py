"""Rigid alignment of one point set onto another: principal axes, then ICP.

``align(a, b)`` finds the rotation ``R``, translation ``t`` and (with ``scale=True``) the
uniform scale ``s`` that put ``b`` on ``a``: ``s * b @ R.T + t``.

1. **Starts.** A part's principal axes leave its orientation ambiguous: each axis may point
   either way, and two axes of nearly equal spread may lie anywhere in their plane. So the
   starts map ``b``'s principal frame onto ``a``'s in every way the spreads leave open: the
   4 proper sign flips when the spreads are well apart; when two are close (within
   ``CLOSE_SPREADS``), turns about the third axis every ``PLANE_STEP_DEGREES`` with either
   sign of it (24); when all three are close (a cube, a ball: no defined axis), the 60
   rotations of the icosahedral group (every orientation within 45 degrees of one). The
   centroids are matched, and with ``scale`` the spreads.
   A *partial* ``b`` (a scan: one side of ``a``) has neither ``a``'s centroid nor its axes.
   Its starts are taken against what each of ``VIEWS`` viewpoints sees of ``a``
   (``core.views.view_from``): a scan and the view that saw the same side are two samplings
   of one patch, as two whole parts are, and align as well.
2. **Refinement** (successive halving). When there are more than ``SCREENED`` starts (a
   partial ``b``'s), the ``SCREENED`` nearest as they are (on ``SCREEN_POINTS`` points of
   each set) go on. Each is refined by ``COARSE_FIRST`` steps of point-to-point ICP
   (iterative closest point: nearest neighbours by ``scipy.spatial.cKDTree``, each step the
   closed-form similarity of Umeyama 1991) on ``COARSE_POINTS`` points of each set, the best
   ``COARSE_KEPT`` of them to ``COARSE_ITERATIONS`` steps, and the best ``REFINED``
   (``PARTIAL_REFINED``) distinct poses by point-to-plane ICP on ``WORKING_POINTS`` points
   of each set, which settles in a few steps where point-to-point slides along a surface
   for dozens. A partial ``b``'s poses are ranked for this last stage by how well they lie
   on the whole ``a``, not on the view they were refined against.
3. **Choice.** The refined pose of least RMS distance on the working sets wins: the best
   final result of every candidate, so a symmetric part, whose starts are equally good,
   never ends worse than any of them.

Whole parts pair their points both ways (each point of ``b`` with its nearest in ``a``
and each point of ``a`` with its nearest in ``b``), so neither part can hide inside the
other, and leave the worst ``TRIM`` share of each way out of each step, so a region where
the parts differ (a stretched end) does not drag the rest along. A partial ``b`` is paired
with its view both ways while the starts are refined, then only its own points with the
whole ``a`` (the rest of ``a`` was not seen), by their distance to ``a``'s tangent planes
(a wrong pose of a patch is as near ``a``'s points as the right one, not as near its
surface), ``PARTIAL_TRIM`` of them left out (stray points of a scan).

Costs are bounded by construction: at most ``WORKING_POINTS`` points of each set take part
(a seeded subset), ``COARSE_POINTS`` in the coarse stage, ``SCREENED`` coarse starts.
``deadline`` (a ``time.monotonic()`` value) stops the work with ``AlignmentBudgetExceeded``
when a busy machine would take longer.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from core.views import view_directions, view_from

__all__ = [
    "COARSE_POINTS",
    "VIEWS",
    "WORKING_POINTS",
    "Alignment",
    "AlignmentBudgetExceeded",
    "Start",
    "align",
    "rotation_angle",
    "signed_permutations",
    "spread_subset",
]

#: Points of each set on which the alignment is decided (a seeded subset of more).
WORKING_POINTS = 1000
#: Points of each set in the coarse stage, where every start is refined.
COARSE_POINTS = 250
#: Viewpoints of ``a`` against which a partial ``b``'s starts are taken.
VIEWS = 20
#: Spreads whose ratio is below this are "close": their axes may turn in their plane.
CLOSE_SPREADS = 1.3
#: Turns about the distinct axis when two spreads are close, in degrees.
PLANE_STEP_DEGREES = 30.0
#: Starts that go on from the coarse stage to the working sets (a partial ``b``'s: more,
#: as a view of ``a`` tells a side and its mirror image apart less well than all of ``a``).
REFINED = 3
PARTIAL_REFINED = 5
#: Starts that go on to the coarse stage (when there are more, a partial ``b``'s, the
#: nearest on ``SCREEN_POINTS`` points of each set).
SCREENED = 24
SCREEN_POINTS = 100
#: ICP iterations of every start in the coarse stage; of the best ``COARSE_KEPT`` in all;
#: at most of the fine stage.
COARSE_FIRST = 3
COARSE_KEPT = 6
COARSE_ITERATIONS = 10
FINE_ITERATIONS = 30
#: The fine stage ends when a step turns by less than this (radians) and moves by less
#: than this share of ``a``'s size, or when ``STALE_STEPS`` steps in a row did not improve
#: its RMS by ``SETTLED_GAIN`` (a share).
SETTLED_RADIANS = 2e-4
SETTLED = 1e-4
STALE_STEPS = 3
SETTLED_GAIN = 1e-3
#: Neighbours of a point whose plane gives its normal.
NORMAL_NEIGHBOURS = 10
#: Share of the worst pairs of each way left out of each ICP step.
TRIM = 0.2
#: A partial ``b`` (a scan, with stray points) leaves out more.
PARTIAL_TRIM = 0.2
#: With ``scale``, an ICP step may change the scale by at most this factor from its start:
#: a partial set can shrink into a corner of the other, closer at every step.
SCALE_RANGE = 1.5


_ICOSAHEDRAL: tuple[np.ndarray, ...] = ()


class AlignmentBudgetExceeded(RuntimeError):
    """The alignment did not finish before its deadline (a slow or busy machine)."""


@dataclass(frozen=True)
class Start:
    """One start of the alignment and what became of it.

    Attributes
    ----------
    rotation : (3, 3) float
        The start's rotation (a proper rotation).
    translation : (3,) float
    scale : float
    rms : float
        Its RMS distance as it is, on the coarse sets (``a``'s units; for a partial ``b``,
        from the view it was taken against; on ``SCREEN_POINTS`` points when it was
        screened out).
    refined_rms : float
        The same after the coarse ICP (inf: screened out).
    """

    rotation: np.ndarray
    translation: np.ndarray
    scale: float
    rms: float
    refined_rms: float


@dataclass(frozen=True)
class Alignment:
    """``b`` put onto ``a``: ``scale * b @ rotation.T + translation``.

    Attributes
    ----------
    rotation : (3, 3) float
        A proper rotation (determinant +1).
    translation : (3,) float
        In ``a``'s units.
    scale : float
        1 unless asked for.
    rms : float
        RMS distance on the working sets at this pose, in ``a``'s units, the worst
        ``TRIM`` of each way left out: nearest points both ways for whole parts; for a
        partial ``b``, of ``b``'s points from ``a``'s tangent planes (``PARTIAL_TRIM``
        left out). The least of every refined pose's.
    candidates : int
        Starts tried.
    starts : tuple of Start
        Every start, in the order tried.
    iterations : int
        Fine ICP steps of the winning pose (0: its coarse pose was best).
    """

    rotation: np.ndarray
    translation: np.ndarray
    scale: float
    rms: float
    candidates: int
    starts: tuple[Start, ...] = field(repr=False)
    iterations: int

    def apply(self, points: np.ndarray) -> np.ndarray:
        """``points : (n, 3)`` of ``b``'s frame in ``a``'s frame, ``(n, 3) float``."""
        moved = self.scale * np.asarray(points, dtype=np.float64) @ self.rotation.T
        return moved + self.translation


# -- helpers ------------------------------------------------------------------------------------


def spread_subset(points: np.ndarray, size: int, seed: int = 0) -> np.ndarray:
    """At most ``size`` rows of ``points : (n, 3)`` (a seeded random subset, in order;
    all of them when there are no more)."""
    if len(points) <= size:
        return points
    keep = np.sort(np.random.default_rng(seed).choice(len(points), size, replace=False))
    return points[keep]


def signed_permutations() -> list[np.ndarray]:
    """The 24 proper rotations among the signed permutation matrices, ``(3, 3)`` each,
    the identity first."""
    out = []
    for order in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            matrix = np.zeros((3, 3))
            matrix[range(3), order] = signs
            if np.linalg.det(matrix) > 0:
                out.append(matrix)
    return out


def rotation_angle(rotation: np.ndarray) -> float:
    """The angle in degrees of a rotation ``(3, 3)`` (0 for the identity)."""
    cosine = (float(np.trace(rotation)) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))))


def _frame(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centroid ``(3,)``, principal axes as columns ``(3, 3)`` (largest spread first, a
    right-handed frame) and the spreads (variances) ``(3,)`` of ``points``."""
    centroid = points.mean(axis=0)
    offsets = points - centroid
    variances, axes = np.linalg.eigh(offsets.T @ offsets / len(points))
    order = np.argsort(variances)[::-1]
    axes, variances = axes[:, order], np.maximum(variances[order], 0.0)
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    return centroid, axes, variances


def _rotations_between(spread_a: np.ndarray, spread_b: np.ndarray) -> list[np.ndarray]:
    """The start rotations ``(3, 3)`` between two principal frames, in frame coordinates,
    the identity first: the 4 proper sign flips when the spreads are well apart; when two
    neighbouring spreads are close (in either set: their axes may turn freely in their
    plane), turns about the third axis every ``PLANE_STEP_DEGREES`` with either sign of it;
    when all three are close (no defined axis), the 60 rotations of the icosahedral group
    (every orientation within 45 degrees of one)."""
    low_a, low_b = np.maximum(spread_a, 1e-300), np.maximum(spread_b, 1e-300)
    close = (low_a[:-1] / low_a[1:] < CLOSE_SPREADS) | (low_b[:-1] / low_b[1:] < CLOSE_SPREADS)
    if close.all():
        return list(_ICOSAHEDRAL)
    if not close.any():
        return [m for m in signed_permutations() if np.allclose(np.abs(m), np.eye(3))]
    axis = 2 if close[0] else 0
    plane = [i for i in range(3) if i != axis]
    flip = np.ones(3)
    flip[[axis, plane[0]]] = -1.0
    out = []
    for sign in (np.ones(3), flip):
        for angle in np.radians(np.arange(0.0, 360.0, PLANE_STEP_DEGREES)):
            turn = np.eye(3)
            c, s = np.cos(angle), np.sin(angle)
            turn[np.ix_(plane, plane)] = [[c, -s], [s, c]]
            out.append(turn * sign)
    return out


def _icosahedral() -> tuple[np.ndarray, ...]:
    """The 60 rotations of the icosahedral group, ``(3, 3)`` each, the identity first:
    generated from a turn by 72 degrees about a vertex and by 180 degrees about an edge."""
    golden = (1.0 + 5.0**0.5) / 2.0
    vertex = np.array([0.0, 1.0, golden]) / np.linalg.norm([0.0, 1.0, golden])
    edge = np.array([0.0, 0.0, 1.0])

    def turn(axis: np.ndarray, angle: float) -> np.ndarray:
        cross = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        return np.eye(3) + np.sin(angle) * cross + (1 - np.cos(angle)) * cross @ cross

    generators = (turn(vertex, 2 * np.pi / 5), turn(edge, np.pi))
    group = [np.eye(3)]
    frontier = [np.eye(3)]
    while frontier:
        grown = []
        for member in frontier:
            for generator in generators:
                product = generator @ member
                if not any(np.allclose(product, known, atol=1e-9) for known in group):
                    group.append(product)
                    grown.append(product)
        frontier = grown
    return tuple(group)


def _similarity(
    source: np.ndarray, target: np.ndarray, scale: bool
) -> tuple[np.ndarray, np.ndarray, float]:
    """The rotation, translation and scale that best map ``source : (m, 3)`` onto the
    paired ``target : (m, 3)`` in least squares (Umeyama 1991)."""
    mean_s, mean_t = source.mean(axis=0), target.mean(axis=0)
    s0, t0 = source - mean_s, target - mean_t
    covariance = t0.T @ s0 / len(source)
    u, singular, vt = np.linalg.svd(covariance)
    d = np.ones(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        d[2] = -1.0
    rotation = (u * d) @ vt
    factor = 1.0
    if scale:
        variance = float(np.mean(np.sum(s0**2, axis=1)))
        if variance > 0:
            factor = float(np.sum(singular * d) / variance)
    translation = mean_t - factor * rotation @ mean_s
    return rotation, translation, factor


@dataclass
class _Pose:
    rotation: np.ndarray
    translation: np.ndarray
    scale: float

    def forward(self, points: np.ndarray) -> np.ndarray:
        return self.scale * points @ self.rotation.T + self.translation

    def backward(self, points: np.ndarray) -> np.ndarray:
        return (points - self.translation) @ self.rotation / self.scale


class _Sets:
    """Two point sets with their trees, for nearest neighbours both ways, and their
    normals (computed when first asked for)."""

    def __init__(self, a: np.ndarray, b: np.ndarray, *, plane: bool = False) -> None:
        self.a, self.b = a, b
        self.tree_a, self.tree_b = cKDTree(a), cKDTree(b)
        self.plane = plane
        self._normals_a: np.ndarray | None = None
        self._normals_b: np.ndarray | None = None

    @property
    def normals_a(self) -> np.ndarray:
        """Unit normals ``(n, 3)`` of ``a`` (PCA of ``NORMAL_NEIGHBOURS``)."""
        if self._normals_a is None:
            self._normals_a = _normals(self.a, self.tree_a)
        return self._normals_a

    @property
    def normals_b(self) -> np.ndarray:
        """Unit normals ``(m, 3)`` of ``b``."""
        if self._normals_b is None:
            self._normals_b = _normals(self.b, self.tree_b)
        return self._normals_b

    def pairs(
        self, pose: _Pose, both: bool, trim: float
    ) -> tuple[np.ndarray, np.ndarray, float]:
        """The kept pairs ``(source in b, target in a)`` at ``pose`` (the ``1 - trim``
        nearest of each way) and their RMS distance (in ``a``'s units; with ``plane``, of
        ``b``'s points from the planes of their partners in ``a``: the distance between
        the surfaces, without the spacing of the samples)."""
        moved = pose.forward(self.b)
        d_b, i_b = self.tree_a.query(moved)
        if self.plane:
            d_b = np.abs(np.sum((moved - self.a[i_b]) * self.normals_a[i_b], axis=1))
        keep = _kept(d_b, trim)
        sources, targets, squares = [self.b[keep]], [self.a[i_b[keep]]], [d_b[keep] ** 2]
        if both:
            d_a, i_a = self.tree_b.query(pose.backward(self.a))
            keep = _kept(d_a, trim)
            sources.append(self.b[i_a[keep]])
            targets.append(self.a[keep])
            squares.append((d_a[keep] * pose.scale) ** 2)
        rms = float(np.sqrt(np.concatenate(squares).mean()))
        return np.concatenate(sources), np.concatenate(targets), rms

    def rms(self, pose: _Pose, both: bool, trim: float) -> float:
        """The RMS distance of the kept pairs at ``pose``."""
        return self.pairs(pose, both, trim)[2]


def _normals(points: np.ndarray, tree: cKDTree) -> np.ndarray:
    """Unit normals ``(n, 3)`` of ``points`` from a PCA of each one's neighbourhood."""
    _, index = tree.query(points, k=min(NORMAL_NEIGHBOURS, len(points)))
    local = points[index]
    centred = local - local.mean(axis=1, keepdims=True)
    _, axes = np.linalg.eigh(np.einsum("nki,nkj->nij", centred, centred))
    return np.asarray(axes[:, :, 0])


def _plane_step(
    moved: np.ndarray, target: np.ndarray, normals: np.ndarray, pose: _Pose, scale: bool
) -> tuple[_Pose, float]:
    """One linearised point-to-plane step: the pose after moving the paired points
    ``moved : (m, 3)`` (``b``'s, already at ``pose``) towards the planes through
    ``target : (m, 3)`` with ``normals : (m, 3)``; and the step's angle in radians."""
    centre = target.mean(axis=0)
    x = moved - centre
    columns = [np.cross(x, normals), normals]
    if scale:
        columns.append(np.sum(x * normals, axis=1, keepdims=True))
    matrix = np.hstack(columns)
    residual = -np.sum((moved - target) * normals, axis=1)
    # The normal equations (6 or 7 unknowns): far cheaper than a least-squares solver's
    # factorisation of the tall matrix.
    normal = matrix.T @ matrix
    normal[np.diag_indices_from(normal)] += 1e-12 * max(float(np.trace(normal)), 1e-300)
    solution = np.linalg.solve(normal, matrix.T @ residual)
    omega, shift = solution[:3], solution[3:6]
    factor = 1.0 + (float(solution[6]) if scale else 0.0)
    angle = float(np.linalg.norm(omega))
    turn = np.eye(3)
    if angle > 0:
        axis = omega / angle
        cross = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]],
                          [-axis[1], axis[0], 0]])
        turn = np.eye(3) + np.sin(angle) * cross + (1 - np.cos(angle)) * cross @ cross
    rotation = turn @ pose.rotation
    translation = factor * turn @ (pose.translation - centre) + centre + shift
    return _Pose(rotation, translation, pose.scale * factor), angle


def _plane_icp(
    sets: _Sets,
    pose: _Pose,
    *,
    both: bool,
    trim: float,
    scale: bool,
    iterations: int,
    deadline: float | None,
) -> tuple[_Pose, float, int]:
    """Point-to-plane ICP from ``pose``: the pose with the least RMS seen (``_Sets.pairs``'
    yardstick, the same as the coarse stage's), that RMS and its step."""
    normals_a = sets.normals_a
    normals_b = sets.normals_b if both else normals_a[:0]
    low, high = pose.scale / SCALE_RANGE, pose.scale * SCALE_RANGE
    size = float(np.ptp(sets.a, axis=0).max())
    best, best_rms, done = pose, float("inf"), 0
    for step in range(iterations + 1):
        _check(deadline)
        moved_b = pose.forward(sets.b)
        d_b, i_b = sets.tree_a.query(moved_b)
        if sets.plane:
            d_b = np.abs(np.sum((moved_b - sets.a[i_b]) * normals_a[i_b], axis=1))
        keep = _kept(d_b, trim)
        moved, target, normals = [moved_b[keep]], [sets.a[i_b[keep]]], [normals_a[i_b[keep]]]
        squares = [d_b[keep] ** 2]
        if both:
            d_a, i_a = sets.tree_b.query(pose.backward(sets.a))
            keep = _kept(d_a, trim)
            moved.append(moved_b[i_a[keep]])
            target.append(sets.a[keep])
            normals.append(normals_b[i_a[keep]] @ pose.rotation.T)
            squares.append((d_a[keep] * pose.scale) ** 2)
        rms = float(np.sqrt(np.concatenate(squares).mean()))
        if rms < best_rms * (1.0 - SETTLED_GAIN):
            best, best_rms, done = pose, rms, step
        elif rms < best_rms:
            best, best_rms = pose, rms
        if step == iterations or step - done >= STALE_STEPS:
            break
        before = pose
        pose, angle = _plane_step(np.concatenate(moved), np.concatenate(target),
                                  np.concatenate(normals), pose, scale)
        if scale and not low <= pose.scale <= high:
            pose = _Pose(pose.rotation, pose.translation, float(np.clip(pose.scale, low, high)))
        shift = float(np.linalg.norm(pose.translation - before.translation))
        if angle < SETTLED_RADIANS and shift < SETTLED * size:
            break
    return best, best_rms, done


def _kept(distances: np.ndarray, trim: float) -> np.ndarray:
    """The ``1 - trim`` share of ``distances`` that are least (all of few)."""
    if trim <= 0 or len(distances) < 10:
        return np.ones(len(distances), dtype=bool)
    count = int(np.ceil((1.0 - trim) * len(distances)))
    keep = np.zeros(len(distances), dtype=bool)
    keep[np.argpartition(distances, count - 1)[:count]] = True
    return keep


def _icp(
    sets: _Sets,
    pose: _Pose,
    *,
    both: bool,
    trim: float,
    scale: bool,
    iterations: int,
    deadline: float | None,
) -> tuple[_Pose, float, int, float]:
    """Point-to-point ICP from ``pose`` for ``iterations`` steps (fewer when one does not
    improve): the pose with the least RMS seen, its RMS, its step and the RMS at ``pose``."""
    low, high = pose.scale / SCALE_RANGE, pose.scale * SCALE_RANGE
    best, best_rms, done, first = pose, float("inf"), 0, float("nan")
    for step in range(iterations + 1):
        _check(deadline)
        source, target, rms = sets.pairs(pose, both, trim)
        if step == 0:
            first = rms
        if rms < best_rms:
            best, best_rms, done = pose, rms, step
        elif step > 0:
            break
        if step == iterations or len(source) < 3:
            break
        rotation, translation, factor = _similarity(source, target, scale)
        if not scale or not low <= factor <= high:
            factor = float(np.clip(factor, low, high)) if scale else pose.scale
            translation = target.mean(axis=0) - factor * rotation @ source.mean(axis=0)
        pose = _Pose(rotation, translation, factor)
    return best, best_rms, done, first


def _check(deadline: float | None) -> None:
    if deadline is not None and time.monotonic() > deadline:
        raise AlignmentBudgetExceeded("the alignment took longer than its budget")


def _checked(points: np.ndarray, name: str) -> np.ndarray:
    array = np.asarray(points, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != 3 or len(array) < 4:
        raise ValueError(f"{name} must be (n, 3) with n >= 4, not {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} holds non-finite coordinates")
    return array


# -- the alignment ------------------------------------------------------------------------------


def align(
    points_a: np.ndarray,
    points_b: np.ndarray,
    scale: bool = False,
    *,
    partial: bool = False,
    seed: int = 0,
    deadline: float | None = None,
) -> Alignment:
    """Put ``points_b`` onto ``points_a`` (see the module's docstring).

    Parameters
    ----------
    points_a : (n, 3) float
        The reference (its units are the answer's).
    points_b : (m, 3) float
        The set to move.
    scale : bool
        Also find a uniform scale (``b`` in other units than ``a``).
    partial : bool
        ``b`` is a partial view of ``a`` (a scan of one side): starts against ``a``'s
        views, correspondences from ``b`` only.
    seed : int
        Seed of the subsets (the same inputs give the same answer).
    deadline : float, optional
        A ``time.monotonic()`` value after which ``AlignmentBudgetExceeded`` is raised.

    Returns
    -------
    Alignment

    Raises
    ------
    ValueError
        A set that is not ``(n, 3)`` with at least 4 finite points, or has no extent.
    AlignmentBudgetExceeded
        Past ``deadline``.
    """
    a = _checked(points_a, "points_a")
    b = _checked(points_b, "points_b")
    if np.ptp(a, axis=0).max() <= 0 or np.ptp(b, axis=0).max() <= 0:
        raise ValueError("a point set has no extent")
    work = _Sets(spread_subset(a, WORKING_POINTS, seed), spread_subset(b, WORKING_POINTS, seed),
                 plane=partial)
    coarse_b = spread_subset(work.b, COARSE_POINTS, seed + 1)
    if partial:
        # Each start against what one viewpoint sees of a, both ways: a scan and the view
        # that saw the same side are two samplings of one patch, as two whole parts are.
        pairs = [(_Sets(spread_subset(seen, COARSE_POINTS, seed + 1), coarse_b), pose)
                 for seen in _views(work.a, deadline)
                 for pose in _whole_starts(seen, coarse_b, scale)]
        if not pairs:  # a flat a seen edge-on from everywhere: its own frame
            pairs = [(_Sets(spread_subset(work.a, COARSE_POINTS, seed + 1), coarse_b), pose)
                     for pose in _whole_starts(work.a, coarse_b, scale)]
    else:
        coarse = _Sets(spread_subset(work.a, COARSE_POINTS, seed + 1), coarse_b)
        pairs = [(coarse, pose) for pose in _whole_starts(work.a, work.b, scale)]

    def coarse_icp(sets: _Sets, pose: _Pose, iterations: int) -> tuple[_Pose, float, int, float]:
        return _icp(sets, pose, both=True, trim=TRIM, scale=scale, iterations=iterations,
                    deadline=deadline)

    # Successive halving: many starts (a partial b's) are first scored as they are on a
    # few points; the best ``SCREENED`` (every whole part's) take a few ICP steps on the
    # coarse sets; the best ``COARSE_KEPT`` of those more; the best few go on to the
    # working sets.
    screen: dict[int, float] = {}
    tried = list(range(len(pairs)))
    if len(pairs) > SCREENED:
        screen = _screen(pairs, seed, deadline)
        tried = sorted(sorted(screen, key=lambda i: (screen[i], i))[:SCREENED])
    first = {i: coarse_icp(*pairs[i], COARSE_FIRST) for i in tried}
    order = sorted(first, key=lambda i: (first[i][1], i))
    refined = dict(first)
    for i in order[:COARSE_KEPT]:
        refined[i] = coarse_icp(pairs[i][0], first[i][0], COARSE_ITERATIONS - COARSE_FIRST)
    starts = tuple(
        Start(pose.rotation, pose.translation, pose.scale,
              first[i][3] if i in first else screen[i],
              refined[i][1] if i in refined else float("inf"))
        for i, (_, pose) in enumerate(pairs)
    )
    trim = PARTIAL_TRIM if partial else TRIM
    # A partial b was refined against views of a: whether it lies on a as a whole decides
    # which go on (a part and a flipped copy of one side can look alike to a view).
    ranked = sorted(((work.rms(refined[i][0], False, trim) if partial else refined[i][1],
                      i, refined[i][0]) for i in order), key=lambda r: (r[0], r[1]))
    best_pose, best_rms, best_iterations = ranked[0][2], float("inf"), 0
    size = float(np.linalg.norm(np.ptp(work.a, axis=0)))
    for _, _, pose in _distinct(ranked, size)[: PARTIAL_REFINED if partial else REFINED]:
        moved, rms, iterations = _plane_icp(work, pose, both=not partial, trim=trim,
                                            scale=scale, iterations=FINE_ITERATIONS,
                                            deadline=deadline)
        if rms < best_rms:
            best_pose, best_rms, best_iterations = moved, rms, iterations
    return Alignment(
        rotation=best_pose.rotation,
        translation=best_pose.translation,
        scale=float(best_pose.scale),
        rms=best_rms,
        candidates=len(starts),
        starts=starts,
        iterations=best_iterations,
    )


def _screen(
    pairs: list[tuple[_Sets, _Pose]], seed: int, deadline: float | None
) -> dict[int, float]:
    """The RMS distance, both ways, of every pair's start as it is, on ``SCREEN_POINTS``
    points of each set: index -> RMS."""
    small: dict[int, _Sets] = {}
    scores = {}
    for number, (sets, pose) in enumerate(pairs):
        _check(deadline)
        key = id(sets)
        if key not in small:
            small[key] = _Sets(spread_subset(sets.a, SCREEN_POINTS, seed + 2),
                               spread_subset(sets.b, SCREEN_POINTS, seed + 2))
        scores[number] = small[key].rms(pose, True, TRIM)
    return scores


def _distinct(
    ranked: list[tuple[float, int, _Pose]], size: float
) -> list[tuple[float, int, _Pose]]:
    """``ranked`` without the poses that a better one repeats (within 2 degrees, 1 % of
    scale and 1 % of ``size``): starts that the coarse stage brought to one place."""
    kept: list[tuple[float, int, _Pose]] = []
    for entry in ranked:
        pose = entry[2]
        if not any(
            rotation_angle(pose.rotation @ other.rotation.T) < 2.0
            and abs(pose.scale / other.scale - 1.0) < 0.01
            and float(np.linalg.norm(pose.translation - other.translation)) < 0.01 * size
            for _, _, other in kept
        ):
            kept.append(entry)
    return kept


def _whole_starts(a: np.ndarray, b: np.ndarray, scale: bool) -> list[_Pose]:
    """The starts of ``b`` onto ``a``: principal frames matched by the rotations of
    ``_rotations_between``, centroids matched, and with ``scale`` the spreads."""
    centre_a, axes_a, spread_a = _frame(a)
    centre_b, axes_b, spread_b = _frame(b)
    factor = float(np.sqrt(spread_a.sum() / spread_b.sum())) if scale else 1.0
    poses = []
    for turn in _rotations_between(spread_a, spread_b):
        rotation = axes_a @ turn @ axes_b.T
        poses.append(_Pose(rotation, centre_a - factor * rotation @ centre_b, factor))
    return poses


def _views(points: np.ndarray, deadline: float | None) -> list[np.ndarray]:
    """What each of ``VIEWS`` viewpoints sees of ``points`` (``core.views.view_from``),
    those that see at least 10 points."""
    seen = []
    for direction in view_directions(VIEWS):
        _check(deadline)
        view = view_from(points, direction)
        if len(view) >= 10:
            seen.append(view)
    return seen


_ICOSAHEDRAL = _icosahedral()
