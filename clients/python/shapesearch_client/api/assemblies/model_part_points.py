from http import HTTPStatus
from typing import Any, cast
from urllib.parse import quote

import httpx

from ...client import AuthenticatedClient, Client
from ...types import Response, UNSET
from ... import errors

from ...models.part_points_response import PartPointsResponse
from ...models.problem import Problem
from ...types import UNSET, Unset
from typing import cast



def _get_kwargs(
    model_id: str,
    *,
    points: int | Unset = 2000,

) -> dict[str, Any]:
    

    

    params: dict[str, Any] = {}

    params["points"] = points


    params = {k: v for k, v in params.items() if v is not UNSET and v is not None}


    _kwargs: dict[str, Any] = {
        "method": "get",
        "url": "/v1/models/{model_id}/parts/points".format(model_id=quote(str(model_id), safe=""),),
        "params": params,
    }


    return _kwargs



def _parse_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> PartPointsResponse | Problem | None:
    if response.status_code == 200:
        response_200 = PartPointsResponse.from_dict(response.json())



        return response_200

    if response.status_code == 401:
        response_401 = Problem.from_dict(response.json())



        return response_401

    if response.status_code == 404:
        response_404 = Problem.from_dict(response.json())



        return response_404

    if response.status_code == 409:
        response_409 = Problem.from_dict(response.json())



        return response_409

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


def _build_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Response[PartPointsResponse | Problem]:
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
    points: int | Unset = 2000,

) -> Response[PartPointsResponse | Problem]:
    """ Points on an assembly, each with the part it lies on

     What a viewer needs to highlight a part in its assembly: points on the whole assembly, each labelled
    with one of its parts (every placement of it). 409 `model-not-ready` until the assembly is
    described; a part not described yet labels nothing.

    Args:
        model_id (str):
        points (int | Unset): At most this many points. Default: 2000.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[PartPointsResponse | Problem]
     """


    kwargs = _get_kwargs(
        model_id=model_id,
points=points,

    )

    response = client.get_httpx_client().request(
        **kwargs,
    )

    return _build_response(client=client, response=response)

def sync(
    model_id: str,
    *,
    client: AuthenticatedClient,
    points: int | Unset = 2000,

) -> PartPointsResponse | Problem | None:
    """ Points on an assembly, each with the part it lies on

     What a viewer needs to highlight a part in its assembly: points on the whole assembly, each labelled
    with one of its parts (every placement of it). 409 `model-not-ready` until the assembly is
    described; a part not described yet labels nothing.

    Args:
        model_id (str):
        points (int | Unset): At most this many points. Default: 2000.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        PartPointsResponse | Problem
     """


    return sync_detailed(
        model_id=model_id,
client=client,
points=points,

    ).parsed

async def asyncio_detailed(
    model_id: str,
    *,
    client: AuthenticatedClient,
    points: int | Unset = 2000,

) -> Response[PartPointsResponse | Problem]:
    """ Points on an assembly, each with the part it lies on

     What a viewer needs to highlight a part in its assembly: points on the whole assembly, each labelled
    with one of its parts (every placement of it). 409 `model-not-ready` until the assembly is
    described; a part not described yet labels nothing.

    Args:
        model_id (str):
        points (int | Unset): At most this many points. Default: 2000.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[PartPointsResponse | Problem]
     """


    kwargs = _get_kwargs(
        model_id=model_id,
points=points,

    )

    response = await client.get_async_httpx_client().request(
        **kwargs
    )

    return _build_response(client=client, response=response)

async def asyncio(
    model_id: str,
    *,
    client: AuthenticatedClient,
    points: int | Unset = 2000,

) -> PartPointsResponse | Problem | None:
    """ Points on an assembly, each with the part it lies on

     What a viewer needs to highlight a part in its assembly: points on the whole assembly, each labelled
    with one of its parts (every placement of it). 409 `model-not-ready` until the assembly is
    described; a part not described yet labels nothing.

    Args:
        model_id (str):
        points (int | Unset): At most this many points. Default: 2000.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        PartPointsResponse | Problem
     """


    return (await asyncio_detailed(
        model_id=model_id,
client=client,
points=points,

    )).parsed
