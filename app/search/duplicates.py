"""The duplicates report: groups of parts whose descriptors are at least ``min_score`` alike.

A report is computed once per request for one (``POST /v1/duplicates``: a job, or
``shapesearch duplicates``), stored (``app.search.duplicate_reports``) and then paged, so
no page request reads a descriptor. The computation:

1. the tenant's partition of the search index for the descriptor version is built the way
   every API process builds its own (``ShapeIndex.rebuild``, restricted to that partition:
   each descriptor is read from the database once, in chunks): flat up to
   ``SHAPESEARCH_INDEX_EXACT_MAX`` models, IVF above;
2. its k-nearest-neighbour graph (``ShapeIndex.neighbour_graph``): every part's
   ``neighbours`` most alike others, with exact cosines of the full vectors (never of the
   index's 8-bit codes). In an IVF partition only pairs within nearby inverted lists are
   compared (the report says ``exact: false``);
3. edges below ``min_score`` (and, with ``size_tolerance``, between parts of different
   sizes) are dropped; the connected components of what remains (scipy.sparse.csgraph)
   with two or more members are the groups, largest first, and each group keeps the edges
   that joined it. Scores are the API's: ``(1 + cosine) / 2``.

What "duplicate" means here: the descriptor is intrinsic and scale-normalised, so a part,
its mirror image, a rotated or moved copy and a uniformly scaled copy describe alike and
group together; so can genuinely different parts with very similar intrinsic geometry
(e.g. two plates whose holes sit in different places). Groups are candidates for review.
"""

from __future__ import annotations

import time
import uuid
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any, Unpack

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from sqlalchemy import select
from sqlalchemy.orm import Session, sessionmaker

from app.db.models import Model
from app.search.index import NeighbourGraph, ShapeIndex
from app.search.sizing import extents_mm

if TYPE_CHECKING:
    from app.settings import IndexOptions

__all__ = [
    "DEFAULT_MIN_SCORE",
    "DEFAULT_NEIGHBOURS",
    "ComputedReport",
    "DuplicatesQuery",
    "Group",
    "compute_report",
    "group_graph",
]

DEFAULT_MIN_SCORE = 0.98
DEFAULT_NEIGHBOURS = 16


@dataclass(frozen=True)
class DuplicatesQuery:
    """The parameters of a report: what ``POST /v1/duplicates`` asks and a report keeps."""

    descriptor_version: str
    min_score: float = DEFAULT_MIN_SCORE
    # Same size too: every extent within this relative tolerance; None: any size (families).
    size_tolerance: float | None = None
    neighbours: int = DEFAULT_NEIGHBOURS  # k of the graph

    def params(self) -> dict[str, Any]:
        """As a job stores them (``Job.params``)."""
        return asdict(self)

    @classmethod
    def from_params(cls, params: dict[str, Any]) -> DuplicatesQuery:
        return cls(**params)


@dataclass(frozen=True)
class Group:
    """One group: its members' public ids, oldest model first, and the edges that joined
    them, ``(i, j, score)`` with ``i < j`` indexes of ``members``, best first."""

    members: list[uuid.UUID]
    pairs: list[tuple[int, int, float]]


@dataclass(frozen=True)
class ComputedReport:
    """A report as computed, before it is stored."""

    query: DuplicatesQuery
    revision: int  # the change-feed revision whose searchable set it describes
    models: int  # ready models compared
    groups: list[Group]  # largest first
    exact: bool  # every pair compared (see ``NeighbourGraph.exact``)
    # Seconds of each step: "load" (the partition from the database), "graph", "groups".
    timings: dict[str, float]

    @property
    def seconds(self) -> float:
        return sum(self.timings.values())


