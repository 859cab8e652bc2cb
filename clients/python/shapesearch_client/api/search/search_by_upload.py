from http import HTTPStatus
from typing import Any, cast
from urllib.parse import quote

import httpx

from ...client import AuthenticatedClient, Client
from ...types import Response, UNSET
from ... import errors

from ...models.body_search_by_upload import BodySearchByUpload
from ...models.metadata_filter import MetadataFilter
from ...models.metadata_ranges import MetadataRanges
from ...models.problem import Problem
from ...models.search_by_upload_mode import SearchByUploadMode
from ...models.search_response import SearchResponse
from ...types import UNSET, Unset
from typing import cast
from uuid import UUID



def _get_kwargs(
    *,
    body: BodySearchByUpload,
    k: int | Unset = 10,
    min_score: float | Unset = UNSET,
    mode: SearchByUploadMode | Unset = SearchByUploadMode.SHAPE,
    explain: bool | Unset = False,
    points: int | Unset = 0,
    assembly_id: UUID | Unset = UNSET,
    where_used: bool | Unset = False,
    size_tolerance: float | Unset = UNSET,
    size_weight: float | Unset = 0.0,
    metadata: MetadataFilter | Unset = UNSET,
    metadata_ranges: MetadataRanges | Unset = UNSET,
    size_length_gte: float | Unset = UNSET,
    size_length_lte: float | Unset = UNSET,
    size_width_gte: float | Unset = UNSET,
    size_width_lte: float | Unset = UNSET,
    size_height_gte: float | Unset = UNSET,
    size_height_lte: float | Unset = UNSET,
    size_area_gte: float | Unset = UNSET,
    size_area_lte: float | Unset = UNSET,
    size_volume_gte: float | Unset = UNSET,
    size_volume_lte: float | Unset = UNSET,

) -> dict[str, Any]:
    headers: dict[str, Any] = {}


    

    params: dict[str, Any] = {}

    params["k"] = k

    params["min_score"] = min_score

    json_mode: str | Unset = UNSET
    if not isinstance(mode, Unset):
        json_mode = mode.value

    params["mode"] = json_mode

    params["explain"] = explain

    params["points"] = points

    json_assembly_id: str | Unset = UNSET
    if not isinstance(assembly_id, Unset):
        json_assembly_id = str(assembly_id)
    params["assembly_id"] = json_assembly_id

    params["where_used"] = where_used

    params["size_tolerance"] = size_tolerance

    params["size_weight"] = size_weight

    json_metadata: dict[str, Any] | Unset = UNSET
    if not isinstance(metadata, Unset):
        json_metadata = metadata.to_dict()
    if not isinstance(json_metadata, Unset):
        params.update(json_metadata)


    json_metadata_ranges: dict[str, Any] | Unset = UNSET
    if not isinstance(metadata_ranges, Unset):
        json_metadata_ranges = metadata_ranges.to_dict()
    if not isinstance(json_metadata_ranges, Unset):
        params.update(json_metadata_ranges)


    params["size.length.gte"] = size_length_gte

    params["size.length.lte"] = size_length_lte

    params["size.width.gte"] = size_width_gte

    params["size.width.lte"] = size_width_lte

    params["size.height.gte"] = size_height_gte

    params["size.height.lte"] = size_height_lte

    params["size.area.gte"] = size_area_gte

    params["size.area.lte"] = size_area_lte

    params["size.volume.gte"] = size_volume_gte

    params["size.volume.lte"] = size_volume_lte


    params = {k: v for k, v in params.items() if v is not UNSET and v is not None}


    _kwargs: dict[str, Any] = {
        "method": "post",
        "url": "/v1/search",
        "params": params,
    }

    _kwargs["files"] = body.to_multipart()

    headers["Content-Type"] = "multipart/form-data; boundary=+++"

    _kwargs["headers"] = headers
    return _kwargs



