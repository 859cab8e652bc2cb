"""A rebuild: every ready descriptor streamed from the database into new partitions, built
aside and swapped in at once, so searches never wait for it."""

from __future__ import annotations

import numpy as np
from sqlalchemy import func, null, select
from sqlalchemy.orm import Session

from app.db.models import FeedState, Model
from app.search.index._held import Held
from app.search.index._milvus import AnyPartition
from app.search.index._rows import ModelRows
from app.search.index._view_ids import PartitionKey, holds_views, view_ids, views_array, views_key

__all__ = ["rebuild"]


def rebuild(held: Held, rows: ModelRows) -> None:
    """Replace what ``held`` holds with the models of ``rows`` as the database has them now;
    ``held.revision`` becomes the change-feed revision read before them: the caller then
    catches up with the feed (``_feed.follow``)."""
    with held.lock:
        with rows.sessions() as session:
            # Read the revision first: every change after it is replayed by sync, and
            # replaying a change already loaded here is harmless.
            revision = session.execute(
                select(FeedState.revision).where(FeedState.id == 1)
            ).scalar_one()
            sizes = _sizes(session, rows)
        builders = {key: held.builder(size) for key, size in sizes.items()}
        views_of: dict[int, int] = {}
        index_id_of: dict[int, int] = {}
        for index_id, tenant, version, descriptor, view_blob, model_id in rows.ready():
            builder = builders.get((tenant, version))
            if builder is None:  # became ready after the count: sync replays it
                continue
            vector = np.frombuffer(descriptor, dtype=np.float32)
            builder.add_one(index_id, vector)
            index_id_of[model_id.int] = index_id
            views = views_array(view_blob, len(vector))
            view_builder = builders.get(views_key((tenant, version)))
            if views is not None and view_builder is not None:
                for entry, view in zip(view_ids(index_id, len(views)), views, strict=True):
                    view_builder.add_one(entry, view)
                views_of[index_id] = len(views)
        partitions: dict[PartitionKey, AnyPartition] = {}
        partition_of: dict[int, PartitionKey] = {}
        for key, builder in builders.items():
            partition = builder.finish()
            if partition is not None:
                partitions[key] = partition
                if not holds_views(key):
                    partition_of.update(dict.fromkeys(builder.ids, key))
        held.install(partitions, partition_of, views_of, index_id_of, int(revision))


def _sizes(session: Session, rows: ModelRows) -> dict[PartitionKey, int]:
    """How many vectors each partition will hold: its ready models, and for their views'
    partition the views' bytes over a descriptor's (none with ``rows.only``)."""
    sizes: dict[PartitionKey, int] = {}
    view_bytes_of = null() if rows.only else func.sum(func.length(Model.view_descriptors))
    for tenant, version, count, view_bytes, vector_bytes in session.execute(
        select(
            Model.tenant,
            Model.descriptor_version,
            func.count(),
            view_bytes_of,
            func.max(func.length(Model.descriptor)),
        )
        .where(
            Model.status == "ready",
            Model.descriptor_version.is_not(None),
            rows.in_scope(),
        )
        .group_by(Model.tenant, Model.descriptor_version)
    ):
        sizes[(tenant, version)] = int(count)
        if view_bytes and vector_bytes:
            sizes[views_key((tenant, version))] = int(view_bytes) // int(vector_bytes)
    return sizes
