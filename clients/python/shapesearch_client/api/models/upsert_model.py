from http import HTTPStatus
from typing import Any, cast
from urllib.parse import quote

import httpx

from ...client import AuthenticatedClient, Client
from ...types import Response, UNSET
from ... import errors

from ...models.body_upsert_model import BodyUpsertModel
from ...models.model_resource import ModelResource
from ...models.problem import Problem
from typing import cast



def _get_kwargs(
    external_id: str,
    *,
    body: BodyUpsertModel,

) -> dict[str, Any]:
    headers: dict[str, Any] = {}


    

    

    _kwargs: dict[str, Any] = {
        "method": "put",
        "url": "/v1/models/by-external-id/{external_id}".format(external_id=quote(str(external_id), safe=""),),
    }

    _kwargs["files"] = body.to_multipart()

    headers["Content-Type"] = "multipart/form-data; boundary=+++"

    _kwargs["headers"] = headers
    return _kwargs



def _parse_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> ModelResource | Problem | None:
    if response.status_code == 200:
        response_200 = ModelResource.from_dict(response.json())



        return response_200

    if response.status_code == 201:
        response_201 = ModelResource.from_dict(response.json())



        return response_201

    if response.status_code == 202:
        response_202 = ModelResource.from_dict(response.json())



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


def _build_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Response[ModelResource | Problem]:
    return Response(
        status_code=HTTPStatus(response.status_code),
        content=response.content,
        headers=response.headers,
        parsed=_parse_response(client=client, response=response),
    )


def sync_detailed(
    external_id: str,
    *,
    client: AuthenticatedClient,
    body: BodyUpsertModel,

) -> Response[ModelResource | Problem]:
    """ Create or update the model with this external id

     Absent: created (201 + job). Present with the same file (sha256): only name and metadata change
    (200, no job). A new file: a new revision is described (202 + job) while the model keeps its id and
    its previous descriptor stays searchable; when the job completes the new descriptor replaces it
    atomically.

    Args:
        external_id (str): Your id; unique per tenant.
        body (BodyUpsertModel):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[ModelResource | Problem]
     """


    kwargs = _get_kwargs(
        external_id=external_id,
body=body,

    )

    response = client.get_httpx_client().request(
        **kwargs,
    )

    return _build_response(client=client, response=response)

def sync(
    external_id: str,
    *,
    client: AuthenticatedClient,
    body: BodyUpsertModel,

) -> ModelResource | Problem | None:
    """ Create or update the model with this external id

     Absent: created (201 + job). Present with the same file (sha256): only name and metadata change
    (200, no job). A new file: a new revision is described (202 + job) while the model keeps its id and
    its previous descriptor stays searchable; when the job completes the new descriptor replaces it
    atomically.

    Args:
        external_id (str): Your id; unique per tenant.
        body (BodyUpsertModel):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        ModelResource | Problem
     """


    return sync_detailed(
        external_id=external_id,
client=client,
body=body,

    ).parsed

async def asyncio_detailed(
    external_id: str,
    *,
    client: AuthenticatedClient,
    body: BodyUpsertModel,

) -> Response[ModelResource | Problem]:
    """ Create or update the model with this external id

     Absent: created (201 + job). Present with the same file (sha256): only name and metadata change
    (200, no job). A new file: a new revision is described (202 + job) while the model keeps its id and
    its previous descriptor stays searchable; when the job completes the new descriptor replaces it
    atomically.

    Args:
        external_id (str): Your id; unique per tenant.
        body (BodyUpsertModel):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[ModelResource | Problem]
     """


    kwargs = _get_kwargs(
        external_id=external_id,
body=body,

    )

    response = await client.get_async_httpx_client().request(
        **kwargs
    )

    return _build_response(client=client, response=response)

async def asyncio(
    external_id: str,
    *,
    client: AuthenticatedClient,
    body: BodyUpsertModel,

) -> ModelResource | Problem | None:
    """ Create or update the model with this external id

     Absent: created (201 + job). Present with the same file (sha256): only name and metadata change
    (200, no job). A new file: a new revision is described (202 + job) while the model keeps its id and
    its previous descriptor stays searchable; when the job completes the new descriptor replaces it
    atomically.

    Args:
        external_id (str): Your id; unique per tenant.
        body (BodyUpsertModel):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        ModelResource | Problem
     """


    return (await asyncio_detailed(
        external_id=external_id,
client=client,
body=body,

    )).parsed