def _parse_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Problem | SearchResponse | None:
    if response.status_code == 200:
        response_200 = SearchResponse.from_dict(response.json())



        return response_200

    if response.status_code == 400:
        response_400 = Problem.from_dict(response.json())



        return response_400

    if response.status_code == 401:
        response_401 = Problem.from_dict(response.json())



        return response_401

    if response.status_code == 413:
        response_413 = Problem.from_dict(response.json())



        return response_413

    if response.status_code == 415:
        response_415 = Problem.from_dict(response.json())



        return response_415

    if response.status_code == 422:
        response_422 = Problem.from_dict(response.json())



        return response_422

    if response.status_code == 503:
        response_503 = Problem.from_dict(response.json())



        return response_503

    if response.status_code == 507:
        response_507 = Problem.from_dict(response.json())



        return response_507

    if client.raise_on_unexpected_status:
        raise errors.UnexpectedStatus(response.status_code, response.content)
    else:
        return None


def _build_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Response[Problem | SearchResponse]:
    return Response(
        status_code=HTTPStatus(response.status_code),
        content=response.content,
        headers=response.headers,
        parsed=_parse_response(client=client, response=response),
    )


def sync_detailed(
    *,
    client: AuthenticatedClient,
    body: BodySearchByUpload,
    k: int | Unset = 10,
    min_score: float | Unset = UNSET,
    mode: SearchByUploadMode | Unset = SearchByUploadMode.SHAPE,
    explain: bool | Unset = False,
    points: int | Unset = 0,
    assembly_id: UUID | Unset = UNSET,
    where_used: bool | Unset = False,
    size_tolerance: float | Unset = UNSET,
    size_weight: float | Unset = 0.0,
    metadata: MetadataFilter | Unset = UNSET,
    metadata_ranges: MetadataRanges | Unset = UNSET,
    size_length_gte: float | Unset = UNSET,
    size_length_lte: float | Unset = UNSET,
    size_width_gte: float | Unset = UNSET,
    size_width_lte: float | Unset = UNSET,
    size_height_gte: float | Unset = UNSET,
    size_height_lte: float | Unset = UNSET,
    size_area_gte: float | Unset = UNSET,
    size_area_lte: float | Unset = UNSET,
    size_volume_gte: float | Unset = UNSET,
    size_volume_lte: float | Unset = UNSET,

) -> Response[Problem | SearchResponse]:
    """ Find the models most similar to an uploaded scan (nothing is stored)

     The scan is described synchronously, which takes seconds; at most SHAPESEARCH_SEARCH_MAX_CONCURRENT
    at a time (beyond: 503 with Retry-After). A file seen before (same bytes, same mode) is answered
    without describing it again. Same filters, score and order as /v1/models/{id}/similar. mode=scan is
    for scans, one side of a part or several sides merged: every model is compared both whole and as
    each of its virtual partial views (SHAPESEARCH_SCAN_VIEWS per model); a model's distance is that of
    its best entry, one result per model (SHAPESEARCH_SCAN_BOUNDARY_WEIGHTS, off by default, also fades
    the query's points near an open rim). mode=shape (the default) compares whole models only, which
    suits complete meshes. Order: with mode=shape the max(4k, 40) nearest models are ordered by
    distance^2 + r, r a model's mean cosine to its 10 most alike other models (a hub discount,
    SHAPESEARCH_SEARCH_HUB_NEIGHBOURS; 0 turns it off), so a part near everything comes a little later,
    and then re-ranked k-reciprocally among themselves (a model whose own nearest include the query
    comes earlier), the discount's first answer kept first (SHAPESEARCH_SEARCH_RECIPROCAL=false keeps
    the discount's order); score, the plain similarity, need not fall along the list; a model with the
    query's own descriptor stays first. With mode=scan, of the max(4k, 40) nearest models by best entry
    the one of least key comes first, key the best entry's distance^2 + r/2, r that entry's mean best
    cosine to the 5 other models most alike it; the others, joined with the 120 models nearest the first
    answer's whole descriptor, follow in the order mode=shape gives them for that descriptor, so the
    first answer's kind comes next, also where the scan itself missed it (off with
    SHAPESEARCH_SEARCH_HUB_NEIGHBOURS=0). Numeric metadata: `metadata.KEY.gte=N` and
    `metadata.KEY.lte=N` keep models whose KEY holds a number in the range. Size (sizes compare in
    millimetres where the models' units are known, as given otherwise): `size.length.gte=`,
    `size.length.lte=` (and width, height, area, volume) keep models in a range, before the top-k cut;
    `size_tolerance=0.1` keeps models whose three extents are each within +-10% of the query's;
    `size_weight=w` (default 0) ranks by D = sqrt(d^2 + w * sum of ln(extent ratio)^2) over the three
    extents, and score = 1 - D^2/4. Models without a size pass no size filter. The query's size is the
    upload's, in its `units`; a partial scan under-measures. With `explain=true` the first 5 results (at
    most; the others get none, to bound the cost: about a few tenths of a second each) carry an
    `explanation`: the scan placed on the part at the part's scale (the scan's units are unknown), the
    scan's RMS distance from the part and the share of the part it covers; `points=N` adds up to N
    points of both, aligned, with their deviations.

    Args:
        k (int | Unset):  Default: 10.
        min_score (float | Unset):
        mode (SearchByUploadMode | Unset): shape (default): whole models; scan: for scans, partial
            or merged, the best entry (whole or a view) of each model. Default:
            SearchByUploadMode.SHAPE.
        explain (bool | Unset): Place the scan on each of the first 5 results (at most) and say
            how well it fits (`explanation`). Default: False.
        points (int | Unset): With `explain`: up to this many points of the part and of the
            aligned scan in each explanation. Default: 0.
        assembly_id (UUID | Unset): Only the parts that this assembly places (the id of a model
            uploaded with `assembly=split`); an id that places nothing: no results.
        where_used (bool | Unset): true: each result also lists `where_used`, the assemblies that
            contain it or a copy of it (as `GET /v1/models/{id}/where-used`). Default: False.
        size_tolerance (float | Unset): Keep models whose three extents are each within this
            relative tolerance of the query's (0.1: +-10%).
        size_weight (float | Unset): Weight of the size term in the ranking distance (0: the
            descriptor alone). Default: 0.0.
        metadata (MetadataFilter | Unset): Keep models whose metadata KEY equals the value: one
            query parameter metadata.KEY=VALUE per property (string values compare as text, others by
            their JSON form, e.g. metadata.qty=3).
        metadata_ranges (MetadataRanges | Unset): Keep models whose metadata KEY holds a number in
            the range: one query parameter metadata.KEY.gte=N or metadata.KEY.lte=N per property.
        size_length_gte (float | Unset):
        size_length_lte (float | Unset):
        size_width_gte (float | Unset):
        size_width_lte (float | Unset):
        size_height_gte (float | Unset):
        size_height_lte (float | Unset):
        size_area_gte (float | Unset):
        size_area_lte (float | Unset):
        size_volume_gte (float | Unset):
        size_volume_lte (float | Unset):
        body (BodySearchByUpload):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[Problem | SearchResponse]
     """


    kwargs = _get_kwargs(
        body=body,
k=k,
min_score=min_score,
mode=mode,
explain=explain,
points=points,
assembly_id=assembly_id,
where_used=where_used,
size_tolerance=size_tolerance,
size_weight=size_weight,
metadata=metadata,
metadata_ranges=metadata_ranges,
size_length_gte=size_length_gte,
size_length_lte=size_length_lte,
size_width_gte=size_width_gte,
size_width_lte=size_width_lte,
size_height_gte=size_height_gte,
size_height_lte=size_height_lte,
size_area_gte=size_area_gte,
size_area_lte=size_area_lte,
size_volume_gte=size_volume_gte,
size_volume_lte=size_volume_lte,

    )

    response = client.get_httpx_client().request(
        **kwargs,
    )

    return _build_response(client=client, response=response)

