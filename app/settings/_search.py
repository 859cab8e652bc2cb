"""How a similar or search request is served and ordered."""

from __future__ import annotations

from pydantic import BaseModel, Field

from core.rank.hubness import HUB_NEIGHBOURS

__all__ = ["SearchSettings"]


class SearchSettings(BaseModel):
    """Search uploads at once, the answers' order (hub discount, reciprocal re-rank), metadata
    filters, and the answers kept in memory."""

    search_max_concurrent: int = Field(
        default=2,
        ge=1,
        description="Uploads POST /v1/search describes at the same time in one API process; "
        "one more is refused with 503 and Retry-After.",
    )
    search_retry_after_seconds: int = Field(
        default=5, ge=1, description="Retry-After of that 503, in seconds."
    )
    search_cache_size: int = Field(
        default=128,
        ge=0,
        description="Recent search uploads (by sha256) whose description is kept in memory, "
        "so that the same file is not described twice (0: no cache).",
    )
    search_hub_neighbours: int = Field(
        default=HUB_NEIGHBOURS,
        ge=0,
        le=100,
        description="Shape-mode similar answers are ordered with a hub discount (CSLS): the "
        "4 k nearest models re-ordered by distance^2 + r, r a candidate's mean cosine to "
        "its this many most alike other models, so a part that is near everything (a hub) "
        "comes a little later; `score` stays the plain similarity. 0: plain distance "
        "order, in scan mode too. Chosen on seven tuning sources, +0.01 mAP left out "
        "(docs/guide/search.md, The order of the results). Scan mode's discount has its own k "
        "(5) and weight (0.5), core.rank.hubness.SCAN_HUB_NEIGHBOURS, and orders the answers "
        "after its first as this order ranks them for that answer (core.rank.scan_order); 0 "
        "turns both off.",
    )
    search_reciprocal: bool = Field(
        default=True,
        description="With the hub discount on: shape-mode similar answers are re-ranked "
        "k-reciprocally over the hub discount's order (Zhong et al. 2017): the nearest "
        "max(4 k, 40) models are compared by their neighbourhoods among each other, so a "
        "part whose own nearest include the query comes earlier, the discount's first answer "
        "kept first; `score` stays the plain similarity. Confirmed on a tuning source no "
        "setting had seen, +0.04 mAP (docs/guide/search.md, The order of the results). false: "
        "the hub discount's order.",
    )
    filter_pushdown_max: int = Field(
        default=10_000,
        ge=0,
        description="A metadata filter matching at most this many models is selected in SQL "
        "first and only those models are searched; broader filters are applied to widening "
        "index results.",
    )
    response_cache_seconds: float = Field(
        default=1.0,
        ge=0,
        description="How long an API process serves a repeated model list or similar-model "
        "list from memory (0: never). Its own writes and every index change drop the kept "
        "answers at once; other processes' changes show within this time. Never longer "
        "than auth_cache_seconds.",
    )
    readyz_count_seconds: float = Field(
        default=30.0,
        ge=0,
        description="/readyz compares the index with the change feed on every probe, and "
        "counts the ready models (a table scan) at most this often.",
    )
