from http import HTTPStatus
from typing import Any, cast
from urllib.parse import quote

import httpx

from ...client import AuthenticatedClient, Client
from ...types import Response, UNSET
from ... import errors

from ...models.job_resource import JobResource
from ...models.problem import Problem
from ...types import UNSET, Unset
from typing import cast



def _get_kwargs(
    model_id: str,
    *,
    background: bool | Unset = False,

) -> dict[str, Any]:
    

    

    params: dict[str, Any] = {}

    params["background"] = background


    params = {k: v for k, v in params.items() if v is not UNSET and v is not None}


    _kwargs: dict[str, Any] = {
        "method": "post",
        "url": "/v1/models/{model_id}/redescribe".format(model_id=quote(str(model_id), safe=""),),
        "params": params,
    }


    return _kwargs



def _parse_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> JobResource | Problem | None:
    if response.status_code == 202:
        response_202 = JobResource.from_dict(response.json())



        return response_202

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
    model_id: str,
    *,
    client: AuthenticatedClient,
    background: bool | Unset = False,

) -> Response[JobResource | Problem]:
    """ Describe a model again from its stored original

     With the service's current engine settings. A ready model stays ready and searchable with its
    previous descriptor until the new one replaces it.

    Args:
        model_id (str):
        background (bool | Unset): true for one of many re-describes sent together (a PLM system
            re-describing a product line): its job takes turns with the tenant's uploads instead of
            holding them up, as `shapesearch redescribe` does. Scheduling only. Default: False.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[JobResource | Problem]
     """


    kwargs = _get_kwargs(
        model_id=model_id,
background=background,

    )

    response = client.get_httpx_client().request(
        **kwargs,
    )

    return _build_response(client=client, response=response)

def sync(
    model_id: str,
    *,
    client: AuthenticatedClient,
    background: bool | Unset = False,

) -> JobResource | Problem | None:
    """ Describe a model again from its stored original

     With the service's current engine settings. A ready model stays ready and searchable with its
    previous descriptor until the new one replaces it.

    Args:
        model_id (str):
        background (bool | Unset): true for one of many re-describes sent together (a PLM system
            re-describing a product line): its job takes turns with the tenant's uploads instead of
            holding them up, as `shapesearch redescribe` does. Scheduling only. Default: False.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        JobResource | Problem
     """


    return sync_detailed(
        model_id=model_id,
client=client,
background=background,

    ).parsed

async def asyncio_detailed(
    model_id: str,
    *,
    client: AuthenticatedClient,
    background: bool | Unset = False,

) -> Response[JobResource | Problem]:
    """ Describe a model again from its stored original

     With the service's current engine settings. A ready model stays ready and searchable with its
    previous descriptor until the new one replaces it.

    Args:
        model_id (str):
        background (bool | Unset): true for one of many re-describes sent together (a PLM system
            re-describing a product line): its job takes turns with the tenant's uploads instead of
            holding them up, as `shapesearch redescribe` does. Scheduling only. Default: False.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[JobResource | Problem]
     """


    kwargs = _get_kwargs(
        model_id=model_id,
background=background,

    )

    response = await client.get_async_httpx_client().request(
        **kwargs
    )

    return _build_response(client=client, response=response)

async def asyncio(
    model_id: str,
    *,
    client: AuthenticatedClient,
    background: bool | Unset = False,

) -> JobResource | Problem | None:
    """ Describe a model again from its stored original

     With the service's current engine settings. A ready model stays ready and searchable with its
    previous descriptor until the new one replaces it.

    Args:
        model_id (str):
        background (bool | Unset): true for one of many re-describes sent together (a PLM system
            re-describing a product line): its job takes turns with the tenant's uploads instead of
            holding them up, as `shapesearch redescribe` does. Scheduling only. Default: False.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        JobResource | Problem
     """


    return (await asyncio_detailed(
        model_id=model_id,
client=client,
background=background,

    )).parsed
