"""Assemblies (issue 76): an upload with ``assembly=split`` becomes the assembly model (its
whole shape, described as any upload) plus one part model per distinct geometry, and one
``assembly_parts`` row per placement; and the questions asked of them: an assembly's parts,
and where a part is used.

Splitting (``core.io.split_assembly``) runs in the sandbox, after a check of a
GLB's node graph in this process that refuses a bomb before anything is built. A part model
is an ordinary model whose file is the part's triangles in its own frame (a binary STL): the
worker describes it like any upload, so parts are searchable like any model.

Identity across assemblies is decided at query time (``where_used``): the assemblies that
hold the part itself, and those holding a part the index finds to be a copy of it (its
likeness ``copy``; without a calibration, a raw score of at least ``UNCALIBRATED_COPY``) whose
size agrees within ``SIZE_TOLERANCE`` (when both sizes are known).
"""

from __future__ import annotations

import hashlib
import re
import uuid
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import PurePosixPath
from typing import Any

import numpy as np
from sqlalchemy import Connection, delete, insert, select
from sqlalchemy.orm import Session

from app.db.models import AssemblyPart as PartRow
from app.db.models import Model
from app.ingest.revisions import create_model_rows
from app.ingest.sandbox import sandbox_of
from app.search.index import ShapeIndex
from app.search.similarity import find_similar
from app.search.sizing import extents_mm
from app.settings import Settings
from core.io import AssemblyPart, check_gltf_graph, detect_format, split_assembly, stl_bytes
from core.rank.score_calibration import calibration_for, in_words

__all__ = [
    "ASSEMBLY_FORMATS",
    "COPY_NEIGHBOURS",
    "SIZE_TOLERANCE",
    "UNCALIBRATED_COPY",
    "PartFile",
    "WhereUsed",
    "add_parts",
    "assembly_parts",
    "copies_of",
    "is_assembly",
    "split_upload",
    "splits_by_default",
    "where_used",
    "where_used_of_groups",
]

#: Relative difference of each extent under which two parts' sizes agree.
SIZE_TOLERANCE = 0.03
#: Raw score from which two parts count as copies when their descriptor layout has no
#: calibration (then the likeness is unknown).
UNCALIBRATED_COPY = 0.999
#: Nearest models the index is asked for when looking for copies of a part.
COPY_NEIGHBOURS = 20


@dataclass(frozen=True)
class PartFile:
    """One distinct part of an uploaded assembly, as the file its part model stores."""

    name: str
    content: bytes  # binary STL, in the part's own frame
    sha256: str
    placements: tuple[tuple[float, ...], ...]


def _part_files(parts: Sequence[AssemblyPart]) -> list[PartFile]:
    files = []
    for part in parts:
        content = stl_bytes(part.vertices, part.faces)
        files.append(PartFile(part.name, content, hashlib.sha256(content).hexdigest(),
                              part.placements))
    return files


#: The formats that can hold an assembly: scenes of meshes, and CAD files of solids.
ASSEMBLY_FORMATS = ("glb", "gltf", "3mf", "obj", "step", "iges")


def split_upload(settings: Settings, content: bytes, filename: str) -> list[PartFile]:
    """The parts of an uploaded assembly (at most ``assembly_max_parts``); raises
    ``InvalidShapeError`` (a glTF bomb in this process, before anything is built; every
    other refusal from the sandbox)."""
    if detect_format(filename, content[:4096]) in ("glb", "gltf"):
        check_gltf_graph(content)
    sandbox = sandbox_of(settings, max(settings.upload_check_timeout_seconds, 30.0))
    return _part_files(sandbox.run(split_assembly, content, filename,
                                   settings.assembly_max_parts))


def splits_by_default(settings: Settings, file_format: str) -> bool:
    """Whether an upload that does not say ``assembly`` is split: with
    ``assembly_default=split``, a file of a format that can hold an assembly."""
    return settings.assembly_default == "split" and file_format in ASSEMBLY_FORMATS


def is_assembly(parts: Sequence[PartFile]) -> bool:
    """Whether split parts make an assembly: more than one placement (a file of one part
    placed once is that part, one model)."""
    return sum(len(part.placements) for part in parts) > 1


def _file_stem(name: str) -> str:
    stem = PurePosixPath(name).stem or "assembly"
    return stem[:200]


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name)[:100] or "part"