def sync(
    *,
    client: AuthenticatedClient,
    body: BodySearchByUpload,
    k: int | Unset = 10,
    min_score: float | Unset = UNSET,
    mode: SearchByUploadMode | Unset = SearchByUploadMode.SHAPE,
    explain: bool | Unset = False,
    points: int | Unset = 0,
    assembly_id: UUID | Unset = UNSET,
    where_used: bool | Unset = False,
    size_tolerance: float | Unset = UNSET,
    size_weight: float | Unset = 0.0,
    metadata: MetadataFilter | Unset = UNSET,
    metadata_ranges: MetadataRanges | Unset = UNSET,
    size_length_gte: float | Unset = UNSET,
    size_length_lte: float | Unset = UNSET,
    size_width_gte: float | Unset = UNSET,
    size_width_lte: float | Unset = UNSET,
    size_height_gte: float | Unset = UNSET,
    size_height_lte: float | Unset = UNSET,
    size_area_gte: float | Unset = UNSET,
    size_area_lte: float | Unset = UNSET,
    size_volume_gte: float | Unset = UNSET,
    size_volume_lte: float | Unset = UNSET,

) -> Problem | SearchResponse | None:
    """ Find the models most similar to an uploaded scan (nothing is stored)

     The scan is described synchronously, which takes seconds; at most SHAPESEARCH_SEARCH_MAX_CONCURRENT
    at a time (beyond: 503 with Retry-After). A file seen before (same bytes, same mode) is answered
    without describing it again. Same filters, score and order as /v1/models/{id}/similar. mode=scan is
    for scans, one side of a part or several sides merged: every model is compared both whole and as
    each of its virtual partial views (SHAPESEARCH_SCAN_VIEWS per model); a model's distance is that of
    its best entry, one result per model (SHAPESEARCH_SCAN_BOUNDARY_WEIGHTS, off by default, also fades
    the query's points near an open rim). mode=shape (the default) compares whole models only, which
    suits complete meshes. Order: with mode=shape the max(4k, 40) nearest models are ordered by
    distance^2 + r, r a model's mean cosine to its 10 most alike other models (a hub discount,
    SHAPESEARCH_SEARCH_HUB_NEIGHBOURS; 0 turns it off), so a part near everything comes a little later,
    and then re-ranked k-reciprocally among themselves (a model whose own nearest include the query
    comes earlier), the discount's first answer kept first (SHAPESEARCH_SEARCH_RECIPROCAL=false keeps
    the discount's order); score, the plain similarity, need not fall along the list; a model with the
    query's own descriptor stays first. With mode=scan, of the max(4k, 40) nearest models by best entry
    the one of least key comes first, key the best entry's distance^2 + r/2, r that entry's mean best
    cosine to the 5 other models most alike it; the others, joined with the 120 models nearest the first
    answer's whole descriptor, follow in the order mode=shape gives them for that descriptor, so the
    first answer's kind comes next, also where the scan itself missed it (off with
    SHAPESEARCH_SEARCH_HUB_NEIGHBOURS=0). Numeric metadata: `metadata.KEY.gte=N` and
    `metadata.KEY.lte=N` keep models whose KEY holds a number in the range. Size (sizes compare in
    millimetres where the models' units are known, as given otherwise): `size.length.gte=`,
    `size.length.lte=` (and width, height, area, volume) keep models in a range, before the top-k cut;
    `size_tolerance=0.1` keeps models whose three extents are each within +-10% of the query's;
    `size_weight=w` (default 0) ranks by D = sqrt(d^2 + w * sum of ln(extent ratio)^2) over the three
    extents, and score = 1 - D^2/4. Models without a size pass no size filter. The query's size is the
    upload's, in its `units`; a partial scan under-measures. With `explain=true` the first 5 results (at
    most; the others get none, to bound the cost: about a few tenths of a second each) carry an
    `explanation`: the scan placed on the part at the part's scale (the scan's units are unknown), the
    scan's RMS distance from the part and the share of the part it covers; `points=N` adds up to N
    points of both, aligned, with their deviations.

    Args:
        k (int | Unset):  Default: 10.
        min_score (float | Unset):
        mode (SearchByUploadMode | Unset): shape (default): whole models; scan: for scans, partial
            or merged, the best entry (whole or a view) of each model. Default:
            SearchByUploadMode.SHAPE.
        explain (bool | Unset): Place the scan on each of the first 5 results (at most) and say
            how well it fits (`explanation`). Default: False.
        points (int | Unset): With `explain`: up to this many points of the part and of the
            aligned scan in each explanation. Default: 0.
        assembly_id (UUID | Unset): Only the parts that this assembly places (the id of a model
            uploaded with `assembly=split`); an id that places nothing: no results.
        where_used (bool | Unset): true: each result also lists `where_used`, the assemblies that
            contain it or a copy of it (as `GET /v1/models/{id}/where-used`). Default: False.
        size_tolerance (float | Unset): Keep models whose three extents are each within this
            relative tolerance of the query's (0.1: +-10%).
        size_weight (float | Unset): Weight of the size term in the ranking distance (0: the
            descriptor alone). Default: 0.0.
        metadata (MetadataFilter | Unset): Keep models whose metadata KEY equals the value: one
            query parameter metadata.KEY=VALUE per property (string values compare as text, others by
            their JSON form, e.g. metadata.qty=3).
        metadata_ranges (MetadataRanges | Unset): Keep models whose metadata KEY holds a number in
            the range: one query parameter metadata.KEY.gte=N or metadata.KEY.lte=N per property.
        size_length_gte (float | Unset):
        size_length_lte (float | Unset):
        size_width_gte (float | Unset):
        size_width_lte (float | Unset):
        size_height_gte (float | Unset):
        size_height_lte (float | Unset):
        size_area_gte (float | Unset):
        size_area_lte (float | Unset):
        size_volume_gte (float | Unset):
        size_volume_lte (float | Unset):
        body (BodySearchByUpload):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Problem | SearchResponse
     """


    return sync_detailed(
        client=client,
body=body,
k=k,
min_score=min_score,
mode=mode,
explain=explain,
points=points,
assembly_id=assembly_id,
where_used=where_used,
size_tolerance=size_tolerance,
size_weight=size_weight,
metadata=metadata,
metadata_ranges=metadata_ranges,
size_length_gte=size_length_gte,
size_length_lte=size_length_lte,
size_width_gte=size_width_gte,
size_width_lte=size_width_lte,
size_height_gte=size_height_gte,
size_height_lte=size_height_lte,
size_area_gte=size_area_gte,
size_area_lte=size_area_lte,
size_volume_gte=size_volume_gte,
size_volume_lte=size_volume_lte,

    ).parsed

