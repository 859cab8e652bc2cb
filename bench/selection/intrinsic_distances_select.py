"""Issue 24 follow-up: distributions of intrinsic (biharmonic) distances, for both families.

Measurement first (a choice that ships by the rule is adopted in a later step, with its
tests and the score calibration). Why: every block of the default that sees the whole
shape's layout (D2, D1, normals, symmetry, ring, caps) is extrinsic and moves when a shape
bends, and the intrinsic blocks (HKS, WKS, slope, ShapeDNA, the local words) are
per-point or spectral. Nothing measures how the surface is laid out *along itself*. The
eigenpairs that the adaptive cutoff keeps already give that: the biharmonic distance
(Lipman, Rustamov and Funkhouser, ACM TOG 2010)

    d_B(x, y)^2 = sum_k (phi_k(x) - phi_k(y))^2 / lambda_k^2

is smooth, global, unchanged by bending (an isometry keeps every ``(lambda_k, phi_k)``),
unchanged by the sign of each eigenvector and by rotations inside an eigenspace, and its
``1 / lambda^2`` weights make the sum converge fast, so the cutoff ``n`` the method
chooses (../shared/docs/method.md) holds nearly all of it. Its distribution is the
intrinsic analogue of D2 (Osada et al. 2002; the GPS-distance distributions of Rustamov,
SGP 2007, with biharmonic weights).

The blocks of one model (computed from the study's cached eigenpairs: the first ``n``, ``n``
the adaptive cutoff's, as the service keeps them; eigenvalues at or below 1e-6 times the
``n``-th, one per connected piece, are left out):

- ``bD2``: the distances ``d_B`` of the D2 block's point pairs (``d2_pairs`` = 20000 pairs
  with ``d2_seed``, each end drawn by area) over their mean, histogrammed on D2's edges
  (0 to 3, 32 bins);
- ``bD1``: each point's ``d_B`` from the surface's biharmonic centroid (the origin of the
  embedding, as every ``phi_k``, k >= 1, has zero area-weighted mean) over the
  area-weighted mean, histogrammed by area on D1's edges (0 to 3, 32 bins);

each square-rooted and scaled to unit norm, as the D2 and D1 blocks are.

Before any score (``/tmp`` check on shapes made in code, three 3000-point samplings each,
200 eigenpairs; mean block distance between samplings): a tube bent by 90 and by 180
degrees stays 0.025-0.036 from the straight tube in ``bD2`` (its own samplings 0.027 apart)
and 0.017-0.063 in ``bD1`` (0.015), while the extrinsic D2 block moves 0.064 and 0.231;
a box of the tube's proportions is 0.099 / 0.075 away, a cone 0.33 / 0.69, a torus 0.61 /
1.19. About 30-40 ms per model for ``bD2`` at 200 eigenpairs.

The grid, written before any score of it was seen: blocks {``bD2``, ``bD1``, ``bD2`` and
``bD1`` joined} x weight {0.5, 1, 2}, 9 candidates in each family:

- **parts family**: each joins ``ss9``'s weighted blocks (as the service joins them, the
  whole scaled to unit norm once); ``ss9`` alone is the tenth candidate. The rule (the ring
  study's): mAP per source, capod-nonrigid scored apart; the choice is the best mean over
  the seven sources, ties within 0.002 to the narrower vector; leave-one-source-out with a
  paired bootstrap over queries against ``ss9``; ships only if the leave-one-source-out
  mean is above ``ss9``'s by more than 0.002 and the 95 % interval lies above zero.
- **bendable family** (issue 24's rule 4): each joins the ``bendable`` family's blocks (the
  spectral blocks and the idf word counts of HKS on 64 words at weight 2, each source's
  words fitted on the other sources); the family alone is the tenth candidate. The same
  rule on the non-rigid sources only (``bendable``, capod-nonrigid: leave-one-source-out is
  each chosen on the other one), against the family as it is; ships only if it passes the
  same condition there and its mean over the seven sources is not below the family's.

**Result: declined in both families** (2026-11-26, eighth session). Parts family: every
candidate's mean is below ``ss9``'s (0.8594; the best, ``bD1`` at 0.5, 0.8589), the rule
keeps ``ss9`` without every source, leave-one-source-out +0.0000. ``bD2`` and ``bD1`` do what
they are for on bent shapes (``bendable`` 0.976 -> 0.983 at weight 2) and cost the rigid
sources (pymadcad 0.887 -> 0.800, our generator 0.729 -> 0.656, bd-vslot 0.872 -> 0.801):
an intrinsic layout cannot tell parts apart that differ in how their surface sits in space.
Bendable family: the rule picks ``bD1`` at 2 on the two non-rigid sources (0.9607 against
0.9541) but without capod-nonrigid keeps the family as it is, leave-one-source-out +0.0003
(95 % -0.0003 .. +0.0012), and its mean over the seven sources drops 0.7900 -> 0.7684. 39 ms
per model (median, both blocks).

    nice -n 10 .venv/bin/python bench/selection/intrinsic_distances_select.py /work/study \\
        --json /work/study/intrinsic_distances.json
"""

