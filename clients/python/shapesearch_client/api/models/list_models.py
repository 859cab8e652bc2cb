from http import HTTPStatus
from typing import Any, cast
from urllib.parse import quote

import httpx

from ...client import AuthenticatedClient, Client
from ...types import Response, UNSET
from ... import errors

from ...models.list_models_status import ListModelsStatus
from ...models.model_list import ModelList
from ...models.problem import Problem
from ...types import UNSET, Unset
from typing import cast
from uuid import UUID



def _get_kwargs(
    *,
    status: ListModelsStatus | Unset = UNSET,
    external_id: str | Unset = UNSET,
    limit: int | Unset = 50,
    cursor: str | Unset = '',
    assembly_id: UUID | Unset = UNSET,

) -> dict[str, Any]:
    

    

    params: dict[str, Any] = {}

    json_status: str | Unset = UNSET
    if not isinstance(status, Unset):
        json_status = status.value

    params["status"] = json_status

    params["external_id"] = external_id

    params["limit"] = limit

    params["cursor"] = cursor

    json_assembly_id: str | Unset = UNSET
    if not isinstance(assembly_id, Unset):
        json_assembly_id = str(assembly_id)
    params["assembly_id"] = json_assembly_id


    params = {k: v for k, v in params.items() if v is not UNSET and v is not None}


    _kwargs: dict[str, Any] = {
        "method": "get",
        "url": "/v1/models",
        "params": params,
    }


    return _kwargs



def _parse_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> ModelList | Problem | None:
    if response.status_code == 200:
        response_200 = ModelList.from_dict(response.json())



        return response_200

    if response.status_code == 401:
        response_401 = Problem.from_dict(response.json())



        return response_401

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


def _build_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Response[ModelList | Problem]:
    return Response(
        status_code=HTTPStatus(response.status_code),
        content=response.content,
        headers=response.headers,
        parsed=_parse_response(client=client, response=response),
    )


def sync_detailed(
    *,
    client: AuthenticatedClient,
    status: ListModelsStatus | Unset = UNSET,
    external_id: str | Unset = UNSET,
    limit: int | Unset = 50,
    cursor: str | Unset = '',
    assembly_id: UUID | Unset = UNSET,

) -> Response[ModelList | Problem]:
    """ List models, newest first

    Args:
        status (ListModelsStatus | Unset):
        external_id (str | Unset):
        limit (int | Unset):  Default: 50.
        cursor (str | Unset): The previous page's next_cursor, unchanged; empty or absent: the
            first page. Default: ''.
        assembly_id (UUID | Unset): Only the parts that this assembly places (the id of a model
            uploaded with `assembly=split`); an id that places nothing: no results.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[ModelList | Problem]
     """


    kwargs = _get_kwargs(
        status=status,
external_id=external_id,
limit=limit,
cursor=cursor,
assembly_id=assembly_id,

    )

    response = client.get_httpx_client().request(
        **kwargs,
    )

    return _build_response(client=client, response=response)

def sync(
    *,
    client: AuthenticatedClient,
    status: ListModelsStatus | Unset = UNSET,
    external_id: str | Unset = UNSET,
    limit: int | Unset = 50,
    cursor: str | Unset = '',
    assembly_id: UUID | Unset = UNSET,

) -> ModelList | Problem | None:
    """ List models, newest first

    Args:
        status (ListModelsStatus | Unset):
        external_id (str | Unset):
        limit (int | Unset):  Default: 50.
        cursor (str | Unset): The previous page's next_cursor, unchanged; empty or absent: the
            first page. Default: ''.
        assembly_id (UUID | Unset): Only the parts that this assembly places (the id of a model
            uploaded with `assembly=split`); an id that places nothing: no results.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        ModelList | Problem
     """


    return sync_detailed(
        client=client,
status=status,
external_id=external_id,
limit=limit,
cursor=cursor,
assembly_id=assembly_id,

    ).parsed

async def asyncio_detailed(
    *,
    client: AuthenticatedClient,
    status: ListModelsStatus | Unset = UNSET,
    external_id: str | Unset = UNSET,
    limit: int | Unset = 50,
    cursor: str | Unset = '',
    assembly_id: UUID | Unset = UNSET,

) -> Response[ModelList | Problem]:
    """ List models, newest first

    Args:
        status (ListModelsStatus | Unset):
        external_id (str | Unset):
        limit (int | Unset):  Default: 50.
        cursor (str | Unset): The previous page's next_cursor, unchanged; empty or absent: the
            first page. Default: ''.
        assembly_id (UUID | Unset): Only the parts that this assembly places (the id of a model
            uploaded with `assembly=split`); an id that places nothing: no results.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[ModelList | Problem]
     """


    kwargs = _get_kwargs(
        status=status,
external_id=external_id,
limit=limit,
cursor=cursor,
assembly_id=assembly_id,

    )

    response = await client.get_async_httpx_client().request(
        **kwargs
    )

    return _build_response(client=client, response=response)

async def asyncio(
    *,
    client: AuthenticatedClient,
    status: ListModelsStatus | Unset = UNSET,
    external_id: str | Unset = UNSET,
    limit: int | Unset = 50,
    cursor: str | Unset = '',
    assembly_id: UUID | Unset = UNSET,

) -> ModelList | Problem | None:
    """ List models, newest first

    Args:
        status (ListModelsStatus | Unset):
        external_id (str | Unset):
        limit (int | Unset):  Default: 50.
        cursor (str | Unset): The previous page's next_cursor, unchanged; empty or absent: the
            first page. Default: ''.
        assembly_id (UUID | Unset): Only the parts that this assembly places (the id of a model
            uploaded with `assembly=split`); an id that places nothing: no results.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        ModelList | Problem
     """


    return (await asyncio_detailed(
        client=client,
status=status,
external_id=external_id,
limit=limit,
cursor=cursor,
assembly_id=assembly_id,

    )).parsed
