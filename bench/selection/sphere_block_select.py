"""Issue 24 follow-up: does a spherical-harmonic energy block generalise across sources?

Measurement only (the service's descriptor does not change in this step; a choice that
ships by the rule is adopted in a later step, with its tests and the score calibration).
Why, disclosed: on the Engineering Shape Benchmark (Jayanti et al., 2006) the spherical
harmonics descriptor (Kazhdan, Funkhouser & Rusinkiewicz, 2003) was among the best global
descriptors for engineering parts. ``ss6`` sees where area lies from the centre only as a
distance (D1) and about its principal axes (symmetry, ring); the directions in which it lies
at each distance, with no axis chosen at all, it does not see: a screw's head is area at
large distance toward one pole, a gear's teeth area at large distance around an equator,
a flange's bolt holes gaps in a band.

The ``sphere`` block (computed on the stored normalised sample ``points`` ``(n, 3)`` with
``areas`` ``(n,)``): about the area-weighted centroid, the points fall into ``S`` shells of
equal area by their distance from it (area-weighted quantiles, so proportions stay D1's
job); per shell, the area-weighted mean of every spherical harmonic ``Y_lm`` over the
points' directions, and per degree ``l = 1..L`` the energy ``sqrt(sum_m |f_lm|^2)`` over
its largest possible value ``sqrt((2l + 1) / (4 pi))`` (all the shell's area in one
direction), so each value lies in [0, 1]. A rotation mixes the ``m`` of one ``l`` and keeps
the energy; translation, uniform scale and point order do not enter. ``S x L`` values divided
by ``sqrt(S L)``, like the ring block (norm at most 1, not unit norm: a ball has a small
block). A shell with fewer than 3 points gives zeros.

The grid, written before any score of it was seen: ``ss6`` (the reference) and ``ss6`` with
the ``sphere`` block added at shells ``S`` in {4, 8} x degrees ``L`` in {8, 16} x weight in
{1, 2, 4, 8}: 17 candidates. The rule and the ship condition are the ring study's
(``bench/selection/profile_block_select.py``): mAP per source, mean over the seven sources
(capod-nonrigid scored apart), ties within 0.002 to the narrower vector, leave-one-source-out
with a paired bootstrap against ``ss6``; ship only if the LOSO mean is above ``ss6``'s by
more than 0.002 with the 95 % interval above zero. The block is extrinsic: the ``bendable``
family would leave it out.

    nice -n 10 .venv/bin/python bench/selection/sphere_block_select.py /work/study \\
        --json /work/study/sphere.json
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
from scipy.special import sph_harm_y  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from profile_block_select import added_block_question, study_command  # noqa: E402

SHELLS = (4, 8)
DEGREES = (8, 16)
WEIGHTS = (1.0, 2.0, 4.0, 8.0)


def sphere_block(points: np.ndarray, areas: np.ndarray, shells: int, degrees: int
                 ) -> np.ndarray:
    """Spherical-harmonic energies per shell of equal area, ``(shells * degrees,) float``.

    Parameters
    ----------
    points : (n, 3) float
    areas : (n,) float
    shells : int
    degrees : int
        Degrees ``l = 1..degrees`` (``l = 0`` is constant).
    """
    weights = areas / areas.sum()
    offsets = points - weights @ points
    radius = np.linalg.norm(offsets, axis=1)
    order = np.argsort(radius, kind="stable")
    # Area-weighted quantiles: shell i holds the points whose cumulative area lies in
    # [i / shells, (i + 1) / shells).
    cumulative = np.cumsum(weights[order]) - 0.5 * weights[order]
    shell_of = np.empty(len(points), dtype=int)
    shell_of[order] = np.minimum((cumulative * shells).astype(int), shells - 1)
    polar = np.arccos(np.clip(offsets[:, 2] / np.maximum(radius, 1e-300), -1.0, 1.0))
    azimuth = np.arctan2(offsets[:, 1], offsets[:, 0])
    # Every (l, m >= 0) at once: |f_{l,-m}| = |f_{l,m}| for real weights, so m > 0 counts twice.
    degree, order_m = np.array([(d, m) for d in range(1, degrees + 1) for m in range(d + 1)]).T
    harmonics = sph_harm_y(degree[:, None], order_m[:, None], polar[None], azimuth[None])
    members = shell_of[None, :] == np.arange(shells)[:, None]  # (shells, n)
    shell_weights = np.where(members, weights[None, :], 0.0)
    totals = shell_weights.sum(axis=1, keepdims=True)
    means = (shell_weights / np.maximum(totals, 1e-300)) @ harmonics.T  # (shells, K)
    power = np.abs(means) ** 2 * np.where(order_m == 0, 1.0, 2.0)
    energy = np.zeros((shells, degrees))
    np.add.at(energy.T, degree - 1, power.T)
    block = np.sqrt(energy / ((2 * np.arange(1, degrees + 1) + 1) / (4 * np.pi)))
    block[members.sum(axis=1) < 3] = 0.0
    return block.ravel() / np.sqrt(block.size)


def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(__doc__, argv)
    grid = {f"sphere S{shells} L{degrees}": partial(sphere_block, shells=shells, degrees=degrees)
            for shells, degrees in itertools.product(SHELLS, DEGREES)}
    added_block_question(study, cache, grid, WEIGHTS, "sphere block", args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
