"""Assemblies (issue 76): an upload with ``assembly=split`` becomes the assembly model (its
whole shape, described as any upload) plus one part model per distinct geometry, and one
``assembly_parts`` row per placement (the questions asked of them: ``app.search.assemblies``).

Splitting (``core.io.split_assembly``) runs in the sandbox, after a check of a
GLB's node graph in this process that refuses a bomb before anything is built. A part model
is an ordinary model whose file is the part's triangles in its own frame (a binary STL): the
worker describes it like any upload, so parts are searchable like any model.
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

from sqlalchemy import delete, insert, select
from sqlalchemy.orm import Session

from app.db.models import AssemblyPart as PartRow
from app.db.models import Model
from app.ingest.revisions import create_model_rows
from app.ingest.sandbox import sandbox_of
from app.settings import Settings
from core.io import AssemblyPart, check_gltf_graph, detect_format, split_assembly, stl_bytes

__all__ = [
    "ASSEMBLY_FORMATS",
    "PartFile",
    "add_parts",
    "is_assembly",
    "split_upload",
    "splits_by_default",
]


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
