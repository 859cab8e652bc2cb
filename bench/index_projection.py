"""Do an IVF partition's projected codes keep the true neighbours of real descriptors?

A compressed partition's codes hold the leading principal components of its descriptors
(``app.search.index._projection``); the exact re-rank then reads the full vectors. This
checks that choice on real descriptors rather than bench/search_scale.py's synthetic ones
(mixtures of 40 real descriptors plus isotropic noise, which no projection can compress):
every model of the tuning sources (``python -m core.evaluation.sources OUT``) is described
with the service's default, and for each source left out, the projection is fitted on the
other sources alone, as a catalogue's first sample cannot foresee every later part.

For each source left out, its models query the whole pool (every source, the query left
out); the figures are the variance of the left-out descriptors that the projection keeps,
the share of the true 10 nearest that are among the ``R`` nearest projections (recall@10,
what the exact re-rank can then recover), and the mean ratio of the 10th distance found
to the true one.

    .venv/bin/python -m core.evaluation.sources /work/tuning
    .venv/bin/python -m bench.index_projection /work/tuning
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from app.search.index._projection import Projection
from bench._common import REPO

OUT = REPO / "bench" / "out" / "index_projection"
SUFFIXES = {".stl", ".ply", ".obj", ".off"}
K = 10


def described(folder: Path) -> tuple[np.ndarray, np.ndarray]:
    """``(n, d) float32`` default descriptors of every model under ``folder`` and ``(n,)``
    source names, described once and cached per descriptor version."""
    from app.ingest.describing import pin_blas_threads
    from core.descriptor import DescriptorSpec
    from core.pipeline import describe
    from core.settings import EngineSettings

    settings = EngineSettings()
    version = DescriptorSpec.from_settings(settings.descriptor).version(settings)
    cache = OUT / f"{folder.name}_{version.rsplit(';', 1)[-1]}.npz"
    if cache.exists():
        stored = np.load(cache)
        return stored["vectors"], stored["sources"]
    pin_blas_threads()
    # Per source: a source may be a link to a shared dataset, which rglob would not enter.
    files = sorted(p for source in folder.iterdir() if source.is_dir()
                   for p in source.rglob("*") if p.suffix.lower() in SUFFIXES)
    vectors, sources = [], []
    for path in files:
        try:
            vectors.append(describe(path, settings).descriptor.astype(np.float32))
        except Exception as error:  # an edge case the engine refuses: skip it
            print(f"  skipped {path}: {error}", flush=True)
            continue
        sources.append(path.relative_to(folder).parts[0])
    OUT.mkdir(parents=True, exist_ok=True)
    np.savez(cache, vectors=np.stack(vectors), sources=np.array(sources))
    return np.stack(vectors), np.array(sources)


def squared_distances(rows: np.ndarray, pool: np.ndarray) -> np.ndarray:
    """``(m, n)`` squared L2 distances of ``rows : (m, d)`` to ``pool : (n, d)``."""
    products = rows @ pool.T
    return np.maximum((rows**2).sum(1)[:, None] + (pool**2).sum(1)[None, :] - 2 * products, 0)


def check(vectors: np.ndarray, held_out: np.ndarray, dims: int, candidates: list[int]) -> str:
    """One line of figures for the models ``held_out : (n,) bool`` of ``vectors``."""
    projection = Projection.fit(vectors[~held_out], dims)
    queries = np.flatnonzero(held_out)
    left = vectors[queries]
    kept = projection.apply(left)
    variance = (kept - kept.mean(0)).var(0).sum() / left.var(0).sum()
    exact = squared_distances(left.astype(np.float64), vectors.astype(np.float64))
    projected = projection.apply(vectors).astype(np.float64)
    approximate = squared_distances(projected[queries], projected)
    exact[np.arange(len(queries)), queries] = np.inf  # a query is not its own neighbour
    approximate[np.arange(len(queries)), queries] = np.inf
    true = np.argsort(exact, axis=1, kind="stable")[:, :K]
    figures = [f"variance kept {variance:.3f}"]
    for count in candidates:
        found = np.argsort(approximate, axis=1, kind="stable")[:, :count]
        recall = np.mean([len(set(f) & set(t)) / K for f, t in zip(found, true, strict=True)])
        tenth = np.sort(np.take_along_axis(exact, found, axis=1), axis=1)[:, K - 1]
        ratio = np.mean(np.sqrt(tenth / np.take_along_axis(exact, true[:, -1:], 1)[:, 0]))
        figures.append(f"R{count} recall@{K} {recall:.4f} ratio {ratio:.4f}")
    return "; ".join(figures)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sources", type=Path, help="a folder made by core.evaluation.sources")
    parser.add_argument("--dims", type=int, nargs="*", default=[64, 128, 256])
    parser.add_argument("--candidates", type=int, nargs="*", default=[10, 20, 40])
    args = parser.parse_args()
    start = time.perf_counter()
    vectors, sources = described(args.sources)
    print(f"{len(vectors)} descriptors of {vectors.shape[1]} dims "
          f"({time.perf_counter() - start:.0f} s)")
    for dims in args.dims:
        for source in sorted(set(sources.tolist())):
            held_out = sources == source
            if dims + 64 > min((~held_out).sum(), vectors.shape[1]):
                continue
            line = check(vectors, held_out, dims, args.candidates)
            print(f"{dims} dims, {source} left out ({held_out.sum()} queries): {line}",
                  flush=True)


if __name__ == "__main__":
    main()
