"""Partition keys and the ids of scan mode's view entries.

View ``v`` of model ``i`` has the id ``view_id(i, v)``, above every model id, and lives in
the partition ``views_key(key)`` next to its model's partition ``key``.
"""

from __future__ import annotations

import numpy as np

from core.settings import MAX_VIEWS

__all__ = [
    "VIEW_ID_BASE", "PartitionKey", "holds_views", "view_id", "view_ids", "view_of",
    "views_array", "views_key",
]

PartitionKey = tuple[str, str]  # (tenant, descriptor_version)

#: View ids start above every model id (index_id is a 64-bit sequence that never gets near
#: 2^48), so that an id alone tells a view from a model.
VIEW_ID_BASE = 1 << 48


_VIEWS = "#views"


def views_key(key: PartitionKey) -> PartitionKey:
    """The partition of the view entries of partition ``key``'s models."""
    tenant, version = key
    return tenant, version + _VIEWS


def holds_views(key: PartitionKey) -> bool:
    """Whether partition ``key`` holds view entries."""
    return key[1].endswith(_VIEWS)


def view_id(index_id: int, view: int) -> int:
    """The index id of view ``view`` (< ``MAX_VIEWS``) of model ``index_id``."""
    return VIEW_ID_BASE + index_id * MAX_VIEWS + view


def view_of(entry_id: int) -> tuple[int, int]:
    """``(index_id, view)`` of a view entry's id (the inverse of ``view_id``)."""
    return divmod(entry_id - VIEW_ID_BASE, MAX_VIEWS)


def view_ids(index_id: int, count: int) -> list[int]:
    """The ids of the first ``count`` views of model ``index_id``."""
    return [view_id(index_id, view) for view in range(count)]


def views_array(blob: bytes | None, dim: int) -> np.ndarray | None:
    """``Model.view_descriptors`` as ``(v, dim) float32``, or None when there are none."""
    if not blob or dim == 0:
        return None
    views = np.frombuffer(blob, dtype=np.float32)
    return views.reshape(-1, dim)[:MAX_VIEWS] if len(views) % dim == 0 else None
