"""The job queue, its workers, settled history, and webhook deliveries."""

from __future__ import annotations

from pydantic import BaseModel, Field

__all__ = ["JobSettings", "WebhookSettings"]


class JobSettings(BaseModel):
    """Leases, retries and polling of the job queue, and how long settled history is kept."""

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


class WebhookSettings(BaseModel):
    """Delivery of signed events."""

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
