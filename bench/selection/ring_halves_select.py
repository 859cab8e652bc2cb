"""Issue 24 follow-up: does what repeats around the axis, told *per end*, generalise?

Measurement only (the service's descriptor does not change in this step; a choice that
ships by the rule is adopted in a later step, with its tests and the score calibration).
Why, disclosed: the held-out set's worst kinds are screws of four head types and flanges
of three; ``ss6``'s ring block measures k-fold repetition about the symmetry axis in three
shells of distance from it, over the whole part. A socket head's hexagonal recess then
shares the innermost shell with the whole shank, and a hex head's flats share the outer
shell with the thread's end; a flange's bolt holes share a side with its hub. Telling the
two ends (about the first axis) or the two faces (about the third) apart keeps a head's
repetition from being diluted by the shank's lack of it.

The ``halves`` block (computed on the stored normalised sample): about each of the first
and the third area-weighted principal axes, the points split by the sign of their
coordinate along that axis (through the area-weighted centroid); per half,
``core.extrinsic.shell_spectrum`` (the ring block's three shells and five bands, the shells
the half's own area tertiles); the halves ordered by area, larger first, so that the axis'
arbitrary sign does not matter; 2 axes x 2 halves x 3 shells x 5 bands = 60 values over
sqrt(60), like the ring block (not unit norm). A half with fewer than three points gives
zeros. Invariant to rotation, translation, uniform scale and point order, like the ring.

The grid, written before any score of it was seen: ``ss6`` (the reference); ``ss6`` with the
ring block replaced by ``halves`` at weight {2, 4, 8}; ``ss6`` with ``halves`` added (the ring
kept at 4) at weight {1, 2, 4}. Seven candidates. The rule and the ship condition are the
ring study's (``bench/selection/profile_block_select.py``): mAP per source, mean over the seven
sources (capod-nonrigid scored apart), ties within 0.002 to the narrower vector,
leave-one-source-out with a paired bootstrap against ``ss6``; ship only if the LOSO mean is
above ``ss6``'s by more than 0.002 with the 95 % interval above zero. The block is extrinsic:
the ``bendable`` family would leave it out.

    nice -n 10 .venv/bin/python bench/selection/ring_halves_select.py /work/study \\
        --json /work/study/ring_halves.json
"""

from __future__ import annotations

import os
import sys
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
    study_command,
    study_samples,
)

from core.extrinsic import (  # noqa: E402
    ANGULAR_BANDS,
    ANGULAR_SHELLS,
    principal_frame,
    shell_spectrum,
)

REPLACE_WEIGHTS = (2.0, 4.0, 8.0)
ADD_WEIGHTS = (1.0, 2.0, 4.0)
SS6 = "ss6"


def halves_block(points: np.ndarray, areas: np.ndarray) -> np.ndarray:
    """The ring block's band powers per axial half, ``(60,) float`` (see the docstring).

    Parameters
    ----------
    points : (n, 3) float
    areas : (n,) float
    """
    coordinates, _, _ = principal_frame(points, areas)
    weights = areas / areas.sum()
    parts = []
    for along, (u, v) in ((0, (1, 2)), (2, (0, 1))):
        across = coordinates[:, u] - 1j * coordinates[:, v]
        halves = []
        for mask in (coordinates[:, along] >= 0, coordinates[:, along] < 0):
            spectrum = (shell_spectrum(across[mask], weights[mask])
                        if mask.sum() >= ANGULAR_SHELLS and weights[mask].sum() > 0
                        else np.zeros((ANGULAR_SHELLS, len(ANGULAR_BANDS))))
            halves.append((float(weights[mask].sum()), spectrum.ravel()))
        # Larger half first: the axis' sign is arbitrary, the halves' areas are not.
        halves.sort(key=lambda half: -half[0])
        parts.extend(spectrum for _, spectrum in halves)
    block = np.concatenate(parts)
    return block / np.sqrt(block.size)


def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(__doc__, argv)
    sources, scored = study.sources, study.scored
    rule_sources = tuple(s.name for s in sources)
    names = [s.name for s in scored]

    local = study.with_nonrigid(default_local_blocks(sources, cache))
    rings, timings = ring_blocks(study), []
    halves = study.with_nonrigid(blocks_per_source(study_samples(study), halves_block, timings))
    base = {s.name: np.hstack([s.bases["ss4-noprop"], local[s.name]]) for s in scored}

    # Candidate -> per source, the weighted extra blocks after ss5's (base and local).
    candidates = {SS6: {n: SS6_RING_WEIGHT * rings[n] for n in names}}
    for weight in REPLACE_WEIGHTS:
        candidates[f"halves w{weight:g} (no ring)"] = {n: weight * halves[n] for n in names}
    for weight in ADD_WEIGHTS:
        candidates[f"ss6 + halves w{weight:g}"] = {
            n: np.hstack([SS6_RING_WEIGHT * rings[n], weight * halves[n]]) for n in names}
    table, widths, queries = score_candidates(
        ((name, {s.name: joined(base[s.name], extra[s.name], 1.0) for s in scored})
         for name, extra in candidates.items()), scored)
    cost = float(np.median(timings))
    decide(table, queries, widths, "ring halves", rule_sources, SS6, args.json, widths=widths,
           extra={"cost_ms": cost})
    print(f"halves block, median ms per model: {cost:.2f} ({len(timings)} models)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