async def asyncio_detailed(
    *,
    client: AuthenticatedClient,
    body: BodySearchByUpload,
    k: int | Unset = 10,
    min_score: float | Unset = UNSET,
    mode: SearchByUploadMode | Unset = SearchByUploadMode.SHAPE,
    explain: bool | Unset = False,
    points: int | Unset = 0,
    assembly_id: UUID | Unset = UNSET,
    where_used: bool | Unset = False,
    size_tolerance: float | Unset = UNSET,
    size_weight: float | Unset = 0.0,
    metadata: MetadataFilter | Unset = UNSET,
    metadata_ranges: MetadataRanges | Unset = UNSET,
    size_length_gte: float | Unset = UNSET,
    size_length_lte: float | Unset = UNSET,
    size_width_gte: float | Unset = UNSET,
    size_width_lte: float | Unset = UNSET,
    size_height_gte: float | Unset = UNSET,
    size_height_lte: float | Unset = UNSET,
    size_area_gte: float | Unset = UNSET,
    size_area_lte: float | Unset = UNSET,
    size_volume_gte: float | Unset = UNSET,
    size_volume_lte: float | Unset = UNSET,

) -> Response[Problem | SearchResponse]:
    """ Find the models most similar to an uploaded scan (nothing is stored)

     The scan is described synchronously, which takes seconds; at most SHAPESEARCH_SEARCH_MAX_CONCURRENT
    at a time (beyond: 503 with Retry-After). A file seen before (same bytes, same mode) is answered
    without describing it again. Same filters, score and order as /v1/models/{id}/similar. mode=scan is
    for scans, one side of a part or several sides merged: every model is compared both whole and as
    each of its virtual partial views (SHAPESEARCH_SCAN_VIEWS per model); a model's distance is that of
    its best entry, one result per model (SHAPESEARCH_SCAN_BOUNDARY_WEIGHTS, off by default, also fades
    the query's points near an open rim). mode=shape (the default) compares whole models only, which
    suits complete meshes. Order: with mode=shape the max(4k, 40) nearest models are ordered by
    distance^2 + r, r a model's mean cosine to its 10 most alike other models (a hub discount,
    SHAPESEARCH_SEARCH_HUB_NEIGHBOURS; 0 turns it off), so a part near everything comes a little later,
    and then re-ranked k-reciprocally among themselves (a model whose own nearest include the query
    comes earlier), the discount's first answer kept first (SHAPESEARCH_SEARCH_RECIPROCAL=false keeps
    the discount's order); score, the plain similarity, need not fall along the list; a model with the
    query's own descriptor stays first. With mode=scan, of the max(4k, 40) nearest models by best entry
    the one of least key comes first, key the best entry's distance^2 + r/2, r that entry's mean best
    cosine to the 5 other models most alike it; the others, joined with the 120 models nearest the first
    answer's whole descriptor, follow in the order mode=shape gives them for that descriptor, so the
    first answer's kind comes next, also where the scan itself missed it (off with
    SHAPESEARCH_SEARCH_HUB_NEIGHBOURS=0). Numeric metadata: `metadata.KEY.gte=N` and
    `metadata.KEY.lte=N` keep models whose KEY holds a number in the range. Size (sizes compare in
    millimetres where the models' units are known, as given otherwise): `size.length.gte=`,
    `size.length.lte=` (and width, height, area, volume) keep models in a range, before the top-k cut;
    `size_tolerance=0.1` keeps models whose three extents are each within +-10% of the query's;
    `size_weight=w` (default 0) ranks by D = sqrt(d^2 + w * sum of ln(extent ratio)^2) over the three
    extents, and score = 1 - D^2/4. Models without a size pass no size filter. The query's size is the
    upload's, in its `units`; a partial scan under-measures. With `explain=true` the first 5 results (at
    most; the others get none, to bound the cost: about a few tenths of a second each) carry an
    `explanation`: the scan placed on the part at the part's scale (the scan's units are unknown), the
    scan's RMS distance from the part and the share of the part it covers; `points=N` adds up to N
    points of both, aligned, with their deviations.

    Args:
        k (int | Unset):  Default: 10.
        min_score (float | Unset):
        mode (SearchByUploadMode | Unset): shape (default): whole models; scan: for scans, partial
            or merged, the best entry (whole or a view) of each model. Default:
            SearchByUploadMode.SHAPE.
        explain (bool | Unset): Place the scan on each of the first 5 results (at most) and say
            how well it fits (`explanation`). Default: False.
        points (int | Unset): With `explain`: up to this many points of the part and of the
            aligned scan in each explanation. Default: 0.
        assembly_id (UUID | Unset): Only the parts that this assembly places (the id of a model
            uploaded with `assembly=split`); an id that places nothing: no results.
        where_used (bool | Unset): true: each result also lists `where_used`, the assemblies that
            contain it or a copy of it (as `GET /v1/models/{id}/where-used`). Default: False.
        size_tolerance (float | Unset): Keep models whose three extents are each within this
            relative tolerance of the query's (0.1: +-10%).
        size_weight (float | Unset): Weight of the size term in the ranking distance (0: the
            descriptor alone). Default: 0.0.
        metadata (MetadataFilter | Unset): Keep models whose metadata KEY equals the value: one
            query parameter metadata.KEY=VALUE per property (string values compare as text, others by
            their JSON form, e.g. metadata.qty=3).
        metadata_ranges (MetadataRanges | Unset): Keep models whose metadata KEY holds a number in
            the range: one query parameter metadata.KEY.gte=N or metadata.KEY.lte=N per property.
        size_length_gte (float | Unset):
        size_length_lte (float | Unset):
        size_width_gte (float | Unset):
        size_width_lte (float | Unset):
        size_height_gte (float | Unset):
        size_height_lte (float | Unset):
        size_area_gte (float | Unset):
        size_area_lte (float | Unset):
        size_volume_gte (float | Unset):
        size_volume_lte (float | Unset):
        body (BodySearchByUpload):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[Problem | SearchResponse]
     """


    kwargs = _get_kwargs(
        body=body,
k=k,
min_score=min_score,
mode=mode,
explain=explain,
points=points,
assembly_id=assembly_id,
where_used=where_used,
size_tolerance=size_tolerance,
size_weight=size_weight,
metadata=metadata,
metadata_ranges=metadata_ranges,
size_length_gte=size_length_gte,
size_length_lte=size_length_lte,
size_width_gte=size_width_gte,
size_width_lte=size_width_lte,
size_height_gte=size_height_gte,
size_height_lte=size_height_lte,
size_area_gte=size_area_gte,
size_area_lte=size_area_lte,
size_volume_gte=size_volume_gte,
size_volume_lte=size_volume_lte,

    )

    response = await client.get_async_httpx_client().request(
        **kwargs
    )

    return _build_response(client=client, response=response)

