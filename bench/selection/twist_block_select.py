"""Issue 24 follow-up: does a block that sees teeth twist about the axis generalise?

Measurement only (the service's descriptor does not change in this step; a choice that
ships by the rule is adopted in a later step, with its tests and the score calibration).
Why, disclosed: the four third-party libraries as one catalogue scored by kind
(``catalogue_by_kind.py``, twelfth session) miss 49 of 326 first answers in the service's
order, and 28 of them are spur, helical and herringbone gears taken for each other (spur
9 / 18 right, helical 8 / 18, herringbone 2 / 10): the gears of two libraries that differ
only in how their teeth turn along the axis. The ring block (``core.extrinsic.
angular_spectrum``) pools a shell's points over the whole axis, so it sees that teeth repeat
but not whether the repetition stays in phase from one face to the other.

The ``twist`` block (on the stored normalised sample ``points`` ``(n, 3)`` with ``areas``
``(n,)``): about the first and the third principal axis, as the ring block, the outer half
of the area by distance from the axis (teeth, threads, splines lie at the rim) cut into
``SLABS`` slabs of equal area along the axis; in each slab ``s`` the area-weighted angular
Fourier coefficients ``c_k(s)`` (``k`` 1 .. 47); per band of ``ANGULAR_BANDS`` and slab
distance ``d`` (1 .. ``SLABS`` - 1), the mean over slab pairs ``d`` apart of
``sum_k Re(c_k(i) conj c_k(i + d))`` over the mean slab power ``sum_k |c_k(s)|^2`` plus
the power uniform sampling noise alone would put there: about 1 while the repetition stays
in phase along the axis (spur teeth), ``cos(k * twist * d)`` when it turns (helical teeth:
falling with ``d``), falling then rising again when it turns back (herringbone), near 0
when nothing repeats beyond noise. ``2 x 5 x 3`` = 30 values in [-1, 1], over the square
root of its length like the ring block. A common rotation about the axis, its direction and
the axis' sign (which reverses the slabs; every value is symmetric in that) cancel, so the
block is invariant to rotation, translation, uniform scale and point order.

The grid, written before any score of it was seen: ``ss9`` (the reference) and ``ss9`` with
the ``twist`` block (4 slabs, the outer half) at weight {1, 2, 4} (the ring block's is 4):
4 candidates. The study is the first on eight sources (``/work/study8``: the seven and
OpenSCAD's MCAD, which judged the re-rank in the eleventh session and is a tuning source
from here on). The rule and the ship condition are the ring study's
(``bench/selection/profile_block_select.py``): mAP per source, mean over the eight sources
(capod-nonrigid scored apart), ties within 0.002 to the narrower vector,
leave-one-source-out with a paired bootstrap against ``ss9``; ship only if the LOSO mean is
above ``ss9``'s by more than 0.002 with the 95 % interval above zero. The block is
extrinsic: the ``bendable`` family leaves it out. Reported beside, not part of the rule:
the rule's choice in the one catalogue scored by kind, plain and in the service's order.

    nice -n 10 .venv/bin/python bench/selection/twist_block_select.py /work/study8 \\
        --json /work/study8/twist.json
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from catalogue_by_kind import KIND_OF, scores  # noqa: E402
from hubness_select import pooled_rows  # noqa: E402
from local_features_select import joined  # noqa: E402
from mcad_check import CANDIDATE, CATALOGUE, KEYS  # noqa: E402
from profile_block_select import (  # noqa: E402
    blocks_per_source,
    decide,
    score_candidates,
    ss9_blocks,
    study_command,
    study_samples,
)

from core.extrinsic import ANGULAR_BANDS, principal_frame  # noqa: E402

SS9 = "ss9"
SLABS = 4
WEIGHTS = (1.0, 2.0, 4.0)


def _slab_coefficients(across: np.ndarray, along: np.ndarray, weights: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Per slab of equal weight along the axis: the angular coefficients ``(SLABS, 47)``
    complex and the power uniform noise puts into one coefficient ``(SLABS,)``."""
    highest = max(high for _, high in ANGULAR_BANDS)
    radius = np.abs(across)
    unit = np.where(radius > 0, across / np.where(radius > 0, radius, 1.0), 1.0)
    powers = np.cumprod(np.repeat(unit[:, None], highest - 1, axis=1), axis=1)
    order = np.argsort(along, kind="stable")
    share = np.cumsum(weights[order])
    slab = np.empty(len(along), dtype=np.int64)
    slab[order] = np.minimum((SLABS * share / share[-1]).astype(np.int64), SLABS - 1)
    member = np.zeros((SLABS, len(along)))
    member[slab, np.arange(len(along))] = weights
    mass = member.sum(axis=1)
    safe = np.where(mass > 0, mass, 1.0)
    return (member @ powers) / safe[:, None], (member ** 2).sum(axis=1) / safe ** 2


