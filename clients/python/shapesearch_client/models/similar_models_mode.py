from enum import StrEnum

class SimilarModelsMode(StrEnum):
    SCAN = "scan"
    SHAPE = "shape"

    def __str__(self) -> str:
        return str(self.value)
