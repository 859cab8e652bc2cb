"""Similarity queries: nearest descriptors from the index, confirmed, re-ranked and filtered
by the database, scored.

Score: descriptors are unit vectors, so the L2 distance ``d`` lies in [0, 2] and
``score = 1 - d**2 / 4`` (clipped to [0, 1]) equals ``(1 + cos) / 2``: 1 for identical
descriptors, 0.5 for orthogonal ones, 0 for opposite ones.

Every candidate is confirmed by the database, the source of truth, in one statement of
the few columns an answer shows: a model deleted by another process a moment ago is never
returned. When the partition is approximate (IVF-SQ, see ``app.search.index``) the distances are
recomputed exactly from the full vectors the index keeps (``app.search.full_vectors``), so scores
never carry quantisation error.

Metadata filters, two ways, and either way "k results whenever k matching models exist":

* selective (at most ``pushdown_max`` models match): the matching ids are selected in SQL
  (``jsonb @>`` on PostgreSQL, served by a GIN index; on SQLite from a table of metadata
  entries indexed on (tenant, key, value), kept by triggers) and only those ids are
  searched (a FAISS ``IDSelectorBatch``);
* otherwise the index is searched for more and more candidates (x4 each round) until ``k``
  of them pass the filters or the partition is exhausted; matches are then common, so few
  rounds are needed. With the hub discount the nearest candidates' rows are read first,
  a few at a time, until the pool the discount orders is full of models that pass
  (``first_passing``).

Numeric ranges on metadata (``metadata.KEY.gte=``, ``.lte=``, ``metadata_ranges``) work the
same way: a value passes when it is a JSON number (not a boolean) within the range.

SQL only narrows the candidates; ``metadata_matches`` and ``metadata_in_ranges`` decide, so
both ways agree exactly.

Two modes (``SearchMode``): ``shape`` compares the query with each model's descriptor;
``scan``, for partial scans, also with the descriptors of each model's virtual partial views
(``app.search.index.views_key``). A model's distance is then that of its best entry (the
whole model or one view), computed exactly from the index's vectors as added (a compressed
partition's full vectors, as in shape mode), and each model is one result. Both partitions
are searched for more and more candidates until ``k`` of them are certain: no model not yet
seen can be nearer than the last hit of a partition not exhausted.

Order: shape mode ranks with a hub discount (cross-domain similarity local scaling,
``core.rank.hubness``): the ``4 k`` nearest candidates are re-ordered by ``d^2 + r_k``, ``r_k`` a
candidate's mean cosine to its 10 most alike other models of the partition (the index's
``neighbourhood_radii``), so a part near everything comes a little later and the rest of
the query's kind earlier (+0.01 mAP left out over seven tuning sources).
Then, without a size term, those candidates are re-ranked k-reciprocally among themselves
(``core.rank.reciprocal.pool_keys``: a candidate whose own nearest hold the query comes earlier;
+0.04 mAP on a tuning source that no setting had seen), the hub discount's first answer
kept first (the re-rank alone moved right first answers down). A candidate with the query's
own descriptor stays first. ``distance`` and ``score`` stay plain (``min_score``, the
calibration and the duplicates report keep their meaning). Scan mode has a discount of its
own (``core.rank.hubness.model_radii``): of the ``core.rank.scan_order.scan_depth(k)`` (``max(4 k,
40)``) nearest models by best entry, the one whose best entry has the least ``d^2 + 0.5 r``,
``r`` the entry's mean best cosine to the 5 other models most alike it, comes first (+0.006 mAP
of single-view scans left out over seven sources); the others, joined with the
``core.rank.scan_order.ANCHOR_NEIGHBOURS`` (120) models nearest that first answer's whole
descriptor, follow in the order a shape query for it gives them (``core.rank.scan_order``: a
partial scan is far from every whole model, whole models find their kind well; +0.015 mAP
of single-view scans left out over seven sources against the blend it replaced, itself
+0.073 over the discount alone; the joined neighbours a further +0.013). An entry's
radius costs a search, so entries are taken best bound first (``_scan_hub_order``) and the
index keeps what it searched while the catalogue stays as it is.

The package's face is ``find_similar`` and the names of ``__all__``; behind it, one job a
module: ``_filters`` (metadata filters, the predicate and the SQL that narrows),
``_rows`` (what the database confirms and an answer shows), ``_shape`` (shape mode's search
and order) and ``_scan`` (scan mode's).
"""

