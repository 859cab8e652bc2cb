"""Issue 24 follow-up: should the ring block say how much a part repeats about its axis,
but not in which octave?

Measurement only (a choice that ships by the rule is adopted in a later step, with its tests
and the score calibration). Why ask: the ring block (``core.extrinsic.angular_spectrum``,
``ss11``'s heaviest, weight 4) measures, about the first and the third principal axis and in
three shells of distance from it, the power of ``k``-fold repetition in five octave bands
(``k`` 1-2, 3-5, 6-11, 12-23, 24-47). Which band holds the power is often what varies within
a kind: a kind of gear or sprocket comes in many tooth counts, a kind of flange in 4, 8 or
12 bolt holes, and a gear of 20 teeth and one of 30 put their teeth in different bands. The
twenty-fifth session's thickness study repeated the series' lesson: what carries over takes
a nuisance out (``ss10``, ``ss11``: the proportions) rather than adding detail. Sorting each
shell's five band powers, largest first, keeps how much the part repeats (and at which
strength the second, third... band) and forgets at which ``k``; the block's norm does not
change (a permutation), nor its invariance to rotation, translation, scale and point order.
What it gives up: a hex (``k`` 6) and a 24-tooth ring differ by band only.

The grid, written before any score of it was seen: ``ss11`` (the reference: the ring block
as it is), ``ring sorted`` (each axis' and shell's five bands sorted, largest first, in place
of the block) and ``ring both`` (the block and its sorted copy side by side, over the square
root of 2, so that the block's norm and weight stay): 3 candidates, at ``ss11``'s weights,
every one in the service's order (``reciprocal_blend_select.SERVICE_ORDER``), each source's
local words fitted on every other source. The sources: the nine of
``vocabulary_sources_select.py``, capod-nonrigid scored apart. The rule
(``evened_areas_select``'s): mAP per source, the mean over the nine, ties within 0.002 to the
reference, then the grid's order; leave-one-source-out with a paired bootstrap over queries
against ``ss11``. A candidate ships only if

1. its leave-one-source-out mean is above ``ss11``'s by more than 0.002 with the 95 %
   interval above zero;
2. the four third-party libraries as one catalogue by kind (``catalogue_by_kind.py``, one
   vocabulary fitted on the other sources): mAP not below ``ss11``'s, NN not below by more
   than 0.01;
3. on the seed-7 extraction (made in the twenty-fifth session and not scored by any step
   before this one), the choice fixed (``--confirm``): its mean over the nine above
   ``ss11``'s by more than 0.002 with the 95 % paired interval above zero, and test 2 there;
4. after adoption, BOSL2 (no choice saw it) through ``shapesearch eval`` in the service's
   order: mAP not below the release's, measured in the same session, by more than 0.002, NN
   not below by more than 0.01; scans of the tuning sources in scan mode reported.

Otherwise nothing changes. Reported whatever the verdict: every source's mAP and NN per
candidate.

    # the sources and the seed-0 extraction of vocabulary_sources_select.py (/work/study9)
    nice -n 5 .venv/bin/python bench/selection/ring_order_select.py /work/study9 \\
        --json /work/study9/ring_order.json
    nice -n 5 .venv/bin/python bench/selection/ring_order_select.py /work/seed7 \\
        --confirm "CHOICE" --json /work/seed7/ring_order.json
**Result** (2026-11-29, twenty-fifth session, a 2-core Intel Xeon; the seed-0 extraction of
the nine sources): declined. Mean of nine (mAP): ``ss11`` 0.8931, ``ring sorted`` 0.8945,
``ring both`` 0.8938: within the 0.002 tie, so the rule keeps ``ss11`` on the nine and
without every source, left out **+0.0000**; one catalogue by kind NN 0.874, mAP 0.719. The
gain in sample is our generator's (0.838 -> 0.848); FreeCAD +0.002, MCAD +0.001, bd-vslot
-0.001, and py-gearworks, whose gears the question was about, does not move (0.615). Tests 3
and 4 were not needed; the seed-7 extraction stays unscored.
"""

from __future__ import annotations

import functools
import os
import sys
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from evened_areas_rest_select import service_base  # noqa: E402
from evened_areas_select import catalogue_scores, close_study, service_scores  # noqa: E402
from hubness_select import pooled_local  # noqa: E402
from mcad_check import CATALOGUE  # noqa: E402
from profile_block_select import Replacing, study_command  # noqa: E402
from reciprocal_blend_select import SERVICE_ORDER  # noqa: E402
from vlad_idf_select import check_sources  # noqa: E402

from core.extrinsic import ANGULAR_BANDS, ANGULAR_SHELLS  # noqa: E402

REFERENCE = "ss11"
GRID = (REFERENCE, "ring sorted", "ring both")


def sorted_bands(rows: np.ndarray) -> np.ndarray:
    """Ring blocks ``(m, 2 * shells * bands)`` with each axis' and shell's band powers sorted,
    largest first (the same norm)."""
    shaped = rows.reshape(len(rows), 2, ANGULAR_SHELLS, len(ANGULAR_BANDS))
    return -np.sort(-shaped, axis=-1).reshape(len(rows), -1)


def candidate_ring(name: str, ring: dict[str, np.ndarray]) -> dict[str, np.ndarray] | None:
    """The ring block per source a candidate uses (``None``: the service's)."""
    if name == "ring sorted":
        return {source: sorted_bands(rows) for source, rows in ring.items()}
    if name == "ring both":
        return {source: np.hstack([rows, sorted_bands(rows)]) / np.sqrt(2.0)
                for source, rows in ring.items()}
    return None


def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(
        __doc__, argv, confirm="test 3: this candidate, fixed, against ss11")
    check_sources(study)
    replacing = Replacing(study, cache)
    base = service_base(study)
    names = [REFERENCE, args.confirm] if args.confirm else list(GRID)
    rings = {name: candidate_ring(name, replacing.ring) for name in names}
    table, queries = service_scores(
        study, ((name, replacing(base, ring=rings[name])) for name in names), SERVICE_ORDER)
    pooled = functools.cache(lambda: pooled_local(study, CATALOGUE))
    catalogue = {name: catalogue_scores(study, replacing, base, ring=rings[name],
                                        order=SERVICE_ORDER, local=pooled())
                 for name in names}
    close_study("the ring block's bands sorted, parts family", REFERENCE, table, queries,
                catalogue, [s.name for s in study.sources], args.confirm, args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
