from enum import StrEnum

class PointsSourcesOther(StrEnum):
    PREVIEW = "preview"
    SAMPLE = "sample"

    def __str__(self) -> str:
        return str(self.value)