def twist_coherence(points: np.ndarray, areas: np.ndarray) -> np.ndarray:
    """How the angular repetition keeps its phase along the first and third principal axes,
    ``(2, 5, SLABS - 1) float`` (axis, band, slab distance); see the module's text."""
    coordinates, _, _ = principal_frame(points, areas)
    weights = areas / areas.sum()
    result = np.zeros((2, len(ANGULAR_BANDS), SLABS - 1))
    for row, (u, v, axis) in enumerate(((1, 2, 0), (0, 1, 2))):
        across = coordinates[:, u] - 1j * coordinates[:, v]
        radius = np.abs(across)
        order = np.argsort(radius, kind="stable")
        share = np.cumsum(weights[order])
        outer = order[share > 0.5 * share[-1]]
        coefficients, noise = _slab_coefficients(across[outer], coordinates[outer, axis],
                                                 weights[outer])
        for band, (low, high) in enumerate(ANGULAR_BANDS):
            in_band = coefficients[:, low - 1 : high - 1]
            power = np.mean(np.sum(np.abs(in_band) ** 2, axis=1)) + np.mean(noise) * (high - low)
            for distance in range(1, SLABS):
                cross = np.real(np.sum(in_band[:-distance] * np.conj(in_band[distance:]),
                                       axis=1))
                result[row, band, distance - 1] = np.mean(cross) / power
    return result


def twist_block(points: np.ndarray, areas: np.ndarray) -> np.ndarray:
    """The ``twist`` block at weight 1, ``(30,) float``, over the square root of its length."""
    values = twist_coherence(points, areas).ravel()
    return values / np.sqrt(values.size)


def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(__doc__, argv)
    scored = study.scored
    raw, caps = ss9_blocks(study, cache)
    timings: list[float] = []
    samples = study_samples(study)
    twist = study.with_nonrigid(blocks_per_source(samples, twist_block, timings))
    print(f"twist block: median {np.median(timings):.1f} ms per model", flush=True)

    def candidates() -> Iterator[tuple[str, dict[str, np.ndarray]]]:
        yield SS9, {s.name: joined(raw[s.name], caps[s.name], 1.0) for s in scored}
        for weight in WEIGHTS:
            yield f"ss9 + twist w{weight:g}", {
                s.name: joined(np.hstack([raw[s.name], caps[s.name]]), twist[s.name], weight)
                for s in scored}

    table, widths, queries = score_candidates(candidates(), scored)
    report = decide(table, queries, widths, "twist block", tuple(s.name for s in study.sources),
                    SS9, args.json, widths=widths,
                    extra={"cost_ms": float(np.median(timings))})
    choice = str(report["chosen"])
    added = None if choice == SS9 else (twist, float(choice.rsplit("w", 1)[1]))
    rows, library_kinds = pooled_rows(study, CATALOGUE, added)
    kinds = [KIND_OF.get(label, label) for label in library_kinds]
    for order, name in (("plain", SS9), ("service", CANDIDATE)):
        result = scores(KEYS[name](rows), kinds)
        print(f"one catalogue by kind, {choice}, {order}: NN {result['nn']:.3f}, "
              f"mAP {result['map']:.3f}, top-5 {result['top5']:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
