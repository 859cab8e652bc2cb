"""The spectral blocks: intrinsic, so unchanged when a shape bends.

- ``hks``: per heat time, the area-weighted histogram of log scaled HKS;
- ``wks``: per energy, the area-weighted histogram of log WKS;
- ``slope``: per pair of neighbouring energies, the histogram of
  ``log WKS(x, e_{j+1}) - log WKS(x, e_j)``. Per-scale histograms lose which values occur
  together at one point; the slope keeps the part of that joint information that separates
  classes best (measured on capod);
- ``dna``: the first non-zero eigenvalues on Weyl's scale (ShapeDNA, Reuter et al. 2006).

With unit total area and M-orthonormal eigenvectors the scaled HKS and the WKS (normalised
by its filter sum) have area-weighted mean 1 at every scale, so their logs are centred near
0 and one set of bin edges fits every scale.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from core.descriptor._block import Block, bin_edges, hellinger_histograms, unit_block
from core.descriptor._sample import Sample
from core.signatures import zero_eigenvalue_count

__all__ = ["DnaBlock", "HksBlock", "SlopeBlock", "WksBlock"]


@dataclass(frozen=True)
class _ScaleHistograms(Block):
    """Per column of a per-point signature, its area-weighted histogram, ``(columns * bins,)``
    of unit norm (Hellinger embedding). Subclasses say which columns (``values``).

    Parameters
    ----------
    columns : int
        Columns of the signature (heat times or energies); 0: the block is left out.
    bins : int
        Bins per column.
    bounds : (2,) float
        Bin range; values outside go to the end bins.
    """

    columns: int
    bins: int
    bounds: tuple[float, float]

    @property
    def width(self) -> int:
        return self.columns * self.bins

    def values(self, sample: Sample) -> np.ndarray:
        """The ``(n, columns)`` signature values this block histograms."""
        raise NotImplementedError

    def measure(self, sample: Sample) -> np.ndarray:
        return hellinger_histograms(self.values(sample), sample.areas,
                                    bin_edges(self.bounds, self.bins))


@dataclass(frozen=True)
class HksBlock(_ScaleHistograms):
    """Histograms of log HKS per heat time (``bounds`` about [-2, 2.5] on capod)."""

    name: ClassVar[str] = "hks"

    def values(self, sample: Sample) -> np.ndarray:
        return sample.log_hks


@dataclass(frozen=True)
class WksBlock(_ScaleHistograms):
    """Histograms of log WKS per energy (its area-weighted mean is 1, so the log is centred
    near 0)."""

    name: ClassVar[str] = "wks"

    def values(self, sample: Sample) -> np.ndarray:
        return sample.log_wks


@dataclass(frozen=True)
class SlopeBlock(Block):
    """Histograms of the WKS slope between neighbouring energies, ``((columns - 1) * bins,)``
    of unit norm.

    Parameters
    ----------
    columns : int
        Energies; fewer than 2: no slope, the block is left out.
    bins : int
    bounds : (2,) float
        Bin range of the difference of neighbouring log WKS values.
    """

    name: ClassVar[str] = "slope"

    columns: int
    bins: int
    bounds: tuple[float, float] = (-1.0, 1.0)

    @property
    def width(self) -> int:
        return max(self.columns - 1, 0) * self.bins

    def measure(self, sample: Sample) -> np.ndarray:
        return hellinger_histograms(np.diff(sample.log_wks, axis=1), sample.areas,
                                    bin_edges(self.bounds, self.bins))


@dataclass(frozen=True)
class DnaBlock(Block):
    """The normalised eigenvalue channel, ``(count,)`` of unit norm.

    Parameters
    ----------
    count : int
        Eigenvalues; 0: the block is left out.
    """

    name: ClassVar[str] = "dna"

    count: int

    @property
    def width(self) -> int:
        return self.count

    def measure(self, sample: Sample) -> np.ndarray:
        return unit_block(self.channel(sample.eigenvalues))

    def channel(self, eigenvalues: np.ndarray) -> np.ndarray:
        """ShapeDNA on Weyl's scale, ``(count,) float``: ``log(lambda_j / 4 pi j)`` for the
        first non-zero eigenvalues of ``eigenvalues : (k,) float``, centred.

        Zero eigenvalues (one per connected component of a multi-part model) are skipped, so
        a part made of two bodies is not shifted by one against a part made of one. A short
        spectrum repeats its last value rather than leaving zeros that would look like data.
        """
        nonzero = eigenvalues[zero_eigenvalue_count(eigenvalues) :][: self.count]
        channel = np.zeros(self.count)
        if nonzero.size:
            ratios = np.log(nonzero / (4.0 * np.pi * np.arange(1, nonzero.size + 1)))
            channel[: nonzero.size] = ratios
            channel[nonzero.size :] = ratios[-1]
        # Centre so the channel measures the shape of the spectrum, not a global offset.
        return channel - channel.mean()