def compute_report(
    sessions: sessionmaker[Session],
    tenant: str,
    query: DuplicatesQuery,
    **index_options: Unpack[IndexOptions],
) -> ComputedReport:
    """The report of ``tenant``'s ready models of ``query.descriptor_version``; the index
    options (``ShapeIndex``'s keyword arguments) are the service's
    (``Settings.index_options``), so the partition is the one its API processes search."""
    clock = time.perf_counter()
    timings: dict[str, float] = {}

    def lap(step: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        timings[step], clock = now - clock, now

    key = (tenant, query.descriptor_version)
    index = ShapeIndex(sessions, only=key, **index_options)
    index.rebuild()
    lap("load")
    graph = index.neighbour_graph(key, query.neighbours)
    lap("graph")
    public_ids, extents = _model_facts(sessions, tenant, query.descriptor_version, graph.ids)
    held = np.array([public_id is not None for public_id in public_ids], dtype=bool)
    groups = [
        Group(members=[public_ids[m] for m in members], pairs=pairs)
        for members, pairs in group_graph(
            graph, query.min_score, extents, query.size_tolerance, held
        )
    ]
    lap("groups")
    return ComputedReport(
        query=query,
        revision=index.revision,
        models=len(graph.ids),
        groups=groups,
        exact=graph.exact,
        timings=timings,
    )


def _model_facts(
    sessions: sessionmaker[Session], tenant: str, version: str, index_ids: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The public ids ``(n,) object`` (None: deleted since the index was built) and the
    extents in millimetres ``(n, 3) float`` (NaN: unknown) of the graph's models."""
    row_of = {int(index_id): row for row, index_id in enumerate(index_ids.tolist())}
    public_ids = np.full(len(index_ids), None, dtype=object)
    extents = np.full((len(index_ids), 3), np.nan)
    with sessions() as session:
        found = session.execute(
            select(Model.index_id, Model.id, Model.size_length, Model.size_width,
                   Model.size_height, Model.units)
            .where(Model.tenant == tenant, Model.descriptor_version == version,
                   Model.status == "ready")
        )
        for index_id, model_id, length, width, height, units in found:
            row = row_of.get(index_id)
            if row is None:  # ready since the index was built: not in this report
                continue
            public_ids[row] = model_id
            size = extents_mm(length, width, height, units)
            if size is not None:
                extents[row] = size
    return public_ids, extents


def group_graph(
    graph: NeighbourGraph,
    min_score: float,
    extents: np.ndarray | None = None,
    size_tolerance: float | None = None,
    held: np.ndarray | None = None,
) -> list[tuple[np.ndarray, list[tuple[int, int, float]]]]:
    """The groups of a neighbour graph: each as the graph rows of its members (oldest model
    first: ascending index id) and its edges ``(i, j, score)`` between them
    (``i < j`` indexes of the members), best first; largest group first.

    Parameters
    ----------
    graph : NeighbourGraph
        ``n`` vectors and their k most alike others.
    min_score : float
        Keep edges with ``(1 + cosine) / 2 >= min_score``.
    extents : (n, 3) float, optional
        Each row's length, width and height in millimetres (NaN: unknown).
    size_tolerance : float, optional
        Keep only edges between rows whose extents each differ by at most this factor
        (``max / min - 1``): true duplicates, same shape and same size. None: any size.
    held : (n,) bool, optional
        Rows that may take part (False: a model deleted since the graph was computed).
    """
    n, k = graph.neighbours.shape
    if n < 2:
        return []
    rows = np.repeat(np.arange(n), k)
    cols = graph.neighbours.ravel()
    scores = np.minimum(1.0, (1.0 + graph.cosines.ravel().astype(np.float64)) / 2.0)
    keep = (cols >= 0) & (scores >= min_score)
    other = np.where(cols >= 0, cols, 0)
    if held is not None:
        keep &= held[rows] & held[other]
    if size_tolerance is not None and extents is not None:
        a, b = extents[rows], extents[other]
        with np.errstate(invalid="ignore"):
            ratio = np.maximum(a, b) / np.minimum(a, b)  # NaN for unknown sizes: never kept
        keep &= np.all(ratio - 1.0 <= size_tolerance + 1e-9, axis=1)
    first, second, scores = rows[keep], cols[keep], scores[keep]
    low, high = np.minimum(first, second), np.maximum(first, second)
    graph_matrix = coo_matrix((np.ones(len(low)), (low, high)), shape=(n, n))
    count, labels = connected_components(graph_matrix, directed=False)
    # Each undirected edge once (found from both ends: keep the better score), best first.
    order = np.lexsort((high, low, -scores))
    low, high, scores = low[order], high[order], scores[order]
    _, unique = np.unique(low * n + high, return_index=True)
    unique.sort()
    low, high, scores = low[unique], high[unique], scores[unique]
    edges_of: dict[int, list[int]] = {}
    for edge, label in enumerate(labels[low].tolist()):
        edges_of.setdefault(label, []).append(edge)
    # Members by label, each group's oldest model (smallest index id) first.
    by_label = np.lexsort((graph.ids, labels))
    bounds = np.searchsorted(labels[by_label], np.arange(count + 1))
    groups = []
    for label, edges in edges_of.items():  # a label with an edge has two members or more
        members = by_label[bounds[label] : bounds[label + 1]]
        place = {int(m): i for i, m in enumerate(members.tolist())}
        pairs = [(place[int(low[e])], place[int(high[e])], float(scores[e])) for e in edges]
        groups.append((members, pairs))
    return sorted(groups, key=lambda group: (-len(group[0]), int(graph.ids[group[0][0]])))
