"""The models a search index holds, as rows of the database: which ones (``in_scope``),
which columns (``columns``), every ready one streamed in chunks (``ready``), and a row as the
index adds it (``added``). A rebuild (``_rebuild``) and the change-feed follower (``_feed``)
read the models through these."""

from __future__ import annotations

import uuid
from collections.abc import Iterator
from typing import Any, cast

import numpy as np
from sqlalchemy import ColumnElement, null, select, true
from sqlalchemy.orm import QueryableAttribute, Session, sessionmaker

from app.db.models import Model
from app.search.index._held import ROW_CHUNK, Added
from app.search.index._view_ids import PartitionKey, views_array

__all__ = ["ModelRows", "Row", "added"]

_Column = QueryableAttribute[Any] | ColumnElement[Any]
#: A row of ``_INDEXED``: index_id, tenant, descriptor_version, descriptor, views, id.
Row = tuple[int, str, str, bytes, "bytes | None", uuid.UUID]
# What the index holds of a model: the rows a rebuild streams and a sync reads.
_INDEXED: tuple[_Column, ...] = (
    Model.index_id,
    Model.tenant,
    Model.descriptor_version,
    Model.descriptor,
    Model.view_descriptors,
    Model.id,
)


class ModelRows:
    """The rows of the models an index holds: all, or with ``only`` those of one partition
    (without their views)."""

    def __init__(self, sessions: sessionmaker[Session], only: PartitionKey | None) -> None:
        self.sessions = sessions
        self.only = only

    def in_scope(self) -> ColumnElement[bool]:
        """The models this index holds: all, or those of partition ``only``."""
        if self.only is None:
            return true()
        tenant, version = self.only
        return (Model.tenant == tenant) & (Model.descriptor_version == version)

    def columns(self) -> tuple[_Column, ...]:
        """The columns read of each model: with ``only``, no views (never used there, and
        up to 16 times the descriptor's bytes)."""
        if self.only is None:
            return _INDEXED
        return tuple(null() if column is Model.view_descriptors else column for column in _INDEXED)

    def ready(self) -> Iterator[Row]:
        """Every ready descriptor with its views, ``ROW_CHUNK`` rows per query (keyset on
        index_id)."""
        last = -1
        while True:
            with self.sessions() as session:
                rows = cast(list[Row], session.execute(
                    select(*self.columns())
                    .where(
                        Model.index_id > last,
                        Model.status == "ready",
                        Model.descriptor.is_not(None),
                        Model.descriptor_version.is_not(None),
                        self.in_scope(),
                    )
                    .order_by(Model.index_id)
                    .limit(ROW_CHUNK)
                ).all())
            if not rows:
                return
            yield from rows
            last = rows[-1][0]


def added(
    index_id: int,
    tenant: str,
    version: str,
    descriptor: bytes,
    view_blob: bytes | None,
    model_id: uuid.UUID,
) -> Added:
    """A ready row as ``Held.apply`` adds it."""
    vector = np.frombuffer(descriptor, dtype=np.float32)
    return index_id, (tenant, version), vector, views_array(view_blob, len(vector)), model_id
