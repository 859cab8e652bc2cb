"""The duplicate report: groups of parts whose descriptors are at least ``min_score`` alike.

One batched k-nearest-neighbour search of every ready descriptor of a (tenant,
descriptor_version) against all of them (FAISS, exact inner product on unit vectors) gives
the kNN graph; edges below ``min_score`` are dropped and the connected components of what
remains (scipy.sparse.csgraph) are the groups. Cost: one n x n x d BLAS product inside
FAISS, never a Python double loop. Scores are the API's: (1 + cosine) / 2.

What "duplicate" means here: the descriptor is intrinsic and scale-normalised, so a part,
its mirror image, a rotated or moved copy and a uniformly scaled copy describe alike and
group together; so can genuinely different parts with very similar intrinsic geometry
(e.g. two plates whose holes sit in different places). Groups are candidates for review.
"""

from __future__ import annotations

import uuid
from dataclasses import dataclass

import faiss
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from sqlalchemy import select
from sqlalchemy.orm import Session

from app.db.models import Model
from app.search.sizing import extents_mm

__all__ = ["DuplicateGroup", "Member", "find_groups", "group_vectors"]

DEFAULT_NEIGHBOURS = 16


@dataclass(frozen=True)
class Member:
    id: uuid.UUID
    external_id: str | None
    name: str | None


@dataclass(frozen=True)
class DuplicateGroup:
    members: list[Member]
    # (i, j, score) for every pair i < j of members, best first
    pairs: list[tuple[int, int, float]]


def group_vectors(
    vectors: np.ndarray,
    min_score: float,
    neighbours: int = DEFAULT_NEIGHBOURS,
    extents: np.ndarray | None = None,
    size_tolerance: float | None = None,
) -> list[np.ndarray]:
    """Row indices of each group of two or more, largest group first.

    Parameters
    ----------
    vectors : (n, d) float32
        Unit descriptors.
    min_score : float
        Keep kNN edges with (1 + cosine) / 2 >= min_score.
    neighbours : int
        k of the kNN graph (the row itself included).
    extents : (n, 3) float, optional
        Each row's length, width and height in millimetres (NaN: unknown).
    size_tolerance : float, optional
        Keep only edges between rows whose extents each differ by at most this factor
        (``max / min - 1``): true duplicates, same shape and same size. None: any size.
    """
    n = len(vectors)
    if n < 2:
        return []
    data = np.ascontiguousarray(vectors, dtype=np.float32)
    index = faiss.IndexFlatIP(data.shape[1])
    index.add(data)
    cosines, ids = index.search(data, min(neighbours, n))  # one batched search
    rows = np.repeat(np.arange(n), ids.shape[1])
    cols = ids.ravel()
    keep = (cols >= 0) & (cols != rows) & ((1.0 + cosines.ravel()) / 2.0 >= min_score)
    if size_tolerance is not None and extents is not None:
        a, b = extents[rows], extents[np.where(cols >= 0, cols, 0)]
        ratio = np.maximum(a, b) / np.minimum(a, b)  # NaN for unknown sizes: never kept
        keep &= np.all(ratio - 1.0 <= size_tolerance + 1e-9, axis=1)
    graph = coo_matrix((np.ones(int(keep.sum())), (rows[keep], cols[keep])), shape=(n, n))
    count, labels = connected_components(graph, directed=False)
    sizes = np.bincount(labels, minlength=count)
    groups = [np.flatnonzero(labels == label) for label in np.flatnonzero(sizes >= 2)]
    return sorted(groups, key=lambda members: (-len(members), int(members[0])))


def find_groups(
    session: Session, tenant: str, descriptor_version: str, min_score: float,
    neighbours: int = DEFAULT_NEIGHBOURS, size_tolerance: float | None = None,
) -> list[DuplicateGroup]:
    """Duplicate groups among the tenant's ready models of one descriptor version; with
    ``size_tolerance``, of the same size too (extents compared in millimetres)."""
    rows = session.execute(
        select(Model.id, Model.external_id, Model.name, Model.descriptor, Model.size_length,
               Model.size_width, Model.size_height, Model.units)
        .where(
            Model.tenant == tenant,
            Model.status == "ready",
            Model.descriptor_version == descriptor_version,
            Model.descriptor.is_not(None),
        )
        .order_by(Model.created_at, Model.id)
    ).all()
    if len(rows) < 2:
        return []
    vectors = np.stack([np.frombuffer(row.descriptor, dtype=np.float32) for row in rows])
    extents = np.array([
        extents_mm(row.size_length, row.size_width, row.size_height, row.units)
        or (np.nan, np.nan, np.nan)
        for row in rows
    ], dtype=np.float64)
    groups = []
    for members in group_vectors(vectors, min_score, neighbours, extents, size_tolerance):
        block = vectors[members]
        scores = (1.0 + block @ block.T) / 2.0  # small: one group
        i, j = np.triu_indices(len(members), k=1)
        order = np.argsort(-scores[i, j], kind="stable")
        groups.append(
            DuplicateGroup(
                members=[
                    Member(rows[m].id, rows[m].external_id, rows[m].name) for m in members
                ],
                pairs=[(int(i[o]), int(j[o]), float(min(1.0, scores[i[o], j[o]]))) for o in order],
            )
        )
    return groups

