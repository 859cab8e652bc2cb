from enum import StrEnum

class BodyUploadModelAssembly(StrEnum):
    SPLIT = "split"
    WHOLE = "whole"

    def __str__(self) -> str:
        return str(self.value)
