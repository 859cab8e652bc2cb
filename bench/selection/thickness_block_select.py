"""Issue 24 follow-up: does a histogram of how thick the part is carry over across sources?

Measurement only (a choice that ships by the rule is adopted in a later step, with its tests
and the score calibration). Why ask: every block of ``ss11`` measures the surface as a
surface (its spectrum, its distances, its normals, what repeats around an axis, its ends);
none measures the solid behind it: how far it is through the material from one wall to the
one opposite. The kinds the held-out set confuses differ there: a plain or toothed lock
washer and a circlip are one thin sheet, a sprocket a plate several times thicker than its
teeth are apart, a flange a thick hub on a thinner disc, a socket head a thin wall round its
socket and a button head none. The shape diameter function (Shapira, Shamir & Cohen-Or 2008)
measures it on meshes by casting rays inward; it changes little when a shape bends, so it is
one of the few extrinsic measures the ``bendable`` family could also use (not asked here).

The ``thickness`` block (computed on the stored normalised sample ``points`` ``(n, 3)`` with
``areas`` ``(n,)``; normals by local PCA, ``core.extrinsic.surface_normals`` at the
descriptor's 12 neighbours, sign arbitrary): for each point ``p`` with normal ``nu``, a
point ``q`` of another wall on the normal line is one with ``|(q - p) . nu| = t > h / 2``
(``h`` the median distance of a point to its fourth nearest neighbour: the point's own wall
is left out, and a wall thinner than ``h / 2`` is not resolved), lying within the cone of
half-angle 15 degrees about the line (plus ``h``), and whose own normal is within 45 degrees
of ``nu`` (an opposite wall, not a side wall grazed). On each side of the surface the
nearest such ``t`` is taken; ``near`` is the smaller of the two sides, ``far`` the larger
(no wall: none). The normal's sign does not enter: ``near`` is the thickness of the material
or the width of the gap beside the point, whichever is smaller. Lengths are over the area-
weighted root mean square distance from the centroid, so uniform scale does not enter; nor
do rotation, translation or point order.

Two forms, written before any score of it was seen:

- ``thickness near``: the area-weighted histogram of ``log(near)`` in 16 equal bins over
  ``[log 0.01, log 2]`` (values beyond in the end bins) and one bin for points with no wall
  on either side: 17 values;
- ``thickness pair``: the joint histogram of ``log(near)`` and ``log(far)``, 8 bins each over
  the same range plus a ninth for none: 81 values.

Each is a unit block like the descriptor's histograms (the square root of the histogram over
its norm).

The grid: ``ss11`` (the reference, the shipped default as ``evened_areas_rest_select.
service_base`` and ``Replacing`` make it) and ``ss11`` with one of the two forms joined last
at weight 0.5, 1 or 2 (the base blocks' weights are 0.5-1): 7 candidates, each ranked in the
service's order (``reciprocal_blend_select.SERVICE_ORDER``), the local block encoded on words
fitted on every other source (the studies' convention since ``ss6``). The sources: the nine
of ``vocabulary_sources_select.py``, capod-nonrigid scored apart. The rule
(``evened_areas_select``'s): mAP per source, the mean over the nine, ties within 0.002 to the
reference, then the grid's order (narrower form first, lower weight first);
leave-one-source-out with a paired bootstrap over queries against ``ss11``. A candidate
ships only if

1. its leave-one-source-out mean is above ``ss11``'s by more than 0.002 with the 95 %
   interval above zero;
2. the four third-party libraries as one catalogue by kind (``catalogue_by_kind.py``, one
   vocabulary fitted on the other sources): mAP not below ``ss11``'s, NN not below by more
   than 0.01;
3. on the seed-7 extraction, the choice fixed (``--confirm``): its mean over the nine above
   ``ss11``'s by more than 0.002 with the 95 % paired interval above zero, and test 2 there;
4. after adoption, BOSL2 (no choice saw it) through ``shapesearch eval`` in the service's
   order: mAP not below the release's, measured in the same session, by more than 0.002, NN
   not below by more than 0.01; ``bench/descriptor_cost.py``: the describe at most 1.5x
   ``ss4``'s; and scans of the tuning sources in scan mode measured and reported (a single
   view has no opposite walls, so the block is expected to move scans apart from whole
   parts: a loss there is disclosed, not hidden).

Otherwise nothing changes. Reported whatever the verdict: every source's mAP and NN per
candidate and the block's median milliseconds per model.

Before any score, checked on shapes made in code only (``--check``): a thin ring, a solid
disc and a solid cylinder have distinct ``near`` histograms (the thin ring's mass in the
lowest occupied bins), and rotation, translation, scale and point order leave the block
unchanged.

    .venv/bin/python bench/selection/thickness_block_select.py --check
    # the sources and the seed-0 extraction of vocabulary_sources_select.py (/work/study9)
    nice -n 5 .venv/bin/python bench/selection/thickness_block_select.py /work/study9 \\
        --json /work/study9/thickness.json
    # the same three extractions with --seed 7 into /work/seed7, then
    nice -n 5 .venv/bin/python bench/selection/thickness_block_select.py /work/seed7 \\
        --confirm "CHOICE" --json /work/seed7/thickness.json
The pre-score check (``--check``): thin ring, solid disc and cylinder 1.26-1.34 apart (a unit
block's largest distance is 1.41); invariance 5e-15; 130-150 ms a shape.

**Result** (2026-11-29, twenty-fifth session, a 2-core Intel Xeon; the seed-0 extraction of
the nine sources, 839 models; the block's median 128 ms per model): declined, by a wide
margin. Mean of nine (mAP): ``ss11`` 0.8931; ``near`` w0.5 / 1 / 2 0.8848 / 0.8579 / 0.7912;
``pair`` w0.5 / 1 / 2 0.8868 / 0.8734 / 0.8247. Every third-party library pays at every
weight (``pair`` w0.5: pymadcad 0.963 -> 0.940, FreeCAD 0.905 -> 0.889, MCAD 0.825 -> 0.808,
py-gearworks 0.615 -> 0.612, bd-vslot 0.912 -> 0.910, our generator 0.838 -> 0.834); only
the bent shapes gain (0.992 -> 1.000) and capod a little (0.989 -> 0.990). The rule keeps
``ss11`` on the nine and without every source: left out **+0.0000**; one catalogue by kind
NN 0.874, mAP 0.719. How thick a part is, over its size, varies within a kind as much as
across kinds: a standard's sizes and lengths change it. Tests 3 and 4 were not needed (the
seed-7 extraction, made beside the first to save time, was not scored).
"""

