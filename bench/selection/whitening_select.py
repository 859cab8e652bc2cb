"""Issue 24 follow-up: does PCA whitening of the descriptor generalise across sources?

Measurement only (the service's descriptor does not change in this step; a choice that
ships by the rule is adopted in a later step, with its tests and the score calibration).
Why, disclosed: ``ss6`` joins histograms whose bins rise and fall together (neighbouring
bins of one histogram, the HKS and WKS of one part, VLAD residuals of similar words), so
whatever several correlated bins carry is counted several times in a distance. Jegou & Chum
(2012, "Negative evidence and co-occurrences in image retrieval") showed that PCA whitening
learned on other data removes such over-counting and raises retrieval mAP of bag-of-words
and VLAD vectors. Unlike the nuisance projection (``bench/selection/nuisance_projection_select.py``)
it uses no labels: it only equalises the descriptor's directions of variance.

The candidate of ``d`` components and power ``alpha`` (computed on the stored study
features):

- ``ss6`` unit rows ``x`` ``(m, 2817)`` as the service builds them;
- fitted on the *fitting* sources, each weighing the same: the mean ``mu`` of the sources'
  means, and the SVD of the stacked ``(X_t - mu) / sqrt(m_t)``, giving the leading ``d``
  directions ``U`` ``(2817, d)`` and their standard deviations ``sigma`` ``(d,)``;
- ``y = sigma ** -alpha * U^T (x - mu)``, scaled to unit norm (``alpha`` 1 whitens, 0.5 goes
  half way, 0 only projects onto the ``d`` leading directions).

Leave-one-source-out without a leak, as for the nuisance projection: for each source ``s``
one vocabulary fitted on the other sources encodes every source, the whitening is fitted on
the other sources' rows, and ``s`` is scored with it; capod-nonrigid with capod's fold.

The grid, written before any score of it was seen: ``ss6`` (the reference) and ``d`` in
{64, 128, 256} x ``alpha`` in {0, 0.5, 1}: 10 candidates. The rule and the ship condition are
the ring study's (``bench/selection/profile_block_select.py``): mAP per source, mean over the seven
sources, ties within 0.002 to the narrower vector (``ss6`` counts as 2817 wide), applied
leave-one-source-out with a paired bootstrap against ``ss6``; ship only if the LOSO mean is
above ``ss6``'s by more than 0.002 with the 95 % interval above zero. The bendable family is
not part of this question.

    nice -n 10 .venv/bin/python bench/selection/whitening_select.py /work/study \\
        --json /work/study/whitening.json
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from nuisance_projection_select import fold_local_blocks  # noqa: E402
from profile_block_select import (  # noqa: E402
    decide,
    ring_blocks,
    score_candidates,
    ss6_rows,
    study_command,
)

COMPONENTS = (64, 128, 256)
POWERS = (0.0, 0.5, 1.0)
SS6 = "ss6"


def fitted_whitening(rows: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean ``(d,)``, directions ``(d, k)`` and standard deviations ``(k,)`` of the
    fitting sources' rows, each source weighing the same.

    Parameters
    ----------
    rows : list of (m_t, d) float
        Each fitting source's unit rows.
    """
    mean = np.mean([source_rows.mean(axis=0) for source_rows in rows], axis=0)
    stacked = np.vstack([(source_rows - mean) / np.sqrt(len(source_rows))
                         for source_rows in rows])
    _, singular, right = np.linalg.svd(stacked, full_matrices=False)
    return mean, right.T, singular / np.sqrt(len(rows))


def whitened(rows: np.ndarray, mean: np.ndarray, directions: np.ndarray,
             deviations: np.ndarray, power: float) -> np.ndarray:
    """``rows`` ``(m, d)`` on ``directions`` ``(d, k)``, each divided by its deviation to
    the ``power``, scaled to unit norm ``(m, k)``."""
    projected = (rows - mean) @ directions / deviations**power
    return projected / np.maximum(np.linalg.norm(projected, axis=1, keepdims=True), 1e-300)


def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(__doc__, argv)
    sources, scored = study.sources, study.scored
    rule_sources = tuple(s.name for s in sources)

    rings = ring_blocks(study)
    folds = fold_local_blocks(sources, cache)
    rows = {fold: {s.name: ss6_rows(s, folds[fold][s.name], rings[s.name]) for s in sources}
            for fold in rule_sources}
    fitted = {fold: fitted_whitening([rows[fold][s.name] for s in sources if s.name != fold])
              for fold in rule_sources}

    def vectors(components: int, power: float) -> dict[str, np.ndarray]:
        if components == 0:
            return study.with_nonrigid({fold: rows[fold][fold] for fold in rule_sources})
        out = {}
        for fold in rule_sources:
            mean, directions, deviations = fitted[fold]
            out[fold] = whitened(rows[fold][fold], mean, directions[:, :components],
                                 deviations[:components], power)
        # capod-nonrigid is scored with capod's fold.
        return study.with_nonrigid(out)

    grid = [(SS6, 0, 0.0)] + [(f"pca{d} alpha{a:g}", d, a)
                              for d in COMPONENTS for a in POWERS]
    table, widths, queries = score_candidates(
        ((name, vectors(d, a)) for name, d, a in grid), scored)
    decide(table, queries, widths, "whitening", rule_sources, SS6, args.json, widths=widths)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