def _placement_rows(tenant: str, assembly_id: uuid.UUID, part_id: uuid.UUID,
                    placements: Sequence[Sequence[float]], first: int = 0
                    ) -> list[dict[str, Any]]:
    return [
        {"tenant": tenant, "assembly_id": assembly_id, "part_id": part_id,
         "instance": first + number, "placement": [float(v) for v in placement]}
        for number, placement in enumerate(placements)
    ]


def add_parts(session: Session, assembly: Model, parts: Sequence[PartFile], *,
              background: bool = False, reuse: bool = False) -> list[uuid.UUID]:
    """Make ``parts`` the assembly's part list, in the caller's transaction: a new part
    model (with its describe job) per part, or with ``reuse`` the part model of the
    assembly's current list with the same file, kept; then the assembly's rows are replaced
    by one per placement. Part models that leave the list stay (other assemblies, or
    searches, may use them). Returns the part ids, in ``parts``' order."""
    existing: dict[str, uuid.UUID] = {}
    if reuse:
        for kept_id, sha256 in session.execute(
            select(Model.id, Model.file_sha256)
            .join(PartRow, PartRow.part_id == Model.id)
            .where(PartRow.assembly_id == assembly.id, PartRow.tenant == assembly.tenant)
            .distinct()
        ):
            existing.setdefault(sha256, kept_id)
    session.execute(delete(PartRow).where(PartRow.assembly_id == assembly.id))
    stem = _file_stem(assembly.file_name)
    ids: list[uuid.UUID] = []
    rows: dict[uuid.UUID, list[tuple[float, ...]]] = defaultdict(list)
    for part in parts:
        found = existing.get(part.sha256)
        if found is None:
            part_model = Model(
                id=uuid.uuid4(),
                tenant=assembly.tenant,
                name=f"{assembly.name or stem} / {part.name}"[:500],
                meta={},
                status="queued",
                file_name=f"{stem}.{_safe(part.name)}.stl",
                file_size=len(part.content),
                file_sha256=part.sha256,
                file_format="stl",
                units=assembly.units,
            )
            create_model_rows(session, part_model, part.content, background=background)
            found = existing[part.sha256] = part_model.id
        part_id: uuid.UUID = found
        ids.append(part_id)
        rows[part_id].extend(part.placements)
    values = [
        row for part_id, placements in rows.items()
        for row in _placement_rows(assembly.tenant, assembly.id, part_id, placements)
    ]
    if values:
        session.execute(insert(PartRow), values)
    return ids


# --- questions ---------------------------------------------------------------------------


def assembly_parts(connection: Connection, tenant: str, assembly_id: uuid.UUID
                   ) -> list[tuple[Any, list[list[float]]]]:
    """The assembly's parts: each part model's row (``id, external_id, name, meta``, size
    columns and ``units``) with its placements in instance order, first placed first."""
    rows = connection.execute(
        select(PartRow.part_id, PartRow.instance, PartRow.placement)
        .where(PartRow.tenant == tenant, PartRow.assembly_id == assembly_id)
        .order_by(PartRow.part_id, PartRow.instance)
    ).all()
    placements: dict[uuid.UUID, list[list[float]]] = defaultdict(list)
    for part_id, _, placement in rows:
        placements[part_id].append(list(placement))
    models = {row.id: row for row in _summaries(connection, tenant, list(placements))}
    return [(models[part_id], placements[part_id]) for part_id in placements
            if part_id in models]


def _summaries(connection: Connection, tenant: str, ids: Sequence[uuid.UUID]) -> list[Any]:
    if not ids:
        return []
    return list(connection.execute(
        select(Model.id, Model.external_id, Model.name, Model.meta.label("meta"),
               Model.size_length,
               Model.size_width, Model.size_height, Model.size_area, Model.size_volume,
               Model.units, Model.created_at)
        .where(Model.tenant == tenant, Model.id.in_(ids))
        .order_by(Model.created_at, Model.id)
    ).all())


def _sizes_agree(one: tuple[float, float, float] | None,
                 other: tuple[float, float, float] | None) -> bool:
    if one is None or other is None:
        return True  # a size unknown cannot disagree; the shape decides
    return all(abs(a - b) <= SIZE_TOLERANCE * max(abs(a), abs(b), 1e-12)
               for a, b in zip(sorted(one), sorted(other), strict=True))


