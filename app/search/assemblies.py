"""The questions asked of assemblies (issue 76; the split itself: ``app.ingest.assemblies``):
an assembly's parts, where a part is used, which assemblies use each group of a duplicates
report, and which part each point of an assembly lies on.

Identity across assemblies is decided at query time (``where_used``): the assemblies that
hold the part itself, and those holding a part the index finds to be a copy of it (its
likeness ``copy``; without a calibration, a raw score of at least ``UNCALIBRATED_COPY``) whose
size agrees within ``SIZE_TOLERANCE`` (when both sizes are known).
"""

from __future__ import annotations

import uuid
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from sqlalchemy import Connection, select

from app.db.models import AssemblyPart as PartRow
from app.db.models import Model
from app.ingest.describing import decode_sample
from app.search.index import ShapeIndex
from app.search.similarity import find_similar
from app.search.sizing import extents_mm
from core.placement import part_labels
from core.rank.score_calibration import calibration_for, in_words

__all__ = [
    "COPY_NEIGHBOURS",
    "SIZE_TOLERANCE",
    "UNCALIBRATED_COPY",
    "LabelledPoints",
    "WhereUsed",
    "assembly_parts",
    "copies_of",
    "labelled_points",
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


@dataclass(frozen=True)
class LabelledPoints:
    """Points on an assembly (its stored sample, in its units) and the part each lies on.

    Attributes
    ----------
    part_ids : list of UUID
        The assembly's parts, in ``assembly_parts``' order.
    points : (n, 3) float64
    labels : (n,) int64
        Index into ``part_ids``; -1: on no known part (a part not described yet).
    """

    part_ids: list[uuid.UUID]
    points: np.ndarray
    labels: np.ndarray


def labelled_points(connection: Connection, tenant: str, assembly_id: uuid.UUID,
                    count: int) -> LabelledPoints | None:
    """At most ``count`` of the assembly's sample points (evenly thinned), each labelled
    with the part it lies on (``core.placement.part_labels``, from the parts' own samples
    at their placements); None when the assembly has no sample (not ready)."""
    sample = connection.scalar(
        select(Model.sample).where(Model.id == assembly_id, Model.tenant == tenant))
    if not sample:
        return None
    points = decode_sample(sample)
    if len(points) > count:
        points = points[np.linspace(0, len(points) - 1, count).astype(np.int64)]
    parts = assembly_parts(connection, tenant, assembly_id)
    samples: dict[uuid.UUID, bytes | None] = dict(connection.execute(
        select(Model.id, Model.sample)
        .where(Model.tenant == tenant, Model.id.in_([row.id for row, _ in parts]))
    ).all()) if parts else {}
    known = []
    for row, placements in parts:
        part_sample = samples.get(row.id)
        known.append(None if not part_sample else (
            decode_sample(part_sample), np.asarray(placements, np.float64).reshape(-1, 4, 4)))
    return LabelledPoints([row.id for row, _ in parts], points, part_labels(points, known))
