from enum import StrEnum

class SearchByUploadMode(StrEnum):
    SCAN = "scan"
    SHAPE = "shape"

    def __str__(self) -> str:
        return str(self.value)
