"""Each API process's in-memory search index: how it follows the database, when its
partitions are compressed, and where the hub discount's neighbourhoods are saved."""

from __future__ import annotations

from pathlib import Path
from typing import Literal, TypedDict

from pydantic import BaseModel, Field

__all__ = ["IndexOptions", "IndexSettings"]


class IndexOptions(TypedDict):
    """``ShapeIndex``'s keyword arguments from the settings (``Settings.index_options``)."""

    exact_max: int
    compact_min: int
    nprobe: int
    rerank_factor: int
    projected_dims: int
    hub_neighbours: int
    reciprocal: bool
    cache_dir: Path | None
    backend: str
    milvus_uri: str | None
    milvus_index: str
    milvus_prefix: str
    milvus_token: str | None


class IndexSettings(BaseModel):
    """The search index of an API process."""

    index_sync_interval: float = Field(
        default=1.0,
        gt=0,
        description="Seconds between polls of the change feed that keeps the search index "
        "of an API process in step with the database (a change committed in the process, or "
        "announced by another process (PostgreSQL's NOTIFY, a Unix socket beside a SQLite "
        "file), is synced at once).",
    )
    index_exact_max: int = Field(
        default=5_000,
        ge=1,
        description="Largest index partition (tenant, descriptor version) searched exactly; "
        "larger ones are IVF with 8-bit scalar-quantised vectors (4x smaller), re-ranked "
        "exactly from their full vectors, kept in a memory-mapped temporary file (4 bytes "
        "per dimension per model in TMPDIR: local disk, not tmpfs, and served from the page "
        "cache). An exact search scans every vector: a similar at 20,000 models took 6.2 ms "
        "exact and 1.5 ms in IVF (recall@10 0.9985-1 from 6,000 models up; "
        "bench/search_scale.py).",
    )
    index_compact_min: int = Field(
        default=500_000,
        ge=1,
        description="An index partition built (at start-up) with more models than this "
        "stores 4-bit codes instead of 8-bit ones: half a byte per dimension, 1.5 GB at 10^6 "
        "models of the 2961-dim default instead of 3.0 GB, with twice the candidates "
        "re-ranked exactly (recall@10 0.994 at 10^6; bench/search_scale.py).",
    )
    index_nprobe: int = Field(
        default=8, ge=1, description="Inverted lists searched per query in an IVF partition."
    )
    index_rerank_factor: int = Field(
        default=2,
        ge=1,
        description="Candidates per wanted result that an IVF partition returns for exact "
        "re-ranking (at least k + 10).",
    )
    index_projected_dims: int = Field(
        default=0,
        ge=0,
        le=1024,
        description="0 (default): an IVF partition's codes hold every dimension. N > 0: "
        "they hold the vectors' N leading principal components, fitted on the partition's "
        "training sample (when it and the vectors are wide enough), and the exact re-rank "
        "is unchanged. At 10^5 models and 256: 1.4-1.6x the similar requests per second at "
        "c=16, a 9x smaller index; recall@10 1.0 on real descriptors, 0.85 on the "
        "benchmark's synthetic ones, 0.37 at 10^6 (near ties; docs/benchmarks.md, Projected "
        "codes).",
    )
    index_cache_dir: Path | None = Field(
        default=None,
        description="Directory where each API process saves the hub discount's "
        "neighbourhoods (a file per tenant and descriptor version, 77 bytes a model: 77 MB "
        "at 10^6) after its pass, every 10 minutes while parts change and on shutdown, and "
        "restores them from at start-up instead of computing them again (at 10^6 models "
        "about 17 minutes of a core per process, with slow similar queries meanwhile), "
        "forgetting what changed since. Processes that share it share the pass: one "
        "computes it, the others restore it. Files no partition reads any more (a "
        "retired descriptor version, another k, a killed save) are removed a day after "
        "they were last written. Unset: `index-cache` in "
        "the data directory with the embedded SQLite database, none (always computed) "
        "with another database URL (docs/operations.md, Restarts restore the pass).",
    )
    index_backend: Literal["faiss", "milvus"] = Field(
        default="faiss",
        description="Where the search index's vectors are. faiss (default): every API "
        "process holds a FAISS replica of the whole catalogue, read from the database at "
        "start-up. milvus: they are in Milvus at SHAPESEARCH_MILVUS_URI (a collection per "
        "descriptor version, the tenant its partition key), which shards and replicates "
        "them; a process reads no vector at start-up and keeps none. Needs the milvus "
        "extra (docs/operations.md, The vector index beyond one machine).",
    )
    milvus_uri: str | None = Field(
        default=None,
        description="With SHAPESEARCH_INDEX_BACKEND=milvus: a Milvus server, "
        "http://host:19530, or a milvus-lite file (embedded: one process at a time may "
        "open it, so one API process with --no-worker and workers apart; tests and trials).",
    )
    milvus_index: Literal["FLAT", "HNSW", "IVF_FLAT"] = Field(
        default="HNSW",
        description="The vector index of each Milvus collection: FLAT (exact, a scan per "
        "query), HNSW (graph, M 16, ef max(128, 2k)) or IVF_FLAT (1024 lists, "
        "SHAPESEARCH_INDEX_NPROBE searched). Distances are always exact: Milvus keeps the "
        "whole vectors, so nothing is re-ranked. Applies to collections when created.",
    )
    milvus_prefix: str = Field(
        default="shapesearch",
        pattern=r"^[A-Za-z_][A-Za-z0-9_]{0,63}$",
        description="What the names of this catalogue's Milvus collections start with: "
        "deployments (or databases) that share one Milvus apart.",
    )
    milvus_token: str | None = Field(
        default=None,
        description="The Milvus server's credentials, user:password or an API key.",
    )