from __future__ import annotations

import json
import os
import sys
import time
from collections.abc import Iterator
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from extraction_select import NON_RIGID_SOURCES, bendable_blocks  # noqa: E402
from local_features_select import Study, joined  # noqa: E402
from profile_block_select import (  # noqa: E402
    decide,
    score_candidates,
    ss9_blocks,
    study_command,
)

from core.descriptor import _unit_block, area_histograms  # noqa: E402
from core.evaluation.runner import sampling_of  # noqa: E402
from core.evaluation.scan_retrieval import ROTATION_SEED  # noqa: E402
from core.extrinsic import pair_distance_ratios  # noqa: E402
from core.settings import DescriptorSettings, EngineSettings  # noqa: E402

SS9 = "ss9"
BENDABLE = "bendable"
BLOCKS = ("bD2", "bD1", "bD2+bD1")
WEIGHTS = (0.5, 1.0, 2.0)
#: Eigenvalues at or below this share of the n-th are a connected piece's constant.
ZERO_SHARE = 1e-6


def biharmonic_embedding(eigenvalues: np.ndarray, eigenvectors: np.ndarray) -> np.ndarray:
    """Points in the biharmonic embedding, ``(n_points, k)``: ``phi_k / lambda_k`` for every
    eigenpair above the constant ones; Euclidean distance there is ``d_B``."""
    keep = eigenvalues > ZERO_SHARE * eigenvalues[-1]
    return eigenvectors[:, keep] / eigenvalues[keep]


def intrinsic_blocks(eigenvalues: np.ndarray, eigenvectors: np.ndarray, areas: np.ndarray,
                     settings: DescriptorSettings) -> dict[str, np.ndarray]:
    """The ``bD2`` and ``bD1`` unit blocks of one model, ``(32,)`` each.

    Parameters
    ----------
    eigenvalues : (n,) float
    eigenvectors : (n_points, n) float
        M-orthonormal, unit total area.
    areas : (n_points,) float
    settings : DescriptorSettings
        For D2's pairs, seed and edges and D1's edges.
    """
    embedding = biharmonic_embedding(eigenvalues, eigenvectors)
    d2_edges = np.linspace(*settings.d2_range, settings.bins + 1)
    d1_edges = np.linspace(*settings.d1_range, settings.bins + 1)
    pairs = pair_distance_ratios(embedding, areas, settings.d2_pairs, settings.d2_seed)
    d2 = area_histograms(pairs[:, None], np.ones(pairs.size), d2_edges)[0]
    weights = areas / areas.sum()
    eccentricity = np.linalg.norm(embedding, axis=1)
    mean = float(weights @ eccentricity)
    d1 = area_histograms((eccentricity / mean if mean > 0 else eccentricity)[:, None],
                         areas, d1_edges)[0]
    return {"bD2": _unit_block(np.sqrt(d2)), "bD1": _unit_block(np.sqrt(d1))}