from __future__ import annotations

import uuid
from dataclasses import replace
from typing import Literal

import numpy as np
from sqlalchemy import Connection

from app.search.index import PartitionKey, ShapeIndex
from app.search.similarity._filters import (
    Ranges,
    assembly_part_ids,
    matching_ids,
    metadata_in_ranges,
    metadata_matches,
    sql_filter,
)
from app.search.similarity._query import Query
from app.search.similarity._rows import Candidate, Match, QueryChanged, score_of
from app.search.similarity._scan import scan_matches
from app.search.similarity._shape import shape_matches
from app.search.sizing import SizeQuery

__all__ = [
    "PUSHDOWN_MAX",
    "Candidate",
    "Match",
    "QueryChanged",
    "Ranges",
    "SearchMode",
    "find_similar",
    "matching_ids",
    "metadata_in_ranges",
    "metadata_matches",
    "score_of",
    "sql_filter",
]

#: At most this many models pass the filters for their ids to be searched alone.
PUSHDOWN_MAX = 10_000

#: ``shape``: whole models only (the default); ``scan``: best of each model and its views.
SearchMode = Literal["shape", "scan"]


def find_similar(
    index: ShapeIndex,
    connection: Connection,
    key: PartitionKey,
    vector: np.ndarray,
    *,
    k: int,
    min_score: float | None = None,
    filters: dict[str, str] | None = None,
    exclude: int | None = None,
    pushdown_max: int = PUSHDOWN_MAX,
    mode: SearchMode = "shape",
    indexed_query: bool = False,
    size: SizeQuery | None = None,
    metadata_ranges: Ranges | None = None,
    assembly_id: uuid.UUID | None = None,
) -> list[Match]:
    """The ``k`` best matches in partition ``key`` (tenant, descriptor version); in
    ``scan`` mode each model's best entry counts (see the module's docstring). With
    ``assembly_id``, only among the parts that assembly places.

    ``indexed_query`` (shape mode): ``vector`` is the index's copy of model ``exclude``
    (``ShapeIndex.vector``: the vector as added, in a compressed partition too), not read
    from the database. That model's row is then confirmed in the statement that confirms
    the first candidates, one statement for the whole query. Raises ``QueryChanged`` when
    the row is no longer ready under ``key``.

    ``size`` (``app.search.sizing``): size filters, which narrow the candidates like the
    metadata filters, and a size term that ranks by the combined distance; a match's
    ``distance`` and ``score`` are then the combined ones.

    Shape mode orders its answer with the index's hub discount (``index.hub_neighbours``
    above 0): the ``rerank_depth(k)`` nearest candidates that pass, re-ordered by
    ``core.rank.hubness.hub_keys`` and, with ``index.reciprocal`` and no size term, re-ranked
    k-reciprocally among the ``reciprocal_depth(k)`` nearest (``core.rank.reciprocal``), the
    first ``k`` returned; ``distance`` and ``score`` stay the plain ones, so scores need not
    fall along the answer.
    """
    vector = np.ascontiguousarray(vector, dtype=np.float32).ravel()
    query = Query(vector, k, min_score, filters or {}, metadata_ranges or {},
                  size or SizeQuery(), exclude, None, indexed_query)
    if assembly_id is not None:  # always narrow: searched among its parts' ids alone
        within = assembly_part_ids(connection, key[0], assembly_id)
        allowed = matching_ids(connection, key, query.filters, len(within), query.size,
                               query.ranges, within) if within else []
        query = replace(query, allowed=[i for i in allowed or [] if i != exclude])
    elif query.filtered:
        allowed = matching_ids(connection, key, query.filters, pushdown_max, query.size,
                               query.ranges)
        if allowed is not None:
            query = replace(query, allowed=[i for i in allowed if i != exclude])
    if mode == "scan":
        return scan_matches(index, connection, key, query)
    return shape_matches(index, connection, key, query)
