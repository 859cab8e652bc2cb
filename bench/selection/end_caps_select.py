"""Issue 24 follow-up: does a profile of each *end*, measured in the part's own radius, generalise?

Measurement first (a choice that ships by the rule is adopted in a later step, with its
tests and the score calibration). The rule shipped ``B`` 6, ``H`` 1, weight 1: the block is
now ``core.descriptor.caps_block`` (``core.extrinsic.end_profiles``), which this script uses,
so the study and the service compute one block.
Why, disclosed: on every part source the first answer is mostly of the right kind while the
rest of the kind comes late (pymadcad: NN 1.000, mAP 0.865; its screws' AP 0.66-0.80), the
pattern of the held-out set (NN 0.882, mAP 0.580). A kind that comes in many lengths (screws,
shafts, keys, flanges of several thicknesses) spreads in every block that measures the whole
part over its size: a long screw of one head type lies nearer a long screw of another than
a short one of its own. What stays the same across lengths is each *end* measured in the
part's cross-section: a socket head one diameter deep looks the same on a screw of any
length. Round 1 of the ring study measured an axial-radial profile over the whole part
(normalised by the part's spread) and declined it; this block anchors the axial coordinate
at each end and measures both coordinates in the part's radius, so length drops out.

The ``caps`` block (computed on the stored normalised sample ``points`` ``(n, 3)`` with
``areas`` ``(n,)``): about each of the first and the third area-weighted principal axes
(the symmetry axis of a long and of a flat turned part), ``z`` the coordinate along it and
``r`` the distance from it; ``R`` the area-weighted median of ``r``; the two ends at the
area-weighted 0.5 % and 99.5 % quantiles of ``z`` (a stray point does not move them); for
each end the points whose depth from it, over ``R``, is below ``H``, and their area-weighted
joint histogram of (depth / ``R`` in ``B`` equal bins over [0, ``H``), ``r / R`` in ``B``
equal bins over [0, 2.5), values beyond in the last bin), summing to 1 (zeros if the end
holds no area); the two ends ordered by their area-weighted mean ``r / R``, larger first,
because the axis' sign is arbitrary and a head is wider than a tip. 2 axes x 2 ends x
``B**2`` values; square root at unit norm, like the D2 block. Invariant to rotation,
translation, uniform scale and point order.

The grid, written before any score of it was seen: ``ss6`` (the reference) and ``ss6`` with
the ``caps`` block added at ``B`` in {4, 6} x ``H`` in {1, 2} x weight in {0.5, 1, 2}: 13
candidates. The rule and the ship condition are the ring study's
(``bench/selection/profile_block_select.py``): mAP per source, mean over the seven sources
(capod-nonrigid scored apart), ties within 0.002 to the narrower vector,
leave-one-source-out with a paired bootstrap against ``ss6``; ship only if the LOSO mean is
above ``ss6``'s by more than 0.002 with the 95 % interval above zero. The block is extrinsic:
the ``bendable`` family would leave it out.

    nice -n 10 .venv/bin/python bench/selection/end_caps_select.py /work/study \\
        --json /work/study/end_caps.json

**Round 2, written after round 1's result and before any score of it (disclosed as such).**
Round 1 shipped by its rule (``B`` 6, ``H`` 1, weight 1: LOSO +0.0051 over ``ss6``). Adopting
it, a unit test failed: two samplings of a square plate lay 0.44 of the way to another shape
in the extrinsic blocks (0.17 and less for the other shapes). An axis whose variance equals
its neighbour's is not defined by the shape: a square plate's first axis turns between an
edge and a diagonal from one sampling to the next, and its ends with it (a disc's, a gear's
or a washer's turn too, but their ends look alike from every side). Round 2 weighs each
axis' two end histograms (square root, unit norm per axis) by how distinct the axis is:
``w1 = clip((l1 / l2 - 1) / (rho - 1), 0, 1)`` for the first axis and
``w3 = clip((l2 / l3 - 1) / (rho - 1), 0, 1)`` for the third (``l`` the area-weighted
principal variances, largest first; ``l3 = 0`` gives 1), the two axes joined over sqrt(2),
not scaled to unit norm, so the block fades out continuously as an axis stops being defined
(a square plate keeps only its third axis' profile, a cube or a sphere has none). A part
with one defined axis (a screw, a washer) then has a block of norm 0.71, so weight 1.4 gives
it round 1's weight 1. The pool: ``ss6`` and ``ss6`` with the weighted block at ``B`` 6,
``H`` 1, ``rho`` in {1.25, 1.5, 2} x weight in {1, 1.4}: 7 candidates. Round 1's unweighted
block is not in the pool (it fails the resampling check). Same rule and ship condition; the
``--round 2`` option runs it.

**Round 3, written after round 2's result and before any score of it (disclosed as such).**
Round 2 faded an undefined axis out and lost bent shapes (the block's norm moved with the
pose). Round 3 keeps the block's norm and replaces each axis by a kernel-weighted mean of
the profiles along 131 fixed directions of the principal frame
(``core.extrinsic.soft_axis_weights``): a direction ``d`` stands for the first axis with
weight ``exp(-s |(l1 I - C) d|^2 / l1^2)`` and for the third with
``exp(-s |(C - l3 I) d|^2 / l1^2)`` (``C = diag(l)``, ``s`` the sharpness). An estimated
eigenvector turns by about the covariance's error over its eigen-gap (Davis and Kahan), so
the kernel is narrow about a well-separated axis (a screw's, a washer's: the profile is
round 1's) and spreads over the plane or the sphere of directions an undefined axis could
take (a square plate's first axis, every axis of a cube), where the mean does not follow
the sampling. Before any score, on four synthetic shapes each sampled four times and
rotated: the largest distance between two samplings' blocks (unit norm) of a cube 0.372
round 1, 0.023 at ``s`` 256 and 1024, 0.118 at 4096; of a square plate 0.246, 0.094, 0.134,
0.223; a cylinder and a bar unchanged (0.08-0.14).

The pool: ``ss7`` (``ss6`` + round 1's block at ``B`` 6, ``H`` 1, weight 1, the default it would
replace) and ``ss6`` + the soft block at ``B`` 6, ``H`` 1, weight 1, ``s`` in {64, 256, 1024,
4096}: 5 candidates, one width. The rule is the ring study's, with one change written here:
ties within 0.002 go to the soft candidates first, the sharper first (the smaller change),
``ss7`` last, because the soft block is the one whose resamplings agree. It ships only if
(1) the rule's choice over the seven sources is a soft candidate, (2) its
leave-one-source-out mean against ``ss7``'s has a 95 % bootstrap interval whose lower end is
above -0.005 (it does not give back round 1's gain, +0.0051), and (3) the lowest cosine
between two copies of one mesh in the ``parts`` source (each mesh re-sampled and rotated 6
times) is higher than ``ss7``'s (the defect it is meant to fix). ``--round 3`` runs it.

Round 3's result: ``s`` 4096, chosen without each of the seven sources; LOSO +0.0024 over
``ss7`` (95 % +0.0014 .. +0.0037); the parts copies' lowest cosine 0.929 against 0.901: it
ships (layout ``ss8``). Disclosed: its first run used a direction set that did not map onto
itself when the eigensolver flips an axis' sign (a rotation moved a broad kernel's mean by
up to 0.017, found by the invariance test written to adopt it); the set now holds an
octant's spiral and its mirrors, and the figures above are the re-run's (the first run's:
the same choice, +0.0025, copies 0.931).

    nice -n 10 .venv/bin/python bench/selection/end_caps_select.py /work/study --round 3 \\
        --json /work/study/end_caps_round3.json
"""

