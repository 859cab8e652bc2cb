"""Issue 24 follow-up: does the ShapeDNA count, chosen on capod, hold on other sources?

Measurement only (the service's descriptor does not change in this step; a choice that
ships by the rule is adopted in a later step, with its tests and the score calibration).
Why, disclosed: written after the WKS band width held (``bench/selection/extraction_select.py``,
question 5), as the next setting of the descriptor chosen on capod alone: the ``dna`` block
(Reuter et al. 2006, on Weyl's scale: ``log(lambda_j / 4 pi j)`` of the first ``dna_count``
non-zero eigenvalues, centred), 30 values at weight 0.2. Fewer values keep the coarse
spectrum only; more reach eigenvalues that tell finer, repeated features apart (teeth,
threads, holes on a circle), and are noisier.

The ``parts`` family's vectors as ``ss6`` joins them, the ``dna`` block recomputed from each
model's stored eigenvalues (``bench/selection/local_features_extract.py`` keeps those up to the
adaptive cutoff; a shorter spectrum repeats its last value, as the service does) by
``DescriptorSpec`` with ``dna_count`` changed, every other block as stored; the local block
(each source encoded by words fitted on the other sources) and the ring block at weight 4
as the service joins them.

The grid, written before any score of it was seen: ``dna_count`` in {30 (the service's), 15,
60}, ties in that order. The rule and the ship condition are the ring study's
(``bench/selection/profile_block_select.py``): mAP per source, mean over the seven sources
(capod-nonrigid scored apart), leave-one-source-out with a paired bootstrap against 30; ship
only if the LOSO mean is above 30's by more than 0.002 with the 95 % interval above zero.
The ``bendable`` family is not part of this question (it keeps 30 until asked by its own
rule).

    nice -n 10 .venv/bin/python bench/selection/shape_dna_select.py /work/study \\
        --json /work/study/dna.json
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")


sys.path.insert(0, str(Path(__file__).resolve().parent))
from histogram_bins_select import ss6_recomputed  # noqa: E402
from profile_block_select import (  # noqa: E402
    decide,
    default_local_blocks,
    ring_blocks,
    score_candidates,
    study_command,
)

COUNTS = (30, 15, 60)


def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(__doc__, argv)
    local = study.with_nonrigid(default_local_blocks(study.sources, cache))
    changes = {f"dna {count}": {"dna_count": count} for count in COUNTS}
    table, widths, queries = score_candidates(
        ss6_recomputed(study, cache, local, ring_blocks(study), ("dna",), changes), study.scored)
    order = {name: rank for rank, name in enumerate(table)}
    decide(table, queries, order, "ShapeDNA count", tuple(s.name for s in study.sources),
           "dna 30", args.json, tie_key="order", widths=widths)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
