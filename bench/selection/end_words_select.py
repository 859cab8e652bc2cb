"""Issue 24 follow-up: the local words of each *end*, pooled apart from the whole.

Measurement only (the service's descriptor does not change in this step; a choice that
ships by the rule is adopted in a later step, with its tests, the scan tables and the score
calibration). Why, disclosed: the issue's own diagnosis is that what separates standard
parts is a small share of the surface (a head, a socket, a hub, teeth) and area-weighted
pooling over the whole part drowns it. The caps block measures each end's *geometry* in
the part's radius and is the best block alone on pymadcad's screws (0.96), but weighing it
more costs bent shapes and capod (``bench/selection/stabilised_weights_select.py``). The
local block (VLAD of per-point HKS and surface-variation words) sees fine detail but pools
it over the whole part, where a screw's shank outweighs its head. This candidate pools the
same words over each end alone, so that an end's detail counts as much as the whole's.

The ``end words`` block of a model: its sample's local features (``hks+sv``, as the local
block's), softly assigned to the 64 words fitted without the model's source (as the local
block's fold words); about each of the first and the third principal axis, the ends found
as the caps block finds them (the area-weighted 0.5 % and 99.5 % quantiles of the
coordinate along the axis, the region ``depth`` part radii deep from each, the radius the
area-weighted median distance from the axis; the wider end first) and the area-weighted
word frequencies of each end's points; averaged over the directions an axis could take with
the caps block's soft axes (``core.extrinsic.soft_axis_weights``, sharpness 4096); then per
end ``sqrt(frequency * idf)`` (as ``core.local_features.encode_bof``), the four ends
joined, ``(256,)`` at unit norm. Invariant to rotation, translation, uniform scale and
point order as the caps block is; it changes when a part bends (its ends are extrinsic),
like the caps block.

The grid, written before any score of it was seen: ``ss9`` and ``ss9`` with the end words
block of ``depth`` in {1, 2} at weight in {0.5, 1, 2}, joined before the one unit scaling
as the service joins blocks: 7 candidates, ties within 0.002 in the order ``ss9``, then
lighter weight first, then depth 1 before 2. The rule and the ship condition are the ring
study's (``bench/selection/profile_block_select.py``): mAP per source, leave-one-out
within each source, mean over the seven sources (capod-nonrigid scored apart),
leave-one-source-out with a paired bootstrap against ``ss9``; ship only if the LOSO mean is
above ``ss9``'s by more than 0.002 with the 95 % interval above zero. Adoption would also
need the bendable family's check (rule 4: the default's non-rigid sources are in the rule
already) and the scan-mode tables not to fall by more than 0.01 mAP on any source, both
measured only if the rule ships a choice.

    nice -n 10 .venv/bin/python bench/selection/end_words_select.py /work/study \\
        --json /work/study/end_words.json
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Iterator
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from local_features_select import Study, joined  # noqa: E402
from profile_block_select import (  # noqa: E402
    decide,
    fold_words,
    score_candidates,
    ss9_blocks,
    study_command,
    study_samples,
)

from core.extrinsic import (  # noqa: E402
    END_DIRECTIONS,
    END_QUANTILE,
    _weighted_quantile,
    principal_frame,
    soft_axis_weights,
)
from core.local_features import Vocabulary  # noqa: E402
from core.settings import DescriptorSettings  # noqa: E402

SS9 = "ss9"
DEPTHS = (1.0, 2.0)
WEIGHTS = (0.5, 1.0, 2.0)
#: Soft-axis directions whose kernel is below this share of the largest are left out (as
#: the caps block's).
NEGLIGIBLE = 1e-4


def candidate_name(depth: float, weight: float) -> str:
    return f"ss9 + end words H{depth:g} w{weight:g}"


def _direction_end_words(z: np.ndarray, r: np.ndarray, weights: np.ndarray,
                         assignment: np.ndarray, depth: float) -> np.ndarray:
    """The two ends' word frequencies along one direction, wider first, ``(2, k)``; an
    end that holds no area is zeros."""
    radius = _weighted_quantile(r, weights, 0.5)
    scale = radius if radius > 0 else 1.0
    low = _weighted_quantile(z, weights, END_QUANTILE)
    high = _weighted_quantile(z, weights, 1.0 - END_QUANTILE)
    ends = []
    for reach in ((high - z) / scale, (z - low) / scale):
        inside = (reach >= 0) & (reach < depth)
        mass = float(weights[inside].sum())
        width = float(weights[inside] @ r[inside]) / mass / scale if mass > 0 else 0.0
        frequencies = weights[inside] @ assignment[inside]
        ends.append((width, frequencies / mass if mass > 0 else frequencies))
    ends.sort(key=lambda end: -end[0])
    return np.stack([frequencies for _, frequencies in ends])


def end_words_block(points: np.ndarray, areas: np.ndarray, features: np.ndarray,
                    vocabulary: Vocabulary, depth: float, sharpness: float) -> np.ndarray:
    """The end words block of one model, ``(4 * k,)`` at unit norm.

    Parameters
    ----------
    points : (n, 3) float
    areas : (n,) float
    features : (n, d) float
        The local features of ``points`` (``hks+sv``).
    vocabulary : Vocabulary
    depth : float
        How deep an end reaches, in part radii.
    sharpness : float
        The soft axes' kernel (``soft_axis_weights``).
    """
    coordinates, variances, _ = principal_frame(points, areas)
    weights = areas / areas.sum()
    assignment = vocabulary.assign(features)
    kernels = soft_axis_weights(variances, END_DIRECTIONS, sharpness)
    used = (kernels > NEGLIGIBLE * kernels.max(axis=1, keepdims=True)).any(axis=0)
    frequencies = np.zeros((2, 2, vocabulary.size))
    for direction, kernel in zip(END_DIRECTIONS[used], kernels[:, used].T, strict=True):
        z = coordinates @ direction
        r = np.linalg.norm(coordinates - z[:, None] * direction, axis=1)
        ends = _direction_end_words(z, r, weights, assignment, depth)
        frequencies += kernel[:, None, None] * ends[None]
    encoded = np.sqrt(frequencies * vocabulary.idf).ravel()
    norm = np.linalg.norm(encoded)
    return encoded / norm if norm > 0 else encoded


def end_words_blocks(study: Study, depth: float, timings: list[float]
                     ) -> dict[str, np.ndarray]:
    """The end words block of every model at ``depth``, per source, each source on the
    words fitted without it; capod-nonrigid included."""
    sharpness = DescriptorSettings().caps_sharpness
    assert sharpness is not None
    samples = study_samples(study)
    blocks: dict[str, np.ndarray] = {}
    for source in study.sources:
        vocabulary = fold_words(study.sources, source.name)
        rows = []
        for (points, areas), features in zip(samples[source.name], source.local["hks+sv"],
                                             strict=True):
            start = time.perf_counter()
            rows.append(end_words_block(points, areas, features, vocabulary, depth, sharpness))
            timings.append(1000.0 * (time.perf_counter() - start))
        blocks[source.name] = np.array(rows)
    return study.with_nonrigid(blocks)


def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(__doc__, argv)
    scored = study.scored
    rest, caps = ss9_blocks(study, cache)
    # ss9's weighted blocks before the one unit scaling; a new block joins them there.
    raw = {name: np.hstack([rows, caps[name]]) for name, rows in rest.items()}
    timings: dict[str, list[float]] = {}
    ends: dict[float, dict[str, np.ndarray]] = {}
    for depth in DEPTHS:
        timings[f"H{depth:g}"] = []
        ends[depth] = end_words_blocks(study, depth, timings[f"H{depth:g}"])
    print("blocks done", flush=True)

    def candidates() -> Iterator[tuple[str, dict[str, np.ndarray]]]:
        yield SS9, {s.name: joined(raw[s.name], None, 0.0) for s in scored}
        for weight in WEIGHTS:
            for depth in DEPTHS:
                yield candidate_name(depth, weight), {
                    s.name: joined(raw[s.name], ends[depth][s.name], weight) for s in scored}

    table, widths, queries = score_candidates(candidates(), scored)
    order = {name: rank for rank, name in enumerate(table)}
    cost = {label: float(np.median(spent)) for label, spent in timings.items()}
    decide(table, queries, order, "end words", tuple(s.name for s in study.sources), SS9,
           args.json, tie_key="tie order", widths=widths, extra={"cost_ms": cost})
    print("end words, median ms per model:", {k: round(v, 2) for k, v in cost.items()})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
