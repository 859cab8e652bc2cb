"""The answers of the assembly calls (issue 76): an assembly's parts, where a part is used,
and the ``assembly`` form field of an upload."""

from __future__ import annotations

import uuid
from typing import Annotated, Any, Literal

from fastapi import Form
from pydantic import BaseModel, Field

from app.api.schemas import ModelSummary, WhereUsedEntry, size_of

__all__ = [
    "AssemblyField",
    "PartPointsResponse",
    "PartUse",
    "PartsResponse",
    "WhereUsedEntry",
    "WhereUsedResponse",
    "summary_of",
]

#: The form field that splits an uploaded assembly into part models.
AssemblyField = Annotated[
    Literal["whole", "split"] | None,
    Form(description="`split`: the file is an assembly (GLB, glTF, 3MF, OBJ: its geometry "
         "nodes; STEP or IGES: its solids); besides the model of the whole assembly, each "
         "distinct part becomes a model of its own, its instances counted and placed "
         "(`GET /v1/models/{id}/parts`). `whole`: one model. Absent: "
         "SHAPESEARCH_ASSEMBLY_DEFAULT (`whole` unless set; with `split`, a file that "
         "places one part once stays one model)."),
]


def summary_of(row: Any) -> ModelSummary:
    """A ``ModelSummary`` of a row with ``id, external_id, name, meta`` and the size
    columns."""
    return ModelSummary(
        id=row.id, external_id=row.external_id, name=row.name, metadata=row.meta or {},
        size=size_of(row.size_length, row.size_width, row.size_height, row.size_area,
                     row.size_volume, row.units),
    )


class PartUse(BaseModel):
    model: ModelSummary = Field(description="The part model.")
    count: int = Field(description="How many times the assembly places it.")
    placements: list[list[float]] = Field(
        description="Each instance's 4x4 transform from the part's frame to the assembly's, "
        "16 numbers row-major (translation in the 4th, 8th and 12th).",
    )


class PartsResponse(BaseModel):
    assembly_id: uuid.UUID
    parts: list[PartUse] = Field(
        description="The distinct parts, in the order the file first places them; empty for "
        "a model that was not uploaded as a split assembly.",
    )


class PartPointsResponse(BaseModel):
    assembly_id: uuid.UUID
    part_ids: list[uuid.UUID] = Field(
        description="The assembly's parts, as `GET /v1/models/{id}/parts` lists them.")
    points: list[list[float]] = Field(
        description="Points on the whole assembly, x y z in its file's coordinates (the "
        "stored sample of its describe, evenly thinned to at most `points`).")
    labels: list[int] = Field(
        description="Per point, the index in `part_ids` of the part it lies on (its own "
        "points placed at every placement, the nearest); -1: on none known (a part not "
        "described yet).")


class WhereUsedResponse(BaseModel):
    model_id: uuid.UUID
    assemblies: list[WhereUsedEntry] = Field(description="Oldest assembly first.")
