from enum import StrEnum

class BodySearchByUploadUnits(StrEnum):
    CM = "cm"
    IN = "in"
    M = "m"
    MM = "mm"

    def __str__(self) -> str:
        return str(self.value)
