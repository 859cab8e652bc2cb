"""Query parameters shared by the similar and search routes: the search mode and the
metadata filters."""

from __future__ import annotations

from typing import Annotated

from fastapi import Query, Request

from app.search.similarity import SearchMode

__all__ = ["SCAN_MODE_HELP", "ModeQuery", "metadata_filters", "query_column"]

SCAN_MODE_HELP = (
    "mode=scan is for partial scans (one side of a part): the query is described with the "
    "points near its open rim faded out, and every model is compared both whole and as "
    "each of its virtual partial views (SHAPESEARCH_SCAN_VIEWS per model); a model's "
    "distance is that of its best view, one result per model. mode=shape (the default) "
    "compares whole models only, which suits complete meshes and merged scans better."
)
ModeQuery = Annotated[
    SearchMode,
    Query(description="shape (default): whole models; scan: for partial scans, best view "
          "of each model."),
]


def query_column(mode: SearchMode) -> str:
    """The descriptor column a query uses in ``mode``: the scan descriptor in scan mode."""
    return "scan_descriptor" if mode == "scan" else "descriptor"


async def metadata_filters(request: Request) -> dict[str, str]:
    """``metadata.KEY=VALUE`` query parameters as {KEY: VALUE} (async: no thread hop)."""
    return {
        key.removeprefix("metadata."): value
        for key, value in request.query_params.items()
        if key.startswith("metadata.") and len(key) > len("metadata.")
    }
