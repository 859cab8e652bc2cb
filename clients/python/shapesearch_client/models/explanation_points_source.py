from enum import StrEnum

class ExplanationPointsSource(StrEnum):
    PREVIEW = "preview"
    SAMPLE = "sample"

    def __str__(self) -> str:
        return str(self.value)
