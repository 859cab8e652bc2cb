from http import HTTPStatus
from typing import Any, cast
from urllib.parse import quote

import httpx

from ...client import AuthenticatedClient, Client
from ...types import Response, UNSET
from ... import errors

from ...models.duplicates_request import DuplicatesRequest
from ...models.job_resource import JobResource
from ...models.problem import Problem
from ...types import UNSET, Unset
from typing import cast



def _get_kwargs(
    *,
    body: DuplicatesRequest | None | Unset = UNSET,

) -> dict[str, Any]:
    headers: dict[str, Any] = {}


    

    

    _kwargs: dict[str, Any] = {
        "method": "post",
        "url": "/v1/duplicates",
    }

    
    if isinstance(body, DuplicatesRequest):
        _kwargs["json"] = body.to_dict()
    else:
        _kwargs["json"] = body

    headers["Content-Type"] = "application/json"

    _kwargs["headers"] = headers
    return _kwargs



def _parse_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> JobResource | Problem | None:
    if response.status_code == 202:
        response_202 = JobResource.from_dict(response.json())



        return response_202

    if response.status_code == 400:
        response_400 = Problem.from_dict(response.json())



        return response_400

    if response.status_code == 401:
        response_401 = Problem.from_dict(response.json())



        return response_401

    if response.status_code == 413:
        response_413 = Problem.from_dict(response.json())



        return response_413

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


def _build_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Response[JobResource | Problem]:
    return Response(
        status_code=HTTPStatus(response.status_code),
        content=response.content,
        headers=response.headers,
        parsed=_parse_response(client=client, response=response),
    )


def sync_detailed(
    *,
    client: AuthenticatedClient,
    body: DuplicatesRequest | None | Unset = UNSET,

) -> Response[JobResource | Problem]:
    """ Compute the duplicates report (a job)

     Connected components of the k-nearest-neighbour graph of the tenant's ready descriptors of one
    descriptor_version (k = 16), keeping edges with score >= min_score. The descriptor is intrinsic and
    scale-normalised: mirror images and uniformly scaled copies group with their part: without
    size_tolerance the report answers 'which parts are alike at any size' (families); with it (e.g.
    0.02: every extent within 2%, in millimetres where units are known) 'do we already have this part'
    (true duplicates). A worker computes the report and stores it; poll the job (Location), then page it
    with GET /v1/duplicates and the same parameters. While a job with the same parameters is queued or
    running, that job is answered.

    Args:
        body (DuplicatesRequest | None | Unset):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[JobResource | Problem]
     """


    kwargs = _get_kwargs(
        body=body,

    )

    response = client.get_httpx_client().request(
        **kwargs,
    )

    return _build_response(client=client, response=response)

def sync(
    *,
    client: AuthenticatedClient,
    body: DuplicatesRequest | None | Unset = UNSET,

) -> JobResource | Problem | None:
    """ Compute the duplicates report (a job)

     Connected components of the k-nearest-neighbour graph of the tenant's ready descriptors of one
    descriptor_version (k = 16), keeping edges with score >= min_score. The descriptor is intrinsic and
    scale-normalised: mirror images and uniformly scaled copies group with their part: without
    size_tolerance the report answers 'which parts are alike at any size' (families); with it (e.g.
    0.02: every extent within 2%, in millimetres where units are known) 'do we already have this part'
    (true duplicates). A worker computes the report and stores it; poll the job (Location), then page it
    with GET /v1/duplicates and the same parameters. While a job with the same parameters is queued or
    running, that job is answered.

    Args:
        body (DuplicatesRequest | None | Unset):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        JobResource | Problem
     """


    return sync_detailed(
        client=client,
body=body,

    ).parsed

async def asyncio_detailed(
    *,
    client: AuthenticatedClient,
    body: DuplicatesRequest | None | Unset = UNSET,

) -> Response[JobResource | Problem]:
    """ Compute the duplicates report (a job)

     Connected components of the k-nearest-neighbour graph of the tenant's ready descriptors of one
    descriptor_version (k = 16), keeping edges with score >= min_score. The descriptor is intrinsic and
    scale-normalised: mirror images and uniformly scaled copies group with their part: without
    size_tolerance the report answers 'which parts are alike at any size' (families); with it (e.g.
    0.02: every extent within 2%, in millimetres where units are known) 'do we already have this part'
    (true duplicates). A worker computes the report and stores it; poll the job (Location), then page it
    with GET /v1/duplicates and the same parameters. While a job with the same parameters is queued or
    running, that job is answered.

    Args:
        body (DuplicatesRequest | None | Unset):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[JobResource | Problem]
     """


    kwargs = _get_kwargs(
        body=body,

    )

    response = await client.get_async_httpx_client().request(
        **kwargs
    )

    return _build_response(client=client, response=response)

async def asyncio(
    *,
    client: AuthenticatedClient,
    body: DuplicatesRequest | None | Unset = UNSET,

) -> JobResource | Problem | None:
    """ Compute the duplicates report (a job)

     Connected components of the k-nearest-neighbour graph of the tenant's ready descriptors of one
    descriptor_version (k = 16), keeping edges with score >= min_score. The descriptor is intrinsic and
    scale-normalised: mirror images and uniformly scaled copies group with their part: without
    size_tolerance the report answers 'which parts are alike at any size' (families); with it (e.g.
    0.02: every extent within 2%, in millimetres where units are known) 'do we already have this part'
    (true duplicates). A worker computes the report and stores it; poll the job (Location), then page it
    with GET /v1/duplicates and the same parameters. While a job with the same parameters is queued or
    running, that job is answered.

    Args:
        body (DuplicatesRequest | None | Unset):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        JobResource | Problem
     """


    return (await asyncio_detailed(
        client=client,
body=body,

    )).parsed
