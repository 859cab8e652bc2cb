from enum import StrEnum

class BodyUpsertModelAssembly(StrEnum):
    SPLIT = "split"
    WHOLE = "whole"

    def __str__(self) -> str:
        return str(self.value)
