"""Issue 24 follow-up: the caps and ring blocks' weights, asked again now that both are steadier.

Measurement first (a choice that ships by the rule is adopted in a later step, with the
score calibration). Why: the caps block's weight (1) was chosen in its round 1 with hard
principal axes, and the ring block's (4) in its round 2 with area tertiles; since then soft
axes (``ss8``) and soft shells (``ss9``) took sampling noise out of both (a re-sampled copy's
lowest cosine 0.901 -> 0.938 in the ``parts`` source). A block that carries less noise may
deserve more weight: the weights that balanced signal against noise were measured on the
noisier blocks. The block weights study (``bench/selection/block_weights_select.py``) asked the
other blocks at ``ss6``, before the caps block existed.

The pool, written before any score of it was seen: caps weight {1, 1.5, 2} x ring weight
{4, 6}, every other block as ``ss9`` (caps 1, ring 4 is ``ss9``): 6 candidates, one width.
The rule is the ring study's (mean mAP over the seven sources, capod-nonrigid scored apart,
leave-one-source-out with a paired bootstrap against ``ss9``); within 0.002 the tie order
is ``ss9`` first, then the smaller change (caps 1.5 before ring 6, before both, before caps
2). The choice ships on the rule's usual condition (``rule_report``): its leave-one-source-out
mean above ``ss9``'s mean by more than the tie margin, the bootstrap's lower end above zero.
The bendable family has neither block and is not asked.

    nice -n 10 .venv/bin/python bench/selection/stabilised_weights_select.py /work/study \\
        --json /work/study/stabilised_weights.json
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterable
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from local_features_select import joined  # noqa: E402
from profile_block_select import (  # noqa: E402
    decide,
    default_local_blocks,
    default_ring_and_caps,
    score_candidates,
    study_command,
)

from core.settings import DescriptorSettings  # noqa: E402

SS9 = "ss9"
#: (caps weight, ring weight) in the tie order; the first is ``ss9``.
GRID = ((1.0, 4.0), (1.5, 4.0), (1.0, 6.0), (1.5, 6.0), (2.0, 4.0), (2.0, 6.0))


def label(caps: float, ring: float) -> str:
    return SS9 if (caps, ring) == GRID[0] else f"ss9, caps w{caps:g}, ring w{ring:g}"


def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(__doc__, argv)
    settings = DescriptorSettings()
    assert (settings.caps_weight, settings.ring_weight) == GRID[0], "ss9 is not the default"
    scored = study.scored
    local = study.with_nonrigid(default_local_blocks(study.sources, cache))
    ring, caps = default_ring_and_caps(study)
    print("blocks done", flush=True)

    def candidates() -> Iterable[tuple[str, dict[str, np.ndarray]]]:
        for caps_weight, ring_weight in GRID:
            yield label(caps_weight, ring_weight), {
                s.name: joined(np.hstack([s.bases["ss4-noprop"], local[s.name],
                                          ring_weight * ring[s.name]]),
                               caps[s.name], caps_weight)
                for s in scored}

    table, widths, queries = score_candidates(candidates(), scored)
    tie_order = {label(*weights): rank for rank, weights in enumerate(GRID)}
    decide(table, queries, tie_order, "stabilised weights",
           tuple(s.name for s in study.sources), SS9, args.json, tie_key="tie order",
           widths=widths, pool=list(tie_order))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
