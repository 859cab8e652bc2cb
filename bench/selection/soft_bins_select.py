"""Issue 24 follow-up: the histogram blocks with soft bins instead of hard ones. Declined.

Measurement first (a choice that ships by the rule is adopted in a later step, with its
tests and the score calibration). Why: the HKS, WKS, slope, D2, D1 and normal blocks count
each point's value into the one bin it falls in, so a re-sampling of the same surface that
moves a value across a bin edge moves a whole count, while a value that moves as far inside
a bin moves nothing. Soft bins split each value between the two bins whose centres enclose
it, linearly (``soft_area_histograms``): the histogram then changes continuously with the
values. The same kind of fix as the caps block's soft axes and the ring block's soft shells,
which carried over by small, even margins; it costs no width and next to no time.

Before any score (``ss9`` against ``ss9`` with soft bins, the service's own describe, four
sample seeds of one mesh, the mean distance between two of them): a cylinder's samplings
0.031 -> 0.026, a cube's 0.166 -> 0.140, a hex-headed bolt's 0.053 -> 0.047.

The pool, written before any score of it was seen: ``ss9`` (the default) and ``ss9`` with
soft bins in every histogram block it has (HKS, WKS, slope, D2, D1, normals): 2 candidates,
one width. The rule is the ring study's (mean mAP over the seven sources, capod-nonrigid
scored apart, leave-one-source-out with a paired bootstrap against ``ss9``), with the tie
order of the stabilisations before it: within 0.002 soft bins first, because they do not
jump with the sampling. They ship only if (1) the rule's choice over the seven sources is
soft bins, (2) its leave-one-source-out mean against ``ss9``'s has a 95 % bootstrap interval
whose lower end is above -0.005, and (3) the lowest cosine between two copies of one mesh in
the ``parts`` source is higher than ``ss9``'s (``profile_block_select.stabilisation_ships``).
The bendable family keeps its own preset (hard bins) whatever this finds: it was chosen by
its own rule, and this study does not score it.

The hard-bin base recomputed here must equal the study's stored ``ss4-noprop`` base (checked
before scoring: the recomputation is the service's ``DescriptorSpec.blocks``), up to the
study's float32 storage of the signatures and points, which moves a value that lies on a bin
edge into the next bin now and then (the first run of the check, before any score, asked for
bit equality and found 6e-4 in 2 entries of some models' HKS or normal blocks): at most 1e-3
in any entry and 1e-4 of all entries above 1e-6.

**Result, and why it was declined (disclosed).** Means over the seven sources: ``ss9``
0.8592, soft bins 0.8576, within the tie margin, so the rule chose soft bins for five of the
seven folds; leave-one-source-out 0.8570 against 0.8592: **-0.0022 (95 % -0.0033 .. -0.0012)**;
gearworks 0.576 (0.585; NN 0.586 against 0.643), bendable 0.972 (0.978), the others within
0.002. Copies' lowest cosine 0.9407 against 0.9383. The three conditions written above held,
so the test said ship; the change was not adopted all the same, because the whole interval
lies below zero: it costs retrieval for certain, and its gain in steadiness is a quarter of
the ring shells' (+0.0024 against +0.0096). The margin was written for a fix expected to be
neutral; ``stabilisation_ships`` now also asks that the interval's upper end be above zero
(added after this result, disclosed; the two shipped stabilisations pass it: +0.0037 and
+0.0021). The run (commit c6b35a2 and the check's fix after it) used the same soft histogram
as a setting of the service; it lives here now, patched into ``core.descriptor`` for the
run, so that no unused setting changes every database's version digest.

    nice -n 10 .venv/bin/python bench/selection/soft_bins_select.py /work/study \\
        --json /work/study/soft_bins.json
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Iterable
from dataclasses import replace
from pathlib import Path
from unittest.mock import patch

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from local_features_select import BASES, Study, joined  # noqa: E402
from profile_block_select import (  # noqa: E402
    SS6_RING_WEIGHT,
    default_local_blocks,
    default_ring_and_caps,
    lowest_copy_cosine,
    score_candidates,
    stabilisation_decision,
    study_command,
)

import core.descriptor  # noqa: E402
from core.descriptor import DescriptorSpec  # noqa: E402
from core.descriptor import area_histograms as hard_area_histograms  # noqa: E402
from core.settings import DescriptorSettings  # noqa: E402

SS9 = "ss9"
SOFT = "ss9, soft bins"
#: The blocks the base recomputes (the rest of ``ss4-noprop``: ShapeDNA, symmetry, stored).
HISTOGRAM_BLOCKS = ("hks", "wks", "slope", "d2", "d1", "normals")


def soft_area_histograms(values: np.ndarray, areas: np.ndarray,
                         edges: np.ndarray) -> np.ndarray:
    """``core.descriptor.area_histograms`` with soft bins: each value's area split between
    the two bins whose centres enclose it, linearly by its distance to each (whole to the
    end bin beyond the end centres). A value on a centre stays whole; halfway between two
    centres it splits in halves.

    Parameters
    ----------
    values : (n, s) float
    areas : (n,) float
    edges : (b + 1,) float

    Returns
    -------
    histograms : (s, b) float
        Each row sums to 1.
    """
    bins = edges.size - 1
    columns = values.shape[1]
    centres = (edges[:-1] + edges[1:]) / 2
    position = np.interp(values, centres, np.arange(bins, dtype=float))
    lower = np.minimum(np.floor(position).astype(np.intp), bins - 1)
    upper_share = position - lower
    # Each column's bins after the previous columns', so one bincount fills them all.
    offsets = bins * np.arange(columns)
    index = np.stack([lower, np.minimum(lower + 1, bins - 1)]) + offsets
    weights = areas[:, None] * np.stack([1.0 - upper_share, upper_share])
    histograms = np.bincount(index.ravel(), weights=weights.ravel(),
                             minlength=bins * columns).reshape(columns, bins)
    return histograms / np.maximum(histograms.sum(axis=1, keepdims=True), 1e-300)


def histogram_spec() -> DescriptorSpec:
    """The default's histogram blocks at weight 1 (unit blocks), every other block off."""
    off = dict.fromkeys(DescriptorSettings.WEIGHTS, 0.0)
    unit = {"hks_weight": 1.0, "wks_weight": 1.0, "wks_slope_weight": 1.0, "d2_weight": 1.0,
            "d1_weight": 1.0, "normal_weight": 1.0}
    return DescriptorSpec.from_settings(replace(DescriptorSettings(), **{**off, **unit}))


