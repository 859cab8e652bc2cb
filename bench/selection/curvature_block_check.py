"""Issue 24: would a curvature block tell screw heads apart better than ``ss11`` does?

A check before a study, not a study: it decides only whether a study is worth asking. Why:
``screw_heads_report.py`` finds the ring block and ShapeDNA still ranking BOSL2's screws by
their proportions; a head differs from another by the kind of surface it has (a button head's
dome is umbilic, a socket head's sides cylindrical, a countersink conical, a hex flat), which
an area-weighted histogram of each point's shape index (Koenderink and van Doorn 1992) and
curvedness would see at any length. The block: principal curvatures by a least-squares
quadric over each point's nearest neighbours in its local PCA frame (the part scaled to unit
RMS radius), the shape index's magnitude (normals are unoriented, so a dome and a bowl are
alike) in 8 bins by log curvedness in 8 bins, plus one bin for flat points, area-weighted,
square root. Its pair distances on pymadcad's 40 screws (four heads, ten sizes each, the
same sizes for every head; a tuning source, not BOSL2) are scored as ``screw_heads_report.py``
scores BOSL2's: how often a screw of another head and the same size is nearer than the
median screw of the query's own head, and how many first answers are of the query's head;
alone, with the sample's or the evened areas, and joined to ``ss11``'s descriptor.

    .venv/bin/python -m core.evaluation.sources /work/tuning --sources madcad
    .venv/bin/python bench/selection/curvature_block_check.py /work/tuning/madcad

**Result** (2026-11-28, twenty-first session; no study asked). ``ss11`` alone: 4 of 120 pairs,
first answers 40 of 40. The block alone: 57-94 of 120 (16, 24 or 40 neighbours, either
areas), first answers 37-40 of 40; joined to ``ss11`` at weight 0.5, 1 or 2: 38, 50 and 56 of
120. It ranks heads worse than the descriptor already does, so no study was written.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from core.extrinsic import evened_areas, surface_normals
from core.pipeline import describe_points
from core.settings import DescriptorSettings

HEADS = ("screw_button_head", "screw_flat_head", "screw_hex_head", "screw_socket_head")
NEIGHBOURS = (16, 24, 40)
BINS = 8
#: log10 curvedness of the part at unit RMS radius spanned by the bins; below: flat.
CURVEDNESS_SPAN = (-1.0, 2.5)


def principal_curvatures(points: np.ndarray, neighbours: int) -> np.ndarray:
    """``(n, 2)`` principal curvatures, larger first, of ``points : (n, 3)``: a quadric
    ``w = a u^2 + b uv + c v^2 + d u + e v + f`` fitted to each point's ``neighbours``
    nearest in its local PCA frame, its fundamental forms at the point."""
    _, index = cKDTree(points).query(points, k=neighbours + 1)
    local = points[index] - points[:, None, :]
    _, vectors = np.linalg.eigh(np.einsum("nki,nkj->nij", local, local))
    u, v, w = np.moveaxis(np.einsum("nki,nij->nkj", local, vectors[:, :, ::-1]), -1, 0)
    design = np.stack([u * u, u * v, v * v, u, v, np.ones_like(u)], axis=-1)
    normal_matrix = np.einsum("nki,nkj->nij", design, design) + 1e-12 * np.eye(6)
    a, b, c, d, e, _ = np.linalg.solve(
        normal_matrix, np.einsum("nki,nk->ni", design, w)[..., None])[..., 0].T
    first = np.stack([1 + d * d, d * e, 1 + e * e])  # E, F, G
    root = np.sqrt(1 + d * d + e * e)
    second = np.stack([2 * a, b, 2 * c]) / root  # L, M, N
    determinant = first[0] * first[2] - first[1] ** 2
    mean = (first[0] * second[2] - 2 * first[1] * second[1] + first[2] * second[0]) / (
        2 * determinant)
    gauss = (second[0] * second[2] - second[1] ** 2) / determinant
    spread = np.sqrt(np.maximum(mean * mean - gauss, 0.0))
    return np.stack([mean + spread, mean - spread], axis=1)


def curvature_block(points: np.ndarray, areas: np.ndarray, neighbours: int) -> np.ndarray:
    """The block ``(BINS * BINS + 1,)`` of ``points : (n, 3)`` weighted by ``areas : (n,)``."""
    centred = points - np.average(points, axis=0, weights=areas)
    radius = np.sqrt(np.average((centred**2).sum(axis=1), weights=areas))
    high, low = principal_curvatures(centred / radius, neighbours).T
    shape_index = np.abs(2 / np.pi * np.arctan2(high + low, high - low))
    curvedness = np.log10(np.sqrt((high**2 + low**2) / 2) + 1e-9)
    index_bin = np.clip((shape_index * BINS).astype(int), 0, BINS - 1)
    start, stop = CURVEDNESS_SPAN
    curvedness_bin = np.clip(((curvedness - start) / (stop - start) * BINS).astype(int), -1,
                             BINS - 1)
    cell = np.where(curvedness_bin < 0, BINS * BINS, curvedness_bin * BINS + index_bin)
    histogram = np.bincount(cell, weights=areas, minlength=BINS * BINS + 1)
    return np.sqrt(histogram / histogram.sum())


def head_counts(vectors: np.ndarray, names: list[tuple[str, str]]) -> tuple[int, int, int]:
    """(pairs where a same-size screw of another head is nearer than the median screw of the
    query's own head, such pairs, first answers of the query's head)."""
    distances = np.linalg.norm(vectors[:, None] - vectors[None], axis=-1)
    nearer = pairs = first = 0
    for query, (head, size) in enumerate(names):
        own = [distances[query, j] for j, (h, _) in enumerate(names) if h == head and j != query]
        median = np.median(own)
        for j, (other_head, other_size) in enumerate(names):
            if other_head != head and other_size == size:
                pairs += 1
                nearer += distances[query, j] < median
        order = [j for j in np.argsort(distances[query]) if j != query]
        first += names[order[0]][0] == head
    return int(nearer), pairs, int(first)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("madcad", type=Path, help="pymadcad's folder of the tuning sources")
    args = parser.parse_args(argv)
    names, descriptors, blocks = [], [], {}
    normal_neighbours = DescriptorSettings().normal_neighbours
    for head in HEADS:
        for path in sorted((args.madcad / head).glob("*.ply")):
            points, _ = trimesh.sample.sample_surface(trimesh.load(path), 3000, seed=0)
            points = np.asarray(points)
            areas = np.full(len(points), 1.0 / len(points))
            evened = evened_areas(points, areas, surface_normals(points, normal_neighbours))
            names.append((head, path.stem))
            descriptors.append(np.asarray(describe_points(points).descriptor, dtype=np.float64))
            for neighbours in NEIGHBOURS:
                for label, weights in (("sample", areas), ("evened", evened)):
                    blocks.setdefault((neighbours, label), []).append(
                        curvature_block(points, weights, neighbours))
    rows = {"ss11": np.array(descriptors)}
    rows.update({f"block alone, {k} neighbours, {label} areas": np.array(b)
                 for (k, label), b in blocks.items()})
    for weight in (0.5, 1.0, 2.0):
        joined = np.hstack([rows["ss11"], weight * np.array(blocks[(NEIGHBOURS[0], "sample")])])
        rows[f"ss11 + block ({NEIGHBOURS[0]}, sample) at {weight:g}"] = (
            joined / np.linalg.norm(joined, axis=1, keepdims=True))
    for label, vectors in rows.items():
        nearer, pairs, first = head_counts(vectors, names)
        print(f"{label}: another head nearer than the own head's median in {nearer} of {pairs} "
              f"pairs; first answers of the query's head {first} of {len(names)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
