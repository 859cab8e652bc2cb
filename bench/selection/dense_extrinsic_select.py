"""Issue 24 follow-up: do the extrinsic blocks carry over better measured on a dense sample?

Measurement only (the service's descriptor does not change in this step). Why, disclosed:
written after the twist study (``twist_block_select.py``, both rounds declined) and the
catalogue by kind (``catalogue_by_kind.py``): among the third-party libraries' first
answers, what is still wrong is kinds that differ by a detail the 3000 points of the
Laplacian's sample do not resolve: MCAD's blocks against its rounded boxes (the rounded
edges), gears' teeth. The spectral blocks need the Laplacian and its 3000 points; the
extrinsic blocks (D2, D1, the normals, symmetry, ring and caps blocks of ``ss9``) only need
where the surface is and how it faces, which is cheap to sample densely. At 3000 points the
normals block's 12 neighbours span a patch that rounds every edge; at 30000 they resolve a
sharp edge from a rounded one.

Candidates, bounded by the issue's cost limit (ingest at most 1.5x ``ss4``'s; ``ss9`` is
1.10x): the extrinsic blocks cost 0.095 s per model at 3000 points, 0.29 s at 8000, 0.45 s
at 12000 and 1.3 s at 30000, nine tenths of it the caps block's soft axes (measured on
random points before this grid was written). ``ss9`` (the reference), and ``ss9`` with its
extrinsic blocks measured by the service's own code (``DescriptorSpec._extrinsic_blocks`` at
the default settings) on a dense sample of the same mesh (``core.io.load_points`` with the
service's seed; every point the same area), the spectral and local blocks as stored:

- ``extrinsic on 8000``: every extrinsic block on 8000 points (about +0.19 s per model);
- ``extrinsic but caps on 12000``: D2, D1, the normals, symmetry and ring blocks on 12000
  points, the caps block on the Laplacian's 3000 as now (about +0.13 s).

3 candidates. A check before scoring: the same code on the study's stored 3000-point samples
must give back ``ss9``'s stored rows (as ``profile_block_select.check_recomputed`` asks). The
rule and the ship condition are the ring study's (mAP per source, mean over the eight
sources, capod-nonrigid scored apart, ties within 0.002 to the narrower vector, then the
grid's order, ``ss9`` first; leave-one-source-out with a paired bootstrap against ``ss9``;
ship only if above it by more than 0.002 with the 95 % interval above zero). The blocks are
extrinsic: the ``bendable`` family has none. Reported beside: the one catalogue by kind, and
the cost per model (sampling and the blocks).

    nice -n 10 .venv/bin/python bench/selection/dense_extrinsic_select.py /work/study8 \\
        --models /work/tuning /work/tuning-mcad --json /work/study8/dense_extrinsic.json

**Result** (2026-11-27, twelfth session; docs/results.md, "The extrinsic blocks on a dense
sample"): declined. The check passed (largest cosine difference 6.8e-06). Over the eight
the rule picks ``extrinsic on 8000`` (0.8407 against 0.8376), but only because of MCAD
(0.673 -> 0.697); without MCAD it keeps ``ss9``, so leave-one-source-out is +0.0001 (95 %
-0.0016 .. +0.0019). Bent shapes lose (0.981 -> 0.973), as do py-gearworks (0.587 -> 0.581)
and capod-nonrigid. The one catalogue by kind in the service's order: NN 0.850 -> 0.859, mAP
0.663 -> 0.672 (reported, not a test). 113 ms (8000) and 148 ms (12000 without caps) per
model, median, sampling and blocks.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from catalogue_by_kind import KIND_OF, print_orders  # noqa: E402
from hubness_select import pooled_labels, pooled_local, pooled_rows  # noqa: E402
from local_features_select import Study, joined  # noqa: E402
from mcad_check import CATALOGUE  # noqa: E402
from profile_block_select import (  # noqa: E402
    decide,
    default_local_blocks,
    score_candidates,
    ss9_blocks,
    study_command,
    study_samples,
)
from twist_block_select import model_paths  # noqa: E402

from core.descriptor import DescriptorSpec  # noqa: E402
from core.io import load_points  # noqa: E402
from core.settings import DescriptorSettings, EngineSettings  # noqa: E402

SS9 = "ss9"
ALL_DENSE = 8000
BUT_CAPS_DENSE = 12000
SPECTRAL_BLOCKS = ("hks", "wks", "slope", "dna")


def extrinsic_blocks(spec: DescriptorSpec, points: np.ndarray, areas: np.ndarray
                     ) -> dict[str, np.ndarray]:
    """Every weighted extrinsic block of one sample, in the service's order."""
    return spec._extrinsic_blocks(points, areas, len(points))


def extrinsic_row(spec: DescriptorSpec, points: np.ndarray, areas: np.ndarray) -> np.ndarray:
    """Every weighted extrinsic block of one sample, joined in the service's order."""
    return np.concatenate(list(extrinsic_blocks(spec, points, areas).values()))


def spectral_rows(study: Study) -> dict[str, np.ndarray]:
    """Each model's stored spectral blocks at ``ss9``'s weights, ``(m, 1534)`` per source."""
    settings = DescriptorSettings()
    weights = {"hks": settings.hks_weight, "wks": settings.wks_weight,
               "slope": settings.wks_slope_weight, "dna": settings.dna_weight}
    rows = {}
    for source, folder in zip(study.sources, study.folders, strict=True):
        models = []
        for file in sorted(folder.glob("*.npz")):
            with np.load(file) as stored:
                models.append(np.concatenate([weights[key] * stored[f"blocks_{key}"]
                                              for key in SPECTRAL_BLOCKS]))
        rows[source.name] = np.array(models)
    return study.with_nonrigid(rows)