def base_rows(study: Study, soft: bool, timings: list[float]) -> dict[str, np.ndarray]:
    """The ``ss4-noprop`` base of every model, per source, its histogram blocks hard or soft
    (weighted as ``local_features_select.load_source`` weighs the stored blocks)."""
    spec = histogram_spec()
    weights = BASES["ss4-noprop"]
    # The service's blocks, their histogram function swapped for the soft one.
    histograms = soft_area_histograms if soft else hard_area_histograms
    rows: dict[str, np.ndarray] = {}
    for source, folder in zip(study.sources, study.folders, strict=True):
        models = []
        for file in sorted(folder.glob("*.npz")):
            with np.load(file) as data, patch.object(core.descriptor, "area_histograms",
                                                      histograms):
                start = time.perf_counter()
                blocks = spec.blocks(data["signature"].astype(np.float64),
                                     data["areas"].astype(np.float64), np.zeros(0),
                                     data["points"].astype(np.float64))
                timings.append(1000.0 * (time.perf_counter() - start))
                models.append(np.concatenate([
                    weights[key] * (blocks[key] if key in HISTOGRAM_BLOCKS
                                    else data[f"blocks_{key}"])
                    for key in weights if weights[key] > 0]))
        rows[source.name] = np.array(models)
    return rows


def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(__doc__, argv)
    scored = study.scored
    timings: dict[str, list[float]] = {SS9: [], SOFT: []}
    bases = {SS9: study.with_nonrigid(base_rows(study, False, timings[SS9])),
             SOFT: study.with_nonrigid(base_rows(study, True, timings[SOFT]))}
    stored = {s.name: s.bases["ss4-noprop"] for s in scored}
    gaps = np.concatenate([np.abs(bases[SS9][name] - rows).ravel()
                           for name, rows in stored.items()])
    moved = float(np.mean(gaps > 1e-6))
    print(f"hard base recomputed vs stored: largest difference {gaps.max():.2e}, share of "
          f"entries above 1e-6 {moved:.1e}", flush=True)
    if gaps.max() > 1e-3 or moved > 1e-4:
        raise SystemExit("the recomputed base is not the stored one: stop before scoring")
    local = study.with_nonrigid(default_local_blocks(study.sources, cache))
    ring, caps = default_ring_and_caps(study)
    print("blocks done", flush=True)
    labels = np.asarray(next(s.labels for s in scored if s.name == "parts"))
    copies: dict[str, float] = {}

    def candidates() -> Iterable[tuple[str, dict[str, np.ndarray]]]:
        for name, base in bases.items():
            rows = {s.name: joined(np.hstack([base[s.name], local[s.name],
                                              SS6_RING_WEIGHT * ring[s.name]]), caps[s.name], 1.0)
                    for s in scored}
            copies[name] = lowest_copy_cosine(rows["parts"], labels)
            yield name, rows

    table, widths, queries = score_candidates(candidates(), scored)
    stabilisation_decision(table, widths, queries, [SOFT], SS9, copies, timings, "soft bins",
                           tuple(s.name for s in study.sources), args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