from __future__ import annotations

import functools
import os
import sys
import time
from functools import partial
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from evened_areas_rest_select import service_base  # noqa: E402
from evened_areas_select import catalogue_scores, close_study, service_scores  # noqa: E402
from hubness_select import pooled_local  # noqa: E402
from mcad_check import CATALOGUE  # noqa: E402
from profile_block_select import (  # noqa: E402
    Replacing,
    blocks_per_source,
    study_command,
    study_samples,
)
from reciprocal_blend_select import SERVICE_ORDER  # noqa: E402
from vlad_idf_select import check_sources  # noqa: E402

from core.extrinsic import surface_normals  # noqa: E402

REFERENCE = "ss11"
#: The cone about the normal line within which another wall counts, and how far apart the
#: two walls' normals may turn.
CONE_HALF_ANGLE = np.radians(15.0)
OPPOSITE_COSINE = np.cos(np.radians(45.0))
#: ``log`` thickness over the RMS radius is binned over this range.
LOG_RANGE = (np.log(0.01), np.log(2.0))
NEIGHBOURS = 12
FORMS = {"near": 16, "pair": 8}
WEIGHTS = (0.5, 1.0, 2.0)
#: Rows of the point-to-point products taken at once (memory: a few rows x n floats).
CHUNK = 256


