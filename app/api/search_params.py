"""Query parameters shared by the similar and search routes: the search mode and the
metadata and size filters.

The filters are read from the raw query string (``metadata.KEY=VALUE``,
``metadata.KEY.gte=N``, ``size.length.lte=N``): their names are data, which FastAPI cannot
declare. ``FILTER_PARAMETERS`` declares them in the OpenAPI document as they travel, so
that generated clients can send them: the metadata filters as two free-form objects
serialized ``style: form, explode: true`` (each property is one query parameter, named by
its key: ``{"metadata.material": "steel"}`` is ``metadata.material=steel``), the size
ranges as the ten fixed parameters they are.
"""

from __future__ import annotations

import math
import uuid
from dataclasses import dataclass
from typing import Annotated, Any, Literal

from fastapi import Form, Query, Request

from app.api.inputs import invalid_input
from app.search.similarity import SearchMode
from app.search.sizing import SIZE_FILTER_FIELDS, SizeQuery

__all__ = [
    "FILTER_PARAMETERS",
    "FILTER_SCHEMAS",
    "ORDER_HELP",
    "AssemblyQuery",
    "SCAN_MODE_HELP",
    "SIZE_HELP",
    "ModeQuery",
    "SizeOptions",
    "UnitsField",
    "metadata_filters",
    "metadata_ranges",
    "query_column",
    "size_options",
]

SCAN_MODE_HELP = (
    "mode=scan is for scans, one side of a part or several sides merged: every model is "
    "compared both whole and as each of its virtual partial views (SHAPESEARCH_SCAN_VIEWS "
    "per model); a model's distance is that of its best entry, one result per model "
    "(SHAPESEARCH_SCAN_BOUNDARY_WEIGHTS, off by default, also fades the query's points near "
    "an open rim). mode=shape (the default) compares whole models only, which suits "
    "complete meshes."
)
ORDER_HELP = (
    " Order: with mode=shape the max(4k, 40) nearest models are ordered by distance^2 + r, "
    "r a model's mean cosine to its 10 most alike other models (a hub discount, "
    "SHAPESEARCH_SEARCH_HUB_NEIGHBOURS; 0 turns it off), so a part near everything comes a "
    "little later, and then re-ranked k-reciprocally among themselves (a model whose own "
    "nearest include the query comes earlier), the discount's first answer kept first "
    "(SHAPESEARCH_SEARCH_RECIPROCAL=false keeps the discount's order); score, the plain "
    "similarity, need not fall along the list; a model with the query's own descriptor "
    "stays first. With mode=scan, of the max(4k, 40) nearest models by best entry the one "
    "of least key comes first, key the best entry's distance^2 + r/2, r that entry's mean "
    "best cosine to the 5 other models most alike it; the others, joined with the 120 "
    "models nearest the first answer's whole descriptor, follow in the order mode=shape "
    "gives them for that descriptor, so the first answer's kind comes next, also where the "
    "scan itself missed it (off with SHAPESEARCH_SEARCH_HUB_NEIGHBOURS=0)."
)
AssemblyQuery = Annotated[
    uuid.UUID | None,
    Query(description="Only the parts that this assembly places (the id of a model uploaded "
          "with `assembly=split`); an id that places nothing: no results."),
]
ModeQuery = Annotated[
    SearchMode,
    Query(description="shape (default): whole models; scan: for scans, partial or merged, "
          "the best entry (whole or a view) of each model."),
]


def query_column(mode: SearchMode) -> str:
    """The descriptor column a query uses in ``mode``: the scan descriptor in scan mode."""
    return "scan_descriptor" if mode == "scan" else "descriptor"


_BOUNDS = (".gte", ".lte")

#: The filter objects of the OpenAPI document (``components/schemas``), one class each in a
#: generated client. A key ending in .gte or .lte is a range; every other is an equality.
FILTER_SCHEMAS: dict[str, dict[str, Any]] = {
    "MetadataFilter": {
        "title": "MetadataFilter",
        "description": "Keep models whose metadata KEY equals the value: one query "
        "parameter metadata.KEY=VALUE per property (string values compare as text, others "
        "by their JSON form, e.g. metadata.qty=3).",
        "type": "object",
        "propertyNames": {"pattern": r"^metadata\.(?!.*\.(gte|lte)$)[^\x00]+$"},
        "additionalProperties": {"type": "string"},
        "examples": [{"metadata.material": "steel"}],
    },
    "MetadataRanges": {
        "title": "MetadataRanges",
        "description": "Keep models whose metadata KEY holds a number in the range: one "
        "query parameter metadata.KEY.gte=N or metadata.KEY.lte=N per property.",
        "type": "object",
        "propertyNames": {"pattern": r"^metadata\.[^\x00]+\.(gte|lte)$"},
        "additionalProperties": {"type": "number"},
        "examples": [{"metadata.qty.gte": 2, "metadata.qty.lte": 10}],
    },
}


def _filter_parameters() -> list[dict[str, Any]]:
    objects = [
        {"name": name, "in": "query", "required": False, "style": "form", "explode": True,
         "schema": {"$ref": f"#/components/schemas/{schema}"},
         "description": FILTER_SCHEMAS[schema]["description"]}
        for name, schema in (("metadata", "MetadataFilter"), ("metadata_ranges", "MetadataRanges"))
    ]
    sizes = [
        {"name": f"size.{field}.{bound}", "in": "query", "required": False,
         "schema": {"type": "number"},
         "description": f"Keep models whose {field} is {words} this (in mm, mm2 or mm3 where "
         "units are known, as given otherwise)."}
        for field in SIZE_FILTER_FIELDS
        for bound, words in (("gte", "at least"), ("lte", "at most"))
    ]
    return objects + sizes


