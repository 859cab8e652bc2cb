"""Access and observability: API keys, who may read the metrics, and how the logs look."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field

__all__ = ["AccessSettings", "ObservabilitySettings"]


class AccessSettings(BaseModel):
    """API keys: whether they are required, and how long a lookup is trusted."""

    require_api_keys: bool = Field(
        default=False,
        description="Always require an API key. Unset: keys are required as soon as one "
        "exists (`shapesearch keys create`); with none the service is open as tenant "
        "'default' and only binds to loopback.",
    )
    auth_cache_seconds: float = Field(
        default=5.0,
        ge=0,
        description="How long an API process trusts a key lookup; a revoked key stops "
        "working within this time.",
    )


class ObservabilitySettings(BaseModel):
    """Metrics and logs."""

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
    log_format: Literal["auto", "json", "text"] = Field(
        default="auto",
        description="Log lines on standard error: json (one JSON object a line: time, "
        "level, logger, message, request_id, job_id and the event's fields, for a log "
        "collector), text (the same as one readable line, for a person), or auto: text when "
        "standard error is a terminal, json otherwise.",
    )
