"""Issue 24 follow-up: does a surflet-pair histogram generalise across sources?

Measurement only (the service's descriptor does not change in this step; a choice that
ships by the rule is adopted in a later step, with its tests and the score calibration).
Why, disclosed: Wahl, Hillenbrand & Hirzinger (2003) classified CAD-like objects with the
joint histogram of how random pairs of oriented surface points relate (their distance, the
angles of both normals to the line joining them, the angle between the normals). ``ss6``
sees distances without normals (D2) and normals only against the principal axes (the
normals block); how two patches of surface face each other at a given distance it does not
see: a hex head's and a hex nut's parallel flats across a width, a socket's walls square to
a head's top, a washer's or a flange's two faces at its thickness, a countersink's cone
against the face it meets, gear and sprocket flanks across a tooth.

The ``surflet`` block (computed on the stored normalised sample ``points`` ``(n, 3)`` with
``areas`` ``(n,)``): unoriented normals by ``core.extrinsic.surface_normals`` with the
service's 12 neighbours; 20,000 pairs drawn as D2 draws them (each end with probability
proportional to its area, seed 0), pairs of one point dropped; per pair the distance over
the pairs' mean distance, ``a = |n1 . u|`` and ``b = |n2 . u|`` for the unit direction ``u``
between the ends, ordered as ``(min, max)`` because a pair has no first end, and
``g = |n1 . n2|``; absolute cosines because the normals' signs are arbitrary. The joint
histogram of (distance ratio in ``D`` equal bins over [0, 2.5), values beyond in the last;
``min``, ``max`` and ``g`` each in ``A`` equal bins over [0, 1]) counts pairs; its square
root at unit norm, like the D2 block. Invariant to rotation, translation, uniform scale
and the sign of normals; repeatable by its seed (the pair draw, like D2's, follows the
point order).

The grid, written before any score of it was seen: ``ss6`` (the reference) and ``ss6`` with
the ``surflet`` block added at (``D``, ``A``) in {(4, 3), (6, 4)} x weight in {0.5, 1, 2}:
7 candidates. The rule and the ship condition are the ring study's
(``bench/selection/profile_block_select.py``): mAP per source, mean over the seven sources
(capod-nonrigid scored apart), ties within 0.002 to the narrower vector,
leave-one-source-out with a paired bootstrap against ``ss6``; ship only if the LOSO mean is
above ``ss6``'s by more than 0.002 with the 95 % interval above zero. The block is
extrinsic: the ``bendable`` family would leave it out.

    nice -n 10 .venv/bin/python bench/selection/surflet_block_select.py /work/study \\
        --json /work/study/surflet.json
"""

from __future__ import annotations

import os
import sys
from functools import partial
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from profile_block_select import added_block_question, study_command  # noqa: E402

from core.extrinsic import surface_normals  # noqa: E402

RESOLUTIONS = ((4, 3), (6, 4))  # (distance bins D, angle bins A)
WEIGHTS = (0.5, 1.0, 2.0)
PAIRS = 20000
NEIGHBOURS = 12
DISTANCE_RANGE = 2.5


def surflet_block(points: np.ndarray, areas: np.ndarray, distance_bins: int,
                  angle_bins: int) -> np.ndarray:
    """The surflet-pair histogram's square root at unit norm, ``(D * A**3,) float``.

    Parameters
    ----------
    points : (n, 3) float
    areas : (n,) float
    distance_bins : int
        ``D``: equal bins of distance over mean distance in [0, 2.5).
    angle_bins : int
        ``A``: equal bins of each absolute cosine in [0, 1].
    """
    normals = surface_normals(points, NEIGHBOURS)
    rng = np.random.default_rng(0)
    first, second = rng.choice(len(points), size=(2, PAIRS), p=areas / areas.sum())
    keep = first != second
    first, second = first[keep], second[keep]
    offsets = points[second] - points[first]
    distances = np.linalg.norm(offsets, axis=1)
    keep = distances > 0
    first, second, offsets, distances = first[keep], second[keep], offsets[keep], distances[keep]
    directions = offsets / distances[:, None]
    a = np.abs(np.einsum("ij,ij->i", normals[first], directions))
    b = np.abs(np.einsum("ij,ij->i", normals[second], directions))
    g = np.abs(np.einsum("ij,ij->i", normals[first], normals[second]))
    ratio = distances / distances.mean()

    def bins(values: np.ndarray, count: int, top: float) -> np.ndarray:
        return np.clip((values / top * count).astype(int), 0, count - 1)

    index = np.ravel_multi_index(
        (bins(ratio, distance_bins, DISTANCE_RANGE), bins(np.minimum(a, b), angle_bins, 1.0),
         bins(np.maximum(a, b), angle_bins, 1.0), bins(g, angle_bins, 1.0)),
        (distance_bins, angle_bins, angle_bins, angle_bins))
    counts = np.bincount(index, minlength=distance_bins * angle_bins**3).astype(float)
    block = np.sqrt(counts / max(counts.sum(), 1.0))
    norm = np.linalg.norm(block)
    return block / norm if norm > 0 else block


def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(__doc__, argv)
    grid = {f"surflet D{distance_bins} A{angle_bins}":
            partial(surflet_block, distance_bins=distance_bins, angle_bins=angle_bins)
            for distance_bins, angle_bins in RESOLUTIONS}
    added_block_question(study, cache, grid, WEIGHTS, "surflet block", args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