def wall_distances(points: np.ndarray, normals: np.ndarray, areas: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Each point's nearest other wall on its normal line, on either side, ``near`` and
    ``far`` ``(n,) float`` (``inf``: none), over the area-weighted RMS radius.

    Parameters
    ----------
    points : (n, 3) float
    normals : (n, 3) float
        Unit, sign arbitrary.
    areas : (n,) float
    """
    weights = areas / areas.sum()
    offsets = points - weights @ points
    radius = float(np.sqrt(weights @ np.einsum("ij,ij->i", offsets, offsets)))
    spacing = float(np.median(cKDTree(points).query(points, k=5)[0][:, 4]))
    slope = np.tan(CONE_HALF_ANGLE)
    squares = np.einsum("ij,ij->i", points, points)
    sides = np.full((len(points), 2), np.inf)
    for start in range(0, len(points), CHUNK):
        rows = slice(start, start + CHUNK)
        # Three small matrix products instead of every difference vector: the offset along
        # each row's normal, the squared distance, and how the two normals face.
        along = normals[rows] @ points.T - np.einsum("ij,ij->i", normals[rows],
                                                     points[rows])[:, None]
        distance = squares[None, :] + squares[rows, None] - 2.0 * points[rows] @ points.T
        reach = slope * np.abs(along) + spacing
        wall = ((np.abs(normals[rows] @ normals.T) >= OPPOSITE_COSINE)
                & (np.abs(along) > 0.5 * spacing) & (distance - along**2 <= reach**2))
        sides[rows, 0] = np.where(wall & (along > 0), along, np.inf).min(axis=1)
        sides[rows, 1] = np.where(wall & (along < 0), -along, np.inf).min(axis=1)
    return sides.min(axis=1) / radius, sides.max(axis=1) / radius


def _bins(values: np.ndarray, count: int) -> np.ndarray:
    """Bin of each ``log`` length in ``count`` equal bins over ``LOG_RANGE``; ``count`` for
    none (``inf``)."""
    low, high = LOG_RANGE
    finite = np.isfinite(values)
    logs = np.log(np.where(finite, np.maximum(values, 1e-300), 1.0))
    index = np.clip(((logs - low) / (high - low) * count).astype(int), 0, count - 1)
    return np.where(finite, index, count)


def thickness_block(points: np.ndarray, areas: np.ndarray, form: str) -> np.ndarray:
    """The ``thickness`` block of one sample, unit norm: ``(17,)`` for ``near``, ``(81,)``
    for ``pair``.

    Parameters
    ----------
    points : (n, 3) float
    areas : (n,) float
    form : {"near", "pair"}
    """
    near, far = wall_distances(points, surface_normals(points, NEIGHBOURS), areas)
    count = FORMS[form]
    if form == "near":
        cells, size = _bins(near, count), count + 1
    else:
        cells, size = _bins(near, count) * (count + 1) + _bins(far, count), (count + 1) ** 2
    histogram = np.bincount(cells, weights=areas, minlength=size)
    root = np.sqrt(histogram / histogram.sum())
    return root / np.linalg.norm(root)


def check() -> int:
    """The pre-score check on shapes made in code (the docstring's ``--check``)."""
    import trimesh

    rng = np.random.default_rng(0)

    def sample(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
        points, _ = trimesh.sample.sample_surface_even(mesh, 3000, seed=0)
        points = np.asarray(points)[:3000]
        return points, np.full(len(points), mesh.area / len(points))

    ring = trimesh.creation.annulus(r_min=0.8, r_max=1.0, height=0.05, sections=96)
    shapes = {"thin ring": sample(ring),
              "solid disc": sample(trimesh.creation.cylinder(radius=1.0, height=0.3,
                                                             sections=96)),
              "cylinder": sample(trimesh.creation.cylinder(radius=0.3, height=2.0,
                                                           sections=96))}
    blocks = {}
    for name, (points, areas) in shapes.items():
        start = time.perf_counter()
        blocks[name] = thickness_block(points, areas, "near")
        spent = 1000 * (time.perf_counter() - start)
        occupied = np.nonzero(blocks[name] > 0.05)[0]
        print(f"{name}: {spent:.0f} ms; occupied bins {occupied.tolist()}; "
              f"none share {blocks[name][-1] ** 2:.3f}")
    names = list(blocks)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            print(f"{a} - {b}: {np.linalg.norm(blocks[a] - blocks[b]):.3f}")
    points, areas = shapes["solid disc"]
    rotation = trimesh.transformations.random_rotation_matrix(rng.random(3))[:3, :3]
    order = rng.permutation(len(points))
    moved = 7.5 * points[order] @ rotation.T + np.array([3.0, -2.0, 1.0])
    for form in FORMS:
        gap = np.abs(thickness_block(moved, 56.25 * areas[order], form)
                     - thickness_block(points, areas, form)).max()
        print(f"{form}: rotated, moved, scaled, reordered: largest difference {gap:.2e}")
        if gap > 1e-9:
            raise SystemExit("not invariant")
    return 0


def main(argv: list[str] | None = None) -> int:
    args_list = sys.argv[1:] if argv is None else argv
    if args_list == ["--check"]:
        return check()
    args, study, cache = study_command(
        __doc__, argv, confirm="test 3: this candidate, fixed, against ss11")
    check_sources(study)
    replacing = Replacing(study, cache)
    base = service_base(study)
    samples = study_samples(study)
    blocks, cost = {}, {}
    for form in FORMS:
        timings: list[float] = []
        blocks[form] = study.with_nonrigid(blocks_per_source(
            samples, partial(thickness_block, form=form), timings))
        cost[form] = float(np.median(timings))
        print(f"thickness {form}: median {cost[form]:.1f} ms per model", flush=True)
    grid: dict[str, tuple[str, float] | None] = {REFERENCE: None}
    for form in FORMS:
        for weight in WEIGHTS:
            grid[f"ss11 + thickness {form} w{weight:g}"] = (form, weight)
    names = [REFERENCE, args.confirm] if args.confirm else list(grid)

    def added(name: str) -> tuple[dict[str, np.ndarray], float] | None:
        chosen = grid[name]
        return None if chosen is None else (blocks[chosen[0]], chosen[1])

    table, queries = service_scores(
        study, ((name, replacing(base, added=added(name))) for name in names), SERVICE_ORDER)
    pooled = functools.cache(lambda: pooled_local(study, CATALOGUE))
    catalogue = {name: catalogue_scores(study, replacing, base, order=SERVICE_ORDER,
                                        local=pooled(), added=added(name)) for name in names}
    close_study("a thickness block, parts family", REFERENCE, table, queries, catalogue,
                [s.name for s in study.sources], args.confirm, args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
