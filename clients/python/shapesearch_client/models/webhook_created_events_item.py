from enum import StrEnum

class WebhookCreatedEventsItem(StrEnum):
    MODEL_DELETED = "model.deleted"
    MODEL_FAILED = "model.failed"
    MODEL_READY = "model.ready"

    def __str__(self) -> str:
        return str(self.value)
