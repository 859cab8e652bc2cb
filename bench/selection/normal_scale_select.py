"""Issue 24 follow-up: the normals block's neighbourhood, chosen on capod, asked on the sources.

Measurement only (the service's descriptor does not change in this step; a choice that
ships by the rule is adopted in a later step, with its tests, the scan tables and the score
calibration). Why, disclosed: the per-block diagnostic behind the query-adaptive fusion
(``bench/selection/adaptive_fusion_select.py``) found that no block tells py-gearworks' spur,
helical and herringbone gears apart (each of the three near 0.3 mAP with every block alone, the
normals block included), although a helical gear's tooth flanks lean against its axis by
``|cos| ~ sin(helix angle)`` and a spur gear's do not. The normals block
(``normal_weight`` 0.5) histograms the ``|cos|`` between each point's normal and the
principal axes, the normal taken by local PCA of its ``normal_neighbours`` (12) nearest
points, a setting chosen on capod alone and never asked on the sources. Checked before any
score, on a toothed cylinder made in code (3000 points on its side surface, the normal known
analytically; no tuning model, no label): the median normal error at 30 teeth is 9.0 degrees
with 6 neighbours, 15.3 with 8, 20.1 with 12, 22.8 with 16 (helix 0.35 rad: 12.8, 18.3, 23.0,
25.0); at 12 teeth all are within 2.2-2.8 degrees; at 48 teeth no choice resolves the teeth
(38-56 degrees). Fewer neighbours see small features (teeth, threads, a head's socket)
sharper and are noisier on smooth or scanned surfaces; a heavier block would let a sharper
one count for more.

The ``ss9`` vectors with the ``normals`` block recomputed from each model's stored sample
(``points``, ``areas``) by ``DescriptorSpec`` with ``normal_neighbours`` changed, at weight
``normal_weight`` in place of 0.5; every other block as ``ss9`` joins it (the stored blocks,
the local block encoded on words fitted without the source, the ring block at weight 4, the
caps block with soft axes and the ring block's soft shells). A check before scoring: the
recomputed block at 12 neighbours must be the stored one (else stop). Disclosed: written first
as "no entry more than 1e-6 apart", that check stopped the first run before any score: 14 of
735 models differ by up to 1.2e-3, because the study stores the points in float32 (a nearest
neighbour swaps places in a tie); it now asks that no entry be more than 2e-3 apart and at
most 3 % of the models differ, and every candidate, ``ss9`` included, uses the recomputed
block, so all eight are built the same way.

The grid, written before any score of it was seen: ``normal_neighbours`` in {12, 8, 6, 16}
x ``normal_weight`` in {0.5, 1.0}: 8 candidates, ``ss9`` (12, 0.5) first, ties within 0.002
broken in the order (12, 0.5), (8, 0.5), (6, 0.5), (16, 0.5), (12, 1), (8, 1), (6, 1),
(16, 1): the service's, then its neighbourhood before its weight, nearer to 12 first. The
rule and the ship condition are the ring study's (``bench/selection/profile_block_select.py``): mAP
per source, leave-one-out within each source, mean over the seven sources (capod-nonrigid
scored apart), leave-one-source-out with a paired bootstrap against ``ss9``; ship only if
the LOSO mean is above ``ss9``'s by more than 0.002 with the 95 % interval above zero.
Adoption would also need the scan-mode tables (merged and single-view scans, where the
noise that small neighbourhoods see is largest) not to fall by more than 0.01 mAP on any
source; they are measured only if the rule ships a choice.

    nice -n 10 .venv/bin/python bench/selection/normal_scale_select.py /work/study \\
        --json /work/study/normal_scale.json
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from local_features_select import Study  # noqa: E402
from profile_block_select import (  # noqa: E402
    check_recomputed,
    decide,
    score_candidates,
    ss9_replacing,
    study_command,
)

from core.descriptor import DescriptorSpec  # noqa: E402
from core.settings import DescriptorSettings  # noqa: E402

SS9 = "ss9"
SS9_NEIGHBOURS = DescriptorSettings().normal_neighbours
SS9_WEIGHT = DescriptorSettings().normal_weight
#: (neighbours, weight) in the tie order, the service's first.
GRID = ((12, 0.5), (8, 0.5), (6, 0.5), (16, 0.5), (12, 1.0), (8, 1.0), (6, 1.0), (16, 1.0))


def candidate_name(neighbours: int, weight: float) -> str:
    if (neighbours, weight) == (SS9_NEIGHBOURS, SS9_WEIGHT):
        return SS9
    return f"normals k{neighbours} w{weight:g}"


def normals_blocks(study: Study, neighbours: int) -> dict[str, np.ndarray]:
    """The unit ``normals`` block of every model at ``neighbours``, per source, ``(m, 30)``."""
    off = dict.fromkeys(DescriptorSettings.WEIGHTS, 0.0)
    settings = replace(DescriptorSettings(), **{**off, "normal_weight": 1.0,
                                                "normal_neighbours": neighbours})
    spec = DescriptorSpec.from_settings(settings)
    blocks: dict[str, np.ndarray] = {}
    for source, folder in zip(study.sources, study.folders, strict=True):
        models = []
        for file in sorted(folder.glob("*.npz")):
            with np.load(file) as data:
                points = data["points"].astype(np.float64)
                areas = data["areas"].astype(np.float64)
                models.append(spec.blocks(np.zeros((len(points), 0)), areas, np.zeros(0),
                                          points)["normals"])
        blocks[source.name] = np.array(models)
    return study.with_nonrigid(blocks)


def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(__doc__, argv)
    neighbourhoods = sorted({neighbours for neighbours, _ in GRID})
    normals = {k: normals_blocks(study, k) for k in neighbourhoods}
    check_recomputed(study, "normals", normals[SS9_NEIGHBOURS])
    rows = ss9_replacing(study, cache, "normals")

    def candidates() -> Iterator[tuple[str, dict[str, np.ndarray]]]:
        for neighbours, weight in GRID:
            yield candidate_name(neighbours, weight), rows(normals[neighbours], weight)

    table, widths, queries = score_candidates(candidates(), study.scored)
    order = {candidate_name(*cell): rank for rank, cell in enumerate(GRID)}
    decide(table, queries, order, "normals neighbourhood", tuple(s.name for s in study.sources),
           SS9, args.json, tie_key="tie order", widths=widths)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
