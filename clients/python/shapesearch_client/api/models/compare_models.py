from http import HTTPStatus
from typing import Any, cast
from urllib.parse import quote

import httpx

from ...client import AuthenticatedClient, Client
from ...types import Response, UNSET
from ... import errors

from ...models.compare_response import CompareResponse
from ...models.problem import Problem
from ...types import UNSET, Unset
from typing import cast



def _get_kwargs(
    model_id: str,
    other_id: str,
    *,
    scale: bool | Unset = False,
    tolerance: float | Unset = UNSET,
    points: int | Unset = 0,

) -> dict[str, Any]:
    

    

    params: dict[str, Any] = {}

    params["scale"] = scale

    params["tolerance"] = tolerance

    params["points"] = points


    params = {k: v for k, v in params.items() if v is not UNSET and v is not None}


    _kwargs: dict[str, Any] = {
        "method": "get",
        "url": "/v1/models/{model_id}/compare/{other_id}".format(model_id=quote(str(model_id), safe=""),other_id=quote(str(other_id), safe=""),),
        "params": params,
    }


    return _kwargs



def _parse_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> CompareResponse | Problem | None:
    if response.status_code == 200:
        response_200 = CompareResponse.from_dict(response.json())



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


def _build_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Response[CompareResponse | Problem]:
    return Response(
        status_code=HTTPStatus(response.status_code),
        content=response.content,
        headers=response.headers,
        parsed=_parse_response(client=client, response=response),
    )


def sync_detailed(
    model_id: str,
    other_id: str,
    *,
    client: AuthenticatedClient,
    scale: bool | Unset = False,
    tolerance: float | Unset = UNSET,
    points: int | Unset = 0,

) -> Response[CompareResponse | Problem]:
    """ Why two parts match: one placed on the other, and their deviations

     Places `other_id` on `model_id` (a rotation and translation, with `scale=true` also a uniform
    scale): principal axes with their ambiguities tried (sign flips, and turns where two spreads are
    close), each start refined by ICP, the best result kept. Then, in the model's units, how far each
    part's points lie from the other's surface (as sampled) both ways: RMS, mean, 95th percentile,
    maximum and the share within `tolerance` (default 1 % of the larger bounding-box diagonal), and the
    other's extents over the model's along the model's principal axes. `points=N` adds N points of each
    part, aligned, with their deviations. Both models must be ready (409 `model-not-ready`). Computed on
    request on at most 3000 points of each part (a few tenths of a second) and kept in a small cache; at
    most a few run at once, each within 5 s: beyond, 503 `busy` with Retry-After.

    Args:
        model_id (str):
        other_id (str):
        scale (bool | Unset): Also find a uniform scale (parts in other units, or a family member
            at another size). Default: False.
        tolerance (float | Unset): Distance within which a point counts as matched, in the model's
            units (default: 1 % of the larger bounding-box diagonal).
        points (int | Unset): Return up to this many points of each part (a seeded subset of at
            most 3000) with their deviations. Default: 0.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[CompareResponse | Problem]
     """


    kwargs = _get_kwargs(
        model_id=model_id,
other_id=other_id,
scale=scale,
tolerance=tolerance,
points=points,

    )

    response = client.get_httpx_client().request(
        **kwargs,
    )

    return _build_response(client=client, response=response)

def sync(
    model_id: str,
    other_id: str,
    *,
    client: AuthenticatedClient,
    scale: bool | Unset = False,
    tolerance: float | Unset = UNSET,
    points: int | Unset = 0,

) -> CompareResponse | Problem | None:
    """ Why two parts match: one placed on the other, and their deviations

     Places `other_id` on `model_id` (a rotation and translation, with `scale=true` also a uniform
    scale): principal axes with their ambiguities tried (sign flips, and turns where two spreads are
    close), each start refined by ICP, the best result kept. Then, in the model's units, how far each
    part's points lie from the other's surface (as sampled) both ways: RMS, mean, 95th percentile,
    maximum and the share within `tolerance` (default 1 % of the larger bounding-box diagonal), and the
    other's extents over the model's along the model's principal axes. `points=N` adds N points of each
    part, aligned, with their deviations. Both models must be ready (409 `model-not-ready`). Computed on
    request on at most 3000 points of each part (a few tenths of a second) and kept in a small cache; at
    most a few run at once, each within 5 s: beyond, 503 `busy` with Retry-After.

    Args:
        model_id (str):
        other_id (str):
        scale (bool | Unset): Also find a uniform scale (parts in other units, or a family member
            at another size). Default: False.
        tolerance (float | Unset): Distance within which a point counts as matched, in the model's
            units (default: 1 % of the larger bounding-box diagonal).
        points (int | Unset): Return up to this many points of each part (a seeded subset of at
            most 3000) with their deviations. Default: 0.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        CompareResponse | Problem
     """


    return sync_detailed(
        model_id=model_id,
other_id=other_id,
client=client,
scale=scale,
tolerance=tolerance,
points=points,

    ).parsed

