"""Issue 24 follow-up: does a profile of each *end*, measured in the part's own radius, generalise?

Measurement only (the service's descriptor does not change in this step; a choice that
ships by the rule is adopted in a later step, with its tests and the score calibration).
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
(``bench/profile_block_select.py``): mAP per source, mean over the seven sources
(capod-nonrigid scored apart), ties within 0.002 to the narrower vector,
leave-one-source-out with a paired bootstrap against ``ss6``; ship only if the LOSO mean is
above ``ss6``'s by more than 0.002 with the 95 % interval above zero. The block is extrinsic:
the ``bendable`` family would leave it out.

    nice -n 10 .venv/bin/python bench/end_caps_select.py /work/study \\
        --json /work/study/end_caps.json
"""

from __future__ import annotations

import itertools
import os
import sys
from collections.abc import Iterator
from functools import partial
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from local_features_select import joined  # noqa: E402
from profile_block_select import (  # noqa: E402
    SS6_RING_WEIGHT,
    blocks_per_source,
    decide,
    default_local_blocks,
    ring_blocks,
    score_candidates,
    ss6_rows,
    study_command,
    study_samples,
)

from core.extrinsic import principal_frame  # noqa: E402

BINS = (4, 6)
DEPTHS = (1.0, 2.0)
WEIGHTS = (0.5, 1.0, 2.0)
RADIAL_RANGE = 2.5
END_QUANTILE = 0.005
SS6 = "ss6"


def weighted_quantile(values: np.ndarray, weights: np.ndarray, share: float) -> float:
    """The value below which ``share`` of the weight lies (``weights`` sum to 1)."""
    order = np.argsort(values, kind="stable")
    cumulative = np.cumsum(weights[order])
    return float(values[order][min(np.searchsorted(cumulative, share), len(values) - 1)])


def end_histogram(depth: np.ndarray, radial: np.ndarray, weights: np.ndarray, bins: int,
                  cap: float) -> np.ndarray:
    """Area-weighted ``(bins, bins)`` histogram of (depth, radial) of the points with
    ``depth < cap``, summing to 1 (zeros if they hold no area)."""
    inside = (depth >= 0) & (depth < cap)
    row = np.clip((depth[inside] / cap * bins).astype(int), 0, bins - 1)
    column = np.clip((radial[inside] / RADIAL_RANGE * bins).astype(int), 0, bins - 1)
    histogram = np.bincount(row * bins + column, weights=weights[inside],
                            minlength=bins * bins)
    total = histogram.sum()
    return histogram / total if total > 0 else histogram


def caps_block(points: np.ndarray, areas: np.ndarray, bins: int, cap: float) -> np.ndarray:
    """Each end's (depth, radius) profile in the part's radius, ``(4 * bins**2,) float``.

    Parameters
    ----------
    points : (n, 3) float
    areas : (n,) float
    bins : int
        ``B``, bins per coordinate.
    cap : float
        ``H``, how deep an end reaches, in radii.
    """
    coordinates, _, _ = principal_frame(points, areas)
    weights = areas / areas.sum()
    parts = []
    for along, across in ((0, (1, 2)), (2, (0, 1))):
        z = coordinates[:, along]
        r = np.hypot(coordinates[:, across[0]], coordinates[:, across[1]])
        radius = weighted_quantile(r, weights, 0.5)
        radial = r / radius if radius > 0 else np.zeros_like(r)
        scale = radius if radius > 0 else 1.0
        low = weighted_quantile(z, weights, END_QUANTILE)
        high = weighted_quantile(z, weights, 1.0 - END_QUANTILE)
        ends = []
        for depth in ((high - z) / scale, (z - low) / scale):
            histogram = end_histogram(depth, radial, weights, bins, cap)
            inside = (depth >= 0) & (depth < cap)
            width = (weights[inside] @ radial[inside] / weights[inside].sum()
                     if weights[inside].sum() > 0 else 0.0)
            ends.append((width, histogram))
        # Wider end first: the axis' sign is arbitrary, a head is wider than a tip.
        ends.sort(key=lambda end: -end[0])
        parts.extend(histogram for _, histogram in ends)
    block = np.sqrt(np.concatenate(parts))
    norm = np.linalg.norm(block)
    return block / norm if norm > 0 else block


def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(__doc__, argv)
    sources, scored = study.sources, study.scored
    rule_sources = tuple(s.name for s in sources)

    local = study.with_nonrigid(default_local_blocks(sources, cache))
    rings = ring_blocks(study)
    samples = study_samples(study)
    caps: dict[tuple[int, float], dict[str, np.ndarray]] = {}
    timings: dict[tuple[int, float], list[float]] = {}
    for bins, cap in itertools.product(BINS, DEPTHS):
        timings[bins, cap] = []
        caps[bins, cap] = study.with_nonrigid(blocks_per_source(
            samples, partial(caps_block, bins=bins, cap=cap), timings[bins, cap]))
    # ss6's raw weighted blocks: a new block joins them before the one unit scaling.
    raw = {s.name: np.hstack([s.bases["ss4-noprop"], local[s.name],
                              SS6_RING_WEIGHT * rings[s.name]]) for s in scored}

    def candidates() -> Iterator[tuple[str, dict[str, np.ndarray]]]:
        yield SS6, {s.name: ss6_rows(s, local[s.name], rings[s.name]) for s in scored}
        for ((bins, cap), block), weight in itertools.product(caps.items(), WEIGHTS):
            yield (f"ss6 + caps B{bins} H{cap:g} w{weight:g}",
                   {s.name: joined(raw[s.name], block[s.name], weight) for s in scored})

    table, widths, queries = score_candidates(candidates(), scored)
    cost = {f"B{b} H{h:g}": float(np.median(t)) for (b, h), t in timings.items()}
    decide(table, queries, widths, "end caps", rule_sources, SS6, args.json, widths=widths,
           extra={"cost_ms": cost})
    print("caps block, median ms per model:", cost)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
