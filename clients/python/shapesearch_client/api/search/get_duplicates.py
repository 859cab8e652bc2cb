from http import HTTPStatus
from typing import Any, cast
from urllib.parse import quote

import httpx

from ...client import AuthenticatedClient, Client
from ...types import Response, UNSET
from ... import errors

from ...models.duplicate_report_resource import DuplicateReportResource
from ...models.problem import Problem
from ...types import UNSET, Unset
from typing import cast



def _get_kwargs(
    *,
    min_score: float | Unset = 0.98,
    size_tolerance: float | Unset = UNSET,
    descriptor_version: str | Unset = UNSET,
    limit: int | Unset = 50,
    cursor: str | Unset = '',
    where_used: bool | Unset = False,

) -> dict[str, Any]:
    

    

    params: dict[str, Any] = {}

    params["min_score"] = min_score

    params["size_tolerance"] = size_tolerance

    params["descriptor_version"] = descriptor_version

    params["limit"] = limit

    params["cursor"] = cursor

    params["where_used"] = where_used


    params = {k: v for k, v in params.items() if v is not UNSET and v is not None}


    _kwargs: dict[str, Any] = {
        "method": "get",
        "url": "/v1/duplicates",
        "params": params,
    }


    return _kwargs



def _parse_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> DuplicateReportResource | Problem | None:
    if response.status_code == 200:
        response_200 = DuplicateReportResource.from_dict(response.json())



        return response_200

    if response.status_code == 401:
        response_401 = Problem.from_dict(response.json())



        return response_401

    if response.status_code == 404:
        response_404 = Problem.from_dict(response.json())



        return response_404

    if response.status_code == 422:
        response_422 = Problem.from_dict(response.json())



        return response_422

    if response.status_code == 503:
        response_503 = Problem.from_dict(response.json())



        return response_503

    if client.raise_on_unexpected_status:
        raise errors.UnexpectedStatus(response.status_code, response.content)
    else:
        return None


def _build_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Response[DuplicateReportResource | Problem]:
    return Response(
        status_code=HTTPStatus(response.status_code),
        content=response.content,
        headers=response.headers,
        parsed=_parse_response(client=client, response=response),
    )


def sync_detailed(
    *,
    client: AuthenticatedClient,
    min_score: float | Unset = 0.98,
    size_tolerance: float | Unset = UNSET,
    descriptor_version: str | Unset = UNSET,
    limit: int | Unset = 50,
    cursor: str | Unset = '',
    where_used: bool | Unset = False,

) -> Response[DuplicateReportResource | Problem]:
    """ A page of the stored duplicates report

     Connected components of the k-nearest-neighbour graph of the tenant's ready descriptors of one
    descriptor_version (k = 16), keeping edges with score >= min_score. The descriptor is intrinsic and
    scale-normalised: mirror images and uniformly scaled copies group with their part: without
    size_tolerance the report answers 'which parts are alike at any size' (families); with it (e.g.
    0.02: every extent within 2%, in millimetres where units are known) 'do we already have this part'
    (true duplicates). The newest report computed (POST /v1/duplicates) with exactly these parameters;
    404 `duplicates-report-not-found` when there is none. With a cursor, the next page of the report the
    cursor came from (the parameters are then ignored): pages never shift, whatever models are added
    meanwhile; `stale` says whether they were.

    Args:
        min_score (float | Unset):  Default: 0.98.
        size_tolerance (float | Unset): As the report was asked with; absent: the report without
            one (families).
        descriptor_version (str | Unset): Default: the service's current one.
        limit (int | Unset):  Default: 50.
        cursor (str | Unset): The previous page's next_cursor, unchanged; empty or absent: the
            first page. Default: ''.
        where_used (bool | Unset): true: each group also lists `where_used`, the assemblies that
            place its members (the same part used across assemblies). Default: False.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[DuplicateReportResource | Problem]
     """


    kwargs = _get_kwargs(
        min_score=min_score,
size_tolerance=size_tolerance,
descriptor_version=descriptor_version,
limit=limit,
cursor=cursor,
where_used=where_used,

    )

    response = client.get_httpx_client().request(
        **kwargs,
    )

    return _build_response(client=client, response=response)

