"""Issue 24 follow-up: do the D2 and D1 blocks of ``ss6`` cost kinds that come in many lengths?

Measurement only (nothing under ``core/``, ``app/`` or ``tests/`` changes). Why, disclosed: on
pymadcad's screws (a tuning source) ``spectral`` + normals + symmetry + the local block scores
button, hex and socket heads 0.83 / 0.96 / 0.82 mAP against ``ss6``'s 0.65 / 0.76 / 0.69, and
the blocks in between are D2 and D1 (``core.extrinsic``): their histograms, over their mean,
follow a part's length-to-diameter ratio, so one kind of screw in many lengths spreads out. The
earlier selector (``bench/selection/local_features_select.py``) tried bases with both or neither.

The grid, written before any score of it was seen: ``ss6`` as the service builds it (the
``ss4-noprop`` blocks, the VLAD block of ``hks+sv`` at 64 words and weight 1, each source
encoded by a vocabulary fitted on the other sources, and the ring block at weight 4) with the
D2 weight and the D1 weight each scaled by {0, 0.5, 1}: nine candidates, ``ss6`` is (1, 1).

The rule (``bench/selection/profile_block_select.py``'s): mAP per source, leave-one-out within it;
the mean over the rule's sources (every source of the study; capod-nonrigid is scored apart), ties
within 0.002 to the narrower vector; leave-one-source-out with a paired bootstrap over queries
against ``ss6``; ship only if the LOSO mean is above ``ss6``'s by more than 0.002 and the 95 %
interval lies above zero.

    nice -n 10 .venv/bin/python bench/selection/proportion_blocks_select.py /work/study \\
        --json /work/study/proportion.json
"""

from __future__ import annotations

import argparse
import itertools
import os
import sys
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from local_features_select import BASES, joined, load_study  # noqa: E402
from profile_block_select import (  # noqa: E402
    SS6_RING_WEIGHT,
    decide,
    default_local_blocks,
    ring_blocks,
    score_candidates,
)

SCALES = (0.0, 0.5, 1.0)
SS6 = "ss6 (d2 x1, d1 x1)"


def base_rows(folder: Path, scales: dict[str, float],
              made: Callable[[Mapping[str, np.ndarray]], dict[str, np.ndarray]] | None = None
              ) -> np.ndarray:
    """The ``ss4-noprop`` weighted blocks of every model in ``folder`` ``(m, d)``, each
    block's weight scaled by ``scales[block]`` (1 if absent; a block at 0 is left out).
    ``made``: blocks made afresh from a model's stored features, in place of its stored
    ones (``histogram_bins_select.recomputed_rows``)."""
    weights = {key: value * scales.get(key, 1.0) for key, value in BASES["ss4-noprop"].items()}
    rows = []
    for path in sorted(folder.glob("*.npz")):
        with np.load(path) as data:
            blocks = {key: data[f"blocks_{key}"] for key in weights if weights[key] > 0}
            if made is not None:
                blocks.update(made(data))
            rows.append(np.concatenate([weights[key] * blocks[key]
                                        for key in weights if weights[key] > 0]))
    return np.array(rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--kind", default="clean")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    study = load_study(args.out / "features" / args.kind)
    cache = args.out / "profile_cache" / args.kind  # shared with profile_block_select
    cache.mkdir(parents=True, exist_ok=True)
    sources, scored, folders = study.sources, study.scored, study.folders
    rule_sources = tuple(s.name for s in sources)

    local = study.with_nonrigid(default_local_blocks(sources, cache))
    rings = ring_blocks(study)

    def candidates() -> Iterator[tuple[str, dict[str, np.ndarray]]]:
        for d2, d1 in itertools.product(SCALES, SCALES):
            name = SS6 if (d2, d1) == (1.0, 1.0) else f"ss6 (d2 x{d2:g}, d1 x{d1:g})"
            bases = study.with_nonrigid({source.name: base_rows(path, {"d2": d2, "d1": d1})
                                         for source, path in zip(sources, folders, strict=True)})
            yield name, {s.name: joined(np.hstack([bases[s.name], local[s.name]]),
                                        rings[s.name], SS6_RING_WEIGHT) for s in scored}

    table, widths, queries = score_candidates(candidates(), scored)
    decide(table, queries, widths, "D2 and D1 scales", rule_sources, SS6, args.json,
           widths=widths, by_mean=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