from __future__ import annotations

import itertools
import os
import sys
from functools import partial
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from local_features_select import Study  # noqa: E402
from profile_block_select import (  # noqa: E402
    added_block_question,
    lowest_copy_cosine,
    stabilisation_ships,
    study_command,
)

from core.descriptor import caps_block  # noqa: E402
from core.extrinsic import end_profiles, principal_frame  # noqa: E402

BINS = (4, 6)
DEPTHS = (1.0, 2.0)
WEIGHTS = (0.5, 1.0, 2.0)
DISTINCT_RATIOS = (1.25, 1.5, 2.0)
ROUND2_WEIGHTS = (1.0, 1.4)
SHARPNESSES = (64.0, 256.0, 1024.0, 4096.0)
SS7 = "ss6 + caps B6 H1 w1"


def distinct_caps_block(points: np.ndarray, areas: np.ndarray, ratio: float) -> np.ndarray:
    """Round 2's block at ``B`` 6, ``H`` 1, ``(144,) float``: per axis, the square root of
    its two end histograms at unit norm times how distinct the axis is (see the docstring),
    over sqrt(2); norm at most 1, not unit (a part without a defined axis has a small block,
    as the ring block's nothing-repeating part has)."""
    _, variances, _ = principal_frame(points, areas)
    first = variances[0] / variances[1] if variances[1] > 0 else np.inf
    third = variances[1] / variances[2] if variances[2] > 0 else np.inf
    distinct = np.clip((np.array([first, third]) - 1.0) / (ratio - 1.0), 0.0, 1.0)
    parts = []
    for weight, profile in zip(distinct, end_profiles(points, areas, 6, 1.0), strict=True):
        unit = np.sqrt(profile).ravel()
        norm = np.linalg.norm(unit)
        parts.append(weight * (unit / norm if norm > 0 else unit))
    return np.concatenate(parts) / np.sqrt(2.0)


