"""Service settings, read from ``SHAPESEARCH_*`` environment variables.

One class, ``Settings``; every field carries a description so the README table can be
generated from it (``Settings.model_fields``). ``engine_settings`` is the single place
where service settings become the engine's ``core.settings.EngineSettings``.
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path
from typing import Literal, TypedDict

import numpy as np
from pydantic import Field, ValidationInfo, field_validator
from pydantic_settings import BaseSettings, SettingsConfigDict
from sqlalchemy.engine import make_url
from sqlalchemy.exc import ArgumentError

from core.descriptor import DescriptorSpec
from core.errors import SettingsError
from core.rank.hubness import HUB_NEIGHBOURS
from core.settings import (
    DESCRIPTOR_FAMILIES,
    CutoffMode,
    CutoffSettings,
    EngineSettings,
    Laplacian,
    Normalisation,
)

__all__ = ["ENGINE_VARIABLES", "Settings", "engine_settings", "variables_of"]

MIB = 1024 * 1024
# Engine defaults come from core, so that the service and ``shapesearch describe`` agree.
_ENGINE = EngineSettings()


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


class Settings(BaseSettings):
    """Everything the service reads from its environment."""

    model_config = SettingsConfigDict(env_prefix="SHAPESEARCH_", extra="ignore", frozen=True)

    # --- where things live -------------------------------------------------------------
    database_url: str | None = Field(
        default=None,
        description="SQLAlchemy URL of the database, e.g. postgresql+psycopg://user@host/db. "
        "Unset: a SQLite file shapesearch.db in the data directory (embedded mode).",
    )
    database_password_file: Path | None = Field(
        default=None,
        description="File holding the database password (a Docker or Compose secret, e.g. "
        "/run/secrets/postgres_password): it takes the place of any password in "
        "SHAPESEARCH_DATABASE_URL, so that no environment variable holds it. Trailing "
        "newlines are not part of it. Unset: the URL's own.",
    )
    data_dir: Path = Field(
        default=Path("data"), description="Directory for the embedded SQLite database."
    )
    host: str = Field(
        default="127.0.0.1",
        description="Address `shapesearch serve` binds, and `shapesearch worker` for its "
        "metrics port.",
    )
    port: int = Field(default=8000, ge=1, le=65535, description="Port `shapesearch serve` binds.")

    # --- uploads -------------------------------------------------------------------------
    max_upload_bytes: int = Field(
        default=64 * MIB, ge=1, description="Largest accepted upload in bytes (larger: 413)."
    )
    upload_check_points: int = Field(
        default=2000,
        ge=10,
        description="Points sampled when an upload is parsed at once to reject bad files "
        "with 422 (the full description runs later in a worker).",
    )
    upload_check_timeout_seconds: float = Field(
        default=10.0,
        gt=0,
        description="Time an upload's sandboxed quick check (STEP, IGES, GLB, LAZ, E57 and "
        "files over 256 KiB) may take, waiting for a free check slot included; past it the "
        "upload is accepted unchecked and its describe in the worker decides.",
    )
    upload_check_max_concurrent: int = Field(
        default=2,
        ge=1,
        description="Sandboxed quick checks one API process runs at once (each a child that "
        "may take SHAPESEARCH_DESCRIBE_MEMORY_BYTES); more uploads wait for a slot.",
    )

    max_text_length: int = Field(
        default=500,
        ge=1,
        le=10000,
        description="Longest external_id, name, filename or query parameter, in characters "
        "(longer: 422). Text must be valid UTF-8 without NUL characters.",
    )
    max_metadata_bytes: int = Field(
        default=16384,
        ge=2,
        description="Largest metadata object, in bytes of compact JSON (larger: 422).",
    )
    max_metadata_depth: int = Field(
        default=8,
        ge=1,
        le=100,
        description="Deepest nesting of objects and arrays in metadata, the top object "
        "counting as 1 (deeper: 422). Numbers must be finite.",
    )

    describe_memory_bytes: int = Field(
        default=4 * 1024 * MIB,
        ge=64 * MIB,
        description="Address space the child process that parses and describes each file may "
        "take beyond its start (its RLIMIT_AS is its start plus this); above it the file is "
        "refused as too large (413 or a failed job).",
    )
    describe_timeout_seconds: float = Field(
        default=300.0,
        gt=0,
        description="Wall-clock limit of that child process for the largest files; a file "
        "that takes longer than its limit is refused as too large.",
    )
    describe_timeout_base_seconds: float = Field(
        default=60.0,
        gt=0,
        description="The limit of a small file: a file of S MB may take this plus "
        "describe_timeout_seconds_per_mb times S, at most describe_timeout_seconds (a reader "
        "that hangs on a small corrupt file is stopped in a minute, not five).",
    )
    describe_timeout_seconds_per_mb: float = Field(
        default=10.0,
        ge=0,
        description="What each MB of a file adds to its limit (valid mesh and cloud files "
        "of 6 MB and more needed at most 1.1 s a MB, bench/describe_by_size.py).",
    )

    search_max_concurrent: int = Field(
        default=2,
        ge=1,
        description="Uploads POST /v1/search describes at the same time in one API process; "
        "one more is refused with 503 and Retry-After.",
    )
    search_retry_after_seconds: int = Field(
        default=5, ge=1, description="Retry-After of that 503, in seconds."
    )
    search_cache_size: int = Field(
        default=128,
        ge=0,
        description="Recent search uploads (by sha256) whose description is kept in memory, "
        "so that the same file is not described twice (0: no cache).",
    )

    # --- engine (mapped onto core.settings.EngineSettings by engine_settings) ----------
    max_points: int = Field(
        default=_ENGINE.max_points,
        description="Points per shape: meshes are sampled with exactly this many, larger "
        "clouds thinned to it, smaller clouds keep all theirs. Raise it (e.g. 20000) for "
        "thin-walled parts; one database uses one value (docs/results.md).",
    )
    min_points: int = Field(
        default=_ENGINE.min_points,
        description="Fewer usable points than this: the shape is refused.",
    )
    laplacian: Laplacian = Field(
        default=_ENGINE.laplacian, description="Point-cloud Laplacian: robust or spcl."
    )
    normalisation: Normalisation = Field(
        default=_ENGINE.normalisation,
        description="Scale normalisation: unit surface area or unit bounding box.",
    )
    sample_seed: int = Field(default=_ENGINE.sample_seed, description="Seed of the point sampling.")
    outlier_filter: bool = Field(
        default=_ENGINE.outlier_filter,
        description="Drop statistical outliers (stray points) of uploaded point clouds; "
        "meshes are never filtered.",
    )
    outlier_ratio: float = Field(
        default=_ENGINE.outlier_ratio,
        description="Outlier filter cut: a cloud point whose mean distance to its 8 nearest "
        "neighbours exceeds this many times the median of that distance is dropped.",
    )
    cutoff_mode: CutoffMode = Field(
        default=_ENGINE.cutoff.mode, description="adaptive (per-model eigenpair count) or fixed."
    )
    cutoff_xi: float = Field(
        default=_ENGINE.cutoff.xi, description="Adaptive cutoff: xi."
    )
    cutoff_t: float = Field(
        default=_ENGINE.cutoff.t, description="Adaptive cutoff: diffusion time t."
    )
    cutoff_seed: int = Field(
        default=_ENGINE.cutoff.seed,
        description="Adaptive cutoff: eigenpairs of the first round.",
    )
    cutoff_n_min: int = Field(
        default=_ENGINE.cutoff.n_min, description="Adaptive cutoff: smallest n."
    )
    cutoff_n_max: int = Field(
        default=_ENGINE.cutoff.n_max, description="Adaptive cutoff: largest n."
    )
    cutoff_margin: int = Field(
        default=_ENGINE.cutoff.margin,
        description="Adaptive cutoff: extra eigenpairs per round.",
    )
    cutoff_n: int = Field(
        default=_ENGINE.cutoff.n, description="Fixed cutoff: eigenpairs per model."
    )
    descriptor_family: Literal["parts", "bendable"] = Field(
        default="parts",
        description="Descriptor family of this database: parts (rigid parts; sees how the "
        "surface sits in space) or bendable (hoses, cables, springs, hands, people: only what "
        "bending keeps). Written into descriptor_version; a change needs a re-describe.",
    )
    descriptor_t_min: float = Field(
        default=min(_ENGINE.descriptor.hks_times),
        description="Descriptor: smallest heat-kernel time.",
    )
    descriptor_t_max: float = Field(
        default=max(_ENGINE.descriptor.hks_times),
        description="Descriptor: largest heat-kernel time.",
    )
    descriptor_times: int = Field(
        default=len(_ENGINE.descriptor.hks_times),
        description="Descriptor: number of log-spaced heat-kernel times.",
    )
    descriptor_hks_scaled: bool = Field(
        default=_ENGINE.descriptor.hks_scaled,
        description="Descriptor: use the scale-invariant heat-kernel signature.",
    )
    descriptor_bins: int = Field(
        default=_ENGINE.descriptor.bins, description="Descriptor: histogram bins."
    )
    descriptor_wks_energies: int = Field(
        default=_ENGINE.descriptor.wks_energies,
        description="Descriptor: wave-kernel energies (0: no WKS block).",
    )
    descriptor_hks_weight: float | None = Field(
        default=None,
        description="Descriptor: weight of the heat-kernel block (unset: the family's).",
    )
    descriptor_wks_slope_weight: float | None = Field(
        default=None,
        description="Descriptor: weight of the WKS slope block (unset: the family's).",
    )
    descriptor_wks_weight: float = Field(
        default=_ENGINE.descriptor.wks_weight,
        description="Descriptor: weight of the WKS block.",
    )
    descriptor_dna_count: int = Field(
        default=_ENGINE.descriptor.dna_count,
        description="Descriptor: eigenvalues in the shape-DNA block (0: none).",
    )
    descriptor_dna_weight: float = Field(
        default=_ENGINE.descriptor.dna_weight,
        description="Descriptor: weight of the shape-DNA block.",
    )
    scan_views: int = Field(
        default=_ENGINE.views.count,
        description="Scan mode: virtual partial views described and indexed per model, next "
        "to the model itself (0: none; search?mode=scan then compares whole models only). "
        "Applies to models described from then on.",
    )
    scan_boundary_weights: bool = Field(
        default=_ENGINE.views.boundary_weights,
        description="Scan mode: fade points near an open rim out of the histograms of views "
        "and scan queries.",
    )
    scan_boundary_neighbours: int = Field(
        default=_ENGINE.views.boundary_neighbours,
        description="Scan mode: neighbours that decide whether a point lies on an open rim.",
    )
    scan_boundary_threshold: float = Field(
        default=_ENGINE.views.boundary_threshold,
        description="Scan mode: a point is on a rim when its neighbours' centroid is off by "
        "more than this many mean neighbour distances.",
    )
    scan_boundary_reach: float = Field(
        default=_ENGINE.views.boundary_reach,
        description="Scan mode: distance from the rim, in square roots of the surface area, "
        "over which a point's histogram weight rises from 0 to 1.",
    )

    # --- workers and the job queue -------------------------------------------------------
    workers: int | None = Field(
        default=None,
        ge=0,
        description="Worker threads of `serve` (embedded; 0: none) or processes of "
        "`shapesearch worker`. Unset: one per core (each describe pins BLAS to one thread).",
    )
    idempotency_ttl_seconds: float = Field(
        default=86400.0,
        gt=0,
        description="Seconds an Idempotency-Key is remembered; a retry after that is a new "
        "request (expired keys are deleted as new ones are stored).",
    )
    lease_seconds: float = Field(
        default=60.0,
        gt=0,
        description="How long a claimed job stays with its worker without a heartbeat; "
        "after that another worker takes it over.",
    )
    max_attempts: int = Field(
        default=5, ge=1, description="Attempts per job before it is marked failed."
    )
    retry_backoff_seconds: float = Field(
        default=5.0, ge=0, description="First retry delay; doubles each attempt."
    )
    retry_backoff_max_seconds: float = Field(
        default=300.0, ge=0, description="Cap of the retry delay."
    )
    poll_interval: float = Field(
        default=1.0,
        gt=0,
        description="Seconds between an idle worker's looks for jobs nothing woke it for (a "
        "job queued in its process, or announced by another process (PostgreSQL's NOTIFY, a "
        "Unix socket beside a SQLite file), wakes it at once).",
    )
    shutdown_grace_seconds: float = Field(
        default=30.0,
        ge=0,
        description="On shutdown, how long a running job may take to finish before it is "
        "released to other workers.",
    )
    history_days: float = Field(
        default=30.0,
        ge=0,
        description="Days settled jobs (done, failed) and webhook deliveries (delivered, "
        "failed, with their attempts) are kept; older ones are deleted hourly by each "
        "process that runs workers, but never a model's newest job. 0: kept forever.",
    )

    # --- index and access ----------------------------------------------------------------
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
    index_projected_dims: int = Field(
        default=0,
        ge=0,
        le=1024,
        description="0 (default): an IVF partition's codes hold every dimension. N > 0: "
        "they hold the vectors' N leading principal components, fitted on the partition's "
        "training sample (when it and the vectors are wide enough), and the exact re-rank "
        "is unchanged. At 10^5 models and 256: 1.4-1.6x the similar requests per second at "
        "c=16, a 9x smaller index; recall@10 1.0 on real descriptors, 0.85 on the "
        "benchmark's synthetic ones, 0.37 at 10^6 (near ties; README, Projected codes).",
    )
    api_processes: int = Field(
        default=1,
        ge=1,
        description="API processes `shapesearch serve` runs on its port (Linux: each has a "
        "socket of its own, SO_REUSEPORT). Each holds its own index and follows the change "
        "feed; the embedded worker's threads are shared out among them. Two on two cores "
        "served 1.6x the similar requests of one (README, Scale-out).",
    )
    query_threads: int = Field(
        default=4,
        ge=1,
        description="Threads of an API process that run similarity queries (database and "
        "index); more concurrent requests wait in line for them. With several API processes "
        "one each does best (README, Scale-out).",
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
        "with another database URL (README, Restarts restore the pass).",
    )
    index_rerank_factor: int = Field(
        default=2,
        ge=1,
        description="Candidates per wanted result that an IVF partition returns for exact "
        "re-ranking (at least k + 10).",
    )
    search_hub_neighbours: int = Field(
        default=HUB_NEIGHBOURS,
        ge=0,
        le=100,
        description="Shape-mode similar answers are ordered with a hub discount (CSLS): the "
        "4 k nearest models re-ordered by distance^2 + r, r a candidate's mean cosine to "
        "its this many most alike other models, so a part that is near everything (a hub) "
        "comes a little later; `score` stays the plain similarity. 0: plain distance "
        "order, in scan mode too. Chosen on seven tuning sources, +0.01 mAP left out "
        "(README, Order of the results). Scan mode's discount has its own k (5) and weight "
        "(0.5), core.rank.hubness.SCAN_HUB_NEIGHBOURS, and orders the answers after its first "
        "as this order ranks them for that answer (core.rank.scan_order); 0 turns both off.",
    )
    search_reciprocal: bool = Field(
        default=True,
        description="With the hub discount on: shape-mode similar answers are re-ranked "
        "k-reciprocally over the hub discount's order (Zhong et al. 2017): the nearest "
        "max(4 k, 40) models are compared by their neighbourhoods among each other, so a "
        "part whose own nearest include the query comes earlier, the discount's first answer "
        "kept first; `score` stays the plain similarity. Confirmed on a tuning source no "
        "setting had seen, +0.04 mAP (README, Order of the results). false: the hub "
        "discount's order.",
    )
    filter_pushdown_max: int = Field(
        default=10_000,
        ge=0,
        description="A metadata filter matching at most this many models is selected in SQL "
        "first and only those models are searched; broader filters are applied to widening "
        "index results.",
    )
    auth_cache_seconds: float = Field(
        default=5.0,
        ge=0,
        description="How long an API process trusts a key lookup; a revoked key stops "
        "working within this time.",
    )
    response_cache_seconds: float = Field(
        default=1.0,
        ge=0,
        description="How long an API process serves a repeated model list or similar-model "
        "list from memory (0: never). Its own writes and every index change drop the kept "
        "answers at once; other processes' changes show within this time. Never longer "
        "than auth_cache_seconds.",
    )
    readyz_count_seconds: float = Field(
        default=30.0,
        ge=0,
        description="/readyz compares the index with the change feed on every probe, and "
        "counts the ready models (a table scan) at most this often.",
    )
    require_api_keys: bool = Field(
        default=False,
        description="Always require an API key. Unset: keys are required as soon as one "
        "exists (`shapesearch keys create`); with none the service is open as tenant "
        "'default' and only binds to loopback.",
    )

    # --- webhooks ------------------------------------------------------------------------
    webhook_allow_private: bool = Field(
        default=False,
        description="Allow webhook URLs on private, loopback and link-local addresses "
        "(refused by default: a caller must not make the service probe its own network).",
    )
    webhook_timeout_seconds: float = Field(
        default=10.0, gt=0, description="Timeout of one webhook delivery attempt."
    )
    webhook_lanes: int = Field(
        default=4,
        ge=1,
        le=64,
        description="Webhook deliveries each process (serve, worker) sends at once. An "
        "endpoint gets one at a time, in order, so an endpoint that hangs holds one lane "
        "for its timeout and the others serve every other endpoint.",
    )
    webhook_max_attempts: int = Field(
        default=20,
        ge=1,
        description="Delivery attempts per event before it is marked failed. With the "
        "default backoff, 20 attempts span about 10.4 hours: a receiver away overnight "
        "misses nothing. A failed delivery can be sent again (POST "
        "/v1/webhooks/{id}/recover).",
    )
    webhook_backoff_seconds: float = Field(
        default=5.0, ge=0, description="Delay after the first failed delivery; doubles each time."
    )
    webhook_backoff_max_seconds: float = Field(
        default=3600.0, ge=0, description="Cap of the webhook retry delay."
    )

    # --- browsers --------------------------------------------------------------------
    cors_origins: str = Field(
        default="",
        description="Origins (comma-separated, e.g. https://plm.example.com) whose web pages "
        "may call the API from a browser (CORS); empty: none.",
    )

    # --- observability ---------------------------------------------------------------
    metrics_from_anywhere: bool = Field(
        default=False,
        description="Answer GET /metrics for any client; unset: loopback clients only (the "
        "metrics name tenants and their model counts).",
    )

    worker_metrics_port: int | None = Field(
        default=None,
        ge=1,
        le=65535,
        description="Port on which `shapesearch worker` serves the Prometheus metrics of all "
        "its processes (describe, cutoff, queue, webhooks) at /metrics, on SHAPESEARCH_HOST "
        "(--metrics-port wins); unset: none.",
    )

    @property
    def cors_origin_list(self) -> list[str]:
        """``cors_origins`` as a list (blank entries dropped)."""
        return [origin.strip() for origin in self.cors_origins.split(",") if origin.strip()]

    @property
    def index_options(self) -> IndexOptions:
        """The search index's options (``ShapeIndex``'s keyword arguments), one mapping
        for the API processes and the duplicates reports alike."""
        return IndexOptions(
            exact_max=self.index_exact_max,
            compact_min=self.index_compact_min,
            nprobe=self.index_nprobe,
            rerank_factor=self.index_rerank_factor,
            projected_dims=self.index_projected_dims,
            hub_neighbours=self.search_hub_neighbours,
            reciprocal=self.search_reciprocal,
            cache_dir=self.resolved_index_cache_dir,
        )

    @property
    def resolved_index_cache_dir(self) -> Path | None:
        """``index_cache_dir``, defaulting to the data directory's with the embedded
        database."""
        if self.index_cache_dir is not None or self.database_url:
            return self.index_cache_dir
        return self.data_dir / "index-cache"

    @property
    def worker_count(self) -> int:
        """Describes run at once: ``workers``, or one per core when unset. Processes
        (``shapesearch worker``) scale better than the embedded worker's threads, part of a
        describe holding the GIL (docs/results.md, "Throughput")."""
        return self.workers if self.workers is not None else (os.cpu_count() or 1)

    @field_validator("database_password_file")
    @classmethod
    def _password_file_usable(cls, path: Path | None, info: ValidationInfo) -> Path | None:
        """A password file needs a server URL to go into and a password in it."""
        if path is None:
            return None
        url = info.data.get("database_url")
        if not url:
            raise ValueError("needs SHAPESEARCH_DATABASE_URL (an embedded SQLite database "
                             "has no password)")
        try:
            make_url(url)
        except ArgumentError:
            raise ValueError("SHAPESEARCH_DATABASE_URL is not a database URL") from None
        _read_password(path)
        return path

    @property
    def resolved_database_url(self) -> str:
        """The database URL with the password file's password, defaulting to the embedded
        SQLite file."""
        if self.database_url and self.database_password_file is not None:
            password = _read_password(self.database_password_file)
            url = make_url(self.database_url).set(password=password)
            return url.render_as_string(hide_password=False)
        if self.database_url:
            return self.database_url
        return f"sqlite:///{(self.data_dir / 'shapesearch.db').as_posix()}"


def _read_password(path: Path) -> str:
    """The password in ``path``, without the trailing newlines (as the PostgreSQL image
    reads its POSTGRES_PASSWORD_FILE); ``ValueError`` when unreadable or empty."""
    try:
        password = path.read_text(encoding="utf-8").rstrip("\n")
    except (OSError, UnicodeDecodeError) as error:
        reason = getattr(error, "strerror", None) or str(error)
        raise ValueError(f"cannot read {path}: {reason}") from None
    if not password:
        raise ValueError(f"{path} holds no password")
    return password


def _or(value: float | None, family_value: float) -> float:
    return family_value if value is None else value


#: The variables behind each engine setting (``core.errors.SettingsError.fields``); engine
#: settings without a variable of their own keep their family's value.
ENGINE_VARIABLES: dict[str, tuple[str, ...]] = {
    **{name: (name,) for name in ("max_points", "min_points", "laplacian", "normalisation",
                                  "outlier_ratio")},
    **{f"cutoff.{name}": (f"cutoff_{name}",)
       for name in ("mode", "xi", "t", "seed", "n_min", "n_max", "margin", "n")},
    "descriptor.hks_times": ("descriptor_t_min", "descriptor_t_max", "descriptor_times"),
    **{f"descriptor.{name}": (f"descriptor_{name}",)
       for name in ("bins", "wks_energies", "hks_weight", "wks_weight", "wks_slope_weight",
                    "dna_count", "dna_weight")},
    "views.count": ("scan_views",),
    **{f"views.{name}": (f"scan_{name}",)
       for name in ("boundary_neighbours", "boundary_threshold", "boundary_reach")},
}


def variables_of(error: SettingsError) -> list[str]:
    """The ``SHAPESEARCH_*`` variables an engine ``SettingsError`` is about (a setting without
    a variable is named by its engine path)."""
    names = [
        f"SHAPESEARCH_{variable.upper()}" if path in ENGINE_VARIABLES else path
        for path in error.fields
        for variable in ENGINE_VARIABLES.get(path, (path,))
    ]
    return list(dict.fromkeys(names))


def engine_settings(settings: Settings) -> EngineSettings:
    """Map the service settings onto the engine's settings, validated by the engine
    (``core.errors.SettingsError`` names the settings that do not work together)."""
    family = DESCRIPTOR_FAMILIES[settings.descriptor_family]
    if min(settings.descriptor_t_min, settings.descriptor_t_max) <= 0:
        raise SettingsError("heat-kernel times must be positive", "descriptor.hks_times")
    engine = EngineSettings(
        max_points=settings.max_points,
        min_points=settings.min_points,
        laplacian=settings.laplacian,
        normalisation=settings.normalisation,
        sample_seed=settings.sample_seed,
        outlier_filter=settings.outlier_filter,
        outlier_ratio=settings.outlier_ratio,
        cutoff=CutoffSettings(
            mode=settings.cutoff_mode,
            xi=settings.cutoff_xi,
            t=settings.cutoff_t,
            seed=settings.cutoff_seed,
            n_min=settings.cutoff_n_min,
            n_max=settings.cutoff_n_max,
            margin=settings.cutoff_margin,
            n=settings.cutoff_n,
        ),
        # Fields without a variable of their own (bin ranges, filter widths) keep the
        # family's measured defaults: start from them, never from a second copy of the numbers.
        descriptor=replace(
            family,
            hks_times=tuple(
                np.geomspace(
                    settings.descriptor_t_min, settings.descriptor_t_max, settings.descriptor_times
                ).tolist()
            ),
            hks_scaled=settings.descriptor_hks_scaled,
            hks_weight=_or(settings.descriptor_hks_weight, family.hks_weight),
            bins=settings.descriptor_bins,
            wks_energies=settings.descriptor_wks_energies,
            wks_weight=settings.descriptor_wks_weight,
            wks_slope_weight=_or(settings.descriptor_wks_slope_weight, family.wks_slope_weight),
            dna_count=settings.descriptor_dna_count,
            dna_weight=settings.descriptor_dna_weight,
        ),
        views=replace(
            _ENGINE.views,
            count=settings.scan_views,
            boundary_weights=settings.scan_boundary_weights,
            boundary_neighbours=settings.scan_boundary_neighbours,
            boundary_threshold=settings.scan_boundary_threshold,
            boundary_reach=settings.scan_boundary_reach,
        ),
    )
    engine.validate()
    try:
        # The local block's vocabulary must fit the time grid: refused at start-up, not per job.
        DescriptorSpec.from_settings(engine.descriptor)
    except SettingsError as error:
        raise error.within("descriptor") from None
    return engine
