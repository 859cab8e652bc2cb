from http import HTTPStatus
from typing import Any, cast
from urllib.parse import quote

import httpx

from ...client import AuthenticatedClient, Client
from ...types import Response, UNSET
from ... import errors

from ...models.problem import Problem
from ...models.recovered import Recovered
from ...models.recovery import Recovery
from typing import cast



def _get_kwargs(
    webhook_id: str,
    *,
    body: Recovery,

) -> dict[str, Any]:
    headers: dict[str, Any] = {}


    

    

    _kwargs: dict[str, Any] = {
        "method": "post",
        "url": "/v1/webhooks/{webhook_id}/recover".format(webhook_id=quote(str(webhook_id), safe=""),),
    }

    _kwargs["json"] = body.to_dict()

    headers["Content-Type"] = "application/json"

    _kwargs["headers"] = headers
    return _kwargs



def _parse_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Problem | Recovered | None:
    if response.status_code == 202:
        response_202 = Recovered.from_dict(response.json())



        return response_202

    if response.status_code == 400:
        response_400 = Problem.from_dict(response.json())



        return response_400

    if response.status_code == 401:
        response_401 = Problem.from_dict(response.json())



        return response_401

    if response.status_code == 404:
        response_404 = Problem.from_dict(response.json())



        return response_404

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


def _build_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Response[Problem | Recovered]:
    return Response(
        status_code=HTTPStatus(response.status_code),
        content=response.content,
        headers=response.headers,
        parsed=_parse_response(client=client, response=response),
    )


def sync_detailed(
    webhook_id: str,
    *,
    client: AuthenticatedClient,
    body: Recovery,

) -> Response[Problem | Recovered]:
    """ Queue the endpoint's failed deliveries again

     For a receiver that was away longer than the retries last (SHAPESEARCH_WEBHOOK_MAX_ATTEMPTS
    attempts, backing off to SHAPESEARCH_WEBHOOK_BACKOFF_MAX_SECONDS): every failed delivery (since
    `since`) is sent again, oldest first, one at a time, each with a new round of attempts and its own
    webhook-id, so a receiver that did get one deduplicates it.

    Args:
        webhook_id (str):
        body (Recovery):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[Problem | Recovered]
     """


    kwargs = _get_kwargs(
        webhook_id=webhook_id,
body=body,

    )

    response = client.get_httpx_client().request(
        **kwargs,
    )

    return _build_response(client=client, response=response)

def sync(
    webhook_id: str,
    *,
    client: AuthenticatedClient,
    body: Recovery,

) -> Problem | Recovered | None:
    """ Queue the endpoint's failed deliveries again

     For a receiver that was away longer than the retries last (SHAPESEARCH_WEBHOOK_MAX_ATTEMPTS
    attempts, backing off to SHAPESEARCH_WEBHOOK_BACKOFF_MAX_SECONDS): every failed delivery (since
    `since`) is sent again, oldest first, one at a time, each with a new round of attempts and its own
    webhook-id, so a receiver that did get one deduplicates it.

    Args:
        webhook_id (str):
        body (Recovery):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Problem | Recovered
     """


    return sync_detailed(
        webhook_id=webhook_id,
client=client,
body=body,

    ).parsed

async def asyncio_detailed(
    webhook_id: str,
    *,
    client: AuthenticatedClient,
    body: Recovery,

) -> Response[Problem | Recovered]:
    """ Queue the endpoint's failed deliveries again

     For a receiver that was away longer than the retries last (SHAPESEARCH_WEBHOOK_MAX_ATTEMPTS
    attempts, backing off to SHAPESEARCH_WEBHOOK_BACKOFF_MAX_SECONDS): every failed delivery (since
    `since`) is sent again, oldest first, one at a time, each with a new round of attempts and its own
    webhook-id, so a receiver that did get one deduplicates it.

    Args:
        webhook_id (str):
        body (Recovery):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[Problem | Recovered]
     """


    kwargs = _get_kwargs(
        webhook_id=webhook_id,
body=body,

    )

    response = await client.get_async_httpx_client().request(
        **kwargs
    )

    return _build_response(client=client, response=response)

async def asyncio(
    webhook_id: str,
    *,
    client: AuthenticatedClient,
    body: Recovery,

) -> Problem | Recovered | None:
    """ Queue the endpoint's failed deliveries again

     For a receiver that was away longer than the retries last (SHAPESEARCH_WEBHOOK_MAX_ATTEMPTS
    attempts, backing off to SHAPESEARCH_WEBHOOK_BACKOFF_MAX_SECONDS): every failed delivery (since
    `since`) is sent again, oldest first, one at a time, each with a new round of attempts and its own
    webhook-id, so a receiver that did get one deduplicates it.

    Args:
        webhook_id (str):
        body (Recovery):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Problem | Recovered
     """


    return (await asyncio_detailed(
        webhook_id=webhook_id,
client=client,
body=body,

    )).parsed
