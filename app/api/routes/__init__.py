"""The API's route handlers, one module per resource; ``ROUTERS`` in the order they mount.

Handlers are thin: they read the request, call the subsystem that does the work
(``app.search``, ``app.ingest``, ``app.jobs``, ``app.webhooks``) and shape the answer.
"""

from app.api.routes import (
    assemblies,
    compare,
    duplicates,
    health,
    jobs,
    metrics,
    models,
    previews,
    revisions,
    search,
    stats,
    webhooks,
)

ROUTERS = (
    revisions.router,  # before models: /models/by-external-id/... is not an id
    models.router,
    compare.router,
    assemblies.router,
    search.router,
    jobs.router,
    webhooks.router,
    duplicates.router,
    health.router,
    previews.router,
    stats.router,
    metrics.router,
)
