"""Service settings, read from ``SHAPESEARCH_*`` environment variables.

One class, ``Settings``, made of one group of fields per concern (modules of their own):

    _server   DatabaseSettings, ServerSettings         where it runs
    _access   AccessSettings, ObservabilitySettings    API keys, metrics, logs
    _uploads  UploadSettings                           uploads and their limits
    _engine   DescribeSettings, ScanSettings           the engine (``engine_settings``)
    _search   SearchSettings                           how requests are served and ordered
    _index    IndexSettings                            each API process's search index
    _jobs     JobSettings, WebhookSettings             the job queue, webhook deliveries

Every field carries a description, so that the configuration reference can be checked
against ``Settings.model_fields``; the fields come in the order of that reference's tables.
``engine_settings`` is the single place where service settings become the engine's
``core.settings.EngineSettings``.
"""

from __future__ import annotations

from pathlib import Path

from pydantic_settings import BaseSettings, SettingsConfigDict

from app.settings._access import AccessSettings, ObservabilitySettings
from app.settings._engine import (
    ENGINE_VARIABLES,
    DescribeSettings,
    ScanSettings,
    engine_settings,
    variables_of,
)
from app.settings._index import IndexOptions, IndexSettings
from app.settings._jobs import JobSettings, WebhookSettings
from app.settings._search import SearchSettings
from app.settings._server import DatabaseSettings, ServerSettings
from app.settings._uploads import UploadSettings

__all__ = ["ENGINE_VARIABLES", "IndexOptions", "Settings", "engine_settings", "variables_of"]


# pydantic collects the fields of the last base first: the groups are listed last to first,
# so that ``model_fields`` runs from DatabaseSettings to WebhookSettings.
class Settings(
    WebhookSettings,
    JobSettings,
    IndexSettings,
    SearchSettings,
    ScanSettings,
    DescribeSettings,
    UploadSettings,
    ObservabilitySettings,
    AccessSettings,
    ServerSettings,
    DatabaseSettings,
    BaseSettings,
):
    """Everything the service reads from its environment."""

    model_config = SettingsConfigDict(env_prefix="SHAPESEARCH_", extra="ignore", frozen=True)

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
            backend=self.index_backend,
            milvus_uri=self.milvus_uri,
            milvus_index=self.milvus_index,
            milvus_prefix=self.milvus_prefix,
            milvus_token=self.milvus_token,
        )

    @property
    def resolved_index_cache_dir(self) -> Path | None:
        """``index_cache_dir``, defaulting to the data directory's with the embedded
        database."""
        if self.index_cache_dir is not None or self.database_url:
            return self.index_cache_dir
        return self.data_dir / "index-cache"
