"""The block interface, and the histogram helpers the blocks share.

A block is one measurement of a ``Sample`` turned into a fixed-width vector: a histogram
with fixed bin edges, square-rooted (Hellinger embedding: L2 distance between two of them is
the Hellinger distance) and scaled to unit norm, or raw values where their size is itself
information. Its constructor stores its parameters and nothing else (as scikit-learn's
estimators do); ``DescriptorSpec`` weighs and joins the blocks.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np

from core.descriptor._sample import Sample

__all__ = ["Block", "area_histograms", "bin_edges", "hellinger_histograms", "unit_block"]


class Block(ABC):
    """One block of the descriptor: a name, a width and a measurement.

    Subclasses set ``name`` (unique in a descriptor; ``DescriptorSpec.blocks`` is keyed by
    it), ``extrinsic`` when the block measures the points (how the surface sits in space)
    rather than only the spectrum, and ``tag``, how ``descriptor_version``'s ``ext=`` list
    names it (None: the block is written in a part of the version of its own).
    """

    name: ClassVar[str]
    extrinsic: ClassVar[bool] = False
    tag: ClassVar[str | None] = None

    @property
    @abstractmethod
    def width(self) -> int:
        """Length of ``measure``'s vector (0: the block has nothing to measure and is left
        out whatever its weight)."""

    @abstractmethod
    def measure(self, sample: Sample) -> np.ndarray:
        """The block before weighting, ``(width,) float``: unit norm unless the block says
        otherwise."""


def unit_block(block: np.ndarray) -> np.ndarray:
    """``block`` flattened and scaled to unit norm, ``(size,) float`` (zeros stay zeros)."""
    flat = block.ravel()
    norm = np.linalg.norm(flat)
    return flat / norm if norm > 0 else flat


def area_histograms(
    values: np.ndarray, areas: np.ndarray, edges: np.ndarray
) -> np.ndarray:
    """Area-weighted histograms, one per column, with shared fixed bin edges.

    Parameters
    ----------
    values : (n, s) float
    areas : (n,) float
        Non-negative weights.
    edges : (b + 1,) float
        Increasing bin edges; values outside go to the end bins.

    Returns
    -------
    histograms : (s, b) float
        Each row sums to 1.
    """
    bins = edges.size - 1
    # Bin index of every value; clipping keeps outliers in the end bins instead of losing them.
    index = np.clip(np.searchsorted(edges, values, side="right") - 1, 0, bins - 1)
    histograms = np.zeros((values.shape[1], bins))
    for column in range(values.shape[1]):
        histograms[column] = np.bincount(index[:, column], weights=areas, minlength=bins)
    return histograms / np.maximum(histograms.sum(axis=1, keepdims=True), 1e-300)


def bin_edges(bounds: tuple[float, float], bins: int) -> np.ndarray:
    """``bins`` equal bins over ``bounds``: ``(bins + 1,) float`` edges."""
    return np.linspace(*bounds, bins + 1)


def hellinger_histograms(values: np.ndarray, areas: np.ndarray,
                         edges: np.ndarray) -> np.ndarray:
    """``area_histograms`` square-rooted, at unit norm as one block, ``(s * b,) float``."""
    return unit_block(np.sqrt(area_histograms(values, areas, edges)))