def third_round(study: Study, cache: Path, json_path: Path | None) -> None:
    """Round 3 (see the docstring): the soft block against ``ss7``, by the rule and the
    three conditions."""
    grid = {"caps B6 H1": partial(caps_block, bins=6, depth=1.0)}
    grid |= {f"caps B6 H1 s{sharpness:g}": partial(caps_block, bins=6, depth=1.0,
                                                   sharpness=sharpness)
             for sharpness in SHARPNESSES}
    soft = [f"ss6 + caps B6 H1 s{sharpness:g} w1" for sharpness in sorted(SHARPNESSES)[::-1]]
    tie_order = {name: rank for rank, name in enumerate([*soft, SS7])}
    labels = next(s.labels for s in study.scored if s.name == "parts")
    report = added_block_question(
        study, cache, grid, (1.0,), "end caps, round 3", json_path, reference=SS7,
        tie_order=tie_order, measure=lambda vectors: lowest_copy_cosine(vectors["parts"],
                                                                      np.asarray(labels)))
    stabilisation_ships(report, soft, SS7, report["measure"], "round 3",  # type: ignore[arg-type]
                        json_path)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    # ``--round 2`` or ``--round 3`` anywhere on the line; study_command parses the rest.
    chosen_round = argv[argv.index("--round") + 1] if "--round" in argv else "1"
    if "--round" in argv:
        del argv[argv.index("--round"):argv.index("--round") + 2]
    args, study, cache = study_command(__doc__, argv)
    if chosen_round == "3":
        third_round(study, cache, args.json)
    elif chosen_round == "2":
        grid = {f"caps B6 H1 rho{ratio:g}": partial(distinct_caps_block, ratio=ratio)
                for ratio in DISTINCT_RATIOS}
        added_block_question(study, cache, grid, ROUND2_WEIGHTS, "end caps, round 2", args.json)
    else:
        grid = {f"caps B{bins} H{depth:g}": partial(caps_block, bins=bins, depth=depth)
                for bins, depth in itertools.product(BINS, DEPTHS)}
        added_block_question(study, cache, grid, WEIGHTS, "end caps", args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
