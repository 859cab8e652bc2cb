"""What the viewer draws of one model: ``GET /v1/models/{id}/preview``.

The preview is the binary blob of ``app.ingest.previews`` (points, HKS per time, eigenvalues),
served with an ETag so a browser fetches it once per description. The database page's plot
comes from ``GET /v1/stats/cutoff`` (``app.api.routes.stats``).
"""

from __future__ import annotations

import hashlib

from fastapi import APIRouter, Header, Response

from app.api.deps import SessionDep
from app.api.lookups import load_model
from app.api.problems import Problem, problem_responses
from app.auth.dependency import TenantDep
from app.ingest.previews import PREVIEW_POINTS

__all__ = ["PREVIEW_MEDIA_TYPE", "router"]

router = APIRouter(prefix="/v1", tags=["viewer"])

PREVIEW_MEDIA_TYPE = "application/vnd.shapesearch.preview"


@router.get(
    "/models/{model_id}/preview",
    response_class=Response,
    responses={
        200: {
            "description": f"Up to {PREVIEW_POINTS} points of the model with their log scaled "
            "heat kernel signature at every time of the descriptor's grid, and the "
            "eigenvalues; binary layout in app/ingest/previews.py (little-endian: b'SSP1', uint32 "
            "n, s, k; float32 times[s], eigenvalues[k]; float16 points[n,3], log_hks[n,s]).",
            "content": {PREVIEW_MEDIA_TYPE: {"schema": {"type": "string", "format": "binary"}}},
        },
        304: {"description": "Not modified (If-None-Match matched the ETag)."},
        **problem_responses(401, 404, 409),
    },
    summary="A small point/HKS preview of a ready model, for drawing it",
)
def get_model_preview(
    model_id: str,
    tenant: TenantDep,
    session: SessionDep,
    if_none_match: str | None = Header(default=None),
) -> Response:
    model = load_model(session, tenant, model_id)
    if model.status != "ready":
        raise Problem(
            "model-not-ready",
            f"Model {model.id} is {model.status}; a preview needs a ready model.",
            model_status=model.status,
        )
    blob = model.preview
    if blob is None:
        raise Problem(
            "preview-not-available",
            f"Model {model.id} was described before previews were stored; upload it again "
            "to get one.",
        )
    # The preview changes only when the model is described again (new version, new bytes).
    digest = hashlib.sha256(f"{model.descriptor_version}\0".encode() + blob).hexdigest()[:32]
    etag = f'"{digest}"'
    headers = {"ETag": etag, "Cache-Control": "private, no-cache"}
    if if_none_match is not None and etag in [tag.strip() for tag in if_none_match.split(",")]:
        return Response(status_code=304, headers=headers)
    return Response(content=blob, media_type=PREVIEW_MEDIA_TYPE, headers=headers)
