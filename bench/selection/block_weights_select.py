"""Issue 24 follow-up: were ``ss6``'s block weights chosen on data that generalises?

Measurement only (the service's descriptor does not change in this step; a choice that
ships by the rule is adopted in a later step, with its tests and the score calibration).
Why, disclosed: issue 24 says every setting was chosen on capod and on our own generator.
The weights of ``ss6``'s extrinsic blocks come from ``bench/selection/descriptor_weights.py`` (issue
12, on our generated parts and capod, scans included), its spectral weights from ``ss3``
(capod); only some were looked at again by the leave-one-source-out rule since (D2 and D1
in ``bench/selection/proportion_blocks_select.py``, the ring block's weight in
``bench/selection/profile_block_select.py``, the local block's weight with the base before the
ring).

The grid, written before any score of it was seen: ``ss6`` as the service builds it (the
``ss4-noprop`` blocks, the VLAD block of ``hks+sv`` at 64 words, each source encoded by a
vocabulary fitted on the other sources, the ring block at weight 4), and one block at a time
with its weight halved or doubled, for the blocks not yet re-weighed by the rule with the
ring in place: ``hks``, ``wks``, ``slope``, ``dna``, ``normals``, ``symmetry`` and the local
block: 15 candidates. The rule and the ship condition are the ring study's
(``bench/selection/profile_block_select.py``): mAP per source, mean over the seven sources
(capod-nonrigid scored apart), leave-one-source-out with a paired bootstrap against ``ss6``;
ship only if the LOSO mean is above ``ss6``'s by more than 0.002 with the 95 % interval above
zero. Every candidate has the same width, so ties within 0.002 go to ``ss6`` (the tie key is
the number of weights changed, 0 or 1).

    nice -n 10 .venv/bin/python bench/selection/block_weights_select.py /work/study \\
        --json /work/study/block_weights.json
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
from local_features_select import joined  # noqa: E402
from profile_block_select import (  # noqa: E402
    SS6_RING_WEIGHT,
    decide,
    default_local_blocks,
    ring_blocks,
    score_candidates,
    study_command,
)
from proportion_blocks_select import base_rows  # noqa: E402

BLOCKS = ("hks", "wks", "slope", "dna", "normals", "symmetry", "local")
SCALES = (0.5, 2.0)
SS6 = "ss6"


def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(__doc__, argv)
    sources, scored = study.sources, study.scored
    rule_sources = tuple(s.name for s in sources)

    local = study.with_nonrigid(default_local_blocks(sources, cache))
    rings = ring_blocks(study)

    def vectors(block: str | None, scale: float) -> dict[str, np.ndarray]:
        scales = {} if block in (None, "local") else {block: scale}
        local_scale = scale if block == "local" else 1.0
        bases = study.with_nonrigid({
            source.name: base_rows(path, scales)
            for source, path in zip(sources, study.folders, strict=True)})
        return {s.name: joined(np.hstack([bases[s.name], local_scale * local[s.name]]),
                               rings[s.name], SS6_RING_WEIGHT) for s in scored}

    def candidates() -> Iterator[tuple[str, dict[str, np.ndarray]]]:
        yield SS6, vectors(None, 1.0)
        for block in BLOCKS:
            for scale in SCALES:
                yield f"{block} x{scale:g}", vectors(block, scale)

    table, _, queries = score_candidates(candidates(), scored)
    changed = {name: int(name != SS6) for name in table}
    decide(table, queries, changed, "block weights", rule_sources, SS6, args.json,
           tie_key="weights changed", by_mean=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
