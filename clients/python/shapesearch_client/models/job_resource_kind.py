from enum import StrEnum

class JobResourceKind(StrEnum):
    DESCRIBE = "describe"
    DUPLICATES = "duplicates"
    REDESCRIBE = "redescribe"

    def __str__(self) -> str:
        return str(self.value)
