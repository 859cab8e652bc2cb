from enum import StrEnum

class RevisionResourceStatus(StrEnum):
    CURRENT = "current"
    FAILED = "failed"
    PENDING = "pending"
    SUPERSEDED = "superseded"

    def __str__(self) -> str:
        return str(self.value)
