"""What one similarity query asks: its vector, how many answers, and its filters."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from sqlalchemy import Row

from app.search.similarity._filters import Ranges, metadata_in_ranges, metadata_matches
from app.search.sizing import SizeQuery


@dataclass(frozen=True)
class Query:
    """One similarity query, its filters resolved (``find_similar`` makes it).

    Attributes
    ----------
    vector : (d,) float32
        The query's descriptor.
    k : int
        How many answers.
    min_score : float or None
        No answer scores below it.
    filters : dict of str to str
        Metadata equality filters (``metadata_matches``).
    ranges : Ranges
        Metadata number ranges (``metadata_in_ranges``).
    size : SizeQuery
        Size filters and the size term (``app.search.sizing``).
    exclude : int or None
        The query model's ``index_id``, never an answer.
    allowed : list of int or None
        The ids SQL narrowed the filters to (``matching_ids``); None: not narrowed (no
        filter, or too many models pass it).
    indexed_query : bool
        ``vector`` is the index's copy of model ``exclude`` (``find_similar``).
    """

    vector: np.ndarray
    k: int
    min_score: float | None
    filters: dict[str, str]
    ranges: Ranges
    size: SizeQuery
    exclude: int | None
    allowed: list[int] | None
    indexed_query: bool = False

    @property
    def filtered(self) -> bool:
        """Whether any filter applies (metadata equality or ranges, size)."""
        return bool(self.filters) or bool(self.ranges) or self.size.filters

    @property
    def screen(self) -> bool:
        """Filters that SQL could not narrow to ids: candidates' rows are screened."""
        return self.filtered and self.allowed is None

    def passes(self, row: Row[Any]) -> bool:
        """Whether a candidate row passes every filter (metadata equality and ranges, size)."""
        meta = row.meta or {}
        return (metadata_matches(meta, self.filters) and metadata_in_ranges(meta, self.ranges)
                and self.size.admits(row))