def study_intrinsic_blocks(study: Study, cache: Path, timings: list[float]
                           ) -> dict[str, dict[str, np.ndarray]]:
    """``bD2``, ``bD1`` and the two joined for every model, per block and source
    (capod-nonrigid included), from the study's eigen cache and stored cutoffs."""
    settings = DescriptorSettings()
    # The study's sampling (local_features_extract's); a feature file is named by the
    # model's sha256[:24], which is all of it that the cache's name holds.
    sampling = sampling_of(EngineSettings(), ROTATION_SEED)
    per_block: dict[str, dict[str, np.ndarray]] = {name: {} for name in BLOCKS}
    for source, folder in zip(study.sources, study.folders, strict=True):
        rows: dict[str, list[np.ndarray]] = {"bD2": [], "bD1": []}
        for file in sorted(folder.glob("*.npz")):
            with np.load(file) as features:
                n = int(features["n"])
            with np.load(cache / sampling.cache_name(file.stem), allow_pickle=True) as store:
                values = store["eigenvalues"][:n]
                vectors = store["eigenvectors"][:, :n]
                areas = store["areas"]
            start = time.perf_counter()
            blocks = intrinsic_blocks(values, vectors, areas, settings)
            timings.append(1000.0 * (time.perf_counter() - start))
            for name, block in blocks.items():
                rows[name].append(block)
        per_block["bD2"][source.name] = np.array(rows["bD2"])
        per_block["bD1"][source.name] = np.array(rows["bD1"])
        per_block["bD2+bD1"][source.name] = np.hstack([per_block["bD2"][source.name],
                                                        per_block["bD1"][source.name]])
    return {name: study.with_nonrigid(rows_) for name, rows_ in per_block.items()}


def family_question(study: Study, raw: dict[str, np.ndarray],
                    blocks: dict[str, dict[str, np.ndarray]], reference: str,
                    sources: tuple[str, ...], title: str, json_path: Path | None
                    ) -> tuple[dict[str, object], dict[str, float]]:
    """One family's grid: ``reference`` (its weighted blocks ``raw`` per source) alone and
    with each block at each weight; the rule over ``sources``. Returns the rule's report and
    every candidate's mean over all seven sources."""
    scored = study.scored

    def candidates() -> Iterator[tuple[str, dict[str, np.ndarray]]]:
        yield reference, {s.name: joined(raw[s.name], None, 0.0) for s in scored}
        for weight in WEIGHTS:
            for name in BLOCKS:
                yield f"{reference} + {name} w{weight:g}", {
                    s.name: joined(raw[s.name], blocks[name][s.name], weight) for s in scored}

    table, widths, queries = score_candidates(candidates(), scored)
    report = decide(table, queries, widths, title, sources, reference, json_path,
                    widths=widths)
    everywhere = tuple(s.name for s in study.sources)
    overall = {c: float(np.mean([table[c][s]["map"] for s in everywhere])) for c in table}
    return report, overall


def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(__doc__, argv)
    timings: list[float] = []
    blocks = study_intrinsic_blocks(study, args.out / "cache", timings)
    print(f"blocks done, median {np.median(timings):.1f} ms per model", flush=True)

    rest, caps = ss9_blocks(study, cache)
    parts_raw = {name: np.hstack([rows, caps[name]]) for name, rows in rest.items()}
    parts_json = args.json.with_name(f"{args.json.stem}-parts.json") if args.json else None
    parts, _ = family_question(study, parts_raw, blocks, SS9,
                               tuple(s.name for s in study.sources),
                               "intrinsic distances, parts family", parts_json)

    bendable_raw = bendable_blocks(study, cache)
    bendable_json = (args.json.with_name(f"{args.json.stem}-bendable.json") if args.json
                     else None)
    bendable, overall = family_question(study, bendable_raw, blocks, BENDABLE,
                                        NON_RIGID_SOURCES,
                                        "intrinsic distances, bendable family", bendable_json)
    chosen = str(bendable["chosen"])
    kept = bool(bendable["ships"]) and overall[chosen] >= overall[BENDABLE]
    print(f"bendable family: choice {chosen}, mean over the seven {overall[chosen]:.4f} "
          f"against {overall[BENDABLE]:.4f}; ships: {kept}")
    if args.json:
        args.json.write_text(json.dumps({
            "parts": {"chosen": parts["chosen"], "ships": parts["ships"]},
            "bendable": {"chosen": chosen, "ships": kept, "overall": overall},
            "cost_ms": float(np.median(timings))}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
