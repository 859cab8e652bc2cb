"""Signed webhooks: the event outbox, the target rules and the deliverer, one module each.

    outbox            record_model_event writes one delivery row per subscribed endpoint
                      inside the caller's transaction (the change and its event commit
                      together); requeue and recover queue settled deliveries again (a
                      receiver that was away longer than the retries)
    targets           check_target: http(s) only; private, loopback and link-local addresses
                      refused unless SHAPESEARCH_WEBHOOK_ALLOW_PRIVATE=true; the request then
                      goes to the checked address (``pinned``), so DNS cannot swap it after
                      the check
    endpoint_secrets  new_secret, valid_secret (``whsec_`` + base64)
    delivery          Deliverer claims due deliveries under a lease (``app.jobs.lease``),
                      POSTs them signed per Standard Webhooks, logs every attempt, retries
                      with capped exponential backoff: at least once, one delivery in
                      flight per endpoint; DeliveryLanes runs it in a few threads next to
                      the job workers

The body is ``{"type", "timestamp", "data": {"model": ..., "job": ...}}``; the headers are
``webhook-id`` (the delivery id, the same on every retry so receivers can deduplicate),
``webhook-timestamp`` and ``webhook-signature`` (``v1,`` + base64 HMAC-SHA256 over
``id.timestamp.body`` with the endpoint's secret), made by the ``standardwebhooks`` package.
"""

from app.webhooks.delivery import Deliverer, DeliveryLanes, start_delivery_lanes
from app.webhooks.endpoint_secrets import new_secret, valid_secret
from app.webhooks.outbox import EVENT_TYPES, record_model_event, recover, requeue
from app.webhooks.targets import TargetRefused, check_target, pinned

__all__ = [
    "EVENT_TYPES",
    "Deliverer",
    "DeliveryLanes",
    "TargetRefused",
    "check_target",
    "new_secret",
    "pinned",
    "record_model_event",
    "recover",
    "requeue",
    "start_delivery_lanes",
    "valid_secret",
]
