"""Issue 24 follow-up: how far does a part's tessellation move its descriptor? (a report)

Why: OpenSCAD renders curved surfaces with as many facets as ``$fa`` and ``$fs`` allow, and
MCAD's parts come at its defaults (``$fa`` 12, ``$fs`` 2): an M3 bolt's shank is a five-sided
prism, an M16's a 25-sided one. STL exports from CAD systems vary as much. The sampler is
uniform in area, so the spectrum hardly sees flat facets, but the normals block counts their
directions and the ring block their repetition about the axis. If the facets move a part
further than the gap to another kind, a catalogue whose parts come from several exporters
sorts them by exporter too.

This script renders MCAD's 88 parts twice (``core.evaluation.sources.mcad_parts``): as the
library renders them by default, and finely (``FINE``: ``$fa`` 3, ``$fs`` 0.25; the tubes'
and rounded boxes' own ``$fn`` still win, so those two kinds are a control: the same vertices,
triangulated differently, which moves only the sample drawn from them). It describes each
with the shipped default (``core.pipeline.describe``) and reports

1. per kind: the median cosine distance between a part's two renderings, and the median
   distance from the coarse part to the nearest coarse part of another kind;
2. the same per block (``DescriptorSpec.blocks``, each at unit norm): which blocks the
   facets move, as the median of (twin distance / distance to the nearest other kind);
3. retrieval by kind, leave-one-out, plain cosine: the coarse renderings alone, the fine
   ones alone, and fine queries against the coarse catalogue (a fine export searched among
   coarse ones; its own coarse twin left out).

It chooses nothing. Needs ``openscad`` and ``openscad-mcad`` (Debian).

**Result** (2026-11-28, twentieth session, ``ss11``): the facets move a part about as much
as a new sample of the same surface does. Twin distance median 0.0013 against 0.0657 to the
nearest other kind; every part's twin is nearer than any part of another kind (88 of 88);
the control kinds' twins (same vertices) 0.0009-0.0019, the most moved kinds helical gears
and stepper motors (0.0076, 0.0074). Per block the normals (0.113 of the gap) and the two
blocks whose gap between kinds is tiny anyway (D2 0.321, symmetry 0.410) move most. By kind:
coarse among coarse NN / mAP 0.898 / 0.735, fine among fine 0.898 / 0.737, fine queries
among coarse parts 0.886 / 0.737.

    .venv/bin/python bench/selection/tessellation_report.py /work/tessellation
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

from core.descriptor import DescriptorSpec  # noqa: E402
from core.evaluation.metrics import ranked_relevance, score_rankings  # noqa: E402
from core.evaluation.sources.mcad_parts import parts  # noqa: E402
from core.pipeline import describe  # noqa: E402
from core.settings import EngineSettings  # noqa: E402

FINE = "$fa = 3; $fs = 0.25;\n"
RENDERINGS = {"coarse": "", "fine": FINE}


def described(out: Path) -> dict[str, dict[str, np.ndarray]]:
    """Per rendering: ``"whole"`` ``(m, d)``, each block ``(m, b)`` and ``"kinds"``; written
    to ``out`` once and read back on a re-run."""
    spec = DescriptorSpec.from_settings(EngineSettings().descriptor)
    found: dict[str, dict[str, np.ndarray]] = {}
    for rendering, resolution in RENDERINGS.items():
        cache = out / f"{rendering}.npz"
        if not cache.exists():
            rows: dict[str, list[np.ndarray]] = {}
            kinds = []
            for kind, _, mesh in parts(resolution=resolution):
                one = describe(mesh.export(file_type="ply"), filename="part.ply")
                blocks = spec.blocks(one.signature, one.areas, one.eigenvalues, one.points)
                for name, block in {"whole": one.descriptor, **blocks}.items():
                    rows.setdefault(name, []).append(np.asarray(block, dtype=np.float64))
                kinds.append(kind)
                print(f"{rendering} {kind} {len(kinds)}", flush=True)
            np.savez(cache, kinds=np.array(kinds), **{k: np.array(v) for k, v in rows.items()})
        with np.load(cache) as data:
            found[rendering] = {key: data[key] for key in data.files}
    return found


def cosine(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cosine distances ``(len(a), len(b))`` between the rows; a zero row is 1 from all."""
    def unit(rows: np.ndarray) -> np.ndarray:
        norms = np.linalg.norm(rows, axis=1, keepdims=True)
        return np.divide(rows, norms, out=np.zeros_like(rows), where=norms > 0)
    return 1.0 - unit(a) @ unit(b).T


def twin_and_other(coarse: np.ndarray, fine: np.ndarray, kinds: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Per part: the distance to its own other rendering, and from its coarse rendering to
    the nearest coarse part of another kind."""
    twin = np.diag(cosine(coarse, fine))
    among = cosine(coarse, coarse)
    other = np.where(kinds[:, None] != kinds[None, :], among, np.inf).min(axis=1)
    return twin, other


def retrieval(queries: np.ndarray, catalogue: np.ndarray, kinds: np.ndarray) -> dict[str, float]:
    """Leave-one-out by kind in plain cosine order (the query's own index left out)."""
    relevance = ranked_relevance(cosine(queries, catalogue), list(kinds), list(kinds),
                                 np.eye(len(kinds), dtype=bool))
    return score_rankings(relevance)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    found = described(args.out)
    coarse, fine = found["coarse"], found["fine"]
    kinds = coarse["kinds"]
    if not np.array_equal(kinds, fine["kinds"]):
        raise SystemExit("the two renderings do not list the same parts")
    twin, other = twin_and_other(coarse["whole"], fine["whole"], kinds)
    print("\n1. whole descriptor, per kind: median twin distance / median distance to the "
          "nearest other kind (parts whose twin is nearer than any other kind)")
    for kind in dict.fromkeys(kinds):
        mine = kinds == kind
        print(f"  {kind:18s} {np.median(twin[mine]):.4f} / {np.median(other[mine]):.4f}  "
              f"({int(np.sum(twin[mine] < other[mine]))} of {int(mine.sum())})")
    print(f"  {'all':18s} {np.median(twin):.4f} / {np.median(other):.4f}  "
          f"({int(np.sum(twin < other))} of {len(kinds)})")
    print("\n2. per block: median of twin distance / distance to the nearest other kind")
    for name in coarse:
        if name in ("kinds", "whole"):
            continue
        block_twin, block_other = twin_and_other(coarse[name], fine[name], kinds)
        ratio = block_twin / np.maximum(block_other, 1e-12)
        print(f"  {name:10s} {np.median(ratio):.3f}   (twin {np.median(block_twin):.4f}, "
              f"other kind {np.median(block_other):.4f})")
    print("\n3. retrieval by kind, plain cosine, leave-one-out: NN / mAP / top-5")
    for label, (queries, catalogue) in {
        "coarse among coarse": (coarse["whole"], coarse["whole"]),
        "fine among fine": (fine["whole"], fine["whole"]),
        "fine among coarse": (fine["whole"], coarse["whole"]),
    }.items():
        result = retrieval(queries, catalogue, kinds)
        print(f"  {label:20s} {result['nn']:.3f} / {result['map']:.3f} / {result['top5']:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
