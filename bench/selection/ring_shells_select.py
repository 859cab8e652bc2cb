"""Issue 24 follow-up: the ring block's shells, soft instead of area tertiles.

Measurement first (a choice that ships by the rule is adopted in a later step, with its
tests and the score calibration). Why, disclosed (found while checking, before any score,
whether the ring block needed the caps block's soft axes): ``ss8``'s ring block splits the
points about each axis into the area tertiles of their distance from it, and a wall whose
points all lie at one distance (a shaft's, a cylinder's: most of a turned part) is cut by a
tertile; which of its points fall on which side then follows the axis' sampling noise, and
the cut's side is lopsided, so ``k`` = 1 and 2 jump. Four samplings of a plain cylinder at
3000 points, rotated, lay up to 0.347 apart in the spectrum (norm 1.37). Soft shells: a
point at distance ``r`` from the axis, over the area-weighted median distance, belongs to
the three shells by linear interpolation between three centres (all to the first below the
first centre, to the last beyond the last), so membership changes continuously with ``r``:
the cylinder's samplings then lay 0.23 apart, a cube's 0.26-0.27 (0.33); a disc's, an
annulus', a square plate's and a bar's spreads (0.08-0.11) moved by under 0.025
(``core.extrinsic.shell_spectrum``).

The pool, written before any score of it was seen: ``ss8`` (the default: ``ss6``'s blocks
with the ring block at weight 4 and the caps block with soft axes, ``s`` 4096, weight 1) and
``ss8`` with the ring block's shells soft at centres (0.5, 1, 1.5) or (0.25, 1, 1.75):
3 candidates, one width. The rule is the ring study's (mean mAP over the seven sources,
capod-nonrigid scored apart, leave-one-source-out with a paired bootstrap against ``ss8``),
with the tie order of the caps block's round 3: within 0.002 the soft shells first, (0.5, 1,
1.5) before (0.25, 1, 1.75), ``ss8`` last, because soft shells do not jump with the sampling.
They ship only if (1) the rule's choice over the seven sources is a soft-shell candidate,
(2) its leave-one-source-out mean against ``ss8``'s has a 95 % bootstrap interval whose lower
end is above -0.005, and (3) the lowest cosine between two copies of one mesh in the
``parts`` source is higher than ``ss8``'s.

    nice -n 10 .venv/bin/python bench/selection/ring_shells_select.py /work/study \\
        --json /work/study/ring_shells.json

**Round 1's result, and why it was not adopted (disclosed).** With each soft shell's
coefficients over the shell's own mass, the rule chose centres (0.5, 1, 1.5): LOSO +0.0000
against ``ss8`` (95 % -0.0008 .. +0.0009), copies' lowest cosine 0.9332 against 0.9287: the
three conditions held (the code as run: commit 3c3c85d). Adopting it, the analytic test of
a hexagon of points at the median distance failed: a shell holding 2e-16 of the area gave
coefficients of 1. Over its own mass a nearly empty shell counts as a whole one: the sliver
of a cylinder's wall just beyond the middle centre, lopsided by the axis' noise, keeps the
jumps the soft shells were meant to remove (the cylinder's samplings: 0.23 apart, not less).

**Round 2, written after round 1's result and before any score of it (disclosed as such).**
A soft shell's coefficients over its mass or a third of the whole, whichever is larger (a
tertile's mass, so nothing changes for a shell that holds a third or more): before any
score, four samplings of a plain cylinder lay 0.065 apart at centres (0.5, 1, 1.5) and 0.051
at (0.25, 1, 1.75) (tertiles 0.347), a cube's 0.18 and 0.13 (0.33), a disc's, an annulus', a
square plate's and a bar's 0.06-0.11 (0.08-0.11). Same pool, rule, tie order and ship
conditions as round 1.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterable
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
    default_local_blocks,
    lowest_copy_cosine,
    score_candidates,
    stabilisation_decision,
    study_command,
    study_samples,
)

from core.descriptor import caps_block, ring_block  # noqa: E402

SS8 = "ss8"
CAPS_SHARPNESS = 4096.0
CENTRES = ((0.5, 1.0, 1.5), (0.25, 1.0, 1.75))


def label(centres: tuple[float, float, float]) -> str:
    return "ss8, ring shells soft " + "-".join(f"{c:g}" for c in centres)


def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(__doc__, argv)
    scored = study.scored
    local = study.with_nonrigid(default_local_blocks(study.sources, cache))
    samples = study_samples(study)
    caps = study.with_nonrigid(blocks_per_source(
        samples, partial(caps_block, bins=6, depth=1.0, sharpness=CAPS_SHARPNESS), []))
    timings: dict[str, list[float]] = {SS8: []}
    rings = {SS8: study.with_nonrigid(blocks_per_source(samples, ring_block, timings[SS8]))}
    for centres in CENTRES:
        timings[label(centres)] = []
        rings[label(centres)] = study.with_nonrigid(blocks_per_source(
            samples, partial(ring_block, shell_centres=centres), timings[label(centres)]))
    print("blocks done", flush=True)
    labels = next(s.labels for s in scored if s.name == "parts")
    copies: dict[str, float] = {}

    def candidates() -> Iterable[tuple[str, dict[str, np.ndarray]]]:
        for name, ring in rings.items():
            rows = {s.name: joined(np.hstack([s.bases["ss4-noprop"], local[s.name],
                                              SS6_RING_WEIGHT * ring[s.name]]), caps[s.name], 1.0)
                    for s in scored}
            copies[name] = lowest_copy_cosine(rows["parts"], np.asarray(labels))
            yield name, rows

    table, widths, queries = score_candidates(candidates(), scored)
    stabilisation_decision(table, widths, queries, [label(centres) for centres in CENTRES], SS8,
                           copies, timings, "ring shells",
                           tuple(s.name for s in study.sources), args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