def copies_of(index: ShapeIndex, connection: Connection, tenant: str, model_id: uuid.UUID
              ) -> list[uuid.UUID]:
    """The tenant's models the index finds to be copies of ready model ``model_id`` (its
    likeness ``copy``, or a raw score of ``UNCALIBRATED_COPY`` without a calibration) with
    a size that agrees; none when the model is not ready."""
    model = connection.execute(
        select(Model.index_id, Model.status, Model.descriptor, Model.descriptor_version,
               Model.size_length, Model.size_width, Model.size_height, Model.units)
        .where(Model.id == model_id, Model.tenant == tenant)
    ).one_or_none()
    if (model is None or model.status != "ready" or model.descriptor is None
            or model.descriptor_version is None):
        return []
    vector = np.frombuffer(model.descriptor, dtype=np.float32)
    matches = find_similar(
        index, connection, (tenant, model.descriptor_version), vector, k=COPY_NEIGHBOURS,
        exclude=model.index_id,
    )
    calibration = calibration_for(model.descriptor_version)
    own = extents_mm(model.size_length, model.size_width, model.size_height, model.units)
    copies = []
    for match in matches:
        if calibration is None:
            copy = match.score >= UNCALIBRATED_COPY
        else:
            copy = in_words(calibration(match.score)) == "copy"
        size = match.model.size
        other = None if size is None else extents_mm(
            size.length, size.width, size.height, match.model.units)
        if copy and _sizes_agree(own, other):
            copies.append(match.model.id)
    return copies


@dataclass(frozen=True)
class WhereUsed:
    """One assembly that uses a part: its row (as ``_summaries``), the placements of the
    part (and of its copies) in it, and which part models of it matched."""

    assembly: Any
    count: int
    parts: list[uuid.UUID]


def where_used(index: ShapeIndex, connection: Connection, tenant: str,
               model_id: uuid.UUID) -> list[WhereUsed]:
    """The assemblies of the tenant that contain model ``model_id`` or a copy of it
    (``copies_of``), oldest first, each with its count of placements."""
    ids = [model_id, *copies_of(index, connection, tenant, model_id)]
    rows = connection.execute(
        select(PartRow.assembly_id, PartRow.part_id, PartRow.instance)
        .where(PartRow.tenant == tenant, PartRow.part_id.in_(ids))
    ).all()
    counts: dict[uuid.UUID, int] = defaultdict(int)
    parts: dict[uuid.UUID, set[uuid.UUID]] = defaultdict(set)
    for assembly_id, part_id, _ in rows:
        counts[assembly_id] += 1
        parts[assembly_id].add(part_id)
    order = {part_id: number for number, part_id in enumerate(ids)}
    return [
        WhereUsed(row, counts[row.id], sorted(parts[row.id], key=order.__getitem__))
        for row in _summaries(connection, tenant, list(counts))
    ]


def where_used_of_groups(connection: Connection, tenant: str,
                         groups: Sequence[Sequence[uuid.UUID]]) -> list[list[WhereUsed]]:
    """For each group of models (a duplicates report's groups), the tenant's assemblies that
    place any of its members, oldest first, each with the members' placements counted: a
    group used in several assemblies is one part used across products. One statement for
    all the groups' placements, one for the assemblies."""
    members = {member for group in groups for member in group}
    rows = connection.execute(
        select(PartRow.assembly_id, PartRow.part_id)
        .where(PartRow.tenant == tenant, PartRow.part_id.in_(members))
    ).all() if members else []
    placed: dict[uuid.UUID, list[uuid.UUID]] = defaultdict(list)
    for assembly_id, part_id in rows:
        placed[part_id].append(assembly_id)
    assemblies = {row.id: row for row in _summaries(
        connection, tenant, list({a for ids in placed.values() for a in ids}))}
    answers = []
    for group in groups:
        counts: dict[uuid.UUID, int] = defaultdict(int)
        parts: dict[uuid.UUID, list[uuid.UUID]] = defaultdict(list)
        for member in group:
            for assembly_id in placed.get(member, []):
                counts[assembly_id] += 1
                if member not in parts[assembly_id]:
                    parts[assembly_id].append(member)
        answers.append([
            WhereUsed(row, counts[row.id], parts[row.id])
            for row in assemblies.values() if row.id in counts
        ])
    return answers
