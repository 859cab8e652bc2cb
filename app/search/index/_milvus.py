"""The index's vectors in Milvus instead of this process (``SHAPESEARCH_INDEX_BACKEND=milvus``).

A ``MilvusStore`` is one Milvus deployment: a server (``http://host:19530``) or an embedded
milvus-lite file. It holds one collection per descriptor version (and one for that version's
scan-mode views, ``views_key``), named after a hash of the version and the vectors' width,
with the model's ``index_id`` (or a view's ``view_id``) as primary key, the tenant as
partition key and the full float32 vector; its vector index is ``FLAT`` (exact),
``HNSW`` or ``IVF_FLAT`` (``SHAPESEARCH_MILVUS_INDEX``), by inner product on the unit
vectors (the order of L2; ``search`` answers squared L2 distances, 2 - 2 ip, as a FAISS
partition does). Milvus keeps the vectors whole, so its distances are exact whatever index
chooses the candidates: no re-rank is needed.

One more collection, ``<prefix>_state``, holds a single row: the change-feed revision
through which the vector collections are known to be in step with the database. It is
written after the vectors of a batch (``MilvusStore.set_revision``), so a process killed
between the two replays that batch on its next sync: every write is an ``upsert`` or a
``delete`` by primary key, which a replay repeats without duplicating anything.

Writes are made by one process at a time (``MilvusStore.writer``: a PostgreSQL advisory
lock, or a file lock beside a SQLite database or milvus-lite file): each reads the rows it
writes under that lock, so a slow writer never puts back a model that a faster one removed.

A ``MilvusPartition`` is what ``Held`` keeps per (tenant, descriptor version) for this
backend: the collection and tenant it reads and writes, and a count of what it holds. Its
vectors live in Milvus only; ``exact_vectors`` fetches them by id, ``search`` sends the
query with the tenant (and the allowed ids, if any) as a boolean expression.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import itertools
import os
import tempfile
import threading
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from sqlalchemy import text
from sqlalchemy.orm import Session, sessionmaker

from app.search.index._kept import KeptNeighbourhoods
from app.search.index._lock import ReadWriteLock
from app.search.index._partition import Partition
from app.search.index._view_ids import PartitionKey, view_ids
from core.settings import MAX_VIEWS

__all__ = ["INDEX_TYPES", "AnyPartition", "MilvusPartition", "MilvusStore", "MilvusUnavailable"]

#: The vector indexes a collection may be built with (``SHAPESEARCH_MILVUS_INDEX``).
INDEX_TYPES = ("FLAT", "HNSW", "IVF_FLAT")
#: Milvus answers at most this many results per query (its ``topk`` limit).
MAX_TOPK = 16_384
_STATE_ROW = 1
_HNSW_EF = 128  # HNSW's candidate list per query, at least (2 k when more)
_IVF_LISTS = 1024  # IVF_FLAT's inverted lists (all searched when few are wanted)
_UPSERT_ROWS = 256  # rows per upsert call: ~3 MB of 2961-dim vectors
_GET_IDS = 1_024  # ids per get call
_LOCK_WAIT_SECONDS = 30.0  # how long opening a milvus-lite file waits for its last user
#: Allowed ids (a narrow filter) up to which a search fetches their vectors and compares
#: them here, exactly, instead of asking the vector index: an HNSW graph walked under a
#: filter that few rows pass can stop short of k (milvus-lite answered none at all for a
#: filter 100 of 10^5 models pass).
EXACT_ALLOWED = 4_096
_DELETE_IDS = 4_096
_ADVISORY_LOCK = 0x5EA7C4  # pg_advisory_lock key of the Milvus writer
_SERIALS = itertools.count(1 << 40)  # apart from the FAISS partitions' serials


class MilvusUnavailable(RuntimeError):
    """Milvus cannot be reached or opened (a milvus-lite file open in another process)."""


def _load_client(uri: str, token: str | None) -> Any:
    """A ``pymilvus.MilvusClient`` for ``uri`` (imported here: an optional extra)."""
    try:
        from pymilvus import MilvusClient
    except ImportError as error:  # pragma: no cover - the extra is missing
        raise MilvusUnavailable(
            "SHAPESEARCH_INDEX_BACKEND=milvus needs the milvus extra: "
            "pip install 'shapesearch[milvus]'") from error
    local = not uri.startswith(("http://", "https://", "tcp://", "unix:"))
    deadline = time.monotonic() + (_LOCK_WAIT_SECONDS if local else 0.0)
    while True:
        try:
            return MilvusClient(uri=uri, token=token or "")
        except Exception as error:
            # A milvus-lite file whose last user is still letting go of it (a process
            # closing, or exiting): wait for it a little, then say who holds it.
            if local and "lock" in str(error) and time.monotonic() < deadline:
                time.sleep(0.5)
                continue
            hint = ""
            if local:
                hint = (" (milvus-lite is embedded: one process at a time may open a file; "
                        "several API processes need a Milvus server)")
            raise MilvusUnavailable(f"cannot open Milvus at {uri}{hint}: {error}") from error


def collection_name(prefix: str, version: str, dim: int) -> str:
    """The collection of descriptor version ``version`` (views included: the version of a
    views partition ends in ``#views``) with vectors of ``dim`` floats."""
    digest = hashlib.sha1(version.encode()).hexdigest()[:16]
    return f"{prefix}_{digest}_{dim}"


def _quoted(value: str) -> str:
    """``value`` as a string literal of a Milvus boolean expression."""
    return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'


class MilvusStore:
    """One Milvus deployment's collections for this catalogue.

    Parameters
    ----------
    uri : str
        A server (``http://host:19530``) or a milvus-lite file (``/path/index.db``).
    index_type : str
        ``FLAT`` (exact), ``HNSW`` or ``IVF_FLAT``: how each collection's vectors are
        indexed (``INDEX_TYPES``).
    prefix : str
        What every collection's name starts with: deployments sharing a server apart.
    token : str, optional
        A server's credentials (``user:password`` or an API key).
    """

    def __init__(
        self, uri: str, *, index_type: str = "FLAT", prefix: str = "shapesearch",
        token: str | None = None,
    ) -> None:
        if index_type not in INDEX_TYPES:
            raise ValueError(f"Milvus index type {index_type!r}: one of {INDEX_TYPES}")
        self.uri = uri
        self.index_type = index_type
        self.prefix = prefix
        self.token = token
        self._client: Any = None
        self._ready: set[str] = set()  # collections known to exist and be loaded
        self._open = threading.Lock()
        self._local_writer = threading.Lock()
        #: False while a sync replays events that Milvus holds already (another process
        #: wrote them): partitions then change their counts, not Milvus.
        self.writing = True

    @property
    def local(self) -> bool:
        """Whether ``uri`` is a milvus-lite file (embedded, one process at a time)."""
        return not self.uri.startswith(("http://", "https://", "tcp://", "unix:"))

    @property
    def client(self) -> Any:
        with self._open:
            if self._client is None:
                if self.local:
                    Path(self.uri).parent.mkdir(parents=True, exist_ok=True)
                self._client = _load_client(self.uri, self.token)
            return self._client

    def close(self) -> None:
        """Close the client (a milvus-lite file is then free for another process)."""
        with self._open:
            if self._client is not None:
                self._client.close()
                if self.local:  # milvus-lite keeps the file's server until told (or exit)
                    from milvus_lite.server_manager import server_manager_instance

                    server_manager_instance.release_server(self.uri)
            self._client, self._ready = None, set()

    # --- collections ----------------------------------------------------------------

    def collection(self, version: str, dim: int) -> str:
        """The name of the collection of ``version`` and ``dim``, created and loaded."""
        name = collection_name(self.prefix, version, dim)
        if name not in self._ready:
            self._ensure(name, dim)
        return name

    def _ensure(self, name: str, dim: int) -> None:
        from pymilvus import DataType, MilvusClient

        client = self.client
        if not client.has_collection(name):
            schema = MilvusClient.create_schema(auto_id=False, enable_dynamic_field=False)
            schema.add_field("id", DataType.INT64, is_primary=True)
            schema.add_field("tenant", DataType.VARCHAR, max_length=512, is_partition_key=True)
            schema.add_field("vector", DataType.FLOAT_VECTOR, dim=dim)
            params = client.prepare_index_params()
            # Inner product: the vectors are unit-norm, so its order is L2's and the squared
            # L2 distance is 2 - 2 ip; and milvus-lite scans rows not indexed yet with a
            # matrix product for IP but an (queries, rows, dim) array for L2 (40 GB for 40
            # queries over 92,000 rows of 2961 floats).
            params.add_index(field_name="vector", index_type=self.index_type, metric_type="IP",
                             params=_build_params(self.index_type))
            with contextlib.suppress(Exception):  # created meanwhile by another process
                client.create_collection(name, schema=schema, index_params=params,
                                         consistency_level="Strong")
        client.load_collection(name)
        self._ready.add(name)

    def collections(self) -> list[str]:
        """The vector collections of this prefix (not the state)."""
        state = self._state_name
        return [name for name in self.client.list_collections()
                if name.startswith(self.prefix + "_") and name != state]

    def drop_all(self) -> None:
        """Drop every collection of this prefix, the state too (tests, a fresh start)."""
        for name in [*self.collections(), self._state_name]:
            if self.client.has_collection(name):
                self.client.drop_collection(name)
        self._ready = set()

    # --- the revision Milvus is in step with ------------------------------------------

    @property
    def _state_name(self) -> str:
        return f"{self.prefix}_state"

    def _state(self) -> str:
        from pymilvus import DataType, MilvusClient

        name = self._state_name
        if name not in self._ready:
            client = self.client
            if not client.has_collection(name):
                schema = MilvusClient.create_schema(auto_id=False, enable_dynamic_field=False)
                schema.add_field("id", DataType.INT64, is_primary=True)
                schema.add_field("revision", DataType.INT64)
                schema.add_field("vector", DataType.FLOAT_VECTOR, dim=2)  # Milvus wants one
                params = client.prepare_index_params()
                params.add_index(field_name="vector", index_type="FLAT", metric_type="L2")
                with contextlib.suppress(Exception):
                    client.create_collection(name, schema=schema, index_params=params,
                                             consistency_level="Strong")
            client.load_collection(name)
            self._ready.add(name)
        return name

    def revision(self) -> int | None:
        """The change-feed revision Milvus is in step with; None: never built (or wiped)."""
        rows = self.client.get(self._state(), ids=[_STATE_ROW], output_fields=["revision"])
        return int(rows[0]["revision"]) if rows else None

    def set_revision(self, revision: int) -> None:
        """Record that every change through ``revision`` is in Milvus (after writing it)."""
        self.client.upsert(self._state(), [
            {"id": _STATE_ROW, "revision": int(revision), "vector": [0.0, 0.0]}])

    @contextlib.contextmanager
    def writer(self, sessions: sessionmaker[Session] | None) -> Iterator[None]:
        """Hold the writer's lock: one process (and thread) writes Milvus at a time.

        On PostgreSQL an advisory lock of the database; otherwise a file lock beside the
        SQLite database's directory or the milvus-lite file (``tempfile`` for a server)."""
        with self._local_writer:
            bind = None if sessions is None else sessions.kw.get("bind")
            if bind is not None and bind.dialect.name == "postgresql":
                with bind.connect() as connection:
                    connection.execute(text("SELECT pg_advisory_lock(:k)"), {"k": _ADVISORY_LOCK})
                    connection.commit()
                    try:
                        yield
                    finally:
                        connection.execute(text("SELECT pg_advisory_unlock(:k)"),
                                           {"k": _ADVISORY_LOCK})
                        connection.commit()
                return
            with open(self._lock_path(), "a+b") as handle:
                fcntl.flock(handle, fcntl.LOCK_EX)
                try:
                    yield
                finally:
                    fcntl.flock(handle, fcntl.LOCK_UN)

    def _lock_path(self) -> str:
        if self.local:
            return self.uri + ".writer.lock"
        digest = hashlib.sha1(f"{self.uri}|{self.prefix}".encode()).hexdigest()[:16]
        return os.path.join(tempfile.gettempdir(), f"shapesearch-milvus-{digest}.lock")

    # --- vectors ----------------------------------------------------------------------

    def upsert(self, name: str, tenant: str, ids: Sequence[int], vectors: np.ndarray) -> None:
        """Write ``vectors : (m, d) float32`` under ``ids`` (replacing what they held)."""
        for start in range(0, len(ids), _UPSERT_ROWS):
            rows = [
                {"id": int(i), "tenant": tenant, "vector": vector}
                for i, vector in zip(ids[start:start + _UPSERT_ROWS],
                                     vectors[start:start + _UPSERT_ROWS], strict=True)
            ]
            self.client.upsert(name, rows)

    def delete(self, name: str, ids: Sequence[int]) -> None:
        for start in range(0, len(ids), _DELETE_IDS):
            self.client.delete(name, ids=[int(i) for i in ids[start:start + _DELETE_IDS]])

    def forget(self, index_ids: Sequence[int]) -> None:
        """Delete models ``index_ids`` and every view they may have from every collection:
        what a replay does first, as Milvus may hold models (or views) that the database,
        and so this process, no longer knows of."""
        entries = [entry for i in index_ids for entry in (i, *view_ids(i, MAX_VIEWS))]
        for name in self.collections():
            self.delete(name, entries)

    def get(
        self, name: str, tenant: str, ids: Sequence[int], dim: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(m, dim) float32`` vectors of ``ids`` held for ``tenant`` and the ``(m,)`` mask
        of those held."""
        vectors = np.zeros((len(ids), dim), dtype=np.float32)
        held = np.zeros(len(ids), dtype=bool)
        rows_of: dict[int, list[int]] = {}
        for row, i in enumerate(ids):
            rows_of.setdefault(int(i), []).append(row)
        unique = list(rows_of)
        for start in range(0, len(unique), _GET_IDS):
            found = self.client.get(name, ids=unique[start:start + _GET_IDS],
                                    output_fields=["vector", "tenant"])
            for entity in found:
                if entity["tenant"] != tenant:
                    continue
                rows = rows_of[int(entity["id"])]
                vectors[rows], held[rows] = np.asarray(entity["vector"], dtype=np.float32), True
        return vectors, held

    def search(
        self, name: str, tenant: str, queries: np.ndarray, k: int,
        allowed: np.ndarray | None, search_params: dict[str, Any],
    ) -> tuple[np.ndarray, np.ndarray]:
        """The ``k`` nearest of each query among ``tenant``'s (only ``allowed`` ids, when
        given): ``(m, k)`` squared L2 distances and ids, -1 past the end."""
        expression = f"tenant == {_quoted(tenant)}"
        if allowed is not None:
            expression += " and id in [" + ",".join(str(int(i)) for i in allowed) + "]"
        limit = min(k, MAX_TOPK)
        found = self.client.search(
            name, data=[q for q in np.asarray(queries, dtype=np.float32)], limit=limit,
            filter=expression, output_fields=["id"],
            search_params={"metric_type": "IP", "params": search_params},
        )
        squared = np.full((len(queries), k), np.inf, dtype=np.float32)
        ids = np.full((len(queries), k), -1, dtype=np.int64)
        for row, hits in enumerate(found):
            for column, hit in enumerate(hits):
                ids[row, column] = int(hit["id"])
                squared[row, column] = max(0.0, 2.0 - 2.0 * float(hit["distance"]))
        return squared, ids

    def ids(self, name: str, tenant: str | None = None) -> Iterator[np.ndarray]:
        """Every id of collection ``name`` (of ``tenant``, when given), a batch at a time."""
        expression = "id >= 0" if tenant is None else f"tenant == {_quoted(tenant)}"
        iterator = self.client.query_iterator(name, batch_size=4096, filter=expression,
                                              output_fields=["id"])
        try:
            while batch := iterator.next():
                yield np.fromiter((int(row["id"]) for row in batch), dtype=np.int64,
                                  count=len(batch))
        finally:
            iterator.close()

    def flush(self, name: str) -> None:
        """Seal what was written to ``name`` and index it (after a bulk upload: milvus-lite
        scans unsealed rows one by one, ~1 s a query at 3,000 rows against 60 ms sealed)."""
        self.client.flush(name)

    def count(self, name: str) -> int:
        rows = self.client.query(name, filter="", output_fields=["count(*)"])
        return int(rows[0]["count(*)"])


def _build_params(index_type: str) -> dict[str, Any]:
    if index_type == "HNSW":
        return {"M": 16, "efConstruction": 200}
    if index_type == "IVF_FLAT":
        return {"nlist": _IVF_LISTS}
    return {}


class MilvusPartition:
    """One (tenant, descriptor version)'s vectors in a Milvus collection.

    Parameters
    ----------
    store : MilvusStore
        Where the vectors are.
    key : PartitionKey
        The partition (a views partition's version ends in ``#views``).
    dim : int
        The vectors' width.
    size : int
        How many vectors it holds now (the database's count, at a rebuild): the partition
        then counts what it adds and removes, which ``Held`` keeps exact.
    nprobe : int
        ``IVF_FLAT``'s lists searched per query (``HNSW``: ``ef`` is ``max(64, 2 k)``).
    """

    approximate = False  # Milvus' distances are exact: no re-rank
    rerank_scale = 0
    full = None  # no full-vector file of this process's
    projection = None

    def __init__(
        self, store: MilvusStore, key: PartitionKey, dim: int, size: int = 0, nprobe: int = 8
    ) -> None:
        self.store = store
        self.key = key
        self.tenant = key[0]
        self.dim = dim
        self.nprobe = nprobe
        self.name = store.collection(key[1], dim)
        self.size = size
        self.lock = ReadWriteLock()
        self.kept = KeptNeighbourhoods()  # what queries computed (no background pass)
        self.serial = next(_SERIALS)
        self.version = 0

    @property
    def kind(self) -> str:
        return f"milvus-{self.store.index_type.lower()}"

    def nbytes(self) -> int:
        """Bytes of vectors this process holds: none (they are in Milvus)."""
        return 0

    def add(self, ids: np.ndarray, vectors: np.ndarray) -> None:
        self.version += 1
        self.kept.changed(self, ids, vectors)
        if self.store.writing:
            self.store.upsert(self.name, self.tenant, ids.tolist(),
                              np.ascontiguousarray(vectors, dtype=np.float32))
        self.size += len(ids)

    def remove(self, ids: np.ndarray) -> None:
        self.version += 1
        self.kept.changed(self, ids)
        if self.store.writing:
            self.store.delete(self.name, ids.tolist())
        self.size = max(0, self.size - len(ids))

    def put(self, ids: Sequence[int], vectors: np.ndarray) -> None:
        """Write vectors without counting them (a rebuild's upload: the count comes from
        the database)."""
        self.store.upsert(self.name, self.tenant, ids, vectors)

    def ids(self) -> np.ndarray:
        """``(n,) int64``: every id held, in no particular order."""
        return np.concatenate([np.zeros(0, dtype=np.int64),
                               *self.store.ids(self.name, self.tenant)])

    def exact_vectors(self, ids: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """``(m, dim) float32`` vectors of ``ids`` as added, and the ``(m,) bool`` mask of
        the ids held (fetched from Milvus)."""
        if len(ids) == 0:
            return np.zeros((0, self.dim), dtype=np.float32), np.zeros(0, dtype=bool)
        return self.store.get(self.name, self.tenant, ids, self.dim)

    def search(
        self, query: np.ndarray, k: int, allowed: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(m, k)`` squared L2 distances and ids (-1 past the end), as FAISS gives them."""
        query = query[:, : self.dim]
        if allowed is not None and len(allowed) <= EXACT_ALLOWED:
            return self._exact_among(query, k, allowed)
        if self.store.index_type == "HNSW":
            params: dict[str, Any] = {"ef": min(max(_HNSW_EF, 2 * k), 2 * MAX_TOPK)}
        elif self.store.index_type == "IVF_FLAT":
            params = {"nprobe": self.nprobe if allowed is None else _IVF_LISTS}
        else:
            params = {}
        squared, ids = self.store.search(self.name, self.tenant, query, k, allowed, params)
        if self.store.index_type == "IVF_FLAT" and allowed is None and (ids[:, -1] < 0).any():
            # The nprobe nearest lists held fewer than k: a caller widening its search
            # would take that for the end of the partition (as ``Partition.search``).
            squared, ids = self.store.search(self.name, self.tenant, query, k, None,
                                             {"nprobe": _IVF_LISTS})
        return squared, ids


    def _exact_among(
        self, query: np.ndarray, k: int, allowed: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """``search`` among ``allowed`` ids alone, by their vectors fetched from Milvus."""
        vectors, held = self.exact_vectors([int(i) for i in allowed])
        ids, vectors = np.asarray(allowed, dtype=np.int64)[held], vectors[held]
        squared = np.full((len(query), k), np.inf, dtype=np.float32)
        found = np.full((len(query), k), -1, dtype=np.int64)
        if len(ids):
            distances = np.maximum(
                0.0, 2.0 - 2.0 * (np.asarray(query, np.float32) @ vectors.T))
            count = min(k, len(ids))
            nearest = np.argsort(distances, axis=1, kind="stable")[:, :count]
            found[:, :count] = ids[nearest]
            squared[:, :count] = np.take_along_axis(distances, nearest, axis=1)
        return squared, found


#: A partition of either backend, as ``Held`` keeps it.
AnyPartition = Partition | MilvusPartition