#: ``openapi_extra`` of the similar and search routes: the filters that
#: ``metadata_filters``, ``metadata_ranges`` and ``size_options`` read.
FILTER_PARAMETERS: dict[str, Any] = {"parameters": _filter_parameters()}


async def metadata_filters(request: Request) -> dict[str, str]:
    """``metadata.KEY=VALUE`` query parameters as {KEY: VALUE} (async: no thread hop);
    ``metadata.KEY.gte`` and ``.lte`` are ranges (``metadata_ranges``)."""
    return {
        key.removeprefix("metadata."): value
        for key, value in request.query_params.items()
        if key.startswith("metadata.") and len(key) > len("metadata.")
        and not key.endswith(_BOUNDS)
    }


async def metadata_ranges(request: Request) -> dict[str, tuple[float | None, float | None]]:
    """``metadata.KEY.gte=N`` / ``metadata.KEY.lte=N`` query parameters as
    {KEY: (low, high)}: numeric metadata within the range (async: no thread hop)."""
    ranges: dict[str, list[float | None]] = {}
    for name, value in request.query_params.items():
        if not (name.startswith("metadata.") and name.endswith(_BOUNDS)):
            continue
        key, _, bound = name.removeprefix("metadata.").rpartition(".")
        if not key:
            raise invalid_input(f"/query/{name}", "name a metadata key: metadata.KEY.gte")
        ranges.setdefault(key, [None, None])[0 if bound == "gte" else 1] = _number(name, value)
    return {key: (low, high) for key, (low, high) in ranges.items()}


def _number(name: str, value: str) -> float:
    try:
        number = float(value)
    except ValueError:
        number = float("nan")
    if not math.isfinite(number):
        raise invalid_input(f"/query/{name}", "must be a finite number")
    return number


SIZE_HELP = (
    " Numeric metadata: `metadata.KEY.gte=N` and `metadata.KEY.lte=N` keep models whose KEY "
    "holds a number in the range."
    " Size (sizes compare in millimetres where the models' units are known, as given "
    "otherwise): `size.length.gte=`, `size.length.lte=` (and width, height, area, volume) keep "
    "models in a range, before the top-k cut; `size_tolerance=0.1` keeps models whose three "
    "extents are each within +-10% of the query's; `size_weight=w` (default 0) ranks by "
    "D = sqrt(d^2 + w * sum of ln(extent ratio)^2) over the three extents, and score = "
    "1 - D^2/4. Models without a size pass no size filter."
)

#: The units of an uploaded file (``core.size.UNIT_MILLIMETRES``).
Units = Literal["mm", "cm", "m", "in"]
UnitsField = Annotated[
    Units | None,
    Form(description="Units of the file's coordinates: mm, cm, m or in. Sizes compare in "
         "millimetres where units are known; without, the numbers are compared as given."),
]


@dataclass(frozen=True)
class SizeOptions:
    """The size parameters of a query, before the query's own size is known."""

    ranges: dict[str, tuple[float | None, float | None]]
    tolerance: float | None
    weight: float

    @property
    def needs_query_size(self) -> bool:
        return self.tolerance is not None or self.weight > 0

    def query(self, extents: tuple[float, float, float] | None) -> SizeQuery:
        """The ``SizeQuery`` around a query of ``extents`` (millimetres); a tolerance or a
        weight without a query size is a 422."""
        if self.needs_query_size and extents is None:
            name = "size_tolerance" if self.tolerance is not None else "size_weight"
            raise invalid_input(f"/query/{name}", "the query has no size (re-describe the model)")
        return SizeQuery(extents, self.tolerance, self.weight, self.ranges)


async def size_options(
    request: Request,
    size_tolerance: Annotated[
        float | None,
        Query(ge=0, le=10, description="Keep models whose three extents are each within "
              "this relative tolerance of the query's (0.1: +-10%)."),
    ] = None,
    size_weight: Annotated[
        float,
        Query(ge=0, le=100, description="Weight of the size term in the ranking distance "
              "(0: the descriptor alone)."),
    ] = 0.0,
) -> SizeOptions:
    """``size.FIELD.gte`` / ``size.FIELD.lte`` query parameters, the tolerance and the
    weight (async: no thread hop)."""
    ranges: dict[str, list[float | None]] = {}
    for key, value in request.query_params.items():
        if not key.startswith("size."):
            continue
        pointer = f"/query/{key}"
        name, _, bound = key.removeprefix("size.").partition(".")
        if name not in SIZE_FILTER_FIELDS or bound not in ("gte", "lte"):
            raise invalid_input(
                pointer, f"size filters are size.<{'|'.join(SIZE_FILTER_FIELDS)}>.<gte|lte>"
            )
        ranges.setdefault(name, [None, None])[0 if bound == "gte" else 1] = _number(key, value)
    return SizeOptions(
        {name: (low, high) for name, (low, high) in ranges.items()}, size_tolerance, size_weight
    )