def sync(
    *,
    client: AuthenticatedClient,
    min_score: float | Unset = 0.98,
    size_tolerance: float | Unset = UNSET,
    descriptor_version: str | Unset = UNSET,
    limit: int | Unset = 50,
    cursor: str | Unset = '',
    where_used: bool | Unset = False,

) -> DuplicateReportResource | Problem | None:
    """ A page of the stored duplicates report

     Connected components of the k-nearest-neighbour graph of the tenant's ready descriptors of one
    descriptor_version (k = 16), keeping edges with score >= min_score. The descriptor is intrinsic and
    scale-normalised: mirror images and uniformly scaled copies group with their part: without
    size_tolerance the report answers 'which parts are alike at any size' (families); with it (e.g.
    0.02: every extent within 2%, in millimetres where units are known) 'do we already have this part'
    (true duplicates). The newest report computed (POST /v1/duplicates) with exactly these parameters;
    404 `duplicates-report-not-found` when there is none. With a cursor, the next page of the report the
    cursor came from (the parameters are then ignored): pages never shift, whatever models are added
    meanwhile; `stale` says whether they were.

    Args:
        min_score (float | Unset):  Default: 0.98.
        size_tolerance (float | Unset): As the report was asked with; absent: the report without
            one (families).
        descriptor_version (str | Unset): Default: the service's current one.
        limit (int | Unset):  Default: 50.
        cursor (str | Unset): The previous page's next_cursor, unchanged; empty or absent: the
            first page. Default: ''.
        where_used (bool | Unset): true: each group also lists `where_used`, the assemblies that
            place its members (the same part used across assemblies). Default: False.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        DuplicateReportResource | Problem
     """


    return sync_detailed(
        client=client,
min_score=min_score,
size_tolerance=size_tolerance,
descriptor_version=descriptor_version,
limit=limit,
cursor=cursor,
where_used=where_used,

    ).parsed

async def asyncio_detailed(
    *,
    client: AuthenticatedClient,
    min_score: float | Unset = 0.98,
    size_tolerance: float | Unset = UNSET,
    descriptor_version: str | Unset = UNSET,
    limit: int | Unset = 50,
    cursor: str | Unset = '',
    where_used: bool | Unset = False,

) -> Response[DuplicateReportResource | Problem]:
    """ A page of the stored duplicates report

     Connected components of the k-nearest-neighbour graph of the tenant's ready descriptors of one
    descriptor_version (k = 16), keeping edges with score >= min_score. The descriptor is intrinsic and
    scale-normalised: mirror images and uniformly scaled copies group with their part: without
    size_tolerance the report answers 'which parts are alike at any size' (families); with it (e.g.
    0.02: every extent within 2%, in millimetres where units are known) 'do we already have this part'
    (true duplicates). The newest report computed (POST /v1/duplicates) with exactly these parameters;
    404 `duplicates-report-not-found` when there is none. With a cursor, the next page of the report the
    cursor came from (the parameters are then ignored): pages never shift, whatever models are added
    meanwhile; `stale` says whether they were.

    Args:
        min_score (float | Unset):  Default: 0.98.
        size_tolerance (float | Unset): As the report was asked with; absent: the report without
            one (families).
        descriptor_version (str | Unset): Default: the service's current one.
        limit (int | Unset):  Default: 50.
        cursor (str | Unset): The previous page's next_cursor, unchanged; empty or absent: the
            first page. Default: ''.
        where_used (bool | Unset): true: each group also lists `where_used`, the assemblies that
            place its members (the same part used across assemblies). Default: False.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[DuplicateReportResource | Problem]
     """


    kwargs = _get_kwargs(
        min_score=min_score,
size_tolerance=size_tolerance,
descriptor_version=descriptor_version,
limit=limit,
cursor=cursor,
where_used=where_used,

    )

    response = await client.get_async_httpx_client().request(
        **kwargs
    )

    return _build_response(client=client, response=response)

async def asyncio(
    *,
    client: AuthenticatedClient,
    min_score: float | Unset = 0.98,
    size_tolerance: float | Unset = UNSET,
    descriptor_version: str | Unset = UNSET,
    limit: int | Unset = 50,
    cursor: str | Unset = '',
    where_used: bool | Unset = False,

) -> DuplicateReportResource | Problem | None:
    """ A page of the stored duplicates report

     Connected components of the k-nearest-neighbour graph of the tenant's ready descriptors of one
    descriptor_version (k = 16), keeping edges with score >= min_score. The descriptor is intrinsic and
    scale-normalised: mirror images and uniformly scaled copies group with their part: without
    size_tolerance the report answers 'which parts are alike at any size' (families); with it (e.g.
    0.02: every extent within 2%, in millimetres where units are known) 'do we already have this part'
    (true duplicates). The newest report computed (POST /v1/duplicates) with exactly these parameters;
    404 `duplicates-report-not-found` when there is none. With a cursor, the next page of the report the
    cursor came from (the parameters are then ignored): pages never shift, whatever models are added
    meanwhile; `stale` says whether they were.

    Args:
        min_score (float | Unset):  Default: 0.98.
        size_tolerance (float | Unset): As the report was asked with; absent: the report without
            one (families).
        descriptor_version (str | Unset): Default: the service's current one.
        limit (int | Unset):  Default: 50.
        cursor (str | Unset): The previous page's next_cursor, unchanged; empty or absent: the
            first page. Default: ''.
        where_used (bool | Unset): true: each group also lists `where_used`, the assemblies that
            place its members (the same part used across assemblies). Default: False.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        DuplicateReportResource | Problem
     """


    return (await asyncio_detailed(
        client=client,
min_score=min_score,
size_tolerance=size_tolerance,
descriptor_version=descriptor_version,
limit=limit,
cursor=cursor,
where_used=where_used,

    )).parsed