def dense_extrinsic(study: Study, roots: list[Path], count: int, cache: Path,
                    without_caps: bool = False) -> tuple[dict[str, np.ndarray], list[float]]:
    """Every model's extrinsic blocks joined (``without_caps``: all but the caps block) on a
    dense sample of ``count`` points, per source (capod-nonrigid included), cached; and the
    milliseconds per model (sampling and blocks)."""
    settings = EngineSettings()
    descriptor = settings.descriptor
    if without_caps:
        descriptor = replace(descriptor, caps_weight=0.0)
    spec = DescriptorSpec.from_settings(descriptor)
    rows: dict[str, np.ndarray] = {}
    spent: list[float] = []
    for source, folder in zip(study.sources, study.folders, strict=True):
        name = f"dense-extrinsic-{count}{'-nocaps' if without_caps else ''}-{source.name}"
        path = cache / f"{name}.npz"
        if not path.exists():
            models = model_paths(roots, source.name)
            blocks, timings = [], []
            for file in sorted(folder.glob("*.npz")):
                started = time.perf_counter()
                points = load_points(models[file.stem], max_points=count,
                                     seed=settings.sample_seed).points
                blocks.append(extrinsic_row(spec, points, np.ones(len(points))))
                timings.append(1000.0 * (time.perf_counter() - started))
            np.savez(path, blocks=np.array(blocks), ms=np.array(timings))
        with np.load(path) as stored:
            rows[source.name] = stored["blocks"]
            spent += stored["ms"].tolist()
        print(f"  {name} done", flush=True)
    return study.with_nonrigid(rows), spent


def check_reproduced(study: Study, spectral: dict[str, np.ndarray], local: dict[str, np.ndarray],
                     raw: dict[str, np.ndarray], caps: dict[str, np.ndarray]) -> None:
    """Stop unless the service's code on the stored samples gives back ``ss9``'s rows: the
    same cosines between every two models of a source (the columns are in another order)."""
    spec = DescriptorSpec.from_settings(DescriptorSettings())
    samples = study_samples(study)
    worst = 0.0
    for source in study.sources:
        extrinsic = np.array([extrinsic_row(spec, p, a) for p, a in samples[source.name]])
        mine = joined(np.hstack([spectral[source.name], extrinsic, local[source.name]]),
                      None, 0.0)
        theirs = joined(np.hstack([raw[source.name], caps[source.name]]), None, 0.0)
        worst = max(worst, float(np.abs(mine @ mine.T - theirs @ theirs.T).max()))
    print(f"ss9 recomputed from its blocks vs the study's: largest cosine difference "
          f"{worst:.2e}", flush=True)
    if worst > 1e-3:
        raise SystemExit("the recomputed ss9 rows are not the study's: stop before scoring")


def catalogue_rows(study: Study, spectral: dict[str, np.ndarray],
                   extrinsic: dict[str, np.ndarray]) -> np.ndarray:
    """The one catalogue's unit rows with ``extrinsic`` blocks, its local block encoded by
    one vocabulary fitted on the other sources (``pooled_local``), in its order."""
    local = pooled_local(study, CATALOGUE)
    return np.vstack([joined(np.hstack([spectral[name], extrinsic[name], local[name]]), None,
                             0.0) for name in CATALOGUE])


def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(__doc__, argv, models=True)
    scored = study.scored
    spectral = spectral_rows(study)
    local = study.with_nonrigid(default_local_blocks(study.sources, cache))
    raw, caps = ss9_blocks(study, cache)
    check_reproduced(study, spectral, local, raw, caps)
    dense = {}
    for label, count, without_caps in (("extrinsic on 8000", ALL_DENSE, False),
                                       ("extrinsic but caps on 12000", BUT_CAPS_DENSE, True)):
        blocks, spent = dense_extrinsic(study, args.models, count, cache, without_caps)
        dense[label] = {name: np.hstack([rows, caps[name]]) if without_caps else rows
                        for name, rows in blocks.items()}
        print(f"{label}: median {np.median(spent):.0f} ms per model", flush=True)

    def candidates() -> Iterator[tuple[str, dict[str, np.ndarray]]]:
        yield SS9, {s.name: joined(raw[s.name], caps[s.name], 1.0) for s in scored}
        for label, blocks in dense.items():
            yield label, {
                s.name: joined(np.hstack([spectral[s.name], blocks[s.name], local[s.name]]),
                               None, 0.0) for s in scored}

    table, widths, queries = score_candidates(candidates(), scored)
    order = {name: rank for rank, name in enumerate(table)}
    tie = {name: (widths[name], order[name]) for name in table}
    report = decide(table, queries, tie, "extrinsic blocks on a dense sample",
                    tuple(s.name for s in study.sources), SS9, args.json,
                    tie_key="width, grid order", widths=widths)
    chosen = str(report["chosen"])
    kinds = [KIND_OF.get(label, label) for label in pooled_labels(study, CATALOGUE)]
    catalogues = {SS9: pooled_rows(study, CATALOGUE)[0]}
    if chosen != SS9:
        catalogues[chosen] = catalogue_rows(study, spectral, dense[chosen])
    for name, vectors in catalogues.items():
        print_orders(name, vectors, kinds)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
