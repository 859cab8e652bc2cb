from enum import StrEnum

class SimilarResultLikenessType0(StrEnum):
    COPY = "copy"
    DIFFERENT_KIND = "different kind"
    SAME_KIND = "same kind"

    def __str__(self) -> str:
        return str(self.value)
