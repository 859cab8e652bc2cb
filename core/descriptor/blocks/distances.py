"""The D2 and D1 shape distributions (Osada et al. 2002).

Histograms of the distances between random area-weighted point pairs (D2) and of the
distances from the centroid (D1), each over its mean, so that neither scale nor the
normalisation convention matters. Both are measured on the part with its principal spreads
evened (``Sample.evened_points``), each point weighed by its area on that evened surface
(``Sample.evened_areas``): a kind made in many lengths (screws, shafts, keys) keeps one
distance distribution, and its head or hub counts.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from core.descriptor._block import (
    Block,
    area_histograms,
    bin_edges,
    hellinger_histograms,
    unit_block,
)
from core.descriptor._sample import Sample
from core.extrinsic import centroid_distance_ratios, pair_distance_ratios

__all__ = ["D1Block", "D2Block", "distance_distribution"]


def distance_distribution(
    points: np.ndarray, areas: np.ndarray, edges: np.ndarray, pairs: int, seed: int
) -> np.ndarray:
    """D2 shape distribution of a surface given as weighted points.

    Distances between ``pairs`` random point pairs, each end drawn with probability
    proportional to its area (uniform on the surface, however unevenly it was sampled),
    divided by their mean.

    Parameters
    ----------
    points : (n, 3) float
    areas : (n,) float
        Non-negative, not all zero.
    edges : (b + 1,) float
        Bin edges of distance over mean distance; values outside go to the end bins.
    pairs : int
    seed : int
        Seeds the pair draw: the same points always give the same histogram.

    Returns
    -------
    histogram : (b,) float
        Sums to 1.
    """
    ratios = pair_distance_ratios(points, areas, pairs, seed)
    return area_histograms(ratios[:, None], np.ones(pairs), edges)[0]


@dataclass(frozen=True)
class D2Block(Block):
    """D2 of the evened part, ``(bins,)`` of unit norm.

    Parameters
    ----------
    bins : int
    pairs : int
        Point pairs drawn: 20000 keep two samplings of one part about 0.03 apart in the
        unit block, different parts about 0.2.
    bounds : (2,) float
        Bin range of distance over mean distance: 3 is reached only by a straight segment,
        whose mean distance is a third of its length.
    seed : int
        Seeds the pair draw.
    """

    name: ClassVar[str] = "d2"
    extrinsic: ClassVar[bool] = True
    # "e": measured on the evened part; "a": weighed by the evened surface's areas.
    tag: ClassVar[str | None] = "d2ea"

    bins: int
    pairs: int = 20000
    bounds: tuple[float, float] = (0.0, 3.0)
    seed: int = 0

    @property
    def width(self) -> int:
        return self.bins

    def measure(self, sample: Sample) -> np.ndarray:
        histogram = distance_distribution(sample.evened_points, sample.evened_areas,
                                          bin_edges(self.bounds, self.bins), self.pairs,
                                          self.seed)
        return unit_block(np.sqrt(histogram))


@dataclass(frozen=True)
class D1Block(Block):
    """D1 of the evened part, ``(bins,)`` of unit norm.

    Parameters
    ----------
    bins : int
    bounds : (2,) float
        Bin range of distance from the centroid over its mean; 3 is far beyond any part's
        tail.
    """

    name: ClassVar[str] = "d1"
    extrinsic: ClassVar[bool] = True
    tag: ClassVar[str | None] = "d1ea"

    bins: int
    bounds: tuple[float, float] = (0.0, 3.0)

    @property
    def width(self) -> int:
        return self.bins

    def measure(self, sample: Sample) -> np.ndarray:
        areas = sample.evened_areas
        ratios = centroid_distance_ratios(sample.evened_points, areas)
        return hellinger_histograms(ratios[:, None], areas, bin_edges(self.bounds, self.bins))
