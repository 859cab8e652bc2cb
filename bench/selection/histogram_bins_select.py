"""Issue 24 follow-up: does the histograms' bin count, chosen on capod, hold on other sources?

Measurement only (the service's descriptor does not change in this step; a choice that
ships by the rule is adopted in a later step, with its tests and the score calibration).
Why, disclosed: written after the heat-kernel times held (``bench/selection/extraction_select.py``,
question 4), as the next setting of the descriptor chosen on capod alone (issue 4): the
``bins`` of the HKS, WKS, WKS-slope, D2 and D1 histograms (32). Fewer bins pool more, more
bins resolve a small share of the surface that sits at other signature values.

The ``parts`` family's vectors as ``ss6`` joins them, the five binned blocks recomputed from
each model's stored features (signature, areas, eigenvalues, points, as
``bench/selection/local_features_extract.py`` saved them) by ``DescriptorSpec`` with ``bins``
changed, every other block as stored; the local block (each source encoded by words fitted on the
other sources) and the ring block at weight 4 as the service joins them. The 32-bin
reference is recomputed the same way (the stored signature is float32), so every candidate
is made alike; its mean is printed next to the stored ``ss6``'s as a check.

The grid, written before any score of it was seen: ``bins`` in {32 (the service's), 16, 64},
ties in that order. The rule and the ship condition are the ring study's
(``bench/selection/profile_block_select.py``): mAP per source, mean over the seven sources
(capod-nonrigid scored apart), leave-one-source-out with a paired bootstrap against 32; ship
only if the LOSO mean is above 32's by more than 0.002 with the 95 % interval above zero and
``bench/descriptor_cost.py`` finds it within 1.5x of ``ss4``. The ``bendable`` family is not
part of this question (it would keep 32 whatever this finds, until asked by its own rule).

    nice -n 10 .venv/bin/python bench/selection/histogram_bins_select.py /work/study \\
        --json /work/study/bins.json
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator, Mapping
from dataclasses import replace
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from local_features_select import Study, joined  # noqa: E402
from profile_block_select import (  # noqa: E402
    SS6_RING_WEIGHT,
    decide,
    default_local_blocks,
    ring_blocks,
    score_candidates,
    ss6_rows,
    study_command,
)
from proportion_blocks_select import base_rows  # noqa: E402

from core.descriptor import BLOCK_WEIGHTS, DescriptorSpec  # noqa: E402
from core.settings import DescriptorSettings  # noqa: E402

BINS = (32, 16, 64)
BINNED = ("hks", "wks", "slope", "d2", "d1")


def recomputed_spec(blocks: tuple[str, ...], **change: object) -> DescriptorSpec:
    """The spec that makes ``blocks``, each at weight 1, and nothing else, with the
    descriptor settings ``change``d."""
    weights = {field: 1.0 if block in blocks else 0.0
               for block, field in BLOCK_WEIGHTS.items()}
    return DescriptorSpec.from_settings(replace(DescriptorSettings(), **weights, **change))


def recomputed_rows(folder: Path, cache: Path, blocks: tuple[str, ...], **change: object
                    ) -> np.ndarray:
    """``proportion_blocks_select.base_rows`` of ``folder`` with ``blocks`` recomputed
    from each model's stored features under the settings ``change``; cached per source and
    change."""
    tag = "-".join(f"{name}-{value}" for name, value in sorted(change.items()))
    path = cache / f"{tag}-{folder.name}.npy"
    if not path.exists():
        spec = recomputed_spec(blocks, **change)

        def made(data: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
            return spec.blocks(data["signature"].astype(np.float64), data["areas"],
                               data["eigenvalues"], data["points"].astype(np.float64))

        np.save(path, base_rows(folder, {}, made))
    return np.load(path)


def ss6_recomputed(study: Study, cache: Path, local: dict[str, np.ndarray],
                   rings: dict[str, np.ndarray], blocks: tuple[str, ...],
                   changes: dict[str, dict[str, object]]
                   ) -> Iterator[tuple[str, dict[str, np.ndarray]]]:
    """Per candidate (``changes``: its name -> its settings change of ``blocks``), the
    ``ss6`` rows of every scored source of ``study`` with ``blocks`` recomputed: the local
    block ``local`` and the ring block ``rings`` joined as the service joins them."""
    for name, change in changes.items():
        bases = study.with_nonrigid({
            source.name: recomputed_rows(path, cache, blocks, **change)
            for source, path in zip(study.sources, study.folders, strict=True)})
        yield name, {s.name: joined(np.hstack([bases[s.name], local[s.name]]), rings[s.name],
                                    SS6_RING_WEIGHT) for s in study.scored}


def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(__doc__, argv)
    sources, scored = study.sources, study.scored
    rule_sources = tuple(s.name for s in sources)
    local = study.with_nonrigid(default_local_blocks(sources, cache))
    rings = ring_blocks(study)
    changes = {f"bins {bins}": {"bins": bins} for bins in BINS}
    table, widths, queries = score_candidates(
        ss6_recomputed(study, cache, local, rings, BINNED, changes), scored)
    order = {name: rank for rank, name in enumerate(table)}
    stored, _, _ = score_candidates(
        [("ss6 (stored blocks)", {s.name: ss6_rows(s, local[s.name], rings[s.name])
                                  for s in scored})], scored)
    stored_mean = float(np.mean([stored["ss6 (stored blocks)"][s]["map"] for s in rule_sources]))
    print(f"check: ss6 from the stored blocks, mean {stored_mean:.4f}")
    decide(table, queries, order, "histogram bins", rule_sources, "bins 32", args.json,
           tie_key="order", widths=widths)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
