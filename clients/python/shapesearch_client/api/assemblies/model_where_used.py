from http import HTTPStatus
from typing import Any, cast
from urllib.parse import quote

import httpx

from ...client import AuthenticatedClient, Client
from ...types import Response, UNSET
from ... import errors

from ...models.problem import Problem
from ...models.where_used_response import WhereUsedResponse
from typing import cast



def _get_kwargs(
    model_id: str,

) -> dict[str, Any]:
    

    

    

    _kwargs: dict[str, Any] = {
        "method": "get",
        "url": "/v1/models/{model_id}/where-used".format(model_id=quote(str(model_id), safe=""),),
    }


    return _kwargs



def _parse_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Problem | WhereUsedResponse | None:
    if response.status_code == 200:
        response_200 = WhereUsedResponse.from_dict(response.json())



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


def _build_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Response[Problem | WhereUsedResponse]:
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

) -> Response[Problem | WhereUsedResponse]:
    """ The assemblies that contain a part

     The assemblies that place this model, and those that place a part the index finds to be a copy of it
    (likeness `copy` and sizes within 3 %; decided when asked, so a part uploaded on its own or in
    another assembly is recognised), each with its count. Copies are only looked for once the model is
    ready.

    Args:
        model_id (str):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[Problem | WhereUsedResponse]
     """


    kwargs = _get_kwargs(
        model_id=model_id,

    )

    response = client.get_httpx_client().request(
        **kwargs,
    )

    return _build_response(client=client, response=response)

def sync(
    model_id: str,
    *,
    client: AuthenticatedClient,

) -> Problem | WhereUsedResponse | None:
    """ The assemblies that contain a part

     The assemblies that place this model, and those that place a part the index finds to be a copy of it
    (likeness `copy` and sizes within 3 %; decided when asked, so a part uploaded on its own or in
    another assembly is recognised), each with its count. Copies are only looked for once the model is
    ready.

    Args:
        model_id (str):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Problem | WhereUsedResponse
     """


    return sync_detailed(
        model_id=model_id,
client=client,

    ).parsed

async def asyncio_detailed(
    model_id: str,
    *,
    client: AuthenticatedClient,

) -> Response[Problem | WhereUsedResponse]:
    """ The assemblies that contain a part

     The assemblies that place this model, and those that place a part the index finds to be a copy of it
    (likeness `copy` and sizes within 3 %; decided when asked, so a part uploaded on its own or in
    another assembly is recognised), each with its count. Copies are only looked for once the model is
    ready.

    Args:
        model_id (str):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[Problem | WhereUsedResponse]
     """


    kwargs = _get_kwargs(
        model_id=model_id,

    )

    response = await client.get_async_httpx_client().request(
        **kwargs
    )

    return _build_response(client=client, response=response)

async def asyncio(
    model_id: str,
    *,
    client: AuthenticatedClient,

) -> Problem | WhereUsedResponse | None:
    """ The assemblies that contain a part

     The assemblies that place this model, and those that place a part the index finds to be a copy of it
    (likeness `copy` and sizes within 3 %; decided when asked, so a part uploaded on its own or in
    another assembly is recognised), each with its count. Copies are only looked for once the model is
    ready.

    Args:
        model_id (str):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Problem | WhereUsedResponse
     """


    return (await asyncio_detailed(
        model_id=model_id,
client=client,

    )).parsed