async def asyncio(
    *,
    client: AuthenticatedClient,
    body: BodySearchByUpload,
    k: int | Unset = 10,
    min_score: float | Unset = UNSET,
    mode: SearchByUploadMode | Unset = SearchByUploadMode.SHAPE,
    explain: bool | Unset = False,
    points: int | Unset = 0,
    assembly_id: UUID | Unset = UNSET,
    where_used: bool | Unset = False,
    size_tolerance: float | Unset = UNSET,
    size_weight: float | Unset = 0.0,
    metadata: MetadataFilter | Unset = UNSET,
    metadata_ranges: MetadataRanges | Unset = UNSET,
    size_length_gte: float | Unset = UNSET,
    size_length_lte: float | Unset = UNSET,
    size_width_gte: float | Unset = UNSET,
    size_width_lte: float | Unset = UNSET,
    size_height_gte: float | Unset = UNSET,
    size_height_lte: float | Unset = UNSET,
    size_area_gte: float | Unset = UNSET,
    size_area_lte: float | Unset = UNSET,
    size_volume_gte: float | Unset = UNSET,
    size_volume_lte: float | Unset = UNSET,

) -> Problem | SearchResponse | None:
    """ Find the models most similar to an uploaded scan (nothing is stored)

     The scan is described synchronously, which takes seconds; at most SHAPESEARCH_SEARCH_MAX_CONCURRENT
    at a time (beyond: 503 with Retry-After). A file seen before (same bytes, same mode) is answered
    without describing it again. Same filters, score and order as /v1/models/{id}/similar. mode=scan is
    for scans, one side of a part or several sides merged: every model is compared both whole and as
    each of its virtual partial views (SHAPESEARCH_SCAN_VIEWS per model); a model's distance is that of
    its best entry, one result per model (SHAPESEARCH_SCAN_BOUNDARY_WEIGHTS, off by default, also fades
    the query's points near an open rim). mode=shape (the default) compares whole models only, which
    suits complete meshes. Order: with mode=shape the max(4k, 40) nearest models are ordered by
    distance^2 + r, r a model's mean cosine to its 10 most alike other models (a hub discount,
    SHAPESEARCH_SEARCH_HUB_NEIGHBOURS; 0 turns it off), so a part near everything comes a little later,
    and then re-ranked k-reciprocally among themselves (a model whose own nearest include the query
    comes earlier), the discount's first answer kept first (SHAPESEARCH_SEARCH_RECIPROCAL=false keeps
    the discount's order); score, the plain similarity, need not fall along the list; a model with the
    query's own descriptor stays first. With mode=scan, of the max(4k, 40) nearest models by best entry
    the one of least key comes first, key the best entry's distance^2 + r/2, r that entry's mean best
    cosine to the 5 other models most alike it; the others, joined with the 120 models nearest the first
    answer's whole descriptor, follow in the order mode=shape gives them for that descriptor, so the
    first answer's kind comes next, also where the scan itself missed it (off with
    SHAPESEARCH_SEARCH_HUB_NEIGHBOURS=0). Numeric metadata: `metadata.KEY.gte=N` and
    `metadata.KEY.lte=N` keep models whose KEY holds a number in the range. Size (sizes compare in
    millimetres where the models' units are known, as given otherwise): `size.length.gte=`,
    `size.length.lte=` (and width, height, area, volume) keep models in a range, before the top-k cut;
    `size_tolerance=0.1` keeps models whose three extents are each within +-10% of the query's;
    `size_weight=w` (default 0) ranks by D = sqrt(d^2 + w * sum of ln(extent ratio)^2) over the three
    extents, and score = 1 - D^2/4. Models without a size pass no size filter. The query's size is the
    upload's, in its `units`; a partial scan under-measures. With `explain=true` the first 5 results (at
    most; the others get none, to bound the cost: about a few tenths of a second each) carry an
    `explanation`: the scan placed on the part at the part's scale (the scan's units are unknown), the
    scan's RMS distance from the part and the share of the part it covers; `points=N` adds up to N
    points of both, aligned, with their deviations.

    Args:
        k (int | Unset):  Default: 10.
        min_score (float | Unset):
        mode (SearchByUploadMode | Unset): shape (default): whole models; scan: for scans, partial
            or merged, the best entry (whole or a view) of each model. Default:
            SearchByUploadMode.SHAPE.
        explain (bool | Unset): Place the scan on each of the first 5 results (at most) and say
            how well it fits (`explanation`). Default: False.
        points (int | Unset): With `explain`: up to this many points of the part and of the
            aligned scan in each explanation. Default: 0.
        assembly_id (UUID | Unset): Only the parts that this assembly places (the id of a model
            uploaded with `assembly=split`); an id that places nothing: no results.
        where_used (bool | Unset): true: each result also lists `where_used`, the assemblies that
            contain it or a copy of it (as `GET /v1/models/{id}/where-used`). Default: False.
        size_tolerance (float | Unset): Keep models whose three extents are each within this
            relative tolerance of the query's (0.1: +-10%).
        size_weight (float | Unset): Weight of the size term in the ranking distance (0: the
            descriptor alone). Default: 0.0.
        metadata (MetadataFilter | Unset): Keep models whose metadata KEY equals the value: one
            query parameter metadata.KEY=VALUE per property (string values compare as text, others by
            their JSON form, e.g. metadata.qty=3).
        metadata_ranges (MetadataRanges | Unset): Keep models whose metadata KEY holds a number in
            the range: one query parameter metadata.KEY.gte=N or metadata.KEY.lte=N per property.
        size_length_gte (float | Unset):
        size_length_lte (float | Unset):
        size_width_gte (float | Unset):
        size_width_lte (float | Unset):
        size_height_gte (float | Unset):
        size_height_lte (float | Unset):
        size_area_gte (float | Unset):
        size_area_lte (float | Unset):
        size_volume_gte (float | Unset):
        size_volume_lte (float | Unset):
        body (BodySearchByUpload):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Problem | SearchResponse
     """


    return (await asyncio_detailed(
        client=client,
body=body,
k=k,
min_score=min_score,
mode=mode,
explain=explain,
points=points,
assembly_id=assembly_id,
where_used=where_used,
size_tolerance=size_tolerance,
size_weight=size_weight,
metadata=metadata,
metadata_ranges=metadata_ranges,
size_length_gte=size_length_gte,
size_length_lte=size_length_lte,
size_width_gte=size_width_gte,
size_width_lte=size_width_lte,
size_height_gte=size_height_gte,
size_height_lte=size_height_lte,
size_area_gte=size_area_gte,
size_area_lte=size_area_lte,
size_volume_gte=size_volume_gte,
size_volume_lte=size_volume_lte,

    )).parsed
