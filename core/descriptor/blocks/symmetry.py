"""The symmetry block: how far the surface is from its images under the principal frame's
seven sign changes (mirrors in the principal planes, half-turns about the principal axes,
inversion through the centroid; ``core.extrinsic.reflection_symmetry``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from core.descriptor._block import Block
from core.descriptor._sample import Sample
from core.extrinsic import SIGN_FLIPS, reflection_symmetry

__all__ = ["SymmetryBlock"]


@dataclass(frozen=True)
class SymmetryBlock(Block):
    """The seven distances over the RMS radius, ``(7,)``, each point weighed by its area on
    the evened surface.

    Raw distances, not unit norm: how symmetric a part is, not only in which way.
    """

    name: ClassVar[str] = "symmetry"
    extrinsic: ClassVar[bool] = True
    tag: ClassVar[str | None] = "syma"

    @property
    def width(self) -> int:
        return len(SIGN_FLIPS)

    def measure(self, sample: Sample) -> np.ndarray:
        return reflection_symmetry(sample.body_points, sample.evened_areas)
