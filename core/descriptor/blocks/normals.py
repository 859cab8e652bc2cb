"""The normals block: how the surface faces its principal axes.

Per principal axis, the area-weighted histogram of ``|cos|`` between the surface normals
(local PCA, ``Sample.normals``) and that axis: prismatic parts put their faces square to
their own axes, and an L, U and Z profile differ in how much. Absolute values make it
independent of the signs of the normals and of the axes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from core.descriptor._block import Block, bin_edges, hellinger_histograms
from core.descriptor._sample import Sample
from core.extrinsic import normal_axis_cosines

__all__ = ["NormalsBlock"]


@dataclass(frozen=True)
class NormalsBlock(Block):
    """``|cos|`` histograms per principal axis, ``(3 * bins,)`` of unit norm, each point
    weighed by its area on the evened surface.

    Parameters
    ----------
    bins : int
        Bins of ``|cos|`` over [0, 1] per axis.
    """

    name: ClassVar[str] = "normals"
    extrinsic: ClassVar[bool] = True
    tag: ClassVar[str | None] = "nrma"

    bins: int = 10

    @property
    def width(self) -> int:
        return 3 * self.bins

    def measure(self, sample: Sample) -> np.ndarray:
        areas = sample.evened_areas
        cosines = normal_axis_cosines(sample.body_points, areas, sample.normals)
        return hellinger_histograms(cosines, areas, bin_edges((0.0, 1.0), self.bins))