async def asyncio_detailed(
    model_id: str,
    other_id: str,
    *,
    client: AuthenticatedClient,
    scale: bool | Unset = False,
    tolerance: float | Unset = UNSET,
    points: int | Unset = 0,

) -> Response[CompareResponse | Problem]:
    """ Why two parts match: one placed on the other, and their deviations

     Places `other_id` on `model_id` (a rotation and translation, with `scale=true` also a uniform
    scale): principal axes with their ambiguities tried (sign flips, and turns where two spreads are
    close), each start refined by ICP, the best result kept. Then, in the model's units, how far each
    part's points lie from the other's surface (as sampled) both ways: RMS, mean, 95th percentile,
    maximum and the share within `tolerance` (default 1 % of the larger bounding-box diagonal), and the
    other's extents over the model's along the model's principal axes. `points=N` adds N points of each
    part, aligned, with their deviations. Both models must be ready (409 `model-not-ready`). Computed on
    request on at most 3000 points of each part (a few tenths of a second) and kept in a small cache; at
    most a few run at once, each within 5 s: beyond, 503 `busy` with Retry-After.

    Args:
        model_id (str):
        other_id (str):
        scale (bool | Unset): Also find a uniform scale (parts in other units, or a family member
            at another size). Default: False.
        tolerance (float | Unset): Distance within which a point counts as matched, in the model's
            units (default: 1 % of the larger bounding-box diagonal).
        points (int | Unset): Return up to this many points of each part (a seeded subset of at
            most 3000) with their deviations. Default: 0.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[CompareResponse | Problem]
     """


    kwargs = _get_kwargs(
        model_id=model_id,
other_id=other_id,
scale=scale,
tolerance=tolerance,
points=points,

    )

    response = await client.get_async_httpx_client().request(
        **kwargs
    )

    return _build_response(client=client, response=response)

async def asyncio(
    model_id: str,
    other_id: str,
    *,
    client: AuthenticatedClient,
    scale: bool | Unset = False,
    tolerance: float | Unset = UNSET,
    points: int | Unset = 0,

) -> CompareResponse | Problem | None:
    """ Why two parts match: one placed on the other, and their deviations

     Places `other_id` on `model_id` (a rotation and translation, with `scale=true` also a uniform
    scale): principal axes with their ambiguities tried (sign flips, and turns where two spreads are
    close), each start refined by ICP, the best result kept. Then, in the model's units, how far each
    part's points lie from the other's surface (as sampled) both ways: RMS, mean, 95th percentile,
    maximum and the share within `tolerance` (default 1 % of the larger bounding-box diagonal), and the
    other's extents over the model's along the model's principal axes. `points=N` adds N points of each
    part, aligned, with their deviations. Both models must be ready (409 `model-not-ready`). Computed on
    request on at most 3000 points of each part (a few tenths of a second) and kept in a small cache; at
    most a few run at once, each within 5 s: beyond, 503 `busy` with Retry-After.

    Args:
        model_id (str):
        other_id (str):
        scale (bool | Unset): Also find a uniform scale (parts in other units, or a family member
            at another size). Default: False.
        tolerance (float | Unset): Distance within which a point counts as matched, in the model's
            units (default: 1 % of the larger bounding-box diagonal).
        points (int | Unset): Return up to this many points of each part (a seeded subset of at
            most 3000) with their deviations. Default: 0.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        CompareResponse | Problem
     """


    return (await asyncio_detailed(
        model_id=model_id,
other_id=other_id,
client=client,
scale=scale,
tolerance=tolerance,
points=points,

    )).parsed
